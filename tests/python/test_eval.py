# SPDX-License-Identifier: MIT
# ced.eval.repeatability mirrors `ced eval repeatability`: the same draws, the same numbers.
import csv
import subprocess

import numpy as np
import pytest

import ced


def test_repeatability_matches_the_cli(cli, sample_path, tmp_path):
    out = tmp_path / "rep.csv"
    subprocess.run([cli, "eval", "repeatability", sample_path, "--trials", "2", "--noise", "0,0.5", "--seed", "7",
                    "--detector", "ced6d", "--detector", "xyz:0.25,rgb:0.12", "--detector", "random", "--detector",
                    "robust6d", "--detector", "xyz:0.2,scale=2,refine", "--detector", "robust3d", "--detector",
                    "xyz:0.2,rgb:0.1,share:0.002", "--quiet",
                    "--csv", str(out)], check=True, capture_output=True)
    with open(out) as f:
        expected = [(r["detector"], float(r["noise_resolution"]), int(r["trial"]), int(r["source_keypoints"]),
                     int(r["target_keypoints"]), int(r["repeated"])) for r in csv.DictReader(f)]
    rows = ced.eval.repeatability(ced.read(sample_path), detectors=["ced6d", "xyz:0.25,rgb:0.12", "random", "robust6d",
                                                                        "xyz:0.2,scale=2,refine", "robust3d",
                                                                        "xyz:0.2,rgb:0.1,share:0.002"],
                                  noise=[0, 0.5], trials=2, seed=7)
    got = [(r["detector"], r["noise"], r["trial"], r["source_keypoints"], r["target_keypoints"], r["repeated"])
           for r in rows]
    assert len(expected) == 28
    assert sorted(got) == sorted(expected)
    assert all(0 <= r["relative"] <= 1 for r in rows)
    # The share binds: fewer keypoints than the same modalities without it.
    shared = [r["source_keypoints"] for r in rows if r["detector"] == "xyz:0.2,rgb:0.1,share:0.002"]
    full = [r["source_keypoints"] for r in rows if r["detector"] == "ced6d"]
    assert max(shared) < min(full)
    with pytest.raises(ValueError, match="share"):
        ced.eval.repeatability(ced.read(sample_path), detectors=["xyz:0.2,share:2"], noise=[0], trials=1)


def test_measure_and_transforms():
    rng = ced.eval.Random(3)
    t = ced.eval.random_transform(rng, 1.0)
    assert t.shape == (4, 4)
    np.testing.assert_allclose(t[:3, :3] @ t[:3, :3].T, np.eye(3), atol=1e-12)
    pts = np.random.default_rng(0).random((200, 3))
    q = ced.eval.transform(pts, t, 0.0, rng)
    np.testing.assert_allclose(q.points, (pts @ t[:3, :3].T + t[:3, 3]).astype(np.float32), atol=1e-5)
    kp = np.arange(0, 200, 10)
    assert ced.eval.measure(pts, kp, q, kp, t, 1e-3) == (20, 20, 20)
    assert ced.eval.measure(pts, kp, q, kp + 1, t, 1e-6) == (20, 20, 0)
    with pytest.raises(ValueError, match="4x4"):
        ced.eval.measure(pts, kp, q, kp, np.eye(3), 1e-3)
    with pytest.raises(ValueError, match="PCL detector"):
        ced.eval.repeatability(pts, detectors=["iss3d"])
