#!/usr/bin/env bash
# The CPU sphere tracer before and after region pruning (issue 19), side by
# side in one run:
#
#   bench/tracer.sh                                  # REPS=3 by default
#   BEFORE=bench/out/isoray-658fa58 bench/tracer.sh  # also an older build
#
# Scenes: examples/gallery.toml at 640x360, examples/showcase.toml and
# bench/optics.toml at their own size, and the generated scaling scenes of
# bench/tracer/spheres.sh (10 and 1000 spheres joined by render.blend,
# 320x180). Each runs with `render.prune` on and off (the same binary), and
# with BEFORE when given; whole-process wall times, median of REPS, the
# variants alternating. Prints a markdown table and checks that every
# variant wrote the same image.
set -euo pipefail
REPS=${REPS:-3}
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
cargo build --release -q -p isoray >&2
ISORAY=target/release/isoray
TMP=$(mktemp -d "${TMPDIR:-/tmp}/isoray-tracer.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
bench/tracer/spheres.sh 10 >"$TMP/spheres-10.toml"
bench/tracer/spheres.sh 1000 >"$TMP/spheres-1000.toml"

CASES=("gallery|examples/gallery.toml --width 640 --height 360"
  "showcase|examples/showcase.toml"
  "optics|bench/optics.toml"
  "10 spheres|$TMP/spheres-10.toml"
  "1000 spheres|$TMP/spheres-1000.toml")
VARIANTS=("pruned|$ISORAY|" "unpruned|$ISORAY|--set render.prune=false")
[ -n "${BEFORE:-}" ] && VARIANTS+=("before ($(basename "$BEFORE"))|$BEFORE|")

median() { printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END { printf "%.3f", v[int((NR + 1) / 2)] }'; }
wall() {
  local t0 t1
  t0=$(date +%s%N)
  "$@" >/dev/null 2>&1
  t1=$(date +%s%N)
  awk -v ns=$((t1 - t0)) 'BEGIN { printf "%.3f", ns / 1e9 }'
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), commit $(git rev-parse --short HEAD), $(date -u '+%Y-%m-%d'), median of $REPS, load $(cut -d' ' -f1-3 /proc/loadavg)"
echo
header="| scene |"
rule="|---|"
for v in "${VARIANTS[@]}"; do header+=" ${v%%|*} s |"; rule+="---:|"; done
echo "$header same image |"
echo "$rule---|"
declare -A MED=()
for c in "${CASES[@]}"; do
  name=${c%%|*}
  args=${c#*|}
  declare -A T=()
  for _ in $(seq "$REPS"); do
    for i in "${!VARIANTS[@]}"; do
      IFS='|' read -r _ bin extra <<<"${VARIANTS[$i]}"
      # shellcheck disable=SC2086
      T[$i]+=" $(wall "$bin" render $args $extra -q -o "$TMP/out$i.png")"
    done
  done
  row="| $name |"
  for i in "${!VARIANTS[@]}"; do
    # shellcheck disable=SC2086
    m=$(median ${T[$i]})
    MED["$name|$i"]=$m
    row+=" $m |"
  done
  same=yes
  for i in "${!VARIANTS[@]}"; do cmp -s "$TMP/out0.png" "$TMP/out$i.png" || same=no; done
  echo "$row $same |"
  unset T
done
echo
for i in "${!VARIANTS[@]}"; do
  a=${MED["1000 spheres|$i"]}
  b=${MED["10 spheres|$i"]}
  echo "${VARIANTS[$i]%%|*}: 1000 spheres / 10 spheres = $(awk -v a="$a" -v b="$b" 'BEGIN { printf "%.1f", a / b }')x"
done
