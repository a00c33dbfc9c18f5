#!/bin/sh
# SPDX-License-Identifier: MIT
# ced against the paper's own code, as a whole process, alternately.
#
#   tests/benchmark/paper_compare.sh [BUILD] [CLOUD.ply] [RUNS] [BASELINE_BUILD]
#
# Fetches UCR-Robotics/CED_Detector (the WACV 2023 paper's code, MIT) into
# $WORK (default /tmp/ced-paper; or uses the checkout $CED_DETECTOR_DIR),
# builds tests/benchmark/paper/paper_ced6d.cpp against its headers and
# Debian's PCL with the paper's own build type (RelWithDebInfo: -O2 -g),
# converts CLOUD (default the Redwood loft scan) to binary PCD with ced, then
# times `ced detect --preset ced6d --threads 1` and the paper's detector on
# the same points, RUNS rounds (default 15) alternating, with
# whole_process.py (and BASELINE_BUILD's ced too, when given), and checks
# that both give the same keypoints. Needs g++, libpcl-dev, git (unless the
# checkout is given) and /usr/bin/python3.
set -eu
HERE=$(cd "$(dirname "$0")" && pwd)
BUILD=${1:-build}
CLOUD=${2:-../shared/data/redwood_scan/loft_mesh_240.ply}
RUNS=${3:-15}
BASE=${4:-}
WORK=${WORK:-/tmp/ced-paper}
CED=$BUILD/bin/ced
mkdir -p "$WORK"
SRC=${CED_DETECTOR_DIR:-$WORK/CED_Detector}
if [ ! -f "$SRC/include/ced_6d.h" ]; then
  git clone --quiet --depth 1 https://github.com/UCR-Robotics/CED_Detector "$SRC"
fi
PKGS="pcl_common pcl_io pcl_kdtree pcl_search pcl_keypoints eigen3"
# shellcheck disable=SC2046
g++ -O2 -g -std=c++14 -I"$SRC/include" $(pkg-config --cflags $PKGS) "$HERE/paper/paper_ced6d.cpp" \
  -o "$WORK/paper_ced6d" $(pkg-config --libs $PKGS) -lboost_system 2> "$WORK/build.log" || {
  cat "$WORK/build.log" >&2
  exit 1
}
"$CED" convert "$CLOUD" "$WORK/cloud.pcd" 2> /dev/null
set -- "$CED detect $CLOUD --preset ced6d --threads 1 --indices $WORK/kp_ced.txt -q" \
  "$WORK/paper_ced6d $WORK/cloud.pcd $WORK/kp_paper.txt"
[ -n "$BASE" ] && set -- "$@" "$BASE/bin/ced detect $CLOUD --preset ced6d --threads 1 --indices $WORK/kp_base.txt -q"
/usr/bin/python3 "$HERE/whole_process.py" --runs "$RUNS" "$@"
sort "$WORK/kp_ced.txt" > "$WORK/kp_ced.sorted"
sort "$WORK/kp_paper.txt" > "$WORK/kp_paper.sorted"
both=$(comm -12 "$WORK/kp_ced.sorted" "$WORK/kp_paper.sorted" | wc -l)
echo "keypoints: ced $(wc -l < "$WORK/kp_ced.txt"), the paper's code $(wc -l < "$WORK/kp_paper.txt"), in both $both" \
  "(docs/ALGORITHM.md: the paper's code sums in another order, which flips a few borderline points)"
