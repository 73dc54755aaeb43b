# Shared by the tool tests: tests/tools/<name>.sh BIN_DIR DATA_DIR
set -u
bin=$1
data=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0
checks=0

# expect CODE 'substring of stderr' command...: runs the command, checks its exit code and that
# stderr contains the substring (empty: anything) on one line.
expect() {
  local code=$1 needle=$2
  shift 2
  checks=$((checks + 1))
  "$@" >"$tmp/out" 2>"$tmp/err" </dev/null
  local got=$?
  if [ "$got" != "$code" ]; then
    echo "FAIL: '$*' exited $got, expected $code; stderr: $(head -c 400 "$tmp/err")"
    failures=$((failures + 1))
  elif [ -n "$needle" ] && ! grep -qF -- "$needle" "$tmp/err"; then
    echo "FAIL: '$*' stderr lacks '$needle': $(head -c 400 "$tmp/err")"
    failures=$((failures + 1))
  fi
}

# check 'description' command...: the command must succeed.
check() {
  local what=$1
  shift
  checks=$((checks + 1))
  if ! "$@"; then
    echo "FAIL: $what"
    failures=$((failures + 1))
  fi
}

finish() {
  echo "$((checks - failures)) passed, $failures failed"
  [ "$failures" = 0 ]
}
