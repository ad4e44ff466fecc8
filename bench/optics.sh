#!/usr/bin/env bash
# Side-by-side benchmark of recursive ray tracing: isoray vs POV-Ray 3.7 on
# bench/optics.toml / bench/optics.pov (red mirror sphere, glass sphere with
# Fresnel, torus, checker floor, one point light).
#
#   bench/optics.sh             # from anywhere; REPS=5 bench/optics.sh for more runs
#
# 1. installs the peer (bench/install-peers.sh: apt-get install povray),
# 2. builds isoray (cargo build --release -p isoray),
# 3. renders bench/optics.toml with isoray (the torus, the spheres and the
#    checker floor all sphere-traced SDFs) and bench/optics.pov with POV-Ray
#    (the torus an isosurface with the same SDF, the rest native objects) at
#    1280x720, recursion depth 5, no antialiasing, hard shadows, REPS times
#    each, the tools alternating,
# 4. prints a markdown table of median wall times and of the rays traced per
#    second by kind (also saved to bench/out/optics.md) and copies the two
#    images to bench/out/optics-isoray.png and bench/out/optics-pov.png.
#
# Wall time is measured around the whole process (parse + build + render +
# PNG write) with `date +%s.%N`.  POV-Ray runs with 2 render threads (+WT2),
# no display, no anti-aliasing; isoray uses its default thread count (all
# cores).  Rays by kind come from isoray's `rays:` line and POV-Ray's render
# statistics; both are divided by the renderer's own render time (isoray's
# summary line, POV-Ray's "Trace Time"), which excludes start-up, parsing and
# the PNG write.
set -euo pipefail

NAME=optics
# shellcheck source=bench/common.sh
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

# Names, settings and command lines, in table order.  {OUT} is replaced by a
# per-case PNG path in $TMP.  Case 0 is POV-Ray, case 1 the like-for-like
# isoray run (the floor a plane with a checker material, as POV's checker).

ISO_BASE="$ISORAY render bench/optics.toml -o {OUT} --width $W --height $H"
add_case "POV-Ray 3.7" "native spheres + plane, isosurface torus, depth 5, hard shadows, no AA, 2 threads" \
  "povray +Ibench/optics.pov +O{OUT} +W$W +H$H -A +WT2 -D -V +FN"
add_case "isoray" "SDF scene (plane and spheres recognised and intersected in closed form, torus sphere-traced), checker material, depth 5, hard shadows, no AO, aa 1 (same work as POV)" \
  "$ISO_BASE"


# isoray: "rays: N primary (..), N reflected (..), N refracted (..), N shadow (..)"
# -> "primary reflected refracted shadow" counts; render seconds from the summary.
iso_counts() {
  grep -m1 '^rays:' "$1" | awk '{ for (i = 1; i < NF; i++)
      if ($(i + 1) ~ /^(primary|reflected|refracted|shadow)$/) c[$(i + 1)] = $i
    } END { print c["primary"], c["reflected"], c["refracted"], c["shadow"] }'
}
iso_secs() { grep -m1 '^rendered ' "$1" | sed -n 's/.* in \([0-9.]*\) s:.*/\1/p'; }
# POV-Ray statistics: primary = pixels (no AA), reflected, refracted, shadow ray tests.
pov_counts() {
  tr '\r' '\n' <"$1" | awk '
    /^Pixels:/            { p = $2 }
    /^Reflected Rays:/    { r = $3 }
    /^Refracted Rays:/    { t = $3 }
    /^Shadow Ray Tests:/  { s = $4 }
    END { print p, r, t, s }'
}
pov_secs() { tr '\r' '\n' <"$1" | sed -n 's/^ *Trace Time:.*(\([0-9.]*\) seconds).*/\1/p' | head -n1; }

LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)
declare -A TIMES=()
ISO_RENDER=()
POV_TRACE=()
ISO_COUNTS=""
POV_COUNTS=""
for ((r = 1; r <= REPS; r++)); do
  for i in "${!NAMES[@]}"; do
    out="$TMP/case$i.png"
    log="$TMP/log$i"
    cmd=${CMDS[$i]//\{OUT\}/$out}
    echo "optics: run $r/$REPS [${NAMES[$i]}: ${SETTINGS[$i]}]: $cmd" >&2
    rm -f "$out"
    t0=$(now)
    if ! $cmd >"$log" 2>&1; then
      echo "optics: command failed: $cmd" >&2
      tail -n 40 "$log" >&2
      exit 1
    fi
    t1=$(now)
    [ -s "$out" ] || { echo "optics: no image written by: $cmd" >&2; exit 1; }
    t=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')
    echo "optics:   ${t} s" >&2
    TIMES[$i]="${TIMES[$i]:-}${TIMES[$i]:+ }$t"
    case $i in
      0)
        POV_TRACE+=("$(pov_secs "$log")")
        POV_COUNTS=$(pov_counts "$log")
        ;;
      1)
        ISO_RENDER+=("$(iso_secs "$log")")
        c=$(iso_counts "$log")
        [ -n "$ISO_COUNTS" ] && [ "$c" != "$ISO_COUNTS" ] && echo "optics: warning: isoray ray counts differ between runs: $ISO_COUNTS / $c" >&2
        ISO_COUNTS=$c
        ;;
    esac
  done
done
LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg)

[ -n "$ISO_COUNTS" ] && [ "${ISO_COUNTS// /}" != "" ] || { echo "optics: no 'rays:' line from isoray" >&2; exit 1; }

cp "$TMP/case0.png" bench/out/optics-pov.png
cp "$TMP/case1.png" bench/out/optics-isoray.png

MEDIANS=()
for i in "${!NAMES[@]}"; do
  # shellcheck disable=SC2086
  MEDIANS+=("$(median ${TIMES[$i]})")
done
POV_MED=${MEDIANS[0]}
ISO_MED=${MEDIANS[1]}
ISO_RENDER_MED=$(median "${ISO_RENDER[@]}")
POV_TRACE_MED=$(median "${POV_TRACE[@]}")

machine_facts

{
  echo "## isoray vs POV-Ray: recursive ray tracing, bench/optics.toml at ${W}x${H}"
  echo
  echo "Machine: ${CPU:-unknown CPU}, $(nproc) cores ($(uname -sr)). $POV_VER; ${ISO_VER:-isoray} (git $REV$DIRTY)."
  echo "Median wall time of $REPS runs per row (whole process: parse, render, PNG write), the tools alternating."
  echo "Load average before the timed runs: $LOAD_BEFORE; after: $LOAD_AFTER (the timed job itself adds ~2)."
  echo
  echo "| tool | settings | median s | runs s | POV / isoray |"
  echo "|---|---|---:|---|---:|"
  for i in "${!NAMES[@]}"; do
    ratio=$(awk -v p="$POV_MED" -v m="${MEDIANS[$i]}" 'BEGIN { printf "%.2f", p / m }')
    echo "| ${NAMES[$i]} | ${SETTINGS[$i]} | ${MEDIANS[$i]} | ${TIMES[$i]} | ${ratio} |"
  done
  echo
  awk -v p="$POV_MED" -v m="$ISO_MED" 'BEGIN {
    r = p / m
    printf "Speed ratio POV / isoray (like-for-like rows, wall time): **%.2f** (target >= 1.5: %s).\n", r, (r >= 1.5 ? "met" : "NOT met") }'
  echo "Render time alone (median): isoray ${ISO_RENDER_MED} s (summary line), POV-Ray ${POV_TRACE_MED} s (Trace Time)."
  echo
  echo "Rays traced by kind (same image, depth 5); rays/s = rays / the renderer's own render time (median):"
  echo
  echo "| kind | isoray rays | isoray M rays/s | POV-Ray rays | POV-Ray M rays/s |"
  echo "|---|---:|---:|---:|---:|"
  read -r ip irf irr ish <<<"$ISO_COUNTS"
  read -r pp prf prr psh <<<"$POV_COUNTS"
  for k in primary reflected refracted shadow total; do
    case $k in
      primary) a=$ip; b=$pp ;;
      reflected) a=$irf; b=$prf ;;
      refracted) a=$irr; b=$prr ;;
      shadow) a=$ish; b=$psh ;;
      total) a=$((ip + irf + irr + ish)); b=$((pp + prf + prr + psh)) ;;
    esac
    awk -v k="$k" -v a="$a" -v b="$b" -v ta="$ISO_RENDER_MED" -v tb="$POV_TRACE_MED" \
      'BEGIN { printf "| %s | %d | %.3f | %d | %.3f |\n", k, a, a / ta / 1e6, b, b / tb / 1e6 }'
  done
  echo
  echo "Commands (run from the repository root; images go to a temp dir, the first two are copied to bench/out/optics-pov.png and bench/out/optics-isoray.png):"
  echo
  echo '```'
  echo "REPS=$REPS bench/optics.sh"
  for i in "${!NAMES[@]}"; do
    echo "${CMDS[$i]//\{OUT\}/<tmp>/case$i.png}"
  done
  echo '```'
} | tee bench/out/optics.md
