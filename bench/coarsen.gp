# pf_mesh_coarsen's CPU time per call against the number of groups it merges (log-log), beside
# the refinement that made them: a floor of O(mesh) reading and copying, then a slope of the
# per-group cost.
# gnuplot -e "csv='bench/results/coarsen.csv'" bench/coarsen.gp   (writes coarsen.png)
# optional: -e "out='other.png'"
if (!exists("csv")) csv = 'bench/results/coarsen.csv'
if (!exists("out")) out = 'coarsen.png'
set terminal pngcairo size 800,500
set output out
set datafile separator ','
set datafile commentschars '#'
set key top left
set logscale xy
set xlabel 'groups merged (cubes refined by octs) in a 20x6x6 box'
set ylabel 'CPU ms per call'
set grid
set title 'pf\_mesh\_coarsen: refine-then-coarsen on 720 hexes'
plot csv skip 3 using 1:5 with linespoints title 'coarsen', \
     csv skip 3 using 1:4 with linespoints title 'refine'
