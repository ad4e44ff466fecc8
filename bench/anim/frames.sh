#!/usr/bin/env bash
# Frames per second of `isoray render --frames` against a loop of separate
# `isoray render --time n/fps` processes (docs/BENCHMARKS.md, "Animation"):
# the showcase with one animated parameter (its torus spun by a track on
# params.spin) and the walking character, at 640x360, on the CPU and on the
# GPU (lavapipe without a GPU). Checks that both ways give the same bytes.
#   bash bench/anim/frames.sh              (FRAMES=12; BACKENDS="cpu gpu")
set -euo pipefail
cd "$(dirname "$0")/../.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
FRAMES=${FRAMES:-12}
BACKENDS=${BACKENDS:-cpu gpu}
if [ -z "${NO_BUILD:-}" ]; then
  cargo build --release -q -p isoray --features gpu
fi
ISORAY=$PWD/target/release/isoray
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

# The showcase with one animated parameter: the torus turns once in 2 s.
cp examples/showcase.toml "$WORK/showcase-anim.toml"
cat >> "$WORK/showcase-anim.toml" <<'TOML'

[params]
spin = 0.0

[animation]
fps = 24
duration = 2.0

[[track]]
target = "params.spin"
keys = [[0.0, 0.0], [2.0, 6.283185307179586]]
TOML
SHOWCASE_SET=(--set 'object.1.shape=torus(rotate_x(rotate_y(p - vec3(-2.3, 0.95, -0.2), spin), 1.2), 0.7, 0.22)')

now() { date +%s.%N; }
echo "# $(nproc) cores; $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); commit $(git rev-parse --short HEAD); $FRAMES frames at 640x360"
echo "| scene | backend | --frames 0..$((FRAMES - 1)) | frames/s | $FRAMES separate --time runs | frames/s | ratio | same bytes |"
echo "|---|---|---|---|---|---|---|---|"
run() {
  local name=$1 scene=$2 backend=$3; shift 3
  local args=("$@" --width 640 --height 360 --backend "$backend" -q)
  local d="$WORK/$name-$backend"; mkdir -p "$d"
  local t0 t1 t2
  t0=$(now)
  "$ISORAY" render "$scene" "${args[@]}" --frames 0..$((FRAMES - 1)) -o "$d/f_%04d.png"
  t1=$(now)
  for n in $(seq 0 $((FRAMES - 1))); do
    "$ISORAY" render "$scene" "${args[@]}" --time "$n/24" -o "$d/s_$n.png"
  done
  t2=$(now)
  local same=yes
  for n in $(seq 0 $((FRAMES - 1))); do
    cmp -s "$d/$(printf 'f_%04d.png' "$n")" "$d/s_$n.png" || same=no
  done
  awk -v n="$name" -v b="$backend" -v f="$FRAMES" -v a="$(echo "$t1 - $t0" | bc)" -v l="$(echo "$t2 - $t1" | bc)" -v s="$same" \
    'BEGIN { printf "| %s | %s | %.2f s | %.2f | %.2f s | %.2f | %.2fx | %s |\n", n, b, a, f / a, l, f / l, l / a, s }'
}
for b in $BACKENDS; do
  run "showcase, params.spin on a track" "$WORK/showcase-anim.toml" "$b" "${SHOWCASE_SET[@]}"
  run "character (13 bones, 15 primitives)" examples/realtime/character.toml "$b"
done
