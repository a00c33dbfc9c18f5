#!/usr/bin/env bash
# Every count and number option of every command (#57), against the values
# that slip through a lax parser: hexadecimal, empty (an unset shell
# variable), octal-looking, negative, nan, inf and denormal. Each is refused
# with a message that names the option, or (octal-looking) read as decimal;
# nothing crashes.
#   tests/cli_numbers_test.sh path/to/ced path/to/tests/data
set -u
CED=$1
DATA=$2
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# shellcheck source=cli_support.sh
. "$(dirname "$0")/cli_support.sh"

# A small cloud (a crop of the sample): each valid run is quick.
"$CED" convert "$DATA/apartment_mesh_214.ply" "$T/s.ply" --voxel 0.04 2> /dev/null
S=$T/s.ply
"$CED" plan "$S" --preset ced6d --tile-size 1 -o "$T/plan.json" -q
"$CED" detect "$S" --preset ced6d --viewer "$T/v.ply" -q

has_registration=0
"$CED" eval registration --help > /dev/null 2>&1 && has_registration=1

# ROW: COMMAND-WORDS | OPTION | KIND | ARGS AFTER THE VALUE...
#   KIND count: a whole number; number: a finite decimal number.
rows=(
  "detect $S -m xyz:0.2 -q|-r|number|"
  "detect $S -m xyz:0.2 -r 0.05 -q|--nms-radius|number|"
  "detect $S -m xyz:0.2 -r auto -q|--radius-factor|number|"
  "detect $S -m xyz:0.2 -r 0.05 -q|--voxel|number|"
  "detect $S -m xyz:0.2 -r 0.05 -q|-k|count|"
  "detect $S -m xyz:0.2 -r 0.05 -q|--min-neighbors|count|"
  "detect $S -m xyz:0.2 -r 0.05 -q|-j|count|"
  "detect $S -m xyz:0.2 -r 0.05 -q|--max-keypoints|count|"
  "detect $S -m xyz:0.2 -r 0.05 -q|--keypoint-share|number|"
  "detect $S -m xyz:0.2 -r 0.05 -q|--tile-size|number|"
  "detect $S -m xyz:0.2 -r 0.05 -q|--memory-limit|number|"
  "detect $S -m xyz:0.2 -r 0.05 --html $T/p.html -q|--html-max-points|count|"
  "detect --plan $T/plan.json -o $T/part -q|--tile|count|"
  "plan $S --preset ced6d -o $T/p2.json -q|--tile-size|number|"
  "plan $S --preset ced6d --tile-size 1 -o $T/p2.json -q|--max-keypoints|count|"
  "plan $S -m xyz:0.2 --tile-size 1 -o $T/p2.json -q|-r|number|"
  "info $S|--knn|count|"
  "convert $S $T/c.ply|--voxel|number|"
  "view $T/v.ply -o $T/v.html|--max-points|count|"
  "view $T/v.ply -o $T/v.html|--threshold|number|"
  "eval repeatability $S -d ced3d --trials 1 --noise 0 -q|--trials|count|"
  "eval repeatability $S -d ced3d --trials 1 --noise 0 -q|--seed|count|"
  "eval repeatability $S -d ced3d --trials 1 -q|--noise|number|"
  "eval repeatability $S -d ced3d --trials 1 --noise 0 -q|--voxel|number|"
  "eval repeatability $S -d ced3d --trials 1 --noise 0 -q|--resolution|number|"
  "eval repeatability $S -d ced3d --trials 1 --noise 0 -q|-r|number|"
  "eval repeatability $S -d ced3d --trials 1 --noise 0 -q|-k|count|"
  "eval repeatability $S -d ced3d --trials 1 --noise 0 -q|--max-translation|number|"
  "eval repeatability $S -d ced3d --trials 1 --noise 0 -q|-j|count|"
  "eval repeatability $S -d ced3d --trials 1 --noise 0 -q|--epsilon|number|"
  "eval repeatability $S -d ced3d --trials 1 --noise 0 -q|--counts|count|"
  "eval repeatability --source $S --target $S -d ced3d -q|--gt-error|number|"
  "eval repeatability --source $S --target $S -d ced3d -q|--random-draws|count|"
)
if [ "$has_registration" = 1 ]; then
  reg="eval registration $S -d ced3d --trials 1 --iterations 200 -q"
  for o in --overlap --noise --max-translation --voxel --resolution -r --normal-radius --feature-radius \
    --inlier-distance --inlier-fraction --max-rotation-error --max-translation-error; do
    rows+=("$reg|$o|number|")
  done
  for o in --trials --seed -k -j --iterations; do rows+=("$reg|$o|count|"); done
fi

run() {  # run VALUE ROW: the exit code of the row's command with VALUE, stderr in $T/err
  local value=$1 cmd opt
  IFS='|' read -r cmd opt _ _ <<< "$2"
  # shellcheck disable=SC2086
  timeout 120 "$CED" $cmd "$opt" "$value" > /dev/null 2> "$T/err"
}

for row in "${rows[@]}"; do
  IFS='|' read -r cmd opt kind _ <<< "$row"
  name="${cmd%% /*} $opt"
  case $opt in  # CLI11 names an option by its long name
    -k) long=--min-neighbors ;;
    -j) long=--threads ;;
    -r) long=--radius ;;
    *) long=$opt ;;
  esac
  for value in 0x10 "" nan inf -inf; do
    run "$value" "$row"
    rc=$?
    if [ "$rc" = 2 ] && grep -q -- "$long" "$T/err"; then
      pass=$((pass + 1))
    else
      fail=$((fail + 1))
      echo "FAIL: $name '$value': exit $rc (want 2, naming $opt): $(head -c 300 "$T/err")"
    fi
  done
  # Negative: refused (a count or a size below 0 means nothing here).
  run -1 "$row"
  rc=$?
  if [ "$rc" = 1 ] || [ "$rc" = 2 ]; then pass=$((pass + 1)); else
    fail=$((fail + 1))
    echo "FAIL: $name -1: exit $rc (want 1 or 2): $(head -c 300 "$T/err")"
  fi
  # Octal-looking: read as decimal (the same outcome as without the zero).
  if [ "$kind" = count ]; then a=010 b=10; else a=00.5 b=0.5; fi
  run "$a" "$row"
  ra=$?
  cp "$T/err" "$T/err.a"
  run "$b" "$row"
  rb=$?
  if [ "$ra" = "$rb" ] && [ "$ra" -lt 128 ]; then pass=$((pass + 1)); else
    fail=$((fail + 1))
    echo "FAIL: $name $a: exit $ra, but $b exits $rb: $(head -c 300 "$T/err.a")"
  fi
  # Denormal: a clear outcome, never a crash.
  run 1e-320 "$row"
  rc=$?
  if [ "$rc" -lt 128 ] && [ "$rc" != 124 ]; then pass=$((pass + 1)); else
    fail=$((fail + 1))
    echo "FAIL: $name 1e-320: exit $rc: $(head -c 300 "$T/err")"
  fi
done
# Radii: a denormal is refused, not read as 0 (0.2 r = 0 made every point a keypoint).
for opt in -r --nms-radius; do
  run 1e-320 "detect $S -m xyz:0.2 -r 0.05 -q|$opt|number|"
  check "detect $opt 1e-320: refused" test $? = 2
done

echo "cli_numbers: $pass passed, $fail failed"
[ "$fail" = 0 ]
