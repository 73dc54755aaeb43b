# pf-sim's STAT chunk shown by pf-info (text and --json): the error indicator of a DG run and of a
# CG run on sliced cells (harmonic functions, a nonzero indicator) and the run's counters equal
# what pf-sim --stats says; a stream through pf-sim twice holds the last run's STAT only; a
# refining run writes one STAT for the whole run; a diverged run still writes one; the tools that
# pass streams on or read frames keep or skip it (docs/stream-format.md, STAT).
. "$(dirname "$0")/lib.sh"
"$bin/pf-shape" box --extent 4,1,1 --cells 4,1,1 >"$tmp/beam.pfs" || { echo "FAIL: pf-shape"; exit 1; }
"$bin/pf-shape" torus --segments 10 | "$bin/pf-slice" --res 4 --quiet >"$tmp/torus.pfs" ||
  { echo "FAIL: torus"; exit 1; }
cat >"$tmp/dg.json" <<'JSON'
{"material": {"E": 20000, "nu": 0.3, "density": 100},
 "method": {"name": "dg", "degree": 2, "flux": "ip"},
 "gravity": [0, 0, -9.81],
 "ground": {"point": [0, 0, -0.05], "stiffness": 1e5},
 "fixed": [{"box": [[-0.001, -1, -1], [0.001, 2, 2]]}],
 "time": {"frames": 3, "dt": 0.05}}
JSON
# the torus lies across z = 0: no ground (it would be inside the body)
sed -e 's/"name": "dg", "degree": 2, "flux": "ip"/"name": "cg"/' \
  -e 's/"ground": {"point": \[0, 0, -0.05\], "stiffness": 1e5},/"ground": false,/' \
  "$tmp/dg.json" >"$tmp/cg.json"

# compare STREAM STATS.json MEASURE: pf-info --json's STAT against pf-sim --stats, and the text
# view's indicator line (6 significant digits)
compare() {
  local stream=$1 stats=$2 measure=$3
  "$bin/pf-info" --json "$stream" >"$tmp/info.json" || { echo "FAIL: pf-info --json $stream"; return 1; }
  "$bin/pf-info" "$stream" >"$tmp/info.txt" || { echo "FAIL: pf-info $stream"; return 1; }
  python3 - "$tmp/info.json" "$stats" "$measure" "$tmp/info.txt" <<'PY'
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
stat = [l for l in lines if l.get("chunk") == "STAT"]
assert len(stat) == 1, "one STAT, got %d" % len(stat)
s = stat[0]["stats"]
ref = json.load(open(sys.argv[2]))
ind = ref["error_indicator"]
assert s["error_indicator"] == ind["value"], (s["error_indicator"], ind["value"])
assert s["error_measure"] == ind["measure"] == sys.argv[3], (s["error_measure"], ind["measure"])
for key, want in [("unknowns", ref["dofs"]), ("steps", ref["steps"]), ("frames", ref["frames"]),
                  ("factorisations", ref["solver"]["factorisations"]),
                  ("solves", ref["solver"]["solves"]),
                  ("pcg_iterations", ref["solver"]["pcg_iterations"]),
                  ("solver", ref["solver"]["method"]),
                  ("simulated_time", ref["simulated_time"]),
                  ("mesh_changes", ref["mesh_changes"]["changes"]),
                  ("elements", ref["mesh_changes"]["elements"])]:
    assert s[key] == want, (key, s[key], want)
text = open(sys.argv[4]).read()
line = "      error_indicator %s\n" % ("%.6g" % ind["value"])
assert line in text, "text lacks %r" % line
assert "      error_measure %s\n" % sys.argv[3] in text
print("indicator %.6g (%s), steps %d, factorisations %d" % (ind["value"], sys.argv[3], s["steps"],
                                                            s["factorisations"]))
PY
}

expect 0 "" "$bin/pf-sim" "$tmp/dg.json" --quiet --input "$tmp/beam.pfs" --stats "$tmp/dg.stats.json"
cp "$tmp/out" "$tmp/dg.pfs"
check "dg: pf-info shows the indicator and counters of --stats" \
  compare "$tmp/dg.pfs" "$tmp/dg.stats.json" node_jump_over_displacement
check "dg: the indicator is not zero (a bent beam of 4 elements)" \
  python3 -c "import json,sys; sys.exit(json.load(open('$tmp/dg.stats.json'))['error_indicator']['value'] <= 0)"
check "dg: method, degree and flux" grep -q '"method":"dg","degree":2,"flux":"ip"' "$tmp/info.json"

expect 0 "" "$bin/pf-sim" "$tmp/cg.json" --quiet --input "$tmp/torus.pfs" --stats "$tmp/cg.stats.json"
cp "$tmp/out" "$tmp/cg.pfs"
check "cg: pf-info shows the indicator and counters of --stats" \
  compare "$tmp/cg.pfs" "$tmp/cg.stats.json" basis_boundary_error
check "cg: harmonic cells, a nonzero basis error" \
  python3 -c "import json,sys; sys.exit(json.load(open('$tmp/cg.stats.json'))['error_indicator']['value'] <= 0)"

# pf-sim over a stream that has a STAT already: the earlier run's is dropped, the new one written
expect 0 "" "$bin/pf-sim" "$tmp/cg.json" --quiet --input "$tmp/dg.pfs" --stats "$tmp/again.stats.json"
cp "$tmp/out" "$tmp/again.pfs"
check "pf-sim twice: one STAT, the last run's" \
  compare "$tmp/again.pfs" "$tmp/again.stats.json" basis_boundary_error
check "... last before END_" bash -c "'$bin/pf-info' '$tmp/again.pfs' | grep -E '^[A-Z_]{4}  at' | tail -2 | head -1 | grep -q '^STAT'"

# a refining run: several MESH chunks, one STAT for the whole run (the last mesh's elements)
root=$(cd "$data/../.." && pwd)
"$bin/pf-shape" box --extent 4,1,1 --cells 8,2,2 >"$tmp/bar.pfs"
expect 0 "" "$bin/pf-sim" "$root/data/scenes/cantilever_refine.json" --frames 12 --quiet \
  --input "$tmp/bar.pfs" --stats "$tmp/refine.stats.json"
cp "$tmp/out" "$tmp/refine.pfs"
check "refining: pf-info's STAT equals --stats" \
  compare "$tmp/refine.pfs" "$tmp/refine.stats.json" node_jump_over_displacement
check "refining: the mesh changed, STAT counts it" \
  python3 -c "import json,sys; sys.exit(json.load(open('$tmp/refine.stats.json'))['mesh_changes']['changes'] < 1)"

# a diverged run (free fall under a huge g, as in sim.sh) closes its stream with a STAT
printf '{"gravity": [0, 0, -3e5], "ground": false, "time": {"dt": 0.04, "frames": 10, "substeps": 1}}' \
  >"$tmp/diverge.json"
"$bin/pf-shape" box --cells 1,1,1 >"$tmp/cube.pfs"
expect 1 "diverged" "$bin/pf-sim" "$tmp/diverge.json" --input "$tmp/cube.pfs"
"$bin/pf-info" "$tmp/out" >"$tmp/diverged.txt"
check "diverged: a STAT with the steps advanced" grep -q "^      steps [1-9]" "$tmp/diverged.txt"

# the tools that read frames skip it; those that pass a stream on keep it
expect 0 "" "$bin/pf-export" --quiet --obj "$tmp/obj" "$tmp/dg.pfs"
check "pf-export wrote the frames" test -s "$tmp/obj/frame_00003.obj"
expect 0 "" "$bin/pf-render" --quiet --size 40x30 --frames 3 --out "$tmp/png" "$tmp/dg.pfs"
expect 0 "" "$bin/pf-embed" --quiet "$tmp/cg.pfs"
check "pf-embed passes the STAT on" bash -c "'$bin/pf-info' '$tmp/out' | grep -c '^STAT' | grep -qx 1"
expect 0 "" "$bin/pf-slice" --res 3 --quiet "$tmp/cg.pfs"
check "pf-slice (a new MESH) passes it on, as INFO" \
  bash -c "'$bin/pf-info' '$tmp/out' | grep -c '^STAT' | grep -qx 1"
finish
