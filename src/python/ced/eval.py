# SPDX-License-Identifier: MIT
"""Keypoint repeatability, as `ced eval repeatability` (Tombari et al. 2013, the CED paper's protocol)."""

import math

from ._ced import Cloud, estimate_resolution
from ._ced import _eval as _e

Random = _e.Random
random_transform = _e.random_transform
random_keypoints = _e.random_keypoints


def transform(cloud, transform, sigma, rng):
    """A copy of `cloud` (a ced.Cloud, arrays as for ced.detect, or an Open3D cloud) moved by `transform` (4x4)
    with Gaussian noise of `sigma` metres added to each coordinate."""
    from . import _as_cloud

    return _e.transform(_as_cloud(cloud), transform, sigma, rng)

__all__ = ["Random", "measure", "random_keypoints", "random_transform", "repeatability", "transform"]


def measure(source, source_keypoints, target, target_keypoints, transform, epsilon):
    """(|K_P|, |K_Q|, repeated): keypoints of `source` whose image under `transform` (4x4, local frames) has a
    keypoint of `target` within `epsilon`."""
    from . import _as_cloud

    return _e.measure(_as_cloud(source), source_keypoints, _as_cloud(target), target_keypoints, transform, epsilon)


def _detector(d):
    """(label, modalities or None for the random baseline, refine, keypoint share)."""
    from . import Modality, _ced, preset

    if not isinstance(d, str):
        mods = [m if isinstance(m, Modality) else Modality(m) for m in d]
        if not mods:
            raise ValueError("detectors: an empty modality list")
        return "+".join(m.name for m in mods), mods, False, 0.0
    if d == "random":
        return d, None, False, 0.0
    if d in _ced.preset_names():
        return d, preset(d), _ced.preset_refines(d), _ced.preset_keypoint_share(d)
    if d in ("iss3d", "harris3d", "harris6d", "sift"):
        raise ValueError(f"detectors: {d!r} is a PCL detector, available in the CLI "
                         f"(ced eval repeatability --detector {d}) but not from Python")
    specs = _ced._split_modality_specs(d)
    refine = "refine" in specs  # as in the CLI: the word "refine" among the specs, "share:Q" a keypoint share
    share = 0.0
    for s in specs:
        if s.startswith("share:"):
            try:
                share = float(s[6:])
            except ValueError:
                share = float("nan")
            if not 0 <= share <= 1:
                raise ValueError(f"detectors: {d!r}: share:Q takes a share from 0 to 1, got {s!r}")
    specs = [s for s in specs if s != "refine" and not s.startswith("share:")]
    if not specs:
        raise ValueError(f"detectors: {d!r} names no modality")
    return d, [Modality(s) for s in specs], refine, share


def repeatability(cloud, detectors=("ced6d", "ced3d", "random"), noise=(0.0, 0.5), trials=5, seed=1,
                  epsilon=2.0, resolution=None, radius=None, min_neighbors=5, threads=0, max_translation=1.0):
    """Relative repeatability of each detector on `cloud` against randomly moved, noisy copies of itself: the
    same draws and numbers as `ced eval repeatability INPUT` with the same options.

    detectors: 'ced6d', 'ced3d', 'random', modality specs joined by commas as in the CLI
        ('xyz:0.2,rgb:0.1'), or lists of specs / ced.Modality objects.
    noise: Gaussian noise levels, in multiples of the resolution. epsilon: in multiples of the resolution.
    Returns a list of dicts (one per detector and trial): detector, noise, trial, source_keypoints,
    target_keypoints, repeated, relative.
    """
    from . import detect

    if not isinstance(cloud, Cloud):
        cloud = Cloud(cloud)
    if not (isinstance(trials, int) and 1 <= trials <= 10000):
        raise ValueError("trials: must be an int in 1..10000")
    if not (epsilon > 0 and math.isfinite(epsilon)):
        raise ValueError("epsilon: must be a positive number")
    kinds = [_detector(d) for d in ([detectors] if isinstance(detectors, str) else detectors)]
    if not kinds:
        raise ValueError("detectors: no detector given")
    res = resolution if resolution else estimate_resolution(cloud)
    if not res > 0:
        raise ValueError("cannot estimate the resolution; give resolution=")
    r = radius if radius else 5 * res
    eps = epsilon * res
    rows = []
    master = Random(seed)
    for level in noise:
        if not level >= 0:
            raise ValueError("noise: levels must be >= 0")
        for trial in range(trials):
            rng = Random(master.next())
            t = random_transform(rng, max_translation)
            q = transform(cloud, t, level * res, rng)
            last_count = max(1, len(cloud) // 100)
            for name, mods, refine, share in kinds:
                if mods is None:
                    a = random_keypoints(len(cloud), last_count, rng)
                    b = random_keypoints(len(q), last_count, rng)
                else:
                    a = detect(cloud, modalities=mods, radius=r, nms_radius=r, min_neighbors=min_neighbors,
                               threads=threads, refine=refine, keypoint_share=share).keypoints
                    b = detect(q, modalities=mods, radius=r, nms_radius=r, min_neighbors=min_neighbors,
                               threads=threads, refine=refine, keypoint_share=share).keypoints
                    last_count = max(1, len(a))
                kp, kq, rep = measure(cloud, a, q, b, t, eps)
                rows.append({"detector": name, "noise": level, "trial": trial, "source_keypoints": kp,
                             "target_keypoints": kq, "repeated": rep, "relative": rep / kp if kp else 0.0})
    return rows
