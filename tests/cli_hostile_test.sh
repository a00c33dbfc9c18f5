#!/usr/bin/env bash
# The second hostile campaign (#57) at the command line: coincident points,
# a denormal radius, a non-finite point's precision warning, a key given at a
# config's top and in its [detect] section, convert's output format, and
# `ced eval` on a pair without overlap. Each case failed before the fix.
#   tests/cli_hostile_test.sh path/to/ced path/to/tests/data
set -u
CED=$1
DATA=$2
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# shellcheck source=cli_support.sh
. "$(dirname "$0")/cli_support.sh"

# --- 60,000 points, 50,000 of them at (0, 0, 0): invalid LiDAR returns ---
# (A degenerate kd-tree recursed once a point: SIGSEGV in info, --radius
# auto and eval; knn took minutes. Their time is measured in bench_crowded.)
awk 'BEGIN { srand(7); print "x,y,z,intensity";
  for (i = 0; i < 60000; i++)
    if (i % 6 == 0) printf "%.4f,%.4f,%.4f,%d\n", rand() * 10, rand() * 10, rand(), int(rand() * 1000);
    else print "0,0,0,0" }' > "$T/crowded.csv"
"$CED" info "$T/crowded.csv" > "$T/info.txt" 2> "$T/err"
check "info on coincident points: exit 0" test $? = 0
check "info on coincident points: a resolution" grep -q "resolution" "$T/info.txt"
check "info on coincident points: says how many coincide" grep -q "50000 points share a position" "$T/info.txt"
"$CED" detect "$T/crowded.csv" -m xyz:0.2 --indices "$T/auto.txt" -q
check "detect --radius auto on coincident points: exit 0" test $? = 0
# A fixed radius stays quadratic in the coincident points (each has all of
# them as neighbours; CGAL's reference path sorts each list): 2,000 of them.
awk -F, 'NR == 1 || $1 != 0 || n++ < 2000' "$T/crowded.csv" > "$T/crowd2k.csv"
for nb in knn:8 adaptive:8 radius; do
  cloud=$T/crowded.csv
  [ "$nb" = radius ] && cloud=$T/crowd2k.csv
  "$CED" detect "$cloud" -r 0.5 -m xyz:0.2 --neighborhood "$nb" --indices "$T/$nb.txt" -q
  check "detect --neighborhood $nb on coincident points: exit 0" test $? = 0
  "$CED" detect "$cloud" -r 0.5 -m xyz:0.2 --neighborhood "$nb" --search cgal --indices "$T/$nb.cgal.txt" -q
  check "detect --neighborhood $nb --search cgal: the grid's keypoints" cmp -s "$T/$nb.txt" "$T/$nb.cgal.txt"
  "$CED" detect "$cloud" -r 0.5 -m xyz:0.2 --neighborhood "$nb" --tile-size 3 \
    --indices "$T/$nb.tiled.txt" -q 2> "$T/err"
  check "detect --neighborhood $nb in tiles: the whole run's keypoints" cmp -s "$T/$nb.txt" "$T/$nb.tiled.txt"
done
"$CED" eval repeatability "$T/crowded.csv" -d ced3d --trials 1 --noise 0 -r 0.5 -q > "$T/eval.txt"
check "eval on coincident points: exit 0" test $? = 0

# --- Each point three times: the spacing of the distinct positions ---
awk 'BEGIN { print "x,y,z"; for (c = 0; c < 3; c++) for (i = 0; i < 1000; i++)
  printf "%.3f,%.3f,0\n", (i % 40) * 0.01, int(i / 40) * 0.01 }' > "$T/thrice.csv"
"$CED" info "$T/thrice.csv" > "$T/info3.txt" 2> "$T/err"
check "info on points stored thrice: exit 0" test $? = 0
check "info on points stored thrice: the 1 cm spacing" grep -q "resolution.*: 0\.0\(1\|0999\)" "$T/info3.txt"
"$CED" detect "$T/thrice.csv" -m xyz:0.2 --indices "$T/k3.txt" -q 2> "$T/err"
check "--radius auto on points stored thrice: runs" test $? = 0
check "--radius auto on points stored thrice: not 'fewer than two distinct points'" \
  sh -c "! grep -q 'distinct points' '$T/err'"

# --- A denormal radius: 0.2 r was 0, so every point was a keypoint ---
printf 'x,y,z\n0,0,0\n0.01,0,0\n0,0.01,0\n0.01,0.01,0\n0.02,0,0\n' > "$T/five.csv"
expect_exit 2 "radius must be at least 2.2e-308" "-r 1e-323" -- detect "$T/five.csv" -r 1e-323 -q
expect_exit 2 "nms_radius must be at least 2.2e-308" "--nms-radius 1e-320" -- \
  detect "$T/five.csv" -r 0.05 --nms-radius 1e-320 -q
# A radius far below the spacing, but normal, finds nothing.
"$CED" detect "$T/five.csv" -r 1e-300 -m xyz:0.2 --indices "$T/tiny.txt" -q
check "-r 1e-300: no keypoints" test ! -s "$T/tiny.txt"

# --- A non-finite point is no far point ---
printf 'x,y,z\n0,0,0\n0.01,0,0\n0,0.01,0\ninf,0,0\n0.01,0.01,0\n' > "$T/inf.csv"
"$CED" detect "$T/inf.csv" -r 0.05 -m xyz:0.2 -q > /dev/null 2> "$T/err"
check "a point at x = inf: no precision warning of 'inf m'" sh -c "! grep -q 'inf m' '$T/err'"

# --- A key at a config's top and again in its [detect] section ---
printf 'radius = 0.05\n[detect]\nradius = 0.1\n' > "$T/c.toml"
expect_exit 2 "c.toml: 'radius' is given twice ('radius' and 'detect.radius')" "a key at the top and in [detect]" -- \
  detect "$T/five.csv" --config "$T/c.toml" -q

# --- ced eval on a pair without overlap: "no overlap", not nan ---
printf 'x,y,z\n' > "$T/far.csv"
awk 'BEGIN { for (i = 0; i < 400; i++) printf "%.3f,%.3f,%.3f\n", 100 + (i % 20) * 0.01, int(i / 20) * 0.01, (i % 7) * 0.003 }' >> "$T/far.csv"
awk 'BEGIN { print "x,y,z"; for (i = 0; i < 400; i++) printf "%.3f,%.3f,%.3f\n", (i % 20) * 0.01, int(i / 20) * 0.01, (i % 7) * 0.003 }' > "$T/near.csv"
"$CED" eval repeatability --source "$T/near.csv" --target "$T/far.csv" -d ced3d --resolution 0.01 \
  --csv "$T/no.csv" -q > "$T/no.txt" 2> "$T/err"
check "eval without overlap: exit 0" test $? = 0
check "eval without overlap: the table says so" grep -q "no overlap" "$T/no.txt"
check "eval without overlap: the CSV says so" grep -q "no overlap" "$T/no.csv"
check "eval without overlap: no nan" sh -c "! grep -qi 'nan' '$T/no.txt' '$T/no.csv'"

# --- ced convert: the output's format when its name does not say ---
expect_exit 2 "name the output's format with --to" "convert to /dev/stdout without --to" -- \
  convert "$T/five.csv" /dev/stdout
"$CED" convert "$T/five.csv" /dev/stdout --to las > "$T/stdout.las" 2> "$T/err"
check "convert --to las to /dev/stdout: exit 0" test $? = 0
check "convert --to las to /dev/stdout: a LAS file" sh -c "head -c 4 '$T/stdout.las' | grep -q LASF"
expect_exit 2 "unknown format 'e57'" "convert --to e57" -- convert "$T/five.csv" "$T/x.las" --to e57
# --- A LAS file's VLRs that no writer carries (its coordinate system) are named, not dropped in silence ---
"$CED" convert "$DATA/file_with_both_wkt_and_geotiff_vlrs.las" "$T/crs.las" 2> "$T/err"
check "convert drops the CRS VLRs: said" grep -q "'LASF_Projection' .* are not copied" "$T/err"
"$CED" convert "$DATA/1_4_w_evlr.las" "$T/evlr.ply" 2> "$T/err"
check "convert drops extended VLRs: said" grep -q "extended VLR(s).* are not copied" "$T/err"

echo "cli_hostile: $pass passed, $fail failed"
[ "$fail" = 0 ]
