#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Detects keypoints on an Open3D point cloud and shows them (or saves them with --save DIR).

    PYTHONPATH=build/python python3 examples/python/open3d_keypoints.py tests/data/apartment_mesh_214.ply
    PYTHONPATH=build/python python3 examples/python/open3d_keypoints.py scan.ply --save out/
"""
import argparse
import pathlib

import numpy as np
import open3d as o3d

import ced


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cloud")
    ap.add_argument("--save", metavar="DIR", help="write keypoints.ply and keypoints.png instead of showing them")
    args = ap.parse_args()

    pcd = o3d.io.read_point_cloud(args.cloud)
    result = ced.detect(pcd, radius="auto")  # colours come from the Open3D cloud: ced6d
    print(result)

    keypoints = pcd.select_by_index(result.keypoints.astype(np.int64).tolist())
    keypoints.paint_uniform_color([0.9, 0.1, 0.1])
    if args.save:
        out = pathlib.Path(args.save)
        out.mkdir(parents=True, exist_ok=True)
        o3d.io.write_point_cloud(str(out / "keypoints.ply"), keypoints)
        ced.render(str(out / "keypoints.png"), pcd, result.keypoints)
        print(f"wrote {out / 'keypoints.ply'} and {out / 'keypoints.png'}")
    else:
        spheres = [o3d.geometry.TriangleMesh.create_sphere(radius=result.radius / 5).translate(p)
                   for p in np.asarray(keypoints.points)]
        for s in spheres:
            s.paint_uniform_color([0.9, 0.1, 0.1])
        o3d.visualization.draw_geometries([pcd, *spheres])


if __name__ == "__main__":
    main()
