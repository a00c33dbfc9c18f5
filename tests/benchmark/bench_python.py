#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""ced.detect from numpy against the CLI on the same cloud, and modalities written in Python.

    PYTHONPATH=build/python /usr/bin/python3 tests/benchmark/bench_python.py \\
        --cli build/bin/ced --cloud ../shared/data/redwood_scan/loft_mesh_240.ply

Per thread count:
  cold  alternating fresh processes, each doing one detection: the CLI
        (`ced detect CLOUD --preset ced6d --radius 0.05 --threads T`, its own "detect" time from
        --summary: the ced::detect call, no file reading) and Python (numpy arrays loaded from .npy
        first, then the wall time of one ced.detect(points, channels) call: converting the arrays,
        releasing the GIL, the detection, the Result);
  warm  in this process, repeated: ced.detect from numpy arrays, from a ced.Cloud (no conversion),
        and the detection's own stage times, so the call's overhead is the difference.
All runs must give the CLI's keypoints. Then a modality written in Python (geometry again, as numpy
code by block and as a per-point function) against the built-in xyz, one thread.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import ced


def cli_run(cli, cloud, threads, summary):
    indices = summary + ".txt"
    subprocess.run([cli, "detect", cloud, "--preset", "ced6d", "--radius", "0.05", "--threads", str(threads), "-q",
                    "--summary", summary, "--indices", indices], check=True, capture_output=True)
    with open(summary) as f:
        return json.load(f)["times_ms"]["detect"], np.loadtxt(indices, dtype=np.uint32)


FIRST_CALL = """
import sys, time, numpy as np, ced
folder, threads = sys.argv[1], int(sys.argv[2])
points = np.load(folder + "/points.npy")
channels = {c: np.load(folder + "/" + c + ".npy") for c in ("red", "green", "blue")}
t = time.perf_counter()
r = ced.detect(points, channels, modalities="ced6d", threads=threads)
ms = (time.perf_counter() - t) * 1e3
np.save(folder + "/kp.npy", r.keypoints)
print(ms)
"""


def python_first_call(folder, threads):
    out = subprocess.run([sys.executable, "-c", FIRST_CALL, folder, str(threads)], check=True, capture_output=True,
                         text=True, env=os.environ).stdout
    return float(out), np.load(os.path.join(folder, "kp.npy"))


def timed(fn):
    t = time.perf_counter()
    r = fn()
    return (time.perf_counter() - t) * 1e3, r


def geometry_block(p64):
    def fn(points, offsets, neighbors):
        sums = np.add.reduceat(p64[neighbors], offsets[:-1], axis=0)  # every neighbourhood holds its point
        return np.linalg.norm(sums / np.diff(offsets)[:, None] - p64[points], axis=1)
    return fn


def geometry_point(p64):
    def fn(point, neighbors):
        return float(np.linalg.norm(p64[neighbors].mean(axis=0) - p64[point]))
    return fn


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", required=True)
    ap.add_argument("--cloud", required=True)
    ap.add_argument("--runs", type=int, default=15)
    ap.add_argument("--threads", default="1,2")
    args = ap.parse_args()

    cloud = ced.read(args.cloud)
    points = np.array(cloud.points)  # plain numpy arrays, as a user would have them
    channels = {name: np.array(v) for name, v in cloud.fields.items() if name in ("red", "green", "blue")}
    print(f"{args.cloud}: {len(cloud)} points; {args.runs} alternating runs per thread count; medians")
    folder = tempfile.mkdtemp()
    summary = os.path.join(folder, "summary.json")
    np.save(os.path.join(folder, "points.npy"), points)
    for c, v in channels.items():
        np.save(os.path.join(folder, c + ".npy"), v)
    med = statistics.median
    for threads in map(int, args.threads.split(",")):
        cli_ms, first_ms, np_ms, cloud_ms, inner_ms = [], [], [], [], []
        for _ in range(args.runs):
            ms, cli_kp = cli_run(args.cli, args.cloud, threads, summary)
            cli_ms.append(ms)
            ms, kp = python_first_call(folder, threads)
            first_ms.append(ms)
            assert np.array_equal(kp, cli_kp), "numpy and CLI keypoints differ"
        for _ in range(args.runs):
            ms, r = timed(lambda: ced.detect(points, channels, modalities="ced6d", threads=threads))
            np_ms.append(ms)
            inner_ms.append(r.times["total_ms"])
            assert np.array_equal(r.keypoints, cli_kp), "numpy and CLI keypoints differ"
            ms, r2 = timed(lambda: ced.detect(cloud, modalities="ced6d", threads=threads))
            cloud_ms.append(ms)
            assert np.array_equal(r2.keypoints, cli_kp)
        print(f"threads {threads}, cold: CLI detect {med(cli_ms):.1f} ms, Python first call {med(first_ms):.1f} ms "
              f"({med(first_ms) - med(cli_ms):+.1f} ms, {med(first_ms) / med(cli_ms):.3f}x)")
        print(f"threads {threads}, warm: numpy call {med(np_ms):.1f} ms, Cloud call {med(cloud_ms):.1f} ms, "
              f"stages inside {med(inner_ms):.1f} ms: numpy call overhead {med(np_ms) - med(inner_ms):+.1f} ms; "
              f"{len(cli_kp)} keypoints, identical")

    p64 = points.astype(np.float64)
    built_in_ms, r = timed(lambda: ced.detect(cloud, modalities=["xyz:0.2"], threads=1))
    block_ms, rb = timed(lambda: ced.detect(cloud, modalities=[ced.python_modality("g", geometry_block(p64), 0.01)],
                                            threads=1))
    point_ms, rp = timed(lambda: ced.detect(cloud, modalities=[ced.python_modality("g", geometry_point(p64), 0.01,
                                                                                   per_point=True)], threads=1))
    err = max(np.abs(rb.saliency["g"] - r.saliency["xyz"]).max(), np.abs(rp.saliency["g"] - r.saliency["xyz"]).max())
    print(f"geometry saliency, 1 thread: built-in xyz {built_in_ms:.1f} ms | Python by block "
          f"{block_ms:.0f} ms ({block_ms / built_in_ms:.0f}x) | Python per point {point_ms:.0f} ms "
          f"({point_ms / built_in_ms:.0f}x); largest saliency difference {err:.1e} m")


if __name__ == "__main__":
    main()
