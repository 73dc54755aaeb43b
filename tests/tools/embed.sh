# pf-embed: WGHT through the pipe, every method, the outside warning, --surface, bad input.
. "$(dirname "$0")/lib.sh"

"$bin/pf-shape" sphere --segments 16 >"$tmp/sphere.pfs" || { echo "FAIL: pf-shape sphere"; exit 1; }
"$bin/pf-voxelize" --res 8 --quiet "$tmp/sphere.pfs" >"$tmp/vox.pfs" || { echo "FAIL: pf-voxelize"; exit 1; }

# The voxel mesh lies inside the sphere: the surface pokes out, which is a warning, not an error.
expect 0 "outside every element" "$bin/pf-embed" "$tmp/vox.pfs"
check "the summary names the method" grep -q "pf-embed: mls weights of" "$tmp/err"
"$bin/pf-embed" --quiet "$tmp/vox.pfs" 2>/dev/null | "$bin/pf-info" --json - >"$tmp/info.json"
check "pf-info shows a WGHT chunk" grep -q '"chunk":"WGHT"' "$tmp/info.json"
check "WGHT follows the MESH" bash -c "grep -A1 '\"chunk\":\"MESH\"' '$tmp/info.json' | tail -1 | grep -q '\"chunk\":\"WGHT\"'"
expect 0 "hexes" "$bin/pf-embed" --method bary "$tmp/vox.pfs"

# A sliced sphere holds its surface: no vertex outside, nothing on stderr with --quiet.
"$bin/pf-slice" --res 6 --quiet "$tmp/sphere.pfs" >"$tmp/slice.pfs" || { echo "FAIL: pf-slice"; exit 1; }
expect 0 "" "$bin/pf-embed" --method bary --quiet "$tmp/slice.pfs"
check "quiet and nothing outside: empty stderr" test ! -s "$tmp/err"
check "bary on the sliced sphere: polyhedra" bash -c "'$bin/pf-embed' --method bary '$tmp/slice.pfs' 2>&1 >/dev/null | grep -vq 'polyhedra 0'"
# harmonic: the CG shape functions of the polyhedra holding vertices, and a WGHT in the stream
expect 0 "harmonic functions of" "$bin/pf-embed" --method harmonic "$tmp/slice.pfs"
check "harmonic: one WGHT" test "$("$bin/pf-info" --json "$tmp/out" | grep -c '"chunk":"WGHT"')" = 1

# --surface replaces the stream's surface; a mesh without a surface needs it.
"$bin/pf-shape" box --extent 1,1,1 --cells 2,2,2 >"$tmp/box.pfs"
expect 1 "no SURF" "$bin/pf-embed" "$tmp/box.pfs"
expect 0 "8 vertices" "$bin/pf-embed" --surface "$data/cube.obj" "$tmp/box.pfs"
"$bin/pf-embed" --quiet --surface "$data/cube.obj" "$tmp/box.pfs" | "$bin/pf-info" --json - >"$tmp/box.json"
check "one SURF and one WGHT" test "$(grep -c '"chunk":"SURF"\|"chunk":"WGHT"' "$tmp/box.json")" = 2

# Bad input and usage.
expect 1 "no MESH" "$bin/pf-embed" "$tmp/sphere.pfs"
expect 1 "empty input" "$bin/pf-embed" /dev/null
expect 2 "mls, bary or harmonic" "$bin/pf-embed" --method mvc "$tmp/vox.pfs"
expect 2 "" "$bin/pf-embed" "$tmp/vox.pfs" "$tmp/vox.pfs"
finish
