#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes a hyperspectral test cloud as binary PLY: 100,000 points on a gently waved 10 x 10 m sheet with 192 float
bands b000 ... b191 (a smooth spectrum per patch plus noise), the surface of bench_detect's bands/B benchmark.

    /usr/bin/python3 tests/benchmark/hyperspectral_ply.py OUT.ply [--points N] [--bands B]
"""
import argparse

import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--points", type=int, default=100000)
    ap.add_argument("--bands", type=int, default=192)
    a = ap.parse_args()
    rng = np.random.default_rng(60)
    n, nb = a.points, a.bands
    x, y = rng.random(n) * 10, rng.random(n) * 10
    z = 0.2 * np.sin(x) * np.cos(0.7 * y)
    patch = (x / 0.7).astype(int) * 31 + (y / 0.9).astype(int)
    b = np.arange(nb)
    bands = (0.5 + 0.3 * np.sin(0.05 * b[None, :] + 0.37 * (patch % 17)[:, None])
             + 0.05 * (rng.random((n, nb)) - 0.5)).astype(np.float32)
    dt = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")] + [("b%03d" % i, "<f4") for i in range(nb)]
    rec = np.empty(n, dtype=dt)
    rec["x"], rec["y"], rec["z"] = x, y, z
    for i in range(nb):
        rec["b%03d" % i] = bands[:, i]
    header = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    header += "".join("property float %s\n" % name for name, _ in dt) + "end_header\n"
    with open(a.out, "wb") as f:
        f.write(header.encode())
        f.write(rec.tobytes())


if __name__ == "__main__":
    main()
