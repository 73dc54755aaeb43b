# Frames per second of pf's renderer against triangle count, one line per image size.
# gnuplot -e "in='bench/results/render.csv'; out='render.png'" bench/render.gp
if (!exists("in")) in = 'bench/results/render.csv'
if (!exists("out")) out = 'render.png'
set terminal pngcairo size 800,500
set output out
set datafile separator ','
set key top right
set logscale xy
set xlabel 'triangles'
set ylabel 'frames per second (geometry + render + PNG)'
set grid
set title 'pf-render on llvmpipe (OSMesa), 4x MSAA, shadowed ground'
plot for [size in "640 1280 1920"] in skip 2 using 1:($2 == size + 0 ? $10 : 1/0) \
     with linespoints title size == "640" ? '640x360' : size == "1280" ? '1280x720' : '1920x1080', \
     10 with lines dashtype 2 lc rgb 'gray' title 'target at 1280x720, 100k triangles'
