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

# Version 7 of INFO, which is not critical: listed and skipped, as the spec says.
cp "$tmp/good.pfs" "$tmp/version.pfs"
printf '\007' | dd of="$tmp/version.pfs" bs=1 seek=12 conv=notrunc status=none
expect 0 "" "$bin/pf-info" "$tmp/version.pfs"
check "INFO version 7 is listed as skipped" \
  grep -q "^INFO  at byte 8: version 7, .* bytes (a version this pf does not read: skipped)" "$tmp/out"
check "the MESH after it is read" grep -q "^MESH" "$tmp/out"
# Version 7 of MESH, which is critical: refused, named.
info_size=$(od -An -tu8 -j 16 -N8 "$tmp/good.pfs" | tr -d ' ')
mesh_at=$((8 + 16 + info_size + 4))
cp "$tmp/good.pfs" "$tmp/mesh7.pfs"
printf '\007' | dd of="$tmp/mesh7.pfs" bs=1 seek=$((mesh_at + 4)) conv=notrunc status=none
expect 1 "version 7" "$bin/pf-info" "$tmp/mesh7.pfs"
check "the MESH version message names MESH" grep -q "MESH" "$tmp/err"

# Streams whose frames do not fit their mesh: pf-info refuses them as pf-render and pf-export do
# (the reader state's checks), after printing what came before, and --probe does not drop the bad frame silently.
gen="$bin/../tests/test_export"
for kind in nodes-124 nodes-130 mesh-id before-mesh id-reused; do
  "$gen" --write-bad "$kind" "$tmp/$kind.pfs" || { echo "FAIL: test_export --write-bad $kind"; exit 1; }
done
expect 1 "chunk FRAM at byte 10925: frame 0 has 124 nodes, but its MESH (mesh 1 with 125 nodes and 64 elements) has 125" \
  "$bin/pf-info" "$tmp/nodes-124.pfs"
check "the MESH before the bad frame is printed" grep -q "^MESH" "$tmp/out"
expect 1 "frame 0 has 130 nodes, but its MESH" "$bin/pf-info" --json "$tmp/nodes-130.pfs"
expect 1 "frame 0 refers to mesh 7, which no MESH chunk before it declares" "$bin/pf-info" "$tmp/mesh-id.pfs"
expect 1 "frame 0 refers to mesh 7" "$bin/pf-info" --probe 0,0,0 "$tmp/mesh-id.pfs"
expect 1 "frame 0 has 124 nodes" "$bin/pf-info" --probe 1,1,1 "$tmp/nodes-124.pfs"
expect 1 "chunk FRAM at byte 63: frame 1 refers to mesh 1, which no MESH chunk before it declares (the latest MESH is missing)" "$bin/pf-info" "$tmp/before-mesh.pfs"
expect 1 "mesh id 1 is already that of the MESH at byte 61" "$bin/pf-info" "$tmp/id-reused.pfs"
for kind in nodes-124 mesh-id before-mesh; do
  expect 1 "FRAM" "$bin/pf-render" --quiet --size 40x30 --out "$tmp/r-$kind" "$tmp/$kind.pfs"
  expect 1 "FRAM" "$bin/pf-export" --quiet --obj "$tmp/e-$kind" "$tmp/$kind.pfs"
done

# A finite but huge displacement (1e300 per component): pf-info prints its length, not inf;
# pf-render names the frame and the cause.
"$gen" --write-bad huge "$tmp/huge.pfs" || { echo "FAIL: test_export --write-bad huge"; exit 1; }
expect 0 "" "$bin/pf-info" "$tmp/huge.pfs"
check "largest displacement 1.73205e+300 (not inf)" grep -q "largest displacement 1.73205e+300" "$tmp/out"
expect 0 "" "$bin/pf-info" --json "$tmp/huge.pfs"
check "JSON max_displacement finite" grep -q '"max_displacement":1.73205080756887[0-9]*e+300' "$tmp/out"
expect 1 "frame 1: displaced positions reach 1e+300, beyond the 1e30" \
  "$bin/pf-render" --quiet --size 40x30 --out "$tmp/r-huge" "$tmp/huge.pfs"
checks=$((checks + 1))
if ! cat "$tmp/huge.pfs" | "$bin/pf-render" --quiet --size 40x30 --out "$tmp/r-huge-pipe" 2>"$tmp/err" &&
  grep -q "frame 1: displaced positions" "$tmp/err"; then :; else
  echo "FAIL: pf-render on a pipe: frame 1 not named: $(cat "$tmp/err")"; failures=$((failures + 1))
fi

# A STAT chunk (pf-sim's run statistics) cut short, with a damaged entry behind a valid CRC, and
# of a version this pf does not read: the message names STAT and its byte offset; the chunks
# before it are printed; the unknown version is listed and skipped (STAT is not critical).
printf '{"ground": false, "time": {"frames": 1, "dt": 0.01}}' >"$tmp/stat.json"
"$bin/pf-sim" "$tmp/stat.json" --quiet --input "$tmp/good.pfs" >"$tmp/stat.pfs" ||
  { echo "FAIL: pf-sim for a STAT chunk"; exit 1; }
stat_at=$(python3 - "$tmp/stat.pfs" <<'PY'
import struct, sys
data = open(sys.argv[1], "rb").read()
at = 8
while data[at:at + 4] != b"STAT":
    at += 20 + struct.unpack_from("<Q", data, at + 8)[0]
print(at)
PY
)
head -c $((stat_at + 40)) "$tmp/stat.pfs" >"$tmp/stat-cut.pfs"
expect 1 "truncated inside chunk STAT at byte $stat_at" "$bin/pf-info" "$tmp/stat-cut.pfs"
check "the frames before the cut STAT are printed" grep -q "^FRAM" "$tmp/out"
# the first key's length made 4000, the CRC recomputed: the decoder, not the framing, refuses it
python3 - "$tmp/stat.pfs" "$stat_at" "$tmp/stat-key.pfs" "$tmp/stat-v9.pfs" <<'PY'
import struct, sys, zlib
data = bytearray(open(sys.argv[1], "rb").read())
at = int(sys.argv[2])
size = struct.unpack_from("<Q", data, at + 8)[0]
v9 = bytearray(data)
struct.pack_into("<I", v9, at + 4, 9)
open(sys.argv[4], "wb").write(v9)
struct.pack_into("<I", data, at + 16 + 4, 4000)
struct.pack_into("<I", data, at + 16 + size, zlib.crc32(bytes(data[at + 16:at + 16 + size])))
open(sys.argv[3], "wb").write(data)
PY
expect 1 "chunk STAT at byte $stat_at: entry 0 at payload byte 4: a key of 4000 bytes runs past the payload" \
  "$bin/pf-info" "$tmp/stat-key.pfs"
expect 1 "chunk STAT at byte $stat_at" "$bin/pf-info" --json "$tmp/stat-key.pfs"
expect 0 "" "$bin/pf-info" "$tmp/stat-v9.pfs"
check "STAT version 9 is listed as skipped" \
  grep -q "^STAT  at byte $stat_at: version 9, .* (a version this pf does not read: skipped)" "$tmp/out"
# tools that read frames read past a damaged STAT's contents (they do not decode it)
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/e-stat" "$tmp/stat-key.pfs"

# A stream from stdin works like a file.
checks=$((checks + 1))
"$bin/pf-info" <"$tmp/good.pfs" >"$tmp/stdin.txt" 2>&1 || { echo "FAIL: pf-info from stdin"; failures=$((failures + 1)); }
finish
