#!/usr/bin/env bash
# Renders the pictures of docs/SCENE.md §9.9 (the Unity thesis's
# conventions and Aaltonen's shadow) from examples/realtime/primitives.toml.
#   bash docs/img/realtime.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -q -p isoray
I=target/release/isoray
S="examples/realtime/primitives.toml --width 480 --height 270 -q"
$I render $S -o docs/img/unity_conventions.png
$I render $S -o docs/img/isoray_conventions.png --set render.shadow_floor=0 \
  --set 'render.shadow_applies_to="direct"' --set 'render.ao_applies_to="ambient"' \
  --set 'render.ao_weights="halving"' --set 'render.on_step_limit="hit"'
$I render $S -o docs/img/shadows_soft_primitives.png --set render.shadow_floor=0 --set 'render.shadow_applies_to="direct"' --set 'light.0.size=0.4'
$I render $S -o docs/img/shadows_aaltonen.png --set render.shadow_floor=0 --set 'render.shadow_applies_to="direct"' --set 'light.0.size=0.4' --set 'render.shadows="aaltonen"'
# The debug views of §9.7.
$I render examples/gallery.toml --width 320 --height 180 -q --set 'render.view="uv"' -o docs/img/view_uv.png
for v in mask gradient; do
  $I render examples/algebraic.toml --width 320 --height 180 -q --set "render.view=\"$v\"" -o "docs/img/view_$v.png"
done
# smooth_union_n (§6).
cat > /tmp/isoray-smooth-union-n.toml <<'TOML'
[camera]
position = [0.0, 0.6, 4.0]
target = [0.0, 0.3, 0.0]
fov = 40.0
[render]
width = 320
height = 180
aa = 2
[[light]]
direction = [-1.0, 2.0, 1.5]
[material.m]
diffuse = [0.8, 0.45, 0.2]
[[object]]
material = "m"
shape = "smooth_union_n(0.15, sphere(p - vec3(-0.5, 0.0, 0.0), 0.45), sphere(p - vec3(0.5, 0.0, 0.0), 0.45), sphere(p - vec3(0.0, 0.75, 0.0), 0.45))"
TOML
$I render /tmp/isoray-smooth-union-n.toml -o docs/img/smooth_union_n.png -q
# Fixed-step raymarching (§9.1).
for st in 0.05 0.3; do
  $I render examples/gallery.toml --width 320 --height 180 -q --set 'render.march="fixed"' --set render.fixed_step=$st --set render.max_steps=2000 -o "docs/img/march_fixed_${st/./}.png"
done
# Supersample patterns (§9.6).
for pat in grid rotated jittered; do
  $I render examples/csg.toml --width 160 --height 90 --aa 2 -q --set "render.aa_pattern=\"$pat\"" -o "docs/img/aa_$pat.png"
done
# specular_fresnel (§9.3).
F=""
for m in floor plastic phong schlick lamp; do F="$F --set material.$m.specular_fresnel=true"; done
$I render examples/lighting.toml --width 320 --height 180 -q -o docs/img/specular_fresnel_off.png
# shellcheck disable=SC2086
$I render examples/lighting.toml --width 320 --height 180 -q $F -o docs/img/specular_fresnel_on.png
