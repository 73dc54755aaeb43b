# Mesh changes while the simulation runs: (a) the static cantilever's compliance error against
# unknowns, meshes refined by stress against uniform ones, CG and DG degree 1 and 2 (bench_adapt
# accuracy);
# (b) CPU milliseconds per split element of a refinement, by part, on the bending and twisting
# bars (bench_adapt events); (c) CPU seconds of a CG run's mesh changes with the set-up copying
# what the change did not touch ("reuse") and with every set-up from scratch ("rebuild")
# (bench_adapt reuse).
# gnuplot bench/adapt.gp   (writes adapt.png)
# optional: -e "accuracy='...csv'; events='...csv'; reuse='...csv'; out='other.png'"
if (!exists("accuracy")) accuracy = 'bench/results/adapt_accuracy.csv'
if (!exists("events")) events = 'bench/results/adapt_events.csv'
if (!exists("reuse")) reuse = 'bench/results/adapt_reuse.csv'
if (!exists("out")) out = 'adapt.png'
set terminal pngcairo size 1900,560
set output out
set datafile separator ','
set datafile commentschars '#'
set multiplot layout 1,3
set grid
set key bottom left

# columns: 1 method, 2 mesh, 3 r, 4 fraction, 5 level, 6 elems, 7 dofs, 8 compliance, 9 error
set title 'cantilever compliance error against unknowns'
set logscale xy
set xlabel 'unknowns'
set ylabel 'relative error'
set style data linespoints
sel(m, mesh, r, f) = strcol(1) eq m && strcol(2) eq mesh && (r == 0 || $3 == r) && abs($4 - f) < 1e-9
M = "cg dg1 dg2"
plot for [i=1:3] accuracy using 7:(sel(word(M, i), 'uniform', 0, 0) ? $9 : 1/0) lc i lw 2 pt 7 \
       title word(M, i).' uniform', \
     for [i=1:3] accuracy using 7:(sel(word(M, i), 'stress', 4, 0.9) ? $9 : 1/0) lc i dt 2 pt 6 \
       title word(M, i).' by stress (r 4, 90 %)', \
     for [i=1:3] accuracy using 7:(sel(word(M, i), 'stress', 2, 0.6) ? $9 : 1/0) lc i dt 3 pt 4 \
       title word(M, i).' by stress (r 2, 60 %)'

# columns: 1 case, 2 method, 3 split, 11 mesh_ms, 12 method_ms, 13 setup_ms, 14 transfer_ms, 15 factor_ms
unset logscale
set title 'CPU ms per split element'
set xlabel ''
set ylabel 'ms'
set style data histograms
set style histogram rowstacked
set style fill solid 0.7
set key outside right
set xtics rotate by -30
plot events using 11:xtic(sprintf("%s %s %s", strcol(1), strcol(2), strcol(3))) every ::1 title 'mesh', \
     '' using 12 every ::1 title 'method', '' using 13 every ::1 title 'set-up', \
     '' using 14 every ::1 title 'transfer', '' using 15 every ::1 title 'factorisation'

# columns: 1 case, 2 fraction, 3 mode, 8 change_cpu_s, 9 method_cpu_s (after the header, the warm-up row: skipped)
set title 'CPU s of the mesh changes of a CG run'
set ylabel 's'
plot reuse using 9:xtic(sprintf("%s %s %s", strcol(1), strcol(2), strcol(3))) every ::2 \
       title 'method set-up', \
     '' using ($8 - $9) every ::2 title 'rest of the changes'
unset multiplot
