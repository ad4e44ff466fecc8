//! Sampling checks that each object's field is a distance bound.
//!
//! Sphere tracing may step as far as the field says; if the field is larger
//! than the distance to the surface, rays step through it. For each object,
//! rays from the camera are marched with short steps until the field changes
//! sign (the crossing is then found by bisection) or falls to about zero (an
//! unsigned field such as `abs(f)`), and every sample before it must
//! satisfy |field| ≤ distance along the ray to the crossing. The largest
//! ratio field / distance is the factor by which the field oversteps: a
//! `lipschitz_factor` at least that large on the surface makes the steps safe.

use isoray_scene::Scene;
use isoray_shape::PointEvaluator;
use rayon::prelude::*;

use crate::camera::RayCamera;

/// The result of checking one object.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundCheck {
    /// The object's index.
    pub object: usize,
    /// The implicit and parametric surfaces its shape calls.
    pub surfaces: Vec<String>,
    /// Rays marched.
    pub rays: usize,
    /// Rays that reached the surface.
    pub crossings: usize,
    /// The largest ratio of the field to the distance along the ray to the
    /// surface (≤ 1 for a bound).
    pub worst_ratio: f64,
    /// Where the largest ratio was found.
    pub at: [f64; 3],
}

/// Ratios above this count as violations (rounding of f32 renders aside).
pub const VIOLATION_RATIO: f64 = 1.001;

impl BoundCheck {
    /// True when a sampled value exceeded the distance to the surface.
    pub fn violated(&self) -> bool {
        self.worst_ratio > VIOLATION_RATIO
    }

    /// The `lipschitz_factor` that removes the violations seen, with a 10 % margin,
    /// rounded up to one decimal.
    pub fn suggested_factor(&self) -> f64 {
        (self.worst_ratio * 1.1 * 10.0).ceil() / 10.0
    }
}

/// Marches steps of at most this fraction of the field value.
const STEP_FRACTION: f64 = 0.25;

/// Steps per ray, at most.
const MAX_SAMPLES: usize = 1000;

/// Checks object `object` of the scene on a grid of `nx` × `ny` camera rays.
pub fn check_object(scene: &Scene, object: usize, nx: u32, ny: u32) -> BoundCheck {
    let (w, h) = (scene.render.width, scene.render.height);
    let cam = RayCamera::new(&scene.camera, w, h);
    let tape = scene.objects[object].shape.tape();
    let vars: &[f64] = &scene.inputs;
    let tmax = scene.render.max_distance;
    let max_step = tmax / 400.0;
    let origin = cam.origin().to_array();
    let rays: Vec<[f64; 3]> = (0..ny)
        .flat_map(|j| (0..nx).map(move |i| (i, j)))
        .map(|(i, j)| {
            let x = (i as f64 + 0.5) / nx as f64 * w as f64;
            let y = (j as f64 + 0.5) / ny as f64 * h as f64;
            cam.direction(x, y).to_array()
        })
        .collect();
    let results: Vec<Option<(f64, [f64; 3])>> = rays
        .par_iter()
        .map_init(
            || PointEvaluator::<f64>::new(tape),
            |ev, d| {
                let at = |t: f64| [origin[0] + d[0] * t, origin[1] + d[1] * t, origin[2] + d[2] * t];
                let mut f = |t: f64| {
                    let p = at(t);
                    ev.eval(vars, p[0], p[1], p[2])
                };
                let mut samples: Vec<(f64, f64)> = Vec::new();
                let mut t = 0.0;
                let first = f(0.0);
                if !first.is_finite() || first == 0.0 {
                    return None;
                }
                let sign = first.signum();
                // The worst ratio of the samples before a crossing at `crossing`,
                // ignoring samples closer to it than `near`.
                let worst_before = |samples: &[(f64, f64)], crossing: f64, near: f64| {
                    let mut worst = (0.0f64, at(0.0));
                    for &(ti, vi) in samples {
                        let gap = crossing - ti;
                        if gap > near {
                            let r = vi.abs() / gap;
                            if r > worst.0 {
                                worst = (r, at(ti));
                            }
                        }
                    }
                    worst
                };
                while t <= tmax && samples.len() < MAX_SAMPLES {
                    let v = f(t);
                    if !v.is_finite() {
                        return None;
                    }
                    let touch = 1e-5 * (1.0 + t);
                    // A sign change at t, or just past a near-zero value at t.
                    let mut bracket =
                        (v.signum() != sign && v != 0.0).then(|| (samples.last().map(|s| s.0).unwrap_or(0.0), t));
                    if bracket.is_none() && v.abs() < touch {
                        for k in [2.0, 10.0, 50.0] {
                            let u = t + k * touch;
                            let w = f(u);
                            if w.signum() != sign && w != 0.0 {
                                bracket = Some((t, u));
                                break;
                            }
                        }
                        if bracket.is_none() {
                            // The field reaches zero without changing sign (an
                            // unsigned field such as abs(f), or a tangency): the
                            // surface is at least |v| further on.
                            return Some(worst_before(&samples, t + v.abs(), 1000.0 * touch));
                        }
                    }
                    if let Some((mut a, mut b)) = bracket {
                        for _ in 0..60 {
                            let m = 0.5 * (a + b);
                            if f(m).signum() == sign {
                                a = m;
                            } else {
                                b = m;
                            }
                        }
                        return Some(worst_before(&samples, a, 1e-9 * (1.0 + a)));
                    }
                    samples.push((t, v));
                    t += (v.abs() * STEP_FRACTION).clamp(touch, max_step);
                }
                None
            },
        )
        .collect();
    let crossings = results.iter().flatten().count();
    let (worst_ratio, at) = results
        .iter()
        .flatten()
        .fold((0.0, [0.0; 3]), |acc, r| if r.0 > acc.0 { *r } else { acc });
    BoundCheck {
        object,
        surfaces: scene.equation_surfaces(object),
        rays: rays.len(),
        crossings,
        worst_ratio,
        at,
    }
}

/// Checks every object that calls an implicit or parametric surface, except
/// those whose surfaces are all `image_only` (their field is only
/// approximately a bound, by design; see docs/SURFACES.md).
pub fn check_scene(scene: &Scene) -> Vec<BoundCheck> {
    (0..scene.objects.len())
        .filter(|&i| {
            let names = scene.equation_surfaces(i);
            !names.is_empty()
                && !names
                    .iter()
                    .all(|n| scene.library.surface(n).is_some_and(|s| s.options.image_only))
        })
        .map(|i| check_object(scene, i, 64, 36))
        .collect()
}
