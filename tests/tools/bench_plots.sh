# Every benchmark plot (bench/NAME.gp, drawn by scripts/bench) is committed as
# bench/results/NAME.png beside the CSVs it reads, and those CSVs exist.
. "$(dirname "$0")/lib.sh"
root=$(cd "$data/../.." && pwd)
n=0
for gp in "$root"/bench/*.gp; do
  name=$(basename "$gp" .gp)
  n=$((n + 1))
  check "bench/results/$name.png is committed" test -s "$root/bench/results/$name.png"
  for csv in $(grep -o "bench/results/[A-Za-z0-9_]*\.csv" "$gp" | sort -u); do
    check "$name.gp reads $csv, which exists" test -s "$root/$csv"
  done
done
check "the plots were found ($n)" test "$n" -ge 10
finish
