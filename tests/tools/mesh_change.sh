# A mesh change mid-stream (a new MESH with a fresh id and recomputed WGHT before the next FRAM,
# as refinement and cutting write it): pf-info lists both meshes with their frames, pf-export
# writes each frame on its own mesh (VTU cells, OBJ counts), pf-render draws each frame on its own
# mesh and any --frames range gives the whole run's bytes; a frame naming no known mesh is refused.
. "$(dirname "$0")/lib.sh"
gen="$bin/../tests/test_stream_state"
[ -x "$gen" ] || { echo "FAIL: $gen (writes the test streams) is not built"; exit 1; }
"$gen" --write-two-meshes "$tmp/two.pfs" || { echo "FAIL: --write-two-meshes"; exit 1; }
"$gen" --write-bare "$tmp/bare.pfs" || { echo "FAIL: --write-bare"; exit 1; }
"$gen" --write-unknown-mesh "$tmp/bad.pfs" || { echo "FAIL: --write-unknown-mesh"; exit 1; }

# pf-info: each mesh and which frames use it
expect 0 "" "$bin/pf-info" "$tmp/two.pfs"
"$bin/pf-info" "$tmp/two.pfs" >"$tmp/info.txt" 2>&1
check "info: two meshes" grep -q '^meshes: 2$' "$tmp/info.txt"
check "info: mesh 1, frames 0 .. 1" grep -q 'mesh 1 (MESH at byte [0-9]*): 12 nodes, 2 elements; frames 0 .. 1 (2)$' "$tmp/info.txt"
check "info: mesh 2, frames 2 .. 3" grep -q 'mesh 2 (MESH at byte [0-9]*): 16 nodes, 3 elements; frames 2 .. 3 (2)$' "$tmp/info.txt"
"$bin/pf-info" --json "$tmp/two.pfs" >"$tmp/info.json" 2>&1
check "info --json: both meshes with their frames" grep -q '^{"meshes":\[{"id":1,"offset":[0-9]*,"nodes":12,"faces":11,"elements":2,"frames":2,"first_frame":0,"last_frame":1},{"id":2,"offset":[0-9]*,"nodes":16,"faces":16,"elements":3,"frames":2,"first_frame":2,"last_frame":3}\]}$' "$tmp/info.json"

# pf-export --vtu (ASCII, to read the values here): the cells change with the mesh, every frame keeps its stress
expect 0 "4 VTU files written" "$bin/pf-export" --ascii --vtu "$tmp/vtu" "$tmp/two.pfs"
for k in 0 1; do
  check "VTU frame $k: mesh 1" grep -q 'NumberOfPoints="12" NumberOfCells="2"' "$tmp/vtu/mesh_0000$k.vtu"
done
for k in 2 3; do
  check "VTU frame $k: mesh 2" grep -q 'NumberOfPoints="16" NumberOfCells="3"' "$tmp/vtu/mesh_0000$k.vtu"
done
for k in 0 1 2 3; do
  check "VTU frame $k: stress" grep -q 'Name="stress"' "$tmp/vtu/mesh_0000$k.vtu"
done
check "VTU frame 3: the stress of its 3 elements" test "$(sed -n '/Name="stress"/,/<\/DataArray>/p' "$tmp/vtu/mesh_00003.vtu" | sed -n '2,4p' | tr -d ' ' | tr '\n' ' ')" = "300 301 302 "
# the default binary VTU follows the mesh change too
expect 0 "4 VTU files written" "$bin/pf-export" --vtu "$tmp/vtub" "$tmp/two.pfs"
check "binary VTU frame 1: mesh 1" grep -aq 'NumberOfPoints="12" NumberOfCells="2"' "$tmp/vtub/mesh_00001.vtu"
check "binary VTU frame 3: mesh 2" grep -aq 'NumberOfPoints="16" NumberOfCells="3"' "$tmp/vtub/mesh_00003.vtu"
check "PVD lists four files" test "$(grep -c '<DataSet' "$tmp/vtu/mesh.pvd")" = 4
expect 0 "" "$bin/pf-export" --quiet --vtu "$tmp/vsel" --frames 2 "$tmp/two.pfs"
check "VTU --frames 2: mesh 2" grep -q 'NumberOfPoints="16" NumberOfCells="3"' "$tmp/vsel/mesh_00002.vtu"

# pf-export --obj: the embedded triangle moved by each mesh's weights; the boundary's counts change
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/obj" "$tmp/two.pfs"
check "OBJ frame 1 (mesh 1): corner (2,0,0) sagged by 0.02" grep -q '^v 2 0 -0.02$' "$tmp/obj/frame_00001.obj"
check "OBJ frame 3 (mesh 2): corner (2,0,0) sagged by 0.06" grep -q '^v 2 0 -0.059999999999999998$' "$tmp/obj/frame_00003.obj"
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/bobj" "$tmp/bare.pfs"
counts() { echo "$(grep -c '^v ' "$1") $(grep -c '^f ' "$1")"; }
check "boundary OBJ frame 1: 12 vertices, 20 triangles" test "$(counts "$tmp/bobj/frame_00001.obj")" = "12 20"
check "boundary OBJ frame 2: 16 vertices, 28 triangles" test "$(counts "$tmp/bobj/frame_00002.obj")" = "16 28"
expect 0 "" "$bin/pf-export" --quiet --ply "$tmp/bply" "$tmp/bare.pfs"
check "boundary PLY frame 3: 16 vertices" grep -aq '^element vertex 16$' "$tmp/bply/frame_00003.ply"

# pf-render: every frame, and every range byte-identical to the whole run's frames
for mode in surface mesh stress; do
  expect 0 "" "$bin/pf-render" --quiet --size 96x72 --mode $mode --out "$tmp/$mode" "$tmp/two.pfs"
  check "render $mode: four frames" test "$(ls "$tmp/$mode" | wc -l)" = 4
  for range in 2:3 1:2 3; do
    expect 0 "" "$bin/pf-render" --quiet --size 96x72 --mode $mode --frames $range --out "$tmp/$mode-$range" "$tmp/two.pfs"
    for png in "$tmp/$mode-$range"/*.png; do
      check "render $mode --frames $range: $(basename "$png") as in the whole run" \
        cmp -s "$png" "$tmp/$mode/$(basename "$png")"
    done
  done
done
check "render --frames 1:2: two frames" test "$(ls "$tmp/mesh-1:2" | tr '\n' ' ')" = "frame_00001.png frame_00002.png "
# the split element shows: frame 2 (mesh 2) is not frame 1 (mesh 1) moved
check "render mesh: frames 1 and 2 differ" bash -c "! cmp -s '$tmp/mesh/frame_00001.png' '$tmp/mesh/frame_00002.png'"
expect 0 "" "$bin/pf-render" --quiet --size 96x72 --mode mesh --out "$tmp/bare" "$tmp/bare.pfs"
check "render of the bare stream: four frames" test "$(ls "$tmp/bare" | wc -l)" = 4
checks=$((checks + 1))
if ! cat "$tmp/two.pfs" | "$bin/pf-render" --quiet --size 96x72 --out "$tmp/pipe" 2>"$tmp/err" ||
  [ "$(ls "$tmp/pipe" | wc -l)" != 4 ]; then
  echo "FAIL: pf-render on a pipe: $(cat "$tmp/err")"; failures=$((failures + 1))
fi

# a frame whose mesh id no MESH declared: refused, naming the chunk; the frames before it stay
why="chunk FRAM at byte"
expect 1 "$why" "$bin/pf-info" "$tmp/bad.pfs"
expect 1 "frame 3 refers to mesh 9, which no MESH chunk before it declares" "$bin/pf-info" "$tmp/bad.pfs"
expect 1 "$why" "$bin/pf-export" --quiet --vtu "$tmp/bvtu" "$tmp/bad.pfs"
check "export: frames 0 .. 2 before the bad one" test "$(ls "$tmp/bvtu" | wc -l)" = 4
expect 1 "$why" "$bin/pf-export" --quiet --obj "$tmp/bobj2" --frames 0:1 "$tmp/bad.pfs"
expect 1 "refers to mesh 9" "$bin/pf-render" --quiet --size 96x72 --out "$tmp/brender" "$tmp/bad.pfs"
check "render: frames 0 .. 2 before the bad one" test "$(ls "$tmp/brender" | wc -l)" = 3
expect 1 "refers to mesh 9" "$bin/pf-render" --quiet --size 96x72 --frames 0 --out "$tmp/brender0" "$tmp/bad.pfs"
finish
