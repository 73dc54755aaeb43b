# The CG method: (a) set-up per harmonic element (basis + K_e and M_e) against its node count,
# convex and non-convex cells of sliced spheres and tori; (b) cantilever tip error and median
# boundary error against the kernel offset xi, one line per edge_samples.
# gnuplot bench/cg.gp   (writes cg.png)
# optional: -e "setup='...csv'; sweep='...csv'; refine='...csv'; out='other.png'"
if (!exists("setup")) setup = 'bench/results/cg_setup.csv'
if (!exists("sweep")) sweep = 'bench/results/cg_sweep.csv'
if (!exists("refine")) refine = 'bench/results/cg_refine.csv'
if (!exists("out")) out = 'cg.png'
set terminal pngcairo size 1950,520
set output out
set datafile separator ','
set multiplot layout 1,3

# (a) columns: 3 kind, 4 convex, 5 nodes, 8 setup_ms
set logscale y
set grid
set key top left
set xlabel 'nodes of the element'
set ylabel 'set-up per element, ms (basis + element matrices)'
plot setup using ((strcol(3) eq 'harmonic' && $4 == 1) ? $5 : NaN):8 with points pt 7 ps 0.5 title 'harmonic, convex', \
     setup using ((strcol(3) eq 'harmonic' && $4 == 0) ? $5 : NaN):8 with points pt 5 ps 0.5 title 'harmonic, non-convex', \
     setup using ((strcol(3) ne 'harmonic') ? $5 : NaN):8 with points pt 1 ps 0.8 title 'closed forms', \
     1 with lines dt 2 title 'target 1 ms'

# (b) columns: 1 xi, 2 edge_samples, 4 median boundary error, 6 tip error
set logscale y
set xlabel 'kernel offset xi (fraction of the element size)'
set ylabel 'relative error'
set key top right
plot for [s in "2 3 5"] sweep using ($2 == s+0 ? $1 : NaN):6 with linespoints title sprintf('tip error, edge samples %s', s), \
     for [s in "2 3 5"] sweep using ($2 == s+0 ? $1 : NaN):4 with linespoints dt 2 title sprintf('median boundary error, edge samples %s', s)

# (c) columns: 1 mesh, 5 dofs, 7 tip error
set logscale xy
set xlabel 'degrees of freedom'
set ylabel 'cantilever tip error against the DG limit'
set key bottom left
plot refine using (strcol(1) eq 'hex' ? $5 : NaN):7 with linespoints pt 7 title 'uniform hexes (trilinear)', \
     refine using (strcol(1) eq 'octree' ? $5 : NaN):7 with linespoints pt 5 title 'octree toward the surface (harmonic where coarse meets fine)', \
     refine using (strcol(1) eq 'octree_turned_sliced' ? $5 : NaN):7 with linespoints pt 9 title 'sliced octree, beam turned 30 degrees'
unset multiplot
