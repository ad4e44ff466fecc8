#!/usr/bin/env bash
# Implicitization beside Singular's eliminate (issue 18): the documented
# surfaces and ten random rational parametrizations (fixed seed, degrees 1
# to 3, a different denominator per coordinate) from
# bench/algebra/implicit.py. Each program runs once per case in its own
# process, single-threaded (RAYON_NUM_THREADS=1); wall seconds and peak RSS
# from /usr/bin/time, a timeout per run (TIMEOUT, default 120 s). isoray runs
# the default --method auto (the method it chose in brackets), --method
# resultant and --method groebner; every answer is compared exactly
# (equal up to a rational factor) with Singular's generator of the
# elimination ideal, or, where Singular timed out, with the other isoray
# method's; where neither finished, the answer is evaluated exactly at the
# images of eight random rational points (bench/algebra/implicit.py vanishes).
#
#   bench/algebra-implicit.sh
#   TIMEOUT=600 bench/algebra-implicit.sh
set -euo pipefail
TIMEOUT=${TIMEOUT:-120}
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
bench/install-peers.sh >&2
cargo build --release -q -p isoray >&2
TMP=$(mktemp -d "${TMPDIR:-/tmp}/isoray-implicit.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
cp target/release/isoray "$TMP/isoray"
export RAYON_NUM_THREADS=1

# run NAME CMD..., num X: see bench/algebra/timed.sh
source bench/algebra/timed.sh
ratio() { num "$1" && num "$2" && awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / (b > 0.005 ? b : 0.005) }' || echo "—"; }

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), commit $(git rev-parse --short HEAD), $(date -u '+%Y-%m-%d'), one thread each"
echo "peer: $(Singular --version 2>&1 | grep -m1 -o 'version [0-9.]*' || true) (Singular, eliminate)"
echo
echo "| case | parametrization | isoray auto s (chose) | isoray resultant s | isoray groebner s | Singular s | auto / Singular | peak MiB auto / resultant / groebner / Singular | exact check |"
echo "|---|---|---|---|---|---|---|---|---|"
python3 bench/algebra/implicit.py cases "$TMP" | while IFS='|' read -r name x y z; do
  IFS='|' read -r at am <<<"$(run auto "$TMP/isoray" implicitize --stats --x "$x" --y "$y" --z "$z")"
  chose=$(sed -n 's/^method: \([a-z]*\).*/\1/p' "$TMP/auto.err")
  IFS='|' read -r rt rm <<<"$(run res "$TMP/isoray" implicitize --method resultant --x "$x" --y "$y" --z "$z")"
  IFS='|' read -r gt gm <<<"$(run gro "$TMP/isoray" implicitize --method groebner --x "$x" --y "$y" --z "$z")"
  IFS='|' read -r st sm <<<"$(run sing Singular -q --no-rc "$TMP/$name.sing")"
  check=""
  ref=""
  refname=""
  if num "$st"; then ref="$TMP/sing.out"; refname=Singular; elif num "$gt"; then ref="$TMP/gro.out"; refname=groebner; fi
  for m in auto res gro; do
    case $m in
      auto) t=$at; label=auto ;;
      res) t=$rt; label=resultant ;;
      *) t=$gt; label=groebner ;;
    esac
    if ! num "$t"; then continue; fi
    if [ -z "$ref" ]; then
      if python3 bench/algebra/implicit.py vanishes "$TMP/$m.out" "$x" "$y" "$z"; then check+="$label vanishes at 8 random points (no peer finished); "; else check+="$label DOES NOT VANISH; "; fi
      continue
    fi
    if [ "$ref" = "$TMP/$m.out" ]; then continue; fi
    if python3 bench/algebra/implicit.py same "$TMP/$m.out" "$ref"; then check+="$label = $refname; "; else check+="$label DIFFERS; "; fi
  done
  echo "| $name | \`$x, $y, $z\` | $at (${chose:-?}) | $rt | $gt | $st | $(ratio "$at" "$st") | $am / $rm / $gm / $sm | ${check%; } |"
done
