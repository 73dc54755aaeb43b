#!/usr/bin/env bash
# The static solve on PETSc with every rank assembling its own elements (pf_sim_distrib_run)
# against rank 0 assembling the whole system (PF_SIM_RANK0_ASSEMBLY=1, the path of every other
# scene), on 1 and 2 ranks: memory and CPU per rank. The scene: data/scenes/cantilever.json with
# DG degree 1 and the BZ flux (its default penalty: no definiteness test, so both paths solve the
# same system), on 4r x r x r hexes; METHOD=cg in the environment: CG instead; DYNAMIC=1: DG
# dynamics instead, the same beam swinging under gravity (no ground), corotated, FRAMES frames
# (default 2) of SUBSTEPS steps (default 10); PATHS (default "ranks rank0"): the paths run. CSV
# on stdout, one row per (path, mesh, ranks); the head comment says what machine and load it ran
# on.
#   [METHOD=cg | DYNAMIC=1 [FRAMES=F] [SUBSTEPS=S]] [PATHS=ranks] bench/petsc_static.sh BUILD_DIR
#   [SIZES...]   SIZES: r (default 8 16)
# Needs a build with -DPF_PETSC=ON and /usr/bin/time. Columns:
#   assembly (ranks: each its own; rank0: rank 0 all), elements, unknowns, ranks, iterations
#   (dynamics: per step),
#   rank0_setup_cpu_s (rank 0's CPU outside PETSc's solve and preconditioner set-up: MPI and
#   PETSc start-up, reading, the method's set-up, assembly, the matrix, the output; its whole CPU
#   less what pf-sim reports for the solves), rank0_cpu_s and
#   rank1_cpu_s (user + system of each process), rank0_rss_mb and rank1_rss_mb (peak RSS),
#   wall_s
set -euo pipefail
build=${1:?usage: bench/petsc_static.sh BUILD_DIR [SIZES...]}
shift
sizes=("$@")
[ ${#sizes[@]} -eq 0 ] && sizes=(8 16)
root=$(cd "$(dirname "$0")/.." && pwd)
bin=$build/bin
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "# cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(nproc) cores online, load average $(cut -d' ' -f1 /proc/loadavg) at start; $(mpirun --version | head -1); PETSc $(pkg-config --modversion petsc)"
method=${METHOD:-dg}
if [ -n "${DYNAMIC:-}" ]; then
  frames=${FRAMES:-2} substeps=${SUBSTEPS:-10}
  echo "# scene: data/scenes/cantilever.json, DG degree 1, flux bz, dynamic: no load, gravity, no ground, $frames frames of $substeps steps, dt 0.01 a frame, corotated"
  sed 's/"degree": 2, "flux": "ip", "penalty": 0/"degree": 1, "flux": "bz"/; s/"gravity": \[0, 0, 0\]/"gravity": [0, 0, -1]/; s/"static": true/"ground": false, "corotation": true, "time": {"frames": '"$frames"', "dt": 0.01, "substeps": '"$substeps"'}/; /"loads"/d' \
    "$root/data/scenes/cantilever.json" >"$tmp/bz.json"
elif [ "$method" = cg ]; then
  echo "# scene: data/scenes/cantilever.json, CG, static"
  sed 's/"name": "dg", "degree": 2, "flux": "ip", "penalty": 0/"name": "cg"/' \
    "$root/data/scenes/cantilever.json" >"$tmp/bz.json"
else
  echo "# scene: data/scenes/cantilever.json, DG degree 1, flux bz (default penalty), static"
  sed 's/"degree": 2, "flux": "ip", "penalty": 0/"degree": 1, "flux": "bz"/' \
    "$root/data/scenes/cantilever.json" >"$tmp/bz.json"
fi
echo "assembly,elements,unknowns,ranks,iterations,rank0_setup_cpu_s,rank0_cpu_s,rank1_cpu_s,rank0_rss_mb,rank1_rss_mb,wall_s"
for r in "${sizes[@]}"; do
  "$bin/pf-shape" box --extent 4,1,1 --cells $((4 * r)),$r,$r >"$tmp/beam.pfs"
  for n in 1 2; do
    for path in ${PATHS:-ranks rank0}; do
      if [ $path = rank0 ]; then export PF_SIM_RANK0_ASSEMBLY=1; else unset PF_SIM_RANK0_ASSEMBLY; fi
      start=$(date +%s.%N)
      mpirun -n $n --oversubscribe \
        sh -c 'exec /usr/bin/time -o "$0.$OMPI_COMM_WORLD_RANK" -f "rusage $OMPI_COMM_WORLD_RANK %M %U %S" "$@"' "$tmp/rusage" \
        "$bin/pf-sim" "$tmp/bz.json" --solver petsc --input "$tmp/beam.pfs" \
        --output "$tmp/out.pfs" 2>"$tmp/err"
      end=$(date +%s.%N)
      awk -v path=$path -v n=$n -v wall="$(echo "$end - $start" | bc)" '
        /^pf-sim: [cd]g,/ { for (k = 1; k <= NF; ++k) { if ($(k+1) ~ /^elements/) el = $k; if ($(k+1) ~ /^unknowns/) un = $k } }
        /assembled on/ { for (k = 1; k <= NF; ++k) if ($(k+1) == "iterations,") it = $k }
        / steps, .* iterations per step/ { for (k = 1; k <= NF; ++k) if ($(k+1) == "iterations" && $(k+2) == "per") it = $k }
        /^pf-sim: rank 0: / { for (k = 1; k <= NF; ++k) { if ($k == "set-up") setup = $(k+1); if ($k == "in" && $(k+1) == "all,") all = $(k-3) } }
        /^pf-sim: solver petsc/ { for (k = 1; k <= NF; ++k) { if ($k == "iterations" && $(k+1) == "mean,") it = $(k-1); if ($k == "solves" && $(k+2) == "s") sc = $(k+5) } }
        /^rusage/ { rss[$2] = $3 / 1024; cpu[$2] = $4 + $5 }
        END {
          setup = path == "rank0" ? cpu[0] - sc : cpu[0] - (all - setup)
          printf "%s,%s,%s,%d,%s,%.2f,%.2f,%.2f,%.1f,%.1f,%.2f\n", path, el, un, n, it, setup, cpu[0], (n > 1 ? cpu[1] : 0), rss[0], (n > 1 ? rss[1] : 0), wall
        }' "$tmp/err" "$tmp"/rusage.*
      rm -f "$tmp"/rusage.*
    done
  done
done
