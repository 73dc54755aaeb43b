# Penalty contact per step: (a) against the triangles of a mesh obstacle (contact at the boundary
# nodes of a 6^3 cube), (b) against the vertices of an embedded surface (contact and the
# positions' mat-vec), from bench_contact sweep.
# gnuplot bench/contact.gp   (writes contact.png)
# optional: -e "sweep='...csv'; out='other.png'"
if (!exists("sweep")) sweep = 'bench/results/contact_sweep.csv'
if (!exists("out")) out = 'contact.png'
set terminal pngcairo size 1300,520
set output out
set datafile separator ','
set datafile commentschars '#'
set multiplot layout 1,2
set logscale xy
set grid
set key top left

# columns: 1 case, 3 obstacle triangles, 4 surface vertices, 7 contact ms, 8 embedding ms
set xlabel 'obstacle triangles'
set ylabel 'ms per step'
set title 'mesh obstacle (Embree closest points), 218 boundary nodes'
plot sweep using (strcol(1) eq 'obstacle' ? $3 : 1/0):7 with linespoints title 'contact search + assembly'

set xlabel 'embedded surface vertices'
set title 'contact at the embedded surface (MLS weights), plane obstacle'
plot sweep using (strcol(1) eq 'surface' ? $4 : 1/0):7 with linespoints title 'contact search + assembly', \
     sweep using (strcol(1) eq 'surface' ? $4 : 1/0):8 with linespoints title 'predicted positions (embedding)'
unset multiplot
