#!/usr/bin/env bash
# The studio's latencies (docs/BENCHMARKS.md, "Studio: latencies"): a
# headless 1280x800 studio window on the showcase, driven by pointer events,
# with the GPU renderer as its preview (lavapipe without a GPU): open time,
# orbit, slider and node-drag frame times, release to full frame,
# structural edit to frame; then the open time of the largest examples.
#   bash bench/studio/latency.sh          (MOVES=12; extra arguments go to
#                                          the latency example, e.g. --cpu)
set -euo pipefail
cd "$(dirname "$0")/../.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
if [ ! -x target/release/examples/latency ] || [ -z "${NO_BUILD:-}" ]; then
  cargo build --release -q -p isoray-studio --example latency
fi
echo "# $(nproc) cores; $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); commit $(git rev-parse --short HEAD)"
target/release/examples/latency --size 1280x800 --moves "${MOVES:-12}" "$@" \
  examples/showcase.toml examples/algebraic.toml examples/gallery.toml examples/surfaces.toml
