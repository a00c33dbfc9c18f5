#!/usr/bin/env python3
"""Real RGB-D pairs from three TUM RGB-D sequences, for `ced eval repeatability`.

    /usr/bin/python3 docs/tum_pairs.py OUT [--from DIR] [--check]

Needs numpy and Open3D (Debian: python3-numpy, python3-open3d). The frames
are from the TUM RGB-D benchmark (J. Sturm, N. Engelhard, F. Endres,
W. Burgard, D. Cremers, "A Benchmark for the Evaluation of RGB-D SLAM
Systems", IROS 2012; CC BY 4.0 according to the TUM dataset page), as three
GitHub repositories store them at pinned commits:

- tum_fr1_desk (freiburg1_desk): fy2462/slam-learning (no license stated)
  at d7d234616bb199f68afc08ac9f83a4dea00a0218, `data/`;
- tum_fr1_rpy (freiburg1_rpy, mainly rotation): jmstark/gpu_odometry (no
  license stated) at aec7c853676c7d809d9fd89e728c3f54b725a63e, `data/`;
- tum_fr3_long_office (freiburg3_long_office_household, its first frames):
  ChanghyeonKim93/edgeICP (GPL-3.0 code; the data are TUM's) at
  61a32e67efc2819f6a8ba81406007618e3fa0878,
  `dataset/rgbd_dataset_freiburg3_long_office_household/`.

Each of those folders holds rgb/TIME.png (colour), depth/TIME.png (16-bit,
5000 per metre, 0 = no depth, registered to the colour image) and
groundtruth.txt (camera-to-world poses, 100 Hz: time tx ty tz qx qy qz qw).
Downloads the frames used, or reads DIR, which holds one folder per set
named as above, laid out either as the repository (DIR/tum_fr1_desk/data/rgb/…)
or as that repository folder (DIR/tum_fr1_desk/rgb/…). Writes to OUT/<set>:

- frame<label>.ply: each frame's depth image back-projected without
  undistortion, fr1 intrinsics fx 517.3, fy 516.5, cx 318.6, cy 255.3, fr3
  ones fx 535.4, fy 539.2, cx 320.1, cy 247.6; depths beyond 4 m dropped;
  x y z as float and red green blue (the colour pixel at the same place) as
  uchar, in the camera's frame (x right, y down, z forward). The depth image
  is the one nearest in time to the colour image: 4-16 ms apart for fr1,
  under 0.1 ms for fr3. Labels are frame indices: into the nine frames of
  slam-learning for fr1_desk, lines of gpu_odometry's data/rgbd_assoc.txt
  (from 0) for fr1_rpy, into edgeICP's sixteen frames for fr3;
- T_A_B.txt for the pairs listed in SETS: the 4x4 ground truth that takes
  frame A's points into frame B's (inverse(pose B) · pose A), each pose the
  groundtruth.txt line nearest to the colour image's time, not interpolated.

The fr3 pairs barely move (under 2 cm and 0.6 degrees): near-identical views.

--check estimates each pair's ground-truth error: both clouds in 1 cm
voxels, the share of the source within 2 cm of the target once moved by the
ground truth and the median distance of those points, then point-to-plane
ICP from the ground truth (2 cm reach) and the correction it makes,
inverse(T) · T_icp, in cm and degrees.
"""
import os
import sys
import urllib.request

import numpy as np
from slambook_pairs import write_ply  # beside this script in docs/

DEPTH_SCALE, DEPTH_MAX = 5000.0, 4.0
FR1 = (517.3, 516.5, 318.6, 255.3)  # fx, fy, cx, cy
FR3 = (535.4, 539.2, 320.1, 247.6)
# set: (repository, commit, folder, intrinsics, {label: (colour time, depth time)}, pairs)
SETS = {
    "tum_fr1_desk": (
        "fy2462/slam-learning", "d7d234616bb199f68afc08ac9f83a4dea00a0218", "data/", FR1,
        {0: ("1305031453.359684", "1305031453.374112"), 3: ("1305031453.459685", "1305031453.473352"),
         6: ("1305031453.559753", "1305031453.574074"), 8: ("1305031453.627706", "1305031453.636951")},
        [(0, 3), (3, 6), (0, 6), (0, 8)],
    ),
    "tum_fr1_rpy": (
        "jmstark/gpu_odometry", "aec7c853676c7d809d9fd89e728c3f54b725a63e", "data/", FR1,
        {120: ("1305031233.525708", "1305031233.534161"), 125: ("1305031233.693779", "1305031233.702296"),
         130: ("1305031233.861613", "1305031233.865570"), 240: ("1305031237.529735", "1305031237.537650"),
         250: ("1305031237.861836", "1305031237.875422")},
        [(120, 125), (125, 130), (120, 130), (240, 250)],
    ),
    "tum_fr3_long_office": (
        "ChanghyeonKim93/edgeICP", "61a32e67efc2819f6a8ba81406007618e3fa0878",
        "dataset/rgbd_dataset_freiburg3_long_office_household/", FR3,
        {2: ("1341847980.786856", "1341847980.786879"), 5: ("1341847980.890728", "1341847980.890737"),
         9: ("1341847981.022715", "1341847981.022728"), 15: ("1341847981.222978", "1341847981.222989")},
        [(2, 5), (5, 9), (2, 9), (2, 15)],
    ),
}


def local(name, src, out, s):
    """A local path of set s's file NAME (relative to its folder, e.g. rgb/T.png): in src when given
    (src/s/FOLDER/NAME, else src/s/NAME), else downloaded once to OUT/download/s/FOLDER/NAME."""
    repo, commit, folder = SETS[s][:3]
    if src:
        for path in (os.path.join(src, s, folder + name), os.path.join(src, s, name)):
            if os.path.exists(path):
                return path
        raise FileNotFoundError("%s: no %s or %s under %s" % (s, folder + name, name, os.path.join(src, s)))
    cached = os.path.join(out, "download", s, folder + name)
    if not os.path.exists(cached):
        os.makedirs(os.path.dirname(cached), exist_ok=True)
        url = "https://raw.githubusercontent.com/%s/%s/%s%s" % (repo, commit, folder, name)
        with urllib.request.urlopen(url) as r, open(cached + ".part", "wb") as f:
            f.write(r.read())
        os.replace(cached + ".part", cached)  # no half-downloaded file under the final name
    return cached


def image(path):
    import open3d as o3d

    return np.asarray(o3d.io.read_image(path))


def backproject(depth_path, colour_path, fx, fy, cx, cy):
    """The points (metres, camera frame) of a 16-bit depth PNG and their colours."""
    d = image(depth_path).astype(np.float64) / DEPTH_SCALE
    c = image(colour_path)
    if c.ndim == 2:
        c = np.stack([c] * 3, -1)
    c = c[..., :3].astype(np.uint8)
    h, w = d.shape
    u, v = np.meshgrid(np.arange(w), np.arange(h))
    m = (d > 0) & (d <= DEPTH_MAX) & np.isfinite(d)
    z = d[m]
    return np.stack([(u[m] - cx) * z / fx, (v[m] - cy) * z / fy, z], 1), c[m]


def ground_truth(path):
    """groundtruth.txt's rows (time tx ty tz qx qy qz qw) as an array; '#' and header lines skipped,
    commas taken as spaces."""
    rows = []
    with open(path) as f:
        for line in f:
            s = line.strip()
            if s and s[0] != "#" and not s[0].isalpha():
                rows.append([float(v) for v in s.replace(",", " ").split()][:8])
    return np.array(rows)


def pose_at(gt, t):
    """The camera-to-world pose of the ground-truth row nearest to time t, as a 4x4 matrix."""
    r = gt[int(np.argmin(np.abs(gt[:, 0] - t)))]
    q = np.array([r[7], r[4], r[5], r[6]])
    w, x, y, z = q / np.linalg.norm(q)
    m = np.eye(4)
    m[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    m[:3, 3] = r[1:4]
    return m


def degrees(rot):
    return np.degrees(np.arccos(np.clip((np.trace(rot) - 1) / 2, -1, 1)))


def check(out, s):
    import open3d as o3d

    def load(label):
        return o3d.io.read_point_cloud(os.path.join(out, s, "frame%d.ply" % label)).voxel_down_sample(0.01)

    for a, b in SETS[s][5]:
        gt = np.loadtxt(os.path.join(out, s, "T_%d_%d.txt" % (a, b)))
        print("%s %d-%d: %s" % (s, a, b, gt_error(load(a), load(b), gt)))


def gt_error(s, t, gt):
    """How good the ground truth gt (source s into target t, Open3D clouds) is, as a sentence: the
    share of s within 2 cm of t once moved by gt, those points' median distance, and the correction
    inverse(gt) · T_icp that point-to-plane ICP from gt (2 cm reach) makes."""
    import open3d as o3d

    moved = o3d.geometry.PointCloud(s)
    moved.transform(gt)
    dist = np.asarray(moved.compute_point_cloud_distance(t))
    near = dist < 0.02
    with_normals = o3d.geometry.PointCloud(t)
    with_normals.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=0.05, max_nn=30))
    icp = o3d.pipelines.registration.registration_icp(
        s, with_normals, 0.02, gt, o3d.pipelines.registration.TransformationEstimationPointToPlane(),
        o3d.pipelines.registration.ICPConvergenceCriteria(max_iteration=50),
    )
    fix = np.linalg.inv(gt) @ icp.transformation
    return (
        "ground truth moves %.1f cm, %.2f deg; %.1f %% of the source within 2 cm of the target (median %.2f cm); "
        "ICP corrects it by %.2f cm, %.2f deg (fitness %.3f)"
        % (100 * np.linalg.norm(gt[:3, 3]), degrees(gt[:3, :3]), 100 * near.mean(),
           100 * np.median(dist[near]) if near.any() else float("nan"),
           100 * np.linalg.norm(fix[:3, 3]), degrees(fix[:3, :3]), icp.fitness)
    )


def main(argv):
    import argparse

    p = argparse.ArgumentParser(description="Real RGB-D pairs from three TUM RGB-D sequences.")
    p.add_argument("out", help="folder for the clouds and transforms (one sub-folder a set)")
    p.add_argument("--from", dest="src", help="a folder with one copy a set of its repository folder "
                   "(default: download them)")
    p.add_argument("--check", action="store_true", help="estimate each pair's ground-truth error with ICP")
    a = p.parse_args(argv)
    for s, (_, _, _, (fx, fy, cx, cy), frames, pairs) in SETS.items():
        os.makedirs(os.path.join(a.out, s), exist_ok=True)
        gt = ground_truth(local("groundtruth.txt", a.src, a.out, s))
        poses = {}
        for label, (t_rgb, t_depth) in frames.items():
            xyz, rgb = backproject(local("depth/%s.png" % t_depth, a.src, a.out, s),
                                   local("rgb/%s.png" % t_rgb, a.src, a.out, s), fx, fy, cx, cy)
            write_ply(os.path.join(a.out, s, "frame%d.ply" % label), xyz, rgb)
            poses[label] = pose_at(gt, float(t_rgb))
        for i, j in pairs:
            t = np.linalg.inv(poses[j]) @ poses[i]
            np.savetxt(os.path.join(a.out, s, "T_%d_%d.txt" % (i, j)), t, fmt="%.9f")
        if a.check:
            check(a.out, s)


if __name__ == "__main__":
    main(sys.argv[1:])
