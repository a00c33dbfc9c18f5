#!/usr/bin/env python3
"""Charts for `ced eval repeatability` CSV files (Debian: python3-matplotlib).

    python3 docs/plot_eval.py OUT.png A.csv [B.csv ...]

One panel per CSV: mean relative repeatability (± one standard deviation)
against noise, one line per detector; a last panel: mean detect time.
"""
import csv
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def load(path):
    rows = defaultdict(lambda: defaultdict(list))  # detector -> noise -> [rep]
    times = defaultdict(list)
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            rows[r["detector"]][float(r["noise_resolution"])].append(float(r["relative_repeatability"]))
            times[r["detector"]].append(float(r["detect_ms"]))
    return rows, times


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    out, inputs = sys.argv[1], sys.argv[2:]
    fig, axes = plt.subplots(1, len(inputs) + 1, figsize=(4.2 * (len(inputs) + 1), 3.8))
    all_times = defaultdict(list)
    for ax, path in zip(axes, inputs):
        rows, times = load(path)
        for det, by_noise in rows.items():
            xs = sorted(by_noise)
            means = [sum(by_noise[x]) / len(by_noise[x]) for x in xs]
            sds = [(sum((v - m) ** 2 for v in by_noise[x]) / len(by_noise[x])) ** 0.5 for x, m in zip(xs, means)]
            ax.errorbar(xs, means, yerr=sds, marker="o", capsize=3, label=det)
            all_times[det].extend(times[det])
        ax.set_title(os.path.splitext(os.path.basename(path))[0])
        ax.set_xlabel("noise σ (× resolution)")
        ax.set_ylabel("relative repeatability")
        ax.set_ylim(0, 1.05)
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small")
    dets = list(all_times)
    axes[-1].bar(dets, [sum(all_times[d]) / len(all_times[d]) for d in dets], color="tab:gray")
    axes[-1].set_title("mean detect time per cloud")
    axes[-1].set_ylabel("ms")
    axes[-1].tick_params(axis="x", labelrotation=45)
    fig.tight_layout()
    fig.savefig(out, dpi=90)


if __name__ == "__main__":
    main()
