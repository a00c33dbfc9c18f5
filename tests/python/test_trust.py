# SPDX-License-Identifier: MIT
# Hostile input from Python (#25): parts of another plan, a detection inside a
# Python modality, subarray fields, non-finite saliencies from a Python
# modality, outputs over the plan's input, tile options out of range, tampered
# pickled plans. Each is a clear exception (or, for nested detection, works);
# what once crashed or hung runs in a subprocess with a timeout.
import io
import json
import os
import shutil
import pickle
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import ced
from conftest import room

FOUR = ["xyz:0.2", "rgb:0.1", "lab:0.1", "bands(red,blue):0.1"]


def isolated(code, *args, timeout=120):
    """Runs `code` in a fresh interpreter (the module as this one sees it): a crash or a hang fails the test
    instead of killing or blocking the suite. Returns its stdout."""
    try:
        p = subprocess.run([sys.executable, "-c", textwrap.dedent(code), *map(str, args)], capture_output=True,
                           text=True, timeout=timeout, env=os.environ)
    except subprocess.TimeoutExpired:
        pytest.fail(f"timed out after {timeout} s (deadlock?)")
    assert p.returncode == 0, f"exit code {p.returncode}\nstdout:\n{p.stdout}\nstderr:\n{p.stderr}"
    return p.stdout


@pytest.fixture(scope="module")
def room_file(tmp_path_factory):
    pts, rgb = room(2000)
    path = tmp_path_factory.mktemp("trust") / "room.ply"
    ced.write(str(path), ced.Cloud(pts, {"rgb": rgb}))
    return str(path)


@pytest.fixture(scope="module")
def plans(room_file):
    """Two plans of one file: ced3d (one modality) and four modalities; the same tiles."""
    a = ced.plan_tiles(room_file, tile_size=0.5, modalities="ced3d", radius=0.08)
    b = ced.plan_tiles(room_file, tile_size=0.5, modalities=FOUR, radius=0.08)
    assert [t for t, _, _ in a.tiles] == [t for t, _, _ in b.tiles] and len(a.tiles) > 1
    return a, b


# 1. Parts of another plan ---------------------------------------------------------------------------------------

MERGE_OTHER = """
    import json, sys, ced
    a = ced.plan_tiles(sys.argv[1], tile_size=0.5, modalities="ced3d", radius=0.08)
    b = ced.plan_tiles(sys.argv[1], tile_size=0.5, modalities=json.loads(sys.argv[4]), radius=0.08)
    parts = [ced.detect_tile(a, t) for t, _, _ in a.tiles]
    if sys.argv[2] == "files":
        paths = []
        for p in parts:
            paths.append(f"{sys.argv[3]}/t{p.tile}.part")
            p.write(a, paths[-1])
        parts = paths
    try:
        ced.merge_parts(b, parts)
        print("no error")
    except Exception as e:
        print(type(e).__name__, e)
"""


def test_merge_parts_refuses_parts_of_another_plan(room_file):
    out = isolated(MERGE_OTHER, room_file, "memory", ".", json.dumps(FOUR))
    assert out.startswith("FileError") and "another plan" in out, out


def test_merge_parts_refuses_part_files_of_another_plan(room_file, tmp_path):
    out = isolated(MERGE_OTHER, room_file, "files", tmp_path, json.dumps(FOUR))
    assert out.startswith("FileError") and "another plan" in out and "t0.part" in out, out


def test_read_part_refuses_a_part_of_another_plan(plans, tmp_path):
    a, b = plans
    path = str(tmp_path / "a.part")
    ced.detect_tile(a, a.tiles[0][0], part=path)
    with pytest.raises(ced.FileError, match="another plan"):
        ced.read_part(b, path)


def test_part_write_refuses_another_plan(plans, tmp_path):
    a, b = plans
    part = ced.detect_tile(a, a.tiles[0][0])
    path = tmp_path / "b.part"
    with pytest.raises(ValueError, match=r"TilePart.write: the part of tile \d+ belongs to another plan"):
        part.write(b, str(path))
    assert not path.exists()
    part.write(a, str(path))  # its own plan: fine
    assert ced.read_part(a, str(path)).tile == part.tile


def test_merge_parts_refuses_what_is_not_a_part(plans):
    a, _ = plans
    with pytest.raises(TypeError, match=r"parts: expected ced.TilePart objects or paths of part files, got int"):
        ced.merge_parts(a, [3])


# 2. A detection inside a Python modality ------------------------------------------------------------------------

NESTED = """
    import sys, threading, numpy as np, ced
    rng = np.random.default_rng(1)
    outer, inner = rng.random((6000, 3)), rng.random((4000, 3))
    expected = ced.detect(inner, modalities="ced3d", radius=0.05)
    normals = ced.estimate_normals(inner, 0.05)
    how = sys.argv[1]

    def nested():
        if how == "thread":  # a thread of the callback's, which it waits for
            box = []
            t = threading.Thread(target=lambda: box.append(ced.detect(inner, modalities="ced3d", radius=0.05)))
            t.start()
            t.join()
            return box[0]
        return ced.detect(inner, modalities="ced3d", radius=0.05)  # default threads

    def fn(points, offsets, neighbors):
        if how == "normals":  # the other call that runs on all cores
            assert np.array_equal(ced.estimate_normals(inner, 0.05), normals)
        else:
            r = nested()
            assert np.array_equal(r.keypoints, expected.keypoints)
            assert np.array_equal(r.saliency["xyz"], expected.saliency["xyz"])
        return np.full(len(points), 1.0)

    r = ced.detect(outer, modalities=[ced.python_modality("nested", fn, 0.5)], radius=0.05)
    assert len(r.keypoints) > 0
    print("done")
"""


@pytest.mark.parametrize("how", ["direct", "thread", "normals"])
def test_detect_inside_a_python_modality(how):
    assert isolated(NESTED, how, timeout=180).strip() == "done"


def test_nested_detection_with_python_modalities_at_both_levels():
    out = isolated("""
        import numpy as np, ced
        rng = np.random.default_rng(2)
        outer, inner = rng.random((3000, 3)), rng.random((1500, 3))
        ones = ced.python_modality("ones", lambda p, o, n: np.ones(len(p)), 0.5)
        def fn(points, offsets, neighbors):
            r = ced.detect(inner, modalities=["xyz:0.2", ones], radius=0.06, threads=2)
            return np.full(len(points), float(len(r.keypoints) > 0))
        r = ced.detect(outer, modalities=[ced.python_modality("nested", fn, 0.5)], radius=0.06, threads=2)
        print(len(r.keypoints) > 0)
    """)
    assert out.strip() == "True"


# 3. Subarray fields of structured arrays ------------------------------------------------------------------------

def structured(n, fields):
    rng = np.random.default_rng(5)
    a = np.zeros(n, dtype=fields)
    for name in a.dtype.names:
        a[name] = rng.random(a[name].shape) * 10
    return a


@pytest.mark.parametrize("field", ["X", "y", "Z"])
def test_subarray_coordinate_fields_are_refused(field):
    names = ["X", "y", "Z"]
    dtype = [(n, "f8", (2,)) if n == field else (n, "f8") for n in names]
    a = structured(300, dtype)
    with pytest.raises(ValueError, match=rf"points\['{field}'\]: .*subarray field of shape \(2,\)"):
        ced.detect(a)
    with pytest.raises(ValueError, match=rf"points\['{field}'\]"):
        ced.Cloud(a)


def test_non_numeric_or_doubled_coordinate_fields_are_refused():
    a = structured(50, [("X", "f8"), ("Y", "f8"), ("Z", "f8")])
    s = np.zeros(50, dtype=[("X", "U8"), ("Y", "f8"), ("Z", "f8")])
    s["X"] = a["X"].astype(str)
    with pytest.raises(TypeError, match=r"points\['X'\]: expected a numeric coordinate field.*<U8"):
        ced.Cloud(s)
    d = structured(50, [("X", "f8"), ("x", "f8"), ("Y", "f8"), ("Z", "f8")])
    with pytest.raises(ValueError, match=r"points: the fields 'X' and 'x' both name the x coordinate"):
        ced.Cloud(d)


def test_subarray_channel_fields_become_columns():
    a = structured(200, [("X", "f8"), ("Y", "f8"), ("Z", "f8"), ("rgb", "u1", (3,)), ("nir", "<f4", (2,)),
                         ("big", ">u2", (2,))])
    c = ced.Cloud(a)
    for j, name in enumerate(["red", "green", "blue"]):
        np.testing.assert_array_equal(c.fields[name], a["rgb"][:, j])
    for j in range(2):
        np.testing.assert_array_equal(c.fields[f"nir_{j}"], a["nir"][:, j])
        np.testing.assert_array_equal(c.fields[f"big_{j}"], a["big"][:, j])
    np.testing.assert_allclose(c.absolute_points()[:, 0], a["X"], rtol=0, atol=1e-5)
    # the same as channels of a plain (N, 3) array
    ch = ced.Cloud(np.c_[a["X"], a["Y"], a["Z"]], a[["rgb", "nir"]])
    np.testing.assert_array_equal(ch.fields["green"], a["rgb"][:, 1])
    np.testing.assert_array_equal(ch.fields["nir_1"], a["nir"][:, 1])
    bad = structured(20, [("X", "f8"), ("Y", "f8"), ("Z", "f8"), ("m", "f4", (2, 2))])
    with pytest.raises(ValueError, match=r"points\['m'\]: expected an \(N,\) or \(N, k\) array, got shape \(20, 2, 2\)"):
        ced.Cloud(bad)


# 4. Non-finite or negative saliencies from a Python modality ----------------------------------------------------

@pytest.fixture(scope="module")
def cube():
    return np.random.default_rng(6).random((1500, 3))


@pytest.mark.parametrize("bad, text", [(np.nan, "nan"), (np.inf, "inf"), (-np.inf, "-inf"), (-0.5, "-0.5"),
                                       (1e300, "1e+300")])
def test_python_modality_bad_saliency_is_an_error(cube, bad, text):
    def block(points, offsets, neighbors):
        out = np.ones(len(points))
        out[points == 17] = bad
        return out

    def point(p, neighbors):
        return bad if p == 17 else 1.0

    for fn, per_point in ((block, False), (point, True)):
        mod = ced.python_modality("mine", fn, 0.5, per_point=per_point)
        with pytest.raises(ValueError, match=rf"Python modality 'mine': the function gave {re.escape(text)} for point 17 "
                                             r"\(saliencies must be finite and >= 0"):
            ced.detect(cube, modalities=[mod], radius=0.15, min_neighbors=1)


def test_python_modality_values_of_points_with_few_neighbours_are_ignored(cube):
    def block(points, offsets, neighbors):
        counts = np.diff(offsets)
        return np.where(counts < 8, np.nan, 1.0)  # e.g. a mean over too few points

    r = ced.detect(cube, modalities=[ced.python_modality("mine", block, 0.5)], radius=0.1, min_neighbors=8)
    few = r.neighbor_count < 8
    assert few.any() and (~few).any()
    np.testing.assert_array_equal(r.saliency["mine"], np.where(few, 0.0, 1.0).astype(np.float32))


def test_python_modality_threshold_must_be_at_least_zero():
    with pytest.raises(ValueError, match="threshold: must be a finite number >= 0"):
        ced.python_modality("mine", lambda p, o, n: np.ones(len(p)), -0.1)


# 5. Outputs that are the plan's input ---------------------------------------------------------------------------

def test_nothing_writes_over_the_plans_input(room_file, tmp_path):
    (tmp_path / "in").mkdir()
    room_file = str(shutil.copy(room_file, tmp_path / "in" / "room.ply"))  # its own: the old code overwrote it
    plan = ced.plan_tiles(room_file, tile_size=0.5, modalities="ced3d", radius=0.08)
    before = open(room_file, "rb").read()
    tile = plan.tiles[0][0]
    link = tmp_path / "link.ply"
    os.symlink(room_file, link)
    hard = tmp_path / "hard.ply"
    os.link(room_file, hard)
    roundabout = os.path.join(os.path.dirname(room_file), "..", os.path.basename(os.path.dirname(room_file)),
                              "room.ply")
    part = ced.detect_tile(plan, tile)
    for path in (plan.input, link, hard, roundabout):
        message = r"is the plan's input .*ced never writes over a file it reads"
        with pytest.raises(ValueError, match="part '.*' " + message):
            ced.detect_tile(plan, tile, part=path)
        with pytest.raises(ValueError, match="path '.*' " + message):
            part.write(plan, str(path))
        with pytest.raises(ValueError, match="path '.*' " + message):
            plan.save(str(path))
    assert open(room_file, "rb").read() == before
    assert sorted(os.listdir(tmp_path)) == ["hard.ply", "in", "link.ply"]
    assert os.listdir(tmp_path / "in") == ["room.ply"]
    ced.detect_tile(plan, tile, part=tmp_path / "t.part")  # a path-like part is fine
    assert ced.read_part(plan, str(tmp_path / "t.part")).tile == tile


# 6. Tile options out of range -----------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, error, message", [
    (dict(memory_limit=1e30), ValueError, r"memory_limit: must be 1 \.\. 1e18 bytes, got 1e\+30"),
    (dict(memory_limit=0.5), ValueError, r"memory_limit: must be 1 \.\. 1e18 bytes, got 0\.5"),
    (dict(memory_limit=0), ValueError, r"memory_limit: must be 1 \.\. 1e18 bytes"),
    (dict(memory_limit=-1), ValueError, r"memory_limit: must be 1 \.\. 1e18 bytes"),
    (dict(memory_limit=float("nan")), ValueError, r"memory_limit: must be 1 \.\. 1e18 bytes, got nan"),
    (dict(memory_limit=float("inf")), ValueError, r"memory_limit: must be 1 \.\. 1e18 bytes, got inf"),
    (dict(memory_limit=10**30), ValueError, r"memory_limit: must be 1 \.\. 1e18 bytes"),
    (dict(memory_limit="1G"), TypeError, r"memory_limit: expected a number of bytes, got str"),
    (dict(memory_limit=True), TypeError, r"memory_limit: expected a number of bytes, got bool"),
    (dict(memory_limit=1000), ValueError, r"memory_limit: 1000 bytes is too small"),
    (dict(tile_size=float("nan")), ValueError, r"tile_size: must be a positive number of metres, got nan"),
    (dict(tile_size=float("inf")), ValueError, r"tile_size: must be a positive number of metres, got inf"),
    (dict(tile_size=0), ValueError, r"tile_size: must be a positive number of metres, got 0"),
    (dict(tile_size=-1), ValueError, r"tile_size: must be a positive number of metres, got -1"),
    (dict(tile_size="1"), TypeError, r"tile_size: expected a number, got str"),
    (dict(tile_size=1, memory_limit=1e9), ValueError, r"give tile_size or memory_limit, not both"),
    (dict(tile_size=1, radius=-1), ValueError, r"radius: must be a positive number, got -1"),
    (dict(tile_size=1, radius=float("nan")), ValueError, r"radius: must be a positive number, got nan"),
    (dict(tile_size=1, radius="auto"), TypeError, r"radius: expected a number, got str"),
    (dict(tile_size=1, nms_radius=0), ValueError, r"nms_radius: must be a positive number, got 0"),
    (dict(tile_size=1, nms_radius=float("inf")), ValueError, r"nms_radius: must be a positive number, got inf"),
    (dict(tile_size=1, min_neighbors=-1), ValueError, r"min_neighbors: must be 0 \.\. 4294967295, got -1"),
    (dict(tile_size=1, min_neighbors=2**32), ValueError, r"min_neighbors: must be 0 \.\. 4294967295"),
    (dict(tile_size=1, min_neighbors=2.5), TypeError, r"min_neighbors: expected an int, got float"),
])
def test_plan_tiles_options_out_of_range(room_file, kwargs, error, message):
    with pytest.raises(error, match=message):
        ced.plan_tiles(room_file, **kwargs)


def test_plan_tiles_memory_limit_in_range_works(room_file):
    plan = ced.plan_tiles(room_file, memory_limit=4e9, modalities="ced3d", radius=0.08)
    assert len(plan.tiles) >= 1 and plan.points == 2000


def test_detect_tile_bad_arguments(plans):
    a, _ = plans
    with pytest.raises(ValueError, match=r"threads: must be 0 \(all cores\) \.\. 4096, got -1"):
        ced.detect_tile(a, a.tiles[0][0], threads=-1)
    with pytest.raises(ValueError, match=r"tile: must be 0 \.\. 18446744073709551615, got -1"):
        ced.detect_tile(a, -1)
    with pytest.raises(TypeError, match=r"part: expected a path, got int"):
        ced.detect_tile(a, a.tiles[0][0], part=3)
    # numpy integers are ints
    assert ced.detect_tile(a, np.int64(a.tiles[0][0]), threads=np.int32(1)).tile == a.tiles[0][0]


def test_plan_tiles_takes_numpy_numbers(room_file):
    plan = ced.plan_tiles(room_file, tile_size=np.float32(0.5), modalities="ced3d", radius=np.float64(0.08),
                          nms_radius=np.float32(0.08), min_neighbors=np.uint8(5))
    assert plan.radius == 0.08 and plan.tile_size == 0.5


# 7. Tampered pickled plans --------------------------------------------------------------------------------------

def tampered_pickle(plan, state):
    """The pickle of `plan` with `state` (a TilePlan pickles as its JSON text) in place of its own."""

    class Pickler(pickle.Pickler):
        def reducer_override(self, obj):
            if isinstance(obj, ced.TilePlan):
                reduced = obj.__reduce_ex__(2)
                assert reduced[2] == plan.to_json()
                return (reduced[0], reduced[1], state)
            return NotImplemented

    out = io.BytesIO()
    Pickler(out, protocol=2).dump(plan)
    return out.getvalue()


def _halo(j):
    j["grid"]["halo"] = 0.0


def _min_neighbors(j):
    j["request"]["min_neighbors"] = -1


def _tile_counts(j):
    j["tiles"][0][1] += 1


@pytest.mark.parametrize("edit, message", [(_halo, "halo"), (_min_neighbors, "min_neighbors"),
                                           (_tile_counts, "")])
def test_tampered_plans_are_refused(plans, edit, message):
    a, _ = plans
    good = pickle.loads(pickle.dumps(a))
    assert good.digest == a.digest
    state = json.loads(a.to_json())
    edit(state)
    with pytest.raises(ced.FileError, match=rf"<pickle>.*{message}"):
        pickle.loads(tampered_pickle(a, json.dumps(state)))
    with pytest.raises(ced.FileError, match=rf"<json>.*{message}"):
        ced.TilePlan.from_json(json.dumps(state))


def test_pickled_plan_state_of_the_wrong_type_is_refused(plans):
    a, _ = plans
    with pytest.raises(TypeError, match="TilePlan: the pickled state must be the plan's JSON text"):
        pickle.loads(tampered_pickle(a, 5))
    with pytest.raises(ced.FileError, match="<pickle>"):
        pickle.loads(tampered_pickle(a, "{"))


# From an adversarial pass of 2026-12-05 ------------------------------------------------------------------------


def test_masks_and_float_indices_are_refused(room_file):
    # A boolean mask was cast to indices 0 and 1, floats truncated: a wrong answer, not an error.
    cloud = ced.read(room_file)
    mask = ced.detect(cloud).candidate
    with pytest.raises(TypeError, match=r"indices: expected indices, got a boolean mask .*flatnonzero"):
        cloud.select(mask)
    with pytest.raises(TypeError, match=r"indices: expected integer indices, got dtype float64"):
        cloud.select(np.array([1.9, 2.7]))
    with pytest.raises(TypeError, match=r"boolean mask"):
        ced.eval.measure(cloud, mask, cloud, mask, np.eye(4), 0.01)
    assert len(cloud.select(np.flatnonzero(mask))) == mask.sum()


def test_damaged_cloud_pickles_are_refused_not_read_past():
    # A foreign or damaged state read 3N floats out of an N-float buffer (a segfault at 1e6).
    code = """
        import pickle, numpy as np, ced
        keep = ced.Cloud.__getstate__
        def dumped(state):
            ced.Cloud.__getstate__ = lambda self: state
            try:
                return pickle.dumps(ced.Cloud(np.zeros((1, 3))))
            finally:
                ced.Cloud.__getstate__ = keep
        for state, what in [((np.zeros(1_000_000, np.float32), (0., 0., 0.), {}), "(N, 3)"),
                            ((np.zeros((3, 3), np.float32), (float("nan"), 0., 0.), {}), "non-finite origin"),
                            ((np.zeros((3, 3), np.float32), (0., 0.), {}), "3 numbers"),
                            ((np.full((3, 3), np.inf, np.float32), (0., 0., 0.), {}), "non-finite coordinate")]:
            try:
                pickle.loads(dumped(state))
                print("accepted", what)
            except ValueError as e:
                assert what in str(e), str(e)
        c = ced.Cloud(np.arange(12.).reshape(4, 3), {"i": np.arange(4)})
        d = pickle.loads(pickle.dumps(c))
        assert (d.points == c.points).all() and (d.fields["i"] == c.fields["i"]).all()
        print("ok")
    """
    assert isolated(code).strip() == "ok"


def test_paths_may_be_path_objects(room_file, tmp_path):
    import pathlib

    cloud = ced.read(pathlib.Path(room_file))
    ced.write(tmp_path / "c.pcd", cloud)
    assert len(ced.read(tmp_path / "c.pcd")) == len(cloud)
    r = ced.detect(cloud)
    ced.write_keypoints(tmp_path / "k.ply", cloud, r)
    ced.render(tmp_path / "k.png", cloud, r.keypoints)
    plan = ced.plan_tiles(pathlib.Path(room_file), tile_size=0.5, radius=0.08)
    plan.save(tmp_path / "plan.json")
    assert ced.TilePlan.load(tmp_path / "plan.json").digest == plan.digest
    (tmp_path / "parts").mkdir()
    for t, _, _ in plan.tiles:
        ced.detect_tile(plan, t, part=tmp_path / "parts" / f"t{t}.part")
    entries = list(os.scandir(tmp_path / "parts"))  # os.DirEntry was opened as str(entry)
    merged = ced.merge_parts(plan, entries)
    whole = ced.detect(cloud, radius=0.08)
    np.testing.assert_array_equal(merged.keypoints, whole.keypoints)
    first = entries[0]
    np.testing.assert_array_equal(ced.read_part(plan, first).keypoints, ced.read_part(plan, first.path).keypoints)
    with pytest.raises(TypeError, match=r"path: expected a path, got int"):
        ced.read(3)


def test_a_presets_list_runs_the_preset(room_file):
    # ced.preset("robust3d") lost the preset's refinement and share: another detector, silently.
    cloud = ced.read(room_file)
    for name in ("robust3d", "robust6d", "ced6d"):
        by_name, by_list = ced.detect(cloud, modalities=name), ced.detect(cloud, modalities=ced.preset(name))
        np.testing.assert_array_equal(by_name.keypoints, by_list.keypoints)
        assert (by_list.refine, by_list.keypoint_share) == (ced.preset_refines(name), ced.preset_keypoint_share(name))
    changed = ced.preset("robust3d") + [ced.rgb()]  # no longer the preset: plain modalities
    assert ced.detect(cloud, modalities=changed).refine is False
    a = ced.plan_tiles(room_file, tile_size=0.5, radius=0.08, modalities="robust3d")
    b = ced.plan_tiles(room_file, tile_size=0.5, radius=0.08, modalities=ced.preset("robust3d"))
    assert a.digest == b.digest


def test_counts_take_numpy_integers_and_name_the_parameter(room_file):
    cloud = ced.read(room_file)
    ref = ced.detect(cloud, min_neighbors=5, max_keypoints=20, threads=1)
    got = ced.detect(cloud, min_neighbors=np.int64(5), max_keypoints=np.uint16(20), threads=np.int32(1))
    np.testing.assert_array_equal(ref.keypoints, got.keypoints)
    with pytest.raises(ValueError, match=r"max_keypoints: must be 0 \.\. "):
        ced.detect(cloud, max_keypoints=2**64)
    with pytest.raises(ValueError, match=r"threads: must be 0 \.\. "):
        ced.detect(cloud, threads=-1)
    with pytest.raises(TypeError, match=r"min_neighbors: expected an int, got bool_"):
        ced.detect(cloud, min_neighbors=np.bool_(True))


def test_numpys_default_integers_as_colours(sample):
    # int64 colours (np.array of Python ints, pandas) were scaled by 2^64: no colour saliency at all.
    c = sample
    rgb = np.c_[c.fields["red"], c.fields["green"], c.fields["blue"]]
    ref = ced.detect(c.points, {"rgb": rgb.astype(np.uint8)})
    for dt in (np.int64, np.int32, np.uint32):
        np.testing.assert_array_equal(ced.detect(c.points, {"rgb": rgb.astype(dt)}).keypoints, ref.keypoints)


def test_write_keypoints_of_another_cloud_is_refused(sample, room_file, tmp_path):
    other = ced.read(room_file)
    with pytest.raises(ValueError, match=r"result: detected on a cloud of 2000 points, not on this one of 24574"):
        ced.write_keypoints(tmp_path / "k.ply", sample, ced.detect(other))
    assert not (tmp_path / "k.ply").exists()


def test_a_daemon_thread_inside_detect_at_exit_does_not_abort():
    # The interpreter stopped the thread when it took the GIL back, inside C++
    # frames that cannot unwind: "terminate called without an active exception".
    out = isolated("""
        import threading, time
        import numpy as np, ced
        pts = np.random.default_rng(0).random((300000, 3)).astype(np.float32)
        started = threading.Event()
        def work():
            started.set()
            ced.detect(pts, modalities="ced3d", radius=0.03)
        threading.Thread(target=work, daemon=True).start()
        started.wait()
        time.sleep(0.05)
        print("main exits")
    """)
    assert "main exits" in out
