// POV-Ray 3.7 port of examples/showcase.toml for the isoray benchmark.
//
// The whole scene (ground plane + five primitives) is ONE isosurface whose
// function is the smooth union of the six signed distance functions, folded
// left to right in file order with k = render.blend = 0.25, exactly as isoray
// evaluates it.  All functions below are written in isoray's right-handed,
// y-up coordinates; POV-Ray is left-handed, so the world is mirrored by
// negating z when the isosurface samples the function and by negating z of the
// camera and light.  The picture is therefore the same, not mirrored.
//
// Render (see bench/compare.sh):
//   povray +Ibench/showcase.pov +Oout.png +W1280 +H720 -A +WT2 -D -V +FN
//
// Settings: one parallel (directional) light, hard shadows, no anti-aliasing
// (-A), no radiosity, no focal blur.  Shading is not matched to isoray's: one
// finish for everything, pigment = diffuse colour of the nearest object (no
// blending of materials across fillets).
//
// Checked: f_scene agrees with `isoray eval examples/showcase.toml` to 5e-13 at
// 400 random points around the objects (print with #debug str(f_scene(x,y,z),0,12)).

#version 3.7;

global_settings { assumed_gamma 1.0 }

background { color rgb <0.95, 0.95, 0.95> }

// ---------------------------------------------------------------- camera
// isoray: position [0,4,6.5], target [0,0.5,0], up y, VERTICAL fov 40 deg,
// aspect = width/height.  POV's `angle` is the HORIZONTAL fov.
#declare ISO_VFOV = 40;
#declare ISO_ASPECT = image_width / image_height;  // 1280/720 for the benchmark
camera {
  perspective
  location <0, 4, -6.5>          // z mirrored
  look_at  <0, 0.5, 0>
  right    x * ISO_ASPECT
  up       y
  sky      y
  angle    degrees(2 * atan(tan(radians(ISO_VFOV / 2)) * ISO_ASPECT))
}

// ----------------------------------------------------------------- light
// isoray: directional light, direction towards the light [-1, 2, 1].
light_source {
  <-1, 2, -1> * 1000             // z mirrored
  color rgb <1.0, 0.97, 0.9>
  parallel
  point_at <0, 0, 0>
}

// ------------------------------------------------------------ primitives
// Each takes a point already moved into the primitive's local frame.
#declare K_BLEND = 0.25;         // render.blend

// smin(a,b,k) = min(a,b) - h*h/(4k),  h = max(k - |a-b|, 0)
#declare f_smin = function(da, db) {
  min(da, db) - pow(max(K_BLEND - abs(da - db), 0), 2) / (4 * K_BLEND)
}

// plane(p, n, h) = dot(p, n) + h   with n = (0,1,0), h = 0
#declare f_plane = function(px, py, pz) { py }

// torus(p, R, r) = length(vec2(length(p.xz) - R, p.y)) - r
#declare f_torus = function(px, py, pz, RR, rr) {
  sqrt(pow(sqrt(px*px + pz*pz) - RR, 2) + py*py) - rr
}

// tri_prism(p, h, w): q = abs(p);
//   max(q.z - h, max(q.x*sqrt(3)/2 + p.y*0.5, -p.y) - w*0.5)
#declare SQRT3_2 = sqrt(3) / 2;      // isoray uses 3f64.sqrt() / 2 (0.866025...)
#declare f_tri_prism = function(px, py, pz, hh, ww) {
  max(abs(pz) - hh, max(abs(px)*SQRT3_2 + py*0.5, -py) - ww*0.5)
}

// box(p, b): q = abs(p) - b; length(max(q,0)) + min(max(q.x,max(q.y,q.z)),0)
#declare f_box = function(qx, qy, qz) {
  sqrt(pow(max(qx,0),2) + pow(max(qy,0),2) + pow(max(qz,0),2))
  + min(max(qx, max(qy, qz)), 0)
}

// sphere(p, r) = length(p) - r
#declare f_sphere = function(px, py, pz, rr) { sqrt(px*px + py*py + pz*pz) - rr }

// cylinder(p, h, r), capped, axis y, half-height h:
//   d = abs(vec2(length(p.xz), p.y)) - vec2(r, h)
//   min(max(d.x, d.y), 0) + length(max(d, 0))
#declare f_cyl_d = function(dx, dy) {
  min(max(dx, dy), 0) + sqrt(pow(max(dx,0),2) + pow(max(dy,0),2))
}
#declare f_cylinder = function(px, py, pz, hh, rr) {
  f_cyl_d(sqrt(px*px + pz*pz) - rr, abs(py) - hh)
}

// ------------------------------------------------------------ the objects
// rotate_x(p, a) = (x, cos(a)*y + sin(a)*z, -sin(a)*y + cos(a)*z)
// rotate_y(p, a) = (cos(a)*x - sin(a)*z, y, sin(a)*x + cos(a)*z)
#declare CX = cos(1.2);  #declare SX = sin(1.2);   // torus rotate_x angle
#declare CY = cos(0.6);  #declare SY = sin(0.6);   // box rotate_y angle

// 0: plane(p, vec3(0,1,0), 0)
#declare f_o0 = function(x, y, z) { f_plane(x, y, z) }
// 1: torus(rotate_x(p - vec3(-2.3, 0.95, -0.2), 1.2), 0.7, 0.22)
#declare f_o1_l = function(px, py, pz) {
  f_torus(px, CX*py + SX*pz, -SX*py + CX*pz, 0.7, 0.22)
}
#declare f_o1 = function(x, y, z) { f_o1_l(x + 2.3, y - 0.95, z + 0.2) }
// 2: tri_prism(p - vec3(-0.9, 0.45, 0.7), 0.45, 0.9)
#declare f_o2 = function(x, y, z) { f_tri_prism(x + 0.9, y - 0.45, z - 0.7, 0.45, 0.9) }
// 3: box(rotate_y(p - vec3(0.3, 0.45, -0.5), 0.6), vec3(0.45, 0.45, 0.45))
#declare f_o3_l = function(px, py, pz) {
  f_box(abs(CY*px - SY*pz) - 0.45, abs(py) - 0.45, abs(SY*px + CY*pz) - 0.45)
}
#declare f_o3 = function(x, y, z) { f_o3_l(x - 0.3, y - 0.45, z + 0.5) }
// 4: sphere(p - vec3(1.35, 0.7, 0.55), 0.7)
#declare f_o4 = function(x, y, z) { f_sphere(x - 1.35, y - 0.7, z - 0.55, 0.7) }
// 5: cylinder(p - vec3(2.6, 0.8, -0.6), 0.8, 0.4)
#declare f_o5 = function(x, y, z) { f_cylinder(x - 2.6, y - 0.8, z + 0.6, 0.8, 0.4) }

// Smooth union folded left to right in file order:
//   d = smin(smin(smin(smin(smin(d0, d1), d2), d3), d4), d5)
#declare f_scene = function(x, y, z) {
  f_smin(f_smin(f_smin(f_smin(f_smin(
    f_o0(x, y, z), f_o1(x, y, z)), f_o2(x, y, z)), f_o3(x, y, z)),
    f_o4(x, y, z)), f_o5(x, y, z))
}

// Index (0..5) of the object with the smallest distance; used for colour only.
// select(A, neg, zero, pos); each A is >= 0 and is 0 exactly when that object
// is (one of) the nearest among itself and the later ones.
#declare f_nearest_m = function(d0, d1, d2, d3, d4, d5) {
  select(d0 - min(d0, d1, d2, d3, d4, d5), 0, 0,
  select(d1 - min(d1, d2, d3, d4, d5), 1, 1,
  select(d2 - min(d2, d3, d4, d5), 2, 2,
  select(d3 - min(d3, d4, d5), 3, 3,
  select(d4 - min(d4, d5), 4, 4, 5)))))
}
#declare f_nearest = function(x, y, z) {
  f_nearest_m(f_o0(x, y, z), f_o1(x, y, z), f_o2(x, y, z),
              f_o3(x, y, z), f_o4(x, y, z), f_o5(x, y, z))
}

// ------------------------------------------------------------ isosurface
isosurface {
  function { f_scene(x, y, -z) }      // POV z = -isoray z
  // isoray box <-40,-1,-40> .. <40,2.2,8>, z mirrored.  Every camera ray hits
  // the ground (y = 0) within ~30 units (image corners: |x| < 17, z > -21), well
  // inside this box.  The top, y = 2.2, clears the highest surface (torus top
  // ~1.87, plus at most k/4 = 0.0625 of blend growth) and keeps POV's grazing
  // rays a little shorter (~4% fewer function calls than a top of 3, same image).
  contained_by { box { <-40, -1, -8>, <40, 2.2, 40> } }
  threshold 0
  accuracy 0.0001                     // isoray render.hit_epsilon
  max_gradient 1.0                    // POV reports "maximum gradient found was
                                      // 1.000"; all six SDFs and smin are 1-Lipschitz
  // Colour = diffuse colour of the nearest object (index 0..5 -> 0, 0.2 .. 1).
  // Only evaluated at hit points, so it costs next to nothing.
  pigment {
    function { f_nearest(x, y, -z) / 5 }
    color_map {
      [0.0 color rgb <0.75, 0.75, 0.78>] [0.1 color rgb <0.75, 0.75, 0.78>] // ground
      [0.1 color rgb <0.90, 0.70, 0.30>] [0.3 color rgb <0.90, 0.70, 0.30>] // gold
      [0.3 color rgb <0.85, 0.15, 0.12>] [0.5 color rgb <0.85, 0.15, 0.12>] // red
      [0.5 color rgb <0.15, 0.30, 0.85>] [0.7 color rgb <0.15, 0.30, 0.85>] // blue
      [0.7 color rgb <0.85, 0.85, 0.85>] [0.9 color rgb <0.85, 0.85, 0.85>] // white
      [0.9 color rgb <0.20, 0.70, 0.25>] [1.0 color rgb <0.20, 0.70, 0.25>] // green
    }
  }
  finish { ambient 0.25 diffuse 0.75 phong 0.4 phong_size 40 }
}
