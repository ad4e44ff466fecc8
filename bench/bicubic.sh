#!/usr/bin/env bash
# Implicitization of a generic bicubic patch (bench/bicubic.txt, implicit degree 18):
# isoray by interpolation, isoray by elimination, and Singular's eliminate, each
# under a time limit (LIMIT seconds, default 480 = 8 minutes). Run from anywhere.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
LIMIT=${LIMIT:-480}
bench/install-peers.sh >/dev/null
cargo build --release -p isoray >/dev/null 2>&1
get() { grep "^$1=" bench/bicubic.txt | cut -d= -f2-; }
X=$(get x); Y=$(get y); Z=$(get z)
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
run() { # name, command...
  local name=$1; shift
  local t0 t1 rc=0
  t0=$(date +%s.%N)
  timeout "$LIMIT" "$@" >"$TMP/$name.out" 2>"$TMP/$name.err" || rc=$?
  t1=$(date +%s.%N)
  if [ "$rc" = 124 ]; then echo "| $name | did not finish in $LIMIT s |"; else
    echo "| $name | $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }') s (exit $rc, $(wc -c <"$TMP/$name.out") bytes of output) |"; fi
}
echo "| method | wall time |"
echo "|---|---|"
run isoray-interpolation target/release/isoray implicitize --method interpolation --x "$X" --y "$Y" --z "$Z"
cat >"$TMP/elim.sing" <<SING
ring r = 0, (s,t,x,y,z), dp;
ideal I = x - ($X), y - ($Y), z - ($Z);
ideal J = eliminate(I, s*t);
size(J);
quit;
SING
run singular-eliminate Singular -q "$TMP/elim.sing"
run isoray-groebner target/release/isoray implicitize --method groebner --x "$X" --y "$Y" --z "$Z"
echo
echo "machine: $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) cores; $(date -u +%Y-%m-%d); commit $(git rev-parse --short HEAD)"
