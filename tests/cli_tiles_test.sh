#!/usr/bin/env bash
# End-to-end tests of clouds cut into tiles: `ced detect --tile-size` and
# `--memory-limit` give the whole-cloud outputs byte for byte, so do
# `ced plan` + `ced detect --plan --tile` + `ced merge`, a killed run finished
# with --resume, and `mpirun ced-mpi` on 1, 2 and 3 ranks; bad input is refused.
#   tests/cli_tiles_test.sh path/to/ced path/to/gen_cloud path/to/tests/data [path/to/ced-mpi]
set -u
CED=$1
GEN=$2
DATA=$3
MPI=${4:-}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# shellcheck source=cli_support.sh
. "$(dirname "$0")/cli_support.sh"
export TMPDIR=$T  # default work directories land here too

# Rooms, georeferenced, 16-bit colour holding 8-bit values: a million
# points for the whole runs' checks and MPI, 200,000 for the many others.
"$GEN" 1000000 42 "$T/big.las"
"$GEN" 200000 43 "$T/mid.las"
check "generated the clouds" test -s "$T/big.las" -a -s "$T/mid.las"
same_outputs() {  # same_outputs NAME PREFIX [WHOLE]: PREFIX.txt, PREFIX_o.txt, PREFIX.las equal WHOLE's (whole)
  local w=${3:-whole}
  check "$1: indices" cmp -s "$T/$w.txt" "$2.txt"
  check "$1: original indices" cmp -s "$T/${w}_o.txt" "$2_o.txt"
  check "$1: keypoint cloud" cmp -s "$T/$w.las" "$2.las"
}
run_tiles_and_merge() {  # run_tiles_and_merge PLAN NAME: every tile of PLAN (messages in NAME_err), merged into NAME.*
  : > "$T/$2_err"
  for id in $(tr -d ' \n' < "$1" | grep -o '"tiles":\[.*\]' | grep -o '\[[0-9]*,' | tr -d '[,'); do
    "$CED" detect --plan "$1" --tile "$id" -o "$T/$2_part_$id.cedpart" 2>> "$T/$2_err" || echo "$2: tile $id failed"
  done
  "$CED" merge "$1" "$T/$2"_part_*.cedpart --indices "$T/$2.txt" --indices-original "$T/$2_o.txt" -o "$T/$2.las" -q
}
for c in big mid; do
  "$CED" detect "$T/$c.las" --preset ced6d --indices "$T/${c}_whole.txt" --indices-original "$T/${c}_whole_o.txt" \
    -o "$T/${c}_whole.las" -q
done
n_whole=$(wc -l < "$T/big_whole.txt")
check "the whole cloud has keypoints" test "$n_whole" -gt 1000

# --- One process, a tile cache ---
for size in 3 0.8; do
  c=big
  [ $size = 0.8 ] && c=mid
  "$CED" detect "$T/$c.las" --preset ced6d --tile-size $size --indices "$T/t$size.txt" \
    --indices-original "$T/t${size}_o.txt" -o "$T/t$size.las" --summary "$T/t$size.json" 2> "$T/err"
  check "--tile-size $size exit 0" test $? = 0
  same_outputs "--tile-size $size" "$T/t$size" ${c}_whole
  check "--tile-size $size reports tiles" grep -q "tiles of $size" "$T/err"
  check "--tile-size $size shows tiles done" grep -q "tile [0-9]*/[0-9]* done; .* about .* left" "$T/err"
  check "--tile-size $size summary counts" grep -q "\"keypoints\": $(wc -l < "$T/${c}_whole.txt")" "$T/t$size.json"
done
check "no work directory left" test -z "$(ls -d "$T"/ced-tiles-* 2> /dev/null)"
# Cache buffers of a few records: each tile's is written out when full, by
# the thread that codes it, and all are flushed and released every chunk.
CED_TEST_CACHE_BUDGET=3000 "$CED" detect "$T/mid.las" --preset ced6d --tile-size 0.8 --threads 2 \
  --indices "$T/tb.txt" --indices-original "$T/tb_o.txt" -o "$T/tb.las" -q
check "small cache buffers exit 0" test $? = 0
same_outputs "small cache buffers" "$T/tb" mid_whole
"$CED" detect "$T/mid.las" --preset ced6d --memory-limit 240M --indices "$T/m.txt" --indices-original "$T/m_o.txt" \
  -o "$T/m.las" -q
check "--memory-limit exit 0" test $? = 0
same_outputs "--memory-limit" "$T/m" mid_whole
# Keypoint clouds in every format, written as the merge streams.
for ext in ply pcd csv; do
  "$CED" detect "$T/mid.las" --preset ced6d -o "$T/mid_whole.$ext" -q
  "$CED" detect "$T/mid.las" --preset ced6d --tile-size 1.5 -o "$T/mt.$ext" -q
  check "--tile-size: keypoint cloud as .$ext" cmp -s "$T/mid_whole.$ext" "$T/mt.$ext"
done
# A binary PLY input with every field of the LAS file (intensity, gps_time,
# nir, ...): the tiles carry only the colour, and the merge fetches the
# keypoints' records from the input; the outputs are the whole run's.
"$CED" convert "$T/mid.las" "$T/mid.ply"
for ext in ply las; do
  "$CED" detect "$T/mid.ply" --preset ced6d -o "$T/pw.$ext" --indices-original "$T/pw_o.txt" -q
  "$CED" detect "$T/mid.ply" --preset ced6d --tile-size 1.5 -o "$T/pt.$ext" --indices-original "$T/pt_o.txt" -q
  check "PLY input with extra fields, tiled: keypoint cloud as .$ext" cmp -s "$T/pw.$ext" "$T/pt.$ext"
  check "PLY input with extra fields, tiled: original indices" cmp -s "$T/pw_o.txt" "$T/pt_o.txt"
done
# Another format, and other modalities (PLY is read whole, then tiled).
sample=$DATA/apartment_mesh_214.ply
"$CED" detect "$sample" -m xyz:0.2 -m lab:0.1 --radius 0.05 --indices "$T/s.txt" -q
"$CED" detect "$sample" -m xyz:0.2 -m lab:0.1 --radius 0.05 --indices "$T/st.txt" --tile-size 0.7 -q 2> /dev/null
check "PLY sample, xyz + lab, tiled" cmp -s "$T/s.txt" "$T/st.txt"

# --- LAZ: the same keypoints as its LAS twin, whole, tiled (the chunks
# decoded as the passes reach them), in a plan's tiles, and under ced-mpi ---
laz=$DATA/autzen_trim.laz
lazargs=(--preset ced6d --radius 6)
"$CED" detect "$DATA/autzen_trim.las" "${lazargs[@]}" --indices "$T/laz_whole.txt" \
  --indices-original "$T/laz_whole_o.txt" -o "$T/laz_whole.las" -q
check "LAS twin has keypoints" test "$(wc -l < "$T/laz_whole.txt")" -gt 1000
"$CED" detect "$laz" "${lazargs[@]}" --indices "$T/lz.txt" --indices-original "$T/lz_o.txt" -o "$T/lz.las" -q
same_outputs "LAZ whole" "$T/lz" laz_whole
"$CED" detect "$laz" "${lazargs[@]}" --tile-size 250 --indices "$T/lzt.txt" --indices-original "$T/lzt_o.txt" \
  -o "$T/lzt.las" -q
same_outputs "LAZ --tile-size" "$T/lzt" laz_whole
"$CED" plan "$laz" "${lazargs[@]}" --tile-size 250 -o "$T/lzplan.json" 2> "$T/lzplan_err"
check "LAZ: ced plan records the file's runs" grep -q "3 runs (LAZ chunks" "$T/lzplan_err"
run_tiles_and_merge "$T/lzplan.json" lzp
same_outputs "LAZ plan + tiles + merge" "$T/lzp" laz_whole
# Each tile decodes only the chunks near it: 1 or 2 of the 3 (flight-line order).
check "LAZ: every tile reads only the runs near it" \
  test "$(grep -c "[12] of the file's 3 runs" "$T/lzp_err")" = "$(grep -c '^ced: tile' "$T/lzp_err")"
if [ -n "$MPI" ] && command -v mpirun > /dev/null; then
  mpirun --allow-run-as-root --oversubscribe -np 2 "$MPI" detect "$laz" "${lazargs[@]}" --tile-size 250 \
    --indices "$T/lzm.txt" --indices-original "$T/lzm_o.txt" -o "$T/lzm.las" -q
  same_outputs "LAZ ced-mpi -np 2" "$T/lzm" laz_whole
fi
# COPC: a plan's tiles read only the octree nodes near them, and give the
# whole run's outputs on the file, and on the same points converted to LAS.
copc=$DATA/1.2-with-color.copc.laz
copcargs=(--preset ced6d --radius 60)
"$CED" detect "$copc" "${copcargs[@]}" --indices "$T/copc_whole.txt" --indices-original "$T/copc_whole_o.txt" \
  -o "$T/copc_whole.las" -q
"$CED" convert "$copc" "$T/copc_as.las"
"$CED" detect "$T/copc_as.las" "${copcargs[@]}" --indices "$T/copc_las.txt" -q
check "COPC whole: the keypoints of the same points as LAS" cmp -s "$T/copc_whole.txt" "$T/copc_las.txt"
"$CED" plan "$copc" "${copcargs[@]}" --tile-size 800 -o "$T/copcplan.json" -q
run_tiles_and_merge "$T/copcplan.json" copcp
same_outputs "COPC plan + tiles (by its index) + merge" "$T/copcp" copc_whole
check "COPC tiles are read through the index" grep -q "through the file's COPC index" "$T/copcp_err"
check "COPC: ced info says so" sh -c "'$CED' info '$copc' | grep -q 'point format 7, COPC'"
check "COPC: ced plan plans from the index" grep -q '"indexed": true' "$T/copcplan.json"
"$CED" plan "$copc" "${copcargs[@]}" --tile-size 800 --scan -o "$T/copcscan.json" 2> "$T/copcscan_err"
check "COPC: ced plan --scan passes over the points" sh -c "! grep -q indexed '$T/copcscan.json'"
"$CED" plan "$copc" "${copcargs[@]}" --tile-size 800 -o "$T/copcplan2.json" 2> "$T/copcplan_err"
check "COPC: ced plan says its counts are estimates" grep -q "COPC index and header, without a pass" "$T/copcplan_err"
check "COPC tiles decode part of the file" \
  test "$(grep -o '([0-9]* decoded' "$T/copcp_err" | tr -d '( decoded' | sort -n | head -1)" -lt 1065
# LAZ out: the keypoint cloud as LAZ, whole and merged from tiles, the same bytes.
"$CED" detect "$laz" "${lazargs[@]}" -o "$T/lzw.laz" -q
"$CED" detect "$laz" "${lazargs[@]}" --tile-size 250 -o "$T/lzwt.laz" -q
check "LAZ out: tiled as whole" cmp -s "$T/lzw.laz" "$T/lzwt.laz"
check "LAZ out: the keypoints" sh -c "'$CED' info '$T/lzw.laz' | grep -q \"^$T/lzw.laz: $(wc -l < "$T/laz_whole.txt") points (LAZ 1.2\""
# COPC written by ced: its plan's tiles, read through its index, give its
# whole run's outputs; keypoints out as COPC, whole and tiled, the same bytes.
"$CED" convert "$laz" "$T/autzen.copc.laz"
check "COPC written: ced info says so" sh -c "'$CED' info '$T/autzen.copc.laz' | grep -q 'point format 7, COPC'"
"$CED" detect "$T/autzen.copc.laz" "${lazargs[@]}" --indices "$T/acw.txt" --indices-original "$T/acw_o.txt" \
  -o "$T/acw.las" -q
"$CED" plan "$T/autzen.copc.laz" "${lazargs[@]}" --tile-size 250 -o "$T/acplan.json" -q
check "COPC written: ced plan plans from its index" grep -q '"indexed": true' "$T/acplan.json"
run_tiles_and_merge "$T/acplan.json" acp
same_outputs "COPC written: plan + tiles (by its index) + merge" "$T/acp" acw
check "COPC written: tiles are read through the index" grep -q "through the file's COPC index" "$T/acp_err"
"$CED" detect "$laz" "${lazargs[@]}" -o "$T/lzw.copc.laz" -q
"$CED" detect "$laz" "${lazargs[@]}" --tile-size 250 -o "$T/lzwt.copc.laz" -q
check "COPC out: tiled as whole" cmp -s "$T/lzw.copc.laz" "$T/lzwt.copc.laz"
check "COPC out: the keypoints" sh -c "'$CED' info '$T/lzw.copc.laz' | grep -q \"^$T/lzw.copc.laz: $(wc -l < "$T/laz_whole.txt") points (LAZ 1.4, point format 7, COPC\""

# --- Any scheduler: plan, one tile at a time, merge ---
"$CED" plan "$T/mid.las" --preset ced6d --tile-size 1 -o "$T/plan.json" -q
check "plan exit 0" test $? = 0
ids=$(tr -d ' \n' < "$T/plan.json" | grep -o '"tiles":\[.*\]' | grep -o '\[[0-9]*,' | tr -d '[,')
check "plan lists tiles" test -n "$ids"
for id in $ids; do
  "$CED" detect --plan "$T/plan.json" --tile "$id" -o "$T/part_$id.cedpart" -q || echo "tile $id failed"
done
"$CED" merge "$T/plan.json" "$T"/part_*.cedpart --indices "$T/g.txt" --indices-original "$T/g_o.txt" -o "$T/g.las" -q
check "merge exit 0" test $? = 0
same_outputs "plan + tiles + merge" "$T/g" mid_whole
first=$(echo "$ids" | head -1)
mv "$T/part_$first.cedpart" "$T/missing.cedpart"
expect_exit 1 "have no part: $first" "merge without a part" -- merge "$T/plan.json" "$T"/part_*.cedpart --indices "$T/x.txt"
check "no output after a failed merge" test ! -e "$T/x.txt"
expect_exit 1 "given twice" "merge with a part twice" -- merge "$T/plan.json" "$T"/part_*.cedpart \
  "$T/missing.cedpart" "$T/missing.cedpart"
head -c 100 "$T/missing.cedpart" > "$T/trunc.cedpart"
expect_exit 1 "truncated" "merge with a truncated part" -- merge "$T/plan.json" "$T"/part_*.cedpart "$T/trunc.cedpart"
expect_exit 2 "owns no points" "a tile the plan does not have" -- detect --plan "$T/plan.json" --tile 999999 -o "$T/p.cedpart"
expect_exit 2 "needs --tile" "--plan without --tile" -- detect --plan "$T/plan.json" -o "$T/p.cedpart"
# A plan that does not match its input.
cp "$T/plan.json" "$T/plan_other.json"
sed -i "s|$T/mid.las|$T/other.las|" "$T/plan_other.json"
"$GEN" 20000 1 "$T/other.las"
expect_exit 1 "not the file the plan was made for" "plan of another file" -- detect --plan "$T/plan_other.json" \
  --tile "$first" -o "$T/p.cedpart"
check "no part after a mismatch" test ! -e "$T/p.cedpart"
printf '{"ced_tile_plan": 1, "request": {}}' > "$T/bad_plan.json"
expect_exit 1 "malformed tile plan" "malformed plan" -- detect --plan "$T/bad_plan.json" --tile 0 -o "$T/p.cedpart"

# --- The N strongest (--max-keypoints): tiles, plans and merge keep the whole run's ---
"$CED" detect "$T/mid.las" --preset ced6d --max-keypoints 500 --indices "$T/top_whole.txt" \
  --indices-original "$T/top_whole_o.txt" -o "$T/top_whole.las" -q
check "max-keypoints: 500 kept" test "$(wc -l < "$T/top_whole.txt")" = 500
"$CED" detect "$T/mid.las" --preset ced6d --max-keypoints 500 --tile-size 1 --indices "$T/top_t.txt" \
  --indices-original "$T/top_t_o.txt" -o "$T/top_t.las" -q
same_outputs "max-keypoints: tiles" "$T/top_t" top_whole
"$CED" plan "$T/mid.las" --preset ced6d --max-keypoints 500 --tile-size 1 -o "$T/top_plan.json" -q
check "max-keypoints: the plan records it" grep -q '"max_keypoints": *500' "$T/top_plan.json"
mkdir -p "$T/top_parts"
for id in $(tr -d ' \n' < "$T/top_plan.json" | grep -o '"tiles":\[.*\]' | grep -o '\[[0-9]*,' | tr -d '[,'); do
  "$CED" detect --plan "$T/top_plan.json" --tile "$id" -o "$T/top_parts/$id.cedpart" -q || echo "tile $id failed"
done
"$CED" merge "$T/top_plan.json" "$T"/top_parts/*.cedpart --indices "$T/top_m.txt" --indices-original "$T/top_m_o.txt" \
  -o "$T/top_m.las" -q
same_outputs "max-keypoints: plan + tiles + merge" "$T/top_m" top_whole
if [ -n "$MPI" ] && command -v mpirun > /dev/null; then
  mpirun --allow-run-as-root --oversubscribe -np 2 "$MPI" detect "$T/mid.las" --preset ced6d --max-keypoints 500 \
    --tile-size 1 --indices "$T/top_mpi.txt" --indices-original "$T/top_mpi_o.txt" -o "$T/top_mpi.las" -q
  same_outputs "max-keypoints: ced-mpi -np 2" "$T/top_mpi" top_whole
fi

# --- A keypoint share (--keypoint-share): the share of all tiles' candidates, the whole run's ---
S="--preset ced6d --keypoint-share 0.01"
"$CED" detect "$T/mid.las" $S --indices "$T/share_whole.txt" --indices-original "$T/share_whole_o.txt" \
  -o "$T/share_whole.las" -q
check "keypoint-share: fewer than without it" \
  test "$(wc -l < "$T/share_whole.txt")" -lt "$(wc -l < "$T/mid_whole.txt")"
"$CED" detect "$T/mid.las" $S --tile-size 1 --indices "$T/share_t.txt" --indices-original "$T/share_t_o.txt" \
  -o "$T/share_t.las" -q
same_outputs "keypoint-share: tiles" "$T/share_t" share_whole
"$CED" plan "$T/mid.las" $S --tile-size 1 -o "$T/share_plan.json" -q
check "keypoint-share: the plan records it" grep -q '"keypoint_share": *0.01' "$T/share_plan.json"
mkdir -p "$T/share_parts"
for id in $(tr -d ' \n' < "$T/share_plan.json" | grep -o '"tiles":\[.*\]' | grep -o '\[[0-9]*,' | tr -d '[,'); do
  "$CED" detect --plan "$T/share_plan.json" --tile "$id" -o "$T/share_parts/$id.cedpart" -q || echo "tile $id failed"
done
"$CED" merge "$T/share_plan.json" "$T"/share_parts/*.cedpart --indices "$T/share_m.txt" \
  --indices-original "$T/share_m_o.txt" -o "$T/share_m.las" -q
same_outputs "keypoint-share: plan + tiles + merge" "$T/share_m" share_whole
if [ -n "$MPI" ] && command -v mpirun > /dev/null; then
  mpirun --allow-run-as-root --oversubscribe -np 2 "$MPI" detect "$T/mid.las" $S --tile-size 1 \
    --indices "$T/share_mpi.txt" --indices-original "$T/share_mpi_o.txt" -o "$T/share_mpi.las" -q
  same_outputs "keypoint-share: ced-mpi -np 2" "$T/share_mpi" share_whole
fi
"$CED" plan "$T/mid.las" --preset robust3d --tile-size 1 -o "$T/r3_plan.json" -q
check "keypoint-share: robust3d's plan records its share" grep -q '"keypoint_share": *0.01' "$T/r3_plan.json"
expect_exit 2 "must be a share from 0 to 1" "keypoint-share out of range" -- detect "$T/mid.las" --keypoint-share 1.5 --indices "$T/x.txt"
# A tile size too small for the cloud: named as given (not "0.000000"), and no output.
rm -f "$T/tiny_tiles.txt"
expect_exit 1 "tile size 1e-30 is too small for the cloud" "a tile size too small" -- detect "$T/mid.las" \
  --preset ced6d --tile-size 1e-30 --indices "$T/tiny_tiles.txt"
check "a tile size too small writes no output" test ! -e "$T/tiny_tiles.txt"

# --- A run killed mid-way, then resumed ---
CED_TEST_KILL_AFTER_TILES=3 "$CED" detect "$T/mid.las" --preset ced6d --tile-size 1 --work-dir "$T/wd" \
  --indices "$T/r.txt" --indices-original "$T/r_o.txt" -o "$T/r.las" -q 2> /dev/null
check "the killed run failed" test $? -ne 0
check "the killed run wrote no output" test ! -e "$T/r.txt" -a ! -e "$T/r.las"
check "the killed run kept 3 parts" test "$(ls "$T/wd/parts" | wc -l)" = 3
expect_exit 1 "pass --resume" "a stopped run's directory without --resume" -- detect "$T/mid.las" --preset ced6d \
  --tile-size 1 --work-dir "$T/wd" --indices "$T/r.txt"
expect_exit 1 "another run" "--resume with other parameters" -- detect "$T/mid.las" --preset ced3d \
  --tile-size 1 --work-dir "$T/wd" --indices "$T/r.txt" --resume
"$CED" detect "$T/mid.las" --preset ced6d --tile-size 1 --work-dir "$T/wd" --indices "$T/r.txt" \
  --indices-original "$T/r_o.txt" -o "$T/r.las" --resume -q
check "resume exit 0" test $? = 0
same_outputs "killed and resumed" "$T/r" mid_whole
check "work directory removed" test ! -e "$T/wd"

# --- A folder of LAS, LAZ and COPC files (#61): tiles give the whole catalogue's keypoints ---
mkdir -p "$T/cat"
"$GEN" 60000 51 "$T/cat/a.las"
"$GEN" 60000 52 "$T/cat_b.las"
"$GEN" 60000 53 "$T/cat_c.las"
"$CED" convert "$T/cat_b.las" "$T/cat/b.laz" 2> /dev/null
"$CED" convert "$T/cat_c.las" "$T/cat/c.copc.laz" 2> /dev/null
catargs=(--preset ced6d --indices-global)
"$CED" detect "$T/cat" "${catargs[@]}" "$T/cat_whole_g.txt" --indices "$T/cat_whole.txt" -q
check "catalogue whole: keypoints in every file" test "$(cut -d' ' -f1 "$T/cat_whole.txt" | sort -u | wc -l)" = 3
mkdir -p "$T/cat_pf_whole" "$T/cat_pf_tiled"
"$CED" detect "$T/cat" --preset ced6d --indices-per-file "$T/cat_pf_whole" -q
"$CED" detect "$T/cat" "${catargs[@]}" "$T/cat_tiled_g.txt" --indices "$T/cat_tiled.txt" --tile-size 0.5 \
  --indices-per-file "$T/cat_pf_tiled" -q
check "catalogue tiled: --indices-per-file as the whole run's" diff -r "$T/cat_pf_whole" "$T/cat_pf_tiled"
"$CED" detect "$T/cat" --preset ced6d --tile-size 0.5 -q > "$T/cat_tiled_stdout.txt"
check "catalogue tiled: without outputs, stdout has what --indices writes" cmp -s "$T/cat_whole.txt" "$T/cat_tiled_stdout.txt"
check "catalogue tiled: the whole catalogue's keypoints" cmp -s "$T/cat_whole.txt" "$T/cat_tiled.txt"
check "catalogue tiled: the global numbering" cmp -s "$T/cat_whole_g.txt" "$T/cat_tiled_g.txt"
"$CED" plan "$T/cat" --preset ced6d --tile-size 0.5 -o "$T/cat_plan.json" -q
run_tiles_and_merge "$T/cat_plan.json" cat_merged
check "catalogue plan, tiles and merge" cmp -s "$T/cat_whole.txt" "$T/cat_merged.txt"
check "catalogue plan, tiles and merge: the files' indices" cmp -s "$T/cat_whole.txt" "$T/cat_merged_o.txt"
CED_TEST_KILL_AFTER_TILES=2 "$CED" detect "$T/cat" --preset ced6d --tile-size 0.5 --work-dir "$T/cat_wd" \
  --indices "$T/cat_r.txt" -q 2> /dev/null
check "catalogue: the killed run wrote no output" test ! -e "$T/cat_r.txt"
"$CED" detect "$T/cat" --preset ced6d --tile-size 0.5 --work-dir "$T/cat_wd" --indices "$T/cat_r.txt" --resume -q
check "catalogue: killed and resumed" cmp -s "$T/cat_whole.txt" "$T/cat_r.txt"
if [ -n "$MPI" ] && command -v mpirun > /dev/null; then
  # The ranks fill the tile cache between them, from a plan of the headers:
  # no rank reads the whole catalogue, and the outputs are one process's.
  "$CED" detect "$T/cat" --preset ced6d -o "$T/cat_whole.las" -q > /dev/null
  "$CED" detect "$T/cat" --preset ced6d --tile-size 0.5 -o "$T/cat_tiled.las" -q > /dev/null
  check "catalogue tiled: -o as the whole run's, byte for byte" cmp -s "$T/cat_whole.las" "$T/cat_tiled.las"
  mpirun --allow-run-as-root --oversubscribe -np 3 "$MPI" detect "$T/cat" --preset ced6d --tile-size 0.5 \
    --indices "$T/cat_mpi.txt" -o "$T/cat_mpi.las" -q > /dev/null 2>&1
  check "catalogue: ced-mpi on 3 ranks" cmp -s "$T/cat_whole.txt" "$T/cat_mpi.txt"
  check "catalogue: ced-mpi on 3 ranks, -o as the whole run's" cmp -s "$T/cat_whole.las" "$T/cat_mpi.las"
  CED_TEST_KILL_AFTER_TILES=2 mpirun --allow-run-as-root --oversubscribe -np 3 "$MPI" detect "$T/cat" \
    --preset ced6d --tile-size 0.5 --work-dir "$T/cat_wdm" --indices "$T/cat_mk.txt" -q > /dev/null 2>&1
  check "catalogue: ced-mpi killed, no output" test ! -e "$T/cat_mk.txt"
  check "catalogue: ced-mpi's plan says the cache was filled in 3 shares" grep -q '"cache_shares": 3' \
    "$T/cat_wdm/plan.json"
  check "catalogue: ... and the third rank filled pieces of it" \
    test -n "$(find "$T/cat_wdm/cache" "$T/cat_wdm/parts" -name 't*s2.bin' 2> /dev/null | head -1)"
  mpirun --allow-run-as-root --oversubscribe -np 3 "$MPI" detect "$T/cat" --preset ced6d --tile-size 0.5 \
    --work-dir "$T/cat_wdm" --indices "$T/cat_mk.txt" --resume -q > /dev/null 2>&1
  check "catalogue: ced-mpi killed and resumed" cmp -s "$T/cat_whole.txt" "$T/cat_mk.txt"
  check "catalogue: ced-mpi's work directory removed" test ! -e "$T/cat_wdm"
  # A header whose bounds miss its points (max x set to min x): the ranks'
  # shared pass finds them outside, and rank 0 plans and caches by passes.
  cp "$T/cat/a.las" "$T/lying.las"
  dd if="$T/lying.las" of="$T/lying.las" bs=1 skip=187 seek=179 count=8 conv=notrunc 2> /dev/null
  "$CED" detect "$T/lying.las" --preset ced6d --indices "$T/lying_whole.txt" -q
  mpirun --allow-run-as-root --oversubscribe -np 3 "$MPI" detect "$T/lying.las" --preset ced6d --tile-size 0.5 \
    --indices "$T/lying_mpi.txt" -q > /dev/null 2>&1
  check "ced-mpi: a header that misses its points, planned again by passes, the whole run's keypoints" \
    cmp -s "$T/lying_whole.txt" "$T/lying_mpi.txt"
fi
expect_exit 2 "give several files as a folder or @LIST" "several files with tiles" -- \
  detect "$T/cat/a.las" "$T/cat/b.laz" --preset ced6d --tile-size 0.5 --indices "$T/cat_x.txt"

# --- Bad input ---
for bad in 0 -1 nan inf; do
  expect_exit 2 "tile-size must be a positive" "--tile-size $bad" -- detect "$T/mid.las" --preset ced6d \
    --tile-size "$bad" --indices "$T/b.txt"
done
expect_exit 2 "must be a size" "--memory-limit junk" -- detect "$T/mid.las" --preset ced6d --memory-limit 4Q
expect_exit 1 "too small" "--memory-limit too small" -- detect "$T/mid.las" --preset ced6d --memory-limit 10M
expect_exit 2 "not both" "--tile-size and --memory-limit" -- detect "$T/mid.las" --preset ced6d --tile-size 2 \
  --memory-limit 1G
expect_exit 2 "needs the whole cloud" "--radius auto with tiles" -- detect "$T/mid.las" -m xyz:0.2 --radius auto \
  --tile-size 2
expect_exit 2 "--viewer writes the whole cloud" "--viewer with tiles" -- detect "$T/mid.las" --preset ced6d \
  --tile-size 2 --viewer "$T/v.ply"
"$GEN" 20000 3 "$T/small.las"
"$CED" detect "$T/small.las" --preset ced6d --indices "$T/sw.txt" -q
"$CED" detect "$T/small.las" --preset ced6d --tile-size 0.05 --indices "$T/st.txt" 2> "$T/err" > /dev/null
check "tiny tiles: same keypoints" cmp -s "$T/sw.txt" "$T/st.txt"
check "tiny tiles: a warning with the cost" grep -q "warning: the halo .* outweighs .* read .* times" "$T/err"
"$CED" detect "$T/small.las" --preset ced6d --tile-size 0.05 --indices "$T/st.txt" -q 2> "$T/err" > /dev/null
check "tiny tiles: -q prints nothing, not even the warning" test ! -s "$T/err"
head -c 5000 "$T/big.las" > "$T/cut.las"
expect_exit 1 "truncated" "truncated LAS" -- detect "$T/cut.las" --preset ced6d --tile-size 2 --indices "$T/b.txt"
check "no output for bad input" test ! -e "$T/b.txt"

# --- MPI ---
if [ -z "$MPI" ]; then
  echo "SKIP: ced-mpi is not built (needs libboost-mpi-dev and openmpi-bin)"
elif ! command -v mpirun > /dev/null; then
  echo "SKIP: mpirun is not installed (openmpi-bin)"
else
  run_mpi() { mpirun --allow-run-as-root --oversubscribe -np "$@"; }
  for np in 1 2 3; do
    c=mid
    [ $np = 3 ] && c=big
    run_mpi $np "$MPI" detect "$T/$c.las" --preset ced6d --tile-size 2 --indices "$T/mpi$np.txt" \
      --indices-original "$T/mpi${np}_o.txt" -o "$T/mpi$np.las" -q
    check "ced-mpi -np $np exit 0" test $? = 0
    same_outputs "ced-mpi -np $np ($c)" "$T/mpi$np" ${c}_whole
  done
  CED_TEST_KILL_AFTER_TILES=2 run_mpi 3 "$MPI" detect "$T/mid.las" --preset ced6d --tile-size 1 \
    --work-dir "$T/wdm" --indices "$T/mk.txt" -q > "$T/mpi_err" 2>&1
  check "ced-mpi: a killed rank fails the run" test $? -ne 0
  check "ced-mpi: mpirun names the killed rank" grep -q "signal 9" "$T/mpi_err"
  check "ced-mpi: no output after the failure" test ! -e "$T/mk.txt"
  run_mpi 3 "$MPI" detect "$T/mid.las" --preset ced6d --tile-size 1 --work-dir "$T/wdm" --indices "$T/mk.txt" \
    --resume -q
  check "ced-mpi: resumed" cmp -s "$T/mid_whole.txt" "$T/mk.txt"
  # A reach of ced's own that proves short: ced-mpi grows it, as ced detect
  # does, detecting only the short tiles again (61 of 64 in tiles of 0.7).
  "$CED" detect "$DATA/falloff_patch.ply" --preset ced3d --neighborhood knn:16 --indices "$T/fw.txt" -q
  for np in 1 3; do
    run_mpi $np "$MPI" detect "$DATA/falloff_patch.ply" --preset ced3d --neighborhood knn:16 --tile-size 0.7 \
      --work-dir "$T/wdf" --indices "$T/mf.txt" > "$T/mpi_err" 2>&1
    check "ced-mpi -np $np: a short reach of ced's own grows, tiled = whole" cmp -s "$T/mf.txt" "$T/fw.txt"
    check "ced-mpi -np $np: ... saying so" grep -q "ced-mpi: reach=0.74 was short for 61 tiles" "$T/mpi_err"
    check "ced-mpi -np $np: ... and leaves no work directory" test ! -e "$T/wdf"
    rm -f "$T/mf.txt"
  done
  # A reach the caller gives is a promise: short, the run stops, writes nothing
  run_mpi 2 "$MPI" detect "$DATA/falloff_patch.ply" --preset ced3d --neighborhood knn:16,reach=0.5 --tile-size 1 \
    --work-dir "$T/wdf" --indices "$T/mf.txt" -q > "$T/mpi_err" 2>&1
  check "ced-mpi: a short reach= given fails the run" test $? -ne 0
  check "ced-mpi: ... naming the reach a tile needs" grep -q "this tile's points need" "$T/mpi_err"
  check "ced-mpi: ... with no output and no work directory" test ! -e "$T/mf.txt" -a ! -e "$T/wdf"
  run_mpi 2 "$MPI" detect "$T/mid.las" --preset ced6d --indices "$T/x.txt" > "$T/mpi_err" 2>&1
  check "ced-mpi without a tile size: usage error" grep -q "needs --tile-size or --memory-limit" "$T/mpi_err"
fi

echo "cli tiles: $pass passed, $fail failed"
test "$fail" = 0
