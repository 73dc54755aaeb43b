# Progress on stderr: plain lines with --progress[=S] (here every report: S = 0) giving the share
# done, wall and CPU seconds and the ETA; nothing with -q / --quiet; summaries with CPU seconds.
. "$(dirname "$0")/lib.sh"
"$bin/pf-shape" torus --segments 24 >"$tmp/torus.pfs"
line='[0-9]+%, [0-9.e+-]+ s \(CPU [0-9.e+-]+ s\)'

expect 0 "" "$bin/pf-slice" --res 16 --progress=0 "$tmp/torus.pfs"
check "pf-slice: progress lines" grep -Eq "^pf-slice: $line, ETA [0-9]+ s$" "$tmp/err"
check "pf-slice: the last one at 100 %" grep -Eq "^pf-slice: 100%, " "$tmp/err"
check "pf-slice: the summary gives CPU seconds" grep -Eq "splits, [0-9.]+ s \(CPU [0-9.]+ s\)$" "$tmp/err"
expect 0 "" "$bin/pf-slice" --res 16 -q "$tmp/torus.pfs"
check "pf-slice -q: nothing on stderr" test ! -s "$tmp/err"
expect 0 "" "$bin/pf-slice" --res 16 "$tmp/torus.pfs"
check "pf-slice in a log, a short run: the summary only" test "$(wc -l <"$tmp/err")" = 1

expect 0 "" "$bin/pf-octree" --depth 4 --slice --progress=0 "$tmp/torus.pfs"
check "pf-octree: progress lines" grep -Eq "^pf-octree: $line" "$tmp/err"
check "pf-octree: 100 % at the end" grep -Eq "^pf-octree: 100%, " "$tmp/err"
check "pf-octree: the summary gives CPU seconds" grep -Eq ", [0-9.]+ s \(CPU [0-9.]+ s\)$" "$tmp/err"
expect 0 "" "$bin/pf-octree" --depth 4 --quiet "$tmp/torus.pfs"
check "pf-octree --quiet: nothing on stderr" test ! -s "$tmp/err"

"$bin/pf-shape" box --cells 2,1,1 | "$bin/pf-sim" --frames 4 -q >"$tmp/sim.pfs"
expect 0 "" "$bin/pf-render" --size 64x48 --out "$tmp/a" --progress=0 "$tmp/sim.pfs"
check "pf-render of a file: frame, share and ETA" \
  grep -Eq "^pf-render: frame 2, 3 written, 60%, [0-9.e+-]+ s \(CPU [0-9.e+-]+ s\), ETA [0-9]+ s$" "$tmp/err"
expect 0 "" bash -c "cat '$tmp/sim.pfs' | '$bin/pf-render' --size 64x48 --out '$tmp/b' --progress=0"
check "pf-render of a pipe: no share, no ETA" \
  grep -Eq "^pf-render: frame 4, 5 written, [0-9.e+-]+ s \(CPU [0-9.e+-]+ s\)$" "$tmp/err"
expect 0 "" "$bin/pf-render" --size 64x48 --out "$tmp/c" -q "$tmp/sim.pfs"
# (OSMesa's leaks that LeakSanitizer reports as suppressed in sanitizer builds are not ours)
check "pf-render -q: nothing of pf-render's on stderr" bash -c "! grep -q pf-render '$tmp/err'"
expect 2 "--progress expects seconds >= 0" "$bin/pf-slice" --progress=-1 "$tmp/torus.pfs"

# pf-sim: a line per frame with --progress=0, frame, share and ETA; nothing with -q (which is
# pf-sim's own, not a PETSc option that would take the scene file after it as its value)
"$bin/pf-shape" box --cells 2,1,1 >"$tmp/box.pfs"
expect 0 "" "$bin/pf-sim" --frames 4 --progress=0 --input "$tmp/box.pfs"
check "pf-sim: frame, share, times and ETA" \
  grep -Eq "^pf-sim: frame 2 of 4, 50%, [0-9.e+-]+ s \(CPU [0-9.e+-]+ s\), ETA [0-9]+ s$" "$tmp/err"
check "pf-sim: the last at 100 %" grep -Eq "^pf-sim: frame 4 of 4, 100%, " "$tmp/err"
check "pf-sim: the summary gives CPU beside wall seconds for set-up and assembly" \
  grep -Eq "setup [0-9.]+ s wall / [0-9.]+ s cpu, assembly [0-9.]+ s wall / [0-9.]+ s cpu" "$tmp/err"
# the set-up's phases in a log: a line at each start and end, with the phase's own times
times='[0-9.e+-]+ s \(CPU [0-9.e+-]+ s\)'
for phase in "element integrals" "face integrals" "symbolic analysis" "numeric factorisation"; do
  check "pf-sim dg: '$phase' started" \
    grep -Eq "^pf-sim: $phase started( \([0-9]+\))?$" "$tmp/err"
  check "pf-sim dg: '$phase' done" grep -Eq "^pf-sim: $phase done, $times$" "$tmp/err"
done
check "pf-sim dg: the set-up's lines before the first frame's" \
  bash -c "grep -m1 -E 'face integrals done|frame 1 of 4' '$tmp/err' | grep -q 'face integrals'"
expect 0 "" "$bin/pf-sim" --method cg --frames 1 --input "$tmp/box.pfs"
for phase in "basis functions" "element matrices" "symbolic analysis"; do
  check "pf-sim cg in a log (no --progress): '$phase' done" \
    grep -Eq "^pf-sim: $phase done, $times$" "$tmp/err"
done
printf '{"time": {"frames": 2}}' >"$tmp/two.json"
expect 0 "" "$bin/pf-sim" -q "$tmp/two.json" --input "$tmp/box.pfs"
check "pf-sim -q: nothing on stderr" test ! -s "$tmp/err"
check "pf-sim -q SCENE: the scene is read (frames 0, 1, 2)" \
  bash -c "'$bin/pf-sim' -q '$tmp/two.json' <'$tmp/box.pfs' | '$bin/pf-info' | grep -q '^FRAM .*: 3 frames'"
expect 2 "--progress expects seconds >= 0" "$bin/pf-sim" --progress=-2 --input "$tmp/box.pfs"
finish
