# Pinned results: the SHA-256 of short DG and CG runs (their streams, INFO chunks left out since
# they hold the command line, and the PNG of their last frame) at 1 and 2 threads, against the
# hashes in tests/golden/determinism.txt. Any change of the numbers, however small, shows here and
# must be explained in its commit; the hashes are then regenerated with
#   PF_UPDATE_GOLDEN=1 ctest -R tool_determinism    (or this script with PF_UPDATE_GOLDEN=1)
# which rewrites the file (and fails, having tested nothing). The PNG hashes hold for one Mesa
# build (render.sh compares images with a tolerance across builds).
#
# "Threads" is OMP_NUM_THREADS and LP_NUM_THREADS. Both thread counts are pinned, and the runs
# whose numbers pf keeps independent of the thread count are checked equal across them. Known
# exception: CG with harmonic (MFS) elements, whose dense least squares run in OpenBLAS, which
# takes its thread count from OMP_NUM_THREADS (or OPENBLAS_NUM_THREADS) outside CHOLMOD calls:
# 2 threads change the last bits (about 1e-14 relative) of the cg_torus stream; its image is
# the same.
. "$(dirname "$0")/lib.sh"
pinned="$(cd "$(dirname "$0")/../golden" && pwd)/determinism.txt"
drop="$bin/../tests/test_export"
[ -x "$drop" ] || { echo "FAIL: $drop (drops INFO chunks) is not built"; exit 1; }

cat >"$tmp/dg.json" <<'JSON'
{"material": {"E": 20000, "nu": 0.3, "density": 100},
 "method": {"name": "dg", "degree": 2, "flux": "ip"},
 "gravity": [0, 0, -9.81],
 "ground": {"point": [0, 0, -0.05], "stiffness": 1e5},
 "fixed": [{"box": [[-0.001, -1, -1], [0.001, 2, 2]]}],
 "time": {"frames": 4, "dt": 0.05}}
JSON
sed 's/"name": "dg", "degree": 2, "flux": "ip"/"name": "cg"/' "$tmp/dg.json" >"$tmp/cg.json"
# The torus lies across z = 0: no ground for it, the ground above would be inside the body.
sed 's/"ground": {"point": \[0, 0, -0.05\], "stiffness": 1e5},/"ground": false,/' "$tmp/cg.json" \
  >"$tmp/cgt.json"
# A beam of hexes and a sliced torus (hexes and harmonic polyhedra) for CG's MFS path.
"$bin/pf-shape" box --size 4,1,1 --cells 4,1,1 >"$tmp/beam.pfs" || { echo "FAIL: pf-shape"; exit 1; }
"$bin/pf-shape" torus --res 10 | "$bin/pf-slice" --res 4 --quiet >"$tmp/torus.pfs" ||
  { echo "FAIL: torus"; exit 1; }

: >"$tmp/hashes"
for threads in 1 2; do
  for run in dg:beam:dg_beam cg:beam:cg_beam cgt:torus:cg_torus; do
    IFS=: read -r scene mesh name <<<"$run"
    out="$tmp/$name-$threads"
    expect 0 "" env OMP_NUM_THREADS=$threads LP_NUM_THREADS=$threads "$bin/pf-sim" \
      "$tmp/$scene.json" --quiet --input "$tmp/$mesh.pfs"
    "$drop" --drop INFO "$tmp/out" "$out.pfs" || { echo "FAIL: dropping INFO"; exit 1; }
    expect 0 "" env LP_NUM_THREADS=$threads "$bin/pf-render" --quiet --size 160x120 \
      --frames 4 --out "$out" "$out.pfs"
    echo "$name stream $(sha256sum <"$out.pfs" | cut -c1-64)" >>"$tmp/hashes-$threads"
    echo "$name png $(sha256sum <"$out/frame_00004.png" | cut -c1-64)" >>"$tmp/hashes-$threads"
  done
done
check "1 and 2 threads give the same bytes (all but the cg_torus stream)" \
  cmp -s <(grep -v "cg_torus stream" "$tmp/hashes-1") <(grep -v "cg_torus stream" "$tmp/hashes-2")
sed 's/^/threads 1 /' "$tmp/hashes-1" >"$tmp/hashes"
sed 's/^/threads 2 /' "$tmp/hashes-2" >>"$tmp/hashes"
if [ "${PF_UPDATE_GOLDEN:-0}" = 1 ]; then
  { echo "# SHA-256 of short runs: tests/tools/determinism.sh (PF_UPDATE_GOLDEN=1 rewrites this file)"
    cat "$tmp/hashes"; } >"$pinned"
  echo "updated $pinned"
  updated=1
else
  checks=$((checks + 1))
  if ! diff <(grep -v '^#' "$pinned") "$tmp/hashes" >"$tmp/diff"; then
    echo "FAIL: results differ from tests/golden/determinism.txt (explain the change in its commit," \
      "then regenerate with PF_UPDATE_GOLDEN=1):"
    cat "$tmp/diff"
    failures=$((failures + 1))
  fi
fi
finish
