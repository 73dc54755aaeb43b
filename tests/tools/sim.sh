# pf-sim: the issue's cantilever scene as written, a default drop, and bad input.
. "$(dirname "$0")/lib.sh"
scenes=$data/scenes

# The static cantilever (4 x 1 x 1, clamped at x = 0, traction (0, 0, -1) on x = 4), DG degree 2
# IP on 16 x 4 x 4 hexes: the tip deflection is Timoshenko's 2.685e-3 within 3 % (the 3-D
# clamp and load spread are not in beam theory; test_sim checks the convergence).
"$bin/pf-shape" box --extent 4,1,1 --cells 16,4,4 >"$tmp/beam.pfs" || { echo "FAIL: pf-shape"; exit 1; }
expect 0 "" "$bin/pf-sim" "$scenes/cantilever.json" --input "$tmp/beam.pfs"
"$bin/pf-sim" "$scenes/cantilever.json" --quiet <"$tmp/beam.pfs" >"$tmp/out.pfs"
"$bin/pf-info" --json --probe 4,0.5,0.5 "$tmp/out.pfs" >"$tmp/info.json"
tip=$(grep -o '"u":\[[^]]*\]' "$tmp/info.json" | head -1 | sed 's/.*,//; s/\]//')
check "tip deflection $tip is -2.685e-3 within 3 %" \
  awk -v w="$tip" 'BEGIN { e = w / -2.685e-3 - 1; exit !(e < 0.03 && e > -0.03) }'
check "the output keeps the MESH and adds SCEN, FRAM, STRS" \
  bash -c "grep -q '\"chunk\":\"MESH\"' '$tmp/info.json' && grep -q '\"chunk\":\"SCEN\"' '$tmp/info.json' && grep -q '\"chunk\":\"STRS\"' '$tmp/info.json'"

# Without a scene: the default drop onto the ground, 5 frames plus the rest frame.
"$bin/pf-shape" box --extent 1,1,1 --cells 2,2,2 >"$tmp/cube.pfs"
expect 0 "" "$bin/pf-sim" --frames 5 --input "$tmp/cube.pfs"
"$bin/pf-sim" --frames 5 --quiet <"$tmp/cube.pfs" >"$tmp/drop.pfs"
check "six frames" bash -c "'$bin/pf-info' '$tmp/drop.pfs' | grep -q '^FRAM .*: 6 frames'"

# Bad input: one line naming the file, exit 1; bad usage exit 2.
expect 1 "syntax_error.json:3:" "$bin/pf-sim" "$scenes/syntax_error.json" --input "$tmp/cube.pfs"
expect 1 "material.nuu" "$bin/pf-sim" "$scenes/unknown_key.json" --input "$tmp/cube.pfs"
expect 1 "missing.json" "$bin/pf-sim" "$tmp/missing.json" --input "$tmp/cube.pfs"

# Method cg: the cantilever scene with only the method name changed, on the same 16 x 4 x 4
# hexes (trilinear closed forms): test_cg measured -2.530e-3, 3.8 % stiffer than the DG limit
# (trilinear hexes lock mildly in bending); asserted within 6 % of Timoshenko's 2.685e-3 from
# below. The summary says how many elements skipped MFS.
sed 's/"name": "dg", "degree": 2, "flux": "ip"/"name": "cg"/' "$scenes/cantilever.json" >"$tmp/cg.json"
check "the cg scene differs from the dg one in the method only" \
  bash -c "diff '$scenes/cantilever.json' '$tmp/cg.json' | grep -c '^>' | grep -qx 1 && grep -q '\"name\": \"cg\"' '$tmp/cg.json'"
expect 0 "256 closed forms, MFS skipped" "$bin/pf-sim" "$tmp/cg.json" --input "$tmp/beam.pfs"
"$bin/pf-sim" "$tmp/cg.json" --quiet <"$tmp/beam.pfs" >"$tmp/cg.pfs"
"$bin/pf-info" --json --probe 4,0.5,0.5 "$tmp/cg.pfs" >"$tmp/cginfo.json"
tip=$(grep -o '"u":\[[^]]*\]' "$tmp/cginfo.json" | head -1 | sed 's/.*,//; s/\]//')
check "cg tip deflection $tip is -2.685e-3 within 6 % from below" \
  awk -v w="$tip" 'BEGIN { e = w / -2.685e-3 - 1; exit !(e < 0 && e > -0.06) }'
# --method cg overrides the file's dg and gives the same frame
"$bin/pf-sim" "$scenes/cantilever.json" --method cg --quiet <"$tmp/beam.pfs" >"$tmp/cg2.pfs"
"$bin/pf-info" --json --probe 4,0.5,0.5 "$tmp/cg2.pfs" >"$tmp/cginfo2.json"
tip2=$(grep -o '"u":\[[^]]*\]' "$tmp/cginfo2.json" | head -1 | sed 's/.*,//; s/\]//')
check "--method cg gives the same tip ($tip2 = $tip)" test "$tip2" = "$tip"
# A sliced sphere (hexes and harmonic cut cells) dropped with cg and lumped mass: 3 frames.
"$bin/pf-shape" sphere --segments 8 | "$bin/pf-slice" --res 4 --quiet >"$tmp/ball.pfs"
expect 0 "harmonic" "$bin/pf-sim" --method cg --mass lumped --frames 3 --input "$tmp/ball.pfs"
"$bin/pf-sim" --method cg --frames 3 --quiet <"$tmp/ball.pfs" >"$tmp/ball_out.pfs"
check "four cg frames of the ball" bash -c "'$bin/pf-info' '$tmp/ball_out.pfs' | grep -q '^FRAM .*: 4 frames'"
expect 2 "mass: must be consistent or lumped" "$bin/pf-sim" --method cg --mass diagonal --input "$tmp/cube.pfs"
# --edge-samples reaches the basis: more kernels (the summary counts them), and the SCEN in the
# output records it.
k2=$("$bin/pf-sim" --method cg --frames 1 --input "$tmp/ball.pfs" 2>&1 >/dev/null | sed -n 's/.* \([0-9]*\) kernels.*/\1/p')
k3=$("$bin/pf-sim" --method cg --frames 1 --edge-samples 3 --input "$tmp/ball.pfs" 2>&1 >/dev/null | sed -n 's/.* \([0-9]*\) kernels.*/\1/p')
check "edge_samples 3 gives more kernels ($k3) than the default 2 ($k2)" test "${k3:-0}" -gt "${k2:-0}" -a "${k2:-0}" -gt 0
"$bin/pf-sim" --method cg --frames 1 --edge-samples 3 --quiet <"$tmp/ball.pfs" >"$tmp/ball_es3.pfs"
check "the scene in the stream (SCEN, JSON) records edge_samples 3" \
  bash -c "grep -a -q -E '\"edge_samples\":[[:space:]]*3' '$tmp/ball_es3.pfs'"
# The same bytes whatever OpenBLAS's thread count would be: the library runs its BLAS calls on
# one thread (with OPENBLAS_NUM_THREADS=2, which the library leaves alone, the frames differ).
env -u OPENBLAS_NUM_THREADS -u GOTO_NUM_THREADS -u OMP_NUM_THREADS \
  "$bin/pf-sim" --method cg --frames 2 --quiet <"$tmp/ball.pfs" >"$tmp/ball_default.pfs"
OPENBLAS_NUM_THREADS=1 "$bin/pf-sim" --method cg --frames 2 --quiet <"$tmp/ball.pfs" >"$tmp/ball_one.pfs"
check "cg frames do not depend on OpenBLAS's default thread count" \
  cmp -s "$tmp/ball_default.pfs" "$tmp/ball_one.pfs"
expect 2 "edge_samples: must be an integer from 1 to 16" "$bin/pf-sim" --method cg --edge-samples 0 --input "$tmp/cube.pfs"
"$bin/pf-shape" torus >"$tmp/torus.pfs"
expect 1 "no MESH" "$bin/pf-sim" --input "$tmp/torus.pfs"
head -c 200 "$tmp/cube.pfs" >"$tmp/cut.pfs"
expect 1 "truncated" "$bin/pf-sim" --input "$tmp/cut.pfs"
expect 2 "" "$bin/pf-sim" --degree
expect 2 "" "$bin/pf-sim" --nu 0.7 --input "$tmp/cube.pfs"
expect 2 "" "$bin/pf-sim" --bogus

# A run that diverges stops with exit 1 naming the frame and the element, and the frames before
# it stay readable in a properly ended stream. Free fall under g = 3e5 with dt = 0.04 and one
# substep (semi-implicit Euler: u_n = h^2 g n (n + 1) / 2) has moved 1440 after frame 2 and 2880
# after frame 3, across the divergence bound of 1e3 model sizes (1732 for the unit cube).
cat >"$tmp/diverge.json" <<'JSON'
{"gravity": [0, 0, -3e5], "ground": false, "time": {"dt": 0.04, "frames": 10, "substeps": 1}}
JSON
expect 1 "frame 3, step 1: the simulation diverged (element " \
  "$bin/pf-sim" "$tmp/diverge.json" --input "$tmp/cube.pfs"
"$bin/pf-sim" "$tmp/diverge.json" --quiet <"$tmp/cube.pfs" >"$tmp/diverged.pfs" 2>/dev/null
check "a diverged run exits 1" test $? = 1
"$bin/pf-info" "$tmp/diverged.pfs" >"$tmp/diverged.txt" 2>&1
check "pf-info reads the diverged stream" test $? = 0
check "the frames before the divergence are written: 0, 1, 2" \
  grep -q '^FRAM .*: 3 frames of mesh 0, time 0 \.\. 0\.08' "$tmp/diverged.txt"
check "the stream ends with END_ counting those 3 frames" grep -q '^END_ .*, 3 frames$' "$tmp/diverged.txt"
check "no truncation reported" bash -c "! grep -qi truncated '$tmp/diverged.txt'"

# --stats FILE: the run's statistics as JSON, also for the diverged run (3 frames advanced)
"$bin/pf-sim" "$tmp/diverge.json" --quiet --stats "$tmp/stats.json" <"$tmp/cube.pfs" >/dev/null 2>&1
check "--stats after a divergence: 2 frames advanced, 3 steps (the diverging one too), no .part left" python3 -c "
import json, os, sys
s = json.load(open('$tmp/stats.json'))
sys.exit(0 if s['frames'] == 2 and s['steps'] == 3 and not os.path.exists('$tmp/stats.json.part') else 1)"
"$bin/pf-sim" --quiet --frames 3 --solver pcg --stats "$tmp/stats.json" <"$tmp/cube.pfs" >/dev/null
check "--stats: counts and seconds that agree with each other" python3 -c "
import json, sys
s = json.load(open('$tmp/stats.json'))
v = s['solver']
ok = (s['frames'] == 3 and s['steps'] == 30 and v['method'] == 'pcg' and v['solves'] == 30
      and sum(v['factorisations_by_reason'].values()) == v['factorisations'] >= 1
      and v['pcg_iterations_max'] >= v['pcg_iterations_mean'] >= 0 and s['dofs'] > 0
      and all(s['seconds'][k]['wall'] >= 0 and s['seconds'][k]['cpu'] >= 0
              for k in ('run', 'setup', 'assembly', 'factorisation', 'solves'))
      and s['seconds']['run']['wall'] >= s['seconds']['setup']['wall']
      and s['seconds']['run']['cpu'] >= s['seconds']['setup']['cpu']
      and s['seconds']['run']['cpu'] >= s['seconds']['assembly']['cpu'] > 0)
sys.exit(0 if ok else 1)"
expect 1 "cannot" "$bin/pf-sim" --quiet --frames 0 --stats "$tmp/no/such/dir/stats.json" --input "$tmp/cube.pfs"
finish
