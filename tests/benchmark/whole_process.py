#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Whole-process timings of commands run alternately: what a user waits for.

Each round runs every command once, in the order given, so that drift of the
machine touches all of them alike. Prints, per command, the median, min and
max wall time in ms and the largest peak resident memory (from wait4), and
the ratios of the medians to the first command's.

  tests/benchmark/whole_process.py --runs 15 \\
      'build/bin/ced detect loft.ply --preset ced6d --threads 1 --indices /tmp/kp.txt -q' \\
      'old/bin/ced detect loft.ply --preset ced6d --threads 1 --indices /tmp/kp0.txt -q'

A command is split like a shell line (shlex) and run without a shell; its
output is discarded, and a failure stops the script.
"""
import argparse
import os
import shlex
import statistics
import subprocess
import sys
import time


def run_once(argv):
    start = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    elapsed = (time.perf_counter() - start) * 1000.0
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        sys.exit(f"whole_process: {' '.join(argv)}: exit {code}\n{err}")
    return elapsed, usage.ru_maxrss  # kB on Linux


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=15, help="rounds (default 15)")
    ap.add_argument("--warmup", type=int, default=2, help="rounds run first and not counted (default 2)")
    ap.add_argument("commands", nargs="+", help="command lines")
    a = ap.parse_args()
    if a.runs < 1 or a.warmup < 0:
        ap.error("--runs must be >= 1 and --warmup >= 0")
    argvs = [shlex.split(c) for c in a.commands]
    times = [[] for _ in argvs]
    rss = [0 for _ in argvs]
    for r in range(a.warmup + a.runs):
        for k, argv in enumerate(argvs):
            ms, kb = run_once(argv)
            if r >= a.warmup:
                times[k].append(ms)
                rss[k] = max(rss[k], kb)
    base = statistics.median(times[0])
    print(f"{'median ms':>10} {'min':>8} {'max':>8} {'peak MB':>8} {'x first':>8}  command")
    for k, c in enumerate(a.commands):
        med = statistics.median(times[k])
        print(f"{med:10.1f} {min(times[k]):8.1f} {max(times[k]):8.1f} {rss[k] / 1024:8.1f} {med / base:8.2f}  {c}")


if __name__ == "__main__":
    main()
