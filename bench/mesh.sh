#!/usr/bin/env bash
# Side-by-side benchmark of mesh extraction: isoray vs fidget (manifold dual
# contouring, crates.io) vs fogleman's sdf (marching cubes, PyPI `sdflab`) on
# the CSG classic (sphere r 1.35 ∩ box of half extent 1, minus three cylinders
# of radius 0.55 along x, y and z; centred at the origin).
#
#   bench/mesh.sh               # from anywhere; REPS=5 bench/mesh.sh for more runs
#
# 1. installs the peers (bench/install-peers.sh: pip install sdflab, ...),
# 2. builds isoray (cargo build --release -p isoray) and the fidget harness
#    (bench/mesh/fidget-harness, its own Cargo project, built into
#    bench/out/fidget-target),
# 3. meshes the part with each tool at three resolutions chosen so that the
#    triangle counts line up (about 50k, 200k and 800k triangles; the
#    resolution of each tool per target is set below), REPS times each, the
#    tools alternating; each writes a binary STL to bench/out/mesh/,
# 4. measures the surface error of every mesh with one independent evaluator
#    (bench/mesh/error.py: the analytic SDF at the unique vertices, and at 7
#    points of every triangle),
# 5. prints a markdown table (also saved to bench/out/mesh.md).
#
# Time: wall time of the whole process (start-up, meshing, STL write) with
# `date +%s.%N`, median of REPS; peak RSS: GNU time's %M (maximum resident set
# size), the largest of the REPS runs.  Threads: every tool uses all cores
# (isoray its default, fidget rayon's global pool, sdf
# multiprocessing.cpu_count() worker threads).  "own s" is the meshing time the
# tool reports itself (no start-up, no STL write), median.
#
# isoray's side: `isoray mesh SCENE OBJECT -o OUT.stl --resolution N` (N cells
# along the longest side of the bounds it finds).  If this isoray has no `mesh`
# subcommand yet, its rows are skipped with a warning.
set -euo pipefail

NAME=mesh
# shellcheck source=bench/common.sh
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

# ---- Settings per target triangle count (edit here) -------------------------
TARGETS=(50k 200k 800k)
# isoray: --resolution N (cells along the longest side; triangles ~ N^2).
# First guesses (a marching-cubes grid of N = 2.1 / step cells gives the
# counts): tune them to the triangle counts isoray actually writes.
ISO_RES=(64 128 256)
# fidget: "DEPTH BOUND": octree depth, meshed cube [-BOUND, BOUND]^3; finest
# cell 2 BOUND / 2^DEPTH.  Its triangle count is far from smooth in the cell
# size (it merges cells on flat faces, depending on how they align), so BOUND
# is the fine knob: measured here, 6 1.3 -> 53k, 8 1.5 -> 233k, 8 1.05 -> 881k.
FIDGET_RES=("6 1.3" "8 1.5" "8 1.05")
# sdf: grid step over [-1.05, 1.05]^3 (triangles ~ 16 / step^2 here).
SDFLAB_STEP=(0.035 0.0178 0.0089)
# ------------------------------------------------------------------------------

GNU_TIME=/usr/bin/time
"$GNU_TIME" --version 2>&1 | grep -q GNU || { echo "mesh: GNU time ($GNU_TIME) not found; run bench/install-peers.sh" >&2; exit 1; }

FIDGET_TARGET=bench/out/fidget-target
CARGO_TARGET_DIR=$FIDGET_TARGET cargo build --release --manifest-path bench/mesh/fidget-harness/Cargo.toml
FIDGET=$FIDGET_TARGET/release/fidget-csg
[ -x "$FIDGET" ] || { echo "mesh: $FIDGET not found after build" >&2; exit 1; }

HAVE_ISO=1
if ! "$ISORAY" help mesh >/dev/null 2>&1; then
  HAVE_ISO=0
  echo "mesh: warning: $ISORAY has no 'mesh' subcommand; skipping isoray" >&2
fi

OUTDIR=bench/out/mesh
mkdir -p "$OUTDIR"
rm -f "$OUTDIR"/*.stl

# Cases, in table order: per target isoray, fidget, sdf.  {OUT} is the STL path.
FILES=()
TOOLS=()
TGT=()
for t in "${!TARGETS[@]}"; do
  tg=${TARGETS[$t]}
  if [ "$HAVE_ISO" = 1 ]; then
    add_case "isoray" "--resolution ${ISO_RES[$t]}" \
      "$ISORAY mesh bench/mesh/csg.toml csg -o {OUT} --resolution ${ISO_RES[$t]}"
    FILES+=("$OUTDIR/isoray-$tg.stl"); TOOLS+=(isoray); TGT+=("$t")
  fi
  read -r depth bound <<<"${FIDGET_RES[$t]}"
  add_case "fidget" "depth $depth, cube ±$bound" "$FIDGET $depth {OUT} $bound"
  FILES+=("$OUTDIR/fidget-$tg.stl"); TOOLS+=(fidget); TGT+=("$t")
  add_case "sdf (sdflab)" "step ${SDFLAB_STEP[$t]}" \
    "python3 bench/mesh/sdflab_csg.py ${SDFLAB_STEP[$t]} {OUT}"
  FILES+=("$OUTDIR/sdflab-$tg.stl"); TOOLS+=(sdflab); TGT+=("$t")
done

# The tool's own meshing time from its log (seconds), or "".
own_secs() {
  case $1 in
    fidget) sed -n 's/^time:.* total \([0-9.]*\) s.*/\1/p' "$2" | head -n1 ;;
    sdflab) tr '\r' '\n' <"$2" | sed -n 's/^[0-9]* triangles in \([0-9.e+-]*\) seconds.*/\1/p' | head -n1 ;;
    # isoray: the first number of seconds on a line that names a time.
    isoray) grep -m1 -iE '^(time|meshed|mesh)\b.*[0-9.]+ ?s\b' "$2" | grep -oE '[0-9]+(\.[0-9]+)? ?s\b' | head -n1 | tr -d ' s' || true ;;
  esac
}
# Triangle count from a binary STL header.
stl_tris() { od -An -t u4 -j 80 -N 4 "$1" | tr -d ' '; }

LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)
declare -A TIMES=() RSS=() OWN=()
for ((r = 1; r <= REPS; r++)); do
  for i in "${!NAMES[@]}"; do
    out=${FILES[$i]}
    log="$TMP/log$i"
    cmd=${CMDS[$i]//\{OUT\}/$out}
    echo "mesh: run $r/$REPS [${NAMES[$i]}: ${SETTINGS[$i]}]: $cmd" >&2
    rm -f "$out"
    t0=$(now)
    # shellcheck disable=SC2086
    if ! "$GNU_TIME" -f '%e %M' -o "$TMP/time$i" $cmd >"$log" 2>&1; then
      echo "mesh: command failed: $cmd" >&2
      tail -n 40 "$log" >&2
      exit 1
    fi
    t1=$(now)
    [ -s "$out" ] || { echo "mesh: no mesh written by: $cmd" >&2; exit 1; }
    t=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')
    kb=$(awk 'END { print $2 }' "$TMP/time$i")
    own=$(own_secs "${TOOLS[$i]}" "$log")
    echo "mesh:   ${t} s, peak RSS $((kb / 1024)) MiB, $(stl_tris "$out") triangles" >&2
    TIMES[$i]="${TIMES[$i]:-}${TIMES[$i]:+ }$t"
    RSS[$i]=$(( ${RSS[$i]:-0} > kb ? ${RSS[$i]:-0} : kb ))
    [ -n "$own" ] && OWN[$i]="${OWN[$i]:-}${OWN[$i]:+ }$own"
  done
done
LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg)

echo "mesh: surface error (bench/mesh/error.py)" >&2
python3 bench/mesh/error.py "${FILES[@]}" >"$TMP/errors"
declare -A VMAX=() VRMS=() FMAX=() FRMS=()
while read -r f _ _ _ _ _ vmax _ vrms _ fmax _ frms; do
  VMAX[$f]=$vmax; VRMS[$f]=$vrms; FMAX[$f]=$fmax; FRMS[$f]=$frms
done <"$TMP/errors"

MEDIANS=()
ISO_MED=()
for i in "${!NAMES[@]}"; do
  # shellcheck disable=SC2086
  MEDIANS+=("$(median ${TIMES[$i]})")
  [ "${TOOLS[$i]}" = isoray ] && ISO_MED[${TGT[$i]}]=${MEDIANS[$i]}
done

machine_facts
SDF_VER=$(python3 -c 'import importlib.metadata as m; print("sdflab " + m.version("sdflab") + " (numpy " + m.version("numpy") + ", scikit-image " + m.version("scikit-image") + ")")' 2>/dev/null || echo "sdflab ?")
FIDGET_VER=$(awk '/^name = "fidget"$/ { getline; gsub(/[^0-9.]/, ""); print "fidget " $0; exit }' bench/mesh/fidget-harness/Cargo.lock)

{
  echo "## Mesh extraction: isoray vs fidget vs sdf, the CSG classic"
  echo
  echo "Machine: ${CPU:-unknown CPU}, $(nproc) cores ($(uname -sr)). ${ISO_VER:-isoray} (git $REV$DIRTY); $FIDGET_VER (JIT evaluator, manifold dual contouring); $SDF_VER (marching cubes); $(python3 --version 2>&1)."
  echo "Median wall time of $REPS runs per row (whole process: start-up, meshing, binary STL write), the tools alternating; all cores for every tool. Peak RSS: GNU time %M, largest run."
  echo "Load average before the timed runs: $LOAD_BEFORE; after: $LOAD_AFTER."
  [ "$HAVE_ISO" = 1 ] || echo "**isoray rows skipped: this isoray has no \`mesh\` subcommand.**"
  echo
  echo "Error (bench/mesh/error.py, analytic SDF in float64): *vertex* max / RMS of |d| over the unique vertices; *surface* max / area-weighted RMS over 7 points per triangle (corners, edge midpoints, centroid), which also sees edges cut off by a chamfer. Units: the part spans [-1, 1]^3."
  echo
  echo "| target | tool | setting | triangles | median s | runs s | own s | peak RSS MiB | vertex max | vertex RMS | surface max | surface RMS | time / isoray |"
  echo "|---|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|"
  for i in "${!NAMES[@]}"; do
    f=${FILES[$i]}
    iso=${ISO_MED[${TGT[$i]}]:-}
    ratio=$([ -n "$iso" ] && awk -v a="${MEDIANS[$i]}" -v b="$iso" 'BEGIN { printf "%.2f", a / b }' || echo "n/a")
    # shellcheck disable=SC2086
    own=$([ -n "${OWN[$i]:-}" ] && median ${OWN[$i]} || echo "–")
    printf '| ~%s | %s | %s | %d | %s | %s | %s | %.0f | %.2e | %.2e | %.2e | %.2e | %s |\n' \
      "${TARGETS[${TGT[$i]}]}" "${NAMES[$i]}" "${SETTINGS[$i]}" "$(stl_tris "$f")" "${MEDIANS[$i]}" \
      "${TIMES[$i]}" "$own" "$(awk -v k="${RSS[$i]}" 'BEGIN { print k / 1024 }')" \
      "${VMAX[$f]}" "${VRMS[$f]}" "${FMAX[$f]}" "${FRMS[$f]}" "$ratio"
  done
  echo
  echo "Commands (run from the repository root; the meshes are left in $OUTDIR/):"
  echo
  echo '```'
  echo "REPS=$REPS bench/mesh.sh"
  echo "CARGO_TARGET_DIR=$FIDGET_TARGET cargo build --release --manifest-path bench/mesh/fidget-harness/Cargo.toml"
  for i in "${!NAMES[@]}"; do
    echo "${CMDS[$i]//\{OUT\}/${FILES[$i]}}"
  done
  echo "python3 bench/mesh/error.py ${FILES[*]}"
  echo '```'
} | tee bench/out/mesh.md
