#!/bin/sh
# Regenerates the pictures and the measurements of docs/REFLECTIONS.md:
# renders examples/reflections.toml and examples/hidden.toml with every
# reflection method of `isoray raster`, compares each with the ray tracer
# (--error-vs-raytrace), writes the pictures to docs/img/reflections/ and the
# JSON reports to bench/out/reflections/, and prints the tables.
#
#   docs/img/reflections.sh
#
# The binary is target/release/isoray (built if missing); set ISORAY to use another.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
bin=${ISORAY:-$root/target/release/isoray}
if [ ! -x "$bin" ]; then
    (cd "$root" && cargo build --release -p isoray)
fi
img=$here/reflections
out=$root/bench/out/reflections
mkdir -p "$img" "$out"

run() { # SCENE NAME ARGS...
    scene=$1 name=$2
    shift 2
    "$bin" raster "$root/examples/$scene.toml" -o "$img/$scene-$name.png" \
        --error-vs-raytrace "$out/$scene-$name.json" --quiet "$@"
}

for m in none blinn-newell zbuffer-map abuffer-map; do
    run reflections "$m" --reflections "$m" --shadows buffer
done
run reflections abuffer-map-envmap-shadows --reflections abuffer-map --shadows envmap
cp "$out/reflections-abuffer-map.raytrace.png" "$img/reflections-raytrace.png"
for m in zbuffer-map abuffer-map; do
    run hidden "$m" --reflections "$m"
done
cp "$out/hidden-abuffer-map.raytrace.png" "$img/hidden-raytrace.png"

python3 - "$out" <<'PY'
import json, sys, glob, os
print("| scene | method | shadows | reflective px | angular error mean / p95 / max (°) | wrong | PSNR (dB) | maps (s) | draw (s) | ray tracer (s) |")
print("|---|---|---|---|---|---|---|---|---|---|")
for f in sorted(glob.glob(os.path.join(sys.argv[1], "*.json"))):
    r = json.load(open(f))
    a = r["angular_error_deg"]; s = r["seconds"]
    name = os.path.basename(f)[:-5]
    scene = name.split("-")[0]
    print(f"| {scene} | {r['reflections']} | {r['shadows']} | {r['reflective_pixels']} | "
          f"{a['mean']:.3f} / {a['p95']:.3f} / {a['max']:.3f} | {100 * r['wrong_fraction']:.2f}% | "
          f"{r['psnr_db']:.2f} | {s['maps']:.2f} | {s['draw']:.2f} | {s['raytrace']:.2f} |")
PY
