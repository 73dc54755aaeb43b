# pf-sim --frames as pf-render's and pf-export's: A:B simulates up to frame B and writes frames
# A..B only, the same bits as those frames of the whole run; a lone N stays a count (0..N).
. "$(dirname "$0")/lib.sh"
"$bin/pf-shape" box --extent 1,1,1 --cells 2,2,2 >"$tmp/cube.pfs" || { echo "FAIL: pf-shape"; exit 1; }
"$bin/pf-sim" --frames 4 --quiet <"$tmp/cube.pfs" >"$tmp/full.pfs"
"$bin/pf-sim" --frames 2:4 --quiet <"$tmp/cube.pfs" >"$tmp/part.pfs"
"$bin/pf-info" "$tmp/part.pfs" >"$tmp/part.txt"
check "--frames 2:4 writes frames 2, 3, 4" \
  grep -q '^FRAM .*: 3 frames of mesh 0, time 0.0666667 .. 0.133333' "$tmp/part.txt"
check "and END_ counts those 3" grep -q '^END_ .*, 3 frames$' "$tmp/part.txt"
check "the scene records frames = 4" bash -c "'$bin/pf-info' --scene '$tmp/part.pfs' | grep -q '\"frames\":.4,'"
"$bin/pf-export" --vtu "$tmp/whole" --ascii --frames 2:4 --quiet "$tmp/full.pfs"
"$bin/pf-export" --vtu "$tmp/range" --ascii --quiet "$tmp/part.pfs"
check "frames 2..4 are those of the whole run, bit for bit (17 digits)" diff -r "$tmp/whole" "$tmp/range"
check "three frame files" test "$(ls "$tmp/range"/*.vtu | wc -l)" = 3

# ':B' and a lone B: frames 0..B; 'A:' up to the scene's frames (here set by a count first)
"$bin/pf-sim" --frames :4 --quiet <"$tmp/cube.pfs" >"$tmp/upto.pfs"
"$bin/pf-export" --vtu "$tmp/upto" --ascii --quiet "$tmp/upto.pfs"
"$bin/pf-export" --vtu "$tmp/count" --ascii --quiet "$tmp/full.pfs"
check "--frames :4 is --frames 4" diff -r "$tmp/upto" "$tmp/count"
"$bin/pf-sim" --frames 4 --frames 3: --quiet <"$tmp/cube.pfs" >"$tmp/from.pfs"
check "--frames 4 --frames 3: writes frames 3 and 4" \
  bash -c "'$bin/pf-info' '$tmp/from.pfs' | grep -q '^FRAM .*: 2 frames of mesh 0, time 0.1 .. 0.133333'"

# bad ranges are usage errors (exit 2)
expect 2 "--frames expects A:B" "$bin/pf-sim" --frames 4:2 --input "$tmp/cube.pfs"
expect 2 "--frames 5: the scene makes frames 0 to 4 only" \
  "$bin/pf-sim" --frames 4 --frames 5: --input "$tmp/cube.pfs"
expect 2 "--frames 1: the scene makes frames 0 to 0 only" \
  "$bin/pf-sim" "$data/scenes/cantilever.json" --frames 1:1 --input "$tmp/cube.pfs"
expect 2 "frames: must be" "$bin/pf-sim" --frames 0:4294967295 --input "$tmp/cube.pfs"
finish
