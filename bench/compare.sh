#!/usr/bin/env bash
# Side-by-side benchmark: isoray vs POV-Ray 3.7 on the showcase scene.
#
#   bench/compare.sh            # from anywhere; REPS=5 bench/compare.sh for more runs
#
# 1. installs the peer (bench/install-peers.sh: apt-get install povray),
# 2. builds isoray (cargo build --release -p isoray),
# 3. renders examples/showcase.toml with isoray and bench/showcase.pov (the same
#    SDF as one POV isosurface) at 1280x720, REPS times each, on this machine,
# 4. prints a markdown table of median wall times (also saved to
#    bench/out/results.md) and copies the two baseline images to bench/out/.
#
# Wall time is measured around the whole process (parse + build + render +
# PNG write) with `date +%s.%N`.  POV-Ray runs with 2 render threads (+WT2),
# no display, no anti-aliasing; isoray uses its default thread count.
set -euo pipefail

NAME=compare
# shellcheck source=bench/common.sh
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

# Names, settings and command lines, in table order.  {OUT} is replaced by a
# per-case PNG path in $TMP.

ISO_BASE="$ISORAY render examples/showcase.toml -o {OUT} --width $W --height $H --quiet"
add_case "POV-Ray 3.7" "isosurface, 1 parallel light, hard shadows, no AA, 2 threads" \
  "povray +Ibench/showcase.pov +O{OUT} +W$W +H$H -A +WT2 -D -V +FN"
add_case "isoray" "hard shadows, no AO, aa 1 (baseline, same work as POV)" \
  "$ISO_BASE --aa 1 --set render.shadows=hard --set render.ao=false"
add_case "isoray" "soft shadows, no AO, aa 1" \
  "$ISO_BASE --aa 1 --set render.shadows=soft --set render.ao=false"
add_case "isoray" "soft shadows + AO, aa 1" \
  "$ISO_BASE --aa 1 --set render.shadows=soft --set render.ao=true"
add_case "isoray" "soft shadows + AO, aa 2 (showcase settings)" \
  "$ISO_BASE --aa 2 --set render.shadows=soft --set render.ao=true"


LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)
MEDIANS=()
RUNS=()
for i in "${!NAMES[@]}"; do
  out="$TMP/case$i.png"
  cmd=${CMDS[$i]//\{OUT\}/$out}
  echo "compare: [${NAMES[$i]}: ${SETTINGS[$i]}] $REPS runs: $cmd" >&2
  times=()
  for ((r = 1; r <= REPS; r++)); do
    rm -f "$out"
    t0=$(now)
    if ! $cmd >"$TMP/log" 2>&1; then
      echo "compare: command failed: $cmd" >&2
      tail -n 40 "$TMP/log" >&2
      exit 1
    fi
    t1=$(now)
    [ -s "$out" ] || { echo "compare: no image written by: $cmd" >&2; exit 1; }
    t=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')
    echo "compare:   run $r: ${t} s" >&2
    times+=("$t")
  done
  MEDIANS+=("$(median "${times[@]}")")
  RUNS+=("${times[*]}")
done

cp "$TMP/case0.png" bench/out/pov.png
cp "$TMP/case1.png" bench/out/isoray.png

POV_MED=${MEDIANS[0]}
machine_facts

{
  echo "## isoray vs POV-Ray: examples/showcase.toml at ${W}x${H}"
  echo
  echo "Machine: ${CPU:-unknown CPU}, $(nproc) cores ($(uname -sr)). $POV_VER; ${ISO_VER:-isoray} (git $REV$DIRTY)."
  echo "Median wall time of $REPS runs per row (whole process: parse, render, PNG write)."
  echo "Load average before the timed runs: $LOAD_BEFORE; after: $(cut -d' ' -f1-3 /proc/loadavg) (the timed job itself adds ~2)."
  echo
  echo "| tool | settings | median s | runs s | POV / isoray | x isoray baseline |"
  echo "|---|---|---:|---|---:|---:|"
  for i in "${!NAMES[@]}"; do
    ratio=$(awk -v p="$POV_MED" -v m="${MEDIANS[$i]}" 'BEGIN { printf "%.2f", p / m }')
    rel=$(awk -v b="${MEDIANS[1]}" -v m="${MEDIANS[$i]}" 'BEGIN { printf "%.2f", m / b }')
    echo "| ${NAMES[$i]} | ${SETTINGS[$i]} | ${MEDIANS[$i]} | ${RUNS[$i]} | ${ratio} | ${rel} |"
  done
  echo
  echo "Commands (run from the repository root; images go to a temp dir, the first two are copied to bench/out/pov.png and bench/out/isoray.png):"
  echo
  echo '```'
  echo "REPS=$REPS bench/compare.sh"
  for i in "${!NAMES[@]}"; do
    echo "${CMDS[$i]//\{OUT\}/<tmp>/case$i.png}"
  done
  echo '```'
} | tee bench/out/results.md
