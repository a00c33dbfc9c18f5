# SPDX-License-Identifier: MIT
# Open3D interop: ced.detect takes an open3d.geometry.PointCloud (colours from it).
import numpy as np
import pytest

import ced
from conftest import cli_keypoints

o3d = pytest.importorskip("open3d", reason="Open3D is not installed (Debian: python3-open3d)")


def test_open3d_cloud_gives_the_cli_keypoints(cli, sample_path):
    pcd = o3d.io.read_point_cloud(sample_path)
    assert pcd.has_colors()
    r = ced.detect(pcd)  # colours -> ced6d, as the CLI does
    np.testing.assert_array_equal(r.keypoints, cli_keypoints(cli, sample_path, "--preset", "ced6d"))
    assert list(r.saliency) == ["xyz", "rgb"]


def test_open3d_without_colours_and_with_arbitrary_colours(sample_path):
    pcd = o3d.io.read_point_cloud(sample_path)
    plain = o3d.geometry.PointCloud(pcd.points)
    r = ced.detect(plain)
    assert list(r.saliency) == ["xyz"]
    np.testing.assert_array_equal(r.keypoints, ced.detect(pcd, modalities="ced3d").keypoints)
    # Colours that are not multiples of 1/255 stay floats in [0, 1].
    shaded = o3d.geometry.PointCloud(pcd.points)
    shaded.colors = o3d.utility.Vector3dVector(np.asarray(pcd.colors) * 0.999)
    r2 = ced.detect(shaded)
    assert list(r2.saliency) == ["xyz", "rgb"] and len(r2.keypoints) > 0
    # Normals come along as nx, ny, nz.
    pcd.estimate_normals()
    cloud = ced.Cloud(*ced._from_open3d(pcd, None))
    assert {"nx", "ny", "nz", "red"} <= set(cloud.fields)


def test_cloud_and_normals_take_an_open3d_cloud(sample_path):
    # As every other function of the package does (docs/PYTHON.md).
    pcd = o3d.io.read_point_cloud(sample_path)
    cloud = ced.Cloud(pcd)
    from_arrays = ced.Cloud(*ced._from_open3d(pcd, None))
    assert len(cloud) == len(pcd.points) and set(cloud.fields) == set(from_arrays.fields)
    np.testing.assert_array_equal(cloud.points, from_arrays.points)
    np.testing.assert_array_equal(cloud.fields["red"], from_arrays.fields["red"])
    extra = ced.Cloud(pcd, {"nir": np.arange(len(pcd.points), dtype=np.float32)})
    assert "nir" in extra.fields and "red" in extra.fields
    np.testing.assert_array_equal(ced.estimate_normals(pcd, 0.05), ced.estimate_normals(from_arrays, 0.05))
    assert isinstance(ced.voxel_downsample(cloud, 0.05), ced.Cloud)  # the C++ side still returns ced.Cloud


def test_keypoints_back_to_open3d(sample_path, tmp_path):
    pcd = o3d.io.read_point_cloud(sample_path)
    r = ced.detect(pcd)
    keypoints = pcd.select_by_index(r.keypoints.astype(np.int64).tolist())
    assert len(keypoints.points) == len(r.keypoints)
    ced.write(str(tmp_path / "from_o3d.ply"), pcd)
    assert len(ced.read(str(tmp_path / "from_o3d.ply"))) == len(pcd.points)


def test_eval_takes_open3d_clouds(sample_path):
    pcd = o3d.io.read_point_cloud(sample_path)
    arrays = ced.Cloud(pcd)
    kp = ced.detect(pcd).keypoints
    m = ced.eval.measure
    assert m(pcd, kp, pcd, kp, np.eye(4), 0.01) == m(arrays, kp, arrays, kp, np.eye(4), 0.01)
    moved = ced.eval.transform(pcd, np.eye(4), 0.0, ced.eval.Random(1))
    np.testing.assert_array_equal(moved.points, arrays.points)
