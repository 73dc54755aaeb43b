# pf-cut end to end: planes through a box and a sliced bunny (bodies, the "cut" face group, the
# volume kept, the stream simulated after it), a box clipped by a sphere inside and outside and a
# bunny cut out of a cube (volumes against the surfaces' enclosed volumes), --output and --stats,
# determinism, and the errors of bad arguments and bad input.
. "$(dirname "$0")/lib.sh"
root=$(cd "$data/../.." && pwd)

# the volume of the first MESH / the enclosed volume of the first SURF that pf-info reports
mesh_volume() { "$bin/pf-info" "$1" | sed -n 's/^      volume \([^ ]*\) (elements.*/\1/p' | head -1; }
surf_volume() { "$bin/pf-info" "$1" | sed -n 's/^      enclosed volume \([^,]*\),.*/\1/p' | head -1; }
# close A B REL: |A - B| <= REL |B|
close() { awk -v a="$1" -v b="$2" -v r="$3" 'BEGIN { d = a - b; if (d < 0) d = -d;
  m = b < 0 ? -b : b; exit !(a != "" && d <= r * m) }'; }

# ---- planes ------------------------------------------------------------------------------------
"$bin/pf-shape" box --extent 1,1,1 --cells 4,4,4 >"$tmp/box.pfs"
expect 0 "2 bodies" "$bin/pf-cut" "$tmp/box.pfs" --plane 0.5,0.5,0.37,0.1,0.2,1
cp "$tmp/out" "$tmp/one.pfs"
"$bin/pf-info" "$tmp/one.pfs" >"$tmp/one.txt"
check "one plane: the mesh is valid" grep -q "validation: ok" "$tmp/one.txt"
check "one plane: the opened faces are the face group 'cut'" grep -q "'cut': [1-9][0-9]* faces" "$tmp/one.txt"
v=$(mesh_volume "$tmp/one.pfs")
check "one plane: the volume stays 1 ($v)" close "$v" 1 1e-12
expect 0 "4 bodies" "$bin/pf-cut" "$tmp/box.pfs" --plane 0.5,0.5,0.37,0.1,0.2,1 --plane 0.41,0,0,1,0,0
v=$(mesh_volume "$tmp/out")
check "two planes: the volume stays 1 ($v)" close "$v" 1 1e-12
# a plane 5 % of a cell from a grid plane: no sliver is made, the crack follows the cells' faces
expect 0 "2 bodies" "$bin/pf-cut" "$tmp/box.pfs" --plane 0,0,0.26,0,0,1
check "near a grid plane: no element was split" grep -q "0 elements split" "$tmp/err"
# a plane through a sliced bunny, then simulated and read by pf-info
"$bin/pf-slice" "$root/data/models/bunny.obj" --res 12 --quiet >"$tmp/bunny_sliced.pfs"
expect 0 "2 bodies" "$bin/pf-cut" "$tmp/bunny_sliced.pfs" --plane 0,0,0.5,0,0.2,1 \
  --stats "$tmp/bunny_cut.json"
cp "$tmp/out" "$tmp/bunny_cut.pfs"
check "sliced bunny: every opened face capped (--stats)" grep -q '"uncapped_faces": 0,' "$tmp/bunny_cut.json"
check "sliced bunny: its embedded surface is cut and capped" grep -q "embedded surface: [1-9][0-9]* triangles split.*[1-9][0-9]* cap triangles" "$tmp/err"
"$bin/pf-info" "$tmp/bunny_cut.pfs" >"$tmp/bunny_cut.txt" 2>&1
check "sliced bunny: SURF, MESH and their WGHT, accepted by pf-info" sh -c "grep -q '^SURF' '$tmp/bunny_cut.txt' && grep -q '^WGHT' '$tmp/bunny_cut.txt' && '$bin/pf-info' '$tmp/bunny_cut.pfs' >/dev/null"
# three planes whose cracks cross and bend onto the cells' faces: the surface is cut once along
# all of them and stays closed, enclosing the cut mesh's volume (the slicer makes the mesh's
# boundary the surface; 1e-9: sums over ~10^4 triangles and polyhedra); a second pf-cut cuts
# a capped surface again (the faces the first opened are not cut twice) and keeps it closed
planes3="--plane 0.05,0,0.45,0.2,0.1,1 --plane 0.1,0.02,0.4,1,0.3,0.2 --plane -0.1,0.05,0.5,0.3,-1,0.4"
expect 0 "embedded surface" "$bin/pf-cut" "$tmp/bunny_sliced.pfs" $planes3 --stats "$tmp/cut3.json"
cp "$tmp/out" "$tmp/bunny_cut3.pfs"
check "three planes: every opened face capped" grep -q '"uncapped_faces": 0,' "$tmp/cut3.json"
"$bin/pf-info" "$tmp/bunny_cut3.pfs" >"$tmp/cut3.txt" 2>&1
check "three planes: the cut surface is closed and manifold" grep -q "^SURF .*triangles, closed, manifold" "$tmp/cut3.txt"
v=$(mesh_volume "$tmp/bunny_cut3.pfs")
sv=$(surf_volume "$tmp/bunny_cut3.pfs")
check "three planes: the surface encloses the mesh's volume ($sv, $v)" close "$sv" "$v" 1e-9
"$bin/pf-cut" "$tmp/bunny_sliced.pfs" --plane 0,0,0.6,0,0,1 --quiet --output "$tmp/ears.pfs"
expect 0 "embedded surface" "$bin/pf-cut" "$tmp/ears.pfs" --plane 0.02,0.1,0.3,0,1,0.1
check "a second pf-cut: the surface stays closed" sh -c "'$bin/pf-info' '$tmp/out' | grep -q '^SURF .*triangles, closed, manifold'"
expect 0 "dropped from the stream: the embedded surface" "$bin/pf-cut" "$tmp/bunny_sliced.pfs" \
  --plane 0,0,0.5,0,0.2,1 --drop-surface
check "--drop-surface: no SURF written" sh -c "! '$bin/pf-info' '$tmp/out' | grep -q '^SURF'"
expect 0 "" "$bin/pf-sim" --frames 2 --quiet --input "$tmp/bunny_cut.pfs"
check "the cut bunny simulates" sh -c "'$bin/pf-info' '$tmp/out' >/dev/null"

# ---- a closed surface --------------------------------------------------------------------------
"$bin/pf-shape" sphere --radius 0.37 --segments 12 >"$tmp/sphere.pfs"
"$bin/pf-shape" box --extent 1,1,1 --origin -0.5,-0.47,-0.52 --cells 5,6,5 >"$tmp/cube.pfs"
sv=$(surf_volume "$tmp/sphere.pfs")
cv=$(mesh_volume "$tmp/cube.pfs")
expect 0 "clipped into" "$bin/pf-cut" "$tmp/cube.pfs" --surface "$tmp/sphere.pfs"
v=$(mesh_volume "$tmp/out")
check "inside a sphere: the sphere's volume ($v, $sv)" close "$v" "$sv" 1e-12
check "inside a sphere: valid" sh -c "'$bin/pf-info' '$tmp/out' | grep -q 'validation: ok'"
expect 0 "keep outside" "$bin/pf-cut" "$tmp/cube.pfs" --surface "$tmp/sphere.pfs" --keep outside
v=$(mesh_volume "$tmp/out")
want=$(awk -v a="$cv" -v b="$sv" 'BEGIN { printf "%.17g", a - b }')
check "outside a sphere: the box minus the sphere ($v, $want)" close "$v" "$want" 1e-12
# the DG paper's bunny cut out of a cube
"$bin/pf-import" "$root/data/models/bunny.obj" >"$tmp/bunny.pfs" 2>/dev/null
bv=$(surf_volume "$tmp/bunny.pfs")
"$bin/pf-shape" box --extent 1.1,0.9,1.1 --origin -0.55,-0.45,-0.05 --cells 10,8,10 >"$tmp/block.pfs"
expect 0 "clipped into" "$bin/pf-cut" "$tmp/block.pfs" --surface "$root/data/models/bunny.obj" \
  --stats "$tmp/stats.json" --output "$tmp/bunny_block.pfs"
v=$(mesh_volume "$tmp/bunny_block.pfs")
check "bunny out of a cube: the bunny's volume ($v, $bv)" close "$v" "$bv" 1e-10
check "bunny out of a cube: valid" sh -c "'$bin/pf-info' '$tmp/bunny_block.pfs' | grep -q 'validation: ok'"
check "--output: no .part file left" test ! -e "$tmp/bunny_block.pfs.part"
check "--stats: JSON with the element counts" grep -q '"elements_clipped": [1-9]' "$tmp/stats.json"
check "--stats: the volume kept" grep -q '"volume_out": 0.19428' "$tmp/stats.json"
# then a plane through it, in the same call (clip first): the ears come off
expect 0 "3 bodies" "$bin/pf-cut" "$tmp/block.pfs" --surface "$root/data/models/bunny.obj" \
  --plane 0,0,0.6,0,0,1
v=$(mesh_volume "$tmp/out")
check "bunny, then a plane: the volume stays ($v)" close "$v" "$bv" 1e-10

# ---- determinism -------------------------------------------------------------------------------
"$bin/pf-cut" "$tmp/block.pfs" --surface "$root/data/models/bunny.obj" --plane 0,0,0.6,0,0,1 \
  --quiet >"$tmp/run1.pfs"
"$bin/pf-cut" "$tmp/block.pfs" --surface "$root/data/models/bunny.obj" --plane 0,0,0.6,0,0,1 \
  --quiet >"$tmp/run2.pfs"
check "deterministic: two runs, the same bytes" cmp -s "$tmp/run1.pfs" "$tmp/run2.pfs"

# ---- errors ------------------------------------------------------------------------------------
expect 0 "" "$bin/pf-cut" --help
check "--help: the usage" grep -q "Usage: pf-cut" "$tmp/out"
expect 2 "--plane expects six numbers" "$bin/pf-cut" "$tmp/box.pfs" --plane 1,2,3
expect 2 "--plane expects six numbers" "$bin/pf-cut" "$tmp/box.pfs" --plane 0,0,0,0,0,x
expect 2 "the normal is zero" "$bin/pf-cut" "$tmp/box.pfs" --plane 0,0,0,0,0,0
expect 2 "nothing to cut with" "$bin/pf-cut" "$tmp/box.pfs"
expect 2 "--keep needs --surface" "$bin/pf-cut" "$tmp/box.pfs" --plane 0,0,0,0,0,1 --keep outside
expect 2 "--embed is mls, bary or harmonic" "$bin/pf-cut" "$tmp/box.pfs" --plane 0,0,0,0,0,1 --embed x
expect 2 "--keep is inside or outside" "$bin/pf-cut" "$tmp/box.pfs" --surface "$tmp/sphere.pfs" --keep up
expect 1 "$tmp/missing.pfs" "$bin/pf-cut" "$tmp/missing.pfs" --plane 0,0,0,0,0,1
expect 1 "$tmp/missing.obj" "$bin/pf-cut" "$tmp/box.pfs" --surface "$tmp/missing.obj"
expect 1 "no MESH chunk" "$bin/pf-cut" "$tmp/sphere.pfs" --plane 0,0,0,0,0,1
expect 1 "clip first, then cut" sh -c "'$bin/pf-cut' '$tmp/cube.pfs' --plane 0,0,0,0,0,1 --quiet | '$bin/pf-cut' --surface '$tmp/sphere.pfs'"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\n' >"$tmp/open.obj"
expect 1 "closed" "$bin/pf-cut" "$tmp/box.pfs" --surface "$tmp/open.obj"
check "a failed --output leaves no file" sh -c "! '$bin/pf-cut' '$tmp/box.pfs' --surface \
  '$tmp/open.obj' --output '$tmp/failed.pfs' 2>/dev/null && test ! -e '$tmp/failed.pfs' && \
  test ! -e '$tmp/failed.pfs.part'"
finish
