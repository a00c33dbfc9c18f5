# SPDX-License-Identifier: MIT
# Tiles from Python: plan_tiles, detect_tile, merge_parts give exactly the
# whole-cloud keypoints; plans pickle; the Dask example runs.
import os
import pathlib
import pickle
import subprocess
import sys

import numpy as np
import pytest

import ced
from conftest import DATA

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples" / "python"


@pytest.fixture(scope="module")
def las(tmp_path_factory, sample_path):
    """The bundled sample as a georeferenced LAS file."""
    c = ced.read(sample_path)
    path = tmp_path_factory.mktemp("tiles") / "sample.las"
    ced.write(str(path), ced.Cloud(c.points + np.array([500000.0, 4000000.0, 0.0]), c.fields))
    return str(path)


def test_tiles_give_the_whole_result(las, tmp_path):
    whole = ced.detect(ced.read(las), modalities="ced6d")
    plan = ced.plan_tiles(las, tile_size=0.8, modalities="ced6d")
    assert len(plan.tiles) > 3
    plan = pickle.loads(pickle.dumps(plan))  # as a Dask or multiprocessing worker gets it
    parts = []
    for i, (tile, _, _) in enumerate(plan.tiles):
        part = ced.detect_tile(plan, tile, part=str(tmp_path / f"t{tile}.cedpart") if i % 2 else None)
        parts.append(str(tmp_path / f"t{tile}.cedpart") if i % 2 else part)
    merged = ced.merge_parts(plan, parts)
    assert np.array_equal(merged.keypoints, np.asarray(whole.keypoints, dtype=np.uint64))
    assert np.array_equal(merged.saliency["rgb"], whole.saliency["rgb"][whole.keypoints])
    assert len(merged.cloud) == len(whole.keypoints)


def test_copc_tiles_read_through_its_index_give_the_whole_result():
    """A COPC file's tiles are read through its octree (ced's own LAZ decoder)."""
    copc = str(DATA / "1.2-with-color.copc.laz")
    whole = ced.detect(ced.read(copc), modalities="ced6d", radius=60.0)
    plan = ced.plan_tiles(copc, tile_size=800.0, modalities="ced6d", radius=60.0)
    assert plan.indexed  # from the index and header, no pass over the points
    assert len(plan.tiles) > 3
    merged = ced.merge_parts(plan, [ced.detect_tile(plan, t) for t, _, _ in plan.tiles])
    assert len(whole.keypoints) > 0
    assert np.array_equal(merged.keypoints, np.asarray(whole.keypoints, dtype=np.uint64))
    scanned = ced.plan_tiles(copc, tile_size=800.0, modalities="ced6d", radius=60.0, scan=True)
    assert not scanned.indexed
    merged = ced.merge_parts(scanned, [ced.detect_tile(scanned, t) for t, _, _ in scanned.tiles])
    assert np.array_equal(merged.keypoints, np.asarray(whole.keypoints, dtype=np.uint64))


def test_refined_tiles_give_the_whole_result(las, tmp_path):
    whole = ced.detect(ced.read(las), modalities="robust6d")  # refines
    assert whole.refine
    plan = ced.plan_tiles(las, tile_size=0.8, modalities="robust6d")
    merged = ced.merge_parts(plan, [ced.detect_tile(plan, t) for t, _, _ in plan.tiles])
    assert np.array_equal(merged.keypoints, np.asarray(whole.keypoints, dtype=np.uint64))
    assert np.array_equal(merged.rank, whole.rank_score)
    # The strongest by the maxima the refined keypoints stand for, as the whole run keeps.
    top = ced.plan_tiles(las, tile_size=0.8, modalities="robust6d", max_keypoints=15)
    merged = ced.merge_parts(top, [ced.detect_tile(top, t) for t, _, _ in top.tiles])
    expected = ced.detect(ced.read(las), modalities="robust6d", max_keypoints=15).keypoints
    assert len(expected) == 15 and np.array_equal(merged.keypoints, np.asarray(expected, dtype=np.uint64))
    plain = ced.plan_tiles(las, tile_size=0.8, modalities="robust6d", refine=False)
    merged = ced.merge_parts(plain, [ced.detect_tile(plain, t) for t, _, _ in plain.tiles])
    expected = ced.detect(ced.read(las), modalities="robust6d", refine=False).keypoints
    assert np.array_equal(merged.keypoints, np.asarray(expected, dtype=np.uint64))
    assert not np.array_equal(expected, whole.keypoints)


def test_tiles_keep_the_strongest_as_the_whole_run(las, tmp_path):
    for n in (1, 40, 10**6):
        whole = ced.detect(ced.read(las), modalities="ced6d", max_keypoints=n)
        plan = ced.plan_tiles(las, tile_size=0.8, modalities="ced6d", max_keypoints=n)
        assert len(plan.tiles) > 3
        merged = ced.merge_parts(plan, [ced.detect_tile(plan, t) for t, _, _ in plan.tiles])
        assert np.array_equal(merged.keypoints, np.asarray(whole.keypoints, dtype=np.uint64)), n
    with pytest.raises((ValueError, TypeError), match="max_keypoints"):
        ced.plan_tiles(las, tile_size=0.8, max_keypoints=-1)


def test_tiles_keep_the_share_of_all_candidates_as_the_whole_run(las):
    cloud = ced.read(las)
    full = ced.detect(cloud, modalities="ced6d")
    candidates = int(np.count_nonzero(full.candidate))
    for share in (1 / candidates, 0.4 * len(full) / candidates):
        whole = ced.detect(cloud, modalities="ced6d", keypoint_share=share)
        assert len(whole) < len(full), share
        plan = pickle.loads(pickle.dumps(ced.plan_tiles(las, tile_size=0.8, modalities="ced6d", keypoint_share=share)))
        merged = ced.merge_parts(plan, [ced.detect_tile(plan, t) for t, _, _ in plan.tiles])
        assert np.array_equal(merged.keypoints, np.asarray(whole.keypoints, dtype=np.uint64)), share
    with pytest.raises(ValueError, match="keypoint_share"):
        ced.plan_tiles(las, tile_size=0.8, keypoint_share=2)


def test_neighbourhood_tiles_give_the_whole_result_or_stop_clearly(las):
    cloud = ced.read(las)
    for spec in ["adaptive:12,scale=1.5,max=0.08", "knn:12,reach=0.06"]:
        whole = ced.detect(cloud, modalities="ced6d", neighborhood=spec)
        plan = pickle.loads(pickle.dumps(ced.plan_tiles(las, tile_size=0.8, modalities="ced6d", neighborhood=spec)))
        merged = ced.merge_parts(plan, [ced.detect_tile(plan, t) for t, _, _ in plan.tiles])
        assert np.array_equal(merged.keypoints, np.asarray(whole.keypoints, dtype=np.uint64)), spec
    # Without reach= the plan takes one of its own, from the density.
    own = ced.plan_tiles(las, tile_size=0.8, modalities="ced6d", neighborhood="knn:12")
    assert own.reach_estimated and own.neighborhood.startswith("knn:12,reach=")
    assert not ced.plan_tiles(las, tile_size=0.8, neighborhood="knn:12,reach=0.06").reach_estimated
    whole = ced.detect(cloud, modalities="ced6d", neighborhood="knn:12")
    merged = ced.merge_parts(own, [ced.detect_tile(own, t) for t, _, _ in own.tiles])
    assert np.array_equal(merged.keypoints, np.asarray(whole.keypoints, dtype=np.uint64))
    with pytest.raises(ValueError, match="neighborhood"):
        ced.plan_tiles(las, tile_size=0.8, neighborhood="knn:0")
    with pytest.raises(ValueError, match="search"):
        ced.plan_tiles(las, tile_size=0.8, search="octree")
    short = ced.plan_tiles(las, tile_size=0.8, modalities="ced6d", neighborhood="knn:16,reach=0.02")
    with pytest.raises(RuntimeError, match="beyond the neighbourhood's reach.*this tile's points need"):
        for t, _, _ in short.tiles:
            ced.detect_tile(short, t)


def test_tiles_bad_input(las, tmp_path):
    with pytest.raises(ValueError, match="tile_size"):
        ced.plan_tiles(las)
    with pytest.raises(ValueError, match="tile_size: must be a positive number of metres"):
        ced.plan_tiles(las, tile_size=-1)
    with pytest.raises(TypeError, match="spec strings"):
        ced.plan_tiles(las, tile_size=1, modalities=[ced.Modality("xyz:0.2")])
    plan = ced.plan_tiles(las, tile_size=0.8)
    with pytest.raises(ValueError, match="owns no points"):
        ced.detect_tile(plan, 10**6)
    first = ced.detect_tile(plan, plan.tiles[0][0])
    with pytest.raises(ced.FileError, match="have no part"):
        ced.merge_parts(plan, [first])
    with pytest.raises(ced.FileError, match="given twice"):
        ced.merge_parts(plan, [first, first])
    with pytest.raises(ced.FileError, match="malformed"):
        ced.TilePlan.from_json("{\"ced_tile_plan\": 1}")


def test_dask_example(las, tmp_path):
    pytest.importorskip("distributed", reason="dask.distributed is not installed (Debian: python3-distributed)")
    whole = ced.detect(ced.read(las), modalities="ced6d")
    out = subprocess.run([sys.executable, str(EXAMPLES / "dask_tiles.py"), las, "--tile-size", "0.8", "--workers", "2",
                          "--indices", str(tmp_path / "kp.txt"), "-o", str(tmp_path / "kp.ply")],
                         check=True, capture_output=True, text=True, env=os.environ, timeout=300).stdout
    assert f"{len(whole.keypoints)} keypoints" in out
    assert (tmp_path / "kp.txt").read_text().split() == [str(k) for k in whole.keypoints]
    assert len(ced.read(str(tmp_path / "kp.ply"))) == len(whole.keypoints)


def test_whole_cloud_statistics_give_the_whole_result_in_tiles(tmp_path):
    """range=zscore, quantile and pca= are taken from the whole cloud's sample, which the plan gathers and
    pickles with itself: every tile gets the whole cloud's statistics. 30,000 points: more than the sample."""
    rng = np.random.default_rng(11)
    n = 30000
    pts = (rng.random((n, 3)) * [1.5, 1.5, 0.02]).astype(np.float32)
    x, y = pts[:, 0].astype(np.float64), pts[:, 1].astype(np.float64)
    block = np.stack([1000 * np.sin(9 * x), 5 + np.cos(7 * y), 0.01 * np.sin(5 * (x + y)), 200 + 40 * np.sin(11 * x * y)],
                     axis=1) + rng.normal(0, 0.05, (n, 4)) * [1000, 1, 0.01, 40]
    path = str(tmp_path / "bands.ply")
    ced.write(path, pts, {"hyper": block.astype(np.float32)})
    for spec in ["bands(hyper_*):0.3,range=zscore", "bands(hyper_*):0.2,range=quantile",
                 "bands(hyper_*):0.1,range=zscore,norm=l2,pca=2"]:
        mods = ["xyz:0.2", spec]
        whole = ced.detect(ced.read(path), modalities=mods, radius=0.05)
        assert len(whole.keypoints) > 20, spec
        plan = pickle.loads(pickle.dumps(ced.plan_tiles(path, tile_size=0.5, modalities=mods, radius=0.05)))
        merged = ced.merge_parts(plan, [ced.detect_tile(plan, t) for t, _, _ in plan.tiles])
        assert np.array_equal(merged.keypoints, np.asarray(whole.keypoints, dtype=np.uint64)), spec


def test_a_folder_of_files_is_one_cloud_whole_and_in_tiles(las, tmp_path):
    """A folder (or @list) of files is one cloud: ced.read gives the points file after file, and the tiles of
    plan_tiles give its keypoints, through pickled plans as a Dask worker gets them (#61)."""
    c = ced.read(las)
    pts = c.points
    left = pts[:, 0] < np.median(pts[:, 0])
    folder = tmp_path / "tiles"
    folder.mkdir()
    fields = {k: v for k, v in c.fields.items()}
    for name, keep in (("a.las", left), ("b.las", ~left)):
        ced.write(str(folder / name), ced.Cloud(pts[keep], {k: v[keep] for k, v in fields.items()}))
    both = ced.read(str(folder))
    assert len(both) == len(c)
    assert np.array_equal(both.points, np.concatenate([pts[left], pts[~left]]))
    whole = ced.detect(both, modalities="ced6d")
    assert len(whole.keypoints) > 10
    (tmp_path / "list.txt").write_text("tiles/a.las\ntiles/b.las\n")
    for name in (str(folder), "@" + str(tmp_path / "list.txt")):
        plan = pickle.loads(pickle.dumps(ced.plan_tiles(name, tile_size=0.8, modalities="ced6d")))
        assert len(plan.tiles) > 3
        merged = ced.merge_parts(plan, [ced.detect_tile(plan, t) for t, _, _ in plan.tiles])
        assert np.array_equal(merged.keypoints, np.asarray(whole.keypoints, dtype=np.uint64))
