#!/usr/bin/env python3
"""A threshold sweep of `ced eval repeatability` (Debian: python3-matplotlib).

    python3 docs/plot_sweep.py OUT.png NAME A.csv [B.csv ...]

Each CSV comes from `ced eval repeatability CLOUD -d 'xyz:{0.1,0.2},rgb:0.1'
--noise S --csv A.csv`: one detector a setting. NAME is the modality whose
threshold the sweep varies (e.g. xyz); the x axis is its threshold. Three
panels: mean relative repeatability, mean keypoints of P and mean detect
time, one line per CSV (cloud), and a dashed line for the mean over the
CSVs. Also prints a Markdown table of the mean over the CSVs.
"""
import csv
import os
import re
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def threshold_of(detector, name):
    m = re.search(r"(?:^|,)" + re.escape(name) + r"(?:\([^)]*\))?:([0-9.eE+-]+)", detector)
    if not m:
        sys.exit(f"{detector}: no threshold of {name}")
    return float(m.group(1))


def load(path, name):
    acc = defaultdict(lambda: defaultdict(list))  # threshold -> column -> values
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            t = threshold_of(r["detector"], name)
            acc[t]["rep"].append(float(r["relative_repeatability"]))
            acc[t]["kp"].append(float(r["source_keypoints"]))
            acc[t]["ms"].append(float(r["detect_ms"]))
    return {t: {k: sum(v) / len(v) for k, v in cols.items()} for t, cols in acc.items()}


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    out, name, inputs = sys.argv[1], sys.argv[2], sys.argv[3:]
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    clouds = {os.path.splitext(os.path.basename(p))[0]: load(p, name) for p in inputs}
    ts = sorted(set().union(*[set(c) for c in clouds.values()]))
    mean = {t: {k: sum(c[t][k] for c in clouds.values()) / len(clouds) for k in ("rep", "kp", "ms")} for t in ts}
    for ax, key, label in zip(axes, ("rep", "kp", "ms"), ("relative repeatability", "keypoints", "detect ms")):
        for cloud, by_t in clouds.items():
            ax.plot(ts, [by_t[t][key] for t in ts], marker="o", label=cloud)
        if len(clouds) > 1:
            ax.plot(ts, [mean[t][key] for t in ts], "k--", marker="s", label="mean")
        ax.set_xlabel(f"{name} threshold")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    print(f"| {name} threshold | " + " | ".join(f"{t:g}" for t in ts) + " |")
    print("|---" * (len(ts) + 1) + "|")
    print("| keypoints | " + " | ".join(f"{mean[t]['kp']:.1f}" for t in ts) + " |")
    print("| repeatability (%) | " + " | ".join(f"{100 * mean[t]['rep']:.2f}" for t in ts) + " |")
    print("| detect ms | " + " | ".join(f"{mean[t]['ms']:.1f}" for t in ts) + " |")


if __name__ == "__main__":
    main()
