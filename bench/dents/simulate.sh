#!/usr/bin/env bash
# isoray simulate on examples/dents.toml (a 110 kg ball dropped on the
# dentable plane) at 640x360, 0.5 s at 30 fps, with each renderer: frames
# per second of the whole run (physics, dents, rendering, PNG writing).
#   bash bench/dents/simulate.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -q -p isoray --features physics,gpu
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
OUT=bench/out/dents-simulate
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), commit $(git rev-parse --short HEAD)"
printf '| renderer | frames | seconds | frames/s | of which rendering s | impacts | dents |\n|---|---|---|---|---|---|---|\n'
for r in trace raster gpu; do
  rm -rf "$OUT/$r"
  line=$(target/release/isoray simulate examples/dents.toml -o "$OUT/$r/f_%04d.png" --renderer "$r" \
    --duration 0.5 --fps 30 --maps "$OUT/$r/maps" 2>&1 | grep simulated)
  frames=$(sed -n 's/.*simulated \([0-9]*\) frames.*/\1/p' <<<"$line")
  secs=$(sed -n 's/.* in \([0-9.]*\) s (.*/\1/p' <<<"$line")
  fps=$(sed -n 's/.*(\([0-9.]*\) frames\/s.*/\1/p' <<<"$line")
  rend=$(sed -n 's/.*frames\/s, \([0-9.]*\) s rendering.*/\1/p' <<<"$line")
  imp=$(sed -n 's/.*: \([0-9]*\) impacts.*/\1/p' <<<"$line")
  dents=$(sed -n 's/.*impacts, \([0-9]*\) dents.*/\1/p' <<<"$line")
  printf '| %s | %s | %s | %s | %s | %s | %s |\n' "$r" "$frames" "$secs" "$fps" "$rend" "$imp" "$dents"
done
