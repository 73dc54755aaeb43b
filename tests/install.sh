#!/usr/bin/env bash
# Installs pf to a temporary prefix and builds docs/example.c against it twice: with pkg-config
# (shared and static libpf) and with CMake's find_package(pf); each program must print the volume
# pf-info prints for the same stream.
#   tests/install.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1 src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "install: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$tmp/prefix" >/dev/null
p=$tmp/prefix
for f in bin/pf-sim bin/pf-info include/pf/io.h include/pf/mesh.h include/pf/version.h \
         lib/libpf.a lib/pkgconfig/pf.pc lib/cmake/pf/pfConfig.cmake; do
  [ -e "$p/$f" ] || fail "missing $f in the install tree"
done
so=$(readlink "$p/lib/libpf.so") || fail "lib/libpf.so is not a symlink"
soname=$(objdump -p "$p/lib/libpf.so" | awk '$1 == "SONAME" {print $2}')
[ -n "$soname" ] && [ -e "$p/lib/$soname" ] || fail "soname '$soname' of $so not installed"

for doc in README.md library.md scene.md stream-format.md example.c; do
  [ -s "$p/share/doc/pf/$doc" ] || fail "share/doc/pf/$doc not installed"
done

"$p/bin/pf-shape" torus --segments 12 | "$p/bin/pf-slice" --res 6 --quiet > "$tmp/box.pfs"
expect=$("$build/bin/pf-info" "$tmp/box.pfs" --json | python3 -c \
  'import json,sys; m=[json.loads(l) for l in sys.stdin if "\"MESH\"" in l][0]; print(m["elements"], repr(m["volume"]))')
check() {  # program: its output must hold pf-info's element count and volume
  out=$("$1" < "$tmp/box.pfs") || fail "$1 failed"
  python3 - "$out" "$expect" <<'PY' || fail "$1 printed '$out', pf-info says '$expect'"
import sys
out, exp = sys.argv[1].split(), sys.argv[2].split()
assert out[0] == exp[0] and float(out[3]) == float(exp[1]), (out, exp)
PY
}

export PKG_CONFIG_PATH=$p/lib/pkgconfig
cc -std=c11 -Wall -Werror $(pkg-config --cflags pf) "$src/docs/example.c" -o "$tmp/ex_pc" \
   $(pkg-config --libs pf) -Wl,-rpath,"$p/lib"
check "$tmp/ex_pc"
readelf -d "$tmp/ex_pc" | grep -q "NEEDED.*$soname" || fail "ex_pc does not load $soname"
cc -std=c11 -Wall -Werror $(pkg-config --cflags pf) "$src/docs/example.c" -o "$tmp/ex_static" \
   $(pkg-config --static --libs pf | sed 's/-lpf\b/-l:libpf.a/')
check "$tmp/ex_static"
readelf -d "$tmp/ex_static" | grep -q "NEEDED.*libpf" && fail "ex_static loads libpf.so"

mkdir "$tmp/cm"
cat > "$tmp/cm/CMakeLists.txt" <<CM
cmake_minimum_required(VERSION 3.20)
project(example C)
find_package(pf 0.1 REQUIRED)
add_executable(example $src/docs/example.c)
target_link_libraries(example PRIVATE pf::pf)
CM
cmake -S "$tmp/cm" -B "$tmp/cm/build" -DCMAKE_PREFIX_PATH="$p" >/dev/null
cmake --build "$tmp/cm/build" >/dev/null
check "$tmp/cm/build/example"
echo "install: ok ($soname)"
