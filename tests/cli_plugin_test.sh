#!/usr/bin/env bash
# `ced --plugin`: the example NDVI plugin end to end, and plugins that must
# be refused with a clear error and a non-zero exit, leaving no output.
#   tests/cli_plugin_test.sh CED NDVI_PLUGIN NO_ENTRY_PLUGIN WRONG_ABI_PLUGIN
set -u
CED=$1 NDVI=$2 NO_ENTRY=$3 WRONG_ABI=$4
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# shellcheck source=cli_support.sh
. "$(dirname "$0")/cli_support.sh"

# A 1 cm grid whose NDVI jumps at x = 0 (columns x,y,z,red,nir).
awk 'BEGIN { print "x,y,z,red,nir"; for (y = -10; y <= 10; y++) for (x = -10; x <= 10; x++)
  printf "%.2f,%.2f,0,%d,%d\n", x / 100, y / 100, (x <= 0 ? 80 : 40), (x <= 0 ? 120 : 160) }' > "$T/field.csv"

"$CED" modalities --plugin "$NDVI" > "$T/mods.txt"
check "modalities --plugin exit 0" test $? = 0
check "modalities lists ndvi" grep -q "^ndvi	.*(plugin)" "$T/mods.txt"
check "built-ins still listed" grep -q "^rgb	" "$T/mods.txt"

"$CED" detect "$T/field.csv" --plugin "$NDVI" -m ndvi:0.05 --radius 0.035 --indices "$T/kp.txt" -o "$T/kp.csv" -q
check "detect --plugin exit 0" test $? = 0
check "keypoints found on the edge" test "$(wc -l < "$T/kp.txt")" -gt 0
check "saliency column of the plugin's modality" grep -q "saliency_ndvi" "$T/kp.csv"
check "every keypoint on the NDVI edge" awk -F, 'NR > 1 && ($1 < -0.001 || $1 > 0.011) { bad = 1 } END { exit bad }' "$T/kp.csv"

expect_exit 2 "unknown modality 'ndvi'" "ndvi without its plugin" -- detect "$T/field.csv" -m ndvi:0.05 --indices "$T/x1.txt"
expect_exit 1 "plugin '$T/none.so': no such file" "missing plugin" -- \
  detect "$T/field.csv" --plugin "$T/none.so" -m ndvi --indices "$T/x2.txt"
expect_exit 1 "is not a ced plugin" "plugin without entry points" -- \
  detect "$T/field.csv" --plugin "$NO_ENTRY" -m ndvi --indices "$T/x3.txt"
expect_exit 1 "was built for 'ced plugin ABI 999" "plugin for another ABI" -- \
  detect "$T/field.csv" --plugin "$WRONG_ABI" -m ndvi --indices "$T/x4.txt"
expect_exit 1 "cannot be loaded as a shared library" "not a shared library" -- modalities --plugin "$T/field.csv"
check "no output left by the failures" test ! -e "$T/x1.txt" -a ! -e "$T/x2.txt" -a ! -e "$T/x3.txt" -a ! -e "$T/x4.txt"
check "no temporary files left" test -z "$(ls -A "$T" | grep '^\.')"

echo "$pass passed, $fail failed"
[ "$fail" = 0 ]
