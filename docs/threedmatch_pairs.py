#!/usr/bin/env python3
"""Real pairs of fused depth fragments (3DMatch / 3DLoMatch) and of LiDAR scans with
ground truth, for `ced eval repeatability` (issue #59).

    /usr/bin/python3 docs/threedmatch_pairs.py OUT [--from DIR] [--check]

Needs numpy and Open3D (Debian: python3-numpy, python3-open3d). Reads the files
listed in SOURCES below, each from a public GitHub repository at a pinned commit:
from DIR/<owner>/<repo>/<path> when --from DIR is given, else downloaded once from
raw.githubusercontent.com to OUT/download/<owner>/<repo>/<path> (the same layout,
so a folder filled by hand works as DIR). Without network, fill DIR from clones:

    git -C CLONE show COMMIT:PATH > DIR/OWNER/REPO/PATH

Writes, for every pair in PAIRS:

- OUT/<scene>/<pair>/source.ply, target.ply: x y z as float (binary PLY), the
  points as the repository stores them: no voxel grid, no cropping (fused
  3DMatch fragments are already dense; `ced eval` voxelises);
- OUT/<scene>/<pair>/transform.txt: the 4x4 ground truth, row-major, taking the
  source's points into the target's frame (what `ced eval repeatability
  --transform` takes);
- OUT/pairs.csv: scene, pair, split, kind, resolution, the two fragments, the
  benchmark list the pair is in, overlap, residual, the sources and licences.

The fragments. 3DMatch's test fragments (Zeng et al., CVPR 2017) are fused from
50 depth frames each, in their own frame. Two copies of them are in reach:

- "6mm": the fragments as 3DMatch ships them (cloud_bin_N.ply, 250-350 k points
  on a 6 mm lattice), as MIT-SPARK/TEASER-plusplus and
  zhangxy0517/3D-Registration-with-Maximal-Cliques store them (all under 4 MiB);
- "12mm": OverlapPredator's copies (cloud_bin_N.pth, a pickled float64 N x 3
  array; 15-25 k points with a 12 mm median spacing, a subset of the 6 mm
  points: fragment 0's 12 mm copy lies on its 6 mm copy to 0.0 mm), as
  prs-eth/OverlapPredator, yewzijian/RegTR and qinzheng93/GeoTransformer
  (`data/demo/src.npy`, fragment 6) ship them for their demos.

A pair uses one copy on both sides, except home_at 38 -> 2 ("12mm->6mm"), the
only partner reachable for home_at's 6 mm fragment 2; its densities differ.

Ground truth: the 3DMatch benchmark's gt.log (as OverlapPredator's
configs/benchmarks/{3DMatch,3DLoMatch}/<scene>/gt.log store it; the same entries
as andyzeng/3dmatch-toolbox's). An entry "i j n" and its 4x4 T take fragment j's
points into fragment i's frame. The entries of a scene are consistent (chaining
them around any loop closes to 1e-8), so every fragment gets a pose W_k by chaining
from fragment 0 (W_j = W_i T_ij) and a pair s -> t gets inverse(W_t) W_s; for a
pair that is itself an entry this is that entry. The column `benchmark` says
whether the pair is an entry of 3DMatch's gt.log (overlap > 30 %), of 3DLoMatch's
(10-30 %) or of neither (chained; its overlap is still >= 10 %).

The LiDAR pairs:

- small_gicp: koide3/small_gicp's two outdoor scans `data/source.ply` and
  `target.ply` with `data/T_target_source.txt` (the pose its registration tests
  accept within 0.2 m and 2.5 deg; no error is stated);
- eth_hallway: ethz-asl/libpointmatcher's `examples/data/cloud.00001.vtk` (source)
  and `cloud.00000.vtk` (target), ETH indoor scans; the transform is
  `examples/data/icp_data/defaultIdentityDataPointsFilter.ref_trans`, the result
  its unit tests expect from ICP of cloud.00001 (data) onto cloud.00000
  (reference): a reference registration, not surveyed ground truth.

Splits (by scene: no scene in both):

- tune: sun3d-home_at-home_at_scan1_2013_jan_1, sun3d-hotel_umd-maryland_hotel3,
  LiDAR small_gicp (presets were already chosen on it, docs/journal/real-pairs.md);
- test: 7-scenes-redkitchen (all its pairs), LiDAR eth_hallway.
Only three 3DMatch scenes are reachable, and redkitchen holds most pairs, so the
fused-fragment split is 3 tune pairs against 15 held-out pairs, not 1/3 : 2/3.

--check recomputes each pair's overlap (the share of the source's points with a
target point within REACH after the transform: 3 cm for fragments, 0.2 m for LiDAR),
the residual (the median of those points' distances) and the ground truth's error
estimate as slambook_pairs.py does (point-to-point ICP from the ground truth, 5 cm
reach for fragments and 0.5 m for LiDAR, then how far that correction moves the
source's overlapping points: median), and compares them with pairs.csv.
On fused fragments the residual is the telling figure (4.7-9.4 mm on the 6 mm
pairs; 13-16 mm on the 12 mm ones, their own spacing): the ICP correction
(1.5-7 cm on 2026-12-07) mostly measures ICP sliding along the walls and floors
of partial overlaps, not the ground truth's error.

Licences: the repositories are MIT (OverlapPredator: Shengyu Huang, Zan Gojcic
2021; RegTR: Zi Jian Yew 2022; GeoTransformer: Zheng Qin 2022; TEASER-plusplus:
MIT 2020; 3D-Registration-with-Maximal-Cliques: zhangxy0517 2023; small_gicp:
Kenji Koide 2024) and BSD (libpointmatcher, README "permissive BSD license",
package.xml <license>BSD</license>). The 3DMatch fragments themselves are derived
from 7-Scenes (Microsoft Research; non-commercial research use) and SUN3D
(Xiao, Owens, Torralba); 3DMatch asks users to follow the source data sets'
terms, so use these pairs for research only. small_gicp's and libpointmatcher's
scans carry their repositories' licences; their capture is not otherwise stated.
"""
import csv
import io
import os
import pickle
import sys
import urllib.request

import numpy as np

PREDATOR = ("prs-eth/OverlapPredator", "8c78f125fc58d62ad7d149adf1fed43ed54937e4", "MIT")
REGTR = ("yewzijian/RegTR", "0edee25cda6b1ac1c2b0ac686dcdf2593abf25ba", "MIT")
GEOTR = ("qinzheng93/GeoTransformer", "e7a135af4c318ff3b8d7f6c963df094d7e4ea540", "MIT")
TEASER = ("MIT-SPARK/TEASER-plusplus", "f91cfdb7baed951a3607257bd31f3f6694773497", "MIT")
MAC = ("zhangxy0517/3D-Registration-with-Maximal-Cliques", "15f35093ea61a6344153059433b382b51d455cb4", "MIT")
SMALL_GICP = ("koide3/small_gicp", "aea131352e0d362d3e579a334c477cfafa5ee5eb", "MIT")
LPM = ("ethz-asl/libpointmatcher", "580d29d7611c0611ec524463a2da38c0c090cddd", "BSD")

RK = "7-scenes-redkitchen"
HA = "sun3d-home_at-home_at_scan1_2013_jan_1"
H3 = "sun3d-hotel_umd-maryland_hotel3"
SPLIT = {RK: "test", HA: "tune", H3: "tune", "lidar-small_gicp": "tune", "lidar-eth_hallway": "test"}
TERMS_3DMATCH = "3DMatch data: 7-Scenes / SUN3D terms (research use)"

# (scene, fragment, copy) -> (repository, path in it)
FRAGMENTS = {
    (RK, 0, "12mm"): (REGTR, "data/indoor/test/7-scenes-redkitchen/cloud_bin_0.pth"),
    (RK, 5, "12mm"): (REGTR, "data/indoor/test/7-scenes-redkitchen/cloud_bin_5.pth"),
    (RK, 6, "12mm"): (GEOTR, "data/demo/src.npy"),
    (RK, 21, "12mm"): (PREDATOR, "assets/cloud_bin_21.pth"),
    (RK, 34, "12mm"): (PREDATOR, "assets/cloud_bin_34.pth"),
    (RK, 0, "6mm"): (TEASER, "examples/teaser_python_fpfh_icp/data/cloud_bin_0.ply"),
    (RK, 4, "6mm"): (TEASER, "examples/teaser_python_fpfh_icp/data/cloud_bin_4.ply"),
    (RK, 7, "6mm"): (MAC, "demo/src.pcd"),
    (RK, 59, "6mm"): (MAC, "Python_implement/test/target.ply"),
    (HA, 38, "12mm"): (REGTR, "data/indoor/test/sun3d-home_at-home_at_scan1_2013_jan_1/cloud_bin_38.pth"),
    (HA, 41, "12mm"): (REGTR, "data/indoor/test/sun3d-home_at-home_at_scan1_2013_jan_1/cloud_bin_41.pth"),
    (HA, 2, "6mm"): (TEASER, "examples/example_data/3dmatch_sample/cloud_bin_2.ply"),
    (H3, 8, "12mm"): (REGTR, "data/indoor/test/sun3d-hotel_umd-maryland_hotel3/cloud_bin_8.pth"),
    (H3, 15, "12mm"): (REGTR, "data/indoor/test/sun3d-hotel_umd-maryland_hotel3/cloud_bin_15.pth"),
}
# (scene, source fragment, source copy, target fragment, target copy): every pair of the
# reachable fragments of a scene, in one copy, whose overlap is >= 10 % both ways.
PAIRS = [
    (RK, 5, "12mm", 0, "12mm"), (RK, 6, "12mm", 0, "12mm"), (RK, 34, "12mm", 0, "12mm"),
    (RK, 6, "12mm", 5, "12mm"), (RK, 21, "12mm", 5, "12mm"), (RK, 34, "12mm", 5, "12mm"),
    (RK, 21, "12mm", 6, "12mm"), (RK, 34, "12mm", 6, "12mm"), (RK, 34, "12mm", 21, "12mm"),
    (RK, 4, "6mm", 0, "6mm"), (RK, 7, "6mm", 0, "6mm"), (RK, 59, "6mm", 0, "6mm"),
    (RK, 7, "6mm", 4, "6mm"), (RK, 59, "6mm", 4, "6mm"), (RK, 59, "6mm", 7, "6mm"),
    (HA, 41, "12mm", 38, "12mm"), (HA, 38, "12mm", 2, "6mm"),
    (H3, 15, "12mm", 8, "12mm"),
]
# name -> (repository, source path, target path, transform path)
LIDAR = {
    "small_gicp": (SMALL_GICP, "data/source.ply", "data/target.ply", "data/T_target_source.txt"),
    "eth_hallway": (
        LPM,
        "examples/data/cloud.00001.vtk",
        "examples/data/cloud.00000.vtk",
        "examples/data/icp_data/defaultIdentityDataPointsFilter.ref_trans",
    ),
}
REACH = {"fragment": (0.03, 0.05), "lidar": (0.2, 0.5)}  # overlap reach, ICP reach (m)


def fetched(repo, path, src, out):
    """The local path of PATH in REPO (owner/name, commit, licence): under src when given, else
    downloaded once from raw.githubusercontent.com at the pinned commit to OUT/download."""
    name, commit = repo[0], repo[1]
    if src:
        return os.path.join(src, name, path)
    cached = os.path.join(out, "download", name, path)
    if not os.path.exists(cached):
        os.makedirs(os.path.dirname(cached), exist_ok=True)
        url = "https://raw.githubusercontent.com/%s/%s/%s" % (name, commit, path)
        with urllib.request.urlopen(url) as r, open(cached + ".part", "wb") as f:
            f.write(r.read())
        os.replace(cached + ".part", cached)  # no half-downloaded file under the final name
    return cached


class _Numpy(pickle.Unpickler):
    """Unpickles numpy arrays only; torch's storages (persistent ids) are not expected."""

    def find_class(self, module, name):
        if module.split(".")[0] == "numpy" or (module, name) == ("_codecs", "encode"):  # the array's bytes
            return super().find_class(module, name)
        raise pickle.UnpicklingError("unexpected %s.%s in a fragment file" % (module, name))

    def persistent_load(self, pid):
        raise pickle.UnpicklingError("a torch tensor, not a numpy array")


def read_pth(path):
    """OverlapPredator's fragments: torch.save (legacy format) of a float64 N x 3 numpy array,
    i.e. pickles of a magic number, a protocol version, system info, then the array."""
    with open(path, "rb") as f:
        stream = io.BytesIO(f.read())
    objs = [_Numpy(stream, encoding="latin1").load() for _ in range(4)]
    return np.asarray(objs[3], dtype=np.float64)


def read_vtk(path):
    """An ASCII VTK POLYDATA file's POINTS."""
    words = open(path).read().split()
    k = words.index("POINTS")
    n = int(words[k + 1])
    return np.array(words[k + 3 : k + 3 + 3 * n], dtype=np.float64).reshape(n, 3)


def read_points(path):
    if path.endswith(".pth"):
        p = read_pth(path)
    elif path.endswith(".npy"):
        p = np.load(path, allow_pickle=False)
    elif path.endswith(".vtk"):
        p = read_vtk(path)
    else:
        import open3d as o3d

        p = np.asarray(o3d.io.read_point_cloud(path).points)
    p = np.asarray(p, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
        raise ValueError("%s: expected N x 3 points" % path)
    return p[np.isfinite(p).all(axis=1)]


def read_matrix(path):
    m = np.array(open(path).read().split(), dtype=np.float64)
    if m.size != 16:
        raise ValueError("%s: expected a 4x4 matrix" % path)
    return m.reshape(4, 4)


def read_log(text):
    """A gt.log: {(i, j): 4x4 T taking fragment j into fragment i's frame}."""
    rows = [line.split() for line in text.splitlines() if line.strip()]
    return {
        (int(rows[k][0]), int(rows[k][1])): np.array(rows[k + 1 : k + 5], dtype=np.float64)
        for k in range(0, len(rows), 5)
    }


def scene_poses(scene, src, out):
    """Each fragment's pose W_k (W_0 = I, W_j = W_i T_ij) chained through the scene's 3DMatch and
    3DLoMatch gt.log entries, the entries themselves ({(i, j): benchmark}), and the largest
    disagreement between an entry and the chained poses."""
    edges, bench = {}, {}
    for b in ("3DMatch", "3DLoMatch"):
        text = open(fetched(PREDATOR, "configs/benchmarks/%s/%s/gt.log" % (b, scene), src, out)).read()
        for ij, t in read_log(text).items():
            edges[ij] = t
            bench.setdefault(ij, b)
    adj = {}
    for (i, j), t in edges.items():
        adj.setdefault(i, []).append((j, t))
        adj.setdefault(j, []).append((i, np.linalg.inv(t)))
    poses, todo = {0: np.eye(4)}, [0]
    while todo:
        i = todo.pop()
        for j, t in adj[i]:
            if j not in poses:
                poses[j] = poses[i] @ t
                todo.append(j)
    worst = max(np.abs(np.linalg.inv(poses[i]) @ poses[j] - t).max() for (i, j), t in edges.items())
    return poses, bench, worst


def write_ply(path, xyz):
    rec = np.asarray(xyz, dtype="<f4")
    header = (
        "ply\nformat binary_little_endian 1.0\nelement vertex %d\n"
        "property float x\nproperty float y\nproperty float z\nend_header\n" % len(rec)
    )
    with open(path, "wb") as f:
        f.write(header.encode() + rec.tobytes())


def measure(source, target, gt, kind):
    """(overlap, residual, ICP correction): the share of the source's points within the overlap
    reach of the target after gt, those points' median distance to it, and how far point-to-point
    ICP from gt moves them (median), all in metres."""
    import open3d as o3d

    reach, icp_reach = REACH[kind]
    s = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(source))
    t = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(target))
    moved = source @ gt[:3, :3].T + gt[:3, 3]
    d = np.asarray(o3d.geometry.PointCloud(o3d.utility.Vector3dVector(moved)).compute_point_cloud_distance(t))
    near = d < reach
    icp = o3d.pipelines.registration.registration_icp(
        s, t, icp_reach, gt, o3d.pipelines.registration.TransformationEstimationPointToPoint()
    )
    fix = icp.transformation @ np.linalg.inv(gt)
    shift = np.linalg.norm(moved[near] @ fix[:3, :3].T + fix[:3, 3] - moved[near], axis=1)
    return near.mean(), float(np.median(d[near])), float(np.median(shift))


def source_of(repo, *paths):
    return "%s@%s:%s" % (repo[0], repo[1][:12], "+".join(paths))


def build(out, src):
    """Writes every pair; returns the rows of pairs.csv (without the measures)."""
    rows, poses = [], {}
    for scene, fs, cs, ft, ct in PAIRS:
        if scene not in poses:
            poses[scene] = scene_poses(scene, src, out)
            print("%s: %d fragments posed, gt.log entries agree to %.1e" % (scene, len(poses[scene][0]), poses[scene][2]))
        w, bench, _ = poses[scene]
        gt = np.linalg.inv(w[ft]) @ w[fs]
        (rs, ps), (rt, pt) = FRAGMENTS[(scene, fs, cs)], FRAGMENTS[(scene, ft, ct)]
        pair = "%d-%d" % (fs, ft) if cs == ct else "%d-%d_%s-%s" % (fs, ft, cs, ct)
        d = os.path.join(out, scene, pair)
        os.makedirs(d, exist_ok=True)
        write_ply(os.path.join(d, "source.ply"), read_points(fetched(rs, ps, src, out)))
        write_ply(os.path.join(d, "target.ply"), read_points(fetched(rt, pt, src, out)))
        np.savetxt(os.path.join(d, "transform.txt"), gt, fmt="%.10f")
        gtlog = "gt.log of %s:%s (3DMatch+3DLoMatch), chained" % (PREDATOR[0], PREDATOR[1][:12])
        rows.append({
            "scene": scene, "pair": pair, "split": SPLIT[scene], "kind": "fragment",
            "resolution": cs if cs == ct else "%s->%s" % (cs, ct),
            "source_fragment": "cloud_bin_%d" % fs, "target_fragment": "cloud_bin_%d" % ft,
            "benchmark": bench.get((ft, fs), "chained"),
            "source": "%s; %s; %s" % (source_of(rs, ps), source_of(rt, pt), gtlog),
            "licence": "%s (%s), %s (%s); %s" % (rs[0], rs[2], rt[0], rt[2], TERMS_3DMATCH),
        })
    for name, (repo, ps, pt, pm) in LIDAR.items():
        scene = "lidar-" + name
        d = os.path.join(out, scene, "source-target")
        os.makedirs(d, exist_ok=True)
        write_ply(os.path.join(d, "source.ply"), read_points(fetched(repo, ps, src, out)))
        write_ply(os.path.join(d, "target.ply"), read_points(fetched(repo, pt, src, out)))
        np.savetxt(os.path.join(d, "transform.txt"), read_matrix(fetched(repo, pm, src, out)), fmt="%.10f")
        rows.append({
            "scene": scene, "pair": "source-target", "split": SPLIT[scene], "kind": "lidar",
            "resolution": "as stored", "source_fragment": os.path.basename(ps), "target_fragment": os.path.basename(pt),
            "benchmark": "reference ICP" if name == "eth_hallway" else "repository's T_target_source",
            "source": source_of(repo, ps, pt, pm), "licence": "%s (%s)" % (repo[0], repo[2]),
        })
    return rows


COLUMNS = ["scene", "pair", "split", "kind", "resolution", "source_fragment", "target_fragment", "benchmark",
           "source_points", "target_points", "overlap", "residual_m", "icp_correction_m", "source", "licence"]


def measured(out, row):
    d = os.path.join(out, row["scene"], row["pair"])
    import open3d as o3d

    s = np.asarray(o3d.io.read_point_cloud(os.path.join(d, "source.ply")).points)
    t = np.asarray(o3d.io.read_point_cloud(os.path.join(d, "target.ply")).points)
    gt = np.loadtxt(os.path.join(d, "transform.txt"))
    ov, res, fix = measure(s, t, gt, row["kind"])
    return {"source_points": len(s), "target_points": len(t), "overlap": "%.3f" % ov,
            "residual_m": "%.4f" % res, "icp_correction_m": "%.4f" % fix}


def check(out):
    """Recomputes every pair's measures and compares them with pairs.csv."""
    bad = 0
    with open(os.path.join(out, "pairs.csv")) as f:
        for row in csv.DictReader(f):
            m = measured(out, row)
            same = all(abs(float(m[k]) - float(row[k])) < 1e-3 for k in ("overlap", "residual_m", "icp_correction_m"))
            bad += not same
            print("%-45s %-22s overlap %s residual %s m ICP correction %s m %s" % (
                row["scene"], row["pair"], m["overlap"], m["residual_m"], m["icp_correction_m"],
                "ok" if same else "DIFFERS from pairs.csv"))
    return bad


def main(argv):
    import argparse

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("out", help="folder for the pairs and pairs.csv")
    p.add_argument("--from", dest="src", help="a folder with the sources as <owner>/<repo>/<path> (default: download)")
    p.add_argument("--check", action="store_true", help="recompute overlap, residual and ICP correction")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    rows = build(a.out, a.src)
    for row in rows:
        row.update(measured(a.out, row))
        print("%-45s %-22s %-5s overlap %s residual %s m ICP correction %s m" % (
            row["scene"], row["pair"], row["split"], row["overlap"], row["residual_m"], row["icp_correction_m"]))
    with open(os.path.join(a.out, "pairs.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)
    print("wrote %d pairs to %s" % (len(rows), os.path.join(a.out, "pairs.csv")))
    if a.check and check(a.out):
        sys.exit(1)


if __name__ == "__main__":
    main(sys.argv[1:])
