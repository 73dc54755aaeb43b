# Octree element counts against depth (log scale), with the 4x-per-level (area) and 8x-per-level
# (volume) slopes for reference.
# gnuplot -e "csv='bench/results/octree.csv'" bench/octree.gp   (writes octree.png)
# optional: -e "out='other.png'"
if (!exists("csv")) csv = 'bench/results/octree.csv'
if (!exists("out")) out = 'octree.png'
set terminal pngcairo size 800,500
set output out
set datafile separator ','
set datafile commentschars '#'
set key top left
set logscale y 2
set xrange [3.5:7.5]
set xtics 1
set xlabel 'depth of the surface cells'
set ylabel 'elements'
set grid
set title 'pf\_mesh\_octree, min depth 2: elements grow with the area (4x per level)'
# columns 1 (shape) and 3 (slice) select a series; others become undefined points
plot for [s in "sphere torus"] for [c=0:1] csv skip 3 \
       using 4:(strcol(1) eq s && $3 == c ? $7 : 1/0) with linespoints \
       title s.(c ? ' sliced' : ' cells'), \
     1168 * 4**(x - 4) with lines dashtype 2 title '4x per level', \
     1168 * 8**(x - 4) with lines dashtype 3 title '8x per level'
