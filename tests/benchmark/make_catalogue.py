#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""A folder of LAS tiles laid side by side, as a LiDAR delivery comes: N x N cities of make_las.py.

    /usr/bin/python3 tests/benchmark/make_catalogue.py --tiles 10 --points 10000000 -o /big/catalogue

Tile (i, j) is make_las.py's city of --points points with seed --seed + i * N + j (each a square of
side spacing * sqrt(points)), moved to its place in the mosaic by its header alone: the X and Y
offsets and bounds grow by i and j times the side, the records are make_las.py's. Neighbouring
tiles are different cities, so their borders do not match, but every tile's halo reaches into its
neighbours as in a real delivery. Files are named tile_IIII_JJJJ.las; one already complete (its
size right) is kept, so an interrupted run goes on where it stopped. --jobs runs make_las.py in
parallel.
"""
import argparse
import concurrent.futures
import math
import os
import struct
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
HEADER_SIZE, RECORD = 227, 34  # make_las.py: LAS 1.2, point format 3, no padding besides its VLR


def make_tile(out_dir, i, j, n, points, seed, spacing):
    path = os.path.join(out_dir, f"tile_{i:04d}_{j:04d}.las")
    side = spacing * math.sqrt(max(points, 1))
    if os.path.exists(path):
        with open(path, "rb") as f:
            head = f.read(HEADER_SIZE)
        offset_to_points = struct.unpack_from("<I", head, 96)[0]
        if os.path.getsize(path) == offset_to_points + RECORD * points:
            return path, False
    tmp = path + ".part.las"
    subprocess.run([sys.executable, os.path.join(HERE, "make_las.py"), "--points", str(points), "--seed",
                    str(seed + i * n + j), "--spacing", str(spacing), "-o", tmp, "-q"], check=True)
    with open(tmp, "r+b") as f:
        head = bytearray(f.read(HEADER_SIZE))
        # Offsets at 155 (x), 163 (y); bounds max x 179, min x 187, max y 195, min y 203.
        dx, dy = i * side, j * side
        for at, d in ((155, dx), (163, dy), (179, dx), (187, dx), (195, dy), (203, dy)):
            struct.pack_into("<d", head, at, struct.unpack_from("<d", head, at)[0] + d)
        f.seek(0)
        f.write(head)
    os.replace(tmp, path)
    return path, True


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tiles", type=int, required=True, help="N: an N x N mosaic")
    ap.add_argument("--points", type=int, required=True, help="points a tile")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--spacing", type=float, default=0.1)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("-o", "--output", required=True, help="the folder")
    a = ap.parse_args()
    if a.tiles < 1 or a.points < 1:
        ap.error("--tiles and --points must be >= 1")
    os.makedirs(a.output, exist_ok=True)
    jobs = [(i, j) for i in range(a.tiles) for j in range(a.tiles)]
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as ex:
        done = 0
        for path, made in ex.map(lambda ij: make_tile(a.output, ij[0], ij[1], a.tiles, a.points, a.seed, a.spacing),
                                 jobs):
            done += 1
            print(f"{done}/{len(jobs)} {path}{'' if made else ' (kept)'}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
