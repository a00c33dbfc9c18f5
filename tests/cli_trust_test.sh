#!/usr/bin/env bash
# What ced promises about the user's files (docs/ROBUSTNESS.md, "Your
# files"): a tiled run deletes only what it created, no output is an input
# or another output, output that cannot be written is an error, and plans and
# parts that were changed are refused. Each case failed before issue #25.
#   tests/cli_trust_test.sh path/to/ced path/to/gen_cloud [path/to/ced-mpi]
set -u
CED=$1
GEN=$2
MPI=${3:-}
T=$(mktemp -d)
trap 'chmod -R u+w "$T" 2> /dev/null; rm -rf "$T"' EXIT
# shellcheck source=cli_support.sh
. "$(dirname "$0")/cli_support.sh"
export TMPDIR=$T/tmp # default work directories land here
mkdir -p "$TMPDIR"

"$GEN" 30000 7 "$T/s.las"
cp "$T/s.las" "$T/s.orig"
"$CED" detect "$T/s.las" --preset ced6d --indices "$T/whole.txt" -q
check "the whole cloud has keypoints" test "$(wc -l < "$T/whole.txt")" -gt 20
unchanged() { check "$1: the input is untouched" cmp -s "$T/s.orig" "$T/s.las"; }
tiled=(detect "$T/s.las" --preset ced6d --tile-size 0.3)

# --- A tiled run deletes only what it created ---
mkdir "$T/d"
echo x > "$T/d/important.txt"
expect_exit 2 "holds files ced did not make ('important.txt')" "--resume in a user's directory" -- \
  "${tiled[@]}" --work-dir "$T/d" --resume --indices "$T/k.txt" -q
check "--resume in a user's directory: it keeps its file" test -s "$T/d/important.txt"
check "--resume in a user's directory: no output" test ! -e "$T/k.txt"
expect_exit 2 "holds files ced did not make" "a user's directory" -- \
  "${tiled[@]}" --work-dir "$T/d" --indices "$T/k.txt" -q
check "a user's directory: it keeps its file" test -s "$T/d/important.txt"
mkdir -p "$T/c/cache"
expect_exit 2 "holds files ced did not make ('cache')" "a directory with a cache/ folder" -- \
  "${tiled[@]}" --work-dir "$T/c" --indices "$T/k.txt" -q
check "a directory with a cache/ folder stays" test -d "$T/c/cache"
mkdir "$T/outdir"
expect_exit 2 "lies inside the work directory" "--work-dir = the output's directory" -- \
  "${tiled[@]}" --work-dir "$T/outdir" -o "$T/outdir/k.las" -q
expect_exit 2 "lies inside the work directory" "--work-dir = the input's directory" -- \
  "${tiled[@]}" --work-dir "$T" --indices "$T/elsewhere/k.txt" -q
unchanged "--work-dir = the input's directory"
# HOME-like: a directory with files and folders.
mkdir -p "$T/home/.config" && echo secret > "$T/home/.config/x"
expect_exit 2 "holds files ced did not make" "--work-dir ~" -- \
  "${tiled[@]}" --work-dir "$T/home" --indices "$T/k.txt" -q
check "--work-dir ~: the home stays" test -s "$T/home/.config/x"
# A new directory is ced's: made and removed.
"$CED" "${tiled[@]}" --work-dir "$T/new" --indices "$T/k1.txt" -q
check "a new work directory: the keypoints" cmp -s "$T/whole.txt" "$T/k1.txt"
check "a new work directory: removed after the run" test ! -e "$T/new"
check "the default work directory is removed" test -z "$(ls -A "$TMPDIR")"
"$CED" "${tiled[@]}" --indices "$T/k0.txt" -q
check "the default work directory: the keypoints" cmp -s "$T/whole.txt" "$T/k0.txt"
check "the default work directory: removed" test -z "$(ls -A "$TMPDIR")"
# A run that fails before its plan is written leaves nothing to resume: ced's files go too.
expect_exit 1 "needs field 'swir'" "a failing run in a new work directory" -- \
  "${tiled[@]}" -m 'bands(swir):0.1' --work-dir "$T/failed" --indices "$T/kf.txt" -q
check "a failing run: its new work directory is removed" test ! -e "$T/failed"
mkdir "$T/failed_empty"
expect_exit 1 "needs field 'swir'" "a failing run in an empty work directory" -- \
  "${tiled[@]}" -m 'bands(swir):0.1' --work-dir "$T/failed_empty" --indices "$T/kf.txt" -q
check "a failing run: an empty work directory stays, empty" test -d "$T/failed_empty" -a -z "$(ls -A "$T/failed_empty")"
# An empty directory is lent: ced's files go, the directory stays.
mkdir "$T/empty"
"$CED" "${tiled[@]}" --work-dir "$T/empty" --indices "$T/k2.txt" -q
check "an empty work directory: the keypoints" cmp -s "$T/whole.txt" "$T/k2.txt"
check "an empty work directory: it stays, empty" test -d "$T/empty" -a -z "$(ls -A "$T/empty")"
# A file put into ced's work directory during a (killed) run stays.
(CED_TEST_KILL_AFTER_TILES=3 "$CED" "${tiled[@]}" --work-dir "$T/w" --indices "$T/k3.txt" -q; true) > /dev/null 2>&1
check "killed run: the work directory is marked" test -f "$T/w/.ced-work-dir"
echo notes > "$T/w/notes.txt"
"$CED" "${tiled[@]}" --work-dir "$T/w" --indices "$T/k3.txt" --resume -q
check "resumed: the keypoints" cmp -s "$T/whole.txt" "$T/k3.txt"
check "resumed: the user's file and its directory stay" test -s "$T/w/notes.txt"
check "resumed: ced's files are gone" test "$(ls -A "$T/w")" = notes.txt
check "resumed: no temporary beside the outputs" test -z "$(ls -A "$T" | grep '\.tmp\.')"

# --- No output is an input, and no two outputs are one file ---
"$CED" convert "$T/s.las" "$T/in.ply"
cp "$T/in.ply" "$T/in.orig"
mkdir -p "$T/sub"
ln -s "$T/in.ply" "$T/link.ply"
ln "$T/in.ply" "$T/hard.ply"
for spelling in "$T/in.ply" "$T/sub/../in.ply" "$T/link.ply" "$T/hard.ply"; do
  expect_exit 2 "is the input" "-o $spelling" -- detect "$T/in.ply" -m xyz:0.2 -o "$spelling" -q
done
expect_exit 2 "is the input" "--indices = the input" -- detect "$T/in.ply" -m xyz:0.2 --indices "$T/in.ply" -q
check "detect: the input is untouched" cmp -s "$T/in.orig" "$T/in.ply"
expect_exit 2 "-o '$T/s.las' is the input" "a tiled run, -o = the input" -- "${tiled[@]}" -o "$T/s.las" -q
unchanged "a tiled run, -o = the input"
expect_exit 2 "are one file" "-o k.ply --viewer k.ply" -- \
  detect "$T/in.ply" -m xyz:0.2 -o "$T/k.ply" --viewer "$T/k.ply" -q
check "two outputs of one path: nothing written" test ! -e "$T/k.ply"
expect_exit 2 "is the input" "ced plan -o = the input" -- plan "$T/s.las" --preset ced6d --tile-size 0.3 -o "$T/s.las" -q
unchanged "ced plan -o = the input"
"$CED" plan "$T/s.las" --preset ced6d --tile-size 0.3 -o "$T/plan.json" -q
check "ced plan" test -s "$T/plan.json"
tiles=$(python3 -c "import json,sys; print(' '.join(str(t[0]) for t in json.load(open(sys.argv[1]))['tiles']))" "$T/plan.json")
first=${tiles%% *}
cp "$T/plan.json" "$T/plan.orig"
expect_exit 2 "is --plan" "--plan P --tile I -o P" -- detect --plan "$T/plan.json" --tile "$first" -o "$T/plan.json" -q
check "--plan P -o P: the plan is untouched" cmp -s "$T/plan.orig" "$T/plan.json"
expect_exit 2 "is the plan's input" "--plan P --tile I -o INPUT" -- \
  detect --plan "$T/plan.json" --tile "$first" -o "$T/s.las" -q
unchanged "--plan P --tile I -o INPUT"
expect_exit 2 "cannot be given with it" "--plan with -r and --preset" -- \
  detect --plan "$T/plan.json" --tile "$first" -r 0.1 --preset ced3d -o "$T/p.part" -q
# -m without -r: ced detect would take --radius auto, which a plan cannot (not a silent 0.05).
expect_exit 2 "ced plan with -m needs -r R" "ced plan -m without -r" -- \
  plan "$T/s.las" -m xyz:0.2 --tile-size 1 -o "$T/plan_m.json" -q
check "ced plan -m without -r: no plan written" test ! -e "$T/plan_m.json"
# The plan records its share of candidates too: a share given with it would be ignored.
expect_exit 2 "--keypoint-share cannot be given with it" "--plan with --keypoint-share" -- \
  detect --plan "$T/plan.json" --tile "$first" --keypoint-share 0.5 -o "$T/p.part" -q
mkdir "$T/parts"
for t in $tiles; do "$CED" detect --plan "$T/plan.json" --tile "$t" -o "$T/parts/p$t.cedpart" -q; done
"$CED" merge "$T/plan.json" "$T"/parts/*.cedpart --indices "$T/merged.txt" -q
check "merge: the keypoints" cmp -s "$T/whole.txt" "$T/merged.txt"
cp "$T/parts/p$first.cedpart" "$T/part.orig"
expect_exit 2 "is part" "merge --indices = a part" -- \
  merge "$T/plan.json" "$T"/parts/*.cedpart --indices "$T/parts/p$first.cedpart" -q
check "merge --indices = a part: the part is untouched" cmp -s "$T/part.orig" "$T/parts/p$first.cedpart"
expect_exit 2 "is the plan's input" "merge -o = the plan's input" -- \
  merge "$T/plan.json" "$T"/parts/*.cedpart -o "$T/s.las" -q
unchanged "merge -o = the plan's input"
"$CED" detect "$T/in.ply" -m xyz:0.2 --viewer "$T/v.ply" -q
cp "$T/v.ply" "$T/v.orig"
expect_exit 2 "is the input" "ced view v.ply -o v.ply" -- view "$T/v.ply" -o "$T/v.ply"
check "ced view: the cloud is untouched" cmp -s "$T/v.orig" "$T/v.ply"
expect_exit 2 "is the input" "ced eval --csv = the input" -- \
  eval repeatability "$T/in.ply" -d ced3d --trials 1 --noise 0 --csv "$T/in.ply" -q
check "ced eval: the input is untouched" cmp -s "$T/in.orig" "$T/in.ply"
expect_exit 2 "is the input" "ced convert x x (refused, not in place)" -- convert "$T/in.ply" "$T/in.ply"
check "ced convert: the input is untouched" cmp -s "$T/in.orig" "$T/in.ply"

# --- Output that cannot be written is an error ---
if [ -w /dev/full ]; then
  "$CED" detect "$T/in.ply" -m xyz:0.2 -q > /dev/full 2> "$T/err"
  check "indices to a full stdout: exit 1" test $? = 1
  check "indices to a full stdout: said" grep -q "standard output" "$T/err"
  # All outputs or none: a summary that cannot be written leaves the earlier
  # indices, keypoints and viewer files of the same run where they were.
  "$CED" detect "$T/in.ply" -m xyz:0.2 --indices "$T/all.txt" -o "$T/all.ply" --viewer "$T/allv.ply" -q
  for f in all.txt all.ply allv.ply; do cp "$T/$f" "$T/$f.before"; done
  expect_exit 1 "error writing '/dev/full'" "all or none: the failing summary is named" -- \
    detect "$T/in.ply" -m xyz:0.1 --indices "$T/all.txt" -o "$T/all.ply" --viewer "$T/allv.ply" --summary /dev/full -q
  for f in all.txt all.ply allv.ply; do check "all or none: $f untouched" cmp -s "$T/$f" "$T/$f.before"; done
  check "all or none: no temporaries left" sh -c "! ls -a '$T' | grep -q '\.tmp\.'"
fi
# Temporaries of a killed process (a process id past pid_max runs nothing).
dead=$(($(cat /proc/sys/kernel/pid_max 2> /dev/null || echo 4194304) + 5))
touch "$T/.k9.txt.tmp.$dead.0" "$T/.k9.txt.tmp.$$.1"
"$CED" detect "$T/in.ply" -m xyz:0.2 --indices "$T/k9.txt" -q
check "a killed run's temporary is removed" test ! -e "$T/.k9.txt.tmp.$dead.0"
check "a running process's temporary stays" test -e "$T/.k9.txt.tmp.$$.1"
# A device is written in place, never renamed over (as root this replaced /dev/stdout).
"$CED" detect "$T/in.ply" -m xyz:0.2 --indices /dev/stdout -q > "$T/stdout.txt"
check "--indices /dev/stdout: the indices" test "$(wc -l < "$T/stdout.txt")" -gt 0
check "--indices /dev/stdout: still a link" test -L /dev/stdout

# --- Changed inputs, plans and parts are refused ---
# One point moved in place, away from the blocks the fingerprint samples.
python3 - "$T/s.las" "$T/moved.las" << 'PY'
import struct, sys
b = bytearray(open(sys.argv[1], "rb").read())
offset = struct.unpack_from("<I", b, 96)[0]
rec = struct.unpack_from("<H", b, 105)[0]
n = len(b)
sampled = [(0, 65536), (n - 65536, n)] + [(n // 65 * j, n // 65 * j + 4096) for j in range(1, 65)]
k = next(k for k in range((n - offset) // rec)  # the first record no sampled block touches
         if all(offset + (k + 1) * rec <= lo or offset + k * rec >= hi for lo, hi in sampled))
x = struct.unpack_from("<i", b, offset + k * rec)[0]
struct.pack_into("<i", b, offset + k * rec, x + 3)
open(sys.argv[2], "wb").write(b)
PY
cp "$T/s.las" "$T/p.las"
"$CED" plan "$T/p.las" --preset ced6d --tile-size 0.3 -o "$T/plan2.json" -q
cp "$T/moved.las" "$T/p.las"
bad=0
for t in $tiles; do
  "$CED" detect --plan "$T/plan2.json" --tile "$t" -o "$T/x.cedpart" -q 2> "$T/err" || {
    grep -q "changed since the plan" "$T/err" && bad=$((bad + 1))
  }
done
check "one point moved in place: every tile refuses the changed file" test "$bad" = "$(echo $tiles | wc -w)"
tamper() {  # tamper NAME PYTHON-EXPRESSION-ON-j PATTERN
  python3 -c "import json,sys; j=json.load(open(sys.argv[1])); $2; json.dump(j, open(sys.argv[2], 'w'))" \
    "$T/plan.json" "$T/tampered.json"
  expect_exit 1 "$3" "a plan with $1" -- detect --plan "$T/tampered.json" --tile "$first" -o "$T/x.cedpart" -q
  expect_exit 1 "$3" "merge of a plan with $1" -- merge "$T/tampered.json" "$T"/parts/*.cedpart --indices "$T/x" -q
}
tamper "halo 0" "j['grid']['halo']=0" "less than"
tamper "min_neighbors -1" "j['request']['min_neighbors']=-1" "min_neighbors"
tamper "min_neighbors 2.5" "j['request']['min_neighbors']=2.5" "min_neighbors"
tamper "radius NaN" "j['request']['radius']=float('nan')" "radius"
tamper "a tile owning more than it reads" "j['tiles'][0][1]=j['tiles'][0][2]+1" "counts are inconsistent"
tamper "a bad modality" "j['request']['modalities']=['xyz:zero']" "invalid tile plan"
check "no part written from a tampered plan" test ! -e "$T/x.cedpart"
# A forged plan (#57): a run's box moved off the tiles that read it only
# through their halo. The box decides which tiles read the run, so the tiles
# that still read it check it against the run's points, and refuse it.
python3 - "$T/plan.json" "$T/forged.json" << 'PY'
import json, sys
j = json.load(open(sys.argv[1]))
r = max(j["runs"], key=lambda e: e[5] - e[2])  # the run widest in x
r[5] = r[2] + (r[5] - r[2]) / 2                # its box cut to its lower half
json.dump(j, open(sys.argv[2], "w"))
PY
refused=0
accepted=0
for t in $tiles; do
  if "$CED" detect --plan "$T/forged.json" --tile "$t" -o "$T/forged$t.cedpart" -q 2> "$T/err"; then
    accepted=$((accepted + 1))
  else
    grep -q "is not its points' box" "$T/err" && refused=$((refused + 1))
  fi
done
check "a forged run box: a tile that reads the run refuses the plan" test "$refused" -ge 1
expect_exit 1 "" "a forged run box: the merge lacks the refused tiles' parts" -- \
  merge "$T/forged.json" "$T"/forged*.cedpart --indices "$T/forged.txt" -q
check "a forged run box: no keypoints" test ! -e "$T/forged.txt"
# Parts whose records were changed: a record's indices (after the
# header: magic, format version, digest, tile, count, modalities, fields,
# candidates, any, ms: src/tiled/part_file.cpp).
part_patch() {  # part_patch IN OUT RECORD VALUE: sets the index of record RECORD
  python3 - "$@" << 'PY'
import struct, sys
src, dst, rec_no, value = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
b = bytearray(open(src, "rb").read())
m, f = struct.unpack_from("<II", b, 12 + 16 + 16)
head = 12 + 16 + 8 + 8 + 4 + 4 + 8 * m + 8 + 8
count = struct.unpack_from("<Q", b, 12 + 16 + 8)[0]
rec = (len(b) - head) // count
struct.pack_into("<QQ", b, head + rec_no * rec, value, value)  # index and file index (all points are finite)
open(dst, "wb").write(b)
PY
}
big=""
for t in $tiles; do
  n=$(python3 -c "import struct,sys; print(struct.unpack_from('<Q', open(sys.argv[1],'rb').read(), 36)[0])" "$T/parts/p$t.cedpart")
  [ "$n" -ge 2 ] && big=$t && break
done
check "a part with two keypoints" test -n "$big"
merge_bad() {  # merge_bad NAME PATTERN: the patched part in place of p$big
  mkdir -p "$T/bad"
  rm -f "$T"/bad/*
  cp "$T"/parts/*.cedpart "$T/bad/"
  mv "$T/patched" "$T/bad/p$big.cedpart"
  expect_exit 1 "$2" "merge: $1" -- merge "$T/plan.json" "$T"/bad/*.cedpart --indices "$T/x.txt" -q
  check "merge: $1: no output" test ! -e "$T/x.txt"
}
part_patch "$T/parts/p$big.cedpart" "$T/patched" 0 $((1 << 40))
merge_bad "an index of 2^40" "out of the input's range"
second=$(python3 -c "
import struct,sys; b=open(sys.argv[1],'rb').read(); m=struct.unpack_from('<I',b,44)[0]; head=12+16+8+8+4+4+8*m+8+8
count=struct.unpack_from('<Q',b,36)[0]; rec=(len(b)-head)//count; print(struct.unpack_from('<Q',b,head+rec)[0])" "$T/parts/p$big.cedpart")
part_patch "$T/parts/p$big.cedpart" "$T/patched" 0 $((second + 1))
merge_bad "descending indices" "comes after"
other=""
for t in $tiles; do [ "$t" != "$big" ] && other=$t && break; done
dup=$(python3 -c "
import struct,sys; b=open(sys.argv[1],'rb').read(); m=struct.unpack_from('<I',b,44)[0]; head=12+16+8+8+4+4+8*m+8+8
print(struct.unpack_from('<Q',b,head)[0] if struct.unpack_from('<Q',b,36)[0] else -1)" "$T/parts/p$other.cedpart")
if [ "$dup" -ge 0 ]; then
  part_patch "$T/parts/p$big.cedpart" "$T/patched" 0 "$dup"
  merge_bad "an index of another part" "given twice\|outside tile\|comes after"
fi

# --- A plan of a file read whole (ASCII PCD) with a NaN point: its tiles are the whole run ---
# (every tile failed with "the file changed since the plan was made": the plan
# counted the NaN point, the tiles' reader had dropped it)
awk 'BEGIN { srand(5); n = 1500
  printf "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH %d\nHEIGHT 1\n", n
  printf "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA ascii\n", n
  for (i = 0; i < n; ++i) if (i == 7) print "nan nan nan"; else print rand(), rand(), rand() }' > "$T/nan.pcd"
"$CED" plan "$T/nan.pcd" -m xyz:0.2 -r 0.1 --tile-size 0.5 -o "$T/nanplan.json" -q
nan_tiles=$(python3 -c "import json,sys; print(' '.join(str(t[0]) for t in json.load(open(sys.argv[1]))['tiles']))" \
  "$T/nanplan.json")
rm -f "$T"/nan_*.cedpart
for t in $nan_tiles; do "$CED" detect --plan "$T/nanplan.json" --tile "$t" -o "$T/nan_$t.cedpart" -q; done
"$CED" merge "$T/nanplan.json" "$T"/nan_*.cedpart --indices "$T/nan_merged.txt" -q
"$CED" detect "$T/nan.pcd" -m xyz:0.2 -r 0.1 --indices "$T/nan_whole.txt" -q
check "ASCII PCD with NaN: plan tiles merge to the whole run" cmp -s "$T/nan_merged.txt" "$T/nan_whole.txt"
check "ASCII PCD with NaN: keypoints found" test -s "$T/nan_whole.txt"

# --- Small tiles under a large halo: only tiles that own points are cached ---
# (ced6d at r 0.05 has a halo of about 0.4: with tiles of 0.05 a point is
# near ~4000 tiles, most of them empty air; all of them were cached.)
(CED_TEST_KILL_AFTER_TILES=1 "$CED" detect "$T/s.las" --preset ced6d --tile-size 0.05 --work-dir "$T/small" \
  --indices "$T/ks.txt"; true) > "$T/small_err" 2>&1
owning=$(python3 -c "import json,sys; print(len(json.load(open(sys.argv[1]))['tiles']))" "$T/small/plan.json")
cached=$(ls "$T/small/cache" | wc -l)
parts=$(ls "$T/small/parts" | wc -l)
check "small tiles: only owning tiles are cached ($cached + $parts files, $owning tiles)" \
  test $((cached + parts)) -le "$owning"
check "small tiles: the halo warning comes before the cache is written" grep -q "the halo .* outweighs" "$T/small_err"
"$CED" detect "$T/s.las" --preset ced6d --tile-size 0.05 --work-dir "$T/small" --indices "$T/ks.txt" --resume -q
check "small tiles, resumed: the keypoints" cmp -s "$T/whole.txt" "$T/ks.txt"
expect_exit 2 "memory-limit must be a size from 1 byte" "--memory-limit 0.5" -- \
  detect "$T/s.las" --preset ced6d --memory-limit 0.5 --indices "$T/k.txt"
expect_exit 2 "memory-limit must be a size from 1 byte" "--memory-limit 1e30" -- \
  detect "$T/s.las" --preset ced6d --memory-limit 1e30 --indices "$T/k.txt"

# --- ced-mpi deletes only what it created, too ---
if [ -n "$MPI" ] && command -v mpirun > /dev/null; then
  mpirun --allow-run-as-root --oversubscribe -np 2 "$MPI" detect "$T/s.las" --preset ced6d --tile-size 0.3 \
    --work-dir "$T/d" --resume --indices "$T/km.txt" -q > "$T/err" 2>&1
  check "ced-mpi in a user's directory: refused" grep -q "holds files ced did not make" "$T/err"
  check "ced-mpi in a user's directory: it keeps its file" test -s "$T/d/important.txt"
  mpirun --allow-run-as-root --oversubscribe -np 2 "$MPI" detect "$T/s.las" --preset ced6d --tile-size 0.3 \
    --work-dir "$T/mw" --indices "$T/km.txt" -q
  check "ced-mpi: the keypoints" cmp -s "$T/whole.txt" "$T/km.txt"
  check "ced-mpi: its new work directory is removed" test ! -e "$T/mw"
else
  echo "SKIP: ced-mpi or mpirun missing: the MPI cases are not run"
fi

echo "cli trust: $pass passed, $fail failed"
test "$fail" = 0
