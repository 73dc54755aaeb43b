# Goldens of simulated frames (the other goldens are drawn from synthetic streams): a DG cantilever
# sagging under gravity (mesh and stress views), a CG run on harmonic elements of a sliced sphere
# (mesh view), and a DG drop of a sliced sphere whose embedded surface rests on the ground
# (surface view, contact at the surface). Compared as render.sh compares (pf-imgdiff --tol 3
# --max-fraction 0.01): a change of the simulated shape moves thousands of pixels, a change of
# the last bits of the solver none. PF_UPDATE_GOLDEN=1 rewrites them (see golden_png in lib.sh).
. "$(dirname "$0")/lib.sh"
golden=$(cd "$(dirname "$0")/../golden" && pwd)

# The beam 4 x 1 x 1 fixed at x = 0; the sphere of radius 1 sliced into 93 elements (hexes and
# harmonic polyhedra) with its surface embedded.
cat >"$tmp/dg.json" <<'JSON'
{"material": {"E": 20000, "nu": 0.3, "density": 100},
 "method": {"name": "dg", "degree": 1, "flux": "ip"},
 "gravity": [0, 0, -9.81],
 "ground": false,
 "fixed": [{"box": [[-0.001, -1, -1], [0.001, 2, 2]]}],
 "time": {"frames": 6, "dt": 0.05}}
JSON
cat >"$tmp/cg.json" <<'JSON'
{"material": {"E": 5000, "nu": 0.3, "density": 100},
 "method": {"name": "cg"},
 "gravity": [0, 0, -9.81],
 "ground": false,
 "fixed": [{"box": [[-2, -2, 0.5], [2, 2, 2]]}],
 "time": {"frames": 4, "dt": 0.05}}
JSON
cat >"$tmp/drop.json" <<'JSON'
{"material": {"E": 5000, "nu": 0.3, "density": 100},
 "method": {"name": "dg", "degree": 1},
 "ground": {"point": [0, 0, -1.05], "stiffness": 1e5},
 "time": {"frames": 6, "dt": 0.05}}
JSON
"$bin/pf-shape" box --size 4,1,1 --cells 8,2,2 >"$tmp/beam.pfs" || { echo "FAIL: pf-shape"; exit 1; }
"$bin/pf-shape" sphere --res 12 | "$bin/pf-slice" --res 5 --quiet | "$bin/pf-embed" --quiet \
  >"$tmp/sphere.pfs" || { echo "FAIL: sphere pipeline"; exit 1; }
expect 0 "" "$bin/pf-sim" "$tmp/dg.json" --quiet --input "$tmp/beam.pfs"
cp "$tmp/out" "$tmp/dg.pfs"
expect 0 "74 harmonic" "$bin/pf-sim" "$tmp/cg.json" --input "$tmp/sphere.pfs"
cp "$tmp/out" "$tmp/cg.pfs"
expect 0 "contact at 266 surface vertices" "$bin/pf-sim" "$tmp/drop.json" --input "$tmp/sphere.pfs"
cp "$tmp/out" "$tmp/drop.pfs"

# golden NAME STREAM FRAME pf-render-arguments...
golden() {
  local name=$1 stream=$2 frame=$3
  shift 3
  expect 0 "" "$bin/pf-render" --quiet --size 160x120 --frames "$frame" --out "$tmp/$name" "$@" \
    "$tmp/$stream.pfs"
  golden_png "$name" "$tmp/$name/frame_0000$frame.png" "$golden"
}
golden sim_dg_mesh dg 6 --mode mesh
golden sim_dg_stress dg 6 --mode stress
golden sim_cg_mesh cg 4 --mode mesh
golden sim_embedded_surface drop 6 --mode surface

# The goldens show motion: the last frame differs from the rest shape by far more than the
# tolerance (a run that did not move would pass the goldens of a rest shape only).
expect 0 "" "$bin/pf-render" --quiet --size 160x120 --frames 0 --mode mesh --out "$tmp/rest" \
  "$tmp/dg.pfs"
expect 1 "" "$bin/pf-imgdiff" --tol 3 --max-fraction 0.01 "$tmp/rest/frame_00000.png" \
  "$tmp/sim_dg_mesh/frame_00006.png"
finish
