#!/usr/bin/env bash
# GPU renderer on Mesa's lavapipe against the CPU renderer, side by side in
# one run (docs/BENCHMARKS.md, "GPU renderer: frame times on lavapipe"):
# the showcase and the Unity thesis's Primitives (its four effect sets) at
# 640x480, median frame times, and the latency of a parameter change and of
# a structural edit.
#   bash bench/gpu/lavapipe.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
source bench/gpu/effects.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release -q -p isoray-gpu --example gpu_frames
F=target/release/examples/gpu_frames
N="${FRAMES:-5}"
echo "# $(nproc) cores; $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
"$F" examples/showcase.toml --size 640x480 --frames "$N" --warmup 1 --cpu "$N" --latency --label showcase
for t in 1 2 3 4; do
  # shellcheck disable=SC2046
  "$F" examples/realtime/primitives.toml --size 640x480 --frames "$N" --warmup 1 --cpu "$N" --label "Primitives T$t" $(effect_args "$t")
done
