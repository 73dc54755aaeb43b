# pf-basis: per-element report and summary, closed forms skipped, exactness, bad input.
. "$(dirname "$0")/lib.sh"

# A hex box: every element a closed-form hex, no MFS, exact to round-off.
"$bin/pf-shape" box --cells 2,1,1 >"$tmp/box.pfs" || { echo "FAIL: pf-shape box"; exit 1; }
expect 0 "" "$bin/pf-basis" "$tmp/box.pfs"
"$bin/pf-basis" --quiet "$tmp/box.pfs" >"$tmp/box.txt"
check "closed forms are reported as such" grep -q "closed form, no MFS" "$tmp/box.txt"
check "text summary" grep -q "^summary: 2 elements: 0 tets and 2 hexes" "$tmp/box.txt"

# A sliced sphere: harmonic cells; JSON lines, the summary last with the required keys, and
# partition of unity / linear reproduction exact to 1e-12.
"$bin/pf-shape" sphere --segments 8 >"$tmp/sphere.pfs" || { echo "FAIL: pf-shape sphere"; exit 1; }
"$bin/pf-slice" --res 3 --quiet "$tmp/sphere.pfs" >"$tmp/sliced.pfs" || { echo "FAIL: pf-slice"; exit 1; }
"$bin/pf-basis" --json --quiet - <"$tmp/sliced.pfs" >"$tmp/basis.json"
check "one object per element" bash -c "[ \$(grep -c '\"element\":' '$tmp/basis.json') -ge 20 ]"
check "harmonic elements" grep -q '"kind":"harmonic"' "$tmp/basis.json"
last=$(tail -n 1 "$tmp/basis.json")
for key in max_linear_reproduction_error max_partition_of_unity_error median_boundary_error \
           max_boundary_error median_setup_ms; do
  check "summary has $key" bash -c "echo '$last' | grep -q '\"$key\":'"
done
lin=$(echo "$last" | grep -o '"max_linear_reproduction_error":[^,]*' | cut -d: -f2)
pou=$(echo "$last" | grep -o '"max_partition_of_unity_error":[^,]*' | cut -d: -f2)
check "linear reproduction $lin below 1e-12" awk -v a="$lin" 'BEGIN { exit !(a < 1e-12) }'
check "partition of unity $pou below 1e-12" awk -v a="$pou" 'BEGIN { exit !(a < 1e-12) }'

# --force-mfs on the box: harmonic everywhere.
"$bin/pf-basis" --json --force-mfs --quiet "$tmp/box.pfs" | tail -n 1 >"$tmp/forced.json"
check "forced MFS" grep -q '"harmonic":2,' "$tmp/forced.json"

# Bad input and usage.
expect 1 "no MESH" "$bin/pf-basis" "$tmp/sphere.pfs"
expect 1 "" "$bin/pf-basis" "$data/cube.obj"
expect 2 "" "$bin/pf-basis" --xi 0 "$tmp/box.pfs"
expect 2 "" "$bin/pf-basis" --edge-samples 0 "$tmp/box.pfs"
expect 2 "" "$bin/pf-basis" --bogus
finish
