# pf-import: volume meshes and surfaces into a stream that pf-info reads back with the exact
# volume; bad inputs exit 1 with one line naming the file (and line); bad usage exits 2.
. "$(dirname "$0")/lib.sh"
set -o pipefail

# import_json ARGS...: pf-import ARGS | pf-info --json into $tmp/json (stderr of pf-import in
# $tmp/import.err). Nothing but the stream may reach stdout, or pf-info refuses the input.
import_json() {
  "$bin/pf-import" "$@" 2>"$tmp/import.err" </dev/null | "$bin/pf-info" --json >"$tmp/json"
}

# field CHUNK NAME: the value of "NAME" in the JSON line of CHUNK.
field() {
  grep "^{\"chunk\":\"$1\"" "$tmp/json" | sed -n "s/.*\"$2\":\([^,}]*\).*/\1/p"
}

# near GOT WANT: |GOT - WANT| <= 1e-15 WANT (a few ulps: the cube's element volumes are exact
# sixths, summed).
near() {
  awk -v g="$1" -v w="$2" 'BEGIN { d = g - w; if (d < 0) d = -d; exit !(g != "" && d <= 1e-15 * w) }'
}

# check_volume FILE CHUNK VOLUME [pf-import options]
check_volume() {
  local file=$1 chunk=$2 volume=$3
  shift 3
  checks=$((checks + 1))
  if ! import_json "$@" "$data/$file"; then
    echo "FAIL: pf-import $* $file | pf-info --json failed: $(head -c 300 "$tmp/import.err")"
    failures=$((failures + 1))
    return
  fi
  local got
  got=$(field "$chunk" volume)
  if ! near "$got" "$volume"; then
    echo "FAIL: $file: $chunk volume '$got', expected $volume"
    failures=$((failures + 1))
  fi
}

check_volume cube.msh MESH 1
check "cube.msh: 5 tets, valid" grep -q '"elements":5,"tets":5,.*"valid":true' "$tmp/json"
check_volume cube41.msh MESH 1
check "cube41.msh: 6 tets, valid" grep -q '"elements":6,"tets":6,.*"valid":true' "$tmp/json"
check_volume hexes.msh MESH 2
check "hexes.msh: 2 hexes, valid" grep -q '"elements":2,"tets":0,"hexes":2,.*"valid":true' "$tmp/json"
check_volume cube.node MESH 1
check "cube.node: 6 tets, valid" grep -q '"elements":6,"tets":6,.*"valid":true' "$tmp/json"
check_volume cube.ele MESH 1
check_volume cube MESH 1 --volume
check_volume cube MESH 1 # the TetGen stem alone, as --help says
check "the report names the file and the volume" grep -q "cube: 8 nodes, 18 faces, 6 elements" \
  "$tmp/import.err"

# Surfaces: a SURF chunk, closed and manifold, even with vertices split by normal.
for f in cube.obj cube_split.obj cube.stl; do
  check_volume "$f" SURF 1
  check "$f gives a SURF" grep -q '"chunk":"SURF"' "$tmp/json"
  check "$f is closed and manifold" grep -q '"closed":true,"manifold":true' "$tmp/json"
  check "$f has no MESH" test -z "$(field MESH volume)"
done
check "--quiet silences the report" sh -c "'$bin/pf-import' --quiet '$data/cube.obj' 2>&1 >/dev/null | wc -c | grep -qx 0"

# Bad inputs: exit 1, one line naming the file and, for text formats, the line.
bad() {
  local needle=$1
  shift
  expect 1 "$needle" "$bin/pf-import" "$@"
  checks=$((checks + 1))
  if [ "$(wc -l <"$tmp/err")" != 1 ] || [ -s "$tmp/out" ]; then
    echo "FAIL: pf-import $*: expected one line on stderr and nothing on stdout"
    failures=$((failures + 1))
  fi
}
bad "bad_node_range.msh:23: element 7 refers to node 99, which the file does not define" \
  "$data/bad_node_range.msh"
bad "bad_nan.msh:9:" "$data/bad_nan.msh"
bad "bad_truncated.msh:22:" "$data/bad_truncated.msh"
bad "bad_count.msh:5:" "$data/bad_count.msh"
bad "bad_no_endnodes.msh:18: missing \$EndNodes" "$data/bad_no_endnodes.msh"
bad "empty.msh:1: empty file" "$data/empty.msh"
bad "binary.msh:2: binary .msh is not supported; re-save as ASCII" "$data/binary.msh"
bad "bad_version.msh:2:" "$data/bad_version.msh"
bad "bad_range.ele:4:" "$data/bad_range.node"
bad "bad_nofaces.obj" "$data/bad_nofaces.obj"
bad "no-such-file.msh" "$data/no-such-file.msh"
bad "no-such-file.obj" "$data/no-such-file.obj"
bad "cube.obj: not a volume mesh" --volume "$data/cube.obj"

# Precision: OBJ is read in double (no note), a DirectX .x file through assimp in single
# precision, which the report and pf-info say.
expect 0 "" "$bin/pf-import" "$data/cube.obj"
check "an OBJ import has no single-precision note" bash -c "! grep -q 'single precision' '$tmp/err'"
expect 0 "read by assimp: coordinates rounded to single precision" "$bin/pf-import" "$data/tet.x"
"$bin/pf-import" --quiet "$data/tet.x" | "$bin/pf-info" >"$tmp/info.txt"
check "pf-info says the surface is single precision" \
  grep -q "every coordinate is a float32 value: single precision" "$tmp/info.txt"

# Any scale: the issue's sphere scaled by 1e-12 (refused before as "no triangles") imports and
# slices, and so does one scaled by 1e12.
for scale in 1e-12 1e12; do
  awk -v s="$scale" 'BEGIN { pi = 3.14159265358979; n = 8; m = 16; printf "v 0 0 %.17g\n", s
    for (i = 1; i < n; i++) for (j = 0; j < m; j++) {
      t = pi * i / n; p = 2 * pi * j / m
      printf "v %.17g %.17g %.17g\n", s * sin(t) * cos(p), s * sin(t) * sin(p), s * cos(t) }
    printf "v 0 0 %.17g\n", -s
    for (j = 0; j < m; j++) print "f 1", 2 + j, 2 + (j + 1) % m
    for (i = 0; i < n - 2; i++) for (j = 0; j < m; j++) {
      a = 2 + i * m + j; b = 2 + i * m + (j + 1) % m; print "f", a, a + m, b + m; print "f", a, b + m, b }
    z = 2 + (n - 1) * m
    for (j = 0; j < m; j++) print "f", z, 2 + (n - 2) * m + (j + 1) % m, 2 + (n - 2) * m + j }' \
    >"$tmp/sphere-$scale.obj"
  expect 0 "114 vertices, 224 triangles, closed, manifold" "$bin/pf-import" "$tmp/sphere-$scale.obj"
  expect 0 "elements" "$bin/pf-slice" --res 6 "$tmp/sphere-$scale.obj"
done

# Bad usage: exit 2.
expect 2 "no input file" "$bin/pf-import"
expect 2 "one input file only" "$bin/pf-import" "$data/cube.msh" "$data/cube.obj"
finish
