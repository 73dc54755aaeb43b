# Damaged streams: one-line message naming the chunk and byte offset, exit 1, never a crash.
. "$(dirname "$0")/lib.sh"
"$bin/pf-shape" box --cells 2,1,1 >"$tmp/good.pfs" || { echo "FAIL: pf-shape"; exit 1; }
size=$(stat -c %s "$tmp/good.pfs")

expect 0 "" "$bin/pf-info" "$tmp/good.pfs"
expect 0 "" "$bin/pf-info" --json "$tmp/good.pfs"

: >"$tmp/empty.pfs"
expect 1 "empty" "$bin/pf-info" "$tmp/empty.pfs"
printf 'solid cube\nfacet normal 0 0 1\n' >"$tmp/text.pfs"
expect 1 "not a pf stream" "$bin/pf-info" "$tmp/text.pfs"

# Truncated inside the last chunk, and right before END_ (the MESH is still reported).
head -c $((size - 7)) "$tmp/good.pfs" >"$tmp/cut.pfs"
expect 1 "truncated" "$bin/pf-info" "$tmp/cut.pfs"
check "the chunks before the damage are printed" grep -q "^MESH" "$tmp/out"

# A flipped byte in the middle of the MESH payload: a CRC error naming MESH.
cp "$tmp/good.pfs" "$tmp/flip.pfs"
offset=$((size / 2))
byte=$(od -An -tu1 -j "$offset" -N1 "$tmp/flip.pfs" | tr -d ' ')
printf "$(printf '\\%03o' $(( (byte + 1) % 256 )))" |
  dd of="$tmp/flip.pfs" bs=1 seek="$offset" conv=notrunc status=none
expect 1 "CRC" "$bin/pf-info" "$tmp/flip.pfs"
check "the CRC message names MESH" grep -q "MESH" "$tmp/err"

# A chunk claiming 2^62 payload bytes is refused before allocating anything.
cp "$tmp/good.pfs" "$tmp/huge.pfs"
printf '\000\000\000\000\000\000\000\100' |
  dd of="$tmp/huge.pfs" bs=1 seek=16 conv=notrunc status=none
expect 1 "INFO" "$bin/pf-info" "$tmp/huge.pfs"

# Version 7 of INFO: unsupported, named.
cp "$tmp/good.pfs" "$tmp/version.pfs"
printf '\007' | dd of="$tmp/version.pfs" bs=1 seek=12 conv=notrunc status=none
expect 1 "version 7" "$bin/pf-info" "$tmp/version.pfs"

# A stream from stdin works like a file.
checks=$((checks + 1))
"$bin/pf-info" <"$tmp/good.pfs" >"$tmp/stdin.txt" 2>&1 || { echo "FAIL: pf-info from stdin"; failures=$((failures + 1)); }
finish
