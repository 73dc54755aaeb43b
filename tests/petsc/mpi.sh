# pf-sim --solver petsc under mpirun with 1, 2 and 4 ranks (4 oversubscribed on a small machine)
# against the one-process direct solve: the static cantilever (DG degree 2, CG) to 1e-8 relative,
# a corotated drop to 1e-6 of the largest displacement, the same stream from two runs on 2 ranks,
# PETSc's options passed through, and an error on rank 0 ending every rank with one message and
# exit 1. Built with -DPF_PETSC=ON.
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
expect 0 "1.0 iterations mean" mpi 2 "$bin/pf-sim" "$tmp/cg.json" --solver petsc \
  --input "$tmp/beam.pfs" --output "$tmp/lu.pfs" -pc_type lu -pc_factor_mat_solver_type mumps
got=$(tip "$tmp/lu.pfs" 4,0.5,0.5)
"$bin/pf-sim" "$tmp/cg.json" --solver direct --quiet <"$tmp/beam.pfs" >"$tmp/direct.pfs"
check "MUMPS through the options: tip $got equals direct's" close "$got" "$(tip "$tmp/direct.pfs" 4,0.5,0.5)" 1e-8

# A corotated drop onto the ground (the default scene, 8 frames): every frame's displacement at
# a corner within 1e-6 of the largest, on 2 ranks.
"$bin/pf-shape" box --extent 1,0.5,0.5 --cells 4,2,2 >"$tmp/box.pfs"
"$bin/pf-sim" --frames 8 --solver direct --quiet <"$tmp/box.pfs" >"$tmp/drop_direct.pfs"
expect 0 "solver petsc" mpi 2 "$bin/pf-sim" --frames 8 --solver petsc --input "$tmp/box.pfs" \
  --output "$tmp/drop_petsc.pfs"
"$bin/pf-info" --json --probe 1,0.5,0.5 "$tmp/drop_direct.pfs" | grep -o '"u":\[[^]]*\]' >"$tmp/ud"
"$bin/pf-info" --json --probe 1,0.5,0.5 "$tmp/drop_petsc.pfs" | grep -o '"u":\[[^]]*\]' >"$tmp/up"
check "nine frames of the drop in both" test "$(wc -l <"$tmp/ud")" = 9 -a "$(wc -l <"$tmp/up")" = 9
check "the drop on 2 ranks follows direct's frames to 1e-6 of the largest displacement" \
  bash -c "paste -d, '$tmp/ud' '$tmp/up' | tr -d 'u\":[]' | awk -F, '{ for (k = 1; k <= 3; ++k) { d = \$k - \$(k + 3); if (d < 0) d = -d; if (d > dm) dm = d; a = \$k < 0 ? -\$k : \$k; if (a > am) am = a } } END { exit !(am > 0.01 && dm <= 1e-6 * am) }'"

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
