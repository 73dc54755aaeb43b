# Voxelization: grid cells classified per second against resolution, one line per surface and
# inside test (rays for closed surfaces, the winding number for open ones).
# gnuplot -e "csv='bench/results/voxelize.csv'" bench/voxelize.gp   (writes voxelize.png)
# optional: -e "out='other.png'"
if (!exists("csv")) csv = 'bench/results/voxelize.csv'
if (!exists("out")) out = 'voxelize.png'
set terminal pngcairo size 800,500
set output out
set datafile separator ','
set datafile commentschars '#'
set key outside right
set logscale xy
set xtics (8, 16, 32, 64, 128)
set xlabel 'cells along the longest side'
set ylabel 'cells per CPU second'
set grid
set title 'pf\_mesh\_voxelize, inside mode, one thread'
series = "sphere,960,rays sphere,9800,rays bunny,3674,rays bunny-open,3673,winding sphere-open,959,winding"
key(r) = strcol(1).','.strcol(2).','.strcol(3)
# columns 1-3 are strings: select a series by comparing them, others become undefined points
plot for [s in series] csv skip 3 using 4:(key(0) eq s ? $9 : 1/0) with linespoints title s
