# Shared by the CLI test scripts (sourced): counters and checks.
#   $CED is the tool, $T a temporary directory.
pass=0
fail=0
check() {  # check NAME COMMAND...: the command must succeed
  local name=$1
  shift
  if "$@"; then pass=$((pass + 1)); else fail=$((fail + 1)); echo "FAIL: $name"; fi
}
expect_exit() {  # expect_exit CODE PATTERN NAME -- ced ARGS...: exit code and stderr text
  local code=$1 pattern=$2 name=$3
  shift 4
  "$CED" "$@" > "$T/out" 2> "$T/err"
  local rc=$?
  if [ "$rc" = "$code" ] && grep -q -- "$pattern" "$T/err"; then
    pass=$((pass + 1))
  else
    fail=$((fail + 1))
    echo "FAIL: $name: exit $rc (want $code), stderr: $(cat "$T/err")"
  fi
}
