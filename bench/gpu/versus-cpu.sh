#!/usr/bin/env bash
# The GPU renderer against the CPU renderer on every example scene, side by
# side in one run (issue 41's table in docs/BENCHMARKS.md, "The GPU renderer
# beside the CPU renderer"): `isoray render` at 640x360 with `--backend cpu`
# and `--backend gpu`, the render time from each summary line (the GPU's
# includes building its pipeline, with Mesa's shader cache as it is), the
# median of REPS runs, the two backends alternating; the ratio GPU / CPU;
# and how many pixels of the two images differ by more than 8/255.
#
#   bash bench/gpu/versus-cpu.sh                 # REPS=3, every scene
#   REPS=1 bash bench/gpu/versus-cpu.sh showcase # scenes whose path matches
#   GPU_ARGS="--gpu-kernel interpreted" bash bench/gpu/versus-cpu.sh
#   BEFORE=/tmp/isoray-old bash bench/gpu/versus-cpu.sh
#                          # also that build's GPU time, alternating with
#                          # this one's (a column "GPU before s")
# A GPU run longer than GPU_TIMEOUT seconds (default 300) is stopped and
# reported as such (lavapipe may compile a huge shader for many minutes).
#
# A cold shader cache (the first run of a new kernel) is measured by
# COLD=1, which points Mesa at an empty cache folder for every GPU run.
set -euo pipefail
REPS=${REPS:-3}
SIZE=${SIZE:-640x360}
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$ROOT"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release -q -p isoray --features gpu >&2
ISORAY=${ISORAY:-target/release/isoray}
TMP=$(mktemp -d "${TMPDIR:-/tmp}/isoray-versus.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
W=${SIZE%x*}
H=${SIZE#*x}

# Every scene, with what it needs to render (a MIDI take).
SCENES=()
for f in examples/*.toml examples/realtime/*.toml bench/gpu/stress-bones.toml; do
  SCENES+=("$f")
done
extra() {
  case "$1" in
    examples/realtime/midi-scale.toml) echo "--midi examples/realtime/midi-scale.mid --time 2" ;;
    examples/realtime/midi-twist.toml) echo "--midi examples/realtime/midi-twist.mid --time 2" ;;
    *) echo "" ;;
  esac
}
median() { printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END { printf "%.3f", v[int((NR + 1) / 2)] }'; }
# The median of GPU runs, or the first run's failure when one failed.
pick() {
  for x in "$@"; do
    case "$x" in [0-9]*) ;; *) echo "$x"; return ;; esac
  done
  median "$@"
}
ratio_of() { case "$1" in [0-9]*) awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / b }' ;; *) echo "-" ;; esac; }
# The seconds of a summary line: "... in 0.58 s: ...".
seconds() { sed -n 's/.* in \([0-9.]*\) s: .*/\1/p' "$1" | tail -1; }

echo "# $(nproc) cores; $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); $(date -u +%Y-%m-%d); $(git rev-parse --short HEAD)$(git diff --quiet || echo +)"
if [ -n "${BEFORE:-}" ]; then
  printf '| scene | CPU s | GPU before s | GPU s | GPU / CPU before | GPU / CPU | pixels > 8/255 |\n|---|---|---|---|---|---|---|\n'
else
  printf '| scene | CPU s | GPU s | GPU / CPU | pixels > 8/255 |\n|---|---|---|---|---|\n'
fi
LIMIT=${GPU_TIMEOUT:-300}
# One GPU run of binary $1 (its seconds, or "over N s").
gpu_run() {
  local bin=$1 cache=()
  shift
  rm -f "$TMP/gpu.png"
  if [ -n "${COLD:-}" ]; then
    rm -rf "$TMP/mesa"
    cache=(env MESA_SHADER_CACHE_DIR="$TMP/mesa")
  fi
  # shellcheck disable=SC2086
  if timeout "$LIMIT" "${cache[@]}" "$bin" render "$@" --backend gpu ${GPU_ARGS:-} -o "$TMP/gpu.png" >"$TMP/gpu.log" 2>&1; then
    seconds "$TMP/gpu.log"
  elif [ $? = 124 ]; then
    echo "over $LIMIT s"
  else
    echo "failed: $(tail -1 "$TMP/gpu.log")"
  fi
}
for f in "${SCENES[@]}"; do
  if [ $# -gt 0 ]; then
    keep=0
    for pat in "$@"; do [[ "$f" == *"$pat"* ]] && keep=1; done
    [ $keep = 1 ] || continue
  fi
  # shellcheck disable=SC2046
  args=("$f" --width "$W" --height "$H" $(extra "$f"))
  cpu=()
  gpu=()
  before=()
  for ((r = 0; r < REPS; r++)); do
    "$ISORAY" render "${args[@]}" -o "$TMP/cpu.png" >"$TMP/cpu.log" 2>&1 || { echo "| $f | failed on the CPU | | | |"; continue 2; }
    cpu+=("$(seconds "$TMP/cpu.log")")
    # A build that failed or ran out of time is not run again.
    if [ -n "${BEFORE:-}" ] && [[ "${before[0]:-0}" == [0-9]* ]]; then
      before+=("$(gpu_run "$BEFORE" "${args[@]}")")
    fi
    if [[ "${gpu[0]:-0}" == [0-9]* ]]; then
      gpu+=("$(gpu_run "$ISORAY" "${args[@]}")")
    fi
  done
  c=$(median "${cpu[@]}")
  g=$(pick "${gpu[@]}")
  ratio=$(ratio_of "$g" "$c")
  diff=$(python3 - "$TMP/cpu.png" "$TMP/gpu.png" <<'EOF' 2>/dev/null || echo "?"
import sys, zlib, struct
def png(path):
    data = open(path, 'rb').read()
    pos, idat, w, h = 8, b'', 0, 0
    while pos < len(data):
        n, kind = struct.unpack('>I4s', data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b'IHDR':
            w, h, depth, ctype = struct.unpack('>IIBB', body[:10])
            ch = {2: 3, 6: 4}[ctype]
        if kind == b'IDAT':
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride = w * ch
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - ch] if x >= ch else 0
            b = prev[x]
            c = prev[x - ch] if x >= ch else 0
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + b) & 255
            elif f == 3: line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return w, h, ch, rows
w, h, ch, a = png(sys.argv[1])
_, _, _, b = png(sys.argv[2])
off = 0
for y in range(h):
    for x in range(w):
        if max(abs(a[y][x * ch + k] - b[y][x * ch + k]) for k in range(3)) > 8:
            off += 1
print(f"{off} ({100.0 * off / (w * h):.2f} %)")
EOF
)
  [ -f "$TMP/gpu.png" ] || diff="-"
  if [ -n "${BEFORE:-}" ]; then
    b=$(pick "${before[@]}")
    printf '| %s | %s | %s | %s | %s | %s | %s |\n' "$f" "$c" "$b" "$g" "$(ratio_of "$b" "$c")" "$ratio" "$diff"
  else
    printf '| %s | %s | %s | %s | %s |\n' "$f" "$c" "$g" "$ratio" "$diff"
  fi
done
