# SPDX-License-Identifier: MIT
# Modalities written in Python: by block and per point, against the built-in measure.
import numpy as np

import ced


def geometry_by_block(positions):
    p64 = positions.astype(np.float64)

    def fn(points, offsets, neighbors):
        counts = np.diff(offsets)
        owner = np.repeat(np.arange(len(points)), counts)
        sums = np.zeros((len(points), 3))
        np.add.at(sums, owner, p64[neighbors])
        return np.linalg.norm(sums / np.maximum(counts, 1)[:, None] - p64[points], axis=1)

    return fn


def test_block_modality_reproduces_the_built_in_geometry(sample):
    pts = np.array(sample.points)
    ref = ced.detect(sample, modalities=["xyz:0.2"], threads=1)
    mod = ced.python_modality("geometry", geometry_by_block(pts), threshold=0.2 * 0.05)
    got = ced.detect(sample, modalities=[mod], threads=1)
    np.testing.assert_allclose(got.saliency["geometry"], ref.saliency["xyz"], rtol=0, atol=2e-6)
    # Keypoints can differ only at points whose score ties within rounding; here none do.
    np.testing.assert_array_equal(got.keypoints, ref.keypoints)


def test_per_point_equals_by_block_and_threads_do_not_matter(sample):
    pts = np.array(sample.points, dtype=np.float64)
    calls = []

    def spread(point, neighbors):
        calls.append(point)
        return float(np.abs(pts[neighbors, 2] - pts[point, 2]).max())

    def spread_block(points, offsets, neighbors):
        return np.array([np.abs(pts[neighbors[offsets[k]:offsets[k + 1]], 2] - pts[p, 2]).max()
                         for k, p in enumerate(points)])

    a = ced.detect(sample, modalities=["xyz", ced.python_modality("spread", spread, 0.02, per_point=True)])
    assert len(calls) == len(sample)
    b = ced.detect(sample, modalities=["xyz", ced.python_modality("spread", spread_block, 0.02)], threads=1)
    c = ced.detect(sample, modalities=["xyz", ced.python_modality("spread", spread_block, 0.02)], threads=2)
    np.testing.assert_array_equal(a.saliency["spread"], b.saliency["spread"])
    np.testing.assert_array_equal(b.saliency["spread"], c.saliency["spread"])
    np.testing.assert_array_equal(a.keypoints, c.keypoints)


def test_points_with_few_neighbours_get_zero():
    rng = np.random.default_rng(4)
    pts = rng.random((400, 3))
    mod = ced.python_modality("one", lambda points, offsets, neighbors: np.ones(len(points)), 0.5)
    r = ced.detect(pts, modalities=[mod], radius=0.15, min_neighbors=6)
    few = r.neighbor_count < 6
    assert few.any() and (~few).any()
    np.testing.assert_array_equal(r.saliency["one"], np.where(few, 0.0, 1.0).astype(np.float32))
