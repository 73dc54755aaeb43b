# pf-export: VTU series + PVD, OBJ/PLY sequences, damaged streams, usage.
. "$(dirname "$0")/lib.sh"
gen="$bin/../tests/test_export"
[ -x "$gen" ] || { echo "FAIL: $gen (writes the test stream) is not built"; exit 1; }
"$bin/pf-shape" box --cells 2,1,1 >"$tmp/box.pfs" || { echo "FAIL: pf-shape box"; exit 1; }
"$gen" --write-frames "$tmp/frames.pfs" || { echo "FAIL: test_export --write-frames"; exit 1; }

# valid XML: xmllint where installed, else the structure by grep. A binary VTU's raw
# <AppendedData> section is bytes, not XML (VTK's own format): checked without it.
valid_xml() {
  sed '/^  <AppendedData encoding="raw">$/,/^  <\/AppendedData>$/d' "$1" >"$tmp/xml"
  if command -v xmllint >/dev/null 2>&1; then
    xmllint --noout "$tmp/xml"
  else
    grep -q '^<VTKFile ' "$tmp/xml" && grep -q '^</VTKFile>$' "$tmp/xml"
  fi
}

# a stream without frames: one file of the rest state, through a pipe, DIR created with parents
checks=$((checks + 1))
if ! "$bin/pf-shape" box --cells 2,1,1 | "$bin/pf-export" --quiet --ascii --vtu "$tmp/rest/a/b" 2>"$tmp/err"; then
  echo "FAIL: pf-shape box | pf-export --vtu: $(cat "$tmp/err")"; failures=$((failures + 1))
fi
check "rest: one VTU and the PVD" test "$(ls "$tmp/rest/a/b" | tr '\n' ' ')" = "mesh.pvd mesh_00000.vtu "
check "rest: valid VTU" valid_xml "$tmp/rest/a/b/mesh_00000.vtu"
check "rest: valid PVD" valid_xml "$tmp/rest/a/b/mesh.pvd"
check "rest: 12 points, 2 cells" grep -q 'NumberOfPoints="12" NumberOfCells="2"' "$tmp/rest/a/b/mesh_00000.vtu"
check "rest: two hexahedra" test "$(sed -n '/Name="types"/,/<\/DataArray>/p' "$tmp/rest/a/b/mesh_00000.vtu" | grep -c '^ *12$')" = 2
check "rest: no displacement" test -z "$(grep displacement "$tmp/rest/a/b/mesh_00000.vtu")"
check "quiet: nothing on stderr" test ! -s "$tmp/err"

# frames: one VTU per frame, the PVD with their times, stress where a STRS follows the frame
expect 0 "3 VTU files written" "$bin/pf-export" --vtu "$tmp/vtu" --ascii "$tmp/frames.pfs"
check "frames: three VTU and the PVD" \
  test "$(ls "$tmp/vtu" | tr '\n' ' ')" = "mesh.pvd mesh_00000.vtu mesh_00001.vtu mesh_00002.vtu "
for k in 0 1 2; do
  check "frame $k: valid VTU" valid_xml "$tmp/vtu/mesh_0000$k.vtu"
  check "frame $k: displacement" grep -q 'Name="displacement" NumberOfComponents="3"' "$tmp/vtu/mesh_0000$k.vtu"
done
check "frame 1 has its stress" grep -q 'Name="stress"' "$tmp/vtu/mesh_00001.vtu"
check "frame 1's stress values" test "$(sed -n '/Name="stress"/,/<\/DataArray>/p' "$tmp/vtu/mesh_00001.vtu" | sed -n '2,3p' | tr -d ' ' | tr '\n' ' ')" = "100 101 "
check "frame 2 has no STRS, no stress" test -z "$(grep 'Name="stress"' "$tmp/vtu/mesh_00002.vtu")"
check "PVD lists frame 2 at time 1" grep -q 'timestep="1" group="" part="0" file="mesh_00002.vtu"' "$tmp/vtu/mesh.pvd"
check "PVD lists three files" test "$(grep -c '<DataSet' "$tmp/vtu/mesh.pvd")" = 3
expect 0 "" "$bin/pf-export" --quiet --vtu "$tmp/sel" --frames 1:1 "$tmp/frames.pfs"

# binary (the default): compressed appended arrays, the same XML structure, smaller than ASCII
expect 0 "" "$bin/pf-export" --quiet --vtu "$tmp/bin" "$tmp/frames.pfs"
check "binary: valid XML around the appended data" valid_xml "$tmp/bin/mesh_00001.vtu"
check "binary: zlib compressor" grep -aq 'compressor="vtkZLibDataCompressor"' "$tmp/bin/mesh_00001.vtu"
check "binary: stress appended" grep -aq 'Name="stress" format="appended" offset=' "$tmp/bin/mesh_00001.vtu"
check "binary: no ASCII arrays" test -z "$(grep -a 'format="ascii"' "$tmp/bin/mesh_00001.vtu")"
# --tets: every cell a tetrahedron (VTK type 10), cell data "element"
expect 0 "" "$bin/pf-export" --quiet --vtu "$tmp/tets" --tets --ascii "$tmp/box.pfs"
check "tets: only VTK_TETRA" test "$(sed -n '/Name="types"/,/<\/DataArray>/p' "$tmp/tets/mesh_00000.vtu" | grep -v DataArray | sort -u | tr -d ' ')" = 10
check "tets: element ids" grep -q 'Name="element"' "$tmp/tets/mesh_00000.vtu"
# VTK's own reader, where a python3 with vtk is installed (Debian: python3-vtk9)
for py in python3 /usr/bin/python3; do
  if "$py" -c 'import vtk' >/dev/null 2>&1; then
    "$bin/pf-shape" torus --segments 16 | "$bin/pf-slice" --res 8 --quiet >"$tmp/torus.pfs"
    for o in "" --ascii --tets; do "$bin/pf-export" --quiet --vtu "$tmp/vtk$o" $o "$tmp/torus.pfs"; done
    check "VTK reads binary = ASCII, tets' volume = pf's" "$py" "$(dirname "$0")/vtk_read.py" \
      "$tmp/vtk/mesh_00000.vtu" "$tmp/vtk--ascii/mesh_00000.vtu" "$tmp/vtk--tets/mesh_00000.vtu"
    break
  fi
done
expect 2 "go with --vtu" "$bin/pf-export" --obj "$tmp/x" --tets "$tmp/box.pfs"
check "--frames 1:1 writes frame 1 only" test "$(ls "$tmp/sel" | tr '\n' ' ')" = "mesh.pvd mesh_00001.vtu "

# OBJ and PLY: the SURF moved by its WGHT (3 vertices), else the mesh boundary
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/obj" "$tmp/frames.pfs"
check "OBJ: three frames" test "$(ls "$tmp/obj" | tr '\n' ' ')" = "frame_00000.obj frame_00001.obj frame_00002.obj "
check "OBJ: the embedded triangle" test "$(grep -c '^v ' "$tmp/obj/frame_00002.obj")" = 3
check "OBJ frame 2: corner 2 (x = 2) sagged by 0.04" grep -q '^v 2 0 -0.040000000000000001$' "$tmp/obj/frame_00002.obj"
check "OBJ: one face, with normals" grep -q '^f 1//1 2//2 3//3$' "$tmp/obj/frame_00001.obj"
check "OBJ: three normals" test "$(grep -c '^vn ' "$tmp/obj/frame_00001.obj")" = 3
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/bobj" "$tmp/box.pfs"
check "OBJ of a mesh: its boundary, 12 nodes, 20 triangles" \
  test "$(grep -c '^v ' "$tmp/bobj/frame_00000.obj") $(grep -c '^f ' "$tmp/bobj/frame_00000.obj")" = "12 20"
expect 0 "" "$bin/pf-export" --quiet --ply "$tmp/ply" "$tmp/frames.pfs"
check "PLY: three frames" test "$(ls "$tmp/ply" | wc -l)" = 3
check "PLY: binary header" grep -aq '^format binary_little_endian 1.0$' "$tmp/ply/frame_00001.ply"
check "PLY: normals" grep -aq '^property float nz$' "$tmp/ply/frame_00001.ply"

# USD: one stage, a points sample per frame (3 vertices each), topology sampled once
expect 0 "3 frames written" "$bin/pf-export" --usd "$tmp/anim.usda" "$tmp/frames.pfs"
check "USD: header" test "$(head -1 "$tmp/anim.usda")" = "#usda 1.0"
check "USD: three points samples of 3 points" test "$(sed -n '/points.timeSamples/,/^        }/p' "$tmp/anim.usda" | grep -c '^ *[0-9]*: \[(.*), (.*), (.*)\],$')" = 3
check "USD: three normals samples" test "$(sed -n '/normals.timeSamples/,/^        }/p' "$tmp/anim.usda" | grep -c '^ *[0-9]*: \[')" = 3
check "USD: one topology sample" test "$(sed -n '/faceVertexIndices.timeSamples/,/^        }/p' "$tmp/anim.usda" | grep -c '^ *0: \[0, 1, 2\],$')" = 1
check "USD: frame 2 sagged" grep -q '^ *2: \[(0, 0, 0), (2, 0, -0.0399999991), (2, 1, 0.959999979)\],$' "$tmp/anim.usda"
# of a simulated mesh without SURF: the boundary, with the stress (STRS) per triangle
"$bin/pf-sim" --frames 2 --quiet <"$tmp/box.pfs" >"$tmp/boxsim.pfs"
expect 0 "" "$bin/pf-export" --quiet --usd "$tmp/box.usda" "$tmp/boxsim.pfs"
check "USD: three stress samples of 20 triangles" test "$(sed -n '/primvars:stress.timeSamples/,/^        }/p' "$tmp/box.usda" | grep -E '^ *[0-9]+: \[' | awk -F'[][]' '{print split($2, v, ",")}' | tr '\n' ' ')" = "20 20 20 "
check "USD: stress interpolation uniform" grep -q 'interpolation = "uniform"' "$tmp/box.usda"
expect 2 "one of --vtu" "$bin/pf-export" --usd a.usda --obj b "$tmp/box.pfs"

# damaged streams: the frames before the damage stay (and are listed), exit 1 naming the chunk
size=$(stat -c %s "$tmp/frames.pfs")
head -c $((size - 200)) "$tmp/frames.pfs" >"$tmp/cut.pfs"
expect 1 "truncated" "$bin/pf-export" --quiet --vtu "$tmp/cut" "$tmp/cut.pfs"
check "cut: the message names the input" grep -q "cut.pfs" "$tmp/err"
check "cut: earlier frames kept" test -f "$tmp/cut/mesh_00000.vtu" -a -f "$tmp/cut/mesh_00001.vtu"
check "cut: no partial file" test -z "$(ls "$tmp/cut" | grep part)"
check "cut: the PVD lists what was written" test "$(grep -c '<DataSet' "$tmp/cut/mesh.pvd")" = 2
expect 1 "truncated" "$bin/pf-export" --quiet --obj "$tmp/cutobj" "$tmp/cut.pfs"
check "cut OBJ: earlier frames kept" test -f "$tmp/cutobj/frame_00001.obj"
printf 'solid cube\n' >"$tmp/text.pfs"
expect 1 "not a pf stream" "$bin/pf-export" --vtu "$tmp/text" "$tmp/text.pfs"
expect 1 "cannot open" "$bin/pf-export" --vtu "$tmp/none" "$tmp/no-such-file.pfs"
: >"$tmp/file"
expect 1 "not a directory" "$bin/pf-export" --vtu "$tmp/file" "$tmp/box.pfs"

# usage: exit 2
expect 2 "--vtu DIR" "$bin/pf-export" "$tmp/box.pfs"
expect 2 "one of --vtu" "$bin/pf-export" --vtu a --obj b "$tmp/box.pfs"
expect 2 "--frames expects" "$bin/pf-export" --vtu "$tmp/x" --frames 3:1 "$tmp/box.pfs"
expect 2 "unknown option" "$bin/pf-export" --vtk "$tmp/x"
# no input with stdin a terminal: only testable where a pseudo-terminal can be had (script(1))
if command -v script >/dev/null 2>&1; then
  checks=$((checks + 1))
  script -qec "$bin/pf-export --vtu $tmp/tty" /dev/null >"$tmp/tty.txt" 2>&1 </dev/null
  code=$?
  if [ "$code" != 2 ] || ! grep -q "from a terminal" "$tmp/tty.txt"; then
    echo "FAIL: pf-export on a terminal stdin: exit $code, $(head -c 300 "$tmp/tty.txt")"
    failures=$((failures + 1))
  fi
fi
finish
