#!/usr/bin/env bash
# The GPU renderer on a real GPU (an NVIDIA one where the device tool lends
# it): at most 5 minutes from a clean checkout. Builds with the GPU feature,
# renders the Unity thesis's Primitives at its five resolutions and four
# effect sets, plus 1920x1080 and 3840x2160, and the showcase, each as the
# median GPU time (timestamp queries) of 100 frames after 10 warm-up
# frames, and prints one table beside the thesis's GTX 1070 figures.
#   bash bench/gpu/device.sh            (FRAMES=100 WARMUP=10 by default)
# A machine without Rust (the device tool's): build here with
#   cargo build --release -p isoray-gpu --example gpu_frames
#   cargo build --release -p isoray-studio --example latency
#   cargo build --release -p isoray
# copy the three binaries into an ignored folder that travels (.devbin/), and
# there run: cp .devbin/* target/release/examples/ && NO_BUILD=1 bash bench/gpu/device.sh
# (with the Vulkan loader unpacked first; see the device tool's README).
set -euo pipefail
cd "$(dirname "$0")/../.."
source bench/gpu/effects.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
FRAMES="${FRAMES:-100}"
WARMUP="${WARMUP:-10}"
if [ ! -x target/release/examples/gpu_frames ] || [ -z "${NO_BUILD:-}" ]; then
  command -v cargo >/dev/null || { echo "no cargo here: build the gpu_frames example elsewhere and set NO_BUILD=1" >&2; exit 1; }
  cargo build --release -q -p isoray-gpu --example gpu_frames
fi
F=target/release/examples/gpu_frames
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version --format=csv,noheader || true
# The thesis's Test 1-4 figures for Primitives (ms, whole Unity frames on a GTX 1070, D3D11).
declare -A THESIS=(
  [-,1280x720]=83.2
  [1,640x480]=18.7 [1,800x600]=24.9 [1,1280x720]=35.7 [1,1280x1024]=45.0 [1,1600x1024]=50.1
  [2,640x480]=18.3 [2,800x600]=22.4 [2,1280x720]=31.9 [2,1280x1024]=40.5 [2,1600x1024]=47.3
  [3,640x480]=14.2 [3,800x600]=20.7 [3,1280x720]=26.1 [3,1280x1024]=33.4 [3,1600x1024]=42.1
  [4,640x480]=11.3 [4,800x600]=11.7 [4,1280x720]=18.2 [4,1280x1024]=20.1 [4,1600x1024]=25.1
)
printf '| scene | test | size | GPU ms (median of %s) | frame wall ms | thesis GTX 1070 ms |\n|---|---|---|---|---|---|\n' "$FRAMES"
row() { # label test size args...
  local label=$1 t=$2 size=$3; shift 3
  local line gpu wall
  line=$("$F" "$@" --size "$size" --frames "$FRAMES" --warmup "$WARMUP")
  gpu=$(sed -n 's/.*gpu_ms=\([^\t]*\).*/\1/p' <<<"$line")
  wall=$(sed -n 's/.*wall_ms=\([^\t]*\).*/\1/p' <<<"$line")
  printf '| %s | %s | %s | %s | %s | %s |\n' "$label" "$t" "$size" "$gpu" "$wall" "${THESIS[$t,$size]:--}"
}
for t in 1 2 3 4; do
  for size in 640x480 800x600 1280x720 1280x1024 1600x1024; do
    # shellcheck disable=SC2046
    row Primitives "$t" "$size" examples/realtime/primitives.toml $(effect_args "$t")
  done
done
row Primitives 1 1920x1080 examples/realtime/primitives.toml
row Primitives 1 3840x2160 examples/realtime/primitives.toml
row showcase - 960x540 examples/showcase.toml
row showcase - 1920x1080 examples/showcase.toml
# Animation (issue 16): the walking character at the thesis's resolutions
# (its Character scene: 83.2 ms at 1280x720 on a GTX 1070; target <= 4 ms),
# each frame moved to its time by the tracks and bones before it is drawn,
# and the skeleton stress scene, 1,000 primitives on 200 bones at 1920x1080
# (target: 60 frames per second or better).
for size in 640x480 800x600 1280x720 1280x1024 1600x1024; do
  row Character - "$size" examples/realtime/character.toml
done
row "stress: 1,000 primitives on 200 bones" - 1920x1080 bench/gpu/stress-bones.toml
# Meshes inside an SDF scene: the raster prepass for the primary rays
# against walking the meshes' trees for them.
row "meshes (raster prepass)" - 1920x1080 examples/meshes.toml
row "meshes (tree walk)" - 1920x1080 examples/meshes.toml --walk-meshes
NO_BUILD=1 bash bench/gpu/meshes.sh 1920x1080 20 || echo "bench/gpu/meshes.sh failed (is the isoray binary there?)"
"$F" examples/realtime/primitives.toml --size 1280x720 --frames 10 --warmup 2 --latency | grep latency
# The studio's latencies on this GPU (the same measures as on lavapipe).
bash bench/studio/latency.sh
