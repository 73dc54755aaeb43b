# pf-sim with regions given as node and element list files ("nodes_file", "elements_file"):
# the same frames, bit for bit, as the boxes that select the same faces and elements; list
# files found relative to the scene file; errors that name the key, the file and the line.
. "$(dirname "$0")/lib.sh"

# The bar 2 x 1 x 1 in 4 x 2 x 2 hexes, clamped at x = 0, pulled at x = 2, stiffer for x > 1.
"$bin/pf-shape" box --extent 2,1,1 --cells 4,2,2 >"$tmp/bar.pfs" || { echo "FAIL: pf-shape"; exit 1; }
"$bin/pf-info" --print-mesh "$tmp/bar.pfs" >"$tmp/mesh.txt"
mkdir -p "$tmp/scenes" "$tmp/run"
# the lists, as a user writes them: comments, blank lines; nodes by their coordinates, elements
# by their centre (the mean of their faces' vertices, as a box selects them)
python3 - "$tmp/mesh.txt" "$tmp/scenes" <<'PY' || { echo "FAIL: lists"; exit 1; }
import sys
x, faces, elems = {}, {}, {}
for line in open(sys.argv[1]):
    w = line.split()
    if w and w[0] == 'node':
        x[int(w[1])] = float(w[2])
    elif w and w[0] == 'face':
        faces[int(w[1])] = [int(v) for v in w[2:]]
    elif w and w[0] == 'elem':
        elems[int(w[1])] = [int(f.lstrip('+-')) for f in w[3:]]
with open(sys.argv[2] + '/clamp.txt', 'w') as f:
    f.write('# the nodes at x = 0\n\n' + ''.join('%d  # x = 0\n' % i for i in x if x[i] == 0))
with open(sys.argv[2] + '/tip.txt', 'w') as f:
    f.write(''.join('%d\n' % i for i in x if x[i] == 2))
with open(sys.argv[2] + '/right.txt', 'w') as f:
    for e, fs in elems.items():
        xs = [x[v] for q in fs for v in faces[q]]
        if sum(xs) / len(xs) >= 1:
            f.write('%d\n' % e)
PY
scene() { # fixed, load and material regions
  printf '{"material": {"E": 1e5, "nu": 0.3, "density": 100}, "materials": [{%s, "E": 4e5}],
  "fixed": [{%s}], "loads": [{%s, "traction": [0, 0, -200]}], "ground": false,
  "time": {"dt": 0.02, "frames": 3, "substeps": 2}}\n' "$3" "$1" "$2"
}
scene '"box": [[-1, -1, -1], [0, 2, 2]]' '"box": [[2, -1, -1], [3, 2, 2]]' \
  '"box": [[1, -1, -1], [3, 2, 2]]' >"$tmp/scenes/boxes.json"
scene '"nodes_file": "clamp.txt"' '"nodes_file": "tip.txt"' '"elements_file": "right.txt"' \
  >"$tmp/scenes/lists.json"
for method in dg cg; do
  for s in boxes lists; do
    # run elsewhere: the list files are found beside the scene file
    (cd "$tmp/run" && "$bin/pf-sim" ../scenes/$s.json --method $method --quiet \
      --input ../bar.pfs --stats $s.json >$s.pfs) || echo "FAIL: pf-sim $s $method"
    "$bin/pf-export" --vtu "$tmp/vtu_${s}_$method" --ascii --quiet "$tmp/run/$s.pfs"
  done
  check "$method: 4 fixed and 4 loaded faces either way" python3 -c "
import json, sys
a, b = (json.load(open('$tmp/run/%s.json' % s)) for s in ('boxes', 'lists'))
sys.exit(0 if a['fixed_faces'] == b['fixed_faces'] == 4 and a['loaded_faces'] == b['loaded_faces'] == 4 else 1)"
  check "$method: the frames by lists are those by boxes, bit for bit (17 digits)" \
    diff -r "$tmp/vtu_boxes_$method" "$tmp/vtu_lists_$method"
done
check "the stored scene names the list files as resolved" \
  bash -c "'$bin/pf-info' --scene '$tmp/run/lists.pfs' | grep -q '\"nodes_file\":.*\"../scenes/clamp.txt\"'"

# errors: exit 1, the key, the file and the line
printf '0\n# corner\n45\n' >"$tmp/scenes/bad.txt"
scene '"nodes_file": "bad.txt"' '"box": [[2, -1, -1], [3, 2, 2]]' '"box": [[1, -1, -1], [3, 2, 2]]' \
  >"$tmp/scenes/bad.json"
expect 1 "fixed[0].nodes_file: $tmp/scenes/bad.txt:3: node 45 out of range: the mesh has 45 nodes" \
  "$bin/pf-sim" "$tmp/scenes/bad.json" --input "$tmp/bar.pfs"
printf '3\nseven\n' >"$tmp/scenes/bad.txt"
expect 1 "bad.txt:2: expected node, found 'seven'" \
  "$bin/pf-sim" "$tmp/scenes/bad.json" --input "$tmp/bar.pfs"
rm "$tmp/scenes/bad.txt"
expect 1 "fixed[0].nodes_file: $tmp/scenes/bad.txt: cannot open" \
  "$bin/pf-sim" "$tmp/scenes/bad.json" --input "$tmp/bar.pfs"
printf '99\n' >"$tmp/scenes/bad.txt"
scene '"box": [[-1, -1, -1], [0, 2, 2]]' '"box": [[2, -1, -1], [3, 2, 2]]' \
  '"elements_file": "bad.txt"' >"$tmp/scenes/bad.json"
expect 1 "materials[0].elements_file: $tmp/scenes/bad.txt:1: element 99 out of range: the mesh has 16 elements" \
  "$bin/pf-sim" "$tmp/scenes/bad.json" --input "$tmp/bar.pfs"

# a refining scene: the lists go with the mesh (children in their parent's element list, new
# nodes on a listed face in the node list), so the frames are again those by boxes
for s in boxes lists; do
  sed 's/"ground": false,/"ground": false, "refine": {"threshold": 50, "max_level": 1},/' \
    "$tmp/scenes/$s.json" >"$tmp/scenes/refine_$s.json"
done
for method in dg cg; do
  for s in boxes lists; do
    (cd "$tmp/run" && "$bin/pf-sim" ../scenes/refine_$s.json --method $method --quiet \
      --input ../bar.pfs --stats refine_$s.json >refine_$s.pfs) ||
      echo "FAIL: pf-sim refine $s $method"
    "$bin/pf-export" --vtu "$tmp/rvtu_${s}_$method" --ascii --quiet "$tmp/run/refine_$s.pfs"
  done
  check "$method refined: the mesh changed" python3 -c "
import json, sys
a = json.load(open('$tmp/run/refine_lists.json'))
sys.exit(0 if a['mesh_changes']['changes'] >= 1 and a['mesh_changes']['elements'] > 16 else 1)"
  check "$method refined: the frames by lists are those by boxes, bit for bit (17 digits)" \
    diff -r "$tmp/rvtu_boxes_$method" "$tmp/rvtu_lists_$method"
done
# a cut (nodes duplicated along the crack): the same again
cut='"cuts": [{"plane": {"point": [1.25, 0.5, 0.5], "normal": [1, 0.2, 0]}, "time": 0.03}]'
for s in boxes lists; do
  sed "s/\"ground\": false,/\"ground\": false, $cut,/" "$tmp/scenes/$s.json" >"$tmp/scenes/cut_$s.json"
  (cd "$tmp/run" && "$bin/pf-sim" ../scenes/cut_$s.json --quiet --input ../bar.pfs >cut_$s.pfs) ||
    echo "FAIL: pf-sim cut $s"
  "$bin/pf-export" --vtu "$tmp/cvtu_$s" --ascii --quiet "$tmp/run/cut_$s.pfs"
done
check "cut: the frames by lists are those by boxes, bit for bit" \
  diff -r "$tmp/cvtu_boxes" "$tmp/cvtu_lists"
finish
