# Every option a tool's --help lists is exercised by a tool test: a walker reads each --help and
# the tests/tools scripts (a flag counts for a tool when it stands on a command line of that
# tool, or of a wrapper called after it; pf-sim's scene overrides are walked from
# docs/scene.md's table by scenes.sh). Below, the options no other test ran, each with a check
# that fails when the option is ignored.
. "$(dirname "$0")/lib.sh"
root=$(cd "$data/../.." && pwd)

python3 - "$bin" "$root" >"$tmp/missing.txt" <<'PY'
import glob, re, subprocess, sys
bindir, root = sys.argv[1], sys.argv[2]
flag = re.compile(r'(?<![\w-])(--[a-z][a-z0-9-]*)')
used = {}
for path in sorted(glob.glob(root + '/tests/tools/*.sh')) + [root + '/tests/install.sh']:
    last = set()
    for line in open(path).read().replace('\\\n', ' ').splitlines():
        tools = set(re.findall(r'\bpf-([a-z]+)\b', line)) or last
        last = tools
        for t in tools:
            used.setdefault('pf-' + t, set()).update(flag.findall(line))
doc = open(root + '/docs/scene.md').read()
table = doc.split('## Command-line overrides')[1].split('\n## ')[0]
overrides = {'--' + k.replace('_', '-') for k in re.findall(r'^\| `([A-Za-z_]+)` \|', table, re.M)}
for tool in sorted(glob.glob(bindir + '/pf-*')):
    name = tool.rsplit('/', 1)[1]
    text = subprocess.run([tool, '--help'], capture_output=True, text=True).stdout
    # flags on a help line that names another tool are that tool's ("as pf-embed's --method")
    own = [l for l in text.splitlines() if not set(re.findall(r'\bpf-[a-z]+\b', l)) - {name}]
    for f in sorted(set(flag.findall('\n'.join(own)))):
        if f in ('--help', '--version'):  # cli.sh runs every tool with both
            continue
        if f not in used.get(name, set()) and not (name == 'pf-sim' and f in overrides):
            print(name, f)
PY
check "every option of every tool's --help is run by a test (missing: $(tr '\n' ' ' <"$tmp/missing.txt"))" \
  test ! -s "$tmp/missing.txt"
check "the walker saw the tools" test "$(ls "$bin"/pf-* | wc -l)" -ge 12

# A tetrahedron, outward and inside out, and one with a face missing (open).
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n' >"$tmp/tet.obj"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 4 3\n' >"$tmp/inv.obj"
head -7 "$tmp/tet.obj" >"$tmp/open.obj"
volume() { "$bin/pf-info" | sed -n 's/.*enclosed volume \([-0-9.e]*\),.*/\1/p' | head -1; }
mesh_volume() { "$bin/pf-info" | sed -n 's/^      volume \([-0-9.e]*\) .*/\1/p' | head -1; }
bounds() { "$bin/pf-info" | grep -A3 '^MESH' | sed -n 's/^      bounds \(.*\)/\1/p' | head -1; }

# --keep-orientation: the surface keeps the file's orientation (inside out: a negative enclosed
# volume), where every tool otherwise turns it outward; pf-cut then refuses it as a knife
check "pf-import turns an inside-out surface outward" test "$("$bin/pf-import" "$tmp/inv.obj" --quiet | volume)" = 0.16666666666666669
check "pf-import --keep-orientation keeps it" test "$("$bin/pf-import" "$tmp/inv.obj" --keep-orientation --quiet | volume)" = -0.16666666666666669
check "pf-slice --keep-orientation passes the SURF on as the file has it" \
  test "$("$bin/pf-slice" "$tmp/inv.obj" --res 6 --keep-orientation --quiet | volume)" = -0.16666666666666669
check "pf-voxelize --keep-orientation too" \
  test "$("$bin/pf-voxelize" "$tmp/inv.obj" --res 6 --keep-orientation --quiet | volume)" = -0.16666666666666669
check "pf-octree --keep-orientation too" \
  test "$("$bin/pf-octree" "$tmp/inv.obj" --depth 3 --keep-orientation --quiet | volume)" = -0.16666666666666669
check "pf-slice turns it outward without" \
  test "$("$bin/pf-slice" "$tmp/inv.obj" --res 6 --quiet | volume)" = 0.16666666666666669
"$bin/pf-shape" box --extent 1,1,1 --origin -0.25,-0.25,-0.25 --cells 4,4,4 >"$tmp/cube.pfs"
expect 0 "" "$bin/pf-cut" "$tmp/cube.pfs" --surface "$tmp/inv.obj" --quiet
expect 1 "outward-oriented surface" "$bin/pf-cut" "$tmp/cube.pfs" --surface "$tmp/inv.obj" --keep-orientation
# --merge: a larger sliver fraction merges more of the small pieces the knife leaves
n0=$("$bin/pf-cut" "$tmp/cube.pfs" --surface "$tmp/tet.obj" --merge 0.01 --quiet | "$bin/pf-info" | grep '^MESH')
n5=$("$bin/pf-cut" "$tmp/cube.pfs" --surface "$tmp/tet.obj" --merge 0.3 --quiet | "$bin/pf-info" | grep '^MESH')
check "pf-cut --merge 0.01 and 0.3 give different meshes ('$n0', '$n5')" \
  bash -c "[ -n '$n0' ] && [ -n '$n5' ] && [ '$n0' != '$n5' ]"
expect 2 "--merge" "$bin/pf-cut" "$tmp/cube.pfs" --surface "$tmp/tet.obj" --merge 1

# --up and --scale on a knife, a surface and a grid
check "pf-cut --scale 0.5: the knife, 1/48, lies inside the block" \
  test "$("$bin/pf-cut" "$tmp/cube.pfs" --surface "$tmp/tet.obj" --scale 0.5 --quiet | mesh_volume)" = 0.020833333333333332
check "pf-cut --up -z turns the knife: less of it in the block" \
  test "$("$bin/pf-cut" "$tmp/cube.pfs" --surface "$tmp/tet.obj" --up -z --quiet | mesh_volume)" = 0.044270833333333329
check "pf-import --scale 2: 8 times the volume" test "$("$bin/pf-import" "$tmp/tet.obj" --scale 2 --quiet | volume)" = 1.3333333333333335
check "pf-import --up y: y turned onto z" \
  bash -c "'$bin/pf-import' '$tmp/tet.obj' --up y --quiet | '$bin/pf-info' --print-mesh | grep -q 'enclosed volume 0.1666'"
check "pf-voxelize --cell 0.25 --origin 0,0,0: cells on that grid" \
  test "$("$bin/pf-voxelize" "$tmp/tet.obj" --cell 0.25 --origin 0,0,0 --quiet | bounds)" = "(0, 0, 0) .. (0.75, 0.75, 0.75)"
check "pf-voxelize --scale 2" \
  test "$("$bin/pf-voxelize" "$tmp/tet.obj" --cell 0.25 --origin 0,0,0 --scale 2 --quiet | bounds)" = "(0, 0, 0) .. (1.75, 1.75, 1.75)"
check "pf-voxelize --up y" \
  test "$("$bin/pf-voxelize" "$tmp/tet.obj" --cell 0.25 --origin 0,0,0 --up y --quiet | bounds)" = "(0, -0.75, 0) .. (0.75, 0, 0.75)"
check "pf-octree --scale 2 --up y" \
  test "$("$bin/pf-octree" "$tmp/tet.obj" --depth 2 --scale 2 --up y --quiet | bounds)" = "(0, -1.5, 0) .. (1.5, 0, 1.5)"
# --surface: a surface whatever the extension says
cp "$tmp/tet.obj" "$tmp/tet.msh"
expect 1 "not a Gmsh .msh file" "$bin/pf-import" "$tmp/tet.msh"
check "pf-import --surface reads it as a surface" test "$("$bin/pf-import" "$tmp/tet.msh" --surface --quiet | volume)" = 0.16666666666666669
# pf-octree --refine: the lattice of the winding-number boundary of an open surface
a=$("$bin/pf-octree" "$tmp/open.obj" --depth 3 --slice --refine 4 --quiet | "$bin/pf-info" | grep '^MESH')
b=$("$bin/pf-octree" "$tmp/open.obj" --depth 3 --slice --refine 5 --quiet | "$bin/pf-info" | grep '^MESH')
check "pf-octree --refine 4 and 5 give different boundaries (got '$a' and '$b')" \
  bash -c "[ -n '$a' ] && [ -n '$b' ] && [ '$a' != '$b' ]"
expect 2 "--refine" "$bin/pf-octree" --refine 9 "$tmp/tet.obj"

# pf-basis: the sliced-cell settings (the default) lower the median boundary error of sliced
# cells below the uniform functions' (--sliced off), whichever of their options is varied, and
# --accurate is --sliced all --xi 0.2 --max-kernels 0
"$bin/pf-shape" sphere --segments 6 | "$bin/pf-slice" --res 2 --quiet >"$tmp/cells.pfs"
median() { "$bin/pf-basis" "$@" "$tmp/cells.pfs" | sed -n 's/.*boundary error median \([0-9.e-]*\) .*/\1/p'; }
base=$(median --sliced off)
for o in "" "--accurate" "--sliced all" "--sliced auto --grading 0.3" "--patch-angle 45" "--max-kernels 100"; do
  m=$(median $o)
  check "pf-basis $o: median boundary error $m below the uniform functions' $base" \
    awk -v a="$m" -v b="$base" 'BEGIN { exit !(a > 0 && a < b) }'
done
"$bin/pf-basis" --json --accurate "$tmp/cells.pfs" | sed 's/"[a-z_]*setup_ms":[0-9.e+-]*//g' >"$tmp/acc.json"
"$bin/pf-basis" --json --sliced all --xi 0.2 --max-kernels 0 "$tmp/cells.pfs" |
  sed 's/"[a-z_]*setup_ms":[0-9.e+-]*//g' >"$tmp/explicit.json"
check "pf-basis --accurate = --sliced all --xi 0.2 --max-kernels 0" cmp "$tmp/acc.json" "$tmp/explicit.json"
check "pf-basis --json reported the 8 cells" test "$(wc -l <"$tmp/acc.json")" -ge 8
# --max-kernels: every cell within the budget here (its features alone need fewer)
kmax=$("$bin/pf-basis" --json --max-kernels 60 "$tmp/cells.pfs" | grep '"element"' | grep -o '"kernels":[0-9]*' | cut -d: -f2 | sort -n | tail -n 1)
check "pf-basis --max-kernels 60: at most 60 kernels per cell (got $kmax)" test "$kmax" -le 60
expect 2 "--sliced" "$bin/pf-basis" --sliced some "$tmp/cells.pfs"

# pf-shape --r: the tube radius (torus volume 2 pi^2 R r^2 within the polygon's 2 %)
check "pf-shape torus --R 1 --r 0.5: volume 4.93" \
  awk -v v="$("$bin/pf-shape" torus --R 1 --r 0.5 | volume)" 'BEGIN { e = v / 4.934802 - 1; exit !(e < 0.02 && e > -0.02) }'

# pf-render --fps: the rate handed to ffmpeg (a stand-in that records its arguments)
mkdir -p "$tmp/fakebin"
printf '#!/bin/sh\necho "$@" >"%s/ffmpeg.args"\nfor last; do :; done\ncat >"$last"\n' "$tmp" >"$tmp/fakebin/ffmpeg"
chmod +x "$tmp/fakebin/ffmpeg"
"$bin/pf-shape" box --cells 2,1,1 | "$bin/pf-sim" --frames 1 -q >"$tmp/sim.pfs"
expect 0 "" env PATH="$tmp/fakebin:$PATH" "$bin/pf-render" --quiet --size 64x48 --out "$tmp/r" \
  --mp4 "$tmp/v.raw" --fps 24 "$tmp/sim.pfs"
check "pf-render --fps 24 reaches ffmpeg" grep -q -- " 24 " "$tmp/ffmpeg.args"
expect 2 "fps" "$bin/pf-render" --fps 0 "$tmp/sim.pfs"
finish
