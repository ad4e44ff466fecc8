#!/usr/bin/env bash
# The cost of dents cut into geometry ([[object.sdf_dent]]): the plane of
# examples/dents.toml with 0, 10, 100 and 1,000 ball dents (radius 0.15,
# depths 5-30 mm, seeded) spread over the view, rendered by the CPU
# tracer at 1280x720 (soft shadows): each dent behind its bounding sphere
# in the tree of skips, and the same dents with bounds so large that
# every dent is evaluated everywhere (what the edits cost without them).
# The undented plane is intersected in closed form; a dented one is
# marched, so "0 (marched)" is the plane marched with analytic = false.
# Best of 3 renders (1 for 1,000 unbounded), wall seconds of the whole command.
#   bash bench/dents/sdf.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -q -p isoray
OUT=bench/out/dents-sdf
mkdir -p "$OUT"
python3 - "$OUT" <<'PY'
import math, random, sys
out = sys.argv[1]
base = open("examples/dents.toml").read()
# Only the plane, and no ball: the dents are the scene.
base = base[: base.index("[[object]]\nname = \"ball\"")]
for n in [0, 10, 100, 1000]:
    rnd = random.Random(7)
    for bounded in [True, False]:
        tables = []
        for _ in range(n):
            x, z = rnd.uniform(-1.5, 1.5), rnd.uniform(-1.5, 1.0)
            d, r = rnd.uniform(0.005, 0.03), 0.15
            rho = math.sqrt(2 * r * d - d * d)
            br = 1.05 * max(rho, d) + 1e-6 if bounded else 1000.0
            tables.append(
                f"[[object.sdf_dent]]\nshape = \"sphere(p, {r})\"\n"
                f"position = [{x!r}, {r - d!r}, {z!r}]\nbound = [{x!r}, {-d / 2!r}, {z!r}, {br!r}]\n"
            )
        name = f"{n}" if bounded else f"{n}-unbounded"
        open(f"{out}/{name}.toml", "w").write(base + "\n".join(tables))
PY
best() {
  local best="" reps=3
  case "$1" in *1000-unbounded*) reps=1 ;; esac
  for _ in $(seq $reps); do
    t0=$(date +%s.%N)
    target/release/isoray render "$1" -o "$OUT/out.png" -q --set render.width=1280 --set render.height=720 "${@:2}"
    s=$(awk "BEGIN{print $(date +%s.%N) - $t0}")
    if [ -z "$best" ] || awk "BEGIN{exit !($s < $best)}"; then best=$s; fi
  done
  echo "$best"
}
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), commit $(git rev-parse --short HEAD)"
printf '| dents | bounded: s | × no dents | unbounded: s | × no dents |\n|---|---|---|---|---|\n'
zero=$(best "$OUT/0.toml")
m=$(best "$OUT/0.toml" --set render.analytic=false)
printf '| 0 (marched) | %.3f | %.2f | | |\n' "$m" "$(awk "BEGIN{print $m/$zero}")"
for n in 0 10 100 1000; do
  b=$(best "$OUT/$n.toml")
  u=$(best "$OUT/$n-unbounded.toml")
  printf '| %s | %.3f | %.2f | %.3f | %.2f |\n' "$n" "$b" "$(awk "BEGIN{print $b/$zero}")" "$u" "$(awk "BEGIN{print $u/$zero}")"
done
