# pf-render is deterministic: the same stream gives byte-identical PNGs on every run and whatever
# the number of llvmpipe rasteriser threads (LP_NUM_THREADS).
. "$(dirname "$0")/lib.sh"
gen="$bin/../tests/test_render"
[ -x "$gen" ] || { echo "FAIL: $gen (writes the test streams) is not built"; exit 1; }
"$gen" --write-beam "$tmp/beam.pfs" || { echo "FAIL: test_render --write-beam"; exit 1; }
"$bin/pf-shape" torus --segments 24 >"$tmp/torus.pfs" || { echo "FAIL: pf-shape torus"; exit 1; }

for mode in surface mesh stress; do
  for threads in 1 2; do
    expect 0 "" env LP_NUM_THREADS=$threads "$bin/pf-render" --quiet --size 320x180 \
      --mode "$mode" --out "$tmp/$mode-$threads" "$tmp/beam.pfs"
  done
  for f in 00000 00001; do
    check "$mode frame $f: identical bytes at 1 and 2 threads" \
      cmp "$tmp/$mode-1/frame_$f.png" "$tmp/$mode-2/frame_$f.png"
  done
done
# and run after run, on a surface with a shadow across it
for run in a b; do
  expect 0 "" env LP_NUM_THREADS=2 "$bin/pf-render" --quiet --size 320x180 --out "$tmp/torus-$run" \
    "$tmp/torus.pfs"
done
check "torus: identical bytes run after run" \
  cmp "$tmp/torus-a/frame_00000.png" "$tmp/torus-b/frame_00000.png"
finish
