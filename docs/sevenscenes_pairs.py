#!/usr/bin/env python3
"""Real RGB-D pairs from 7-Scenes' redkitchen frames, for `ced eval repeatability --rgbd`.

    /usr/bin/python3 docs/sevenscenes_pairs.py OUT [--from DIR] [--check]

Reads frames of Microsoft's 7-Scenes (redkitchen, seq-01) as
andyzeng/tsdf-fusion-python (BSD-2) stores them at a pinned commit, in
`data/`: `frame-NNNNNN.color.jpg`, `frame-NNNNNN.depth.png` (16-bit,
millimetres, 0 = no depth), `frame-NNNNNN.pose.txt` (a 4x4 camera-to-world
pose) and `camera-intrinsics.txt` (fx = fy = 585, cx 320, cy 240). The data
themselves are under 7-Scenes' own terms (non-commercial research). Downloads
them, or reads DIR, a copy of that `data/` folder. Writes two Open3D RGB-D
folders, each of five frames 25 apart:

- OUT/a: frames 0, 25, 50, 75, 100; OUT/b: frames 500, 525, 550, 575, 600;
- in each: color/0000k.jpg, depth/0000k.png, odometry.log (the poses, in
  Open3D's trajectory format) and camera_primesense.json (the intrinsics),
  so that `--rgbd OUT/a` pairs frame 0 with each later one.

The colour camera of 7-Scenes is not registered to the depth camera; the
frames are used as they are, as tsdf-fusion-python uses them.

--check estimates each pair's ground-truth error as slambook_pairs.py does
(1 cm voxels, depths beyond 3 m dropped): point-to-point ICP from the
ground truth (5 cm reach), then how far that correction moves the source's
points that lie within 5 cm of the target. Needs numpy and Open3D (Debian: python3-numpy, python3-open3d).
"""
import os
import sys
from slambook_pairs import fetched, gt_error  # beside this script in docs/

COMMIT = "3f22a940d90f684145b1f29b1feaa92e09eb1db6"
URL = "https://raw.githubusercontent.com/andyzeng/tsdf-fusion-python/" + COMMIT + "/data/"
SETS = {"a": [0, 25, 50, 75, 100], "b": [500, 525, 550, 575, 600]}
FX, FY, CX, CY = 585.0, 585.0, 320.0, 240.0


def local(name, src, out):
    """A local path of data/NAME: in src when given, else downloaded once to OUT/download."""
    return fetched(URL, name, src, out)


def read_bytes(path):
    with open(path, "rb") as f:
        return f.read()


def write_bytes(path, data):
    with open(path, "wb") as f:
        f.write(data)


def pose_rows(text, name):
    rows = [line.split() for line in text.strip().splitlines() if line.strip()]
    if len(rows) != 4 or any(len(r) != 4 for r in rows):
        raise ValueError("%s: expected a 4x4 matrix" % name)
    return [[float(v) for v in r] for r in rows]


def write_set(out, src, frames, cache):
    os.makedirs(os.path.join(out, "color"), exist_ok=True)
    os.makedirs(os.path.join(out, "depth"), exist_ok=True)
    log = []
    for k, f in enumerate(frames):
        stem = "frame-%06d" % f
        write_bytes(os.path.join(out, "color", "%05d.jpg" % k), read_bytes(local(stem + ".color.jpg", src, cache)))
        write_bytes(os.path.join(out, "depth", "%05d.png" % k), read_bytes(local(stem + ".depth.png", src, cache)))
        text = read_bytes(local(stem + ".pose.txt", src, cache)).decode()
        pose_rows(text, stem + ".pose.txt")  # checked; written as it is
        log.append("%d\t%d\t%d\n" % (k, k, k + 1))
        log.extend(line.strip() + "\n" for line in text.strip().splitlines() if line.strip())
    with open(os.path.join(out, "odometry.log"), "w") as f:
        f.writelines(log)
    with open(os.path.join(out, "camera_primesense.json"), "w") as f:
        f.write(
            '{\n  "width": 640,\n  "height": 480,\n  "intrinsic_matrix": [%g, 0, 0, 0, %g, 0, %g, %g, 1]\n}\n'
            % (FX, FY, CX, CY)
        )


def check(out):
    import numpy as np
    import open3d as o3d

    cam = o3d.camera.PinholeCameraIntrinsic(640, 480, FX, FY, CX, CY)
    for name in SETS:
        d = os.path.join(out, name)
        lines = [line for line in open(os.path.join(d, "odometry.log")).read().splitlines() if line.strip()]
        poses = [
            np.array([[float(v) for v in lines[5 * k + 1 + r].split()] for r in range(4)])
            for k in range(len(lines) // 5)
        ]

        def load(k):
            depth = o3d.io.read_image(os.path.join(d, "depth", "%05d.png" % k))
            pc = o3d.geometry.PointCloud.create_from_depth_image(depth, cam, depth_scale=1000.0, depth_trunc=3.0)
            return pc.voxel_down_sample(0.01)

        s = load(0)
        for j in range(1, len(poses)):
            t = load(j)
            gt = np.linalg.inv(poses[j]) @ poses[0]  # frame 0's points into frame j's
            print("%s 0-%d: %s" % (name, j, gt_error(s, t, gt)))


def main(argv):
    import argparse

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("out")
    p.add_argument("--from", dest="src", help="a copy of tsdf-fusion-python's data/ folder (else downloaded)")
    p.add_argument("--check", action="store_true", help="estimate each pair's ground-truth error with ICP")
    a = p.parse_args(argv)
    for name, frames in SETS.items():
        write_set(os.path.join(a.out, name), a.src, frames, a.out)
        print("wrote %s: frames %s" % (os.path.join(a.out, name), ", ".join(str(f) for f in frames)))
    if a.check:
        check(a.out)


if __name__ == "__main__":
    main(sys.argv[1:])
