# SPDX-License-Identifier: MIT
"""Keypoints of a cloud too large for one machine's memory, tile by tile on Dask.

The plan (two passes over the file) is made here; each tile is read and
detected by a worker of a dask.distributed cluster (a LocalCluster here; a
cluster's scheduler address works the same), which writes its part to a
shared folder; the parts are merged here into exactly the keypoints of a
whole-cloud detection. Needs Debian's python3-distributed.

    python3 examples/python/dask_tiles.py big.las --tile-size 50 --workers 2 -o keypoints.ply

The input may be a folder of tiles or @LIST (a file of paths): one cloud,
with exact halos across the files' borders.
"""
import argparse
import os
import tempfile

import ced


def detect_one(plan, tile, folder):
    """On a worker: tile `tile` of the plan, its part written to `folder`."""
    path = os.path.join(folder, f"t{tile}.cedpart")
    ced.detect_tile(plan, tile, part=path, threads=1)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("input", help="a point file, a folder of them, or @LIST")
    ap.add_argument("--tile-size", type=float, required=True, help="edge of a tile's core, metres")
    ap.add_argument("--modalities", default="ced6d", help="a preset or specs joined by commas")
    ap.add_argument("--radius", type=float, default=0.05)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scheduler", help="address of a running Dask scheduler (default: a LocalCluster)")
    ap.add_argument("--parts", help="folder for the parts, on storage every worker sees (default: a temporary one)")
    ap.add_argument("-o", "--output", help="keypoints with their fields (.ply, .pcd, .las, .csv)")
    ap.add_argument("--indices", help="keypoint indices, one a line")
    args = ap.parse_args()

    from dask.distributed import Client, LocalCluster

    plan = ced.plan_tiles(args.input, tile_size=args.tile_size, modalities=args.modalities, radius=args.radius)
    print(f"{len(plan.tiles)} tiles of {plan.tile_size:g} (halo {plan.halo:.3g}) over {plan.points} points")
    # Largest tiles first: they take longest, and a worker that ends with one keeps the others waiting.
    tiles = [t[0] for t in sorted(plan.tiles, key=lambda t: -t[2])]
    with tempfile.TemporaryDirectory() as scratch:
        folder = args.parts or scratch
        if args.scheduler:
            client = Client(args.scheduler)
        else:
            client = Client(LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                                         dashboard_address=None))
        with client:
            futures = client.map(detect_one, [plan] * len(tiles), tiles, [folder] * len(tiles), pure=False)
            parts = client.gather(futures)
        merged = ced.merge_parts(plan, parts)
    print(f"{len(merged.keypoints)} keypoints")
    if args.indices:
        with open(args.indices, "w") as f:
            f.writelines(f"{k}\n" for k in merged.keypoints)
    if args.output:
        ced.write(args.output, merged.cloud)


if __name__ == "__main__":
    main()
