#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""A seeded synthetic city scanned from the air, written as an uncompressed LAS 1.2 file.

    /usr/bin/python3 tests/benchmark/make_las.py --points 100000000 --seed 1 -o city.las

The city is a square whose side grows with the point count so that the points stay about
--spacing metres apart (side = spacing * sqrt(points)): gently sloped, slightly undulating ground;
a grid of streets (asphalt, dashed centre lines, kerbs, sidewalks with joints) around blocks of
one to four box buildings (flat roofs with roof units, or gable roofs with tile rows; facades
with windows); street trees (noisy crowns with up to four returns) and parked cars. Colour and
intensity come from each point's material, per object, with texture and noise.

The points are the pulses of an airborne scanner, in the order it takes them: strips flown to
and fro along Y, then cross strips along X, each a zig-zag of scan lines. A pulse hits what its
slanted ray meets first: roofs are shifted toward the scanner, the facades facing it are hit,
and the ground behind a building is in its shadow.

Point data format 3 (34-byte records), scale 0.001 m, offset 500000 / 4000000 / 0 (a projected
CRS, UTM 33N, in a GeoKeyDirectory record): X, Y, Z; intensity; return number and number of
returns; scan direction and edge-of-flight-line flags; classification (1 car, 2 ground, 5 high
vegetation, 6 building, 7 low noise); scan angle rank; user data (the material: see MATERIALS);
point source ID (the strip, from 1); GPS time (adjusted standard); red, green, blue (16-bit).

The file depends only on (points, seed, spacing), byte for byte: the scene's tables come from the
seed; each point is computed from its own index, with random numbers from the raw stream of its
fixed block of RANDOM_BLOCK points (seeded from seed and block), by element-wise arithmetic only
(no sin/exp/log, whose last bits may differ between vector widths and CPUs), so the chunk size
changes nothing. Another point count gives another city (its side and its tables differ), not a
crop of the same one. Memory is bounded by the chunk (under 100 MB at the default, whatever the
point count). The file is written beside the output under a temporary name and renamed when
complete: an interrupted or failed run leaves no partial file.
"""
import argparse
import ctypes
import math
import os
import signal
import struct
import sys
import tempfile
import time

import numpy as np

from city import City, EPSG, HEADER_SIZE, OFFSET, ORIGIN, RECORD, SCALE


def header(points, lo, hi, by_return, seed):
    """The LAS 1.2 public header and its one record, the GeoKeyDirectory."""
    keys = [(1024, 0, 1, 1), (1025, 0, 1, 1), (3072, 0, 1, EPSG), (3076, 0, 1, 9001),
            (4099, 0, 1, 9001)]
    geokeys = struct.pack("<4H", 1, 1, 0, len(keys)) + b"".join(struct.pack("<4H", *k)
                                                                for k in keys)
    vlr = struct.pack("<H16sHH32s", 0, b"LASF_Projection", 34735, len(geokeys),
                      b"GeoKeyDirectoryTag") + geokeys
    mins = [v * SCALE + o for v, o in zip(lo, OFFSET)]
    maxs = [v * SCALE + o for v, o in zip(hi, OFFSET)]
    head = struct.pack(
        "<4sHHIHH8sBB32s32sHHHIIBHI5I3d3d6d", b"LASF", 0, 1, 0, 0, 0, bytes(8), 1, 2,
        b"ced synthetic city", f"ced make_las.py seed {seed}"[:32].encode(), 0, 0, HEADER_SIZE,
        HEADER_SIZE + len(vlr), 1, 3, RECORD.itemsize, points, *by_return, SCALE, SCALE, SCALE,
        *OFFSET, maxs[0], mins[0], maxs[1], mins[1], maxs[2], mins[2])
    assert len(head) == HEADER_SIZE
    return head + vlr


def write(path, points, seed, spacing, chunk, quiet):
    city = City(points, seed, spacing)
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp",
                               dir=folder)
    lo = np.array([np.iinfo(np.int32).max] * 3, np.int64)
    hi = np.array([np.iinfo(np.int32).min] * 3, np.int64)
    by_return = np.zeros(5, np.int64)
    start = last = time.perf_counter()
    try:
        with os.fdopen(fd, "wb") as f:
            size = len(header(points, (0, 0, 0), (0, 0, 0), [0] * 5, seed))
            f.write(bytes(size))
            for a in range(0, points, chunk):
                b = min(points, a + chunk)
                rec, returns = city.chunk(a, b)
                for k, name in enumerate("xyz"):
                    lo[k] = min(lo[k], int(rec[name].min()))
                    hi[k] = max(hi[k], int(rec[name].max()))
                by_return += returns
                f.write(memoryview(rec).cast("B"))
                now = time.perf_counter()
                if not quiet and now - last > 10:
                    last = now
                    print(f"{b / points:6.1%}  {b / (now - start) / 1e6:.2f} M points/s",
                          file=sys.stderr)
            if points == 0:
                lo[:] = hi[:] = 0
            f.seek(0)
            f.write(header(points, lo.tolist(), hi.tolist(), by_return.tolist(), seed))
            f.flush()
            os.fsync(f.fileno())
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise
    seconds = time.perf_counter() - start
    if not quiet:
        print(f"{path}: {points} points, side {city.L:.1f} m, {seconds:.2f} s "
              f"({points / max(seconds, 1e-9) / 1e6:.2f} M points/s)", file=sys.stderr)


def keep_freed_memory():
    """Asks glibc to keep freed memory for reuse: numpy allocates and frees many arrays a chunk,
    and returning them to the kernel costs a page fault per page when they come back (over half
    the time on some virtual machines). Elsewhere, nothing."""
    try:
        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, 32 << 20)  # M_MMAP_THRESHOLD: arrays up to 32 MB from the heap
        libc.mallopt(-1, 1 << 30)  # M_TRIM_THRESHOLD: keep up to 1 GB of free heap
    except (OSError, AttributeError):
        pass


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=int, required=True, help="the number of points")
    ap.add_argument("--seed", type=int, default=0, help="the scene's and the points' seed (>= 0)")
    ap.add_argument("--spacing", type=float, default=0.1,
                    help="the mean distance between points, m (default 0.1)")
    ap.add_argument("--chunk", type=int, default=1 << 16,
                    help="points generated at once (memory, not the output)")
    ap.add_argument("-o", "--output", required=True, help="the LAS file to write")
    ap.add_argument("-q", "--quiet", action="store_true")
    args = ap.parse_args()
    if not 0 <= args.points <= 0xFFFFFFFF:
        ap.error("--points must be in 0..4294967295 (a LAS 1.2 point count)")
    if args.seed < 0:
        ap.error("--seed must be >= 0")
    if not args.spacing > 0 or not math.isfinite(args.spacing):
        ap.error("--spacing must be > 0")
    if args.chunk < 1:
        ap.error("--chunk must be >= 1")
    if args.spacing * math.sqrt(max(args.points, 1)) + ORIGIN[0] > 2.0e6:
        ap.error("the square would not fit in 32-bit millimetres")

    def terminate(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    signal.signal(signal.SIGTERM, terminate)
    keep_freed_memory()
    try:
        write(args.output, args.points, args.seed, args.spacing, args.chunk, args.quiet)
    except KeyboardInterrupt:
        print("interrupted: nothing written", file=sys.stderr)
        return 130
    except OSError as e:
        print(f"make_las.py: error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
