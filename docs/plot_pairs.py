#!/usr/bin/env python3
"""A chart of real-pair lifts from `ced eval repeatability --csv` files, as SVG (no libraries).

    python3 docs/plot_pairs.py OUT.svg --panel [@N] TITLE GROUP=A.csv[,B.csv...] ... [--panel ...]

Each panel is a row of groups (data sets); each group shows, per detector,
the mean `lift` over the CSV rows of its files (pairs), one bar a detector,
with the number of pairs under the group's name. A panel takes the rows at
natural counts (detectors without `@`), or with `@N` those at N keypoints
each (`--counts N`); rows that are n/a are left out. The dashed line is
chance (lift 1).
"""
import csv
import os
import sys
from collections import OrderedDict

COLOURS = OrderedDict(
    [
        ("ced6d", "#1f77b4"),
        ("robust6d", "#d62728"),
        ("ced3d", "#aec7e8"),
        ("robust3d", "#ff9896"),
        ("xyz:0.2,scale=2", "#9467bd"),
        ("harris3d", "#2ca02c"),
        ("harris6d", "#98df8a"),
        ("iss3d", "#8c564b"),
        ("sift", "#e377c2"),
        ("random", "#7f7f7f"),
    ]
)
WIDTH, PANEL_HEIGHT, LEFT, TOP, BOTTOM = 980, 300, 60, 40, 60


def mean_lifts(paths, count):
    """Per detector (in first-seen order), the mean lift over the rows of paths at `count` keypoints
    each ("" for natural counts); and how many pairs."""
    lifts, pairs = OrderedDict(), set()
    for path in paths:
        with open(path, newline="") as f:
            for row in csv.DictReader(f):
                name, _, n = row["detector"].partition("@")
                if n != count:
                    continue
                pairs.add((path, row["pair"]))
                try:
                    lift = float(row["lift"])
                except ValueError:
                    continue  # n/a
                lifts.setdefault(name, []).append(lift)
    return OrderedDict((k, sum(v) / len(v)) for k, v in lifts.items()), len(pairs)


def parse(argv):
    if len(argv) < 3 or argv[1] != "--panel":
        sys.exit(__doc__)
    out, panels = argv[0], []
    i = 1
    while i < len(argv):
        if argv[i] == "--panel":
            count = argv[i + 1][1:] if argv[i + 1].startswith("@") else ""
            i += 2 if count else 1
            panels.append((argv[i], count, []))
            i += 1
            continue
        label, _, files = argv[i].partition("=")
        if not files:
            sys.exit("expected GROUP=A.csv[,B.csv...], got " + argv[i])
        panels[-1][2].append((label, files.split(",")))
        i += 1
    if any(os.path.realpath(out) == os.path.realpath(f) for _, _, groups in panels for _, fs in groups for f in fs):
        sys.exit("the output " + out + " is one of the input CSV files")
    return out, panels


def text(x, y, s, size=12, anchor="middle", extra=""):
    s = s.replace("&", "&amp;").replace("<", "&lt;")
    return '<text x="%.1f" y="%.1f" font-size="%d" text-anchor="%s" %s>%s</text>' % (x, y, size, anchor, extra, s)


def panel(svg, y0, title, count, groups):
    data = [(label, *mean_lifts(files, count)) for label, files in groups]
    top = max([1.0] + [v for _, lifts, _ in data for v in lifts.values()])
    top = float(int(top) + 1)
    plot_h = PANEL_HEIGHT - TOP - BOTTOM
    ybase = y0 + TOP + plot_h

    def y(v):
        return ybase - v / top * plot_h

    svg.append(text(LEFT, y0 + 20, title, 14, "start", 'font-weight="bold"'))
    for t in range(int(top) + 1):
        svg.append('<line x1="%d" x2="%d" y1="%.1f" y2="%.1f" stroke="#ddd"/>' % (LEFT, WIDTH - 10, y(t), y(t)))
        svg.append(text(LEFT - 6, y(t) + 4, str(t), 11, "end"))
    svg.append(
        '<line x1="%d" x2="%d" y1="%.1f" y2="%.1f" stroke="#555" stroke-dasharray="4 3"/>' % (LEFT, WIDTH - 10, y(1), y(1))
    )
    svg.append(text(16, y0 + TOP + plot_h / 2, "mean lift", 12, "middle", 'transform="rotate(-90 16 %.1f)"' % (y0 + TOP + plot_h / 2)))
    group_w = (WIDTH - 10 - LEFT) / max(1, len(data))
    for g, (label, lifts, pairs) in enumerate(data):
        x0 = LEFT + g * group_w
        names = [n for n in COLOURS if n in lifts] + [n for n in lifts if n not in COLOURS]
        bar_w = min(22.0, (group_w - 20) / max(1, len(names)))
        start = x0 + (group_w - bar_w * len(names)) / 2
        for b, name in enumerate(names):
            v = lifts[name]
            x = start + b * bar_w
            svg.append(
                '<rect x="%.1f" y="%.1f" width="%.1f" height="%.1f" fill="%s"><title>%s: %.2f</title></rect>'
                % (x + 1, y(v), bar_w - 2, ybase - y(v), COLOURS.get(name, "#bcbd22"), name, v)
            )
            svg.append(text(x + bar_w / 2, y(v) - 3, "%.1f" % v, 9))
        svg.append(text(x0 + group_w / 2, ybase + 18, label, 12))
        svg.append(text(x0 + group_w / 2, ybase + 33, "%d pair%s" % (pairs, "" if pairs == 1 else "s"), 11, "middle", 'fill="#555"'))


def main(argv):
    out, panels = parse(argv)
    height = 40 + PANEL_HEIGHT * len(panels)
    svg = [
        '<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif">' % (WIDTH, height),
        '<rect width="100%" height="100%" fill="white"/>',
    ]
    x = LEFT
    for name, colour in COLOURS.items():
        svg.append('<rect x="%d" y="12" width="12" height="12" fill="%s"/>' % (x, colour))
        svg.append(text(x + 16, 22, name, 11, "start"))
        x += 24 + 7 * len(name)
    for p, (title, count, groups) in enumerate(panels):
        panel(svg, 30 + p * PANEL_HEIGHT, title, count, groups)
    svg.append("</svg>")
    with open(out, "w") as f:
        f.write("\n".join(svg) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
