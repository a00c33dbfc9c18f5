# SPDX-License-Identifier: MIT
# ced.detect from numpy: the CLI's keypoints, every input layout, the Result.
import math

import numpy as np
import pytest

import ced
from conftest import DATA, cli_keypoints, room


def channels_of(cloud):
    return {name: values for name, values in cloud.fields.items()}


def test_numpy_gives_the_cli_keypoints_on_the_redwood_sample(cli, sample, sample_path):
    points = np.array(sample.points)  # a plain numpy copy: no ced object goes in
    colours = {k: np.array(v) for k, v in channels_of(sample).items()}
    for preset in ("ced6d", "ced3d", "robust6d", "robust3d"):
        expected = cli_keypoints(cli, sample_path, "--preset", preset)
        got = ced.detect(points, colours, modalities=preset)
        assert len(expected) > 50
        np.testing.assert_array_equal(got.keypoints, expected, err_msg=preset)
    # The default is the CLI's: ced6d when the cloud has colour.
    np.testing.assert_array_equal(ced.detect(points, colours).keypoints, cli_keypoints(cli, sample_path, "--preset", "ced6d"))


def test_refine_follows_the_preset_and_can_be_set(cli, sample, sample_path):
    assert ced.preset_refines("robust6d") and not ced.preset_refines("ced6d")
    robust = ced.detect(sample, modalities="robust6d")
    assert robust.refine
    specs = ["xyz:0.2,scale=2.25,inner=1", "rgb:0.5"]
    plain = ced.detect(sample, modalities=specs, keypoint_share=0.01)  # specs: no refinement unless asked
    assert not plain.refine
    np.testing.assert_array_equal(ced.detect(sample, modalities="robust6d", refine=False).keypoints, plain.keypoints)
    np.testing.assert_array_equal(ced.detect(sample, modalities=specs, refine=True, keypoint_share=0.01).keypoints,
                                  robust.keypoints)
    # Refinement moves keypoints, and the CLI's flags do the same.
    assert not np.array_equal(robust.keypoints, plain.keypoints)
    np.testing.assert_array_equal(cli_keypoints(cli, sample_path, "-m", "xyz:0.2", "--radius", "0.05", "--refine"),
                                  ced.detect(sample, modalities="xyz:0.2", refine=True).keypoints)
    np.testing.assert_array_equal(cli_keypoints(cli, sample_path, "--preset", "robust3d", "--no-refine"),
                                  ced.detect(sample, modalities="robust3d", refine=False).keypoints)
    with pytest.raises(TypeError, match="refine"):
        ced.detect(sample, refine="yes")


def test_max_keypoints_keeps_the_strongest_as_the_cli(cli, sample, sample_path):
    full = ced.detect(sample, modalities="ced6d")
    assert len(full) > 100 and full.max_keypoints == 0
    score = full.saliency["xyz"] * full.saliency["rgb"]  # float32, as the detector multiplies
    ranked = sorted(full.keypoints, key=lambda k: (-score[k], k))
    for n in (1, 64, len(full) - 1):
        got = ced.detect(sample, modalities="ced6d", max_keypoints=n)
        assert got.max_keypoints == n
        np.testing.assert_array_equal(got.keypoints, np.sort(np.array(ranked[:n], dtype=np.uint32)), err_msg=str(n))
        np.testing.assert_array_equal(cli_keypoints(cli, sample_path, "--preset", "ced6d", "--max-keypoints", str(n)),
                                      got.keypoints)
    np.testing.assert_array_equal(ced.detect(sample, modalities="ced6d", max_keypoints=10**9).keypoints, full.keypoints)
    with pytest.raises(ValueError, match="max_keypoints"):
        ced.detect(sample, modalities="ced6d", max_keypoints=-1)
    with pytest.raises(TypeError, match="max_keypoints"):
        ced.detect(sample, modalities="ced6d", max_keypoints=2.5)


def test_refined_keypoints_rank_by_their_maximum(cli, sample, sample_path):
    # rank_score: a keypoint's own score, or refined, that of the strongest maximum refined onto it.
    plain = ced.detect(sample, modalities="ced6d")
    score = plain.saliency["xyz"] * plain.saliency["rgb"]
    np.testing.assert_array_equal(plain.rank_score, score[plain.keypoints])
    full = ced.detect(sample, modalities="robust6d")
    assert full.rank_score.dtype == np.float32 and len(full.rank_score) == len(full) > 40
    own = full.saliency[full.names[0]] * full.saliency[full.names[1]]
    assert np.count_nonzero(full.rank_score > own[full.keypoints]) > 0  # refined onto weaker points
    ranked = sorted(range(len(full)), key=lambda q: (-full.rank_score[q], full.keypoints[q]))
    for n in (1, 20):
        got = ced.detect(sample, modalities="robust6d", max_keypoints=n)
        np.testing.assert_array_equal(got.keypoints, np.sort(full.keypoints[ranked[:n]]), err_msg=str(n))
        np.testing.assert_array_equal(got.rank_score, full.rank_score[np.sort(ranked[:n])], err_msg=str(n))
        np.testing.assert_array_equal(cli_keypoints(cli, sample_path, "--preset", "robust6d", "--max-keypoints", str(n)),
                                      got.keypoints)


def test_keypoint_share_keeps_the_strongest_share_of_the_candidates(cli, sample, sample_path):
    full = ced.detect(sample, modalities="ced6d")
    candidates = int(np.count_nonzero(full.candidate))
    assert full.keypoint_share == 0 and candidates > 10 * len(full)
    for share in (0.001, 0.01):
        n = math.ceil(share * candidates)
        got = ced.detect(sample, modalities="ced6d", keypoint_share=share)
        assert got.keypoint_share == share and len(got) == n < len(full)
        np.testing.assert_array_equal(got.keypoints, ced.detect(sample, modalities="ced6d", max_keypoints=n).keypoints)
        np.testing.assert_array_equal(
            cli_keypoints(cli, sample_path, "--preset", "ced6d", "--keypoint-share", str(share)), got.keypoints)
    # The robust presets' own share unless told otherwise; the paper's presets have none.
    assert ced.preset_keypoint_share("robust3d") == ced.preset_keypoint_share("robust6d") == 0.01
    assert ced.preset_keypoint_share("ced6d") == ced.preset_keypoint_share("ced3d") == 0
    r3 = ced.detect(sample, modalities="robust3d")
    assert r3.keypoint_share == 0.01
    assert ced.detect(sample, modalities="robust3d", keypoint_share=0).keypoint_share == 0
    np.testing.assert_array_equal(cli_keypoints(cli, sample_path, "--preset", "robust3d"), r3.keypoints)
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="keypoint_share"):
            ced.detect(sample, modalities="ced6d", keypoint_share=bad)
    with pytest.raises(TypeError, match="keypoint_share"):
        ced.detect(sample, modalities="ced6d", keypoint_share="0.1")


def test_neighborhood_and_search_match_the_cli(cli, sample, sample_path):
    for spec in ("knn:16", "adaptive:12,scale=1.5,max=0.08"):
        got = ced.detect(sample, modalities="ced6d", neighborhood=spec)
        expected = cli_keypoints(cli, sample_path, "--preset", "ced6d", "--neighborhood", spec)
        assert len(expected) > 50
        np.testing.assert_array_equal(got.keypoints, expected, err_msg=spec)
        assert got.point_radius.shape == (len(sample.points),) and got.point_radius.dtype == np.float32
        assert (got.point_radius > 0).all()
    knn = ced.detect(sample, modalities="ced3d", neighborhood="knn:16")
    assert (knn.neighbor_count == 16).all()
    assert knn.point_radius.max() > 2 * knn.point_radius.min()
    # The CGAL reference path gives the grid's keypoints.
    grid = ced.detect(sample, modalities="ced6d")
    assert grid.point_radius is None
    np.testing.assert_array_equal(ced.detect(sample, modalities="ced6d", search="cgal").keypoints, grid.keypoints)
    with pytest.raises(ValueError, match="neighborhood.*K"):
        ced.detect(sample, neighborhood="knn:0")
    with pytest.raises(ValueError, match="larger than max"):
        ced.detect(sample, neighborhood="adaptive:8,min=0.2,max=0.1")
    with pytest.raises(ValueError, match="search"):
        ced.detect(sample, search="octree")
    with pytest.raises(TypeError, match="neighborhood"):
        ced.detect(sample, neighborhood=16)


def test_auto_radius_matches_the_cli(cli, sample, sample_path):
    expected = cli_keypoints(cli, sample_path, "-m", "xyz:0.2", "-m", "rgb:0.1", "--radius", "auto")
    got = ced.detect(sample, modalities=["xyz:0.2", "rgb:0.1"], radius="auto")
    np.testing.assert_array_equal(got.keypoints, expected)
    assert got.radius == pytest.approx(5 * ced.estimate_resolution(sample))


def test_float64_any_strides_and_layouts_give_the_same_result(sample):
    p32 = np.array(sample.points)
    rgb = np.c_[sample.fields["red"], sample.fields["green"], sample.fields["blue"]]
    ref = ced.detect(p32, {"rgb": rgb})
    wide = np.zeros((len(p32), 7))  # positions as a strided view inside a wider float64 array
    wide[:, 2:5] = p32
    variants = {
        "float64": p32.astype(np.float64),
        "fortran": np.asfortranarray(p32),
        "strided float64": wide[:, 2:5],
        "reversed twice": p32[::-1][::-1],
    }
    for name, pts in variants.items():
        got = ced.detect(pts, {"red": rgb[:, 0], "green": rgb[:, 1], "blue": rgb[:, 2]})
        np.testing.assert_array_equal(got.keypoints, ref.keypoints, err_msg=name)
        for m in ref.saliency:
            np.testing.assert_array_equal(got.saliency[m], ref.saliency[m], err_msg=name)
    # uint16 colours holding 8-bit values are scaled by 255, as in LAS files: same result.
    got = ced.detect(p32, {"r,g,b": rgb.astype(np.uint16)})
    np.testing.assert_array_equal(got.keypoints, ref.keypoints)


def test_structured_array_like_pdal():
    pts, rgb = room()
    a = np.zeros(len(pts), dtype=[("X", "f8"), ("Y", "f8"), ("Z", "f8"), ("Intensity", "u2"),
                                  ("Red", "u2"), ("Green", "u2"), ("Blue", "u2")])
    offset = np.array([500000.0, 4100000.0, 120.0])  # georeferenced, as LAS files are
    a["X"], a["Y"], a["Z"] = (pts + offset).T
    a["Red"], a["Green"], a["Blue"] = (rgb.astype(np.uint16) * 257).T
    a["Intensity"] = (pts[:, 2] * 1000).astype(np.uint16)
    cloud = ced.Cloud(a)
    assert cloud.origin[0] > 4e5 and cloud.origin[1] > 4e6 and cloud.origin[2] == 0  # float offsets keep precision
    np.testing.assert_allclose(cloud.absolute_points(), pts + offset, atol=1e-4)
    assert set(cloud.fields) == {"Intensity", "Red", "Green", "Blue"}
    r = ced.detect(a, modalities=["xyz:0.2", "rgb:0.1", "intensity:0.05"], radius=0.1)
    ref = ced.detect(pts, {"rgb": rgb.astype(np.uint16) * 257, "intensity": a["Intensity"]},
                     modalities=["xyz:0.2", "rgb:0.1", "intensity:0.05"], radius=0.1)
    assert len(r.keypoints) > 0
    assert set(r.saliency) == {"xyz", "rgb", "intensity"}
    # Channels may come as a structured array too, beside separate positions (its X, Y, Z are skipped).
    by_channels = ced.detect(pts + offset, a, modalities=["xyz:0.2", "rgb:0.1", "intensity:0.05"], radius=0.1)
    np.testing.assert_array_equal(by_channels.keypoints, r.keypoints)
    assert set(ced.Cloud(pts, a[["Red", "Intensity"]]).fields) == {"Red", "Intensity"}
    with pytest.raises(ValueError, match=r"channels\['Intensity'\]: 3 values, but there are 4000 points"):
        ced.detect(pts, a[:3])
    # The same points up to float rounding of the offsets: nearly the same keypoints.
    assert len(np.intersect1d(r.keypoints, ref.keypoints)) >= 0.9 * len(ref.keypoints)


def test_modality_objects_equal_spec_strings(sample):
    a = ced.detect(sample, modalities=[ced.xyz(0.2), ced.rgb(0.1)])
    b = ced.detect(sample, modalities=("xyz:0.2", "rgb:0.1"))
    c = ced.detect(sample, modalities=ced.preset("ced6d"))
    np.testing.assert_array_equal(a.keypoints, b.keypoints)
    np.testing.assert_array_equal(a.keypoints, c.keypoints)
    assert ced.bands(["red", "green"], 0.1, range=(0, 255)).name == "bands(red,green)"
    assert ced.intensity(0.05, field="red").name.startswith("intensity")
    assert ced.xyz(0.3).threshold(radius=0.1) == pytest.approx(0.03)
    names = [n for n, _ in ced.modalities()]
    assert {"xyz", "rgb", "lab", "intensity", "bands"} <= set(names)
    r = ced.detect(sample, modalities=[ced.xyz(), ced.lab(), ced.bands(["red", "blue"], 0.1)])
    assert list(r.saliency) == ["xyz", "lab", "bands(red,blue)"]


def test_band_ranges_and_globs_read_the_same_fields():
    rng = np.random.default_rng(3)
    pts = (rng.random((4000, 3)) * [1.0, 1.0, 0.05]).astype(np.float32)
    fields = {"b%02d" % i: rng.integers(0, 256, len(pts)).astype(np.uint8) for i in range(12)}
    fields["blue"] = rng.integers(0, 256, len(pts)).astype(np.uint8)
    typed = ced.detect(pts, fields, modalities=["bands(%s):0.2" % ",".join("b%02d" % i for i in range(12))], radius=0.08)
    assert len(typed.keypoints) > 5
    for m in ["bands(b00..b11):0.2", "bands(b??):0.2", ced.bands("b00..b11", 0.2), ced.bands(["b0?", "b1?"], 0.2)]:
        r = ced.detect(pts, fields, modalities=[m], radius=0.08)
        np.testing.assert_array_equal(r.keypoints, typed.keypoints)
    with pytest.raises(ValueError, match="swir"):
        ced.detect(pts, fields, modalities=["bands(swir*)"], radius=0.08)
    # An (n, B) array is one band block: its columns are hyper_0 ... hyper_11, and a glob or range takes them
    # without naming each.
    block = np.stack([fields["b%02d" % i] for i in range(12)], axis=1)
    for spec in ["bands(hyper_*):0.2", "bands(hyper_0..hyper_11):0.2"]:
        r = ced.detect(pts, {"hyper": block}, modalities=[spec], radius=0.08)
        np.testing.assert_array_equal(r.keypoints, typed.keypoints)


def test_result_views_and_fields(sample):
    r = ced.detect(sample, threads=1)
    n = len(sample)
    assert r.keypoints.dtype == np.uint32 and np.all(np.diff(r.keypoints.astype(np.int64)) > 0)
    assert r.keypoints.base is not None  # a view of the C++ result
    s1, s2 = r.saliency["xyz"], r.saliency["xyz"]
    assert s1.dtype == np.float32 and s1.shape == (n,)
    assert np.shares_memory(s1, s2)  # the same C++ vector each time: no copy
    assert not s1.flags.writeable
    assert r.candidate.dtype == np.bool_ and r.candidate.shape == (n,)
    assert r.neighbor_count.dtype == np.uint32 and r.neighbor_count.min() >= 1
    assert r.thresholds == pytest.approx({"xyz": 0.2 * 0.05, "rgb": 0.1})
    assert set(r.times) == {"index_ms", "saliency_ms", "nms_ms", "total_ms"}
    # Candidates are the points some modality reaches its threshold at; keypoints are candidates.
    reach = (r.saliency["xyz"] >= r.thresholds["xyz"]) | (r.saliency["rgb"] >= r.thresholds["rgb"])
    np.testing.assert_array_equal(r.candidate, reach)
    assert r.candidate[r.keypoints].all()
    assert f"{len(r.keypoints)} keypoints" in repr(r) and "xyz" in repr(r)
    keypoints = r.keypoints
    del r  # the arrays keep the result alive
    assert keypoints.sum() > 0


def test_thread_count_does_not_change_the_result(sample):
    one = ced.detect(sample, threads=1)
    for threads in (2, 3, 0):
        other = ced.detect(sample, threads=threads)
        np.testing.assert_array_equal(one.keypoints, other.keypoints)
        for m in one.saliency:
            assert one.saliency[m].tobytes() == other.saliency[m].tobytes()


def test_cloud_read_write_select_render(sample, sample_path, tmp_path):
    c = ced.read(sample_path)
    assert len(c) == len(sample) and c.points.shape == (len(c), 3) and c.points.dtype == np.float32
    assert np.shares_memory(c.points, c.points)  # a view, not a copy
    assert c.fields["red"].dtype == np.uint8
    only = ced.read(sample_path, fields=["red"])
    assert list(only.fields) == ["red"]
    out = tmp_path / "copy.pcd"
    ced.write(str(out), c)
    back = ced.read(str(out))
    np.testing.assert_array_equal(back.points, c.points)
    np.testing.assert_array_equal(back.fields["green"], c.fields["green"])
    r = ced.detect(c)
    kp = tmp_path / "kp.ply"
    ced.write_keypoints(str(kp), c, r)
    k = ced.read(str(kp))
    assert len(k) == len(r.keypoints)
    np.testing.assert_array_equal(k.points, c.points[r.keypoints])
    np.testing.assert_array_equal(k.fields["saliency_xyz"], r.saliency["xyz"][r.keypoints])
    png = tmp_path / "kp.png"
    ced.render(str(png), c, r.keypoints, view="top", width=320, height=240)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # Arrays written directly, with channels.
    pts, rgb = room(500)
    ced.write(str(tmp_path / "room.ply"), pts.astype(np.float32), {"rgb": rgb})
    room_back = ced.read(str(tmp_path / "room.ply"))
    np.testing.assert_array_equal(room_back.fields["blue"], rgb[:, 2])


def test_plugin_modality_from_python(sample):
    import os

    path = os.environ.get("CED_NDVI_PLUGIN")
    if not path:
        pytest.skip("CED_NDVI_PLUGIN is not set (ctest sets it when the examples are built)")
    assert "ndvi" in ced.load_plugin(path)
    pts, rgb = room(3000)
    nir = np.where(pts[:, 1] > 0.5, 200, 40).astype(np.uint8)
    r = ced.detect(pts, {"nir": nir, "red": rgb[:, 0]}, modalities=["xyz:0.2", "ndvi:0.1"], radius=0.1)
    assert "ndvi" in r.saliency and r.saliency["ndvi"].max() > 0.1
    with pytest.raises(ced.PluginError, match="nothing.so"):
        ced.load_plugin("/nonexistent/nothing.so")


def test_contiguous_channels_are_viewed_not_copied():
    pts, rgb = room(1000)
    red = np.ascontiguousarray(rgb[:, 0])
    intensity = np.arange(1000, dtype=np.uint16)
    cloud = ced.Cloud(pts, {"r8": red, "intensity": intensity, "rgb": rgb})
    assert np.shares_memory(cloud.fields["r8"], red)  # a contiguous (N,) array: no copy
    assert np.shares_memory(cloud.fields["intensity"], intensity)
    assert not np.shares_memory(cloud.fields["green"], rgb)  # a column of an (N, 3) array: copied
    del red, intensity  # the cloud keeps the arrays alive
    np.testing.assert_array_equal(cloud.fields["intensity"], np.arange(1000))
    # Non-native byte order, float16 and bool are converted (a copy), values kept.
    big = np.arange(1000, dtype=">u2")
    c2 = ced.Cloud(pts, {"big": big, "half": np.ones(1000, np.float16), "flag": np.ones(1000, bool)})
    np.testing.assert_array_equal(c2.fields["big"], np.arange(1000))
    assert c2.fields["half"].dtype == np.float32 and c2.fields["flag"].dtype == np.uint8


def test_detections_on_several_python_threads_run_together_and_agree(sample):
    import threading

    expected = ced.detect(sample, threads=1)
    pts, rgb = room(5000)
    expected_room = ced.detect(pts, {"rgb": rgb}, radius=0.1, threads=1)
    results, errors = {}, []

    def work(k):
        try:
            if k % 2:
                results[k] = ced.detect(sample, threads=2).keypoints
            else:
                results[k] = ced.detect(pts, {"rgb": rgb}, radius=0.1, threads=1).keypoints
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for k, kp in results.items():
        np.testing.assert_array_equal(kp, expected.keypoints if k % 2 else expected_room.keypoints)


def test_clouds_pickle_exactly(sample):
    import pickle

    pts, rgb = room(800)
    geo = ced.Cloud(pts + [600000.0, 5000000.0, 0.0], {"rgb": rgb, "intensity": np.arange(800, dtype=np.uint16)})
    for cloud in (sample, geo):
        back = pickle.loads(pickle.dumps(cloud))
        assert back.origin == cloud.origin
        np.testing.assert_array_equal(back.points, cloud.points)
        assert list(back.fields) == list(cloud.fields)
        for name, values in cloud.fields.items():
            assert back.fields[name].dtype == values.dtype
            np.testing.assert_array_equal(back.fields[name], values)
    np.testing.assert_array_equal(ced.detect(pickle.loads(pickle.dumps(sample))).keypoints,
                                  ced.detect(sample).keypoints)


def test_normals_modality_reads_or_estimates_normals():
    pts, rgb = room()
    r = 0.1
    est = ced.estimate_normals(pts, r)
    assert est.shape == (len(pts), 3) and est.dtype == np.float32
    lengths = np.linalg.norm(est, axis=1)
    assert np.all((np.abs(lengths - 1) < 1e-5) | (lengths == 0)) and np.mean(lengths > 0) > 0.99
    assert ced.normals(0.2).name == "normals" and ced.normals(0.2, radius=0.5, source="estimate").name == "normals"
    a = ced.detect(pts, {"rgb": rgb}, modalities=[ced.normals(0.2), ced.rgb(0.1)], radius=r)
    b = ced.detect(pts, {"rgb": rgb}, modalities=["normals:0.2", "rgb:0.1"], radius=r)
    np.testing.assert_array_equal(a.keypoints, b.keypoints)
    assert len(a.keypoints) > 0 and set(a.saliency) == {"normals", "rgb"}
    # The estimated normals given as fields give the same saliencies; flipped ones too (n and -n are one axis).
    given = ced.detect(pts, {"nx,ny,nz": -est}, modalities=[ced.normals(0.2, source="fields")], radius=r)
    own = ced.detect(pts, modalities=[ced.normals(0.2, source="estimate")], radius=r)
    np.testing.assert_array_equal(given.saliency["normals"], own.saliency["normals"])
    with pytest.raises(ValueError, match="radius"):
        ced.normals(0.2, radius=2)
    with pytest.raises(ValueError, match="nx"):
        ced.detect(pts, modalities=[ced.normals(source="fields")], radius=r)


def test_laz_reads_as_its_las_twin():
    """ced.read decodes LAZ: every field of the LAZ equals its plain-LAS twin's."""
    laz = ced.read(str(DATA / "autzen_trim.laz"))
    las = ced.read(str(DATA / "autzen_trim.las"))
    assert len(np.asarray(las.points)) == 110000
    np.testing.assert_array_equal(np.asarray(laz.absolute_points()), np.asarray(las.absolute_points()))
    assert list(laz.fields) == list(las.fields)
    for name, values in las.fields.items():
        np.testing.assert_array_equal(np.asarray(laz.fields[name]), np.asarray(values), err_msg=name)


def test_laz_written_reads_back(tmp_path):
    """ced.write to .laz compresses (LAS 1.2 in LAZ); it reads back as the cloud."""
    las = ced.read(str(DATA / "simple.las"))
    ced.write(str(tmp_path / "out.laz"), las)
    back = ced.read(str(tmp_path / "out.laz"))
    np.testing.assert_array_equal(np.asarray(back.absolute_points()), np.asarray(las.absolute_points()))
    for name, values in las.fields.items():
        np.testing.assert_array_equal(np.asarray(back.fields[name]), np.asarray(values), err_msg=name)


def test_copc_written_holds_the_cloud(tmp_path):
    """ced.write to .copc.laz writes COPC (LAS 1.4 in octree nodes): the same
    points and fields as the same cloud written as LAS 1.4, in node order."""
    cloud = ced.read(str(DATA / "autzen_trim.laz"))
    ced.write(str(tmp_path / "out.copc.laz"), cloud)
    ced.write(str(tmp_path / "out14.las"), cloud)
    copc = ced.read(str(tmp_path / "out.copc.laz"))
    las = ced.read(str(tmp_path / "out14.las"))
    assert list(copc.fields) == list(las.fields)

    def rows(c):
        cols = [np.asarray(c.absolute_points())[:, k] for k in range(3)]
        cols += [np.asarray(c.fields[name], dtype=np.float64) for name in c.fields]
        table = np.column_stack(cols)
        return table[np.lexsort(table.T[::-1])]

    np.testing.assert_array_equal(rows(copc), rows(las))
    assert (tmp_path / "out.copc.laz").stat().st_size < (tmp_path / "out14.las").stat().st_size / 3
