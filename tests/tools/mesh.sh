# pf-slice, pf-voxelize and pf-octree: exact volume through the pipe, counts, bad input.
. "$(dirname "$0")/lib.sh"

# A sphere sliced at 10 cells: the MESH volume equals the SURF's enclosed volume (1e-9).
"$bin/pf-shape" sphere >"$tmp/sphere.pfs" || { echo "FAIL: pf-shape sphere"; exit 1; }
expect 0 "pf-slice" "$bin/pf-slice" --res 10 "$tmp/sphere.pfs"
"$bin/pf-slice" --res 10 --quiet <"$tmp/sphere.pfs" | "$bin/pf-info" --json - >"$tmp/info.json"
surf=$(grep '"chunk":"SURF"' "$tmp/info.json" | grep -o '"volume":[^,]*' | cut -d: -f2)
mesh=$(grep '"chunk":"MESH"' "$tmp/info.json" | grep -o '"volume":[^,]*' | cut -d: -f2)
check "sliced volume $mesh equals the surface's $surf" \
  awk -v a="$mesh" -v b="$surf" 'BEGIN { e = a / b - 1; exit !(e < 1e-9 && e > -1e-9) }'
check "the sliced mesh is valid" grep -q '"valid":true' "$tmp/info.json"
check "polyhedra at the surface" bash -c "grep '\"chunk\":\"MESH\"' '$tmp/info.json' | grep -vq '\"polyhedra\":0'"

# A surface file directly; the grid-aligned unit cube gives 64 cells of exact volume.
"$bin/pf-slice" --cell 0.25 --origin 0,0,0 --quiet "$data/cube.obj" | "$bin/pf-info" --json - >"$tmp/cube.json"
check "64 elements of the cube" grep -q '"elements":64,' "$tmp/cube.json"
"$bin/pf-voxelize" --res 4 --quiet "$data/cube.obj" | "$bin/pf-info" --json - >"$tmp/vox.json"
check "voxelized cube: 64 hexes" grep -q '"hexes":64' "$tmp/vox.json"

# pf-octree: with --slice the volume is exact; without, the cells inside. Counts grow about 4x per
# level (the surface's area), not 8x (its volume): the library test justifies the window.
"$bin/pf-octree" --depth 4 --slice --quiet "$tmp/sphere.pfs" | "$bin/pf-info" --json - >"$tmp/oct.json"
surf=$(grep '"chunk":"SURF"' "$tmp/oct.json" | grep -o '"volume":[^,]*' | cut -d: -f2)
mesh=$(grep '"chunk":"MESH"' "$tmp/oct.json" | grep -o '"volume":[^,]*' | cut -d: -f2)
check "octree volume $mesh equals the surface's $surf" \
  awk -v a="$mesh" -v b="$surf" 'BEGIN { e = a / b - 1; exit !(e < 1e-9 && e > -1e-9) }'
check "the octree mesh is valid" grep -q '"valid":true' "$tmp/oct.json"
expect 0 "ray-crossing test" "$bin/pf-octree" --depth 4 "$tmp/sphere.pfs"
expect 0 "cell faces split" "$bin/pf-octree" --depth 4 "$tmp/sphere.pfs"
count() { "$bin/pf-octree" --depth "$1" --quiet "$tmp/sphere.pfs" | "$bin/pf-info" --json - |
  grep '"chunk":"MESH"' | grep -o '"elements":[0-9]*' | cut -d: -f2; }
n5=$(count 5) n6=$(count 6)
check "octree elements $n5 -> $n6 grow like the area" \
  awk -v a="$n5" -v b="$n6" 'BEGIN { r = b / a; exit !(r > 3.5 && r < 4.7) }'
# The unit cube fills its bounding cube, its faces on the root's planes: every cell is whole.
"$bin/pf-octree" --depth 3 --slice --quiet "$data/cube.obj" | "$bin/pf-info" --json - >"$tmp/ocube.json"
check "sliced octree of the cube: 8 cells of depth 2 and 448 of depth 3, volume 1" \
  grep -q '"elements":456,.*"volume":1,' "$tmp/ocube.json"
check "the cube's octree mesh is valid" grep -q '"valid":true' "$tmp/ocube.json"
expect 0 "winding-number test" "$bin/pf-octree" --depth 3 "$data/open_box.obj"
expect 1 "open_box.obj: slicing needs a closed, manifold" "$bin/pf-octree" --slice --exact "$data/open_box.obj"
expect 0 "winding-number solid was sliced" "$bin/pf-octree" --depth 3 --slice "$data/open_box.obj"
expect 2 "" "$bin/pf-octree" --depth 0 "$data/cube.obj"
expect 2 "" "$bin/pf-octree" --depth 3 --min-depth 4 "$data/cube.obj"
expect 2 "" "$bin/pf-octree" --merge 0.1 "$data/cube.obj"

# Bad input and usage.
expect 1 "closed" "$bin/pf-slice" --exact "$data/open_box.obj"
expect 0 "winding-number solid was sliced" "$bin/pf-slice" --res 6 "$data/open_box.obj"
"$bin/pf-slice" --res 6 --quiet "$data/open_box.obj" | "$bin/pf-info" --json - >"$tmp/open.json"
check "the open box's robust slice is valid" grep -q '"valid":true' "$tmp/open.json"
expect 2 "--up" "$bin/pf-slice" --up w "$data/cube.obj"
# Collada is +y up: turned onto +z by default (assimp-testmodels, installed by scripts/setup).
duck=/usr/share/assimp/models/Collada/duck.dae
if [ -f "$duck" ]; then
  expect 0 "import: up y" "$bin/pf-slice" --res 6 "$duck"
  expect 0 "import: up z" "$bin/pf-slice" --res 6 --up z "$duck"
fi
# --repair: the open box's missing top (perimeter 4, 2.3 times the diagonal) is filled when the
# limit allows it, and the closed box then slices exactly, volume 1; within the default limit it
# stays open and the robust mode takes over.
expect 0 "1 of 1 holes filled with 2 triangles: closed and manifold" \
  "$bin/pf-slice" --res 4 --exact --repair=3 "$data/open_box.obj"
"$bin/pf-octree" --depth 2 --slice --exact --repair=3 --quiet "$data/open_box.obj" |
  "$bin/pf-info" --json - >"$tmp/repaired.json"
check "the repaired box's octree mesh has volume 1" \
  grep -q '"chunk":"MESH".*"volume":1,' "$tmp/repaired.json"
expect 0 "0 of 1 holes filled" "$bin/pf-slice" --res 4 --repair "$data/open_box.obj"
expect 0 "winding-number solid was sliced" "$bin/pf-slice" --res 4 --repair "$data/open_box.obj"
expect 2 "--repair" "$bin/pf-slice" --repair=-1 "$data/cube.obj"
expect 2 "--scale" "$bin/pf-slice" --scale 0 "$data/cube.obj"
expect 2 "--refine" "$bin/pf-slice" --refine 9 "$data/cube.obj"
expect 0 "winding" "$bin/pf-voxelize" --res 4 "$data/open_box.obj"
expect 0 "winding" "$bin/pf-voxelize" --res 4 --keep-islands "$data/open_box.obj"
expect 1 "empty.msh" "$bin/pf-slice" "$data/empty.msh"
"$bin/pf-shape" box --cells 1,1,1 >"$tmp/box.pfs"
expect 1 "no SURF" "$bin/pf-slice" "$tmp/box.pfs"
expect 2 "" "$bin/pf-slice" --merge 2 "$data/cube.obj"
expect 2 "" "$bin/pf-slice" --res 0 "$data/cube.obj"

# The Stanford bunny, a scanned surface, through the pipe at 16 and 32 cells: the sliced volume is
# the surface's (1e-9, as above) and the mesh valid; the voxels (cells whose centre is inside) are
# a valid mesh, and fewer than the cells overlapping the surface, which cover the solid.
models=$data/../../data/models
for res in 16 32; do
  "$bin/pf-slice" --res $res --quiet "$models/bunny.obj" | "$bin/pf-info" --json - >"$tmp/bunny.json"
  surf=$(grep '"chunk":"SURF"' "$tmp/bunny.json" | grep -o '"volume":[^,]*' | cut -d: -f2)
  mesh=$(grep '"chunk":"MESH"' "$tmp/bunny.json" | grep -o '"volume":[^,]*' | cut -d: -f2)
  check "bunny at $res: sliced volume $mesh equals the surface's $surf" \
    awk -v a="$mesh" -v b="$surf" 'BEGIN { e = a / b - 1; exit !(e < 1e-9 && e > -1e-9) }'
  check "bunny at $res: the sliced mesh is valid" grep -q '"valid":true' "$tmp/bunny.json"
  "$bin/pf-voxelize" --res $res --quiet "$models/bunny.obj" | "$bin/pf-info" --json - >"$tmp/bvox.json"
  "$bin/pf-voxelize" --res $res --mode overlap --quiet "$models/bunny.obj" |
    "$bin/pf-info" --json - >"$tmp/bover.json"
  inside=$(grep '"chunk":"MESH"' "$tmp/bvox.json" | grep -o '"volume":[^,]*' | cut -d: -f2)
  over=$(grep '"chunk":"MESH"' "$tmp/bover.json" | grep -o '"volume":[^,]*' | cut -d: -f2)
  check "bunny at $res: voxels valid" grep -q '"valid":true' "$tmp/bvox.json"
  check "bunny at $res: voxel volume $inside < overlap $over, which exceeds the solid's $surf" \
    awk -v i="$inside" -v o="$over" -v s="$surf" 'BEGIN { exit !(i < o && o > s) }'
done
# Both inside tests decide the same predicate (cell centre inside) independently: same cells.
rays=$("$bin/pf-voxelize" --res 8 --inside rays "$models/bunny.obj" 2>&1 >/dev/null | grep -o '[0-9]* hexes')
winding=$("$bin/pf-voxelize" --res 8 --inside winding "$models/bunny.obj" 2>&1 >/dev/null | grep -o '[0-9]* hexes')
check "bunny at 8: rays ($rays) and winding number ($winding) agree" test -n "$rays" -a "$rays" = "$winding"
expect 2 "--inside" "$bin/pf-voxelize" --inside sometimes "$data/cube.obj"
# An error found in the surface names the file it came from.
expect 1 "open_box.obj: slicing needs a closed" "$bin/pf-slice" --exact "$data/open_box.obj"
finish
