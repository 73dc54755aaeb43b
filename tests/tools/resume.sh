# pf-sim --resume: a finished stream cut at many byte offsets (inside the signature, the INFO, a
# FRAM, right after a checkpoint, inside END_), resumed, must give the uninterrupted run's bytes;
# DG and CG with contact on a tilted ground and corotation, under the default solver and under
# pcg (whose decisions depend on the history), a static scene, an embedded surface with a mesh
# obstacle; refusals; the other tools skip the CKPT chunks.
. "$(dirname "$0")/lib.sh"
drop="$bin/../tests/test_export"
[ -x "$drop" ] || { echo "FAIL: $drop (drops chunks) is not built"; exit 1; }

cat >"$tmp/dg.json" <<'JSON'
{"material": {"E": 20000, "nu": 0.3, "density": 100},
 "method": {"name": "dg", "degree": 1},
 "gravity": [0, 0, -9.81],
 "ground": {"point": [0, 0, -0.05], "normal": [0.1, 0.05, 1], "stiffness": 1e5},
 "fixed": [{"box": [[-0.001, -1, -1], [0.001, 2, 2]]}],
 "time": {"frames": 12, "dt": 0.05, "substeps": 5}}
JSON
sed 's/"name": "dg", "degree": 1/"name": "cg"/' "$tmp/dg.json" >"$tmp/cg.json"
"$bin/pf-shape" box --extent 4,1,1 --cells 8,2,2 >"$tmp/beam.pfs" || { echo "FAIL: pf-shape"; exit 1; }

# The byte offsets of every chunk of a stream and their ends, from pf-info's chunk list.
chunk_bounds() {
  python3 - "$1" <<'PY'
import struct, sys
data = open(sys.argv[1], "rb").read()
at = 8
while at < len(data):
    tag = data[at:at + 4].decode()
    size = struct.unpack_from("<Q", data, at + 8)[0]
    end = at + 20 + size
    print(tag, at, end)
    at = end
PY
}

# cuts NAME FULL LEAST ARGS...: cuts FULL at offsets inside the signature and the first chunks, at
# every chunk's start (right after the chunk before), 30 bytes into it and its last byte, resumes each with ARGS and
# compares with FULL (at least LEAST cuts after the first checkpoint). Before the first
# checkpoint the resume must refuse, saying there is nothing to resume from.
cuts() {
  local name=$1 full=$2 least=$3
  shift 3
  chunk_bounds "$full" >"$tmp/bounds"
  local first_ckpt
  first_ckpt=$(awk '$1 == "CKPT" {print $3; exit}' "$tmp/bounds")
  local offsets="0 1 5 8 9 20"
  while read -r tag start end; do
    offsets="$offsets $start $((start + 30)) $((end - 1))"
  done <"$tmp/bounds"
  offsets="$offsets $(stat -c %s "$full")"
  local same=0 refused=0 wrong=0
  for cut in $(echo "$offsets" | tr ' ' '\n' | sort -nu); do
    head -c "$cut" "$full" >"$tmp/part.pfs"
    "$bin/pf-sim" --resume "$tmp/part.pfs" --quiet "$@" >"$tmp/res.pfs" 2>"$tmp/err"
    local rc=$?
    if [ "$cut" -lt "$first_ckpt" ]; then
      if [ $rc = 1 ] && grep -q "nothing to resume from" "$tmp/err"; then
        refused=$((refused + 1))
      else
        echo "FAIL: $name cut at $cut (before the first checkpoint): exit $rc, $(head -c 300 "$tmp/err")"
        wrong=$((wrong + 1))
      fi
    elif [ $rc = 0 ] && cmp -s "$tmp/res.pfs" "$full"; then
      same=$((same + 1))
    else
      echo "FAIL: $name cut at $cut: exit $rc, $(cmp "$tmp/res.pfs" "$full" 2>&1 | head -1) $(head -c 300 "$tmp/err")"
      wrong=$((wrong + 1))
    fi
  done
  echo "$name: $same cuts resumed to the same bytes, $refused refused before the first checkpoint"
  checks=$((checks + 1))
  [ $wrong = 0 ] && [ $same -ge "$least" ] && [ $refused -gt 3 ] || failures=$((failures + 1))
}

# The default solver (direct on meshes this small), and pcg at a tolerance where it iterates on
# old factors and refactorises when they fail or the matrix gains terms (contacts): a history the
# checkpoints restart.
for method in dg cg; do
  for solver in auto pcg; do
    full="$tmp/$method-$solver.pfs"
    opts="--solver auto"
    [ $solver = pcg ] && opts="--solver pcg --tolerance 1e-6"
    # shellcheck disable=SC2086
    expect 0 "" "$bin/pf-sim" "$tmp/$method.json" $opts --checkpoint-every 4 --input "$tmp/beam.pfs"
    mv "$tmp/out" "$full"
    check "$method $solver: contacts" grep -qE "[1-9][0-9]* contacts" "$tmp/err"
    [ $solver = pcg ] &&
      check "$method pcg: solves on old factors" grep -qE "pcg [1-9][0-9]* solves" "$tmp/err"
    cuts "$method-$solver" "$full" 10
  done
done

# Under the direct solver a checkpoint changes nothing but the CKPT chunks: the frames of runs
# with and without checkpoints are the same bytes.
for every in 0 1; do
  "$bin/pf-sim" "$tmp/dg.json" --solver direct --checkpoint-every $every --quiet \
    --input "$tmp/beam.pfs" >"$tmp/direct-$every.pfs"
  "$drop" --drop CKPT "$tmp/direct-$every.pfs" "$tmp/direct-$every.nockpt.pfs"
  # STAT too: it counts the factorisations, and a checkpoint's restart may cost one
  "$drop" --drop STAT "$tmp/direct-$every.nockpt.pfs" "$tmp/direct-$every.nostat.pfs"
  "$drop" --drop INFO "$tmp/direct-$every.nostat.pfs" "$tmp/direct-$every.frames.pfs"
done
check "direct: checkpoints leave the frames alone" \
  cmp -s "$tmp/direct-0.frames.pfs" "$tmp/direct-1.frames.pfs"
check "--checkpoint-every 0 writes no CKPT" sh -c "! grep -q CKPT '$tmp/direct-0.pfs'"

# A static scene: one frame and its checkpoint.
expect 0 "" "$bin/pf-sim" "$data/scenes/cantilever.json" --method cg --quiet --input "$tmp/beam.pfs"
mv "$tmp/out" "$tmp/static.pfs"
cuts static "$tmp/static.pfs" 3

# An embedded surface (contact at its vertices) with a mesh obstacle, default checkpoints.
"$bin/pf-shape" sphere --segments 12 >"$tmp/sphere.pfs" &&
  "$bin/pf-voxelize" --res 4 --quiet "$tmp/sphere.pfs" | "$bin/pf-embed" --quiet - >"$tmp/emb.pfs" ||
  { echo "FAIL: embedded stream"; exit 1; }
cp "$(dirname "$0")/../../data/scenes/wedge.obj" "$tmp/wedge.obj"
cat >"$tmp/emb.json" <<'JSON'
{"material": {"E": 30000, "nu": 0.4, "density": 1000},
 "gravity": [0, 0, -9.81],
 "ground": {"normal": [0, 0.2, 1]},
 "obstacles": [{"mesh": {"file": "wedge.obj", "depth": 0.2},
                "path": [{"time": 0, "translation": [0, 0, -1.3]}, {"time": 1, "translation": [0, 0, -0.9]}]}],
 "time": {"dt": 0.04, "frames": 21, "substeps": 4}}
JSON
expect 0 "" "$bin/pf-sim" "$tmp/emb.json" --input "$tmp/emb.pfs"
mv "$tmp/out" "$tmp/emb-full.pfs"
check "embedded: contact at the surface vertices" grep -q "contact at .* surface vertices" "$tmp/err"
cuts embedded "$tmp/emb-full.pfs" 10

# --output FILE: the same bytes through FILE.part; the partial itself may be the target.
full="$tmp/dg-auto.pfs"
head -c 20000 "$full" >"$tmp/p.pfs"
expect 0 "resuming" "$bin/pf-sim" --resume "$tmp/p.pfs" --output "$tmp/p.pfs"
check "--output over the partial: the uninterrupted bytes" cmp -s "$tmp/p.pfs" "$full"
check "--output leaves no .part" test ! -e "$tmp/p.pfs.part"
# the scene given again (file and overrides as in the run) is accepted; another one refused
head -c 20000 "$full" >"$tmp/p.pfs"
expect 0 "" "$bin/pf-sim" "$tmp/dg.json" --solver auto --resume "$tmp/p.pfs" --output "$tmp/q.pfs"
check "the same scene given: the same bytes" cmp -s "$tmp/q.pfs" "$full"
expect 1 "differs from the one stored" "$bin/pf-sim" "$tmp/dg.json" --E 30000 --resume "$tmp/p.pfs"
expect 1 "differs from the one stored" "$bin/pf-sim" "$tmp/cg.json" --resume "$tmp/p.pfs"
expect 1 "was written with 4" "$bin/pf-sim" --checkpoint-every 5 --resume "$tmp/p.pfs"
expect 2 "reads no input stream" "$bin/pf-sim" --input "$tmp/beam.pfs" --resume "$tmp/p.pfs"
# refusals: not pf-sim's, cut before the first checkpoint, no checkpoints, the output is the input
expect 1 "not written by pf-sim" "$bin/pf-sim" --resume "$tmp/beam.pfs"
expect 1 "not written by pf-sim" "$bin/pf-sim" --resume "$tmp/emb.pfs"
head -c 3000 "$tmp/direct-0.pfs" >"$tmp/p0.pfs"
expect 1 "nothing to resume from; rerun" "$bin/pf-sim" --resume "$tmp/p0.pfs"
expect 1 "--checkpoint-every 0" "$bin/pf-sim" --resume "$tmp/direct-0.pfs"
expect 1 "cannot open" "$bin/pf-sim" --resume "$tmp/missing.pfs"
checks=$((checks + 1))
"$bin/pf-sim" --resume "$tmp/p.pfs" >>"$tmp/p.pfs" 2>"$tmp/err" &&
  { echo "FAIL: resuming into the partial itself"; failures=$((failures + 1)); }
grep -q "the stream being resumed" "$tmp/err" ||
  { echo "FAIL: no message for stdout = partial: $(cat "$tmp/err")"; failures=$((failures + 1)); }
# a damaged checkpoint (its state's fingerprint) is refused naming the chunk
python3 - "$full" "$tmp/bad.pfs" <<'PY'
import struct, sys, zlib
data = bytearray(open(sys.argv[1], "rb").read())
at, last = 8, None
while at < len(data):
    size = struct.unpack_from("<Q", data, at + 8)[0]
    if data[at:at + 4] == b"CKPT" and at < 20000:
        last = (at, size)
    at += 20 + size
at, size = last
data[at + 16 + 48 + 12] ^= 1  # the state's fingerprint (after the 48-byte CKPT header)
struct.pack_into("<I", data, at + 16 + size, zlib.crc32(bytes(data[at + 16:at + 16 + size])))
open(sys.argv[2], "wb").write(data[:20000])
PY
expect 1 "chunk CKPT at byte" "$bin/pf-sim" --resume "$tmp/bad.pfs"
check "... saying what differs" grep -q "another scene, mesh or obstacle surface" "$tmp/err"

# a version 1 checkpoint (an older pf-sim: no run counters in its header) is refused, since the
# resumed run's STAT could not count the whole run
python3 - "$full" "$tmp/v1.pfs" <<'PY'
import struct, sys, zlib
data = bytes(open(sys.argv[1], "rb").read()[:20000])
out, at = bytearray(data[:8]), 8
while at + 16 <= len(data):
    size = struct.unpack_from("<Q", data, at + 8)[0]
    chunk = bytearray(data[at:at + 20 + size])
    if len(chunk) < 20 + size:
        break
    if chunk[:4] == b"CKPT":
        payload = chunk[16:32] + chunk[64:16 + size]  # the 16 bytes of version 1, the state
        chunk = bytearray(b"CKPT" + struct.pack("<IQ", 1, len(payload)) + payload +
                          struct.pack("<I", zlib.crc32(bytes(payload))))
    out += chunk
    at += 20 + size
open(sys.argv[2], "wb").write(out)
PY
expect 1 "a version 1 checkpoint, without the run's counters" "$bin/pf-sim" --resume "$tmp/v1.pfs"
check "... naming the chunk" grep -q "chunk CKPT at byte" "$tmp/err"
expect 1 "truncated" "$bin/pf-info" "$tmp/v1.pfs"
check "pf-info reads version 1 checkpoints" grep -q "^CKPT  [0-9]* checkpoints" "$tmp/out"

# A scene that refines changes its mesh between frames: no CKPT (a note when --checkpoint-every
# asks for them), and --resume refuses its stream, cut or whole, saying why.
expect 0 "the scene refines" "$bin/pf-sim" "$(dirname "$0")/../../data/scenes/cantilever_refine.json" --frames 12 \
  --checkpoint-every 2 --input "$tmp/beam.pfs"
mv "$tmp/out" "$tmp/refine.pfs"
check "refining: the mesh changed" grep -q "mesh changes: [1-9]" "$tmp/err"
check "refining: no CKPT" sh -c "! grep -q CKPT '$tmp/refine.pfs'"
expect 1 "mesh changed (refinement) is not supported yet" "$bin/pf-sim" --resume "$tmp/refine.pfs"
head -c 20000 "$tmp/refine.pfs" >"$tmp/refine-cut.pfs"
expect 1 "mesh changed (refinement) is not supported yet" "$bin/pf-sim" --resume "$tmp/refine-cut.pfs"
# a checkpoint of another mesh than the input's (as a refining run would write) is refused too
python3 - "$full" "$tmp/othermesh.pfs" <<'PY'
import struct, sys, zlib
data = bytearray(open(sys.argv[1], "rb").read())
at = 8
while at < len(data):
    size = struct.unpack_from("<Q", data, at + 8)[0]
    if data[at:at + 4] == b"CKPT":
        struct.pack_into("<Q", data, at + 16, struct.unpack_from("<Q", data, at + 16)[0] + 1)
        struct.pack_into("<I", data, at + 16 + size, zlib.crc32(bytes(data[at + 16:at + 16 + size])))
    at += 20 + size
open(sys.argv[2], "wb").write(data[:20000])
PY
expect 1 "mesh changed (refinement) is not supported yet" "$bin/pf-sim" --resume "$tmp/othermesh.pfs"
check "... naming the chunk" grep -q "chunk CKPT at byte" "$tmp/err"

# The other tools skip CKPT: pf-info lists them, pf-export and pf-render read every frame.
expect 0 "" "$bin/pf-info" "$full"
check "pf-info counts the checkpoints" grep -q "CKPT  4 checkpoints" "$tmp/out"
expect 0 "" "$bin/pf-info" --json "$full"
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/exp" "$full"
check "pf-export: every frame" test "$(ls "$tmp/exp" | grep -c '\.obj$')" = 13
expect 0 "" "$bin/pf-render" --quiet --size 64x48 --out "$tmp/png" "$full"
check "pf-render: every frame" test "$(ls "$tmp/png" | grep -c '\.png$')" = 13
finish
