#!/usr/bin/env bash
# Meshes inside an SDF scene on the GPU: the raster prepass for the primary
# rays against walking the meshes' trees for them, and the CPU tracer, on a
# heavy mesh (the CSG example meshed by isoray at resolution 160: 258,528
# triangles) over an SDF floor, hard shadows. Frame wall times on the host
# (lavapipe's timestamps are not reliable once a render pass precedes the
# compute passes). Usage: bash bench/gpu/meshes.sh [WxH] [FRAMES]
set -euo pipefail
cd "$(dirname "$0")/../.."
SIZE="${1:-640x360}"
FRAMES="${2:-5}"
OUT=bench/out/gpu-meshes
mkdir -p "$OUT"
if [ -z "${NO_BUILD:-}" ]; then
  cargo build --release -q -p isoray -p isoray-gpu --example gpu_frames
fi
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
# The isoray binary: built here, or carried prebuilt beside the examples.
ISORAY=target/release/isoray
[ -x "$ISORAY" ] || ISORAY=target/release/examples/isoray
[ -f "$OUT/csg.obj" ] || "$ISORAY" mesh examples/csg.toml -o "$OUT/csg.obj" --resolution 160 >/dev/null
cat > "$OUT/heavy.toml" <<'TOML'
[camera]
position = [3.2, 3.4, 4.6]
target = [0.0, 1.0, 0.0]
[render]
width = 640
height = 360
shadows = "hard"
[[light]]
kind = "directional"
direction = [-0.5, 1.0, 0.6]
[material.floor]
diffuse = [0.55, 0.55, 0.5]
[material.ruby]
diffuse = [0.75, 0.08, 0.1]
[[object]]
shape = "p.y"
material = "floor"
[[mesh]]
file = "csg.obj"
material = "ruby"
TOML
F=target/release/examples/gpu_frames
printf '| renderer | size | frame wall ms (median of %s) |\n|---|---|---|\n' "$FRAMES"
wall() { sed -n 's/.*wall_ms=\([^\t]*\).*/\1/p'; }
cpu() { sed -n 's/.*cpu_ms=\([^\t]*\).*/\1/p'; }
line=$("$F" "$OUT/heavy.toml" --size "$SIZE" --frames "$FRAMES" --warmup 1 --cpu 3)
printf '| GPU, raster prepass for primary rays | %s | %s |\n' "$SIZE" "$(wall <<<"$line")"
printf '| CPU tracer (same process) | %s | %s |\n' "$SIZE" "$(cpu <<<"$line")"
line=$("$F" "$OUT/heavy.toml" --size "$SIZE" --frames "$FRAMES" --warmup 1 --walk-meshes)
printf '| GPU, tree walk for primary rays | %s | %s |\n' "$SIZE" "$(wall <<<"$line")"
sed -n 's/.*adapter=\(.*\)$/adapter: \1/p' <<<"$line"
