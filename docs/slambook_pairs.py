#!/usr/bin/env python3
"""Real RGB-D pairs from slambook2's five sample frames, for `ced eval repeatability`.

    /usr/bin/python3 docs/slambook_pairs.py OUT [--from DIR] [--check]

Needs numpy and Open3D (Debian: python3-numpy, python3-open3d). Reads the
frames of gaoxiang12/slambook2 (MIT) at a pinned commit, `ch5/rgbd`: colour
PNGs, 16-bit depth PGMs in millimetres and `pose.txt` (one camera-to-world
pose a frame: tx ty tz qx qy qz qw). Downloads them, or reads DIR, a copy of
that `ch5/rgbd` folder. Writes to OUT:

- frame1.ply … frame5.ply: each frame back-projected with the book's
  intrinsics (fx 518, fy 519, cx 325.5, cy 253.5), depths beyond 3 m dropped
  as `ced eval repeatability --rgbd` does, x y z as float and red green blue
  as uchar, in the camera's frame;
- T_A_B.txt for the consecutive pairs: the 4x4 ground truth that takes
  frame A's points into frame B's (inverse(pose B) · pose A).

--check estimates each pair's ground-truth error: point-to-point ICP from
the ground truth (1 cm voxels, 5 cm reach), then how far that correction
moves the source's points that lie within 5 cm of the target.
"""
import os
import sys
import urllib.request

import numpy as np

COMMIT = "e62d9cd1f95bab337fb4251608543b71d004c420"
URL = "https://raw.githubusercontent.com/gaoxiang12/slambook2/" + COMMIT + "/ch5/rgbd/"
FX, FY, CX, CY, DEPTH_SCALE, DEPTH_MAX = 518.0, 519.0, 325.5, 253.5, 1000.0, 3.0
PAIRS = [(1, 2), (2, 3), (3, 4), (4, 5)]


def local(name, src, out):
    """A local path of ch5/rgbd/NAME: in src when given, else downloaded once to OUT/download."""
    return fetched(URL, name, src, out)


def fetched(url, name, src, out):
    """src/NAME when src is given, else url + NAME downloaded once to OUT/download/NAME (also
    used by sevenscenes_pairs.py)."""
    if src:
        return os.path.join(src, name)
    cached = os.path.join(out, "download", name)
    if not os.path.exists(cached):
        os.makedirs(os.path.dirname(cached), exist_ok=True)
        with urllib.request.urlopen(url + name) as r, open(cached + ".part", "wb") as f:
            f.write(r.read())
        os.replace(cached + ".part", cached)  # no half-downloaded file under the final name
    return cached


def read_bytes(path):
    with open(path, "rb") as f:
        return f.read()


def depth_metres(pgm):
    """A binary 16-bit PGM (P5, big-endian samples) as metres."""
    magic, width, height, maxval = pgm.split(maxsplit=4)[:4]
    w, h = int(width), int(height)
    if magic != b"P5" or int(maxval) != 65535:
        raise ValueError("expected a 16-bit binary PGM")
    samples = np.frombuffer(pgm[len(pgm) - 2 * w * h :], dtype=">u2").reshape(h, w)
    return samples.astype(np.float64) / DEPTH_SCALE


def colour(path):
    import open3d as o3d

    return np.asarray(o3d.io.read_image(path))[:, :, :3]


def write_ply(path, xyz, rgb):
    rec = np.zeros(len(xyz), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("r", "u1"), ("g", "u1"), ("b", "u1")])
    rec["x"], rec["y"], rec["z"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    rec["r"], rec["g"], rec["b"] = rgb[:, 0], rgb[:, 1], rgb[:, 2]
    header = (
        "ply\nformat binary_little_endian 1.0\nelement vertex %d\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n" % len(xyz)
    )
    with open(path, "wb") as f:
        f.write(header.encode() + rec.tobytes())


def pose_matrix(tx, ty, tz, qx, qy, qz, qw):
    n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x, y, z, w = qx / n, qy / n, qz / n, qw / n
    m = np.eye(4)
    m[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    m[:3, 3] = [tx, ty, tz]
    return m


def check(out):
    import open3d as o3d

    def load(i):
        return o3d.io.read_point_cloud(os.path.join(out, "frame%d.ply" % i)).voxel_down_sample(0.01)

    for a, b in PAIRS:
        gt = np.loadtxt(os.path.join(out, "T_%d_%d.txt" % (a, b)))
        print("%d-%d: %s" % (a, b, gt_error(load(a), load(b), gt)))


def gt_error(s, t, gt):
    """How good the ground truth gt (source s into target t, Open3D clouds) is, as a sentence:
    point-to-point ICP from it (5 cm reach), and how far that correction moves the source's
    points that lie within 5 cm of the target. Also used by sevenscenes_pairs.py."""
    import numpy as np
    import open3d as o3d

    icp = o3d.pipelines.registration.registration_icp(
        s, t, 0.05, gt, o3d.pipelines.registration.TransformationEstimationPointToPoint()
    )
    moved = np.asarray(s.points) @ gt[:3, :3].T + gt[:3, 3]
    near = np.asarray(o3d.geometry.PointCloud(o3d.utility.Vector3dVector(moved)).compute_point_cloud_distance(t))
    near = near < 0.05
    fix = icp.transformation @ np.linalg.inv(gt)
    shift = np.linalg.norm(moved[near] @ fix[:3, :3].T + fix[:3, 3] - moved[near], axis=1)
    return (
        "%.0f %% of the source within 5 cm of the target; ICP moves those points by %.1f cm (median), "
        "%.1f cm (90th percentile)" % (100 * near.mean(), 100 * np.median(shift), 100 * np.percentile(shift, 90))
    )


def main(argv):
    import argparse

    p = argparse.ArgumentParser(description="Real RGB-D pairs from slambook2's five sample frames.")
    p.add_argument("out", help="folder for the clouds and transforms")
    p.add_argument("--from", dest="src", help="a copy of slambook2's ch5/rgbd folder (default: download it)")
    p.add_argument("--check", action="store_true", help="estimate each pair's ground-truth error with ICP")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    lines = read_bytes(local("pose.txt", a.src, a.out)).decode().splitlines()
    poses = [pose_matrix(*map(float, line.split())) for line in lines if line.strip()]
    for i in range(1, 6):
        d = depth_metres(read_bytes(local("depth/%d.pgm" % i, a.src, a.out)))
        c = colour(local("color/%d.png" % i, a.src, a.out))
        v, u = np.nonzero((d > 0) & (d <= DEPTH_MAX))
        z = d[v, u]
        xyz = np.stack([(u - CX) * z / FX, (v - CY) * z / FY, z], axis=1)
        write_ply(os.path.join(a.out, "frame%d.ply" % i), xyz, c[v, u])
    for s, t in PAIRS:
        np.savetxt(os.path.join(a.out, "T_%d_%d.txt" % (s, t)), np.linalg.inv(poses[t - 1]) @ poses[s - 1])
    if a.check:
        check(a.out)


if __name__ == "__main__":
    main(sys.argv[1:])
