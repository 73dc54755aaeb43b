# The solver policy: (a) CPU per corotated step against one factorisation of the same matrix,
# direct and pcg, on the SOFA beams (bench_solver beam); (b) PCG iterations per step against the
# rotation speed of a free body (bench_solver spin).
# gnuplot bench/solver.gp   (writes solver.png; bench/results/solver.png: -e "out='bench/results/solver.png'")
# optional: -e "beam='...csv'; spin='...csv'; out='other.png'"
if (!exists("beam")) beam = 'bench/results/solver_beam.csv'
if (!exists("spin")) spin = 'bench/results/solver_spin.csv'
if (!exists("out")) out = 'solver.png'
set terminal pngcairo size 1300,520
set output out
set datafile separator ','
set datafile commentschars '#'
set multiplot layout 1,2
set grid
set key top left

# columns: 1 case, 2 method, 3 solver, 10 step_per_factor
set title 'CPU per step / CPU per factorisation (target <= 0.3)'
set ylabel 'step / factorisation'
set style data histograms
set style fill solid 0.6
set yrange [0:*]
set xtics rotate by -30 left   # "39x7x7 dg pcg": the labels overlap when level
set bmargin 6
plot beam using 10:xtic(sprintf("%s %s %s", stringcolumn(1), stringcolumn(2), stringcolumn(3))) \
     every ::1 notitle

# columns: 1 omega, 2 factorisations per 100 steps, 3 pcg mean, 4 pcg max
set xtics norotate font ''
set title 'free body spinning: PCG iterations per step'
set xlabel 'rad/s'
set ylabel 'iterations'
set style data linespoints
set xtics norotate
set logscale x
plot spin using 1:3 title 'mean', spin using 1:4 title 'largest', \
     spin using 1:($2 / 10) title 'factorisations per 1000 steps / 100'
unset multiplot
