# Mesh changes while the simulation runs: (a) the static cantilever's tip error against unknowns,
# meshes refined by stress against uniform ones, CG and DG degree 2 (bench_adapt accuracy);
# (b) CPU milliseconds per split element of a refinement, by part, on the bending and twisting
# bars (bench_adapt events).
# gnuplot bench/adapt.gp   (writes adapt.png)
# optional: -e "accuracy='...csv'; events='...csv'; out='other.png'"
if (!exists("accuracy")) accuracy = 'bench/results/adapt_accuracy.csv'
if (!exists("events")) events = 'bench/results/adapt_events.csv'
if (!exists("out")) out = 'adapt.png'
set terminal pngcairo size 1300,520
set output out
set datafile separator ','
set datafile commentschars '#'
set multiplot layout 1,2
set grid
set key top right

# columns: 1 method, 2 mesh, 3 level, 4 elems, 5 dofs, 6 tip, 7 error, 8 cpu_s
set title 'cantilever tip error against unknowns'
set logscale xy
set xlabel 'unknowns'
set ylabel '|error|'
set style data linespoints
plot accuracy using 5:(strcol(1) eq 'cg' && strcol(2) eq 'uniform' ? abs($7) : 1/0) title 'cg uniform', \
     accuracy using 5:(strcol(1) eq 'cg' && strcol(2) eq 'adaptive' ? abs($7) : 1/0) title 'cg by stress', \
     accuracy using 5:(strcol(1) eq 'dg2' && strcol(2) eq 'uniform' ? abs($7) : 1/0) title 'dg 2 uniform', \
     accuracy using 5:(strcol(1) eq 'dg2' && strcol(2) eq 'adaptive' ? abs($7) : 1/0) title 'dg 2 by stress'

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
