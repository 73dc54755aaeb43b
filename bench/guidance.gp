# Method guidance: the cantilever's |tip error| against CPU seconds (set-up + static solve), one
# line per method over 2, 4, 8 elements through the height; nu = 0.3 (left) and 0.499 (right).
# gnuplot bench/guidance.gp   (writes guidance.png)
# optional: -e "csv='...csv'; out='other.png'"
if (!exists("csv")) csv = 'bench/results/guidance.csv'
if (!exists("out")) out = 'guidance.png'
set terminal pngcairo size 1300,520
set output out
set datafile separator ','
set datafile commentschars '#'
set multiplot layout 1,2
set logscale xy
set grid
set key bottom left
set xlabel 'CPU seconds (set-up + static solve)'
set ylabel '|relative tip error|'
# columns: 1 case, 2 nu, 3 method, 4 flux, 5 degree, 11 error, 13 cpu_s
is(m, f, d) = strcol(3) eq m && strcol(4) eq f && $5 == d && strcol(1) ne 'cube'
do for [nu in "0.3 0.499"] {
    set title sprintf('cantilever 4 x 1 x 1, nu = %s', nu)
    plot csv skip 2 using (strcol(2) eq nu && is('cg', '-', 1) ? $13 : 1/0):(abs($11)) \
              with linespoints title 'cg', \
         csv skip 2 using (strcol(2) eq nu && is('dg', 'ip', 1) ? $13 : 1/0):(abs($11)) \
              with linespoints title 'dg IP 1', \
         csv skip 2 using (strcol(2) eq nu && is('dg', 'ip', 2) ? $13 : 1/0):(abs($11)) \
              with linespoints title 'dg IP 2', \
         csv skip 2 using (strcol(2) eq nu && is('dg', 'bz', 1) ? $13 : 1/0):(abs($11)) \
              with linespoints title 'dg BZ 1', \
         csv skip 2 using (strcol(2) eq nu && is('dg', 'bz', 2) ? $13 : 1/0):(abs($11)) \
              with linespoints title 'dg BZ 2'
}
unset multiplot
