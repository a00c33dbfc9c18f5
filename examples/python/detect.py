#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Reads a cloud, detects keypoints, writes them (with their saliencies) and a picture.

    PYTHONPATH=build/python python3 examples/python/detect.py tests/data/apartment_mesh_214.ply out/
"""
import pathlib
import sys

import numpy as np

import ced


def main(path, out_dir):
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cloud = ced.read(path)
    result = ced.detect(cloud, modalities=[ced.xyz(0.2), ced.rgb(0.1)], radius=0.05)
    print(result)
    np.savetxt(out / "keypoints.txt", result.keypoints, fmt="%d")
    ced.write_keypoints(str(out / "keypoints.ply"), cloud, result)
    ced.render(str(out / "keypoints.png"), cloud, result.keypoints)
    strongest = result.keypoints[np.argsort(-result.saliency["xyz"][result.keypoints])[:5]]
    for i in strongest:
        print(f"point {i}: xyz {result.saliency['xyz'][i]:.4f} m, rgb {result.saliency['rgb'][i]:.3f}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: detect.py CLOUD OUT_DIR")
    main(sys.argv[1], sys.argv[2])
