# A run that refines as it bends (data/scenes/cantilever_refine.json, the bending bar: a beam clamped
# at both ends under gravity): pf-sim writes a MESH before the first frame on each new mesh, every
# frame names the mesh it was computed on, and pf-info, pf-export and pf-render read the stream
# (pf-render's --frames ranges give the whole run's bytes); the stream is the same twice and with
# one and two threads. Embedded: a surface's weights are rewritten for each new mesh.
. "$(dirname "$0")/lib.sh"
root=$(cd "$data/../.." && pwd)
scene=$root/data/scenes/cantilever_refine.json
"$bin/pf-shape" box --extent 4,1,1 --cells 8,2,2 >"$tmp/beam.pfs"
expect 0 "mesh changes:" "$bin/pf-sim" "$scene" --frames 12 --input "$tmp/beam.pfs"
cp "$tmp/out" "$tmp/run.pfs"
"$bin/pf-info" "$tmp/run.pfs" >"$tmp/info.txt" 2>&1
meshes=$(sed -n 's/^meshes: //p' "$tmp/info.txt")
check "the bar was refined: more than one mesh ($meshes)" test "${meshes:-0}" -gt 1
check "pf-info accepts the stream" "$bin/pf-info" "$tmp/run.pfs"
check "frames 0 .. 12 present" grep -q ' 13 frames$' "$tmp/info.txt"

# the same run again (the INFO chunk holds the command line: the same one), and on one thread: the
# same bytes. Left to itself pf runs CHOLMOD's BLAS on one thread whatever the cores
# (libcore/solve/threads.c), so the machine's core count changes nothing; a thread count the user
# sets in the environment is OpenBLAS's to use, at the price of the last bits (documented there).
"$bin/pf-sim" "$scene" --frames 12 --quiet --input "$tmp/beam.pfs" >"$tmp/run0.pfs"
"$bin/pf-sim" "$scene" --frames 12 --quiet --input "$tmp/beam.pfs" >"$tmp/run1.pfs"
OMP_NUM_THREADS=1 "$bin/pf-sim" "$scene" --frames 12 --quiet --input "$tmp/beam.pfs" >"$tmp/run2.pfs"
check "deterministic: run twice" cmp -s "$tmp/run0.pfs" "$tmp/run1.pfs"
check "deterministic: the machine's cores or one thread" cmp -s "$tmp/run1.pfs" "$tmp/run2.pfs"

# exports follow the mesh: the last VTU has more cells than the first
expect 0 "" "$bin/pf-export" --ascii --quiet --vtu "$tmp/vtu" "$tmp/run.pfs"
cells() { sed -n 's/.*NumberOfCells="\([0-9]*\)".*/\1/p' "$1" | head -1; }
first=$(cells "$tmp/vtu/mesh_00000.vtu")
last=$(cells "$tmp/vtu/mesh_00012.vtu")
check "VTU: 32 cells at frame 0, more at frame 12 ($first, $last)" test "$first" = 32 -a "${last:-0}" -gt 32

# pf-render: the stress mode over the whole run, and a range reproducing its bytes
expect 0 "" "$bin/pf-render" --quiet --size 96x72 --mode stress --out "$tmp/png" "$tmp/run.pfs"
expect 0 "" "$bin/pf-render" --quiet --size 96x72 --mode stress --frames 10:12 --out "$tmp/png-range" "$tmp/run.pfs"
for png in "$tmp/png-range"/*.png; do
  check "render --frames 10:12: $(basename "$png") as in the whole run" cmp -s "$png" "$tmp/png/$(basename "$png")"
done

# the scene's whole run on its bar of 36 hexes (9 x 2 x 2): the sphere presses it (44 elements)
# and goes back; once the bar has calmed down every split is merged and it ends on its 36 hexes
"$bin/pf-shape" box --extent 4,1,1 --cells 9,2,2 >"$tmp/bar36.pfs"
expect 0 "" "$bin/pf-sim" "$scene" --quiet --input "$tmp/bar36.pfs"
"$bin/pf-info" "$tmp/out" >"$tmp/info36.txt" 2>&1
counts=$(sed -n 's/^ *mesh [0-9]* (MESH at byte [0-9]*): [0-9]* nodes, \([0-9]*\) elements.*/\1/p' \
  "$tmp/info36.txt" | tr '\n' ' ')
most=$(echo "$counts" | tr ' ' '\n' | sort -n | tail -1)
final=$(echo "$counts" | awk '{print $NF}')
check "the pressed bar: 36 -> 44 elements ($counts)" test "${most:-0}" = 44
check "the released bar ends on its 36 hexes ($counts)" test "${final:-0}" = 36
check "its last frame is frame 50" grep -q ' 51 frames$' "$tmp/info36.txt"

# an embedded surface: new weights follow each new mesh (pf-info checks each WGHT against its MESH)
"$bin/pf-shape" sphere --segments 12 | "$bin/pf-voxelize" --res 4 --quiet | "$bin/pf-embed" --quiet >"$tmp/ball.pfs"
printf '{"refine": {"threshold": 1000, "max_level": 1, "max_elements": 120}, "time": {"frames": 10}}' >"$tmp/drop.json"
expect 0 "mesh changes:" "$bin/pf-sim" "$tmp/drop.json" --input "$tmp/ball.pfs"
cp "$tmp/out" "$tmp/drop.pfs"
check "embedded: pf-info accepts every mesh's weights" "$bin/pf-info" "$tmp/drop.pfs"
"$bin/pf-info" "$tmp/drop.pfs" >"$tmp/dinfo.txt" 2>&1
check "embedded: more than one mesh" test "$(sed -n 's/^meshes: //p' "$tmp/dinfo.txt")" -gt 1
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/dobj" "$tmp/drop.pfs"
check "embedded: the surface exported at every frame" test "$(ls "$tmp/dobj" | wc -l)" = 11
finish
