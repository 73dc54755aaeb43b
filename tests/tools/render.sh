# pf-render and pf-imgdiff: golden images, frame selection, pipes, damaged streams, ffmpeg, usage.
#
# Goldens (tests/golden/*.png, 160 x 120) are compared with pf-imgdiff --tol 3 --max-fraction 0.01:
# llvmpipe's shading (its approximate pow, exp and log) and its edge coverage may change by a level
# or two, and at a few edge pixels by more, between Mesa and LLVM versions; exact bytes are
# required only between runs on one machine (render_determinism.sh). 1% of 19200 pixels is 192: a
# moved silhouette or a lost shadow changes thousands. PF_UPDATE_GOLDEN=1 rewrites the goldens
# (and fails the run, which then tested nothing: see golden_png in lib.sh).
. "$(dirname "$0")/lib.sh"
golden=$(cd "$(dirname "$0")/../golden" && pwd)
gen="$bin/../tests/test_render"
[ -x "$gen" ] || { echo "FAIL: $gen (writes the test streams) is not built"; exit 1; }

"$bin/pf-shape" box --cells 4,2,2 >"$tmp/box.pfs" || { echo "FAIL: pf-shape box"; exit 1; }
"$bin/pf-shape" torus --segments 12 >"$tmp/torus.pfs" || { echo "FAIL: pf-shape torus"; exit 1; }
"$gen" --write-beam "$tmp/beam.pfs" || { echo "FAIL: test_render --write-beam"; exit 1; }
"$gen" --write-mixed "$tmp/mixed.pfs" || { echo "FAIL: test_render --write-mixed"; exit 1; }

# golden NAME FRAME pf-render-arguments...: renders into $tmp/NAME and compares frame FRAME.
golden() {
  local name=$1 frame=$2
  shift 2
  expect 0 "" "$bin/pf-render" --quiet --size 160x120 --out "$tmp/$name" "$@"
  golden_png "$name" "$tmp/$name/frame_$frame.png" "$golden"
}

# static meshes and surfaces in each mode (a stream without frames: one image of the rest shape)
golden box_surface 00000 --mode surface "$tmp/box.pfs"
golden box_mesh 00000 --mode mesh "$tmp/box.pfs"
golden mixed_mesh 00000 --mode mesh "$tmp/mixed.pfs"
golden torus_surface 00000 "$tmp/torus.pfs"
golden torus_mesh 00000 --mode mesh "$tmp/torus.pfs"
# the bent beam: embedded surface moved by WGHT, the deformed mesh, its stress with a legend
golden beam_surface 00001 --frames 1 "$tmp/beam.pfs"
golden beam_mesh 00001 --mode mesh --frames 1 "$tmp/beam.pfs"
golden beam_stress 00001 --mode stress --frames 1 "$tmp/beam.pfs"

# a stream without frames renders one image only
check "box: one image" test "$(ls "$tmp/box_mesh")" = "frame_00000.png"
# --frames selects; a file is read twice, so the camera is that of the whole animation
expect 0 "" "$bin/pf-render" --quiet --size 160x120 --out "$tmp/all" "$tmp/beam.pfs"
check "beam: two frames" test "$(ls "$tmp/all" | tr '\n' ' ')" = "frame_00000.png frame_00001.png "
check "--frames 1 renders frame 1 as the whole run does" \
  cmp -s "$tmp/all/frame_00001.png" "$tmp/beam_surface/frame_00001.png"
expect 0 "" "$bin/pf-render" --quiet --size 160x120 --out "$tmp/range" --frames 5: "$tmp/beam.pfs"
check "--frames past the end: nothing" test -z "$(ls "$tmp/range")"
# on a pipe the camera comes from the first frame: same frames, possibly another framing
checks=$((checks + 1))
if ! cat "$tmp/beam.pfs" | "$bin/pf-render" --quiet --size 160x120 --out "$tmp/pipe" 2>"$tmp/err" ||
  [ "$(ls "$tmp/pipe" | wc -l)" != 2 ]; then
  echo "FAIL: pf-render on a pipe: $(cat "$tmp/err")"; failures=$((failures + 1))
fi
# a render farm's range on a pipe: the camera is still the stream's first frame's
checks=$((checks + 1))
if ! cat "$tmp/beam.pfs" | "$bin/pf-render" --quiet --size 160x120 --frames 1 --out "$tmp/pipe1" \
  2>"$tmp/err" || ! cmp -s "$tmp/pipe1/frame_00001.png" "$tmp/pipe/frame_00001.png"; then
  echo "FAIL: --frames 1 on a pipe differs from frame 1 of the whole pipe: $(cat "$tmp/err")"
  failures=$((failures + 1))
fi
# an explicit camera
expect 0 "" "$bin/pf-render" --quiet --size 160x120 --out "$tmp/cam" \
  --camera '{"eye": [2, -6, 3], "target": [2, 0.5, 0.5], "fov": 30}' "$tmp/box.pfs"
echo '{"eye": [2, -6, 3], "target": [2, 0.5, 0.5], "fov": 30}' >"$tmp/cam.json"
expect 0 "" "$bin/pf-render" --quiet --size 160x120 --out "$tmp/cam2" --camera "$tmp/cam.json" \
  "$tmp/box.pfs"
check "camera from a file = inline camera" cmp -s "$tmp/cam/frame_00000.png" "$tmp/cam2/frame_00000.png"
expect 1 "" "$bin/pf-imgdiff" "$tmp/cam/frame_00000.png" "$tmp/box_surface/frame_00000.png"

# a stream cut inside its last frame: the frames before it are written, then exit 1
size=$(stat -c %s "$tmp/beam.pfs")
head -c $((size - 3000)) "$tmp/beam.pfs" >"$tmp/cut.pfs"
expect 1 "truncated" "$bin/pf-render" --quiet --size 160x120 --out "$tmp/cut" "$tmp/cut.pfs"
check "the frame before the damage is kept" test -f "$tmp/cut/frame_00000.png"
check "no partial file is left" test -z "$(ls "$tmp/cut" | grep -v '^frame_00000.png$')"
printf 'solid cube\n' >"$tmp/text.pfs"
expect 1 "not a pf stream" "$bin/pf-render" --quiet --out "$tmp/text" "$tmp/text.pfs"
expect 1 "cannot open" "$bin/pf-render" --quiet --out "$tmp/none" "$tmp/no-such-file.pfs"

# --mp4: a clear error before anything is rendered when ffmpeg is missing; with an ffmpeg (here a
# stand-in that stores what it is given) every frame goes down the pipe as raw RGB
expect 1 "needs ffmpeg" env PATH=/nonexistent "$bin/pf-render" --out "$tmp/nompeg" \
  --mp4 "$tmp/x.mp4" "$tmp/beam.pfs"
check "nothing rendered without ffmpeg" test ! -e "$tmp/nompeg"
mkdir -p "$tmp/fakebin"
cat >"$tmp/fakebin/ffmpeg" <<'EOF'
#!/bin/sh
for last; do :; done
cat >"$last"
EOF
chmod +x "$tmp/fakebin/ffmpeg"
expect 0 "" env PATH="$tmp/fakebin:$PATH" "$bin/pf-render" --quiet --size 160x120 \
  --out "$tmp/mp4" --mp4 "$tmp/video.raw" "$tmp/beam.pfs"
check "two raw 160x120 RGB frames reach ffmpeg" test "$(stat -c %s "$tmp/video.raw")" = 115200
expect 0 "padded to 162x122" env PATH="$tmp/fakebin:$PATH" "$bin/pf-render" --size 161x121 \
  --out "$tmp/odd" --mp4 "$tmp/odd.raw" --frames 1:1 "$tmp/beam.pfs"
check "odd size: the note says what is padded" grep -q "161x121 frames padded to 162x122" "$tmp/err"

# usage errors
expect 2 "--size expects" "$bin/pf-render" --size 0x5 "$tmp/box.pfs"
expect 2 "--frames expects" "$bin/pf-render" --frames 5:2 "$tmp/box.pfs"
expect 2 "--mode expects" "$bin/pf-render" --mode wire "$tmp/box.pfs"
expect 2 "camera JSON" "$bin/pf-render" --camera '{"eye": [1,2,3]}' "$tmp/box.pfs"

# pf-imgdiff: verdicts and exit codes
a="$tmp/beam_mesh/frame_00001.png"
expect 0 "" "$bin/pf-imgdiff" "$a" "$a"
check "identical images: PSNR inf" grep -q "^0 of 19200 pixels differ.*PSNR inf" "$tmp/out"
expect 1 "" "$bin/pf-imgdiff" "$a" "$tmp/beam_surface/frame_00001.png"
check "the verdict names the largest difference" grep -q "largest difference" "$tmp/out"
expect 0 "" "$bin/pf-imgdiff" --max-fraction 1 "$a" "$tmp/beam_surface/frame_00001.png"
expect 0 "" "$bin/pf-render" --quiet --size 80x60 --out "$tmp/small" "$tmp/box.pfs"
expect 1 "" "$bin/pf-imgdiff" "$a" "$tmp/small/frame_00000.png"
check "sizes differ is the verdict" grep -q "sizes differ" "$tmp/out"
expect 2 "not a readable PNG" "$bin/pf-imgdiff" "$a" "$tmp/text.pfs"
expect 2 "cannot open" "$bin/pf-imgdiff" "$a" "$tmp/missing.png"
expect 2 "two images" "$bin/pf-imgdiff" "$a"
expect 1 "" "$bin/pf-imgdiff" --diff "$tmp/d.png" "$a" "$tmp/beam_stress/frame_00001.png"
check "--diff writes an image" test -s "$tmp/d.png"
finish
