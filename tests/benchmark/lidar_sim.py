#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""A seeded spinning-LiDAR simulator, and what fixed, knn and adaptive neighbourhoods do on its scans.

The scene is a street: ground, two rows of building fronts with recesses, parked cars (boxes), poles and
bollards (vertical cylinders). A 32-beam sensor (elevations -25..+15 degrees, 0.2 degree azimuth steps,
1.8 m high, 60 m range, Gaussian range noise) scans it from two positions about 5 m apart. The ground-truth
pose maps scan B's frame into scan A's. Point spacing grows with range, as on a real mobile or terrestrial
scan: about 3 cm x 10 cm at 5 m, and 20 cm x 80 cm at 35 m.

    /usr/bin/python3 tests/benchmark/lidar_sim.py --write /tmp/sim      # scan_a.ply, scan_b.ply, pose_b_to_a.txt
    /usr/bin/python3 tests/benchmark/lidar_sim.py --evaluate            # the table of docs/journal/real-pairs.md#lidar-neighbourhoods-by-range

The evaluation runs ced.detect (the Python module of this build) with several neighbourhoods. For each it
reports keypoints per 1,000 points and starved points by range bin, where a starved point has fewer than
min_neighbors neighbours, so its saliency is 0. It also reports repeatability between the two scans: a
keypoint of A that scan B also sees (B has a point within eps of it) is repeated when B has a keypoint
within eps. The lift is that rate over the rate of random keypoints of the same count, which is the
real-pair protocol of docs/EVALUATION.md.
"""

import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def scene(seed):
    """Axis-aligned boxes (lo, hi) and vertical cylinders (x, y, radius, height)."""
    rng = np.random.default_rng(seed)
    boxes = []
    for side in (-1, 1):  # building fronts along y = ±9 m, with recesses
        x = -60.0
        while x < 60:
            w = rng.uniform(6, 14)
            depth = rng.choice([0.0, 0.0, 1.5])
            y0 = side * (9 + depth)
            boxes.append(((x, min(y0, side * 25), 0), (x + w, max(y0, side * 25), rng.uniform(6, 15))))
            x += w
    for k in range(10):  # parked cars along both kerbs
        side = 1 if k % 2 else -1
        x = rng.uniform(-35, 35)
        y = side * rng.uniform(5.5, 6.5)
        boxes.append(((x - 2.2, y - 0.9, 0.15), (x + 2.2, y + 0.9, 1.5)))
    cylinders = []
    for k in range(14):  # poles and bollards
        x = -39 + 6 * k + rng.uniform(-1, 1)
        y = (1 if k % 2 else -1) * rng.uniform(7.2, 8.0)
        cylinders.append((x, y, 0.12 if k % 3 else 0.3, 6.0 if k % 3 else 1.0))
    return boxes, cylinders


def scan(boxes, cylinders, origin, yaw, seed, noise=0.01, beams=32, step_deg=0.2, max_range=60.0):
    """Points (N, 3) in the sensor's frame (x forward at yaw 0, z up), rays that hit something."""
    rng = np.random.default_rng(seed)
    elev = np.radians(np.linspace(-25.0, 15.0, beams))
    azim = np.radians(np.arange(0.0, 360.0, step_deg))
    el, az = np.meshgrid(elev, azim, indexing="ij")
    d_local = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], -1).reshape(-1, 3)
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    d = d_local @ rot.T  # world directions
    o = np.asarray(origin, dtype=np.float64)
    t = np.full(len(d), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        tg = -o[2] / d[:, 2]  # ground z = 0
        t = np.where((tg > 0), np.minimum(t, tg), t)
        for lo, hi in boxes:
            lo, hi = np.asarray(lo), np.asarray(hi)
            t0 = (lo - o) / d
            t1 = (hi - o) / d
            tn = np.nanmax(np.minimum(t0, t1), axis=1)
            tf = np.nanmin(np.maximum(t0, t1), axis=1)
            hit = (tn <= tf) & (tf > 0)
            t = np.where(hit, np.minimum(t, np.where(tn > 0, tn, tf)), t)
        for x, y, r, h in cylinders:
            px, py = o[0] - x, o[1] - y
            a = d[:, 0] ** 2 + d[:, 1] ** 2
            b = 2 * (px * d[:, 0] + py * d[:, 1])
            cc = px * px + py * py - r * r
            disc = b * b - 4 * a * cc
            tc = (-b - np.sqrt(np.maximum(disc, 0))) / (2 * a)
            z = o[2] + tc * d[:, 2]
            hit = (disc >= 0) & (tc > 0) & (z >= 0) & (z <= h)
            t = np.where(hit, np.minimum(t, tc), t)
    keep = np.isfinite(t) & (t < max_range)
    rng_noisy = t[keep] + rng.normal(0.0, noise, keep.sum())
    return d_local[keep] * rng_noisy[:, None]  # in the sensor's frame


def pose(origin, yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    m = np.eye(4)
    m[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    m[:3, 3] = origin
    return m


SENSOR_A = ((0.0, 0.0, 1.8), 0.0)
SENSOR_B = ((4.0, 1.5, 1.8), math.radians(20.0))


def make_pair(seed=1):
    boxes, cylinders = scene(seed)
    a = scan(boxes, cylinders, *SENSOR_A, seed=seed + 100)
    b = scan(boxes, cylinders, *SENSOR_B, seed=seed + 200)
    b_to_a = np.linalg.inv(pose(*SENSOR_A)) @ pose(*SENSOR_B)
    return a, b, b_to_a


def write_ply(path, xyz):
    with open(path, "wb") as f:
        f.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {len(xyz)}\n"
                "property float x\nproperty float y\nproperty float z\nend_header\n".encode())
        f.write(np.ascontiguousarray(xyz, dtype="<f4").tobytes())


def nearest_distance(points, queries):
    """Distance from each query to its nearest point (Open3D's kd-tree)."""
    import open3d as o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, dtype=np.float64)))
    tree = o3d.geometry.KDTreeFlann(pcd)
    out = np.empty(len(queries))
    for i, q in enumerate(np.asarray(queries, dtype=np.float64)):
        _, _, d2 = tree.search_knn_vector_3d(q, 1)
        out[i] = math.sqrt(d2[0])
    return out


def evaluate(args):
    sys.path.insert(0, args.python_path)
    import ced

    a, b, b_to_a = make_pair(args.seed)
    b_in_a = b @ b_to_a[:3, :3].T + b_to_a[:3, 3]
    range_a = np.linalg.norm(a, axis=1)
    bins = [0, 5, 10, 20, 40, 60]
    print(f"scan A {len(a)} points, scan B {len(b)} points; ranges in bins {bins} m:",
          np.histogram(range_a, bins)[0].tolist())
    seen_by_b = nearest_distance(b_in_a, a) < args.eps  # A's points that B also sees
    rng = np.random.default_rng(7)
    rows = []
    for label, spec in args.configs:
        res_a = ced.detect(a, modalities="ced3d", radius=args.radius, neighborhood=spec, threads=args.threads)
        res_b = ced.detect(b, modalities="ced3d", radius=args.radius, neighborhood=spec, threads=args.threads)
        ka, kb = np.asarray(res_a.keypoints), np.asarray(res_b.keypoints)
        starved = np.asarray(res_a.neighbor_count) < 5
        per_bin = []
        for lo, hi in zip(bins[:-1], bins[1:]):
            m = (range_a >= lo) & (range_a < hi)
            k = np.count_nonzero(m[ka])
            per_bin.append((1000.0 * k / max(1, m.sum()), 100.0 * np.count_nonzero(starved & m) / max(1, m.sum())))
        in_overlap = ka[seen_by_b[ka]]
        kb_in_a = b_in_a[kb]
        hit = nearest_distance(kb_in_a, a[in_overlap]) < args.eps
        rep = np.count_nonzero(hit) / max(1, len(in_overlap))
        far = range_a[in_overlap] >= 20  # keypoints beyond 20 m: repeated / in the overlap
        far_cell = f"{np.count_nonzero(hit & far)} / {np.count_nonzero(far)}"
        # Random keypoints of the same counts, in the same overlap.
        rates = []
        for _ in range(5):
            ra = rng.choice(len(a), len(ka), replace=False)
            rb = rng.choice(len(b), len(kb), replace=False)
            ra = ra[seen_by_b[ra]]
            rates.append(np.count_nonzero(nearest_distance(b_in_a[rb], a[ra]) < args.eps) / max(1, len(ra)))
        base = float(np.mean(rates))
        rows.append((label, len(ka), len(kb), per_bin, rep, base, far_cell))
    print(f"\nced3d, radius {args.radius} m, eps {args.eps} m, scans {args.seed}: per range bin "
          f"{bins} m, keypoints per 1,000 points / % starved")
    print("| neighbourhood | keypoints A / B | " + " | ".join(f"{lo}-{hi} m" for lo, hi in zip(bins[:-1], bins[1:])) +
          " | repeatability | random | lift | repeated beyond 20 m |")
    print("|---" * (len(bins) + 5) + "|")
    for label, na, nb, per_bin, rep, base, far_cell in rows:
        cells = " | ".join(f"{k:.1f} / {s:.0f} %" for k, s in per_bin)
        print(f"| `{label}` | {na} / {nb} | {cells} | {rep:.3f} | {base:.3f} | {rep / base if base else 0:.2f} "
              f"| {far_cell} |")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--write", metavar="DIR", help="write scan_a.ply, scan_b.ply and pose_b_to_a.txt")
    p.add_argument("--evaluate", action="store_true")
    p.add_argument("--radius", type=float, default=0.5)
    p.add_argument("--eps", type=float, default=0.3)
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--python-path", default=os.path.join(HERE, "..", "..", "build", "python"))
    p.add_argument("--neighborhood", action="append", help="a --neighborhood spec to evaluate (repeatable; "
                   "default: the table's)")
    args = p.parse_args()
    specs = args.neighborhood or ["radius", "knn:16", "adaptive:16,min=0.5,max=3", "knn:16,nms=own",
                                  "adaptive:16,min=0.5,max=3,nms=own", "adaptive:32,min=0.5,max=3,nms=own",
                                  "adaptive:8,scale=2,min=0.5,max=3,nms=own"]
    args.configs = [(s, s) for s in specs]
    if args.write:
        os.makedirs(args.write, exist_ok=True)
        a, b, b_to_a = make_pair(args.seed)
        write_ply(os.path.join(args.write, "scan_a.ply"), a)
        write_ply(os.path.join(args.write, "scan_b.ply"), b)
        np.savetxt(os.path.join(args.write, "pose_b_to_a.txt"), b_to_a)
        print(f"{args.write}: scan_a.ply ({len(a)} points), scan_b.ply ({len(b)}), pose_b_to_a.txt")
    if args.evaluate:
        evaluate(args)


if __name__ == "__main__":
    main()
