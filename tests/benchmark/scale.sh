#!/usr/bin/env bash
# The scale figures of docs/RESULTS.md (how: docs/SCALE.md): generated city LAS files of 10 M, 100 M and
# 300 M points (tests/benchmark/make_las.py), each detected whole (when it
# fits in memory), with --tile-size, with --memory-limit 4G, and on 1-3 MPI
# ranks; wall time and peak memory (/usr/bin/time), and whether the keypoints
# are identical.
#   tests/benchmark/scale.sh BUILD_DIR WORK_DIR [SIZES...]   (sizes in millions; default 10 100 300)
set -u
BUILD=$(cd "$1" && pwd)
WORK=$2
shift 2
SIZES=${*:-10 100 300}
CED=$BUILD/bin/ced
MPI=$BUILD/bin/ced-mpi
GEN="/usr/bin/python3 $(dirname "$0")/make_las.py"
# Every run writes --indices; with KEYPOINTS=1 (the default) also the keypoint
# cloud (-o keypoints.las), which makes every run read all the LAS fields.
OPTS="--preset ced6d --radius 0.3"
[ "${KEYPOINTS:-1}" = 1 ] && OPTS="$OPTS -o $WORK/keypoints.las"
mkdir -p "$WORK"
export TMPDIR=$WORK  # the tile caches
echo "# $(date -u +%F) $(uname -n), $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); options: $OPTS"
echo "| points | run | wall s | peak MB | points/s | keypoints | same as whole |"
echo "|---|---|---|---|---|---|---|"
measure() {  # measure LABEL N OUT.txt -- COMMAND...: one row
  local label=$1 n=$2 out=$3
  shift 4
  /usr/bin/time -f "%e %M" -o "$WORK/time" "$@" > /dev/null 2> "$WORK/err" || {
    echo "| $n | $label | failed: $(tail -1 "$WORK/err") | | | | |"
    return
  }
  read -r wall kb < "$WORK/time"
  local same="-"
  [ -f "$WORK/whole.txt" ] && [ "$out" != "$WORK/whole.txt" ] &&
    { cmp -s "$WORK/whole.txt" "$out" && same=yes || same=NO; }
  printf '| %s M | %s | %.1f | %d | %.2f M | %d | %s |\n' "$n" "$label" "$wall" $((kb / 1024)) \
    "$(echo "$n / $wall" | bc -l)" "$(wc -l < "$out")" "$same"
}
for n in $SIZES; do
  las=$WORK/city${n}m.las
  [ -f "$las" ] || $GEN --points $((n * 1000000)) --seed 1 -o "$las" > /dev/null
  rm -f "$WORK/whole.txt"
  # Whole cloud only when it fits: about 70 bytes a point besides the file's own.
  need_kb=$((n * 1000000 * 70 / 1024))
  avail_kb=$(awk '/MemAvailable/ {print $2}' /proc/meminfo)
  if [ "$need_kb" -lt $((avail_kb * 8 / 10)) ]; then
    measure "whole cloud" "$n" "$WORK/whole.txt" -- "$CED" detect "$las" $OPTS --indices "$WORK/whole.txt"
  else
    echo "| $n M | whole cloud | not run: needs about $((need_kb / 1048576)) GB | | | | |"
  fi
  measure "--tile-size 50" "$n" "$WORK/tiled.txt" -- "$CED" detect "$las" $OPTS --tile-size 50 --indices "$WORK/tiled.txt"
  measure "--memory-limit 4G" "$n" "$WORK/limit.txt" -- "$CED" detect "$las" $OPTS --memory-limit 4G \
    --indices "$WORK/limit.txt"
  [ -f "$WORK/whole.txt" ] || cp "$WORK/tiled.txt" "$WORK/whole.txt"  # the MPI rows compare with the tiles
  if [ "$n" = "$(echo $SIZES | cut -d' ' -f1)" ] && [ -x "$MPI" ]; then
    for np in 1 2 3; do
      measure "ced-mpi -np $np, --tile-size 50" "$n" "$WORK/mpi.txt" -- mpirun --allow-run-as-root --oversubscribe \
        -np $np "$MPI" detect "$las" $OPTS --tile-size 50 --indices "$WORK/mpi.txt"
    done
  fi
done
