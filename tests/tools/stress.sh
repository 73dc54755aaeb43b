# Numerical stress: each case ends within a bounded time (timeout) with a right result, a clear
# refusal or a clear divergence message, never a hang or a silent NaN. What each gives today:
#   thin plate, element volumes 1e-6 apart  right result: DG the unslivered plate's deflection
#                                            to 1e-5, CG to 2 %
#   nu = 0.4999, DG degree 2                 right result: no locking, Euler-Bernoulli to 10 %
#   E = 1e12, density 1 (stiff, light)       right result: dynamic sag between 0.5 and 2 times
#                                            the static one (3.9e-9)
#   dt 100 times the default (3.33 s)        right result: CG and DG-BZ settle on the static
#                                            solution to 1 %, DG-IP without corotation to 1e-9
#   50,000 fixed regions                     right result: the same bytes as one region, in ~1 s
# Known defect, left to the simulator's owners: DG with IP fluxes and corotation (the default)
# settles on a deflection about 50 % larger than the static one, with a sideways drift, at any dt
# (the cantilever below: -0.058 against -0.0387); BZ and CG agree with the static solution.
. "$(dirname "$0")/lib.sh"

# tip FILE: the displacement "ux uy uz" of the node at (4, 0, 0) in the stream's last frame.
tip() {
  "$bin/pf-info" --probe 4,0,0 "$1" | awk '$1 == "frame" { u = $6 " " $7 " " $8 } END { print u }'
}
# within A B TOL: |A - B| <= TOL |B|
within() {
  awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { d = a - b; if (d < 0) d = -d; m = b < 0 ? -b : b
    exit !(a != "" && b != "" && d <= t * m) }'
}
# sim NAME SCENE MESH [options]: pf-sim within 120 s into $tmp/NAME.pfs
sim() {
  local name=$1 scene=$2 mesh=$3
  shift 3
  checks=$((checks + 1))
  if ! timeout 120 "$bin/pf-sim" "$tmp/$scene.json" --quiet --input "$tmp/$mesh.pfs" "$@" \
    >"$tmp/$name.pfs" 2>"$tmp/$name.err"; then
    echo "FAIL: $name: pf-sim failed or ran past 120 s: $(head -c 300 "$tmp/$name.err")"
    failures=$((failures + 1))
  fi
}
z() { echo "$1" | awk '{ print $3 }'; }

# A cantilever 4 x 1 x 1 (8 x 2 x 2 hexes) under its weight, fixed at x = 0.
"$bin/pf-shape" box --size 4,1,1 --cells 8,2,2 >"$tmp/beam.pfs" || { echo "FAIL: pf-shape"; exit 1; }
cat >"$tmp/static.json" <<'JSON'
{"material": {"E": 100000, "nu": 0.3, "density": 1},
 "method": {"name": "dg", "degree": 2},
 "gravity": [0, 0, -9.81],
 "fixed": [{"box": [[-0.001, -1, -1], [0.001, 2, 2]]}],
 "static": true}
JSON

# ---- a thin plate whose top layer of cells is 2.5e-7 thick: volumes 1.6e-8 .. 1.6e-2 --------
plate() { # plate NAME EXTRA: the box 4 x 1 x (0.5 + EXTRA) as OBJ, sliced by cells of 0.25
  awk -v d="$2" 'BEGIN { t = 0.5 + d
    printf "v 0 0 0\nv 4 0 0\nv 4 1 0\nv 0 1 0\nv 0 0 %.17g\nv 4 0 %.17g\nv 4 1 %.17g\nv 0 1 %.17g\n", t, t, t, t
    print "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8" }' >"$tmp/$1.obj"
  "$bin/pf-slice" "$tmp/$1.obj" --cell 0.25 --origin 0,0,0 --merge 0 --quiet >"$tmp/$1.pfs" ||
    { echo "FAIL: pf-slice $1"; exit 1; }
}
plate thin 2.5e-7
plate thick 0
ratio=$("$bin/pf-info" --json "$tmp/thin.pfs" | sed -n 's/.*"min_element_volume":\([^,]*\),"max_element_volume":\([^,]*\),.*/\1 \2/p' |
  awk '{ print $1 / $2 }')
check "the thin plate's smallest to largest element volume is 1e-6 (got $ratio)" \
  awk -v r="$ratio" 'BEGIN { exit !(r != "" && r > 0.99e-6 && r < 1.01e-6) }'
sed 's/"degree": 2/"degree": 1/' "$tmp/static.json" >"$tmp/plate_dg.json"
sed 's/"name": "dg", "degree": 2/"name": "cg"/' "$tmp/static.json" >"$tmp/plate_cg.json"
for m in dg cg; do
  sim "thin_$m" "plate_$m" thin
  sim "thick_$m" "plate_$m" thick
done
# The plates differ in thickness by 5e-7 relative: DG's deflections agree to that (measured
# 3.8e-7); CG's meshes differ in which cells are harmonic polyhedra, a discretisation change of
# about 1 % (measured 0.96 %).
a=$(z "$(tip "$tmp/thin_dg.pfs")") b=$(z "$(tip "$tmp/thick_dg.pfs")")
check "DG thin plate: tip $a, plate without the sliver $b (1e-5)" within "$a" "$b" 1e-5
a=$(z "$(tip "$tmp/thin_cg.pfs")") b=$(z "$(tip "$tmp/thick_cg.pfs")")
check "CG thin plate: tip $a, plate without the sliver $b (2 %)" within "$a" "$b" 0.02

# ---- nu = 0.4999 at degree 2: no locking -------------------------------------------------------
# Euler-Bernoulli tip deflection of the cantilever under its weight: q L^4 / (8 E I) with
# q = rho g A = 9.81, L = 4, I = 1/12: 0.037673. Shear and the 3D fixed end move the solid's by a
# few percent (nu = 0.3: +2.6 %); locking would take it down by far more (degree 1: -93 %).
sed 's/"nu": 0.3/"nu": 0.4999/' "$tmp/static.json" >"$tmp/nu.json"
sim nu nu beam
a=$(z "$(tip "$tmp/nu.pfs")")
check "nu = 0.4999, degree 2: tip $a, Euler-Bernoulli -0.037673 (10 %)" within "$a" -0.037673 0.1

# ---- E = 1e12 with density 1 -------------------------------------------------------------------
# Static sag 0.038659 * 1e5 / 1e12 = 3.87e-9; released from rest the beam swings about it:
# the largest displacement over the run lies between the static one and twice it.
cat >"$tmp/stiff.json" <<'JSON'
{"material": {"E": 1e12, "nu": 0.3, "density": 1},
 "method": {"name": "dg", "degree": 2},
 "gravity": [0, 0, -9.81], "ground": false,
 "fixed": [{"box": [[-0.001, -1, -1], [0.001, 2, 2]]}],
 "time": {"frames": 10}}
JSON
sim stiff stiff beam
umax=$("$bin/pf-info" --json "$tmp/stiff.pfs" | sed -n 's/.*"max_displacement":\([^,}]*\).*/\1/p')
check "E = 1e12: largest displacement $umax within [0.5, 2] x 3.87e-9" \
  awk -v u="$umax" 'BEGIN { exit !(u != "" && u >= 0.5 * 3.87e-9 && u <= 2 * 3.87e-9) }'

# ---- dt 100 times the default -------------------------------------------------------------------
# Linearly implicit Euler with steps of 0.33 s (the beam's first period is ~0.4 s) is stable and
# damps: five frames settle on the static solution.
sed 's/"E": 1e12, "nu": 0.3, "density": 1/"E": 100000, "nu": 0.3, "density": 1/; s/"frames": 10}/"frames": 5, "dt": 3.3333}/' \
  "$tmp/stiff.json" >"$tmp/bigdt_ip.json"
sed 's/"degree": 2}/"degree": 2, "flux": "bz"}/' "$tmp/bigdt_ip.json" >"$tmp/bigdt_bz.json"
sed 's/"name": "dg", "degree": 2}/"name": "cg"}/' "$tmp/bigdt_ip.json" >"$tmp/bigdt_cg.json"
for m in ip bz cg; do
  sim "static_$m" "bigdt_$m" beam --static --no-corotation
done
sim bigdt_ip bigdt_ip beam --no-corotation
sim bigdt_bz bigdt_bz beam
sim bigdt_cg bigdt_cg beam
a=$(z "$(tip "$tmp/bigdt_ip.pfs")") b=$(z "$(tip "$tmp/static_ip.pfs")")
check "dt 3.33 s, DG-IP linear: tip $a, static $b (1e-9)" within "$a" "$b" 1e-9
a=$(z "$(tip "$tmp/bigdt_bz.pfs")") b=$(z "$(tip "$tmp/static_bz.pfs")")
check "dt 3.33 s, DG-BZ corotated: tip $a, static $b (1 %)" within "$a" "$b" 0.01
a=$(z "$(tip "$tmp/bigdt_cg.pfs")") b=$(z "$(tip "$tmp/static_cg.pfs")")
check "dt 3.33 s, CG corotated: tip $a, static $b (1 %)" within "$a" "$b" 0.01

# ---- 50,000 fixed regions ------------------------------------------------------------------------
# 50,000 boxes selecting the same end face: the same solution as one box, bit for bit.
awk 'BEGIN { printf "{\"material\": {\"E\": 100000, \"nu\": 0.3, \"density\": 1}, \"method\": {\"name\": \"dg\", \"degree\": 1}, \"gravity\": [0, 0, -9.81], \"static\": true, \"fixed\": ["
  for (i = 0; i < 50000; i++) printf "%s{\"box\": [[%.12g, -1, -1], [0.001, 2, 2]]}", (i ? "," : ""), -0.001 + i * 1e-9
  print "]}" }' >"$tmp/many.json"
sed 's/"degree": 2/"degree": 1/' "$tmp/static.json" >"$tmp/one.json"
sim many many beam
sim one one beam
a=$(tip "$tmp/many.pfs") b=$(tip "$tmp/one.pfs")
check "50,000 fixed regions: tip '$a', one region '$b'" test -n "$a" -a "$a" = "$b"
finish
