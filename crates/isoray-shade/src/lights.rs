//! Lights as a shading point sees them: the unit direction towards the
//! light, the distance to it and the attenuation there ([`Incident`]),
//! either towards the light's centre ([`incident`]) or towards the `j`-th
//! of `n` sample points of an area light ([`sample`]), and the radiance one
//! sample carries ([`radiance`]).
//!
//! Area-light samples are a Fibonacci lattice over the light, rotated per
//! shading point by a hash of its seed (Cranley–Patterson), so the noise is
//! spread evenly, never correlated between neighbouring pixels, and the same
//! for the same pixel whatever the thread count.

use glam::Vec3;
use isoray_scene::{Light, LightKind};

use crate::to_vec3;

/// A 32-bit integer hash (lowbias32): x ^= x >> 16; x *= 0x7feb352d;
/// x ^= x >> 15; x *= 0x846ca68b; x ^= x >> 16 (wrapping products).
pub fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The `j`-th of `n` points of the unit square, shifted by the seed:
/// u = fract((j + ½)/n + h₁), v = fract(j·0.618034 + h₂), with
/// h₁ = hash(seed)/(2³² − 1) and h₂ = hash(seed ^ 0x68e31da4)/(2³² − 1)
/// (each converted to f32 first).
pub fn lattice(j: u32, n: u32, seed: u32) -> (f32, f32) {
    let h1 = hash(seed) as f32 / u32::MAX as f32;
    let h2 = hash(seed ^ 0x68e3_1da4) as f32 / u32::MAX as f32;
    let golden = 0.618_034f32;
    let u = ((j as f32 + 0.5) / n as f32 + h1).fract();
    let v = (j as f32 * golden + h2).fract();
    (u, v)
}

/// Where a light is, seen from a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Incident {
    /// Unit direction from the point towards the light.
    pub dir: Vec3,
    /// Distance to the light (infinite for directional lights).
    pub dist: f32,
    /// The light's [`attenuation`] at that distance.
    pub attenuation: f32,
}

/// The attenuation 1/max(c + l·d + q·d², 10⁻¹²) at distance `d`, with
/// [c, l, q] = `coefficients` (`Light::attenuation`, each rounded to f32);
/// 1 at infinite distance (directional lights).
pub fn attenuation(coefficients: [f64; 3], d: f32) -> f32 {
    let a = coefficients;
    if d.is_finite() {
        1.0 / (a[0] as f32 + a[1] as f32 * d + a[2] as f32 * d * d).max(1e-12)
    } else {
        1.0
    }
}

/// True for area lights (spheres and rectangles), which are sampled at
/// several points; false for point and directional lights.
pub fn is_area(light: &Light) -> bool {
    matches!(light.kind, LightKind::Sphere { .. } | LightKind::Rect { .. })
}

/// How many samples the ray tracer takes of a light: `Light::samples` for
/// area lights ([`is_area`]), 1 for point and directional ones.
pub fn sample_count(light: &Light) -> u32 {
    if is_area(light) {
        light.samples
    } else {
        1
    }
}

/// The radiance one of `samples` samples of the light carries:
/// colour × (intensity / samples).
pub fn radiance(light: &Light, samples: u32) -> Vec3 {
    to_vec3(light.color) * (light.intensity as f32 / samples as f32)
}

fn towards(p: Vec3, q: Vec3) -> (Vec3, f32) {
    let d = q - p;
    (d.normalize_or_zero(), d.length())
}

/// The light's centre seen from `p` (area lights lit from their centre, as
/// the polygon pipeline does): for directional lights the stored direction
/// renormalised in f32 and an infinite distance; for the others
/// normalize(c − p) and |c − p|, c the light's position. With its
/// [`attenuation`].
pub fn incident(light: &Light, p: Vec3) -> Incident {
    let (dir, dist) = match light.kind {
        LightKind::Directional { direction } => (to_vec3(direction).normalize_or_zero(), f32::INFINITY),
        LightKind::Point { position } | LightKind::Sphere { position, .. } | LightKind::Rect { position, .. } => {
            towards(p, to_vec3(position))
        }
    };
    Incident {
        dir,
        dist,
        attenuation: attenuation(light.attenuation, dist),
    }
}

/// The `j`-th of `n` samples of the light seen from `p`, with `seed`
/// choosing the lattice's shift ([`lattice`] gives (u, v)):
/// * directional: the stored direction (unit in f64, only rounded to f32),
///   infinite distance;
/// * point: towards its position;
/// * sphere (centre c, radius r): towards a point of the disc of its
///   silhouette seen from p, c + e₁·ρ cos φ + e₂·ρ sin φ with ρ = r√u,
///   φ = 2πv, w = normalize(c − p), e₁ = normalize(w × a) (a = y when
///   |w.x| > 0.9, else x) and e₂ = w × e₁;
/// * rectangle (centre c, edges u⃗, v⃗): towards c + u⃗(u − ½) + v⃗(v − ½).
///
/// With the [`attenuation`] at the sample's distance.
pub fn sample(light: &Light, p: Vec3, j: u32, n: u32, seed: u32) -> Incident {
    let (dir, dist) = match light.kind {
        LightKind::Directional { direction } => (to_vec3(direction), f32::INFINITY),
        LightKind::Point { position } => towards(p, to_vec3(position)),
        LightKind::Sphere { position, radius } => {
            let c = to_vec3(position);
            let w = (c - p).normalize_or_zero();
            let a = if w.x.abs() > 0.9 { Vec3::Y } else { Vec3::X };
            let e1 = w.cross(a).normalize_or_zero();
            let e2 = w.cross(e1);
            let (u, v) = lattice(j, n, seed);
            let r = radius as f32 * u.sqrt();
            let phi = std::f32::consts::TAU * v;
            towards(p, c + e1 * (r * phi.cos()) + e2 * (r * phi.sin()))
        }
        LightKind::Rect { position, u, v } => {
            let (a, b) = lattice(j, n, seed);
            towards(p, to_vec3(position) + to_vec3(u) * (a - 0.5) + to_vec3(v) * (b - 0.5))
        }
    };
    Incident {
        dir,
        dist,
        attenuation: attenuation(light.attenuation, dist),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn light(kind: LightKind) -> Light {
        Light {
            kind,
            color: [1.0, 0.5, 0.25],
            intensity: 2.0,
            size: 0.1,
            attenuation: [1.0, 0.0, 0.0],
            samples: 16,
        }
    }

    #[test]
    fn attenuation_values() {
        // None by default: 1/(1 + 0 + 0).
        assert_eq!(attenuation([1.0, 0.0, 0.0], 7.0), 1.0);
        // Linear: 1/(0 + 1·4) and quadratic: 1/(0 + 0 + 1·4²).
        assert_eq!(attenuation([0.0, 1.0, 0.0], 4.0), 0.25);
        assert_eq!(attenuation([0.0, 0.0, 1.0], 4.0), 1.0 / 16.0);
        // All three: 1/(1 + 0.5·2 + 0.25·2²) = 1/3.
        assert_eq!(attenuation([1.0, 0.5, 0.25], 2.0), 1.0 / 3.0);
        // Directional lights (infinite distance) are not attenuated.
        assert_eq!(attenuation([0.0, 0.0, 1.0], f32::INFINITY), 1.0);
        // A zero denominator is clamped, never infinite.
        assert_eq!(attenuation([0.0, 0.0, 1.0], 0.0), 1e12);
    }

    #[test]
    fn incidence_from_the_centre() {
        let mut l = light(LightKind::Point {
            position: [0.0, 3.0, 4.0],
        });
        l.attenuation = [0.0, 0.0, 1.0];
        let inc = incident(&l, Vec3::ZERO);
        assert_eq!(inc.dist, 5.0);
        assert!((inc.dir - Vec3::new(0.0, 0.6, 0.8)).length() < 1e-6);
        assert_eq!(inc.attenuation, 1.0 / 25.0);
        // A point light's one sample is its centre.
        assert_eq!(sample(&l, Vec3::ZERO, 0, 1, 9), inc);
        // Area lights are lit from their centre.
        let s = light(LightKind::Sphere {
            position: [0.0, 2.0, 0.0],
            radius: 1.0,
        });
        let inc = incident(&s, Vec3::new(0.0, 1.0, 0.0));
        assert_eq!((inc.dir, inc.dist, inc.attenuation), (Vec3::Y, 1.0, 1.0));
        let d = light(LightKind::Directional {
            direction: [0.0, 0.6, 0.8],
        });
        let inc = incident(&d, Vec3::new(5.0, 5.0, 5.0));
        assert_eq!(inc.dist, f32::INFINITY);
        assert_eq!(inc.attenuation, 1.0);
        assert!((inc.dir - Vec3::new(0.0, 0.6, 0.8)).length() < 1e-6);
        assert_eq!(sample(&d, Vec3::ZERO, 0, 1, 0).dir, Vec3::new(0.0, 0.6, 0.8));
    }

    #[test]
    fn radiance_is_split_over_the_samples() {
        let l = light(LightKind::Rect {
            position: [0.0; 3],
            u: [1.0, 0.0, 0.0],
            v: [0.0, 0.0, 1.0],
        });
        assert_eq!(sample_count(&l), 16);
        assert!(is_area(&l));
        assert_eq!(radiance(&l, 1), Vec3::new(2.0, 1.0, 0.5));
        assert_eq!(radiance(&l, 16), Vec3::new(0.125, 0.0625, 0.03125));
        let p = light(LightKind::Point { position: [0.0; 3] });
        assert_eq!(sample_count(&p), 1);
        assert!(!is_area(&p));
    }

    #[test]
    fn the_hash_is_lowbias32() {
        assert_eq!(hash(0), 0);
        assert_eq!(hash(1), hash(1));
        assert_ne!(hash(1), hash(2));
        let (u, v) = lattice(0, 4, 3);
        assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v));
        // Successive samples are 1/n apart in u (modulo 1).
        let (u1, _) = lattice(1, 4, 3);
        assert!(((u1 - u).rem_euclid(1.0) - 0.25).abs() < 1e-6);
    }

    #[test]
    fn samples_cover_the_light() {
        let kind = LightKind::Rect {
            position: [0.0, 5.0, 0.0],
            u: [2.0, 0.0, 0.0],
            v: [0.0, 0.0, 1.0],
        };
        let rect = light(kind);
        let p = Vec3::ZERO;
        let mut xs = Vec::new();
        for j in 0..64 {
            let s = sample(&rect, p, j, 64, 7);
            let q = s.dir * s.dist;
            assert!(
                (q.y - 5.0).abs() < 1e-4 && q.x.abs() <= 1.0 + 1e-5 && q.z.abs() <= 0.5 + 1e-5,
                "{q}"
            );
            xs.push(q.x);
        }
        let mean = xs.iter().sum::<f32>() / 64.0;
        assert!(mean.abs() < 0.05, "{mean}");
        // The same seed gives the same samples; another seed others.
        assert_eq!(sample(&rect, p, 3, 64, 7), sample(&rect, p, 3, 64, 7));
        assert_ne!(sample(&rect, p, 3, 64, 7), sample(&rect, p, 3, 64, 8));
        let sphere = light(LightKind::Sphere {
            position: [0.0, 4.0, 0.0],
            radius: 0.5,
        });
        for j in 0..32 {
            let s = sample(&sphere, p, j, 32, 1);
            let q = s.dir * s.dist;
            assert!((q.y - 4.0).abs() < 1e-4 && q.x.hypot(q.z) <= 0.5 + 1e-5, "{q}");
        }
    }
}
