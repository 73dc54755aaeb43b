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

# golden_png NAME PNG DIR: compares PNG with DIR/NAME.png (pf-imgdiff --tol 3 --max-fraction
# 0.01, see render.sh). With PF_UPDATE_GOLDEN=1 it copies PNG over the golden instead and compares
# nothing: a run that rewrites goldens tests nothing, and finish then fails so that it is never
# mistaken for a passing run.
updated=0
golden_png() {
  local name=$1 png=$2 dir=$3
  if [ "${PF_UPDATE_GOLDEN:-0}" = 1 ]; then
    checks=$((checks + 1))
    if mkdir -p "$dir" && cp "$png" "$dir/$name.png"; then
      echo "updated $dir/$name.png"
      updated=$((updated + 1))
    else
      echo "FAIL: cannot update $dir/$name.png"
      failures=$((failures + 1))
    fi
    return
  fi
  expect 0 "" "$bin/pf-imgdiff" --tol 3 --max-fraction 0.01 --diff "$tmp/$name.diff.png" \
    "$png" "$dir/$name.png"
}

finish() {
  echo "$((checks - failures)) passed, $failures failed"
  if [ "$updated" != 0 ]; then
    echo "$updated goldens rewritten (PF_UPDATE_GOLDEN=1): review and commit them, then run" \
      "again without PF_UPDATE_GOLDEN to test"
    return 1
  fi
  [ "$failures" = 0 ]
}
