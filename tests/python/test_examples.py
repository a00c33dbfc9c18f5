# SPDX-License-Identifier: MIT
# The Python examples run and write what they promise.
import os
import pathlib
import subprocess
import sys

import pytest

import ced

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples" / "python"


def run(script, *args):
    return subprocess.run([sys.executable, str(EXAMPLES / script), *map(str, args)], check=True,
                          capture_output=True, text=True, env=os.environ).stdout


def test_detect_example(sample_path, tmp_path):
    out = run("detect.py", sample_path, tmp_path)
    r = ced.detect(ced.read(sample_path))
    assert f"{len(r.keypoints)} keypoints" in out
    assert (tmp_path / "keypoints.txt").read_text().split() == [str(k) for k in r.keypoints]
    assert len(ced.read(str(tmp_path / "keypoints.ply"))) == len(r.keypoints)
    assert (tmp_path / "keypoints.png").read_bytes()[:4] == b"\x89PNG"


def test_open3d_example_saves(sample_path, tmp_path):
    pytest.importorskip("open3d", reason="Open3D is not installed (Debian: python3-open3d)")
    out = run("open3d_keypoints.py", sample_path, "--save", tmp_path)
    assert "keypoints" in out
    assert (tmp_path / "keypoints.ply").stat().st_size > 0
    assert (tmp_path / "keypoints.png").read_bytes()[:4] == b"\x89PNG"
