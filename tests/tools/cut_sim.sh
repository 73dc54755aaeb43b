# Cutting while the simulation runs (the scene's "cuts"): a sliced bunny hanging by its ears cut in
# two by a moving blade (data/scenes/bunny_cut.json); a blade that stops half way leaves one body
# (both methods); pf-sim writes a MESH (with the "cut" face group) before the first frame on each
# cut mesh; pf-info, pf-export and pf-render read the stream; the stream is the same twice and on
# one thread; an embedded surface is cut and capped with the mesh, by one blade and by two whose
# cracks cross (every surface closed); an imported tetrahedral mesh and
# an octree are cut with both methods; a bad blade is an error naming the key.
. "$(dirname "$0")/lib.sh"
root=$(cd "$data/../.." && pwd)
scene=$root/data/scenes/bunny_cut.json
"$bin/pf-slice" "$root/data/models/bunny.obj" --res 6 --quiet >"$tmp/bunny.pfs"
stat_of() { sed -n "s/.*\"$2\":[[:space:]]*\([0-9.e+-]*\).*/\1/p" "$1" | head -1; }

expect 0 "cuts:" "$bin/pf-sim" "$scene" --frames 30 --stats "$tmp/dg.json" --input "$tmp/bunny.pfs"
cp "$tmp/out" "$tmp/dg.pfs"
check "dg: the blade cut elements ($(stat_of "$tmp/dg.json" elements_cut))" \
  test "$(stat_of "$tmp/dg.json" elements_cut)" -gt 0
check "dg: the bunny is in two pieces" test "$(stat_of "$tmp/dg.json" bodies)" = 2
"$bin/pf-info" "$tmp/dg.pfs" >"$tmp/info.txt" 2>&1
check "pf-info accepts the cut stream" "$bin/pf-info" "$tmp/dg.pfs"
check "more than one mesh" test "$(sed -n 's/^meshes: //p' "$tmp/info.txt")" -gt 1
check "the cut faces are the mesh's group" grep -q "GRPS" "$tmp/info.txt"


# the same run again, and on one thread: the same bytes (see refine.sh for the thread policy)
"$bin/pf-sim" "$scene" --frames 30 --quiet --input "$tmp/bunny.pfs" >"$tmp/run0.pfs"
"$bin/pf-sim" "$scene" --frames 30 --quiet --input "$tmp/bunny.pfs" >"$tmp/run1.pfs"
OMP_NUM_THREADS=1 "$bin/pf-sim" "$scene" --frames 30 --quiet --input "$tmp/bunny.pfs" >"$tmp/run2.pfs"
check "deterministic: run twice" cmp -s "$tmp/run0.pfs" "$tmp/run1.pfs"
check "deterministic: one thread" cmp -s "$tmp/run1.pfs" "$tmp/run2.pfs"

# pf-render draws every frame on its own mesh, a range reproduces the whole run's bytes
expect 0 "" "$bin/pf-render" --quiet --size 96x72 --out "$tmp/png" "$tmp/dg.pfs"
check "pf-render: 31 images" test "$(ls "$tmp/png" | wc -l)" = 31
expect 0 "" "$bin/pf-render" --quiet --size 96x72 --frames 28:30 --out "$tmp/png-range" "$tmp/dg.pfs"
for png in "$tmp/png-range"/*.png; do
  check "render --frames 28:30: $(basename "$png") as in the whole run" \
    cmp -s "$png" "$tmp/png/$(basename "$png")"
done
expect 0 "" "$bin/pf-export" --ascii --quiet --vtu "$tmp/vtu" "$tmp/dg.pfs"
check "VTU at every frame" test "$(ls "$tmp/vtu"/*.vtu | wc -l)" = 31

# a blade that stops half way through the bar: one body, a crack
"$bin/pf-shape" box --extent 4,1,1 --cells 8,2,4 >"$tmp/bar.pfs"
cat >"$tmp/half.json" <<'JSON'
{"ground": false, "time": {"dt": 0.02, "frames": 8, "substeps": 2},
 "fixed": [{"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}},
           {"plane": {"point": [4, 0, 0], "normal": [1, 0, 0]}}],
 "cuts": [{"blade": [[2.05, -1, 1.5], [2.05, 2, 1.5]],
           "path": [{"time": 0, "translation": [0, 0, 0]}, {"time": 0.1, "translation": [0, 0, -1]}]}]}
JSON
expect 0 "cuts:" "$bin/pf-sim" "$tmp/half.json" --stats "$tmp/half_stats.json" --input "$tmp/bar.pfs"
check "half way: one body" test "$(stat_of "$tmp/half_stats.json" bodies)" = 1
expect 0 "cuts:" "$bin/pf-sim" "$tmp/half.json" --method cg --stats "$tmp/half_cg.json" \
  --input "$tmp/bar.pfs"
check "half way, cg: one body" test "$(stat_of "$tmp/half_cg.json" bodies)" = 1
check "half way, cg: elements cut" test "$(stat_of "$tmp/half_cg.json" elements_cut)" -gt 0

# an embedded surface is cut with the mesh: a new SURF with caps, its weights on the new mesh
"$bin/pf-shape" sphere --segments 12 | "$bin/pf-voxelize" --res 5 --quiet | "$bin/pf-embed" --quiet >"$tmp/ball.pfs"
cat >"$tmp/ball.json" <<'JSON'
{"ground": {"point": [0, 0, -1.05]}, "time": {"frames": 10},
 "cuts": [{"plane": {"point": [0.05, 0, 0], "normal": [1, 0, 0.1]}, "time": 0.05}]}
JSON
expect 0 "cuts:" "$bin/pf-sim" "$tmp/ball.json" --input "$tmp/ball.pfs" --stats "$tmp/ball_stats.json"
cp "$tmp/out" "$tmp/ball_cut.pfs"
check "embedded: every opened face capped" test "$(stat_of "$tmp/ball_stats.json" uncapped_faces)" = 0
"$bin/pf-info" "$tmp/ball_cut.pfs" >"$tmp/binfo.txt" 2>&1
check "embedded: pf-info accepts every surface and its weights" "$bin/pf-info" "$tmp/ball_cut.pfs"
check "embedded: a second SURF" test "$(grep -c '^SURF' "$tmp/binfo.txt")" -ge 2
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/bobj" "$tmp/ball_cut.pfs"
check "embedded: the caps are a group of the last OBJ" grep -q "cap" "$(ls "$tmp/bobj"/*.obj | tail -1)"

# two blades whose cracks cross (one sweeps across, one down) through the embedded bunny: every
# surface the run writes (one per change) is closed and manifold, the crossing and the bends of
# the cracks onto the cells' faces capped, and the bunny ends in four pieces
"$bin/pf-embed" --quiet "$tmp/bunny.pfs" >"$tmp/bunny_embedded.pfs"
cat >"$tmp/cross.json" <<'JSON'
{"material": {"E": 1e7, "nu": 0.3, "density": 1000}, "ground": {"point": [0, 0, -0.4]},
 "time": {"dt": 0.0333333333333, "frames": 16, "substeps": 4},
 "cuts": [{"blade": [[-0.7, -1, 0.42], [-0.7, 1, 0.42]],
           "path": [{"time": 0.1, "translation": [0, 0, 0]}, {"time": 0.5, "translation": [1.4, 0, 0]}]},
          {"blade": [[0.02, -1, 1.2], [0.02, 1, 1.2]],
           "path": [{"time": 0.1, "translation": [0, 0, 0]}, {"time": 0.5, "translation": [0, 0, -1.8]}]}]}
JSON
expect 0 "4 bodies" "$bin/pf-sim" "$tmp/cross.json" --input "$tmp/bunny_embedded.pfs"
"$bin/pf-info" "$tmp/out" | grep '^SURF' >"$tmp/cross_surf.txt"
check "crossing blades: a surface per change ($(wc -l <"$tmp/cross_surf.txt"))" \
  test "$(wc -l <"$tmp/cross_surf.txt")" -gt 2
check "crossing blades: every surface closed and manifold" \
  test "$(grep -vc 'closed, manifold$' "$tmp/cross_surf.txt")" = 0

# an imported tetrahedral mesh (Gmsh, tests/data/bar_tets.geo) clamped by its physical group and
# an octree bunny, each cut through by a plane, both methods: the same bodies
"$bin/pf-import" "$data/bar_tets.msh" >"$tmp/tets.pfs" 2>/dev/null
cat >"$tmp/tets.json" <<'JSON'
{"ground": false, "time": {"dt": 0.02, "frames": 6, "substeps": 2}, "fixed": [{"group": "clamp"}],
 "cuts": [{"plane": {"point": [2.05, 0, 0], "normal": [1, 0, 0.2]}, "time": 0.05}]}
JSON
"$bin/pf-octree" "$root/data/models/bunny.obj" --depth 3 --quiet >"$tmp/octree.pfs"
cat >"$tmp/octree.json" <<'JSON'
{"ground": false, "time": {"dt": 0.02, "frames": 4},
 "cuts": [{"plane": {"point": [0, 0, 0.4], "normal": [0, 0.1, 1]}, "time": 0.03}]}
JSON
for mesh in tets octree; do
  for method in dg cg; do
    expect 0 "cuts:" "$bin/pf-sim" "$tmp/$mesh.json" --method $method \
      --stats "$tmp/${mesh}_$method.json" --input "$tmp/$mesh.pfs"
    check "$mesh, $method: elements cut" test "$(stat_of "$tmp/${mesh}_$method.json" elements_cut)" -gt 0
  done
  check "$mesh: the same bodies with both methods" test \
    "$(stat_of "$tmp/${mesh}_dg.json" bodies)" = "$(stat_of "$tmp/${mesh}_cg.json" bodies)"
done
check "tets: the bar in two" test "$(stat_of "$tmp/tets_dg.json" bodies)" = 2
check "octree: the bunny's ears and body apart" test "$(stat_of "$tmp/octree_dg.json" bodies)" -ge 3

# a blade without a path: exit 1 naming the key
printf '{"cuts": [{"blade": [[0, 0, 0], [1, 0, 0]]}]}' >"$tmp/bad.json"
expect 1 'cuts[0]: a blade needs a "path"' "$bin/pf-sim" "$tmp/bad.json" --input "$tmp/bar.pfs"
finish
