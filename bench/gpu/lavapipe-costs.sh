#!/usr/bin/env bash
# What a software Vulkan driver (lavapipe) charges for the constructs the
# GPU tracer is made of: branches no lane takes, loops, storage against
# uniform buffer reads (docs/BENCHMARKS.md, "What lavapipe charges").
# Prints two Markdown tables; about a minute on two cores.
#
#   bash bench/gpu/lavapipe-costs.sh
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$ROOT"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
echo "# $(nproc) cores; $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); $(date -u +%Y-%m-%d); $(git rev-parse --short HEAD)$(git diff --quiet || echo +)"
cargo run --release -q -p isoray-gpu --example lavapipe_costs
