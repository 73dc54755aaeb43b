#!/usr/bin/env bash
# Every global symbol libpf defines (static and shared) starts with pf_ (or PF_ for constant
# data): a program linking libpf never collides with its names. scripts/prefix-symbols renames
# any that do not.
#   tests/symbols.sh BUILD_DIR
set -u
lib=$1/libcore
status=0
bad=$(nm -g --defined-only "$lib/libpf.a" | awk 'NF == 3 && $3 !~ /^(pf|PF)_/ && $3 !~ /^__/ { print $3 }' | sort -u)
if [ -n "$bad" ]; then
  echo "FAIL: libpf.a defines global symbols without the pf_ prefix (scripts/prefix-symbols):"
  echo "$bad" | head -20
  status=1
fi
count=$(nm -g --defined-only "$lib/libpf.a" | awk 'NF == 3' | wc -l)
[ "$count" -gt 100 ] || { echo "FAIL: only $count global symbols in libpf.a"; status=1; }
bad=$(nm -D --defined-only "$lib/libpf.so" | awk 'NF == 3 && $3 !~ /^pf_/ { print $3 }')
if [ -n "$bad" ]; then
  echo "FAIL: libpf.so exports symbols without the pf_ prefix:"; echo "$bad" | head -20
  status=1
fi
exported=$(nm -D --defined-only "$lib/libpf.so" | grep -c ' T pf_')
[ "$exported" -gt 100 ] || { echo "FAIL: libpf.so exports only $exported pf_ functions"; status=1; }
[ $status = 0 ] && echo "symbols: ok ($count in libpf.a, $exported functions exported by libpf.so)"
exit $status
