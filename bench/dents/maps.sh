#!/usr/bin/env bash
# Dents in maps (issue 17): the cost of one impact (imprint, height and
# normal updates) against a full recompute of the normal map, and the
# dent-shape error of each imprint method against the analytic spherical
# cap at tilts of 0° to 60°. Prints two markdown tables.
#   bash bench/dents/maps.sh [REPEATS]
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -q -p isoray-dent --example dent_cost --example imprint_error
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), commit $(git rev-parse --short HEAD)"
echo
target/release/examples/dent_cost "${1:-9}"
echo
target/release/examples/imprint_error
