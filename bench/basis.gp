# The harmonic basis alone: (a) set-up per harmonic element against its node count (sliced
# spheres and tori, bench_basis); (b) what accuracy costs: median boundary error and median set-up
# of the cells of up to 16 nodes against edge_samples (bench_basis cost).
# gnuplot bench/basis.gp   (writes basis.png)
# optional: -e "cells='...csv'; cost='...csv'; out='other.png'"
if (!exists("cells")) cells = 'bench/results/basis.csv'
if (!exists("cost")) cost = 'bench/results/basis_cost.csv'
if (!exists("out")) out = 'basis.png'
set terminal pngcairo size 1300,520
set output out
set datafile separator ','
set multiplot layout 1,2

# (a) columns: 3 kind, 5 nodes, 8 setup_ms
set logscale y
set grid
set key top left
set xlabel 'nodes of the element'
set ylabel 'basis set-up per element, ms'
plot cells using ((strcol(3) eq 'harmonic') ? $5 : NaN):8 with points pt 7 ps 0.5 title 'harmonic'

# (b) columns: 1 edge_samples, 3 median_setup_ms, 4 median_boundary_error, 5 max
set xlabel 'edge_samples'
set ylabel 'relative boundary L2 error'
set y2label 'median set-up, ms'
set y2tics
set logscale y2
set key top right
plot cost using 1:4 with linespoints pt 7 title 'median boundary error', \
     cost using 1:5 with linespoints pt 5 title 'largest boundary error', \
     cost using 1:3 axes x1y2 with linespoints pt 4 dt 2 title 'median set-up (right)'
unset multiplot
