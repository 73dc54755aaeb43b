# What a cut leaves in a stream (a new MESH, a new SURF with cap triangles and its WGHT between
# frames): pf-info lists each surface with its caps and frames, pf-render draws the caps in their
# own colour (counted in the images) and each frame on the surface in force at it (any --frames
# range gives the whole run's bytes), the bare mesh boundary shows the cut faces, pf-export puts
# the caps in their own OBJ group and material, a PLY face property and a USD GeomSubset; a SURF
# cut short is refused naming the chunk.
. "$(dirname "$0")/lib.sh"
gen="$bin/../tests/test_stream_caps"
[ -x "$gen" ] || { echo "FAIL: $gen (writes the test streams) is not built"; exit 1; }
"$gen" --write-cut "$tmp/cut.pfs" || { echo "FAIL: --write-cut"; exit 1; }
"$gen" --write-cut-bare "$tmp/bare.pfs" || { echo "FAIL: --write-cut-bare"; exit 1; }
near() { "$gen" --count-near "$1" "$2"; }

# pf-info: both surfaces, the caps of the second, the frames drawn on each
"$bin/pf-info" "$tmp/cut.pfs" >"$tmp/info.txt" 2>&1
check "info: two surfaces" grep -q '^surfaces: 2$' "$tmp/info.txt"
check "info: surface 1 without caps, frames 0 .. 1" grep -q 'surface 1 (SURF at byte [0-9]*): 8 vertices, 12 triangles, 0 caps; frames 0 .. 1 (2)$' "$tmp/info.txt"
check "info: surface 2 with 4 caps, frames 2 .. 3" grep -q 'surface 2 (SURF at byte [0-9]*): 16 vertices, 24 triangles, 4 caps; frames 2 .. 3 (2)$' "$tmp/info.txt"
check "info: the SURF chunk's caps" grep -q '4 cap triangles (closing cuts), 20 of the model' "$tmp/info.txt"
"$bin/pf-info" --json "$tmp/cut.pfs" >"$tmp/info.json" 2>&1
check "info --json: the surfaces" grep -q '^{"surfaces":\[{"id":1,"offset":[0-9]*,"vertices":8,"triangles":12,"caps":0,"frames":2,"first_frame":0,"last_frame":1},{"id":2,"offset":[0-9]*,"vertices":16,"triangles":24,"caps":4,"frames":2,"first_frame":2,"last_frame":3}\]}$' "$tmp/info.json"
check "info --json: SURF version 2 with its caps" grep -q '^{"chunk":"SURF","offset":[0-9]*,"version":2,"id":2,.*"caps":4,' "$tmp/info.json"

# pf-render: the caps (a warm red, sRGB cc6b57) show once the boxes part, and only then
size="--size 160x120"
expect 0 "" "$bin/pf-render" --quiet $size --out "$tmp/r" "$tmp/cut.pfs"
check "render: four frames" test "$(ls "$tmp/r" | wc -l)" = 4
for k in 0 1; do
  n=$(near "$tmp/r/frame_0000$k.png" cc6b57)
  check "render frame $k (before the cut): no cap colour ($n pixels)" test "$n" -eq 0
done
caps=$(near "$tmp/r/frame_00003.png" cc6b57)
check "render frame 3: the cap colour on more than 1 % of the image ($caps pixels)" test "$caps" -gt 192
check "render frame 3: the cap is more visible than in frame 2" test "$caps" -gt "$(near "$tmp/r/frame_00002.png" cc6b57)"
# --cap-color: the same pixels in another colour
expect 0 "" "$bin/pf-render" --quiet $size --cap-color '#3050e0' --out "$tmp/blue" "$tmp/cut.pfs"
blue=$(near "$tmp/blue/frame_00003.png" 3050e0)
check "render --cap-color 3050e0: no red left ($(near "$tmp/blue/frame_00003.png" cc6b57))" test "$(near "$tmp/blue/frame_00003.png" cc6b57)" -eq 0
check "render --cap-color 3050e0: the caps' pixels ($blue, red $caps)" test "$blue" -ge $((caps * 9 / 10)) -a "$blue" -le $((caps * 11 / 10))
expect 2 "--cap-color expects 6 hex digits" "$bin/pf-render" --cap-color red "$tmp/cut.pfs"
# every range gives the whole run's bytes, across the change of surface; a pipe the same frames
for mode in surface stress; do
  [ $mode = surface ] || expect 0 "" "$bin/pf-render" --quiet $size --mode $mode --out "$tmp/$mode" "$tmp/cut.pfs"
  [ $mode = surface ] && cp -r "$tmp/r" "$tmp/$mode"
  check "render $mode: four frames" test "$(ls "$tmp/$mode" | wc -l)" = 4
  for range in 1:2 2:3 3; do
    expect 0 "" "$bin/pf-render" --quiet $size --mode $mode --frames $range --out "$tmp/$mode-$range" "$tmp/cut.pfs"
    for png in "$tmp/$mode-$range"/*.png; do
      check "render $mode --frames $range: $(basename "$png") as in the whole run" \
        cmp -s "$png" "$tmp/$mode/$(basename "$png")"
    done
  done
done
checks=$((checks + 1))
if ! cat "$tmp/cut.pfs" | "$bin/pf-render" --quiet $size --out "$tmp/pipe" 2>"$tmp/err" ||
  [ "$(near "$tmp/pipe/frame_00003.png" cc6b57)" -lt 100 ]; then
  echo "FAIL: pf-render on a pipe draws the caps: $(cat "$tmp/err")"; failures=$((failures + 1))
fi
# without a surface the mesh boundary is drawn: the cut faces are boundary faces and appear
# where the caps were (in the model's colour): as much body as the capped surface shows
expect 0 "" "$bin/pf-render" --quiet $size --out "$tmp/bare" "$tmp/bare.pfs"
body=$(( $(near "$tmp/r/frame_00003.png" d1bda8) + caps ))
bare=$(near "$tmp/bare/frame_00003.png" d1bda8)
check "render bare frame 3: no cap colour" test "$(near "$tmp/bare/frame_00003.png" cc6b57)" -eq 0
check "render bare frame 3: the cut face drawn ($bare body pixels, capped surface $body)" \
  test "$bare" -ge $((body * 95 / 100))

# pf-export: caps in their own group and material (OBJ), face property (PLY), subset (USD)
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/obj" "$tmp/cut.pfs"
check "OBJ frame 1: no groups before the cut" test "$(grep -c '^g ' "$tmp/obj/frame_00001.obj")" = 0
for k in 2 3; do
  f="$tmp/obj/frame_0000$k.obj"
  check "OBJ frame $k: g cap and usemtl cap" test "$(grep -A1 '^g cap$' "$f" | grep -c '^usemtl cap$')" = 2
  check "OBJ frame $k: 4 cap faces" test "$(awk '/^g /{p=$2} /^f /&&p=="cap"{n++} END{print n+0}' "$f")" = 4
  check "OBJ frame $k: 20 model faces" test "$(awk '/^g /{p=$2} /^f /&&p=="model"{n++} END{print n+0}' "$f")" = 20
done
check "OBJ frame 3: the second box risen by 1.6" grep -q '^v 1.3999999999999999 0 1.6000000000000001$' "$tmp/obj/frame_00003.obj"
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/obj3" --frames 3 "$tmp/cut.pfs"
check "OBJ --frames 3: as in the whole run" cmp -s "$tmp/obj3/frame_00003.obj" "$tmp/obj/frame_00003.obj"
expect 0 "" "$bin/pf-export" --quiet --ply "$tmp/ply" "$tmp/cut.pfs"
check "PLY frame 1: no part property" bash -c "! grep -aq 'property uchar part' '$tmp/ply/frame_00001.ply'"
check "PLY frame 2: the face property part" grep -aq '^property uchar part$' "$tmp/ply/frame_00002.ply"
expect 0 "" "$bin/pf-export" --quiet --usd "$tmp/cut.usda" "$tmp/cut.pfs"
check "USD: the GeomSubset cap" grep -q 'def GeomSubset "cap"' "$tmp/cut.usda"
check "USD: no caps at frame 0, four from frame 2" test "$(sed -n '/GeomSubset/,$p' "$tmp/cut.usda" | grep -c '^ *0: \[\],$\|^ *2: \[10, 11, 20, 21\],$')" = 2
expect 0 "4 VTU files written" "$bin/pf-export" --vtu "$tmp/vtu" "$tmp/cut.pfs"

# a SURF cut short: refused naming the chunk; the frames before it are drawn
off=$(sed -n 's/^{"chunk":"SURF","offset":\([0-9]*\),"version":2.*/\1/p' "$tmp/info.json")
head -c $((off + 300)) "$tmp/cut.pfs" >"$tmp/short.pfs"
expect 1 "truncated inside chunk SURF at byte $off" "$bin/pf-info" "$tmp/short.pfs"
expect 1 "chunk SURF at byte $off" "$bin/pf-render" --quiet $size --out "$tmp/short" "$tmp/short.pfs"
check "render of the short stream: frames 0 and 1" test "$(ls "$tmp/short" | tr '\n' ' ')" = "frame_00000.png frame_00001.png "
finish
