# Cutting: (a) CPU ms per split element of a cut (whole, and two of its parts), pf_mesh_cut alone and pf_sim_cut with
# DG and CG, on the hex bar and the tets (bench_cut table), beside the harmonic paper's t_init
# (table 1: Bar Cut 688 ms, Dino Cut 48 ms per polyhedral element); (c) a blade sweeping through
# 5k tets, DG degree 1: CPU ms of each frame's cut and per step, and the elements (bench_cut
# progressive).
# gnuplot bench/cut.gp   (writes cut.png)
# optional: -e "table='...csv'; progressive='...csv'; out='other.png'"
if (!exists("table")) table = 'bench/results/cut_table.csv'
if (!exists("progressive")) progressive = 'bench/results/cut_progressive.csv'
if (!exists("out")) out = 'cut.png'
set terminal pngcairo size 1300,520
set output out
set datafile separator ','
set datafile commentschars '#'
set multiplot layout 1,2
set grid

# columns: 1 mesh, 2 method, 9 ms_per_split, 11 method_ms, 12 setup_ms, 17 paper_ms
# (rows: bar mesh, dg, cg, then tets mesh, dg, cg; a gap between the meshes)
set title 'CPU ms per split element of a cut'
set xlabel ''
set ylabel 'ms (log scale)'
set logscale y
set yrange [0.01:20000]
set style fill solid 0.7
set boxwidth 0.26
set key top left
set xtics rotate by -30 noenhanced
x(r) = r + floor(r / 3)
plot table using (x($0)-0.28):9:xtic(sprintf("%s %s", strcol(1), strcol(2) eq 'mesh' ? 'pf_mesh_cut' : strcol(2))) every ::1 with boxes title 'whole cut', \
     '' using (x($0)):($11 > 0 ? $11 : 1/0) every ::1 with boxes title 'method on the new mesh', \
     '' using (x($0)+0.28):($12 > 0 ? $12 : 1/0) every ::1 with boxes title 'rest of the set-up', \
     '' using (x($0)):(strcol(2) eq 'cg' ? $17 : 1/0) every ::1 with points pt 7 ps 1.5 lc rgb 'black' title 'paper t_{init} (harmonic CG, 2010 CPU)'

# columns: 1 frame, 2 elems, 3 nodes, 4 split, 5 cut_ms, 6 step_ms, 7 bodies
unset logscale
unset yrange
set style data linespoints
set title 'progressive cut through 5k tets, DG degree 1'
set xlabel 'frame'
set ylabel 'CPU ms'
set y2label 'elements'
set ytics nomirror
set y2tics
set xtics norotate enhanced
set key top left
plot progressive using 1:5 title 'cut', progressive using 1:6 title 'step', \
     progressive using 1:2 axes x1y2 title 'elements'
