#!/usr/bin/env bash
# Side-by-side benchmark of the classic polygon pipeline (issue 7): isoray's
# CPU Z-buffer rasterizer (crates/isoray-raster, Phong shading) against Mesa's
# llvmpipe (lavapipe, Debian `mesa-vulkan-drivers`) drawing the same triangles
# with the same Phong shading through wgpu's Vulkan backend, on the meshed
# showcase at 1280x720.  Target: isoray within 2x of llvmpipe.
#
#   bench/raster.sh            # from anywhere; FRAMES=9 REPS=5 RES=128 bench/raster.sh
#
# 1. installs the peers (bench/install-peers.sh: mesa-vulkan-drivers,
#    libvulkan1, vulkan-tools, ...) and builds isoray (bench/common.sh),
# 2. builds the harness (bench/raster/wgpu-harness, its own Cargo project,
#    into bench/out/raster-target),
# 3. runs it once: it meshes examples/showcase.toml once at --resolution RES
#    (isoray_raster::scene::mesh_scene, the triangles `isoray raster` draws),
#    then times isoray's raster_meshes and the llvmpipe frame (draw + copy of
#    the colour target into CPU memory) alternately, 2 warm-up + FRAMES timed
#    frames each; reports min / median per frame, the ratio, wgpu's one-time
#    setup, the thread counts, and how many pixels of the two images differ;
#    writes bench/out/raster/{isoray,llvmpipe,diff}.png and report.json,
# 4. times the whole program `isoray raster` (load, mesh, raster, PNG write)
#    REPS times at the same settings (wall time, peak RSS with GNU time),
# 5. times the A-buffer against the Z-buffer (`isoray raster --hidden
#    abuffer|zbuffer`, drawing time as the CLI reports it) on the same scene,
# 6. times the environment-map methods on examples/reflections.toml at WxH
#    (`isoray raster --reflections M --shadows buffer`: map building and
#    drawing as the CLI reports them, and the whole program) against the ray
#    tracer's reflections (`isoray render` of the same scene, whole program),
# 7. prints a markdown report (also saved to bench/out/raster.md).
#
# Threads: llvmpipe uses LP_NUM_THREADS rasterizer threads (the harness sets it
# to the number of cores when unset), isoray its rayon pool (all cores).
# The harness's "CPU s / wall s" column shows how many cores each really used.
# Both cull the same back faces (the harness re-winds the few triangles whose
# winding disagrees with their vertex normals, isoray's culling orientation);
# isoray shades each visible pixel once (deferred), llvmpipe every fragment
# that passes the depth test when drawn (forward), as a GPU pipeline does.
# wgpu (Vulkan backend) is a crates.io dependency of the harness; lavapipe is
# the Debian package.  The machine is shared: compare the load averages.
set -euo pipefail

NAME=raster
# shellcheck source=bench/common.sh
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

# ---- Settings (edit here) ---------------------------------------------------
SCENE=examples/showcase.toml
# Mesh resolution (cells along each object's longest side): 96 -> ~333k
# triangles, 112 -> ~450k, 128 -> ~600k on the showcase.
RES=${RES:-112}
# Timed frames per renderer in the harness (after 2 warm-up frames).
FRAMES=${FRAMES:-7}
# ------------------------------------------------------------------------------

GNU_TIME=/usr/bin/time
"$GNU_TIME" --version 2>&1 | grep -q GNU || { echo "raster: GNU time ($GNU_TIME) not found; run bench/install-peers.sh" >&2; exit 1; }

HARNESS_TARGET=bench/out/raster-target
CARGO_TARGET_DIR=$HARNESS_TARGET cargo build --release --manifest-path bench/raster/wgpu-harness/Cargo.toml
HARNESS=$HARNESS_TARGET/release/raster-bench
[ -x "$HARNESS" ] || { echo "raster: $HARNESS not found after build" >&2; exit 1; }

# Mesa's Vulkan loader / WSI complain without a runtime directory; give them one.
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$TMP}
if command -v vulkaninfo >/dev/null; then
  VK_DEV=$(vulkaninfo --summary 2>/dev/null | sed -n 's/^[[:space:]]*deviceName[[:space:]]*= //p' | paste -sd ';' - || true)
  echo "raster: Vulkan devices: ${VK_DEV:-none}" >&2
fi

OUTDIR=bench/out/raster
mkdir -p "$OUTDIR"

LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)
echo "raster: harness: $HARNESS $SCENE --resolution $RES --width $W --height $H --reps $FRAMES" >&2
"$HARNESS" "$SCENE" --resolution "$RES" --width "$W" --height "$H" --reps "$FRAMES" --warmup 2 \
  --out-dir "$OUTDIR" --json "$OUTDIR/report.json" >"$TMP/harness.md" 2>"$TMP/harness.log" || {
  echo "raster: harness failed" >&2
  cat "$TMP/harness.log" >&2
  exit 1
}
grep -v 'XDG_RUNTIME_DIR' "$TMP/harness.log" >&2 || true

# Whole program: isoray raster, REPS times.
CLI_PNG=$OUTDIR/isoray-cli.png
CLI_CMD="$ISORAY raster $SCENE -o $CLI_PNG --set render.width=$W --set render.height=$H --resolution $RES"
CLI_TIMES=()
CLI_OWN=()
CLI_DRAW=()
CLI_RSS=0
for ((r = 1; r <= REPS; r++)); do
  echo "raster: run $r/$REPS: $CLI_CMD" >&2
  t0=$(now)
  # shellcheck disable=SC2086
  if ! "$GNU_TIME" -f '%e %M' -o "$TMP/time" $CLI_CMD >"$TMP/cli.log" 2>&1; then
    echo "raster: command failed: $CLI_CMD" >&2
    tail -n 40 "$TMP/cli.log" >&2
    exit 1
  fi
  t1=$(now)
  t=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')
  kb=$(awk 'END { print $2 }' "$TMP/time")
  # "rasterised N triangles into WxH in X.XXs → OUT": the CLI's own time (mesh + raster).
  own=$(sed -n 's/^rasterised .* in \([0-9.]*\)s .*/\1/p' "$TMP/cli.log" | head -n1)
  # ... "(meshing X.XXs, maps X.XXs, drawing X.XXs)" where the CLI breaks it down.
  draw=$(sed -n 's/^rasterised .*drawing \([0-9.]*\)s.*/\1/p' "$TMP/cli.log" | head -n1)
  echo "raster:   ${t} s, peak RSS $((kb / 1024)) MiB${own:+, own $own s}${draw:+, drawing $draw s}" >&2
  CLI_TIMES+=("$t")
  [ -n "$own" ] && CLI_OWN+=("$own")
  [ -n "$draw" ] && CLI_DRAW+=("$draw")
  CLI_RSS=$((CLI_RSS > kb ? CLI_RSS : kb))
done
# The CLI's "(meshing X s, maps Y s, drawing Z s)" parts of one run.
cli_parts() { # LOG -> "maps draw"
  sed -n 's/^rasterised .*maps \([0-9.]*\)s, drawing \([0-9.]*\)s.*/\1 \2/p' "$1" | head -n1
}
# median of one field of a list of "a b" pairs: field N
field_median() { local n=$1; shift; median $(printf '%s\n' "$@" | awk -v n="$n" '{ print $n }'); }

# A-buffer cost over the Z-buffer (same scene and settings).
declare -A HID_DRAW
for hidden in zbuffer abuffer; do
  parts=()
  for ((r = 1; r <= REPS; r++)); do
    # shellcheck disable=SC2086
    $ISORAY raster $SCENE -o "$TMP/h.png" --set render.width=$W --set render.height=$H --resolution $RES \
      --hidden $hidden >"$TMP/h.log" 2>&1 || { cat "$TMP/h.log" >&2; exit 1; }
    parts+=("$(cli_parts "$TMP/h.log")")
  done
  HID_DRAW[$hidden]=$(field_median 2 "${parts[@]}")
  echo "raster: --hidden $hidden: drawing ${HID_DRAW[$hidden]} s (median of $REPS)" >&2
done
AB_RATIO=$(awk -v a="${HID_DRAW[abuffer]}" -v z="${HID_DRAW[zbuffer]}" 'BEGIN { printf "%.2f", a / z }')

# Environment-map methods against the ray tracer's reflections.
RSCENE=examples/reflections.toml
ENV_ROWS=()
for m in none blinn-newell zbuffer-map abuffer-map; do
  parts=(); walls=()
  for ((r = 1; r <= REPS; r++)); do
    t0=$(now)
    $ISORAY raster $RSCENE -o "$OUTDIR/reflections-$m.png" --set render.width=$W --set render.height=$H \
      --reflections $m --shadows buffer >"$TMP/e.log" 2>&1 || { cat "$TMP/e.log" >&2; exit 1; }
    t1=$(now)
    walls+=("$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')")
    parts+=("$(cli_parts "$TMP/e.log")")
  done
  ENV_ROWS+=("| \`isoray raster --reflections $m --shadows buffer\` | $(field_median 1 "${parts[@]}") | $(field_median 2 "${parts[@]}") | $(median ${walls[*]}) |")
  echo "raster: --reflections $m: ${ENV_ROWS[-1]}" >&2
done
walls=()
for ((r = 1; r <= REPS; r++)); do
  t0=$(now)
  $ISORAY render $RSCENE -o "$OUTDIR/reflections-raytrace.png" --set render.width=$W --set render.height=$H \
    >"$TMP/rt.log" 2>&1 || { cat "$TMP/rt.log" >&2; exit 1; }
  t1=$(now)
  walls+=("$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')")
done
ENV_ROWS+=("| \`isoray render\` (ray tracer, max_depth 2, hard shadows) | – | – | $(median ${walls[*]}) |")
RT_LINE=$(grep -m1 '^rendered' "$TMP/rt.log" || true)

LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg)
CLI_LINE=$(grep -m1 '^rasterised' "$TMP/cli.log" || true)

machine_facts
WGPU_VER=$(awk '/^name = "wgpu"$/ { getline; gsub(/[^0-9.]/, ""); print "wgpu " $0; exit }' bench/raster/wgpu-harness/Cargo.lock)
MESA_VER=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || echo "?")
RATIO=$(sed -n 's/.*"ratio_median": \([0-9.]*\).*/\1/p' "$OUTDIR/report.json" | awk '{ printf "%.2f", $1 }')

{
  echo "## Polygon pipeline: isoray vs llvmpipe (lavapipe through wgpu), the meshed showcase"
  echo
  echo "Machine: ${CPU:-unknown CPU}, $(nproc) cores ($(uname -sr)). ${ISO_VER:-isoray} (git $REV$DIRTY); $WGPU_VER (Vulkan backend); Mesa lavapipe (Debian mesa-vulkan-drivers $MESA_VER)."
  echo "Load average before the timed runs: $LOAD_BEFORE; after: $LOAD_AFTER."
  echo
  echo "### Per frame, same triangles, one process (bench/raster/wgpu-harness)"
  echo
  sed '1,2{/^## /d;/^$/d}' "$TMP/harness.md"     # its own title: this section's
  echo
  echo "**Ratio isoray / llvmpipe (median frame): $RATIO** (target: within 2x)."
  echo
  echo "### Whole program: \`isoray raster\` at the same settings"
  echo
  echo "| command | median s | runs s | own s (mesh + raster) | own drawing s | peak RSS MiB |"
  echo "|---|---:|---|---:|---:|---:|"
  # shellcheck disable=SC2086
  printf '| `isoray raster` --resolution %s, %sx%s | %s | %s | %s | %s | %.0f |\n' "$RES" "$W" "$H" \
    "$(median ${CLI_TIMES[*]})" "${CLI_TIMES[*]}" \
    "$([ ${#CLI_OWN[@]} -gt 0 ] && median ${CLI_OWN[*]} || echo "–")" \
    "$([ ${#CLI_DRAW[@]} -gt 0 ] && median ${CLI_DRAW[*]} || echo "–")" \
    "$(awk -v k="$CLI_RSS" 'BEGIN { print k / 1024 }')"
  echo
  echo "isoray's own line (last run): ${CLI_LINE:-none}"
  echo
  echo "### A-buffer cost over the Z-buffer (same scene, drawing time as \`isoray raster\` reports it, median of $REPS)"
  echo
  echo "| hidden surfaces | drawing s |"
  echo "|---|---:|"
  echo "| \`--hidden zbuffer\` | ${HID_DRAW[zbuffer]} |"
  echo "| \`--hidden abuffer\` | ${HID_DRAW[abuffer]} |"
  echo
  echo "**A-buffer / Z-buffer: ${AB_RATIO}x.**"
  echo
  echo "### Environment maps against the ray tracer's reflections ($RSCENE, ${W}x${H}, median of $REPS)"
  echo
  echo "| command | maps s | drawing s | whole program s |"
  echo "|---|---:|---:|---:|"
  printf '%s\n' "${ENV_ROWS[@]}"
  echo
  echo "The ray tracer's own line (last run): ${RT_LINE:-none}"
  echo
  echo "Commands (run from the repository root; the images are left in $OUTDIR/):"
  echo
  echo '```'
  echo "FRAMES=$FRAMES REPS=$REPS RES=$RES bench/raster.sh"
  echo "CARGO_TARGET_DIR=$HARNESS_TARGET cargo build --release --manifest-path bench/raster/wgpu-harness/Cargo.toml"
  echo "$HARNESS $SCENE --resolution $RES --width $W --height $H --reps $FRAMES --warmup 2 --out-dir $OUTDIR --json $OUTDIR/report.json"
  echo "$CLI_CMD"
  echo '```'
} | tee bench/out/raster.md
