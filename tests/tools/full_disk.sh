# Lost output is never a success: every tool writing to a full disk (/dev/full) exits 1 and says
# why, whether it writes a stream, a text report, --help or --version.
. "$(dirname "$0")/lib.sh"
[ -w /dev/full ] || { echo "SKIP: no /dev/full"; exit 0; }

"$bin/pf-shape" box --cells 2,1,1 >"$tmp/box.pfs" || { echo "FAIL: pf-shape box"; exit 1; }
"$bin/pf-shape" sphere --res 6 >"$tmp/sphere.pfs" || { echo "FAIL: pf-shape sphere"; exit 1; }
"$bin/pf-sim" --quiet --frames 2 --input "$tmp/box.pfs" >"$tmp/sim.pfs" ||
  { echo "FAIL: pf-sim"; exit 1; }
"$bin/pf-render" --quiet --size 40x30 --out "$tmp/png" "$tmp/box.pfs" ||
  { echo "FAIL: pf-render"; exit 1; }
png="$tmp/png/frame_00000.png"

# full COMMAND...: stdout to /dev/full must end in exit 1 naming stdout and the reason.
full() {
  checks=$((checks + 1))
  "$@" >/dev/full 2>"$tmp/err" </dev/null
  local got=$?
  if [ "$got" != 1 ] || ! grep -q "stdout.*No space left on device" "$tmp/err"; then
    echo "FAIL: '$*' >/dev/full exited $got: $(head -c 300 "$tmp/err")"
    failures=$((failures + 1))
  fi
}

full "$bin/pf-info" "$tmp/sim.pfs"
full "$bin/pf-info" --json "$tmp/sim.pfs"
full "$bin/pf-info" --probe 0,0,0 "$tmp/sim.pfs"
full "$bin/pf-basis" "$tmp/box.pfs"
full "$bin/pf-basis" --json "$tmp/box.pfs"
full "$bin/pf-imgdiff" "$png" "$png"
full "$bin/pf-shape" sphere
full "$bin/pf-import" "$data/cube.obj"
full "$bin/pf-slice" --res 4 "$data/cube.obj"
full "$bin/pf-voxelize" --res 4 "$data/cube.obj"
full "$bin/pf-octree" "$data/cube.obj"
full "$bin/pf-embed" "$tmp/sphere.pfs"
full "$bin/pf-sim" --quiet --frames 2 --input "$tmp/box.pfs"
for tool in pf-shape pf-import pf-slice pf-voxelize pf-octree pf-embed pf-sim pf-render pf-info \
  pf-basis pf-export pf-imgdiff; do
  full "$bin/$tool" --help
  full "$bin/$tool" --version
done
finish
