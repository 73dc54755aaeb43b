# The DG simulator: (a) static cantilever tip error against run time, one line per method;
# (b) time of one corotated step against one CHOLMOD factorisation of its matrix.
# gnuplot bench/dg.gp   (writes dg.png)
# optional: -e "cantilever='...csv'; step='...csv'; out='other.png'"
if (!exists("cantilever")) cantilever = 'bench/results/dg_cantilever.csv'
if (!exists("step")) step = 'bench/results/dg_step.csv'
if (!exists("out")) out = 'dg.png'
set terminal pngcairo size 1300,520
set output out
set datafile separator ','
set datafile commentschars '#'
set multiplot layout 1,2

# (a) columns: 1 method, 9 error against the finest IP degree-2 run (0 for that run itself:
# not drawn on a log scale), 11 seconds (pf_sim_create + pf_sim_solve_static)
set logscale xy
set grid
set key bottom left
set xlabel 'run time, s (set-up with penalty search + static solve)'
set ylabel 'relative tip error (vs. finest IP degree 2)'
set title 'cantilever 4x1x1 on 4r x r x r hexes, r = 1, 2, 4, 8'
methods = "IP1 IP2 BZ1 BZ2 BZ2-eta64"
plot for [m in methods] cantilever skip 2 \
     using (strcol(1) eq m ? $11 : 1/0):(strcol(1) eq m && $9 > 0 ? $9 : 1/0) \
     with linespoints title m

# (b) columns: 2 degree, 5 step_ms, 7 factor_ms, 12 thread settings. The default settings, and
# CHOLMOD's OpenMP capped at one thread with OpenBLAS on both cores (the thread study's best).
set key top left
set xlabel 'one numeric factorisation, ms'
set ylabel 'one corotated step, ms'
set title 'n^3 hex cube, n = 5, 8, 12 (degree 1 and 2)'
tuned = 'OMP_THREAD_LIMIT=1 OPENBLAS_NUM_THREADS=2'
plot step skip 2 using (strcol(12) eq 'default' && $2 == 1 ? $7 : 1/0):5 \
          with linespoints pt 7 title 'degree 1, default threads', \
     step skip 2 using (strcol(12) eq 'default' && $2 == 2 ? $7 : 1/0):5 \
          with linespoints pt 5 title 'degree 2, default threads', \
     step skip 2 using (strcol(12) eq tuned && $2 == 1 ? $7 : 1/0):5 \
          with linespoints pt 6 title 'degree 1, OpenMP capped at 1 thread', \
     step skip 2 using (strcol(12) eq tuned && $2 == 2 ? $7 : 1/0):5 \
          with linespoints pt 4 title 'degree 2, OpenMP capped at 1 thread', \
     x with lines dashtype 2 lc rgb 'gray' title 'step = factorisation', \
     1.3 * x with lines dashtype 3 lc rgb 'black' title 'target: 1.3 x factorisation'
unset multiplot
