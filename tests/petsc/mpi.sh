# pf-sim --solver petsc under mpirun with 1, 2 and 4 ranks (4 oversubscribed on a small machine)
# against the one-process direct solve: the static cantilever (DG degree 2, CG) to 1e-8 relative,
# the same stream from two runs on 2 ranks, PETSc's options passed through, static DG with every
# rank assembling its own elements (IP and BZ on 1 and 2 ranks, each rank's share, no fixed face),
# the same for CG (regions across the parts' cuts, 1, 2 and 4 ranks), corotated DG and CG
# dynamics with every rank assembling its own elements (a clamped beam swinging under gravity; a
# corotated drop onto the ground and a beam pressed by moving obstacles, with contact on every
# rank; 1, 2 and 4 ranks, frames to 1e-8 of the largest displacement), and an error on rank 0
# ending every rank with one message and exit 1. Built with -DPF_PETSC=ON.
. "$(dirname "$0")/../tools/lib.sh"
scenes=$data/scenes
# CI and this machine run as root; Open MPI's mpirun refuses root without these.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# --oversubscribe: more ranks than cores, and ranks that yield while they wait
mpi() { local n=$1; shift; timeout 300 mpirun -n "$n" --oversubscribe "$@"; }

# the vertical displacement at the probe point in the last frame of a stream
tip() { "$bin/pf-info" --json --probe "$2" "$1" | grep -o '"u":\[[^]]*\]' | tail -1 | sed 's/.*,//; s/\]//'; }
# |a - b| <= tol |b|
close() { awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { d = a - b; if (d < 0) d = -d; m = b < 0 ? -b : b; exit !(m > 0 && d <= t * m) }'; }

"$bin/pf-shape" box --extent 4,1,1 --cells 8,2,2 >"$tmp/beam.pfs" || { echo "FAIL: pf-shape"; exit 1; }
sed 's/"name": "dg", "degree": 2, "flux": "ip"/"name": "cg"/' "$scenes/cantilever.json" >"$tmp/cg.json"
for scene in "$scenes/cantilever.json" "$tmp/cg.json"; do
  name=$(basename "$scene" .json)
  "$bin/pf-sim" "$scene" --solver direct --quiet <"$tmp/beam.pfs" >"$tmp/direct.pfs"
  ref=$(tip "$tmp/direct.pfs" 4,0.5,0.5)
  for n in 1 2 4; do
    expect 0 "solver petsc" mpi "$n" "$bin/pf-sim" "$scene" --solver petsc --input "$tmp/beam.pfs" \
      --output "$tmp/petsc$n.pfs"
    got=$(tip "$tmp/petsc$n.pfs" 4,0.5,0.5)
    check "$name on $n ranks: tip $got equals direct's $ref to 1e-8" close "$got" "$ref" 1e-8
  done
done

# Rows are distributed by a PT-Scotch partition of the elements' couplings: a second run on 2
# ranks makes the same partition and writes the same stream, bit for bit (run in two directories
# so that the recorded command lines are the same too). Not asserted on more ranks: there PETSc
# sums what several ranks send in the order it arrives, and the last digits vary (1e-12 relative
# measured on 4 ranks, with the same iterations).
mkdir -p "$tmp/run1" "$tmp/run2"
for k in 1 2; do
  (cd "$tmp/run$k" && mpi 2 "$bin/pf-sim" "$scenes/cantilever.json" --solver petsc \
    --input "$tmp/beam.pfs" --output out.pfs 2>err) || { echo "FAIL: run $k on 2 ranks"; exit 1; }
done
check "two runs of DG on 2 ranks write the same stream" cmp -s "$tmp/run1/out.pfs" "$tmp/run2/out.pfs"

# More ranks than elements: the partition leaves ranks without rows, which still take part.
"$bin/pf-shape" box --extent 4,1,1 --cells 2,1,1 >"$tmp/two.pfs"
"$bin/pf-sim" "$scenes/cantilever.json" --solver direct --quiet <"$tmp/two.pfs" >"$tmp/two_direct.pfs"
expect 0 "on 4 ranks" mpi 4 "$bin/pf-sim" "$scenes/cantilever.json" --solver petsc \
  --input "$tmp/two.pfs" --output "$tmp/two_petsc.pfs"
got=$(tip "$tmp/two_petsc.pfs" 4,0.5,0.5)
check "2 elements on 4 ranks: tip $got equals direct's to 1e-8" close "$got" "$(tip "$tmp/two_direct.pfs" 4,0.5,0.5)" 1e-8

# PETSc's options pass through: MUMPS's distributed LU as CG's preconditioner solves in one
# iteration; the tip is the same.
expect 0 "solver petsc: 1 iterations" mpi 2 "$bin/pf-sim" "$tmp/cg.json" --solver petsc \
  --input "$tmp/beam.pfs" --output "$tmp/lu.pfs" -pc_type lu -pc_factor_mat_solver_type mumps
got=$(tip "$tmp/lu.pfs" 4,0.5,0.5)
"$bin/pf-sim" "$tmp/cg.json" --solver direct --quiet <"$tmp/beam.pfs" >"$tmp/direct.pfs"
check "MUMPS through the options: tip $got equals direct's" close "$got" "$(tip "$tmp/direct.pfs" 4,0.5,0.5)" 1e-8

# Corotated dynamics with every rank assembling its own elements (pf_sim_distrib_run, scenes
# without contact): the beam clamped at x = 0 swinging down under gravity, no ground. DG: IP
# degree 1 with the automatic penalty (the search on the distributed matrix and the corotated
# margin give the one-process run's 16) and BZ degree 2 with a longer step and a softer beam (the
# tip falls 0.21, a fifth of the beam's depth). CG: the softer beam (consistent mass), and with a
# lumped mass, Rayleigh damping, the fixed box and the loaded box that reach across the parts'
# cuts (tip 0.91). Every frame's displacement at three probes (tip, span, a corner on the cut of
# 2 parts) equals the one-process CHOLMOD run's to 1e-8 of the largest (the issue asks 1e-6;
# measured on 1, 2 and 4 ranks: IP 2.0e-11, 2.8e-11, 2.4e-11 over 100 steps, BZ 8.2e-11,
# 7.6e-11, 1.0e-10, CG 6.7e-11, 2.4e-11, 3.4e-11, CG lumped 4.3e-11, 1.3e-10, 6.5e-11 over 120:
# GAMG's CG stops at 1e-10 relative per step).
cat >"$tmp/swing.json" <<'EOF2'
{"material": {"E": 2000, "nu": 0.3, "density": 1}, "method": {"name": "dg", "degree": 1, "flux": "ip"},
 "gravity": [0, 0, -1], "fixed": [{"box": [[-0.001, -1, -1], [0.001, 2, 2]]}], "ground": false,
 "time": {"frames": 10, "dt": 0.02}, "corotation": true}
EOF2
sed 's/"E": 2000/"E": 300/; s/"frames": 10/"frames": 12/; s/"dt": 0.02/"dt": 0.05/; s/"degree": 1, "flux": "ip"/"degree": 2, "flux": "bz"/' \
  "$tmp/swing.json" >"$tmp/swing_bz.json"
sed 's/"degree": 2, "flux": "bz"/"name": "cg"/; s/"name": "dg", //' "$tmp/swing_bz.json" >"$tmp/swing_cg.json"
cat >"$tmp/swing_cgl.json" <<'EOF2'
{"material": {"E": 300, "nu": 0.3, "density": 1}, "method": {"name": "cg", "mass": "lumped"},
 "gravity": [0, 0, -1], "fixed": [{"box": [[-0.001, -1, -1], [1.1, 2, 2]]}], "ground": false,
 "loads": [{"box": [[2.9, -1, -1], [4.1, 2, 2]], "traction": [0, 0, -1]}],
 "time": {"frames": 12, "dt": 0.05}, "damping": {"alpha": 0.5, "beta": 0.02}}
EOF2
# every probe's displacement in every frame, one line per frame and probe
frames() { for q in 4,0.5,0.5 2,0,0 3,1,1; do "$bin/pf-info" --json --probe "$q" "$1" | grep -o '"u":\[[^]]*\]'; done | tr -d 'u":[]'; }
# the largest difference of two runs' frames (files $1, $2 of frames()) within $3 of the largest
# displacement, which must exceed $4; both with $5 lines
same_frames() {
  paste -d, "$1" "$2" | awk -F, -v t="$3" -v floor="$4" -v lines="$5" '{ n++; for (k = 1; k <= 3; ++k) {
    d = $k - $(k + 3); if (d < 0) d = -d; if (d > dm) dm = d; a = $k < 0 ? -$k : $k; if (a > am) am = a } }
    END { exit !(n == lines && am > floor && dm <= t * am) }'
}
# A run where every rank assembles its own elements writes STAT (pf_sim_distrib_stats_entries)
# with the one-process run's entries (file $2): the same counts and sizes, the error indicator to
# 1e-8 relative (DG: the largest node jump over the largest displacement, measured within
# 3.2e-10 of CHOLMOD's on 1, 2 and 4 ranks; CG: the basis error), the solver petsc with its
# iterations and MUMPS's definiteness tests (the automatic IP penalty: one per doubling and one)
# in place of the direct solver's.
same_stat() {
  python3 - "$bin/pf-info" "$1" "$2" <<'PY'
import json, subprocess, sys
def stat(path):
    out = subprocess.run([sys.argv[1], "--json", path], capture_output=True, text=True).stdout
    found = [json.loads(l)["stats"] for l in out.splitlines() if '"chunk":"STAT"' in l]
    assert len(found) == 1, "%s: %d STAT chunks" % (path, len(found))
    return found[0]
a, b = stat(sys.argv[2]), stat(sys.argv[3])
differ = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
assert set(differ) <= {"error_indicator", "factorisations", "pcg_iterations", "solver"}, differ
assert a["solver"] == "petsc" and a["pcg_iterations"] > 0, a
x, y = a["error_indicator"], b["error_indicator"]
assert abs(x - y) <= 1e-8 * abs(y), (x, y)
PY
}
for case in swing:0.02:100 swing_bz:0.2:120 swing_cg:0.2:120 swing_cgl:0.5:120; do
  name=${case%%:*} rest=${case#*:}
  floor=${rest%%:*} steps=${rest#*:}
  "$bin/pf-sim" "$tmp/$name.json" --solver direct --quiet --input "$tmp/beam.pfs" --output "$tmp/swing_direct.pfs"
  frames "$tmp/swing_direct.pfs" >"$tmp/fd"
  lines=$(wc -l <"$tmp/fd")
  for n in 1 2 4; do
    expect 0 "$steps steps" mpi "$n" "$bin/pf-sim" "$tmp/$name.json" --solver petsc \
      --input "$tmp/beam.pfs" --output "$tmp/swing$n.pfs"
    check "$name on $n ranks: each rank assembled its own" grep -q "assembled on $n ranks" "$tmp/err"
    [ "$name" = swing ] && check "$name on $n ranks: penalty 16 as the one-process search" \
      grep -q "penalty 16 (1 doublings)" "$tmp/err"
    frames "$tmp/swing$n.pfs" >"$tmp/fp"
    check "$name on $n ranks: $lines frame probes equal direct's to 1e-8 of the largest" \
      same_frames "$tmp/fd" "$tmp/fp" 1e-8 "$floor" "$lines"
    check "$name on $n ranks: STAT as direct's" same_stat "$tmp/swing$n.pfs" "$tmp/swing_direct.pfs"
  done
done
# Contact with every rank assembling its own elements, each testing the boundary nodes of its own
# elements (DG) or nodes (CG): a corotated drop onto the ground (the default scene, DG, and CG, 12
# frames), the clamped beam pressed by a sphere moving down and back onto a box below it (moving
# obstacles' work in the energy check; Rayleigh damping), and the box dropped onto a mesh
# obstacle. Every frame's displacement at three probes equals the one-process CHOLMOD run's to
# 1e-8 of the largest (the issue asks 1e-6 for the drop; measured on 1, 2 and 4 ranks: drop DG
# 4.1e-11, 2.7e-11, 1.7e-11, CG 6.1e-11, 3.6e-11, 1.0e-10; pressed DG 1.8e-11, 4.5e-11, 2.3e-11,
# CG 6.1e-11, 4.4e-11, 7.1e-11; block DG 5.2e-11, 2.9e-11, 2.1e-11), and as many contacts are
# found as by the one-process run.
"$bin/pf-shape" box --extent 1,0.5,0.5 --cells 4,2,2 >"$tmp/box.pfs" || { echo "FAIL: pf-shape"; exit 1; }
printf '{"time": {"frames": 12}}\n' >"$tmp/drop.json"
printf '{"method": {"name": "cg"}, "time": {"frames": 12}}\n' >"$tmp/drop_cg.json"
cat >"$tmp/press.json" <<'EOF2'
{"material": {"E": 200000, "nu": 0.3, "density": 1000}, "method": {"name": "dg", "degree": 1},
 "corotation": true, "gravity": [0, 0, 0], "ground": false,
 "fixed": [{"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}}, {"plane": {"point": [4, 0, 0], "normal": [1, 0, 0]}}],
 "obstacles": [{"sphere": {"centre": [2, 0.5, 1.55], "radius": 0.5},
                "path": [{"time": 0, "translation": [0, 0, 0]}, {"time": 0.5, "translation": [0, 0, -0.35]},
                         {"time": 1, "translation": [0, 0, 0]}]},
               {"box": [[3.2, -0.5, -1.2], [3.8, 1.5, -0.01]]}],
 "damping": {"alpha": 2, "beta": 0.02}, "time": {"dt": 0.04, "frames": 15, "substeps": 8}}
EOF2
sed 's/"name": "dg", "degree": 1/"name": "cg"/' "$tmp/press.json" >"$tmp/press_cg.json"
# a mesh obstacle (its triangles go to every rank with its part): the unit cube scaled by 3 as a
# block under the box, its top at z = -0.02
cp "$data/cube.obj" "$tmp/block.obj"
printf '%s\n' '{"obstacles": [{"mesh": {"file": "block.obj", "scale": 3},
  "path": [{"time": 0, "translation": [-1, -1, -3.02]}]}], "ground": false, "time": {"frames": 12}}' \
  >"$tmp/slab.json"
contacts() { grep -o '[0-9]* contacts' "$1" | head -1; }
for case in drop:box:1,0.5,0.5:0.5,0,0:0,0.25,0.5:0.02:39 drop_cg:box:1,0.5,0.5:0.5,0,0:0,0.25,0.5:0.02:39 \
            press:beam:4,0.5,0.5:2,0,0:3,1,1:0.1:48 press_cg:beam:4,0.5,0.5:2,0,0:3,1,1:0.1:48 \
            slab:box:1,0.5,0.5:0.5,0,0:0,0.25,0.5:0.02:39; do
  IFS=: read -r name mesh p1 p2 p3 floor lines <<<"$case"
  probes() { for q in "$p1" "$p2" "$p3"; do "$bin/pf-info" --json --probe "$q" "$1" | grep -o '"u":\[[^]]*\]'; done | tr -d 'u":[]'; }
  "$bin/pf-sim" "$tmp/$name.json" --solver direct --input "$tmp/$mesh.pfs" --output "$tmp/c_direct.pfs" 2>"$tmp/c_err"
  probes "$tmp/c_direct.pfs" >"$tmp/fd"
  want=$(contacts "$tmp/c_err")
  check "$name: the one-process run finds contacts ($want)" test -n "$want" -a "$want" != "0 contacts"
  for n in 1 2 4; do
    expect 0 "$want at the boundary nodes" mpi "$n" "$bin/pf-sim" "$tmp/$name.json" --solver petsc \
      --input "$tmp/$mesh.pfs" --output "$tmp/c$n.pfs"
    check "$name on $n ranks: each rank assembled its own" grep -q "assembled on $n ranks" "$tmp/err"
    probes "$tmp/c$n.pfs" >"$tmp/fp"
    check "$name on $n ranks: $lines frame probes equal direct's to 1e-8 of the largest" \
      same_frames "$tmp/fd" "$tmp/fp" 1e-8 "$floor" "$lines"
  done
done
# Contact at an embedded surface's vertices (rows reaching across parts) stays with rank 0
# assembling all.
root=$(cd "$data/../.." && pwd)
"$bin/pf-slice" "$root/data/models/bunny.obj" --res 4 --quiet | "$bin/pf-embed" --quiet >"$tmp/bunny.pfs"
expect 0 "solver petsc" mpi 2 "$bin/pf-sim" "$tmp/drop.json" --frames 2 --solver petsc \
  --input "$tmp/bunny.pfs" --output "$tmp/rank0.pfs"
check "embedded contact: rank 0 assembles all" bash -c "! grep -q 'assembled on' '$tmp/err'"

# against rank 0 assembling the same system on 2 ranks: the same partition and solves, equal but
# for the order of the sums (7e-17 measured)
PF_SIM_RANK0_ASSEMBLY=1 expect 0 "solver petsc" mpi 2 "$bin/pf-sim" "$tmp/swing.json" \
  --solver petsc --input "$tmp/beam.pfs" --output "$tmp/swing_rank0.pfs"
mpi 2 "$bin/pf-sim" "$tmp/swing.json" --solver petsc --input "$tmp/beam.pfs" \
  --output "$tmp/swing2.pfs" 2>/dev/null
frames "$tmp/swing_rank0.pfs" >"$tmp/fd"
frames "$tmp/swing2.pfs" >"$tmp/fp"
check "dynamics: each rank's assembly equals rank 0's to 1e-14" same_frames "$tmp/fd" "$tmp/fp" 1e-14 0.02 33
# more ranks than elements: ranks without elements take part in every step's collective calls
"$bin/pf-shape" box --extent 4,1,1 --cells 2,1,1 >"$tmp/two_swing.pfs"
for name in swing swing_cg; do
  "$bin/pf-sim" "$tmp/$name.json" --solver direct --quiet --input "$tmp/two_swing.pfs" --output "$tmp/fd.pfs"
  expect 0 "assembled on 4 ranks" mpi 4 "$bin/pf-sim" "$tmp/$name.json" --solver petsc \
    --input "$tmp/two_swing.pfs" --output "$tmp/fp.pfs"
  frames "$tmp/fd.pfs" >"$tmp/fd"
  frames "$tmp/fp.pfs" >"$tmp/fp"
  check "$name: 2 elements on 4 ranks, frames as direct's (measured 1.3e-10, 4.4e-10 of the largest)" \
    same_frames "$tmp/fd" "$tmp/fp" 1e-8 0.02 "$(wc -l <"$tmp/fd")"
done
# a failing step (IP with a penalty far below definiteness: CG stops on the indefinite matrix)
# ends every rank with one message and exit 1
sed 's/"flux": "ip"/"flux": "ip", "penalty": 0.05/' "$tmp/swing.json" >"$tmp/swing_bad.json"
expect 1 "frame 1, step 1: PETSc's KSP stopped" mpi 2 "$bin/pf-sim" "$tmp/swing_bad.json" \
  --solver petsc --input "$tmp/beam.pfs" --output "$tmp/swing_bad.pfs"
check "the failed step's message once" test "$(grep -c 'frame 1, step 1' "$tmp/err")" = 1

# Static DG with every rank assembling its own elements (pf_sim_distrib_static): the penalty given
# (IP: 8, what the automatic search finds on this beam), the flux BZ (its default needs no
# definiteness test), or IP's automatic penalty, searched on the distributed matrix (MUMPS's
# inertia): the same 8 after the same 3 doublings as the one-process search, on every count of
# ranks. Each rank's share of the elements is in its summary line.
# The tip against CHOLMOD to 1e-11 relative: round-off is the floor. Measured on 1, 2, 3 and 4
# ranks: IP 1.0e-12, 6.6e-13, 7.8e-13, 9.8e-13; BZ 3.8e-13, 1.6e-12, 4.2e-13, 9.9e-13; the same at
# solver tolerances 1e-10 and 1e-13 (the iterations have converged), and rank 0 assembling the
# whole system (below) is 1.0e-12 from CHOLMOD on 1 rank too.
sed 's/"flux": "ip"/"flux": "ip", "penalty": 8/' "$scenes/cantilever.json" >"$tmp/ip8.json"
sed 's/"flux": "ip"/"flux": "bz"/' "$scenes/cantilever.json" >"$tmp/bz.json"
cp "$scenes/cantilever.json" "$tmp/auto.json"
# the share lines' elements: each rank's count on one line
shares() { sed -n 's/^pf-sim: rank [0-9]*: \([0-9]*\) elements assembled.*/\1/p' "$1"; }
for case in ip8:1e-11 bz:1e-11 auto:1e-11; do
  name=${case%%:*} tol=${case#*:}
  "$bin/pf-sim" "$tmp/$name.json" --solver direct --quiet <"$tmp/beam.pfs" >"$tmp/direct.pfs"
  ref=$(tip "$tmp/direct.pfs" 4,0.5,0.5)
  for n in 1 2; do
    expect 0 "assembled on $n ranks" mpi "$n" "$bin/pf-sim" "$tmp/$name.json" --solver petsc \
      --input "$tmp/beam.pfs" --output "$tmp/own$n.pfs"
    got=$(tip "$tmp/own$n.pfs" 4,0.5,0.5)
    check "$name assembled on $n ranks: tip $got equals direct's $ref to $tol" close "$got" "$ref" "$tol"
    [ "$name" = bz ] || check "$name on $n ranks: penalty 8" grep -q "penalty 8\(, \| (3 doublings), \)assembled" "$tmp/err"
    check "$name on $n ranks: STAT as direct's" same_stat "$tmp/own$n.pfs" "$tmp/direct.pfs"
    [ "$name" = auto ] && check "auto on $n ranks: 4 definiteness tests" \
      grep -q '"factorisations":4,' <("$bin/pf-info" --json "$tmp/own$n.pfs")
    check "$name on $n ranks: $n shares, each rank some of the 32 elements, all of them once" \
      test "$(shares "$tmp/err" | wc -l)" = "$n" -a "$(shares "$tmp/err" | awk '$1 > 0' | wc -l)" = "$n" \
      -a "$(shares "$tmp/err" | awk '{ s += $1 } END { print s }')" = 32
  done
done
# against rank 0 assembling the same system (PF_SIM_RANK0_ASSEMBLY; its automatic penalty finds 8
# too): the same partition and solve, so the same tip but for the order of the sums (5e-16
# measured)
PF_SIM_RANK0_ASSEMBLY=1 expect 0 "solver petsc on 2 ranks" mpi 2 "$bin/pf-sim" \
  "$scenes/cantilever.json" --solver petsc --input "$tmp/beam.pfs" --output "$tmp/rank0.pfs"
check "rank 0 assembled all" grep -q "iterations mean" "$tmp/err"
"$bin/pf-sim" "$tmp/ip8.json" --solver direct --quiet <"$tmp/beam.pfs" >"$tmp/direct.pfs"
expect 0 "assembled on 2 ranks" mpi 2 "$bin/pf-sim" "$tmp/ip8.json" --solver petsc \
  --input "$tmp/beam.pfs" --output "$tmp/own2.pfs"
check "each rank's assembly equals rank 0's to 1e-14" \
  close "$(tip "$tmp/own2.pfs" 4,0.5,0.5)" "$(tip "$tmp/rank0.pfs" 4,0.5,0.5)" 1e-14
# more ranks than elements: ranks without elements take part in the collective calls
expect 0 "rank 3: 1 elements assembled" mpi 4 "$bin/pf-sim" "$tmp/bz.json" --solver petsc \
  --input "$tmp/two.pfs" --output "$tmp/two_own.pfs"
"$bin/pf-sim" "$tmp/bz.json" --solver direct --quiet <"$tmp/two.pfs" >"$tmp/two_direct.pfs"
check "2 elements on 4 ranks, each assembling its own" \
  close "$(tip "$tmp/two_own.pfs" 4,0.5,0.5)" "$(tip "$tmp/two_direct.pfs" 4,0.5,0.5)" 1e-11
# Static CG with every rank assembling its own elements (no halo: the parts share nodes, whose
# entries PETSc sums). The cantilever's loop above took this path on 1, 2 and 4 ranks (1e-8 as the
# issue asks; measured 1.3e-13, 4.4e-14, 8.3e-14). Here fixed and loaded regions that reach across
# the parts' cuts: a fixed box holding the first quarter of the beam (on 4 ranks a cut face lies in
# it, and a node of another part's fixed face must be fixed in every part that holds it) and a
# loaded box holding the last quarter (cut faces there are not the body's boundary: no traction),
# with gravity. Every component at four probes (on cuts, in the span, at the tip) within 1e-11 of
# the largest displacement, as for DG (measured at most 1.4e-13).
cat >"$tmp/cgbox.json" <<'EOF2'
{"material": {"E": 100000, "nu": 0.3, "density": 1}, "method": {"name": "cg"}, "gravity": [0, 0, -1],
 "fixed": [{"box": [[-0.001, -1, -1], [1.1, 2, 2]]}],
 "loads": [{"box": [[2.9, -1, -1], [4.1, 2, 2]], "traction": [0, 0, -1]}], "static": true}
EOF2
probes() { for q in 4,0.5,0.5 2,0,0 3,1,1 1.5,0.5,1; do "$bin/pf-info" --json --probe "$q" "$1" | grep -o '"u":\[[^]]*\]' | tail -1 | tr -d 'u":[]'; done | tr '\n' ,; }
"$bin/pf-sim" "$tmp/cgbox.json" --solver direct --quiet <"$tmp/beam.pfs" >"$tmp/direct.pfs"
for n in 1 2 4; do
  expect 0 "cg, 32 elements, 168 unknowns, assembled on $n ranks" mpi "$n" "$bin/pf-sim" \
    "$tmp/cgbox.json" --solver petsc --input "$tmp/beam.pfs" --output "$tmp/cg_own$n.pfs"
  check "CG regions across the cuts on $n ranks: every probe within 1e-11 of the largest" \
    awk -v a="$(probes "$tmp/cg_own$n.pfs")" -v b="$(probes "$tmp/direct.pfs")" 'BEGIN {
      n = split(a, x, ","); split(b, y, ","); for (k = 1; k < n; ++k) { d = x[k] - y[k]; if (d < 0) d = -d;
      m = y[k] < 0 ? -y[k] : y[k]; if (d > dm) dm = d; if (m > am) am = m } exit !(n == 13 && am > 0.004 && dm <= 1e-11 * am) }'
done
# ranks without elements (2 elements on 4 ranks) take part in CG's collective calls too
"$bin/pf-sim" "$tmp/cg.json" --solver direct --quiet <"$tmp/two.pfs" >"$tmp/two_direct.pfs"
expect 0 "cg, 2 elements, 24 unknowns, assembled on 4 ranks" mpi 4 "$bin/pf-sim" "$tmp/cg.json" --solver petsc \
  --input "$tmp/two.pfs" --output "$tmp/two_own.pfs"
check "CG: 2 elements on 4 ranks, each assembling its own" \
  close "$(tip "$tmp/two_own.pfs" 4,0.5,0.5)" "$(tip "$tmp/two_direct.pfs" 4,0.5,0.5)" 1e-8
# no fixed face: every rank finds it (their counts summed), all exit 1, the message once
sed 's/\[\[-0.001, -1, -1\], \[0.001, 2, 2\]\]/[[-9, -1, -1], [-8, 2, 2]]/' "$tmp/bz.json" >"$tmp/free.json"
for n in 1 2; do
  expect 1 "needs fixed faces" mpi "$n" "$bin/pf-sim" "$tmp/free.json" --solver petsc \
    --input "$tmp/beam.pfs" --output "$tmp/never.pfs"
  check "the message is printed once on $n ranks" test "$(grep -c 'needs fixed faces' "$tmp/err")" = 1
done

# --stats on that path (static, and dynamics without contact): rank 0's CPU by phase and every
# rank's share as JSON
for scene in bz swing; do
  expect 0 "assembled on 2 ranks" mpi 2 "$bin/pf-sim" "$tmp/$scene.json" --solver petsc \
    --input "$tmp/beam.pfs" --output "$tmp/stats.pfs" --stats "$tmp/stats.json"
  check "--stats ($scene): 2 ranks' shares of the 32 elements, the solves and their iterations" \
    python3 -c "import json, sys; d = json.load(open(sys.argv[1])); r = d['ranks']
assert len(r) == 2 and sum(x['elements'] for x in r) == 32 and min(x['elements'] for x in r) > 0
assert d['solver']['method'] == 'petsc' and d['solver']['pcg_iterations'] > 0
assert d['solver']['solves'] == (1 if sys.argv[2] == 'bz' else 100) == max(d['steps'], 1)
assert 0 < d['seconds']['solves_cpu'] <= d['seconds']['run']['cpu']" "$tmp/stats.json" "$scene"
  rm -f "$tmp/stats.json"
done

# Checkpoints where every rank assembles its own elements: rank 0 gathers the one-process
# simulator's CKPT state (the unknowns in the whole mesh's order), so a run continues from it
# on many ranks or on one process, and a one-process checkpoint on many ranks. The swinging beam
# (DG IP degree 1, CG) with a checkpoint every 4 frames, cut after its checkpoint of frame 4:
# - resumed on 2 ranks: every frame equals the uninterrupted run's to 1e-8 of the largest
#   displacement (not bit for bit: GAMG's set-up starts afresh; measured on 2 and 4 ranks DG
#   1.5e-14, 6.6e-15, CG 7.0e-12, 7.7e-13);
# - resumed on one process with CHOLMOD (--solver direct): to 1e-6 (PETSc's CG stops at 1e-10 of
#   the right-hand side; measured from 2 and 4 ranks DG 2.3e-11, 2.4e-11, CG 2.9e-11, 3.3e-11);
# - a one-process CHOLMOD run cut after frame 4 resumed on 2 ranks (--solver petsc): to 1e-6 of
#   the uninterrupted one-process run (measured on 2 and 4 ranks DG 2.3e-11, 2.4e-11, CG
#   2.9e-11, 3.3e-11);
# and the resumed runs' STAT counts the whole run's steps.
steps_of() { "$bin/pf-info" --json "$1" | grep -o '"steps":[0-9]*' | head -1; }
for name in swing swing_cg; do
  expect 0 "assembled on 2 ranks" mpi 2 "$bin/pf-sim" "$tmp/$name.json" --solver petsc \
    --input "$tmp/beam.pfs" --output "$tmp/ck.pfs" --checkpoint-every 4
  last=$(sed -n 's/.*"frames": \([0-9]*\).*/\1/p' "$tmp/$name.json")
  check "$name on 2 ranks: CKPT after frames 0, 4, 8 and $last" \
    grep -q "\"chunk\":\"CKPT\",\"count\":4,\"last_frame\":$last" <("$bin/pf-info" --json "$tmp/ck.pfs")
  head -c $(($(stat -c %s "$tmp/ck.pfs") * 6 / 10)) "$tmp/ck.pfs" >"$tmp/ck_cut.pfs"
  expect 0 "resuming $tmp/ck_cut.pfs after frame 4" mpi 2 "$bin/pf-sim" --resume "$tmp/ck_cut.pfs" \
    --output "$tmp/ck_res2.pfs"
  expect 0 "resuming $tmp/ck_cut.pfs after frame 4" "$bin/pf-sim" --resume "$tmp/ck_cut.pfs" \
    --solver direct --output "$tmp/ck_res1.pfs"
  frames "$tmp/ck.pfs" >"$tmp/fd"
  lines=$(wc -l <"$tmp/fd")
  frames "$tmp/ck_res2.pfs" >"$tmp/fp"
  check "$name: resumed on 2 ranks, $lines frame probes as the uninterrupted run's to 1e-8" \
    same_frames "$tmp/fd" "$tmp/fp" 1e-8 0.02 "$lines"
  frames "$tmp/ck_res1.pfs" >"$tmp/fp"
  check "$name: 2 ranks' checkpoint resumed on one process (CHOLMOD) to 1e-6" \
    same_frames "$tmp/fd" "$tmp/fp" 1e-6 0.02 "$lines"
  for res in ck_res2 ck_res1; do
    check "$name: $res's STAT counts the whole run's steps" \
      test "$(steps_of "$tmp/$res.pfs")" = "$(steps_of "$tmp/ck.pfs")"
  done
  "$bin/pf-sim" "$tmp/$name.json" --solver direct --quiet --input "$tmp/beam.pfs" \
    --output "$tmp/ck_direct.pfs" --checkpoint-every 4
  head -c $(($(stat -c %s "$tmp/ck_direct.pfs") * 6 / 10)) "$tmp/ck_direct.pfs" >"$tmp/ck_cut.pfs"
  expect 0 "assembled on 2 ranks" mpi 2 "$bin/pf-sim" --resume "$tmp/ck_cut.pfs" --solver petsc \
    --output "$tmp/ck_res2.pfs"
  frames "$tmp/ck_direct.pfs" >"$tmp/fd"
  frames "$tmp/ck_res2.pfs" >"$tmp/fp"
  check "$name: a one-process checkpoint resumed on 2 ranks to 1e-6" \
    same_frames "$tmp/fd" "$tmp/fp" 1e-6 0.02 "$lines"
done
# with contact on every rank: the box dropped onto the ground (the default scene, 16 frames),
# checkpoints every 4, cut after frame 8: resumed on 2 ranks to 1e-8 of the largest displacement
# (measured DG 4.1e-12, CG 1.7e-11), on one process with CHOLMOD to 1e-6 (7.6e-12, 2.8e-11)
box_frames() { for q in 1,0.5,0.5 0,0,0 0.5,0.25,0.5; do "$bin/pf-info" --json --probe "$q" "$1" | grep -o '"u":\[[^]]*\]'; done | tr -d 'u":[]'; }
for m in dg cg; do
  expect 0 "contacts at the boundary nodes" mpi 2 "$bin/pf-sim" --method $m --frames 16 \
    --solver petsc --input "$tmp/box.pfs" --output "$tmp/ck_drop.pfs" --checkpoint-every 4
  head -c $(($(stat -c %s "$tmp/ck_drop.pfs") * 6 / 10)) "$tmp/ck_drop.pfs" >"$tmp/ck_cut.pfs"
  expect 0 "after frame 8" mpi 2 "$bin/pf-sim" --resume "$tmp/ck_cut.pfs" --output "$tmp/ck_res2.pfs"
  expect 0 "after frame 8" "$bin/pf-sim" --resume "$tmp/ck_cut.pfs" --solver direct \
    --output "$tmp/ck_res1.pfs"
  box_frames "$tmp/ck_drop.pfs" >"$tmp/fd"
  for res in ck_res2:1e-8 ck_res1:1e-6; do
    box_frames "$tmp/${res%%:*}.pfs" >"$tmp/fp"
    check "$m drop with contact: ${res%%:*} to ${res#*:} of the largest" \
      same_frames "$tmp/fd" "$tmp/fp" "${res#*:}" 0.02 51
  done
done

# a damaged checkpoint (its state's fingerprint flipped, the CRC made right) is refused by rank 0
# on resuming, and every rank ends: exit 1, the message once, naming the chunk
python3 - "$tmp/ck.pfs" "$tmp/ck_bad.pfs" <<'PY'
import struct, sys, zlib
data = bytearray(open(sys.argv[1], "rb").read())
at, last = 8, None
while at < len(data):
    size = struct.unpack_from("<Q", data, at + 8)[0]
    if data[at:at + 4] == b"CKPT":
        last = (at, size)
    at += 20 + size
at, size = last
data[at + 16 + 48 + 12] ^= 1  # the state's fingerprint (after the 48-byte CKPT header)
struct.pack_into("<I", data, at + 16 + size, zlib.crc32(bytes(data[at + 16:at + 16 + size])))
open(sys.argv[2], "wb").write(data)
PY
expect 1 "chunk CKPT at byte" mpi 2 "$bin/pf-sim" --resume "$tmp/ck_bad.pfs" --output "$tmp/ck_bad_res.pfs"
check "a damaged checkpoint on 2 ranks: the message once" \
  test "$(grep -c 'another scene, mesh or obstacle surface' "$tmp/err")" = 1

# A static scene's checkpoint (its solution; DG BZ degree 2) from 2 ranks: restored on one
# process, the same STAT (the error indicator of the restored state to 1e-8 relative, measured
# 1.1e-14); the complete stream resumed on 2 ranks is the same stream, bit for bit.
expect 0 "assembled on 2 ranks" mpi 2 "$bin/pf-sim" "$tmp/bz.json" --solver petsc \
  --input "$tmp/beam.pfs" --output "$tmp/ck.pfs"
expect 0 "the stream was complete" "$bin/pf-sim" --resume "$tmp/ck.pfs" --solver direct \
  --output "$tmp/ck_res1.pfs"
check "static DG: restored on one process, STAT as on 2 ranks" \
  same_stat "$tmp/ck.pfs" "$tmp/ck_res1.pfs"
expect 0 "the stream was complete" mpi 2 "$bin/pf-sim" --resume "$tmp/ck.pfs" \
  --output "$tmp/ck_res2.pfs"
check "static DG: resumed on 2 ranks, the same stream" cmp -s "$tmp/ck.pfs" "$tmp/ck_res2.pfs"

# An error on rank 0 (a missing scene file) ends all ranks: exit 1, the message once, no hang.
expect 1 "missing.json: cannot open" mpi 2 "$bin/pf-sim" "$tmp/missing.json" --solver petsc \
  --input "$tmp/beam.pfs" --output "$tmp/never.pfs"
check "the message is printed once" test "$(grep -c 'missing.json' "$tmp/err")" = 1
# a stream that is not one, and the output under mpirun needs --output
printf 'not a stream' >"$tmp/bad.pfs"
expect 1 "bad.pfs" mpi 4 "$bin/pf-sim" --solver petsc --input "$tmp/bad.pfs" --output "$tmp/never.pfs"
expect 2 "--output FILE" mpi 2 "$bin/pf-sim" --solver petsc --input "$tmp/beam.pfs"
check "no output file after failures" test ! -e "$tmp/never.pfs"
finish
