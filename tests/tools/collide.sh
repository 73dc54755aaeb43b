# Collisions through the tools: issue 7's pipeline pf-voxelize | pf-embed | pf-sim | pf-render on
# a generated model, contact at the embedded surface, obstacles drawn deterministically, bad keys.
. "$(dirname "$0")/lib.sh"

# An ellipsoid 1.4 x 1 x 1 standing on z = 0: 12 bands of 24 segments between the poles.
awk 'BEGIN { pi = 3.14159265358979; nl = 12; nm = 24; print "v 0 0 1"
  for (i = 1; i < nl; i++) { t = pi * i / nl
    for (j = 0; j < nm; j++) { p = 2 * pi * j / nm
      printf "v %.9f %.9f %.9f\n", 0.7 * sin(t) * cos(p), 0.5 * sin(t) * sin(p), 0.5 * cos(t) + 0.5 } }
  print "v 0 0 0"
  for (j = 0; j < nm; j++) print "f 1", 2 + j, 2 + (j + 1) % nm
  for (i = 0; i < nl - 2; i++) for (j = 0; j < nm; j++) {
    a = 2 + i * nm + j; b = 2 + i * nm + (j + 1) % nm; print "f", a, a + nm, b + nm; print "f", a, b + nm, b }
  s = 2 + (nl - 1) * nm
  for (j = 0; j < nm; j++) print "f", s, 2 + (nl - 2) * nm + (j + 1) % nm, 2 + (nl - 2) * nm + j }' >"$tmp/model.obj"

# The ground 0.02 below the model: the voxel mesh (cells whose centre is inside) ends up to half
# a cell away from the surface, so only contact at the surface puts the surface on the ground.
cat >"$tmp/scene.json" <<'JSON'
{"ground": {"point": [0, 0, -0.02], "stiffness": 1e5},
 "damping": {"alpha": 6, "beta": 0.002},
 "time": {"frames": 90, "substeps": 4}}
JSON
"$bin/pf-voxelize" "$tmp/model.obj" --res 8 --quiet |
  "$bin/pf-embed" --method mls --quiet 2>/dev/null |
  "$bin/pf-sim" "$tmp/scene.json" 2>"$tmp/sim.err" | tee "$tmp/sim.pfs" |
  "$bin/pf-render" --out "$tmp/frames" --quiet --size 160x120
check "pf-sim contacts at the 266 surface vertices" grep -q "contact at 266 surface vertices" "$tmp/sim.err"
# The summary's contact count, which must be there and positive (an absent line fails too).
contacts=$(sed -n 's/.*: \([0-9][0-9]*\) contacts,.*/\1/p' "$tmp/sim.err")
check "the surface touched the ground ('$contacts' contacts)" test "${contacts:-0}" -gt 0
check "the pipeline renders 91 frames" test "$(ls "$tmp/frames" | wc -l)" = 91

# At rest on its own surface (3 s; the bounce damps as e^{-3 t}, and the vertices' contact
# stiffness in the step's matrix, which majorises the exact one, slows the last settling: 4.5 %
# of the weight short at 1.33 s, 0.3 % at 3 s): the rendered surface vertices below the ground
# carry the body's weight through their penalty, sum k d = m g (m: the voxel mesh's volume,
# 0.7289, times the density 1000) to 2 %, and the lowest of them lies within a centimetre of the
# ground (about 25 vertices share the load at a mean depth of 3e-3, the pole deepest), while the
# voxel mesh's bottom is up to half a cell (0.09) away from the surface.
"$bin/pf-export" --obj "$tmp/obj" --frames 90 --quiet "$tmp/sim.pfs"
load=$(awk '$1 == "v" && $4 < -0.02 { s += -0.02 - $4 } END { printf "%.1f", s * 1e5 }' \
  "$tmp/obj/frame_00090.obj")
check "the surface vertices' penalty $load carries the weight 7150.3" \
  awk -v f="$load" 'BEGIN { exit !(f > 0.98 * 7150.3 && f < 1.02 * 7150.3) }'
low=$(awk '$1 == "v" && (n == 0 || $4 < m) { m = $4; n = 1 } END { print m }' "$tmp/obj/frame_00090.obj")
check "lowest surface vertex $low rests on the ground at -0.02" \
  awk -v z="$low" 'BEGIN { exit !(z < -0.02 && z > -0.035) }'

# Obstacles: a sphere under a small box and a mesh obstacle beside it, drawn by pf-render the
# same way twice (byte-identical PNGs).
cat >"$tmp/obstacles.json" <<'JSON'
{"ground": false,
 "obstacles": [{"sphere": {"centre": [0.5, 0.5, -0.3], "radius": 0.3}},
               {"mesh": {"file": "model.obj"}, "path": [{"time": 0, "translation": [1.6, 0, -0.6]}]},
               {"plane": {"point": [0, 0, -0.6], "normal": [0, 0, 1]}}],
 "time": {"frames": 4}}
JSON
"$bin/pf-shape" box --extent 1,1,1 --cells 2,2,2 >"$tmp/cube.pfs"
expect 0 "contact at 26 nodes" "$bin/pf-sim" "$tmp/obstacles.json" --input "$tmp/cube.pfs"
"$bin/pf-sim" "$tmp/obstacles.json" --quiet --input "$tmp/cube.pfs" >"$tmp/obst.pfs"
"$bin/pf-render" --out "$tmp/r1" --frames 4 --size 160x120 --quiet "$tmp/obst.pfs"
"$bin/pf-render" --out "$tmp/r2" --frames 4 --size 160x120 --quiet "$tmp/obst.pfs"
check "obstacle frames are deterministic" cmp -s "$tmp/r1/frame_00004.png" "$tmp/r2/frame_00004.png"
# The same stream without its SCEN, which names the obstacles: the same mesh and frames, so a
# different picture is the obstacles being drawn (a frame of another stream would differ anyway).
"$bin/../tests/test_export" --drop SCEN "$tmp/obst.pfs" "$tmp/no-scene.pfs" ||
  { echo "FAIL: test_export --drop"; exit 1; }
check "the copy has no SCEN" bash -c "! '$bin/pf-info' '$tmp/no-scene.pfs' | grep -q '^SCEN'"
"$bin/pf-render" --out "$tmp/r3" --frames 4 --size 160x120 --quiet "$tmp/no-scene.pfs"
check "frame 4 was rendered with and without the obstacles" \
  test -s "$tmp/r1/frame_00004.png" -a -s "$tmp/r3/frame_00004.png"
check "the obstacles change the picture" \
  bash -c "! cmp -s '$tmp/r1/frame_00004.png' '$tmp/r3/frame_00004.png'"

# Bad obstacles: one line naming the key, exit 1.
echo '{"obstacles": [{"sphere": {"centre": [0, 0, 0], "radius": -1}}]}' >"$tmp/bad.json"
expect 1 "obstacles[0].sphere.radius: must be > 0" "$bin/pf-sim" "$tmp/bad.json" --input "$tmp/cube.pfs"
echo '{"obstacles": [{"mesh": {"file": "missing.obj"}}]}' >"$tmp/missing.json"
expect 1 "obstacles[0].mesh" "$bin/pf-sim" "$tmp/missing.json" --input "$tmp/cube.pfs"
expect 1 "missing.obj" "$bin/pf-sim" "$tmp/missing.json" --input "$tmp/cube.pfs"
echo '{"obstacles": [{"mesh": {"file": "missing.obj", "up": "w"}}]}' >"$tmp/badup.json"
expect 1 "obstacles[0].mesh.up: must be" "$bin/pf-sim" "$tmp/badup.json" --input "$tmp/cube.pfs"

# A mesh obstacle's up and scale, as the tools' --up and --scale: a slab 6 x 0.1 x 6 whose top is
# at y = 0.2 in its file, +y up. Turned (y onto z) it is a floor with its top at z = 0.2 (0.4
# scaled by 2) that a unit cube at z 0.5 .. 1.5 falls 0.3 (0.1) onto; as the file lies (+z up)
# it is a wall beside the cube, which falls past it (1.5 in 20 frames). The largest displacement
# is the fall plus the penalty's penetration (under 0.04 here).
cat >"$tmp/slab.obj" <<'OBJ'
v -3 0.1 -3
v 3 0.1 -3
v 3 0.2 -3
v -3 0.2 -3
v -3 0.1 3
v 3 0.1 3
v 3 0.2 3
v -3 0.2 3
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 4 8 7
f 4 7 3
f 1 5 8
f 1 8 4
f 2 3 7
f 2 7 6
OBJ
"$bin/pf-shape" box --extent 1,1,1 --origin -0.5,0.5,0.5 --cells 2,2,2 >"$tmp/above.pfs"
for case in 'z 1 1.2 2' 'y 1 0.3 0.34' 'y 2 0.1 0.14'; do
  set -- $case
  cat >"$tmp/slab.json" <<JSON
{"material": {"E": 1e6, "nu": 0.3, "density": 1000}, "damping": {"alpha": 2, "beta": 0.01},
 "ground": false, "obstacles": [{"mesh": {"file": "slab.obj", "up": "$1", "scale": $2}}],
 "time": {"dt": 0.03333333333333333, "frames": 20, "substeps": 4}}
JSON
  u=$("$bin/pf-sim" "$tmp/slab.json" --quiet <"$tmp/above.pfs" | "$bin/pf-info" --json - |
      grep -o '"max_displacement":[^,]*' | cut -d: -f2)
  check "slab up $1 scale $2: fall $u in [$3, $4]" \
    awk -v u="${u:-0}" -v a="$3" -v b="$4" 'BEGIN { exit !(u >= a && u <= b) }'
done
"$bin/pf-sim" "$tmp/slab.json" --frames 0 --quiet <"$tmp/above.pfs" | "$bin/pf-info" --scene >"$tmp/slab_scene.json"
check "the stream's scene keeps the obstacle's up and scale" python3 -c "
import json, sys
m = json.load(open(sys.argv[1]))['obstacles'][0]['mesh']
sys.exit(0 if m['up'] == 'y' and m['scale'] == 2 else 1)" "$tmp/slab_scene.json"
finish
