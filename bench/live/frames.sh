#!/usr/bin/env bash
# 120 frames of the showcase at 320×180 with one value driven by t (the
# sphere's radius), rendered (a) in one process that loads and compiles
# once and then only moves the time, and (b) by 120 separate cold
# `isoray render --time` runs. Checks that both give the same bytes.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$ROOT"
FRAMES=${FRAMES:-120}
FPS=24
SET=(--set render.width=320 --set render.height=180
     --set 'object.4.shape=sphere(p - vec3(1.35, 0.7, 0.55), 0.6 + 0.15 * sin(3.0 * t))')
cargo build --release -p isoray -p isoray-render --example frames >/dev/null 2>&1
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
t0=$(date +%s.%N)
target/release/examples/frames examples/showcase.toml "$FRAMES" "$FPS" "$TMP/one" "${SET[@]}"
t1=$(date +%s.%N)
mkdir -p "$TMP/many"
for ((n = 0; n < FRAMES; n++)); do
  t=$(python3 -c "print($n / $FPS)")
  target/release/isoray render examples/showcase.toml --time "$t" -q -o "$(printf "$TMP/many/frame%04d.png" "$n")" "${SET[@]}"
done
t2=$(date +%s.%N)
for f in "$TMP"/one/*.png; do
  cmp -s "$f" "$TMP/many/$(basename "$f")" || { echo "frame $(basename "$f") differs" >&2; exit 1; }
done
python3 -c "one = $t1 - $t0; many = $t2 - $t1
print(f'one process: {one:.2f} s; $FRAMES cold runs: {many:.2f} s; ratio {many / one:.2f}; all $FRAMES frames byte-identical')"
