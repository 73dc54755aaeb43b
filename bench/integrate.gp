# Exact polyhedral moments per second against the degree, one line per cell shape.
# gnuplot -e "csv='bench/results/integrate.csv'" bench/integrate.gp   (writes integrate.png)
# optional: -e "out='other.png'"
if (!exists("csv")) csv = 'bench/results/integrate.csv'
if (!exists("out")) out = 'integrate.png'
set terminal pngcairo size 800,500
set output out
set datafile separator ','
set datafile commentschars '#'
set key bottom right
set logscale y
set xrange [-0.5:8.5]
set xtics 1
set xlabel 'degree (all monomials of total degree <= d per call)'
set ylabel 'moments per second'
set grid
set title 'pf\_polyhedron\_moments, one thread, each cell in its own frame'
cells = "hex tet L-prism sliced-sphere"
# column 1 is a string: select a cell by comparing it, others become undefined points
plot for [c in cells] csv skip 2 using 3:(strcol(1) eq c ? $4 : 1/0) \
     with linespoints title c
