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
finish
