#!/usr/bin/env bash
# The `ced` tool loads PCL only when a command uses it (issue #27): from its
# PCL module, libced_pcl.so. A command that does not use PCL loads none of
# PCL's libraries; `ced eval -d iss3d` loads the module out of the box; a
# missing, broken or foreign module is a clear error that names it, before
# any work and with no output written.
#   tests/pcl/cli_pcl_module_test.sh ced tests/data libced_pcl.so foreign.so no_entry.so
set -u
CED=$1
DATA=$2
MODULE=$3
FOREIGN=$4
NO_ENTRY=$5
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# shellcheck source=../cli_support.sh
. "$(dirname "$0")/../cli_support.sh"
sample=$DATA/apartment_mesh_214.ply
unset CED_PCL_MODULE

# loaded FILE PATTERN -- ced ARGS...: the libraries the dynamic loader opened
# for the command (LD_DEBUG=files) go to FILE; the command must succeed.
loaded() {
  local file=$1
  shift 2
  LD_DEBUG=files LD_DEBUG_OUTPUT="$T/ld" "$CED" "$@" > "$T/out" 2> "$T/err" || {
    echo "FAIL: $*: exit $?, stderr: $(cat "$T/err")"
    return 1
  }
  cat "$T"/ld.* | grep 'file=' | sed 's/.*file=\([^ ]*\).*/\1/' | sort -u > "$file"
  rm -f "$T"/ld.*
}
no_pcl_in() { ! grep -q 'libpcl_\|libced_pcl' "$1"; }

# --- 1. The executable itself needs no PCL library ---
check "ldd: no libpcl" bash -c "! ldd '$CED' | grep -q libpcl_"

# --- 2. Commands that do not use PCL load none of it ---
check "--version runs" loaded "$T/version.libs" -- --version
check "--version loads no PCL" no_pcl_in "$T/version.libs"
check "detect runs" loaded "$T/detect.libs" -- detect "$sample" --preset ced6d --indices "$T/kp.txt" -q
check "detect loads no PCL" no_pcl_in "$T/detect.libs"
check "detect wrote keypoints" test -s "$T/kp.txt"
check "eval ced6d runs" loaded "$T/eval.libs" -- eval repeatability "$sample" -d ced6d --trials 1 --noise 0 -q
check "eval ced6d loads no PCL" no_pcl_in "$T/eval.libs"

# --- 3. ced eval -d iss3d works out of the box, through the module ---
check "eval iss3d runs" loaded "$T/iss.libs" -- eval repeatability "$sample" -d iss3d --trials 1 --noise 0 -q
check "eval iss3d prints its row" grep -q '^iss3d ' "$T/out"
check "eval iss3d loads the module" grep -q "$(basename "$MODULE")" "$T/iss.libs"
check "eval iss3d loads PCL" grep -q 'libpcl_features' "$T/iss.libs"
CED_PCL_MODULE=$MODULE "$CED" eval repeatability "$sample" -d iss3d --trials 1 --noise 0 -q > "$T/env.out" 2>&1
check "CED_PCL_MODULE names the module" grep -q '^iss3d ' "$T/env.out"

# --- 4. A missing, broken or foreign module: a clear error naming it, before any work ---
module_error() {  # module_error PATH PATTERN NAME: iss3d and registration both refuse it, write nothing
  local path=$1 pattern=$2 name=$3
  export CED_PCL_MODULE=$path
  expect_exit 1 "ced's PCL module '$path' $pattern" "$name: eval iss3d" -- \
    eval repeatability "$sample" -d ced6d -d iss3d --trials 1 --noise 0 -q --csv "$T/rep.csv"
  check "$name: eval iss3d wrote no csv" test ! -e "$T/rep.csv"
  check "$name: eval iss3d ran nothing" test ! -s "$T/out"
  expect_exit 1 "ced's PCL module '$path' $pattern" "$name: eval registration" -- \
    eval registration "$sample" -d ced6d --trials 1 -q --csv "$T/reg.csv"
  check "$name: registration wrote no csv" test ! -e "$T/reg.csv"
  check "$name: detect does not need it" "$CED" detect "$sample" --preset ced3d --indices "$T/kp3.txt" -q
  unset CED_PCL_MODULE
}
printf 'not a shared library\n' > "$T/broken.so"
module_error "$T/missing/libced_pcl.so" "is not there" "missing"
module_error "$T/broken.so" "cannot be loaded" "broken"
module_error "$NO_ENTRY" "is not ced's PCL module" "no entry point"
module_error "$FOREIGN" "was built for 'ced plugin ABI 0" "foreign"

echo "cli_pcl_module: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
