# SPDX-License-Identifier: MIT
# The Python package `ced`, built by this repository's CMake project through
# scikit-build: only the library and the module (no CLI, tests, examples).
import re
from pathlib import Path

from skbuild import setup

version = re.search(r"project\(ced VERSION ([0-9.]+)", Path(__file__).with_name("CMakeLists.txt").read_text())[1]

setup(
    name="ced",
    version=version,
    description="N-modal CEntroid Distance keypoint detection in point clouds",
    license="MIT",
    python_requires=">=3.8",
    install_requires=["numpy"],
    packages=["ced"],
    package_dir={"": "src/python"},
    package_data={"ced": ["*.pyi", "py.typed"]},
    cmake_args=[
        "-DCMAKE_BUILD_TYPE=Release",
        "-DCED_PYTHON=ON",
        "-DCED_BUILD_TESTS=OFF",
        "-DCED_BUILD_EXAMPLES=OFF",
        "-DCED_BUILD_CLI=OFF",
        "-DCED_BUILD_BENCHMARKS=OFF",
        "-DCED_INSTALL=OFF",
        "-DCED_WITH_PCL=OFF",
        "-DCED_WITH_PCL_REFERENCE=OFF",
    ],
)
