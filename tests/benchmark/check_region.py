#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Checks a catalogue run against a whole-cloud run over a region of it: the same keypoints inside the region.

    /usr/bin/python3 tests/benchmark/check_region.py --all-files all.list --all kp_all.txt \\
        --region-files region.list --region kp_region.txt --margin 1.0

--all is `ced detect` over the whole catalogue (--indices: FILE_ID INDEX a line, ids into --all-files);
--region is a whole-cloud run over some of its files (ids into --region-files). A keypoint depends only
on the points within the radius plus the NMS radius of it, so inside the region's box shrunk by
--margin (at least that sum) the two runs must give the same keypoints. The files are LAS (positions
read from their records). Prints the counts; exit 1 when they differ.
"""
import argparse
import struct
import sys

import numpy as np


def las_xy(path, indices):
    with open(path, "rb") as f:
        head = f.read(227)
    offset = struct.unpack_from("<I", head, 96)[0]
    length = struct.unpack_from("<H", head, 105)[0]
    count = struct.unpack_from("<I", head, 107)[0]
    sx, sy = struct.unpack_from("<dd", head, 131)
    ox, oy = struct.unpack_from("<dd", head, 155)
    rec = np.memmap(path, dtype=np.uint8, mode="r", offset=offset, shape=(count, length))
    raw = rec[np.asarray(indices, dtype=np.int64), :8].copy().view("<i4")
    return raw[:, 0] * sx + ox, raw[:, 1] * sy + oy


def las_box(path):
    with open(path, "rb") as f:
        head = f.read(227)
    max_x, min_x, max_y, min_y = struct.unpack_from("<dddd", head, 179)
    return min_x, max_x, min_y, max_y


def keypoints(list_path, kp_path):
    files = [line.strip() for line in open(list_path) if line.strip() and not line.startswith("#")]
    by_file = {}
    for line in open(kp_path):
        f, i = line.split()
        by_file.setdefault(int(f), []).append(int(i))
    return files, {files[f]: sorted(v) for f, v in by_file.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--all-files", required=True)
    ap.add_argument("--all", required=True)
    ap.add_argument("--region-files", required=True)
    ap.add_argument("--region", required=True)
    ap.add_argument("--margin", type=float, required=True)
    a = ap.parse_args()
    _, all_kp = keypoints(a.all_files, a.all)
    region_files, region_kp = keypoints(a.region_files, a.region)
    boxes = [las_box(f) for f in region_files]
    lo_x = min(b[0] for b in boxes) + a.margin
    hi_x = max(b[1] for b in boxes) - a.margin
    lo_y = min(b[2] for b in boxes) + a.margin
    hi_y = max(b[3] for b in boxes) - a.margin

    def inside(runs):
        out = set()
        for f, idx in runs.items():
            if f not in region_files or not idx:
                continue
            x, y = las_xy(f, idx)
            keep = (x > lo_x) & (x < hi_x) & (y > lo_y) & (y < hi_y)
            out.update((f, i) for i, k in zip(idx, keep) if k)
        return out

    a_in, r_in = inside(all_kp), inside(region_kp)
    print(f"inside the region less {a.margin} m: {len(a_in)} keypoints of the catalogue run, {len(r_in)} of the "
          f"region's whole run, {len(a_in & r_in)} in both")
    return 0 if a_in == r_in and a_in else 1


if __name__ == "__main__":
    sys.exit(main())
