// POV-Ray 3.7 port of bench/optics.toml (examples/optics.toml without the
// environment map) for the recursive ray tracing benchmark, bench/optics.sh.
//
// A red reflective sphere, a clear glass sphere (ior 1.5, Fresnel), a green
// torus and a checker floor, lit by one point light with hard shadows.  The
// torus is an `isosurface` with isoray's exact torus SDF; the spheres and the
// floor are POV's native (analytic) objects.
//
// All positions below are isoray's, which is right-handed and y-up; POV-Ray is
// left-handed, so the world is mirrored by negating z (of the camera, the
// light, the objects, and of z inside the torus function).  The picture is
// therefore the same, not mirrored.
//
// Render (see bench/optics.sh):
//   povray +Ibench/optics.pov +Oout.png +W1280 +H720 -A +WT2 -D -V +FN
//
// Shading follows isoray's (docs/SCENE.md, sections 3 and 9.3) as closely as
// POV's finish allows:
//   - isoray: colour = ambient + diffuse*(N.L) + specular*(N.H)^shininess
//     (Blinn-Phong), ambient and diffuse being separate colours.  POV:
//     pigment = isoray diffuse, `diffuse 1`, `ambient` = ambient/diffuse per
//     channel (POV multiplies ambient by the pigment), `specular` with
//     `roughness 1/shininess` (POV's specular is Blinn-Phong (N.H)^(1/roughness)).
//   - isoray splits reflective/transparent surfaces three ways: reflect = kr +
//     (1 - kr)*F (F Schlick, ior 1.5), transmit = tau*(1 - reflect), local =
//     (1 - tau)(1 - reflect) weighting ambient and diffuse.  POV: `reflection
//     { kr, 1 fresnel on }` (exact Fresnel, needs an interior ior) and
//     `conserve_energy` (transmission reduced by the reflected part); POV does
//     not weight the diffuse term by (1 - reflect), so the red sphere's ambient
//     and diffuse are scaled by 1 - (0.6 + 0.4*0.04) = 0.384, the weight at
//     normal incidence.
//   - Recursion: isoray's max_depth 5 is 5 bounces after the primary hit.  POV
//     counts the primary ray as trace level 1 (TraceRay stops a ray once
//     traceLevel >= max_trace_level), so 5 bounces is max_trace_level 6.
//     adc_bailout = isoray's render.min_weight (0.001).
//   - isoray's rays end at render.max_distance = 100 (from the ray's origin):
//     beyond it the floor is background.  The POV plane is clipped to 100
//     units around the camera so that the horizon looks the same.
//   - Shadows: hard, one point light, no area light.  In both renderers shadow
//     rays pass straight through the glass (transmission 1, not bent).

#version 3.7;

global_settings {
  assumed_gamma 1.0
  max_trace_level 6     // = isoray max_depth 5 (see above)
  adc_bailout 0.001     // isoray render.min_weight
}

// isoray render.background (linear RGB, as everything here)
background { color rgb <0.55, 0.65, 0.8> }

// ---------------------------------------------------------------- camera
// isoray: position [0,2.2,6.5], target [0,0.7,0], up y, VERTICAL fov 40 deg,
// aspect = width/height.  POV's `angle` is the HORIZONTAL fov.
#declare ISO_EYE = <0, 2.2, -6.5>;        // z mirrored
#declare ISO_VFOV = 40;
#declare ISO_ASPECT = image_width / image_height;  // 1280/720 for the benchmark
camera {
  perspective
  location ISO_EYE
  look_at  <0, 0.7, 0>
  right    x * ISO_ASPECT
  up       y
  sky      y
  angle    degrees(2 * atan(tan(radians(ISO_VFOV / 2)) * ISO_ASPECT))
}

// ----------------------------------------------------------------- light
// isoray: kind = "point", position [-4,6,5], colour 1, no attenuation.
light_source { <-4, 6, -5> color rgb 1 }   // z mirrored

// ----------------------------------------------------------------- floor
// isoray: a plane with a checker material, cells [k, k+1) in x and z, light
// where floor(x) + floor(z) is even.  POV's checker has its cell boundaries on
// the integers too and takes its first texture where floor(x) + floor(y) +
// floor(z) is even.  Translated by -0.5 in y, the plane y = 0 lies in the
// middle of a cell layer (no flicker between layers).  Mirroring z
// (z_pov = -z) flips the parity: floor(-z) = -floor(z) - 1 off the integers,
// so the dark texture comes first.
plane {
  y, 0
  texture {
    checker
      texture {   // isoray dark_tile: ambient [0.03,0.03,0.04], diffuse [0.1,0.1,0.12]
        pigment { color rgb <0.1, 0.1, 0.12> }
        finish { ambient rgb <0.3, 0.3, 1/3> diffuse 1 specular 0 phong 0 }
      }
      texture {   // isoray light_tile: ambient 0.2, diffuse 0.8, no specular
        pigment { color rgb 0.8 }
        finish { ambient 0.25 diffuse 1 specular 0 phong 0 }
      }
    translate <0, -0.5, 0>
  }
  clipped_by { sphere { ISO_EYE, 100 } }   // isoray render.max_distance
}

// ------------------------------------------------------------- red sphere
// isoray red_mirror: ambient [0.1,0.02,0.02], diffuse [0.6,0.06,0.05],
// specular 0.8, shininess 80, reflectivity 0.6 (Fresnel on, ior 1.5).
#declare LOCAL_RED = 1 - (0.6 + 0.4 * 0.04);   // isoray's local weight at normal incidence
sphere {
  <-1.5, 0.9, 0>, 0.9
  pigment { color rgb <0.6, 0.06, 0.05> }
  finish {
    ambient rgb <0.1/0.6, 0.02/0.06, 0.02/0.05> * LOCAL_RED
    diffuse LOCAL_RED
    specular 0.8 roughness 1/80
    reflection { 0.6, 1 fresnel on }
  }
  interior { ior 1.5 }   // for the Fresnel reflectance only (the sphere is opaque)
}

// ----------------------------------------------------------- glass sphere
// isoray glass: ambient 0, diffuse 0, specular 1, shininess 300,
// transparency 1, ior 1.5, Fresnel on, no absorption.
sphere {
  <1.2, 0.9, -1>, 0.9                      // z mirrored
  pigment { color rgbf 1 }
  finish {
    ambient 0 diffuse 0
    specular 1 roughness 1/300
    reflection { 0, 1 fresnel on }
    conserve_energy
  }
  interior { ior 1.5 }
}

// ------------------------------------------------------------------ torus
// isoray: torus(p - vec3(0.3, 0.35, -2.0), 0.9, 0.35), material green:
// ambient [0.03,0.12,0.04], diffuse [0.2,0.7,0.25], specular 0.5, shininess 30.
// torus(p, R, r) = length(vec2(length(p.xz) - R, p.y)) - r, exact.
#declare f_torus = function(px, py, pz, RR, rr) {
  sqrt(pow(sqrt(px*px + pz*pz) - RR, 2) + py*py) - rr
}
isosurface {
  function { f_torus(x - 0.3, y - 0.35, -z - (-2.0), 0.9, 0.35) }   // isoray z = -z
  // the torus spans x 0.3 +- 1.25, y 0 .. 0.7, isoray z -2 +- 1.25 (POV z 2 +- 1.25);
  // the box is 0.01 larger on every side.
  contained_by { box { <-0.96, -0.01, 0.74>, <1.56, 0.71, 3.26> } }
  threshold 0
  accuracy 0.0001       // isoray render.hit_epsilon
  max_gradient 1.0      // an exact SDF is 1-Lipschitz
  pigment { color rgb <0.2, 0.7, 0.25> }
  finish {
    ambient rgb <0.03/0.2, 0.12/0.7, 0.04/0.25>
    diffuse 1
    specular 0.5 roughness 1/30
  }
}
