#!/usr/bin/env bash
# Hostile input at the command line (issue #25): deep or odd --config files,
# bad option values, modality specs, images sizes, thresholds, evaluation
# settings and clouds too wide to write. Each is a clear error with its exit
# code (2 usage, 1 data or I/O), never a crash and never a partial output.
#   tests/cli_edges_test.sh path/to/ced path/to/tests/data
set -u
CED=$1
DATA=$2
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# shellcheck source=cli_support.sh
. "$(dirname "$0")/cli_support.sh"
sample=$DATA/apartment_mesh_214.ply
export TMPDIR=$T  # the work directories of the tiled cases (a failed merge keeps its own for --resume)

# repeat CHAR N: CHAR N times, no newline.
repeat() { head -c "$2" < /dev/zero | tr '\0' "$1"; }

# --- 1. --config nested 100,000 levels deep: refused before parsing ---
{ repeat '[' 100000; repeat ']' 100000; } > "$T/deep_array.json"
{ for _ in $(seq 2000); do printf '{"a":'; done; printf '1'; repeat '}' 2000; } > "$T/deep2k.json"
{ printf '{"preset": "ced3d", "radius": '; repeat '[' 100000; } > "$T/deep_open.json"
python_free_objects() {  # {"a":{"a":...1...}} N deep
  local n=$1
  { for ((i = 0; i < n; i += 1000)); do printf '{"a":%.0s' $(seq 1000); done; printf 1; repeat '}' "$n"; }
}
python_free_objects 100000 > "$T/deep_object.json"
for f in deep_array deep_object deep_open deep2k; do
  expect_exit 2 "nested more than 4 deep (line 1)" "config: $f.json" -- detect "$sample" --config "$T/$f.json" -q
done
{ printf 'radius = '; repeat '[' 100000; repeat ']' 100000; echo; } > "$T/deep_value.toml"
{ repeat '[' 100000; repeat ']' 100000; echo; } > "$T/deep_section.toml"
{ printf 'preset = "ced3d"\nradius = '; repeat '{' 100000; echo; } > "$T/deep_table.toml"
for f in deep_value deep_section deep_table; do
  expect_exit 2 "nested more than 4 deep" "config: $f.toml" -- detect "$sample" --config "$T/$f.toml" -q
done
expect_exit 2 "nested more than 4 deep (line 2)" "config: the line is named" -- \
  detect "$sample" --config "$T/deep_table.toml" -q
# Brackets in strings and comments do not count.
printf '{"preset": "ced3d", "indices": "%s/[[[[[{{{{{.txt"}\n' "$T" > "$T/strings.json"
"$CED" detect "$sample" --config "$T/strings.json" -q
check "config: brackets in a JSON string" test -s "$T/[[[[[{{{{{.txt"
printf '# [[[[[[[[[[ {{{{{{{{{{\npreset = "ced3d" # ]]]] [[[[[[\nindices = "%s/[[[[[[.txt"\n' "$T" > "$T/c.toml"
"$CED" detect "$sample" --config "$T/c.toml" -q
check "config: brackets in TOML comments and strings" test -s "$T/[[[[[[.txt"
printf '{"preset": "ced3d", "modality": ["xyz:0.2"], "radius": 0.05}\n' > "$T/flat.json"
check "config: a flat JSON config runs" sh -c "'$CED' detect '$sample' --config '$T/flat.json' -q > '$T/flat.txt'"
check "config: 118 keypoints" test "$(wc -l < "$T/flat.txt")" = 118
expect_exit 2 "larger than 1 MiB" "config: huge file" -- detect "$sample" --config /dev/zero

# --- 2. --config DIR, --config without a file, --config twice ---
mkdir "$T/confdir"
expect_exit 2 "'$T/confdir' is a directory" "config: a directory" -- detect "$sample" --config "$T/confdir" -q
expect_exit 2 "is a directory" "config: a directory (=)" -- detect "$sample" "--config=$T/confdir" -q
expect_exit 2 "cannot open" "config: missing" -- detect "$sample" --config "$T/missing.json" -q
expect_exit 2 "no file given" "config: ''" -- detect "$sample" --config '' -q
expect_exit 2 "no file given" "config: --config=" -- detect "$sample" --config= -q
expect_exit 2 "given twice" "config: twice" -- detect "$sample" --config "$T/flat.json" --config "$T/c.toml" -q
# A key given twice in one file: an error, not "the last wins" (JSON) or CLI11's bare message (TOML).
printf '{"preset": "ced3d", "radius": 0.05, "radius": 0.1}\n' > "$T/dup.json"
expect_exit 2 "dup.json: 'radius' is given twice" "config: a JSON key twice" -- detect "$sample" --config "$T/dup.json" -q
printf '{"preset": "ced3d", "modality": {"radius": 1, "radius": 2}, "radius": 0.05}\n' > "$T/nested.json"
expect_exit 2 "modality" "config: a key twice deeper is not a top-level duplicate" -- \
  detect "$sample" --config "$T/nested.json" -q
check "config: ... and is not called one" sh -c "! grep -q 'given twice' '$T/err'"
printf 'preset = "ced3d"\nradius = 0.05\nradius = 0.1\n' > "$T/dup.toml"
expect_exit 2 "dup.toml: 'radius' is given twice" "config: a TOML key twice" -- detect "$sample" --config "$T/dup.toml" -q

# --- 3. A flag's value is true or false ---
for v in '"yes"' '"no"' 2 '"on"' '[]' '[true, false]' '{}' null; do
  printf '{"preset": "ced3d", "quiet": %s}\n' "$v" > "$T/flag.json"
  expect_exit 2 "'quiet' is a flag: its value must be true or false" "config: quiet = $v" -- \
    detect "$sample" --config "$T/flag.json" --indices "$T/flag.txt"
done
check "config: no output after bad flags" test ! -e "$T/flag.txt"
printf 'preset = "ced3d"\nquiet = yes\n' > "$T/flag.toml"
expect_exit 2 "'quiet' is a flag" "config: TOML quiet = yes" -- detect "$sample" --config "$T/flag.toml"
# Even when the command line gives the flag too.
expect_exit 2 "'quiet' is a flag" "config: a bad flag value, the flag on the command line" -- \
  detect "$sample" --config "$T/flag.toml" -q
for v in true '"true"' 1 '"1"' '[true]'; do
  printf '{"preset": "ced3d", "quiet": %s, "indices": "%s/q.txt"}\n' "$v" "$T" > "$T/flag.json"
  "$CED" detect "$sample" --config "$T/flag.json" 2> "$T/err"
  check "config: quiet = $v is on" test $? = 0 -a ! -s "$T/err"
done
for v in false '"false"' 0; do
  printf '{"preset": "ced3d", "quiet": %s, "indices": "%s/q.txt"}\n' "$v" "$T" > "$T/flag.json"
  "$CED" detect "$sample" --config "$T/flag.json" 2> "$T/err"
  check "config: quiet = $v is off" test $? = 0 -a -s "$T/err"
done
printf 'preset = "ced3d"\nquiet\nindices = "%s/q.txt"\n' "$T" > "$T/bare.toml"
"$CED" detect "$sample" --config "$T/bare.toml" 2> "$T/err"
check "config: a bare TOML flag is on" test $? = 0 -a ! -s "$T/err"

# --- 4. An option without a value ---
printf 'preset = "ced3d"\nradius =\n' > "$T/empty.toml"
expect_exit 2 "'radius' has no value" "config: TOML radius =" -- detect "$sample" --config "$T/empty.toml" -q
printf 'preset = "ced3d"\nradius = ""\n' > "$T/empty2.toml"
expect_exit 2 "'radius' has no value" "config: TOML radius = \"\"" -- detect "$sample" --config "$T/empty2.toml" -q
printf '{"preset": "ced3d", "radius": ""}\n' > "$T/empty.json"
expect_exit 2 "'radius' has no value" "config: JSON radius \"\"" -- detect "$sample" --config "$T/empty.json" -q
printf '{"preset": "ced3d", "modality": []}\n' > "$T/empty2.json"
expect_exit 2 "'modality' has no value" "config: JSON modality []" -- detect "$sample" --config "$T/empty2.json" -q
printf '{"modality": ["xyz:0.2", ""]}\n' > "$T/empty3.json"
expect_exit 2 "'modality' has no value" "config: an empty value in a list" -- \
  detect "$sample" --config "$T/empty3.json" -q
# Also when the command line gives the option.
expect_exit 2 "'radius' has no value" "config: empty value, option on the command line" -- \
  detect "$sample" --config "$T/empty.toml" -r 0.05 -q

# --- 5. A modality's field given twice ---
expect_exit 2 "field given twice" "spec: intensity(red),field=green" -- \
  detect "$sample" -m 'intensity(red):0.05,field=green' -q
expect_exit 2 "field given twice" "spec: intensity(red),field=red" -- detect "$sample" -m 'intensity(red),field=red' -q
expect_exit 2 "lists field 'red' twice" "spec: bands(red,green,red)" -- detect "$sample" -m 'bands(red,green,red)' -q
expect_exit 2 "field given twice" "eval: spec" -- eval repeatability "$sample" -d 'intensity(red),field=green'

# --- 6. A missing field: the file's fields are listed, not those read ---
expect_exit 1 "needs field 'intensity', which .*apartment_mesh_214.ply does not have (its fields: red, green, blue)" \
  "missing field: the file's fields" -- detect "$sample" -m xyz:0.2 -m intensity:0.05 -q
expect_exit 1 "needs field 'nir'.*(its fields: red, green, blue)" "missing field: bands" -- \
  detect "$sample" -m 'bands(red,nir)' -q
printf 'x,y,z\n0,0,0\n1,0,0\n0,1,0\n' > "$T/xyz.csv"
expect_exit 1 "needs field 'red'.*(its fields: none besides x, y, z)" "missing field: no fields" -- \
  detect "$T/xyz.csv" -m xyz:0.2 -m rgb -q
printf 'x,y,z,scalar_intensity\n0,0,0,1\n1,0,0,3\n0,1,0,5\n' > "$T/cc.csv"
expect_exit 1 "(its fields: scalar_intensity); did you mean 'scalar_intensity'? Name it in the spec: intensity(scalar_intensity)" \
  "missing field: CloudCompare's scalar_ prefix is pointed to" -- detect "$T/cc.csv" -m xyz:0.2 -m intensity:0.05 -r 2 -q
"$CED" detect "$T/cc.csv" -m xyz:0.2 -m 'intensity(scalar_intensity):0.05' -r 2 -q > /dev/null
check "missing field: the named scalar_ field is read" test $? = 0
printf 'x,y,z,Intensity,nir\n0,0,0,1,2\n1,0,0,3,4\n0,1,0,5,6\n' > "$T/f.csv"
expect_exit 1 "(its fields: Intensity, nir)" "missing field: CSV" -- detect "$T/f.csv" -m lab -q
"$CED" detect "$T/f.csv" -m xyz:0.2 -m intensity:0.05 -r 2 -q > /dev/null
check "missing field: a field in another case is found" test $? = 0
expect_exit 1 "which .*apartment_mesh_214.ply does not have (its fields: red, green, blue)" "missing field: tiles" -- \
  detect "$sample" -m intensity:0.05 -r 0.05 --tile-size 1 -q
# Every field read (-o): the message was right already, and stays so.
expect_exit 1 "fields present: red, green, blue" "missing field: -o" -- \
  detect "$sample" -m intensity:0.05 -o "$T/x.ply" -q
check "missing field: no output" test ! -e "$T/x.ply"

# --- 6b. Options that would be ignored are usage errors ---
for opt in "--view top" "--png-size 100x80" "--png-color height" "--png-top"; do
  expect_exit 2 "${opt%% *} shapes the --png picture: give --png FILE" "without --png: $opt" -- \
    detect "$sample" --preset ced3d $opt -q
done
expect_exit 2 "this run's radius is the preset's 0.05" "radius-factor with a preset" -- \
  detect "$sample" --preset ced3d --radius-factor 3 -q
expect_exit 2 "this run's radius is '0.04'" "radius-factor with a radius" -- \
  detect "$sample" -m xyz:0.2 --radius 0.04 --radius-factor 3 -q
"$CED" detect "$sample" -m xyz:0.2 --radius auto --radius-factor 3 --indices "$T/rf.txt" -q
check "radius-factor with --radius auto runs" test -s "$T/rf.txt"

# --- 6b'. Two modalities that would write one saliency column: refused, not one column lost ---
expect_exit 2 "would both write the column 'saliency_xyz'" "saliency column clash: -o" -- \
  detect "$sample" -m xyz:0.2 -m xyz:0.3 -r 0.05 -o "$T/clash.ply" -q
check "saliency column clash: no output" test ! -e "$T/clash.ply"
expect_exit 2 "would both write the column 'saliency_bands_red'" "saliency column clash: --viewer" -- \
  detect "$sample" -m 'bands(red):0.1' -m 'bands(red):0.2' -r 0.05 --viewer "$T/clash.ply" -q
"$CED" detect "$sample" -m xyz:0.2 -m xyz:0.3 -r 0.05 --indices "$T/clash.txt" -q
check "saliency column clash: indices alone run" test -s "$T/clash.txt"

# --- 6c. A stray point far from georeferenced data costs precision: said ---
printf 'ply\nformat ascii 1.0\nelement vertex %s\nproperty double x\nproperty double y\nproperty double z\nend_header\n' \
  5 > "$T/geo.ply"
for i in 1 2 3 4 5; do echo "500000.$i 4000000.$i 100.$i" >> "$T/geo.ply"; done
sed 's/vertex 5/vertex 6/' "$T/geo.ply" > "$T/stray.ply" && echo "0 0 0" >> "$T/stray.ply"
"$CED" detect "$T/stray.ply" -m xyz:0.2 -r 0.5 -q > /dev/null 2> "$T/err"
check "stray point: detect warns" grep -q "points lie up to 4000000 m from the cloud's origin" "$T/err"
"$CED" convert "$T/stray.ply" "$T/w.ply" 2> "$T/err"
check "stray point: convert warns" grep -q "keep only about 0.24 m" "$T/err"
"$CED" detect "$T/geo.ply" -m xyz:0.2 -r 0.5 -q > /dev/null 2> "$T/err"
check "no stray point: detect says nothing" test ! -s "$T/err"
"$CED" convert "$T/geo.ply" "$T/w2.ply" 2> "$T/err"
check "no stray point: convert says nothing" test ! -s "$T/err"

# --- 7. --png-size is WIDTHxHEIGHT, nothing else ---
for s in 100x100junk 100x100x 100x100.5 ' 100x100' '+100x100' '100x 100' 100X100 100x -100x100 x100 \
  99999999999x100 100x100' '; do
  expect_exit 2 "png-size must be WIDTHxHEIGHT" "png-size '$s'" -- \
    detect "$sample" --preset ced3d --png "$T/x.png" --png-size "$s" -q
done
expect_exit 2 "png-size must be WIDTHxHEIGHT, 16..16384" "png-size too small" -- \
  detect "$sample" --preset ced3d --png "$T/x.png" --png-size 15x100 -q
check "png-size: no picture after errors" test ! -e "$T/x.png"
"$CED" detect "$sample" --preset ced3d --png "$T/ok.png" --png-size 100x80 -q
check "png-size 100x80" test "$(head -c 24 "$T/ok.png" | od -An -tu1 -j16 | tr -s ' ' | cut -d' ' -f2-9)" = \
  "0 0 0 100 0 0 0 80"

# --- 8. ced view --threshold: finite, >= 0, a saliency field of the cloud ---
"$CED" detect "$sample" --preset ced6d --viewer "$T/view.ply" -q
for t in xyz=-1 xyz=-0.001 xyz=nan xyz=inf xyz=-inf xyz=garbage xyz= xyz=1e999 'xyz=0.1 junk'; do
  expect_exit 2 "--threshold xyz" "view: --threshold $t" -- view "$T/view.ply" -o "$T/x.html" --threshold "$t"
done
expect_exit 2 "no saliency_nope field" "view: unknown name" -- view "$T/view.ply" -o "$T/x.html" --threshold nope=1
expect_exit 2 "given twice" "view: a name twice" -- \
  view "$T/view.ply" -o "$T/x.html" --threshold xyz=0.1 --threshold xyz=0.2
expect_exit 2 "NAME=VALUE" "view: no name" -- view "$T/view.ply" -o "$T/x.html" --threshold =1
check "view: no page after errors" test ! -e "$T/x.html"
"$CED" view "$T/view.ply" -o "$T/ok.html" --threshold xyz=0 --threshold rgb=0.1
check "view: threshold 0 is fine" grep -q '"threshold":0.0[,}]' "$T/ok.html"

# --- 9. ced eval: finite numbers, no negative lengths or counts, no empty lists ---
rep() {
  expect_exit 2 "$1" "eval repeatability: $2" -- eval repeatability "$sample" -d random --trials 1 -q --csv "$T/e.csv" \
    "${@:3}"
}
rep "radius" "-r nan" -r nan
rep "radius" "-r inf" -r inf
rep "radius" "-r -1" -r -1
rep "min-neighbors" "-k -5" -k -5
rep "threads" "-j -1" -j -1
rep "resolution" "--resolution nan" --resolution nan
rep "resolution" "--resolution -1" --resolution -1
rep "max-translation" "--max-translation inf" --max-translation inf
rep "max-translation" "--max-translation nan" --max-translation nan
rep "epsilon" "--epsilon nan" --epsilon nan
rep "noise" "--noise ''" --noise ''
rep "noise" "--noise 0," --noise 0,
rep "noise" "--noise ,0" --noise ,0
rep "noise" "--noise 0,,1" --noise 0,,1
rep "noise" "--noise nan" --noise nan
rep "noise" "--noise -1" --noise -1
rep "noise" "--noise 0,inf" --noise 0,inf
rep "detector" "-d ''" -d ''
check "eval: no CSV after errors" test ! -e "$T/e.csv"
# (An empty value is refused as such before the pair is looked at.)
expect_exit 2 "noise: an empty value" "eval repeatability: --noise '' with a pair" -- \
  eval repeatability --source "$sample" --target "$sample" --noise '' -q
expect_exit 2 "noise applies to INPUT" "eval repeatability: --noise 0 with a pair" -- \
  eval repeatability --source "$sample" --target "$sample" --noise 0 -q
reg() {
  expect_exit 2 "$1" "eval registration: $2" -- eval registration "$sample" -d random --trials 1 -q --csv "$T/e.csv" \
    "${@:3}"
}
reg "radius" "-r nan" -r nan
reg "radius" "-r -1" -r -1
reg "min-neighbors" "-k -5" -k -5
reg "threads" "-j -1" -j -1
reg "noise" "--noise nan" --noise nan
reg "noise" "--noise inf" --noise inf
reg "resolution" "--resolution nan" --resolution nan
reg "voxel" "--voxel nan" --voxel nan
reg "max-translation" "--max-translation inf" --max-translation inf
reg "depth-max" "--depth-max nan" --depth-max nan
reg "depth-max" "--depth-max inf" --depth-max inf
reg "normal-radius" "--normal-radius inf" --normal-radius inf
reg "inlier-fraction" "--inlier-fraction nan" --inlier-fraction nan
reg "overlap" "--overlap nan" --overlap nan
reg "iterations" "--iterations 0" --iterations 0

# --- 10. More values per point than the readers accept: refused before writing ---
# A PLY of 65,536 properties (x, y, z and 65,533 more), the most ced reads;
# -o would add a saliency column.
{
  printf 'ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n'
  awk 'BEGIN { for (i = 0; i < 65533; i++) print "property uchar p" i }'
  echo end_header
  for p in "0 0 0" "1 0 0" "0 1 0" "0 0 1"; do
    awk -v p="$p" 'BEGIN { printf "%s", p; for (i = 0; i < 65533; i++) printf " 1"; print "" }'
  done
} > "$T/wide.ply"
check "wide: ced reads it" sh -c "'$CED' info '$T/wide.ply' | grep -q ': 4 points'"
# An empty LAS file: info names its fields with no range (not "inf .. -inf").
printf 'ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n' \
  > "$T/empty.ply"
"$CED" convert "$T/empty.ply" "$T/empty.las"
check "empty LAS: info says its fields have no values" \
  sh -c "'$CED' info '$T/empty.las' > '$T/info' && grep -q 'intensity (uint16) no values' '$T/info' && ! grep -q inf '$T/info'"
for ext in ply pcd csv; do
  expect_exit 1 "wide_out.$ext': cannot write .*65537 values per point.*at most 65536" "wide: -o .$ext" -- \
    detect "$T/wide.ply" -m xyz:0.2 -r 2 -k 1 -o "$T/wide_out.$ext" -q
  check "wide: no .$ext left" test ! -e "$T/wide_out.$ext"
done
expect_exit 1 "wide_v.ply': cannot write PLY: .*at most 65536" "wide: --viewer" -- detect "$T/wide.ply" -m xyz:0.2 -r 2 -k 1 --viewer "$T/wide_v.ply" -q
check "wide: no viewer cloud left" test ! -e "$T/wide_v.ply"
expect_exit 1 "cannot write PLY: 65537 values per point" "wide: -o in tiles" -- \
  detect "$T/wide.ply" -m xyz:0.2 -r 2 -k 1 --tile-size 10 -o "$T/wide_t.ply" -q
check "wide: no tiled output left" test ! -e "$T/wide_t.ply"
"$CED" convert "$T/wide.ply" "$T/wide.csv"
check "wide: 65,536 values convert" test $? = 0 -a -s "$T/wide.csv"

# --- 11. --max-keypoints: a count, the N strongest; in a config file too ---
expect_exit 2 "max-keypoints must be >= 0" "max-keypoints: negative" -- detect "$sample" --preset ced6d --max-keypoints -1 -q
expect_exit 2 "max-keypoints" "max-keypoints: not a number" -- detect "$sample" --preset ced6d --max-keypoints ten -q
"$CED" detect "$sample" --preset ced6d -q > "$T/all.txt"
"$CED" detect "$sample" --preset ced6d --max-keypoints 17 --indices "$T/top17.txt" -q
check "max-keypoints: 17 kept" test "$(wc -l < "$T/top17.txt")" = 17
check "max-keypoints: a subset of the keypoints" bash -c "[ -z \"\$(comm -23 <(sort '$T/top17.txt') <(sort '$T/all.txt'))\" ]"
"$CED" detect "$sample" --preset ced6d --max-keypoints 100000 --indices "$T/top_all.txt" -q
check "max-keypoints: more than there are keeps all" cmp -s "$T/top_all.txt" "$T/all.txt"
printf '{"preset": "ced6d", "max-keypoints": 17}\n' > "$T/top.json"
"$CED" detect "$sample" --config "$T/top.json" --indices "$T/top17c.txt" -q
check "max-keypoints: from --config" cmp -s "$T/top17c.txt" "$T/top17.txt"
"$CED" detect "$sample" --preset ced6d --max-keypoints 17 --tile-size 0.5 --indices "$T/top_t.txt" -q
check "max-keypoints: tiles keep the same 17" cmp -s "$T/top_t.txt" "$T/top17.txt"

# --- 12. --neighborhood and --search: parsed, checked, in a config file too ---
expect_exit 2 "K in neighbourhood" "neighborhood: K 0" -- detect "$sample" --preset ced6d --neighborhood knn:0 -q
expect_exit 2 "larger than max" "neighborhood: min > max" -- detect "$sample" --preset ced6d --neighborhood adaptive:8,min=0.2,max=0.1 -q
expect_exit 2 "must be radius, knn:K" "neighborhood: unknown kind" -- detect "$sample" --neighborhood ball -q
expect_exit 2 "search must be grid or cgal" "search: unknown" -- detect "$sample" --search octree -q
# knn without reach=: the tiles take a reach of ced's own, grown when short
"$CED" detect "$sample" --preset ced6d --neighborhood knn:8 --indices "$T/k8.txt" -q
"$CED" detect "$sample" --preset ced6d --neighborhood knn:8 --tile-size 0.5 --indices "$T/k8_t.txt" 2> "$T/k8_t.err"
check "neighborhood: knn without reach=, tiled = whole" cmp -s "$T/k8_t.txt" "$T/k8.txt"
check "neighborhood: knn without reach= says the reach it takes" grep -q "the tiles take reach=0.047" "$T/k8_t.err"
# A dense patch among sparse points: the reach from the mean density is short
falloff=$DATA/falloff_patch.ply
"$CED" detect "$falloff" --preset ced3d --neighborhood knn:16 --indices "$T/fo.txt" -q
"$CED" detect "$falloff" --preset ced3d --neighborhood knn:16 --tile-size 1 --work-dir "$T/fo_wd" \
  --indices "$T/fo_t.txt" 2> "$T/fo_t.err"
check "neighborhood: a short reach of ced's own grows, tiled = whole" cmp -s "$T/fo_t.txt" "$T/fo.txt"
check "neighborhood: the growth is said" grep -Eq "reach=0.74 was short for [0-9]+ tiles? \(their points reach up to 2.01\): those again with reach=2.1" "$T/fo_t.err"
check "neighborhood: the grown run leaves no work directory" test ! -e "$T/fo_wd"
# Tiles of 0.7: 61 of 64 are short. The test hook counts the tiles detected
# into a part: the 3 that passed, then the 61 short ones again (the 3 keep
# their parts). Detecting all 64 again would reach the 65th, which kills
# the process.
CED_TEST_KILL_AFTER_TILES=65 "$CED" detect "$falloff" --preset ced3d --neighborhood knn:16 --tile-size 0.7 \
  --work-dir "$T/fo_wd7" --indices "$T/fo_t7.txt" 2> "$T/fo_t7.err"
check "neighborhood: the tiles that passed are not detected again" grep -q "short for 61 tiles" "$T/fo_t7.err"
check "neighborhood: ... and the run is still the whole run" cmp -s "$T/fo_t7.txt" "$T/fo.txt"
check "neighborhood: ... and leaves no work directory (kept parts included)" test ! -e "$T/fo_wd7"
"$CED" plan "$falloff" --preset ced3d --neighborhood knn:16 --tile-size 1 -o "$T/fo_plan.json" -q
check "neighborhood: a plan records ced's own reach" grep -q '"neighborhood": *"knn:16,reach=0.74"' "$T/fo_plan.json"
check "neighborhood: ... and says it is ced's" grep -q '"reach_estimated": *true' "$T/fo_plan.json"
expect_exit 2 "reach must be" "neighborhood: reach=0" -- detect "$sample" --neighborhood knn:8,reach=0 --tile-size 0.5 -q
# knn with reach=: tiles equal the whole run, or a tile stops clearly,
# writing nothing and leaving no tile cache behind (a rerun would fail again)
"$CED" detect "$sample" --preset robust6d --neighborhood knn:12,reach=0.06 --indices "$T/kr.txt" -q
"$CED" detect "$sample" --preset robust6d --neighborhood knn:12,reach=0.06 --tile-size 0.4 --indices "$T/kr_t.txt" -q
check "neighborhood: knn with reach=, tiled = whole" cmp -s "$T/kr_t.txt" "$T/kr.txt"
expect_exit 1 "beyond the neighbourhood's reach" "neighborhood: reach too short" -- detect "$sample" --preset ced6d \
  --neighborhood knn:16,reach=0.02 --tile-size 0.5 --work-dir "$T/kr_wd" --indices "$T/kr_short.txt" -q
check "neighborhood: reach too short writes nothing" test ! -e "$T/kr_short.txt"
check "neighborhood: reach too short leaves no cache" test ! -e "$T/kr_wd"
"$CED" detect "$sample" --preset ced6d --neighborhood adaptive:12,scale=1.5,max=0.08 --indices "$T/ad.txt" -q
"$CED" detect "$sample" --preset ced6d --neighborhood adaptive:12,scale=1.5,max=0.08 --tile-size 0.5 --indices "$T/ad_t.txt" -q
check "neighborhood: adaptive with max, tiled = whole" cmp -s "$T/ad_t.txt" "$T/ad.txt"
"$CED" plan "$sample" --preset ced6d --neighborhood adaptive:12,scale=1.5,max=0.08 --search cgal --tile-size 0.5 -o "$T/ad_plan.json" -q
check "neighborhood: the plan records it" grep -q '"neighborhood": *"adaptive:12,scale=1.5,max=0.08"' "$T/ad_plan.json"
"$CED" detect "$sample" --preset ced6d --search cgal -q > "$T/cgal.txt"
check "search cgal: the grid's keypoints" cmp -s "$T/cgal.txt" "$T/all.txt"
"$CED" detect "$sample" --preset ced6d --neighborhood knn:16 --indices "$T/knn.txt" --summary "$T/knn.json" -q
check "neighborhood: in the summary" grep -q '"neighborhood": *"knn:16"' "$T/knn.json"
check "neighborhood: other keypoints than the ball" bash -c "! cmp -s '$T/knn.txt' '$T/all.txt'"
printf '{"preset": "ced6d", "neighborhood": "knn:16"}\n' > "$T/knn_conf.json"
"$CED" detect "$sample" --config "$T/knn_conf.json" --indices "$T/knn_c.txt" -q
check "neighborhood: from --config" cmp -s "$T/knn_c.txt" "$T/knn.txt"
# ced eval: --neighborhood for every ced detector, DETECTOR|SPEC for one
expect_exit 2 "K in neighbourhood" "eval: DETECTOR|knn:0" -- eval repeatability "$sample" -d 'ced3d|knn:0' -q
expect_exit 2 "applies to ced's detectors" "eval: random|SPEC" -- eval repeatability "$sample" -d 'random|knn:8' -q
expect_exit 2 "K in neighbourhood" "eval: --neighborhood knn:0" -- eval repeatability "$sample" --neighborhood knn:0 -q
expect_exit 2 "search must be grid or cgal" "eval: --search" -- eval repeatability "$sample" --search kd -q
numbers() { "$CED" eval repeatability "$sample" --trials 1 --noise 0.5 -q "$@" | tail -n 1 | awk '{print $2, $3, $4, $5}'; }  # not the name, nor the time
numbers -d 'ced3d|knn:16' > "$T/ev_bar.txt"
numbers -d ced3d --neighborhood knn:16 > "$T/ev_global.txt"
numbers -d ced3d > "$T/ev_ball.txt"
check "eval: DETECTOR|SPEC = --neighborhood SPEC" cmp -s "$T/ev_bar.txt" "$T/ev_global.txt"
check "eval: the neighbourhood changes the figures" bash -c "! cmp -s '$T/ev_bar.txt' '$T/ev_ball.txt'"

# --- The top-N protocol (--counts) on a hand-built pair ---
# A 48 x 48 lattice with five pyramids of different heights, and its copy
# moved by (1, 2, 3) m. Every coordinate is a multiple of 1/128 m, exact in
# float before and after the move, so the two clouds' saliencies are the same
# bits. At N, every detector gives N keypoints a cloud even when its threshold
# admits none (xyz:5), and all of them repeat; with a ground truth 3/128 m off
# (epsilon 1 cm, keypoints at least 5 cm apart) none can.
awk 'BEGIN {
  print "x,y,z"
  split("10 10 4 38 13 3 15 38 5 36 36 2 26 26 1", b, " ")
  for (i = 0; i < 48; i++) for (j = 0; j < 48; j++) {
    z = 0
    for (k = 1; k <= 15; k += 3) { d = (i < b[k] ? b[k] - i : i - b[k]) + (j < b[k+1] ? b[k+1] - j : j - b[k+1])
      h = b[k+2] - d; if (h > z) z = h }
    printf "%.7f,%.7f,%.7f\n", i / 128, j / 128, z / 128
  } }' > "$T/pyr.csv"
awk -F, 'NR == 1 {print; next} {printf "%.7f,%.7f,%.7f\n", $1 + 1, $2 + 2, $3 + 3}' "$T/pyr.csv" > "$T/pyr_moved.csv"
printf '1 0 0 1\n0 1 0 2\n0 0 1 3\n0 0 0 1\n' > "$T/pyr_T.txt"
printf '1 0 0 1.0234375\n0 1 0 2\n0 0 1 3\n0 0 0 1\n' > "$T/pyr_T_off.txt"
topn() {  # topn TRANSFORM CSV: the pair at N = 3 and 7, epsilon 1 cm
  "$CED" eval repeatability --source "$T/pyr.csv" --target "$T/pyr_moved.csv" --transform "$1" --voxel 0 \
    --resolution 0.01 --epsilon 1 --gt-error 0.001 -r 0.05 -d 'xyz:5' -d corner -d random --counts 3,7 -q --csv "$2"
}
topn "$T/pyr_T.txt" "$T/topn.csv" > /dev/null 2>&1
"$CED" eval repeatability --source "$T/pyr.csv" --target "$T/pyr_moved.csv" --transform "$T/pyr_T.txt" --voxel 0 \
  --resolution 0.01 --epsilon 1 --gt-error 0.001 -r 0.05 -d 'xyz:5' -q --csv "$T/natural.csv" > /dev/null 2>&1
check "top-N: xyz:5 has no natural keypoint" awk -F, 'NR == 2 {exit !($3 == 0)}' "$T/natural.csv"
check "top-N: N keypoints a cloud, all in the overlap, all repeated" awk -F, '
  NR > 1 && $1 ~ /xyz/ {rows++; split($1, a, "@"); n = a[2] + 0; if ($3 != n || $4 != n || $5 != n || $6 != n) bad++}
  END {exit !(rows == 2 && bad == 0)}' "$T/topn.csv"
# corner is 0 on the planes and creases: at most the maxima with a score.
check "top-N: corner's maxima all repeat" awk -F, '
  NR > 1 && $1 ~ /corner/ {rows++; split($1, a, "@"); if ($3 > a[2] + 0 || $3 < 3 || $3 != $4 || $3 != $6) bad++}
  END {exit !(rows == 2 && bad == 0)}' "$T/topn.csv"
check "top-N: random draws N" awk -F, 'NR > 1 && $1 ~ /random/ {rows++; split($1, a, "@"); if ($3 != a[2] + 0) bad++}
  END {exit !(rows == 2 && bad == 0)}' "$T/topn.csv"
topn "$T/pyr_T_off.txt" "$T/topn_off.csv" > /dev/null 2>&1
check "top-N: a ground truth 3/128 m off repeats none" awk -F, '
  NR > 1 && $1 !~ /random/ {rows++; if ($6 != 0) bad++} END {exit !(rows == 4 && bad == 0)}' "$T/topn_off.csv"

# --- An adversarial pass of 2026-12-05 ---
# A repeatable option takes one value an occurrence: not the input after it, nor after a --config key.
"$CED" detect "$sample" -m xyz:0.2 -m rgb:0.1 -r 0.05 -q > "$T/m_after.txt"
"$CED" detect -m xyz:0.2 -m rgb:0.1 "$sample" -r 0.05 -q > "$T/m_before.txt"
check "-m before the input: the same keypoints" cmp -s "$T/m_after.txt" "$T/m_before.txt"
printf 'radius = 0.05\nmodality = ["xyz:0.2", "rgb:0.1"]\n' > "$T/m_last.toml"
"$CED" detect "$sample" --config "$T/m_last.toml" -q > "$T/m_toml.txt"
check "--config: a modality key last keeps the input" cmp -s "$T/m_after.txt" "$T/m_toml.txt"
"$CED" eval repeatability -d ced3d "$sample" --trials 1 --noise 0 -q > "$T/d_before.txt"
check "eval -d before the input" grep -q "^ced3d " "$T/d_before.txt"
# Radii the float kernels cannot square (an NMS radius of 1e39 never finished), and NaN.
expect_exit 2 "must be a positive finite number, got 'nan'" "--nms-radius nan" -- detect "$sample" --nms-radius nan -q
expect_exit 2 "at most 1e30" "--nms-radius 1e39" -- detect "$sample" --preset ced3d --nms-radius 1e39 -q
expect_exit 2 "at most 1e30" "--radius 1e39" -- detect "$sample" -m xyz:0.2 -r 1e39 -q
expect_exit 2 "min must be a number from 0 to 1e30" "adaptive min=1e39" -- \
  detect "$sample" --preset ced3d --neighborhood 'adaptive:8,min=1e39,nms=own' -q

# Counts are decimal (CLI11 read 010 as octal 8, and 08 as an error); empty output paths are refused.
"$CED" detect "$sample" --preset ced6d --max-keypoints 010 -q > "$T/kp010.txt"
check "--max-keypoints 010 keeps 10" test "$(wc -l < "$T/kp010.txt")" = 10
"$CED" detect "$sample" --preset ced6d --max-keypoints 08 -q > "$T/kp08.txt"
check "--max-keypoints 08 keeps 8" test "$(wc -l < "$T/kp08.txt")" = 8
for opt in -o --indices --viewer --png --html --summary --indices-original; do
  expect_exit 2 ": an empty path: give a file name" "$opt ''" -- detect "$sample" --preset ced3d "$opt" "" -q
done

# Multispectral LiDAR channels merged into one cloud (issue #60): three
# channels with different points; the merged LAS has one intensity a
# channel, which bands() reads; the rest are clear errors.
for ch in 1:0 2:300 3:600; do
  k=${ch%%:*} off=${ch##*:}
  { printf 'ply\nformat ascii 1.0\nelement vertex 400\nproperty double x\nproperty double y\nproperty double z\n'
    printf 'property ushort intensity\nend_header\n'
    # channel k's points shifted by k mm: each reference point's partner is 1-2 mm away
    awk -v k="$k" -v off="$off" 'BEGIN { for (i = 0; i < 400; i++) { x = i % 20; y = int(i / 20)
      printf "%.3f %.3f 0 %d\n", x + k / 1000, y + k / 1000, 1000 + off + (x * 37 + y * 11) % 200 } }'
  } > "$T/ch$k.ply"
done
"$CED" convert "$T/ch1.ply" "$T/merged.las" --merge-channels "$T/ch2.ply,$T/ch3.ply" --merge-radius 0.01 2> "$T/err"
check "merge: succeeds" test -s "$T/merged.las"
check "merge: says how many found a partner" grep -q "ch2: 400 of 400 points (100.0 %); ch3: 400 of 400" "$T/err"
"$CED" info "$T/merged.las" > "$T/info"
check "merge: intensity_ch2 read back" grep -q "intensity_ch2 (uint16) 1300 .. 1499" "$T/info"
check "merge: intensity_ch3 read back" grep -q "intensity_ch3 (uint16) 1600 .. 1799" "$T/info"
"$CED" detect "$T/merged.las" -r 2.5 -m 'bands(intensity*):0.01,range=auto' -q > "$T/kp_merged.txt"
check "merge: bands(intensity*) detects" test -s "$T/kp_merged.txt"
"$CED" convert "$T/ch1.ply" "$T/m2.ply" --merge-channels "$T/ch2.ply" --merge-radius 0.0015 2> "$T/err"
check "merge: a small radius drops points and says so" grep -q "point(s) without a partner in every channel dropped" "$T/err"
"$CED" convert "$T/ch1.ply" "$T/m3.ply" --merge-channels "$T/ch2.ply" --merge-radius 0.0015 --merge-missing nan 2> "$T/err"
check "merge: nan keeps every point" grep -q "element vertex 400" "$T/m3.ply"
expect_exit 2 "go with --merge-channels" "merge options alone" -- convert "$T/ch1.ply" "$T/m4.ply" --merge-radius 1
expect_exit 2 "must be drop or nan" "merge-missing bad" -- convert "$T/ch1.ply" "$T/m4.ply" --merge-channels "$T/ch2.ply" --merge-missing keep
expect_exit 2 "--merge-radius" "merge-radius bad" -- convert "$T/ch1.ply" "$T/m4.ply" --merge-channels "$T/ch2.ply" --merge-radius -1
expect_exit 1 "has no field 'nir'" "merge a missing field" -- convert "$T/ch1.ply" "$T/m4.ply" --merge-channels "$T/ch2.ply" --merge-fields nir
check "merge: no half-written output" test ! -e "$T/m4.ply"
expect_exit 2 "" "merge into a channel" -- convert "$T/ch1.ply" "$T/ch2.ply" --merge-channels "$T/ch2.ply"
# Channels in different coordinate systems (one LAS file has WKT, the other none) are refused with both names.
expect_exit 1 "is in coordinate system 'none', the input .*file_with_both_wkt_and_geotiff_vlrs.las in 'NAD83_2011_Nebraska_ft'" \
  "merge across coordinate systems" -- convert "$DATA/file_with_both_wkt_and_geotiff_vlrs.las" "$T/m5.las" --merge-channels "$DATA/simple.las"
check "merge across coordinate systems: no output" test ! -e "$T/m5.las"

# A band glob that matches nothing names the glob, the file and its fields.
expect_exit 1 "'swir\*' matches no field of .*merged.las (its fields: .*intensity_ch2" "glob matches nothing" -- \
  detect "$T/merged.las" -r 2.5 -m 'bands(swir*):0.1' -q

# --progress json: one JSON object a line, a stage's start, and the end; -q silences it; a bad mode is a usage error.
"$CED" detect "$sample" --preset ced6d --progress json --indices "$T/prog.txt" 2> "$T/prog.err"
check "progress json: the detecting stage with its points" grep -q '^{"event":"progress","stage":"detecting","fraction":0.0000,"elapsed_s":[0-9.]*,"points":[0-9]*,' "$T/prog.err"
check "progress json: the end" grep -q '^{"event":"done","elapsed_s":[0-9.]*}$' "$T/prog.err"
check "progress json: every line an object" test "$(grep -c '^{"event":"[a-z]*",.*}$' "$T/prog.err")" = "$(grep -c '^{' "$T/prog.err")"
"$CED" detect "$sample" --preset ced6d --progress json -q --indices "$T/prog.txt" 2> "$T/prog_q.err"
check "progress json under -q: nothing" test ! -s "$T/prog_q.err"
expect_exit 2 "--progress" "progress bad mode" -- detect "$sample" --progress fancy --indices "$T/prog.txt"
# A tiled run reports its passes.
"$CED" detect "$sample" --preset ced6d --tile-size 0.7 --progress json --indices "$T/prog_t.txt" 2> "$T/prog_t.err"
check "progress json: a tiled run's passes" grep -q '^{"event":"progress","stage":"[^"]*pass' "$T/prog_t.err"
check "progress json: a tiled run's tiles" grep -q '^{"event":"tiles","done":[0-9]*,"tiles":[0-9]*,"tiles_elapsed_s":' "$T/prog_t.err"

# Several inputs are one cloud (#61): each keypoint's file and index, a global
# numbering, the fields in -o; a folder and an @list name the same files.
mkdir -p "$T/cat" "$T/cat2"
cp "$DATA/apartment_mesh_213.ply" "$T/cat/a.ply"
cp "$DATA/apartment_mesh_214.ply" "$T/cat/b.ply"
printf '# two rooms\n../cat/a.ply\n\n../cat/b.ply\n' > "$T/cat2/rooms.list"
"$CED" detect "$T/cat/a.ply" "$T/cat/b.ply" --preset ced6d --indices "$T/cat_i.txt" --indices-global "$T/cat_g.txt" \
  -o "$T/cat_kp.ply" -q
check "catalogue: 'file_id index' lines" test "$(grep -cE '^[01] [0-9]+$' "$T/cat_i.txt")" = "$(wc -l < "$T/cat_i.txt")"
check "catalogue: keypoints in both files" test "$(grep -c '^0 ' "$T/cat_i.txt")" -gt 0 -a "$(grep -c '^1 ' "$T/cat_i.txt")" -gt 0
n0=$("$CED" info "$T/cat/a.ply" 2>&1 | grep -oE '[0-9]+ points' | head -1 | grep -oE '[0-9]+')
check "catalogue: the global numbering is file after file" test "$(awk -v n0="$n0" '{print ($1 == 0 ? $2 : n0 + $2)}' "$T/cat_i.txt" | cmp - "$T/cat_g.txt" && echo same)" = same
check "catalogue: -o carries file_id and file_index" grep -qa 'property uint file_index' "$T/cat_kp.ply"
"$CED" detect "$T/cat/a.ply" "$T/cat/b.ply" --preset ced6d -q > "$T/cat_stdout.txt"
check "catalogue: without outputs, stdout has what --indices writes" cmp -s "$T/cat_i.txt" "$T/cat_stdout.txt"
check "catalogue: -o alone" "$CED" detect "$T/cat/a.ply" "$T/cat/b.ply" --preset ced6d -o "$T/cat_kp_only.ply" -q
check "catalogue: -o alone, the same keypoints" cmp -s "$T/cat_kp.ply" "$T/cat_kp_only.ply"
"$CED" detect "$T/cat" --preset ced6d --indices "$T/cat_dir.txt" -q
check "catalogue: a folder is its files by name" cmp -s "$T/cat_i.txt" "$T/cat_dir.txt"
"$CED" detect "@$T/cat2/rooms.list" --preset ced6d --indices "$T/cat_list.txt" -q
check "catalogue: an @list, relative to its folder" cmp -s "$T/cat_i.txt" "$T/cat_list.txt"
mkdir -p "$T/per_file"
"$CED" detect "$T/cat" --preset ced6d --indices-per-file "$T/per_file" -q > "$T/per_file_stdout.txt"
check "catalogue: --indices-per-file, one file an input" test "$(ls "$T/per_file" | tr '\n' ' ')" = "a.ply.txt b.ply.txt "
check "catalogue: --indices-per-file, each file's keypoints" cmp -s "$T/per_file/b.ply.txt" <(awk '$1 == 1 {print $2}' "$T/cat_i.txt")
check "catalogue: --indices-per-file, nothing on stdout" test ! -s "$T/per_file_stdout.txt"
expect_exit 2 "goes with several inputs" "--indices-per-file with one input" -- \
  detect "$T/cat/a.ply" --preset ced6d --indices-per-file "$T/per_file"
expect_exit 2 "is not a folder" "--indices-per-file not a folder" -- detect "$T/cat" --preset ced6d --indices-per-file "$T/none"
expect_exit 1 "named twice" "catalogue: a file twice" -- detect "$T/cat/a.ply" "$T/cat" --preset ced6d --indices "$T/cat_x.txt" -q
cp "$T/cat/a.ply" "$T/cat2/copy.ply"
expect_exit 1 "same bytes as" "catalogue: a copy of a file" -- detect "$T/cat" "$T/cat2/copy.ply" --preset ced6d --indices "$T/cat_x.txt" -q
expect_exit 1 "no such file or folder" "catalogue: a missing file" -- detect "$T/cat/a.ply" "$T/cat/none.ply" --indices "$T/cat_x.txt" -q
expect_exit 1 "coordinate system" "catalogue: two coordinate systems" -- \
  detect "$DATA/simple.las" "$DATA/file_with_both_wkt_and_geotiff_vlrs.las" -r 5 -m xyz:0.2 --indices "$T/cat_x.txt" -q
expect_exit 2 "give several files as a folder or @LIST" "catalogue: tiles over several inputs" -- \
  detect "$T/cat/a.ply" "$T/cat/b.ply" --preset ced6d --tile-size 1 --indices "$T/cat_x.txt" -q
check "catalogue errors: no output" test ! -e "$T/cat_x.txt"
# --origin: positions relative to a given point; the reader's own origin gives the same run; tiles refuse it.
own=$("$CED" info "$DATA/autzen_trim.las" | sed -n 's/^origin: \([^ ]*\) \([^ ]*\) \([^ ]*\) .*/\1,\2,\3/p')
"$CED" detect "$DATA/autzen_trim.las" -r 5 -m xyz:0.2 --indices "$T/org_a.txt" -q
"$CED" detect "$DATA/autzen_trim.las" -r 5 -m xyz:0.2 --origin "$own" --indices "$T/org_b.txt" -q
check "origin: the reader's own gives the same keypoints ($own)" cmp -s "$T/org_a.txt" "$T/org_b.txt"
expect_exit 2 "give X,Y,Z" "origin: two numbers" -- detect "$sample" --preset ced6d --origin 1,2 --indices "$T/org_x.txt"
expect_exit 2 "is not a finite number" "origin: nan" -- detect "$sample" --preset ced6d --origin 1,nan,2 --indices "$T/org_x.txt"
expect_exit 2 "whole-cloud runs" "origin: tiles" -- detect "$sample" --preset ced6d --origin 0,0,0 --tile-size 1 --indices "$T/org_x.txt"
# ced info lists a folder's files; ced convert joins the files of an @list into one.
"$CED" info "$T/cat" > "$T/cat_info.txt"
check "info: a folder's files" grep -q "file 1: .*b.ply: [0-9]* points" "$T/cat_info.txt"
"$CED" convert "@$T/cat2/rooms.list" "$T/joined.ply" 2> /dev/null
check "convert: an @list joined into one file" test "$("$CED" info "$T/joined.ply" | head -1 | grep -oE '[0-9]+ points')" = \
  "$(grep -oE '^[^ ]+: [0-9]+ points' "$T/cat_info.txt" | grep -oE '[0-9]+ points')"
expect_exit 2 "" "convert: into one of its inputs" -- convert "$T/cat" "$T/cat/a.ply"

echo "cli_edges: $pass passed, $fail failed"
[ "$fail" = 0 ]
