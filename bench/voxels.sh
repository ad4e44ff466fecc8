#!/usr/bin/env bash
# Depth and normals of fidget's models beside fidget (issue 19): `isoray
# depth` against fidget 0.5.1's voxel renderer with its JIT and its VM
# evaluator (bench/voxels/fidget-render3d, built here from crates.io outside
# the workspace), on exactly the same work: the same model, image size,
# voxels per column, view matrix (model = Ry(yaw)·Rz(roll)·Rx(pitch)·world/scale)
# and thread count. Each run is a whole process; the table gives the median
# of REPS runs (default 3) of the wall time, and of the render time each
# program reports (without loading), and the share of pixels whose depth
# agrees with fidget's VM within one gray level. A run past TIMEOUT seconds
# (default 60) counts as "> TIMEOUT".
#
# Views: fidget's recommended ones, except the bear at scale 1.0 instead of
# 0.222: in fidget's own transform 0.222 leaves the bear 2 % of the image
# (4,823 pixels at 512², in fidget and in isoray alike), and there fidget's
# interval pruning fails (VM 19.5 s, JIT more than 60 s at 512³).
#
#   bench/voxels.sh                 # colonnade and bear at 512² and 1024², 2 threads
#   THREADS=1 REPS=5 bench/voxels.sh
set -euo pipefail
REPS=${REPS:-3}
TIMEOUT=${TIMEOUT:-60}
THREADS=${THREADS:-2}
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
cargo build --release -q -p isoray >&2
CARGO_TARGET_DIR=bench/out/fidget-target cargo build --release -q --manifest-path bench/voxels/fidget-render3d/Cargo.toml >&2
FIDGET=bench/out/fidget-target/release/fidget-render3d
# The depth comparison reads PNGs with Pillow (PyPI).
python3 -c 'import PIL' 2>/dev/null || python3 -m pip install -q --user pillow >&2 || python3 -m pip install -q --user --break-system-packages pillow >&2 || true
TMP=$(mktemp -d "${TMPDIR:-/tmp}/isoray-voxels.XXXXXX")
trap 'rm -rf "$TMP"' EXIT

# name, model, scale, pitch, yaw, roll (fidget's recommended views)
CASES=("colonnade colonnade 0.7 60 0 30" "bear bear 1.0 -25 30 0")
SIZES=(512 1024)

# median of numbers; any "> T" entry (a timeout) makes it "> T"
median() {
  if printf '%s\n' "$@" | grep -q '>'; then echo "> $TIMEOUT"; return; fi
  printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END { printf "%.3f", v[int((NR + 1) / 2)] }'
}
# wall seconds of a command (output kept in $TMP/last.out), "> T" past TIMEOUT
wall() {
  local t0 t1 rc=0
  t0=$(date +%s%N)
  timeout "$TIMEOUT" "$@" >"$TMP/last.out" 2>&1 || rc=$?
  t1=$(date +%s%N)
  if [ "$rc" != 0 ]; then echo "> $TIMEOUT"; : >"$TMP/last.out"; return; fi
  awk -v ns=$((t1 - t0)) 'BEGIN { printf "%.3f", ns / 1e9 }'
}
# the number a program printed (sed expression), or "> T" when it timed out
printed() { local v; v=$(sed -n "$1" "$TMP/last.out"); echo "${v:-> $TIMEOUT}"; }

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), commit $(git rev-parse --short HEAD), $(date -u '+%Y-%m-%d'), $THREADS threads, median of $REPS"
echo
echo "| model | size³ | isoray wall s | fidget JIT wall s | fidget VM wall s | isoray render s | JIT render s | VM render s | isoray / JIT (render) | depth agrees with VM |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for c in "${CASES[@]}"; do
  read -r name model scale pitch yaw roll <<<"$c"
  printf '[surface.m]\nvm = "%s"\n\n[[object]]\nshape = "m(p)"\n' "$ROOT/bench/models/$model.vm" >"$TMP/$name.toml"
  for n in "${SIZES[@]}"; do
    iw=(); ir=(); jw=(); jr=(); vw=(); vr=()
    for _ in $(seq "$REPS"); do
      rm -f "$TMP/iso.png" "$TMP/vm.png"
      iw+=("$(wall target/release/isoray depth "$TMP/$name.toml" -o "$TMP/iso.png" --size "$n" --scale "$scale" --pitch "$pitch" --yaw "$yaw" --roll "$roll" --threads "$THREADS")")
      ir+=("$(printed 's/.* in \([0-9.]*\) s:.*/\1/p')")
      jw+=("$(wall "$FIDGET" "bench/models/$model.vm" "$n" "$n" "$scale" "$pitch" "$yaw" "$roll" jit "$THREADS" "$TMP/jit.png")")
      jr+=("$(printed 's/^render: \([0-9.]*\) s/\1/p')")
      vw+=("$(wall "$FIDGET" "bench/models/$model.vm" "$n" "$n" "$scale" "$pitch" "$yaw" "$roll" vm "$THREADS" "$TMP/vm.png")")
      vr+=("$(printed 's/^render: \([0-9.]*\) s/\1/p')")
    done
    agree=$(python3 - "$TMP/iso.png" "$TMP/vm.png" <<'PY'
import sys
from PIL import Image
a = Image.open(sys.argv[1]).convert("L").tobytes()
b = Image.open(sys.argv[2]).convert("L").tobytes()
print(f"{100 * sum(abs(x - y) <= 1 for x, y in zip(a, b)) / len(a):.2f} %")
PY
) || agree="—"
    ir_m=$(median "${ir[@]}"); jr_m=$(median "${jr[@]}")
    ratio=$(awk -v a="$ir_m" -v b="$jr_m" 'BEGIN { if (a ~ />/) print "—"; else if (b ~ />/) printf "< %.3f", a / substr(b, 3); else printf "%.2f", a / b }')
    echo "| $name | $n | $(median "${iw[@]}") | $(median "${jw[@]}") | $(median "${vw[@]}") | $ir_m | $jr_m | $(median "${vr[@]}") | $ratio | $agree |"
  done
done
