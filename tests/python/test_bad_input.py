# SPDX-License-Identifier: MIT
# Bad input: a TypeError/ValueError (or OSError for files) naming the argument, never a crash.
import os

import numpy as np
import pytest

import ced
from conftest import room


@pytest.fixture(scope="module")
def pts():
    return room(800)[0]


@pytest.mark.parametrize("points, error, message", [
    (np.zeros((10, 2)), ValueError, r"points: expected an \(N, 3\) array, got shape \(10, 2\)"),
    (np.zeros(30), ValueError, r"points: expected an \(N, 3\) array, got shape \(30,\)"),
    (np.zeros((10, 3, 1)), ValueError, r"points: expected an \(N, 3\) array"),
    (np.zeros((10, 3), dtype=np.int32), TypeError, r"points: expected float32 or float64 coordinates, got dtype int32"),
    (np.zeros((10, 3), dtype=np.complex64), TypeError, r"points: expected float32 or float64"),
    (np.array([["a", "b", "c"]]), TypeError, r"points: expected float32 or float64"),
    ("scan.ply", ValueError, r"points: expected an \(N, 3\) array"),
    (np.zeros((0, 3)), ValueError, r"points: the cloud is empty"),
])
def test_bad_points(points, error, message):
    with pytest.raises(error, match=message):
        ced.detect(points)


def test_non_finite_coordinates_name_the_point(pts):
    for bad, word in ((np.nan, "NaN"), (np.inf, "infinite"), (-np.inf, "infinite")):
        p = pts.copy()
        p[17, 1] = bad
        with pytest.raises(ValueError, match=f"points: point 17 has a {word} coordinate"):
            ced.detect(p)
        with pytest.raises(ValueError, match="point 17"):
            ced.detect(p.astype(np.float32))


def test_bad_channels(pts):
    n = len(pts)
    with pytest.raises(ValueError, match=r"channels\['red'\]: 799 values, but there are 800 points"):
        ced.detect(pts, {"red": np.zeros(n - 1)})
    with pytest.raises(ValueError, match=r"channels\['rgb'\]: expected an \(N,\) or \(N, k\) array, got shape"):
        ced.detect(pts, {"rgb": np.zeros((n, 3, 2))})
    with pytest.raises(TypeError, match=r"channels\['red'\]: expected a numeric array .* got dtype complex128"):
        ced.detect(pts, {"red": np.zeros(n, dtype=complex)})
    with pytest.raises(TypeError, match=r"channels\['red'\]: expected a numeric array"):
        ced.detect(pts, {"red": np.array(["x"] * n)})
    with pytest.raises(TypeError, match="channels: expected a dict"):
        ced.detect(pts, [np.zeros(n)])
    with pytest.raises(ValueError, match="the key names 2 columns but the array has 3"):
        ced.detect(pts, {"a,b": np.zeros((n, 3))})
    with pytest.raises(ValueError, match=r"modality 'rgb': field 'red' has a non-finite value \(nan\) at point 5"):
        c = np.zeros((n, 3))
        c[5, 0] = np.nan
        ced.detect(pts, {"rgb": c}, modalities=["rgb:0.1"], radius=0.1)


def test_missing_field_and_unknown_modality(pts):
    with pytest.raises(ValueError, match=r"rgb.*red"):  # names the field it needs
        ced.detect(pts, modalities=["xyz:0.2", "rgb:0.1"], radius=0.1)
    with pytest.raises(ValueError, match=r"bands.*nir"):
        ced.detect(pts, {"red": np.zeros(len(pts), np.uint8)}, modalities=["bands(nir,red):0.1"], radius=0.1)
    with pytest.raises(ValueError, match="unknown modality 'colour'"):
        ced.detect(pts, modalities=["colour:0.1"])
    with pytest.raises(ValueError, match=r"threshold|number"):
        ced.detect(pts, modalities=["xyz:abc"])
    with pytest.raises(TypeError, match="modalities: expected"):
        ced.detect(pts, modalities=[3.5])
    with pytest.raises(ValueError, match="modalities: the list is empty"):
        ced.detect(pts, modalities=[])


@pytest.mark.parametrize("kwargs, error, message", [
    (dict(radius=-1.0), ValueError, "radius"),
    (dict(radius=0.0), ValueError, "radius"),
    (dict(radius=float("nan")), ValueError, "radius"),
    (dict(radius=float("inf")), ValueError, "radius"),
    (dict(radius="big"), ValueError, "radius: expected a positive number or 'auto'"),
    (dict(radius=[1]), TypeError, "radius: expected a number or 'auto'"),
    (dict(radius="auto", radius_factor=-2), ValueError, "radius_factor"),
    (dict(nms_radius=-0.1), ValueError, "nms_radius"),
    (dict(min_neighbors=-1), ValueError, "min_neighbors"),
    (dict(min_neighbors=2.5), TypeError, "min_neighbors: expected an int"),
    (dict(threads=-3), ValueError, "threads"),
    (dict(threads="2"), TypeError, "threads: expected an int"),
])
def test_bad_parameters(pts, kwargs, error, message):
    with pytest.raises(error, match=message):
        ced.detect(pts, **kwargs)


def test_auto_radius_needs_two_distinct_points():
    with pytest.raises(ValueError, match="cannot estimate the resolution"):
        ced.detect(np.ones((10, 3)), radius="auto")


def test_bad_files(tmp_path):
    with pytest.raises(ced.FileError, match="missing.ply"):
        ced.read(str(tmp_path / "missing.ply"))
    assert issubclass(ced.FileError, OSError)
    truncated = tmp_path / "cut.ply"
    truncated.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\n"
                          b"property float y\nproperty float z\nend_header\n" + b"\0" * 50)
    with pytest.raises(ced.FileError, match="cut.ply"):
        ced.read(str(truncated))
    with pytest.raises(ced.FileError, match="x.laz"):
        ced.read(str(tmp_path / "x.laz"))
    with pytest.raises(ValueError, match="format"):
        ced.read(str(truncated), format="obj")
    # A write that fails leaves no file behind.
    target = tmp_path / "no_such_dir" / "out.ply"
    with pytest.raises(ced.FileError):
        ced.write(str(target), room(50)[0])
    assert not target.exists()
    pts = room(50)[0]
    with pytest.raises(ced.FileError):
        ced.write(str(tmp_path / "out.unknown"), pts)
    assert os.listdir(tmp_path) == ["cut.ply"]


def test_bad_python_modality(pts):
    with pytest.raises(ValueError, match=r"must return \d+ saliencies"):
        ced.detect(pts, modalities=[ced.python_modality("long", lambda p, o, nb: np.zeros(len(p) + 1), 0.1)],
                   radius=0.1)
    with pytest.raises(ValueError, match="must return"):
        ced.detect(pts, modalities=[ced.python_modality("short", lambda p, o, nb: np.zeros(1), 0.1)], radius=0.1)
    with pytest.raises(ZeroDivisionError):
        ced.detect(pts, modalities=[ced.python_modality("div", lambda p, o, nb: 1 / 0, 0.1)], radius=0.1)
    with pytest.raises(TypeError, match=r"Python modality 'text': fn\(point, neighbors\) must return a number, got"):
        ced.detect(pts, modalities=[ced.python_modality("text", lambda p, nb: "high", 0.1, per_point=True)],
                   radius=0.1)
    with pytest.raises(TypeError):
        ced.python_modality("nofn", 42, 0.1)
    with pytest.raises(ValueError, match="name"):
        ced.python_modality("", lambda *a: 0, 0.1)
