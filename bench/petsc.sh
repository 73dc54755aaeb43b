#!/usr/bin/env bash
# The petsc solver under mpirun: strong scaling (1 and 2 ranks), memory per rank and GAMG
# iterations per step against unknowns, on the cantilever of data/scenes/cantilever.json run as
# dynamics (corotated, so GAMG is rebuilt every step) for a few frames. CSV on stdout, one row per
# (method, mesh, ranks); the head comment says what machine and load it ran on.
#   bench/petsc.sh BUILD_DIR [SIZES...]   SIZES: r for 4r x r x r hexes (default 4 8 12 16)
#   PF_BENCH_METHODS="cg dg" PF_BENCH_RANKS="1 2" select the rows (DG degree 1 runs r <= 8 only).
# Needs a build with -DPF_PETSC=ON and /usr/bin/time. Columns:
#   method, elements, unknowns, ranks, steps, gamg_iterations_mean, gamg_iterations_max,
#   solve_wall_s, solve_cpu_s (rank 0's CPU in its solves), assembly_s (rank 0, wall: the serial
#   part), wall_s (the whole run),
#   rss_rank0_mb (rank 0: the mesh, the assembled matrix, its share of PETSc's), rss_other_mb
#   (the largest of the other ranks: PETSc's share alone), cpu_all_s (user + system, all ranks)
set -euo pipefail
build=${1:?usage: bench/petsc.sh BUILD_DIR [SIZES...]}
shift
sizes=("$@")
[ ${#sizes[@]} -eq 0 ] && sizes=(4 8 12 16)
root=$(cd "$(dirname "$0")/.." && pwd)
bin=$build/bin
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
frames=2
echo "# cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(nproc) cores online, load average $(cut -d' ' -f1 /proc/loadavg) at start; $(mpirun --version | head -1); PETSc $(pkg-config --modversion petsc)"
echo "# scene: data/scenes/cantilever.json with static false, $frames frames (substeps as the scene's default), corotation on"
echo "method,elements,unknowns,ranks,steps,gamg_iterations_mean,gamg_iterations_max,solve_wall_s,solve_cpu_s,assembly_s,wall_s,rss_rank0_mb,rss_other_mb,cpu_all_s"
sed 's/"name": "dg", "degree": 2, "flux": "ip"/"name": "cg"/' "$root/data/scenes/cantilever.json" >"$tmp/cg.json"
sed 's/"degree": 2, "flux": "ip"/"degree": 1, "flux": "ip"/' "$root/data/scenes/cantilever.json" >"$tmp/dg.json"
for method in ${PF_BENCH_METHODS:-cg dg}; do
  for r in "${sizes[@]}"; do
    [ "$method" = dg ] && [ "$r" -gt 8 ] && continue   # DG degree 1 has 4x CG's unknowns
    "$bin/pf-shape" box --extent 4,1,1 --cells $((4 * r)),$r,$r >"$tmp/beam.pfs"
    for n in ${PF_BENCH_RANKS:-1 2}; do
      start=$(date +%s.%N)
      mpirun -n $n --oversubscribe /usr/bin/time -f 'rusage %M %U %S' "$bin/pf-sim" "$tmp/$method.json" \
        --static=false --frames $frames --solver petsc --input "$tmp/beam.pfs" \
        --output "$tmp/out.pfs" 2>"$tmp/err"
      end=$(date +%s.%N)
      awk -v m=$method -v n=$n -v wall="$(echo "$end - $start" | bc)" '
        /^pf-sim: (cg|dg),/ { for (k = 1; k <= NF; ++k) { if ($(k+1) ~ /^elements/) el = $k; if ($(k+1) ~ /^unknowns/) un = $k; if ($(k+1) ~ /^steps/) st = $k; if ($k == "assembly") as = $(k+1) } }
        /^pf-sim: solver petsc/ { for (k = 1; k <= NF; ++k) { if ($k == "iterations" && $(k+1) == "mean,") it = $(k-1); if ($(k+1) == "max;") mx = $k; if ($k == "solves" && $(k+2) == "s") { sw = $(k+1); sc = $(k+5) } } }
        /^rusage/ { rank++; rss[rank] = $2 / 1024; cpu += $3 + $4 }
        END {
          # rank 0 is the one that printed the summary: the largest RSS
          r0 = 0; other = 0
          for (k in rss) if (rss[k] > r0) r0 = rss[k]
          for (k in rss) if (rss[k] < r0 && rss[k] > other) other = rss[k]
          if (n == 1) other = 0
          printf "%s,%s,%s,%d,%s,%s,%s,%s,%s,%s,%.2f,%.1f,%.1f,%.2f\n", m, el, un, n, st, it, mx, sw, sc, as, wall, r0, other, cpu
        }' "$tmp/err"
    done
  done
done
