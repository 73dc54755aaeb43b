# Every tool: --help, --version, bad usage exits 2, refuses binary output to a terminal.
. "$(dirname "$0")/lib.sh"
for tool in "$bin"/pf-*; do
  name=$(basename "$tool")
  expect 0 "" "$tool" --help
  check "$name --help prints a usage line" grep -q "^Usage: $name" "$tmp/out"
  expect 0 "" "$tool" --version
  check "$name --version names the tool" grep -q "^$name (pf) " "$tmp/out"
  expect 2 "unknown option '--no-such-option'" "$tool" --no-such-option
done
# Binary to a terminal: only testable where a pseudo-terminal can be had (script(1)).
if command -v script >/dev/null 2>&1; then
  checks=$((checks + 1))
  if script -qec "$bin/pf-shape torus" /dev/null >"$tmp/tty" 2>&1; then
    echo "FAIL: pf-shape wrote binary to a terminal"; failures=$((failures + 1))
  elif ! grep -q "refusing to write a binary pf stream to a terminal" "$tmp/tty"; then
    echo "FAIL: no refusal message: $(head -c 300 "$tmp/tty")"; failures=$((failures + 1))
  fi
fi
# one meaning per flag name: pf-shape's --res (segments) and --size (extent) are deprecated
# spellings of --segments and --extent, still working, with a note
"$bin/pf-shape" torus --segments 8 >"$tmp/seg.pfs"
expect 0 "--res is deprecated, use --segments" "$bin/pf-shape" torus --res 8
same_shape() { # the same chunks but INFO (which holds the command line, so offsets shift)
  test "$("$bin/pf-info" --print-mesh "$1" | grep -v '^INFO' | sed 's/at byte [0-9]*//')" = \
       "$("$bin/pf-info" --print-mesh "$2" | grep -v '^INFO' | sed 's/at byte [0-9]*//')"
}
check "pf-shape --res 8 = --segments 8" same_shape "$tmp/out" "$tmp/seg.pfs"
"$bin/pf-shape" box --extent 2,1,1 --cells 2,1,1 >"$tmp/ext.pfs"
expect 0 "--size is deprecated, use --extent" "$bin/pf-shape" box --size 2,1,1 --cells 2,1,1
check "pf-shape box --size = --extent" same_shape "$tmp/out" "$tmp/ext.pfs"
expect 0 "" "$bin/pf-shape" box --extent 2,1,1
check "no note for the current spelling" test ! -s "$tmp/err"
finish
