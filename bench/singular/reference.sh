#!/usr/bin/env bash
# Reference data for crates/isoray-algebra, computed with Singular, so that the
# crate's tests need no Singular (install it with bench/install-peers.sh).
#
# Writes to crates/isoray-algebra/tests/data/ (or to $1 when given):
#   katsura-N.txt (N = 2..6), cyclic-N.txt (N = 3..6):
#     reduced Groebner basis over Q, degrevlex (Singular `dp`), variables in
#     declaration order (x0 > x1 > ... ; x1 > x2 > ...). Format:
#       # vars: x0,x1,x2 order: grevlex
#       # input:
#       #   <input generator>            (one per line)
#       # basis:
#       <basis element>                  (one per line, monic, terms in dp
#                                          order, elements sorted by leading
#                                          monomial ascending in dp)
#   implicit.txt: one line per parametrization,
#       x=...; y=...; z=... => POLY
#     POLY: the generator of eliminate(I, s*t*w) in Q[x,y,z] (dp), I as in
#     systems.lib/implicitIdeal, made primitive over Z with positive leading
#     coefficient (Singular `cleardenom`).
# Polynomials are in Singular's `short=0` syntax: explicit `*` and `^`,
# coefficients as integers or reduced fractions a/b, no spaces.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="${1:-$root/crates/isoray-algebra/tests/data}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"

if ! command -v Singular >/dev/null; then
  echo "reference: Singular not found; run bench/install-peers.sh" >&2
  exit 1
fi

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# run_singular SCRIPT: run a Singular script, fail on any Singular error.
run_singular() {
  local log="$tmp/log"
  if ! Singular -q -t --no-rc "$1" </dev/null >"$log" 2>&1; then
    cat "$log" >&2
    return 1
  fi
  if grep -q '^ *?' "$log"; then
    echo "reference: Singular reported an error:" >&2
    cat "$log" >&2
    return 1
  fi
  cat "$log"
}

# gb_case NAME N KIND VARS: write $out/NAME.txt (KIND: katsuraIdeal|cyclicIdeal)
gb_case() {
  local name="$1" n="$2" kind="$3" vars="$4"
  local file="$tmp/$name.txt"
  cat >"$tmp/$name.sing" <<SING
LIB "$here/systems.lib";
ring r = 0, ($vars), dp;
ideal I = $kind($n);
ideal G = writeReference("$file", "$vars", I);
"$name: " + string(ncols(I)) + " input, " + string(ncols(G)) + " basis elements";
quit;
SING
  run_singular "$tmp/$name.sing"
  mv "$file" "$out/$name.txt"
}

vars_range() { # vars_range FIRST LAST -> xFIRST,...,xLAST
  local s="" i
  for ((i = $1; i <= $2; i++)); do s+="${s:+,}x$i"; done
  echo "$s"
}

for n in 2 3 4 5 6; do
  gb_case "katsura-$n" "$n" katsuraIdeal "$(vars_range 0 "$n")"
done
for n in 3 4 5 6; do
  gb_case "cyclic-$n" "$n" cyclicIdeal "$(vars_range 1 "$n")"
done

# Implicitization.
file="$tmp/implicit.txt"
cat >"$tmp/implicit.sing" <<SING
LIB "$here/systems.lib";
ring r = 0, (s,t,w,x,y,z), dp;
short = 0;
ring rx = 0, (x,y,z), dp;
short = 0;
setring r;
string f = "$file";
list L = implicitCases();
int i;
ideal I, E;
write(":w " + f, "");   // truncate
for (i = 1; i <= size(L); i++)
{
  setring r;
  I = implicitIdeal(L[i]);
  E = eliminate(I, s*t*w);
  E = simplify(E, 2);
  if (ncols(E) != 1 || size(E) != 1) { ERROR("case " + string(i) + ": not one generator"); }
  setring rx;
  ideal Ex = imap(r, E);
  poly p = cleardenom(Ex[1]);
  if (leadcoef(p) <= 0) { ERROR("case " + string(i) + ": leading coefficient not positive"); }
  string line = L[i][7] + " => " + string(p);
  kill Ex, p;
  setring r;
  write(":a " + f, line);
  line;
  kill line;
}
quit;
SING
run_singular "$tmp/implicit.sing"
# Drop the empty first line left by the truncating write.
sed '1{/^$/d}' "$file" >"$out/implicit.txt"

echo "reference: wrote $out/{katsura-{2..6},cyclic-{3..6},implicit}.txt"
