# The example scenes in data/scenes/ run, the README's pipelines run as written (fewer frames, a
# temporary output directory), and every key documented in docs/scene.md is exercised: each key
# of its tables appears in the scene (SCEN) an example scene produces, and each command-line
# override in its override table is accepted and recorded in the stream's scene.
. "$(dirname "$0")/lib.sh"
root=$(cd "$data/../.." && pwd)
scenes=$root/data/scenes
"$bin/pf-shape" box --extent 4,1,1 --cells 8,2,2 >"$tmp/beam.pfs"
"$bin/pf-shape" torus --segments 12 | "$bin/pf-slice" --res 6 --quiet >"$tmp/torus.pfs"

# every example scene, on the beam (cantilevers) or the sliced torus, 2 frames
for f in "$scenes"/*.json; do
  name=$(basename "$f" .json)
  mesh=$tmp/torus.pfs
  case "$name" in
    cantilever*) mesh=$tmp/beam.pfs ;;
    two_materials) "$bin/pf-import" "$scenes/two_materials.msh" --quiet >"$tmp/groups.pfs"
                   mesh=$tmp/groups.pfs ;;
  esac
  expect 0 "" "$bin/pf-sim" "$f" --frames 2 --quiet --input "$mesh"
  "$bin/pf-sim" "$f" --frames 2 --quiet <"$mesh" | "$bin/pf-info" --scene >"$tmp/scene_$name.json"
  check "$name: the stream's scene reads back as a scene file" bash -c \
    "'$bin/pf-sim' '$tmp/scene_$name.json' --frames 0 --quiet --input '$mesh' >/dev/null"
done
check "at least the seven example scenes" test "$(ls "$tmp"/scene_*.json | wc -l)" -ge 7

# every key in the first column of docs/scene.md's key tables (header 'key ...') appears in some example's scene
python3 - "$root/docs/scene.md" "$tmp"/scene_*.json >"$tmp/keys.txt" <<'PY'
import json, re, sys
doc = open(sys.argv[1]).read().split("## Command-line overrides")[0]
keys = set()
in_key_table = False  # tables whose first column is "key" (others list methods, degrees, ...)
for line in doc.splitlines():
    if not line.startswith("|"):
        in_key_table = False
    elif not in_key_table and re.match(r"\| key\b", line):
        in_key_table = True
    m = re.match(r"\| (`[^|]*`) \|", line)
    if m and in_key_table:
        keys.update(re.findall(r"`([A-Za-z_]+)`", m.group(1)))
seen = set()
def walk(v):
    if isinstance(v, dict):
        for k, x in v.items():
            seen.add(k)
            walk(x)
    elif isinstance(v, list):
        for x in v:
            walk(x)
for path in sys.argv[2:]:
    walk(json.load(open(path)))
print(len(keys), " ".join(sorted(keys - seen)))
PY
read -r n_keys missing <"$tmp/keys.txt"
check "docs/scene.md documents keys ($n_keys)" test "${n_keys:-0}" -ge 30
check "every documented key is used by an example scene (missing: ${missing:-none})" test -z "$missing"

# every override in the table: --key=value is accepted and lands in the stream's scene
declare -A sample=([method]=cg [mass]=lumped [degree]=2 [flux]=bz [frames]=1 [substeps]=3
                   [dt]=0.02 [E]=12345 [nu]=0.25 [density]=7 [penalty]=3 [edge_samples]=4
                   [corotation]=false [static]=true [solver]=pcg [tolerance]=1e-08)
declare -A json=([method]='["method"]["name"]' [mass]='["method"]["mass"]'
                 [degree]='["method"]["degree"]' [flux]='["method"]["flux"]'
                 [frames]='["time"]["frames"]' [substeps]='["time"]["substeps"]'
                 [dt]='["time"]["dt"]' [E]='["material"]["E"]' [nu]='["material"]["nu"]'
                 [density]='["material"]["density"]' [penalty]='["method"]["penalty"]'
                 [edge_samples]='["method"]["edge_samples"]'
                 [corotation]='["method"]["corotation"]' [static]='["static"]'
                 [solver]='["solver"]["method"]' [tolerance]='["solver"]["tolerance"]')
overrides=$(sed -n '/^## Command-line overrides/,/^## /p' "$root/docs/scene.md" |
            sed -n 's/^| `\([A-Za-z_]*\)` |.*/\1/p')
check "the override table lists keys" test -n "$overrides"
for key in $overrides; do
  if [ -z "${sample[$key]:-}" ]; then
    echo "FAIL: docs/scene.md documents the override '$key', which this test does not exercise"
    failures=$((failures + 1)); checks=$((checks + 1)); continue
  fi
  option=--$(echo "$key" | tr _ -)
  value=${sample[$key]}
  base=()
  [ "$key" = static ] && base=("$scenes/cantilever.json")
  [ "$key" = mass ] || [ "$key" = edge_samples ] && base=(--method cg)
  expect 0 "" "$bin/pf-sim" "${base[@]}" --frames 0 --quiet "$option=$value" --input "$tmp/beam.pfs"
  "$bin/pf-sim" "${base[@]}" --frames 0 --quiet "$option=$value" <"$tmp/beam.pfs" |
    "$bin/pf-info" --scene >"$tmp/o.json"
  check "$option=$value is recorded in the scene" python3 -c "
import json, sys
got = json.load(open('$tmp/o.json'))${json[$key]}
want = json.loads('$value') if '$value' not in ('cg', 'lumped', 'bz', 'pcg') else '$value'
sys.exit(0 if got == want else 1)"
done
# the flag spellings docs/scene.md gives
expect 0 "" "$bin/pf-sim" --static=false --frames 0 --quiet --input "$tmp/beam.pfs"
expect 0 "" "$bin/pf-sim" --corotation --no-corotation --frames 0 --quiet --input "$tmp/beam.pfs"
expect 2 "corotation: must be true or false, got 'maybe'" "$bin/pf-sim" --corotation=maybe --input "$tmp/beam.pfs"
expect 2 "takes no value" "$bin/pf-sim" --quiet=yes --input "$tmp/beam.pfs"
expect 1 "a static scene needs fixed faces" "$bin/pf-sim" --static --input "$tmp/beam.pfs"

# pf-info: the scene in text and JSON, --scene alone; a stream without one
"$bin/pf-sim" --frames 0 --quiet <"$tmp/beam.pfs" >"$tmp/sim.pfs"
check "pf-info prints the SCEN chunk's JSON" bash -c "'$bin/pf-info' '$tmp/sim.pfs' | grep -q '^SCEN  at byte .*: scene, [0-9]* bytes:$'"
check "pf-info --json gives the scene as a string" bash -c "'$bin/pf-info' --json '$tmp/sim.pfs' | grep -q '\"chunk\":\"SCEN\".*\"scene\":\"{'"
expect 1 "no SCEN chunk" "$bin/pf-info" --scene "$tmp/beam.pfs"

# pf-imgdiff follows cmp(1): trouble (an unreadable image) is 2, not the verdict 1
: >"$tmp/empty.png"
expect 2 "empty.png" "$bin/pf-imgdiff" "$tmp/empty.png" "$tmp/empty.png"

# the README's pipelines, as written but for 2 frames and a temporary output directory
grep -oE '(^|`)pf-[^`]*\| pf-render --out frames/' "$root/README.md" | tr -d '`' | sort -u >"$tmp/pipes"
check "the README shows pipelines with data/scenes" test "$(grep -c 'data/scenes/' "$tmp/pipes")" -ge 3
while read -r pipe; do
  cmd=$(echo "$pipe" | sed "s#pf-sim \([^ |]*\)#pf-sim \1 --frames 2 --quiet#; s#--out frames/#--out $tmp/frames --quiet#; s#data/#$root/data/#g")
  checks=$((checks + 1))
  rm -rf "$tmp/frames"
  if ! (cd "$tmp" && PATH="$bin:$PATH" bash -o pipefail -c "$cmd" >/dev/null 2>"$tmp/err") ||
     [ "$(ls "$tmp/frames" 2>/dev/null | wc -l)" != 3 ]; then
    echo "FAIL: README pipeline '$pipe': $(head -c 300 "$tmp/err")"
    failures=$((failures + 1))
  fi
done <"$tmp/pipes"
finish
