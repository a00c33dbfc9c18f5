# SPDX-License-Identifier: MIT
# Shared fixtures of the Python tests. ctest runs them with the interpreter
# CMake chose (Python3_EXECUTABLE) and PYTHONPATH=build/python; by hand:
#   PYTHONPATH=build/python CED_CLI=build/bin/ced /usr/bin/python3 -m pytest tests/python
import os
import pathlib
import subprocess

import numpy as np
import pytest

import ced

DATA = pathlib.Path(__file__).resolve().parent.parent / "data"
SAMPLE = DATA / "apartment_mesh_214.ply"


@pytest.fixture(scope="session")
def sample_path():
    return str(SAMPLE)


@pytest.fixture(scope="session")
def sample():
    return ced.read(str(SAMPLE))


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("CED_CLI")
    if not path or not os.path.exists(path):
        pytest.skip("CED_CLI is not set to the ced tool (ctest sets it)")
    return path


def cli_keypoints(cli, path, *args):
    """The keypoint indices `ced detect PATH ARGS` prints."""
    out = subprocess.run([cli, "detect", str(path), "-q", *args], check=True, capture_output=True, text=True).stdout
    return np.array([int(v) for v in out.split()], dtype=np.uint32)


def room(n=4000, seed=3, noise=0.002):
    """A synthetic room corner: three planes with a box, and colours with an edge (deterministic)."""
    rng = np.random.default_rng(seed)
    k = n // 4
    floor = np.c_[rng.random(k), rng.random(k), np.zeros(k)]
    wall = np.c_[rng.random(k), np.zeros(k), rng.random(k)]
    wall2 = np.c_[np.zeros(k), rng.random(k), rng.random(k)]
    box = rng.random((n - 3 * k, 3)) * 0.3 + 0.35
    box[:, 2] *= 0.5
    pts = np.vstack([floor, wall, wall2, box]) + rng.normal(0, noise, (n, 3))
    rgb = np.where(pts[:, :1] > 0.5, [200, 40, 40], [30, 30, 220]).astype(np.uint8)
    return pts, rgb
