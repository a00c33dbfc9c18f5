#!/usr/bin/env bash
# End-to-end tests of the `ced` command line: outputs, format equivalence,
# errors with their exit codes, and output safety.
#   tests/cli_test.sh path/to/ced path/to/tests/data
set -u
CED=$1
DATA=$2
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# shellcheck source=cli_support.sh
. "$(dirname "$0")/cli_support.sh"
sample=$DATA/apartment_mesh_214.ply

# --- The main job: indices, keypoints file, viewer, picture, summary ---
"$CED" detect "$sample" --preset ced6d --indices "$T/kp.txt" -o "$T/kp.ply" --viewer "$T/view.ply" \
  --png "$T/kp.png" --summary "$T/s.json" -q
check "detect exit 0" test $? = 0
check "173 indices" test "$(wc -l < "$T/kp.txt")" = 173
check "matches the PCL reference" cmp -s "$T/kp.txt" "$DATA/apartment_mesh_214.ced6d.pcl_reference.txt"
check "png written" test -s "$T/kp.png"
check "png signature" test "$(head -c 8 "$T/kp.png" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a
check "summary has counts" grep -q '"keypoints": 173' "$T/s.json"
"$CED" info "$T/kp.ply" > "$T/info.txt"
check "keypoint file: 173 points" grep -q ": 173 points" "$T/info.txt"
check "keypoint file: saliency fields" grep -q "saliency_rgb" "$T/info.txt"
"$CED" info "$T/view.ply" > "$T/info.txt"
check "viewer: scalar_keypoint" grep -q "scalar_keypoint" "$T/info.txt"
check "stdout without outputs" test "$("$CED" detect "$sample" --preset ced3d -q | wc -l)" = 118

# --- --indices-original counts every point of the file, NaN points of
# organized PCD files included (whole cloud and tiles) ---
"$CED" convert "$sample" "$T/s.csv"
# An organized ascii PCD (HEIGHT 2): a NaN point before every 3rd point, and
# one more to make the count even. The finite points keep their order.
awk -F, 'NR > 1 { if ((NR - 2) % 3 == 0) print "nan nan nan"; print $1, $2, $3 }' "$T/s.csv" > "$T/rows.txt"
[ $(( $(wc -l < "$T/rows.txt") % 2 )) = 1 ] && echo "nan nan nan" >> "$T/rows.txt"
rows=$(wc -l < "$T/rows.txt")
{ printf 'VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH %d\nHEIGHT 2\n' $((rows / 2))
  printf 'VIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA ascii\n' "$rows"; cat "$T/rows.txt"; } > "$T/org.pcd"
awk -F, 'NR > 1 { print $1 "," $2 "," $3 }' "$T/s.csv" | sed '1i x,y,z' > "$T/finite.csv"
"$CED" detect "$T/finite.csv" --preset ced3d --indices "$T/ref.txt" -q
"$CED" detect "$T/org.pcd" --preset ced3d --indices "$T/org_idx.txt" --indices-original "$T/org_orig.txt" -q
check "organized PCD: same keypoints as its finite points" cmp -s "$T/ref.txt" "$T/org_idx.txt"
# The file's own index of the k-th finite point: its line number in rows.txt, less 1.
awk 'NR == FNR { if ($1 != "nan") f[n++] = FNR - 1; next } { print f[$1] }' "$T/rows.txt" "$T/ref.txt" > "$T/want.txt"
check "organized PCD: --indices-original counts NaN points" cmp -s "$T/want.txt" "$T/org_orig.txt"
check "organized PCD: the indices differ from the finite ones" sh -c "! cmp -s '$T/ref.txt' '$T/org_orig.txt'"
"$CED" detect "$T/org.pcd" --preset ced3d --indices-original "$T/org_tiles.txt" --tile-size 1 -q
check "organized PCD in tiles: the same original indices" cmp -s "$T/want.txt" "$T/org_tiles.txt"

# --- Pictures: colours by saliency or height, a second view from above ---
"$CED" detect "$sample" --preset ced6d --png "$T/sal.png" --png-color saliency:xyz --png-top -q
check "png-top: twice as wide" test "$(head -c 24 "$T/sal.png" | od -An -tu1 -j16 | tr -s ' ' | cut -d' ' -f2-5)" = "0 0 10 0"
"$CED" detect "$sample" --preset ced6d --png "$T/h.png" --png-color height -q
check "png-color height" test -s "$T/h.png"
check "png-color changes the picture" sh -c "! cmp -s '$T/h.png' '$T/kp.png'"
expect_exit 2 "no such modality in this run (xyz, rgb)" "png-color: unknown modality" -- \
  detect "$sample" --preset ced6d --png "$T/x.png" --png-color saliency:nope
expect_exit 2 "rgb, height or saliency:NAME" "png-color: bad value" -- \
  detect "$sample" --png "$T/x.png" --png-color blue
check "png-color: no picture after errors" test ! -e "$T/x.png"

# --- The interactive page: from a run, and from clouds written earlier ---
"$CED" detect "$sample" --preset ced6d --html "$T/view.html" -q
check "html written" grep -q "const CED_DATA = " "$T/view.html"
check "html: the run's parameters" grep -q '"min neighbours","5"' "$T/view.html"
check "html: no external script" sh -c "! grep -qi '<script src' '$T/view.html'"
"$CED" view "$T/view.ply" -o "$T/from_viewer.html" --threshold xyz=0.01 --threshold rgb=0.1
check "view: of a viewer cloud" grep -q '"threshold":0.01' "$T/from_viewer.html"
"$CED" view "$T/kp.ply" -o "$T/from_kp.html"
check "view: of a keypoint cloud" grep -q '"threshold":null' "$T/from_kp.html"
expect_exit 2 "html-max-points must be at least 1" "html: zero points" -- \
  detect "$sample" --preset ced6d --html "$T/x.html" --html-max-points 0
expect_exit 2 "html shows the whole cloud" "html: not with tiles" -- \
  detect "$sample" --preset ced6d --html "$T/x.html" --tile-size 1
expect_exit 2 "no saliency_nope field" "view: unknown threshold name" -- \
  view "$T/view.ply" -o "$T/x.html" --threshold nope=1
expect_exit 2 "NAME=VALUE" "view: bad threshold" -- view "$T/view.ply" -o "$T/x.html" --threshold xyz
expect_exit 1 "missing.ply" "view: missing input" -- view "$T/missing.ply" -o "$T/x.html"
check "view: no page after errors" test ! -e "$T/x.html"

# --- The same cloud in every format gives the same keypoints ---
for ext in pcd csv; do
  "$CED" convert "$sample" "$T/sample.$ext"
  check "convert to $ext" test $? = 0
  "$CED" detect "$T/sample.$ext" --preset ced6d --indices "$T/kp_$ext.txt" -q
  check "$ext gives the same keypoints" cmp -s "$T/kp.txt" "$T/kp_$ext.txt"
done
# LAS stores millimetres: compare with the same millimetre cloud as PLY.
"$CED" convert "$sample" "$T/sample.las" && "$CED" convert "$T/sample.las" "$T/sample_mm.ply"
check "las round trip" test $? = 0
"$CED" detect "$T/sample.las" --preset ced6d --indices "$T/kp_las.txt" -q
"$CED" detect "$T/sample_mm.ply" --preset ced6d --indices "$T/kp_mm.txt" -q
check "las gives the same keypoints" cmp -s "$T/kp_las.txt" "$T/kp_mm.txt"
# (Millimetre rounding moves some NMS winners among near-equal neighbours;
# the count stays close: 168 against 173.)
n_las=$(wc -l < "$T/kp_las.txt")
check "las keypoint count close to the original" test "$n_las" -ge 156 -a "$n_las" -le 190

# --- Only the fields a run needs are read (the summary lists them) ---
"$CED" detect "$T/sample.las" --preset ced6d --summary "$T/f6.json" -q > /dev/null
fields_read() { tr -d ' \n' < "$1" | grep -o '"fields_read":\[[^]]*\]'; }
check "ced6d reads colour only" test "$(fields_read "$T/f6.json")" = '"fields_read":["red","green","blue"]'
"$CED" detect "$T/sample.las" -m xyz:0.2 --summary "$T/f3.json" -q > /dev/null
check "xyz reads no field" test "$(fields_read "$T/f3.json")" = '"fields_read":[]'
"$CED" detect "$T/sample.las" -m xyz:0.2 -m 'intensity:0.05' --summary "$T/fi.json" -q > /dev/null
check "intensity reads its field" test "$(fields_read "$T/fi.json")" = '"fields_read":["intensity"]'
"$CED" detect "$T/sample.las" -m xyz:0.2 -o "$T/all.ply" --summary "$T/fa.json" -q
check "-o reads every field" test "$(fields_read "$T/fa.json" | tr -cd , | wc -c)" -ge 8

# --- Config file; flags override it ---
printf '{"preset": "ced3d", "min-neighbors": 5, "radius": "0.05"}\n' > "$T/c.json"
check "json config" test "$("$CED" detect "$sample" --config "$T/c.json" -q | wc -l)" = 118
check "flags override config" test "$("$CED" detect "$sample" --config "$T/c.json" --preset ced6d -q | wc -l)" = 173
printf 'preset = "ced3d"\n' > "$T/c.toml"
check "toml config" test "$("$CED" detect "$sample" --config "$T/c.toml" -q | wc -l)" = 118

# --- Usage errors: exit 2, nothing written ---
expect_exit 2 "refine or --no-refine, not both" "refine: both flags" -- \
  detect "$sample" --preset robust3d --refine --no-refine --indices "$T/no.txt"
expect_exit 2 "radius" "radius 0" -- detect "$sample" --radius 0 --indices "$T/no.txt"
expect_exit 2 "radius" "radius nan" -- detect "$sample" --radius nan --indices "$T/no.txt"
expect_exit 2 "radius" "radius negative" -- detect "$sample" --radius -1 --indices "$T/no.txt"
expect_exit 2 "unknown modality 'colour'" "unknown modality" -- detect "$sample" -m colour:0.1 --indices "$T/no.txt"
expect_exit 2 "negative" "negative threshold" -- detect "$sample" -m rgb:-1 --indices "$T/no.txt"
expect_exit 2 "min-neighbors" "negative min neighbours" -- detect "$sample" -k -3 --indices "$T/no.txt"
expect_exit 2 "voxel" "negative voxel" -- detect "$sample" --voxel -1 --indices "$T/no.txt"
expect_exit 2 "give an input file" "no input" -- detect
check "usage errors wrote nothing" test ! -e "$T/no.txt"

# --- Bad input: exit 1, file named, no output, existing output kept ---
expect_exit 1 "no field 'nir'\|needs field 'nir'" "missing field" -- detect "$sample" -m 'bands(nir)' --indices "$T/no.txt"
expect_exit 1 "No such file\|cannot open\|does not exist" "missing input" -- detect "$T/missing.ply" --indices "$T/no.txt"
head -c 3000 "$sample" > "$T/trunc.ply"
echo "keep me" > "$T/existing.txt"
expect_exit 1 "trunc.ply" "truncated ply" -- detect "$T/trunc.ply" --indices "$T/existing.txt"
check "existing output kept" grep -q "keep me" "$T/existing.txt"
check "no temporary files left" test -z "$(ls -A "$T" | grep '^\.' || true)"
: > "$T/empty.ply"
expect_exit 1 "empty.ply" "empty file" -- detect "$T/empty.ply" --indices "$T/no.txt"
mkdir "$T/dir.ply"
expect_exit 1 "dir.ply" "input is a directory" -- detect "$T/dir.ply" --indices "$T/no.txt"
expect_exit 1 "missing_dir" "output directory missing" -- detect "$sample" --indices "$T/missing_dir/kp.txt"
expect_exit 1 "x.laz" "missing laz" -- detect "$T/x.laz"
head -c 300000 "$DATA/autzen_trim.laz" > "$T/cut.laz"
expect_exit 1 "cut.laz: .*LAZ" "truncated laz" -- detect "$T/cut.laz" --indices "$T/no.txt"
"$CED" convert "$DATA/simple.laz" "$T/simple_from_laz.csv"
"$CED" convert "$DATA/simple.las" "$T/simple_from_las.csv"
check "convert LAZ: the LAS twin's points" cmp -s "$T/simple_from_laz.csv" "$T/simple_from_las.csv"
check "info LAZ" sh -c "'$CED' info '$DATA/simple.laz' | grep -q '1065 points (LAZ 1.2, point format 3)'"
"$CED" convert "$DATA/simple.las" "$T/out.laz"
"$CED" convert "$T/out.laz" "$T/out_back.csv"
check "convert to LAZ and back: the same points" cmp -s "$T/out_back.csv" "$T/simple_from_las.csv"
expect_exit 1 "unsupported" "unknown extension" -- detect "$T/x.abc"
printf 'ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\nnan 1 1\n' > "$T/nan.ply"
"$CED" detect "$T/nan.ply" --preset ced3d --min-neighbors 0 -q > /dev/null 2>&1
check "NaN points dropped, not fatal" test $? = 0
printf 'ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\nnan nan nan\n' > "$T/allnan.ply"
expect_exit 1 "no (finite) points" "all points NaN" -- detect "$T/allnan.ply" --indices "$T/no.txt"
check "bad inputs wrote nothing" test ! -e "$T/no.txt"

# --- An interrupted run leaves nothing behind ---
# The input is a FIFO nobody writes to, so ced waits in the read with its
# output (a temporary file) already open; SIGTERM must remove it.
mkfifo "$T/slow.ply"
"$CED" detect "$T/slow.ply" --indices "$T/sig.txt" -q &
pid=$!
for _ in 1 2 3 4 5 6 7 8 9 10; do
  ls -A "$T" | grep -q '^\.sig.txt.tmp' && break
  sleep 0.2
done
check "temporary output exists while running" sh -c "ls -A '$T' | grep -q '^\.sig.txt.tmp'"
kill -TERM "$pid"
wait "$pid" 2> /dev/null
check "killed run: no temporary file" sh -c "! ls -A '$T' | grep -q '^\.sig.txt.tmp'"
check "killed run: no output" test ! -e "$T/sig.txt"
rm -f "$T/slow.ply"

# --- Voxel, radius auto, original indices ---
"$CED" detect "$sample" --voxel 0.02 --preset ced3d --indices "$T/v.txt" --indices-original "$T/vo.txt" -q
check "voxel run" test $? = 0
check "original indices within the input" awk '$1 >= 24574 { exit 1 }' "$T/vo.txt"
"$CED" detect "$sample" -m xyz --summary "$T/auto.json" -q
check "radius auto recorded" grep -q '"radius_auto": true' "$T/auto.json"

# --- eval: a given pair, transform files, PCL availability ---
"$CED" eval repeatability --source "$sample" --target "$sample" -d ced6d --trials 1 -q --csv "$T/pair.csv" > "$T/pair.txt"
check "pair: identity gives full repeatability" grep -q "^ced6d .* 1.000 " "$T/pair.txt"
check "pair: csv rows" test "$(wc -l < "$T/pair.csv")" = 2
# The real-pair protocol: voxelised to 1 cm, overlap, lift; a detector that
# cannot run on the clouds is "n/a" and the table goes on.
"$CED" eval repeatability --source "$sample" --target "$sample" -d ced6d -d 'xyz:0.2,intensity:0.1' -d random \
  --csv "$T/pair_na.csv" > "$T/pair_na.txt" 2> "$T/pair_na.err"
check "pair: voxel 0.01 by default, epsilon 2 cm" grep -q "voxel 0.01, resolution 0.01, radius 0.05, epsilon 0.02" \
  "$T/pair_na.err"
check "pair: every point in the overlap" grep -q "(100%) lie in the overlap" "$T/pair_na.err"
check "pair: lift column" grep -q "^detector .* lift " "$T/pair_na.txt"
check "pair: n/a row" grep -q "^xyz:0.2,intensity:0.1 *pair *n/a" "$T/pair_na.txt"
check "pair: n/a says why" grep -q "xyz:0.2,intensity:0.1 on pair: n/a: .*needs field 'intensity'" "$T/pair_na.err"
check "pair: the table goes on" grep -q "^random " "$T/pair_na.txt"
check "pair: ced6d far above random" awk '$1 == "ced6d" { exit !($8 > 3) }' "$T/pair_na.txt"
check "pair: csv n/a row" grep -q '^"xyz:0.2,intensity:0.1","pair",,,,,n/a' "$T/pair_na.csv"
# A row's chance (few draws: noisy) is drawn for its own counts, whatever came before it.
chance_of_ced3d() {
  "$CED" eval repeatability --source "$sample" --target "$sample" "$@" -d ced3d --random-draws 2 -q |
    awk '$1 == "ced3d" { print $7, $8 }'
}
check "pair: a row's chance does not depend on the rows before it" test "$(chance_of_ced3d)" = \
  "$(chance_of_ced3d -d ced6d -d random)"
"$CED" eval repeatability "$sample" -d 'xyz:0.2,intensity:0.1' -d ced6d --trials 1 --noise 0 > "$T/syn_na.txt" 2> "$T/syn_na.err"
check "synthetic: n/a row" grep -q "^xyz:0.2,intensity:0.1 *0.00 *n/a" "$T/syn_na.txt"
check "synthetic: the table goes on" grep -q "^ced6d *0.00 " "$T/syn_na.txt"
"$CED" eval repeatability --source "$sample" --target "$sample" -d ced6d --epsilon 0.5 > /dev/null 2> "$T/eps.err"
check "pair: epsilon below the ground truth's error warns" grep -q "below the ground truth's error" "$T/eps.err"
"$CED" eval repeatability --source "$sample" --target "$sample" -d ced6d --counts 20 > /dev/null 2> "$T/few.err"
check "pair: fewer than 50 in the overlap warns" grep -q "only 20 keypoints lie in the overlap" "$T/few.err"
expect_exit 2 "apply to given pairs" "pair options without a pair" -- eval repeatability "$sample" --voxel 0.02
expect_exit 2 "random-draws must be" "random draws" -- eval repeatability --source "$sample" --target "$sample" \
  --random-draws 0
# A sweep: one detector a setting, in order (the last list fastest).
"$CED" eval repeatability "$sample" -d 'xyz:{0.1,0.3},rgb:{0.1,0.5}' --trials 1 --noise 0.5 -q > "$T/sweep.txt"
check "sweep: four settings in order" test "$(awk 'NR > 1 { printf "%s;", $1 }' "$T/sweep.txt")" = \
  "xyz:0.1,rgb:0.1;xyz:0.1,rgb:0.5;xyz:0.3,rgb:0.1;xyz:0.3,rgb:0.5;"
check "sweep: higher thresholds, fewer keypoints" awk 'NR == 2 { a = $3 } NR == 5 { b = $3 } END { exit !(b < a) }' \
  "$T/sweep.txt"
expect_exit 2 "unbalanced braces" "sweep: unbalanced" -- eval repeatability "$sample" -d 'xyz:{0.1,0.2'
expect_exit 2 "empty value" "sweep: empty value" -- eval repeatability "$sample" -d 'xyz:{0.1,}'
expect_exit 2 "cannot be nested" "sweep: nested" -- eval repeatability "$sample" -d 'xyz:{0.1,{0.2}}'
# --counts: every detector at fixed keypoint counts (the N strongest; random N points).
"$CED" eval repeatability "$sample" -d ced6d -d random --counts 16,64 --trials 1 --noise 0.5 -q --csv "$T/counts.csv" \
  > "$T/counts.txt"
check "counts: detector@N rows in order" test "$(awk 'NR > 1 { printf "%s;", $1 }' "$T/counts.txt")" = \
  "ced6d@16;ced6d@64;random@16;random@64;"
check "counts: exactly N keypoints" awk 'NR > 1 { n = substr($1, index($1, "@") + 1); if ($3 != n ".0") exit 1 }' \
  "$T/counts.txt"
check "counts: csv names them" grep -q '^"ced6d@64",' "$T/counts.csv"
expect_exit 2 "whole numbers from 1" "counts: zero" -- eval repeatability "$sample" --counts 0,64
expect_exit 2 "whole numbers from 1" "counts: fraction" -- eval repeatability "$sample" --counts 6.5
expect_exit 2 "counts" "counts: not a number" -- eval repeatability "$sample" --counts 64,x
printf '# a quarter turn about z\n0 -1 0 1\n1 0 0 2\n0 0 1 3\n0 0 0 1\n' > "$T/T.txt"
"$CED" eval repeatability --source "$sample" --target "$sample" --transform "$T/T.txt" -d ced6d --trials 1 -q > "$T/pair2.txt"
check "pair: the transform is applied" grep -q "^ced6d .* 0.0[0-9][0-9] " "$T/pair2.txt"
printf '1 0 0 0\n0 1 0 0\n0 0 1 0\n' > "$T/short.txt"
expect_exit 1 "expected a 4x4 matrix (16 numbers, row by row), found 12" "eval: short matrix" -- \
  eval repeatability --source "$sample" --target "$sample" --transform "$T/short.txt" -d ced6d --csv "$T/bad.csv"
check "eval: no csv after an error" test ! -e "$T/bad.csv"
printf '2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n' > "$T/scale.txt"
expect_exit 1 "not a rotation" "eval: scaling matrix" -- \
  eval repeatability --source "$sample" --target "$sample" --transform "$T/scale.txt"
expect_exit 1 "cannot open the transform file" "eval: missing matrix" -- \
  eval repeatability --source "$sample" --target "$sample" --transform "$T/none.txt"
expect_exit 2 "--noise applies" "eval: noise with a pair" -- \
  eval repeatability --source "$sample" --target "$sample" --noise 0.5
expect_exit 2 "exactly one of INPUT" "eval: INPUT and a pair" -- eval repeatability "$sample" --source "$sample" --target "$sample"
expect_exit 2 "exactly one of INPUT" "eval: INPUT and --rgbd" -- eval repeatability "$sample" --rgbd "$T"
expect_exit 2 "go with --rgbd" "eval: --intrinsics without --rgbd" -- eval repeatability "$sample" --intrinsics "$T/k.json"
expect_exit 1 "cannot open the intrinsics file" "eval: rgbd without intrinsics" -- eval repeatability --rgbd "$T"
# --csv never over a file an --rgbd folder holds (checked before any file is read).
mkdir -p "$T/rg/color" "$T/rg/depth"
printf 'log\n' > "$T/rg/odometry.log"
printf 'jpg\n' > "$T/rg/color/00000.jpg"
printf 'png\n' > "$T/rg/depth/00000.png"
printf '{}\n' > "$T/rg/camera_primesense.json"
for c in repeatability registration; do
  for f in odometry.log color/00000.jpg depth/00000.png camera_primesense.json; do
    expect_exit 2 "never writes over a file it reads" "eval $c: --csv over --rgbd's $f" -- \
      eval "$c" --rgbd "$T/rg" -d random --csv "$T/rg/$f" -q
  done
done
check "eval: the --rgbd folder is intact" test "$(cat "$T/rg/odometry.log" "$T/rg/color/00000.jpg" "$T/rg/depth/00000.png" \
  "$T/rg/camera_primesense.json")" = "$(printf 'log\njpg\npng\n{}')"
if "$CED" eval repeatability "$sample" -d iss3d --trials 1 --noise 0 -q > /dev/null 2> "$T/pcl.err"; then
  expect_exit 2 "exactly one of INPUT" "registration: two modes" -- \
    eval registration "$sample" --rgbd "$T"
  expect_exit 1 "cannot open the intrinsics file" "registration: rgbd without intrinsics" -- \
    eval registration --rgbd "$T"
  # --counts and 3DMatch's recall (RMSE over the overlap) with the inlier ratio (#59).
  expect_exit 2 "--max-rmse must be > 0" "registration: --max-rmse 0" -- eval registration "$sample" --max-rmse 0
  "$CED" eval registration "$sample" -d ced3d -d random --counts 40,80 --trials 2 --iterations 2000 \
    --csv "$T/reg.csv" -q > "$T/reg.txt"
  check "registration: one row per detector at each count" \
    test "$(grep -c '^"ced3d@40"' "$T/reg.csv") $(grep -c '^"random@80"' "$T/reg.csv")" = "2 2"
  check "registration: the csv has rmse, recall and inlier ratio" \
    sh -c "head -1 '$T/reg.csv' | grep -q ',rmse_m,recall,inlier_ratio\$'"
  check "registration: recall is the RMSE below 0.2 m, the ratio inliers over matches" awk -F, \
    'NR > 1 { rec = ($14 != "inf" && $14 + 0 < 0.2); r = ($7 > 0 ? $8 / $7 : 0);
              if ($15 != rec || (r - $16 > 1e-4 || $16 - r > 1e-4)) bad = 1 } END { exit bad }' "$T/reg.csv"
  check "registration: the summary shows recall and ratio" grep -q "success   recall.*ratio" "$T/reg.txt"
else
  check "no PCL: says which component is missing" grep -q "needs ced's PCL component" "$T/pcl.err"
  expect_exit 2 "needs ced's PCL component" "no PCL: registration" -- eval registration "$sample"
fi

# --- Refinement: the robust presets refine, --no-refine keeps the NMS maxima ---
check "modalities: robust presets list --refine and the share" \
  sh -c "'$CED' modalities | grep -q '^robust6d.*-m rgb:0.5 --refine --keypoint-share 0.01'"
"$CED" detect "$sample" --preset robust6d --indices "$T/r6.txt" --summary "$T/r6.json" -q
"$CED" detect "$sample" -m xyz:0.2,scale=2.25,inner=1 -m rgb:0.5 --radius 0.05 --refine --keypoint-share 0.01 \
  --indices "$T/r6m.txt" -q
"$CED" detect "$sample" --preset robust6d --no-refine --indices "$T/r6n.txt" -q
check "refine: the preset is its specs with --refine and its share" cmp -s "$T/r6.txt" "$T/r6m.txt"
check "refine: --no-refine changes the keypoints" sh -c "! cmp -s '$T/r6.txt' '$T/r6n.txt'"
check "refine: the summary says so" grep -q '"refine": *true' "$T/r6.json"
printf '{"preset": "robust6d", "no-refine": true}' > "$T/norefine.json"
"$CED" detect "$sample" --config "$T/norefine.json" --indices "$T/r6c.txt" -q
check "refine: --config takes no-refine" cmp -s "$T/r6n.txt" "$T/r6c.txt"

echo "cli: $pass passed, $fail failed"
[ "$fail" = 0 ]

