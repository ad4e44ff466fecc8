//! Sampling lights: the direction and distance from a shading point to a
//! light, or to the `j`-th of `n` sample points of an area light.
//!
//! Area-light samples are a Fibonacci lattice over the light, rotated per
//! shading point by a hash of its seed (Cranley–Patterson), so the noise is
//! spread evenly, never correlated between neighbouring pixels, and the same
//! for the same pixel whatever the thread count.

use glam::Vec3;
use isoray_scene::LightKind;

/// A 32-bit integer hash (lowbias32).
pub fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The `j`-th of `n` points of the unit square, shifted by the seed.
pub fn lattice(j: u32, n: u32, seed: u32) -> (f32, f32) {
    let h1 = hash(seed) as f32 / u32::MAX as f32;
    let h2 = hash(seed ^ 0x68e3_1da4) as f32 / u32::MAX as f32;
    let golden = 0.618_034f32;
    let u = ((j as f32 + 0.5) / n as f32 + h1).fract();
    let v = (j as f32 * golden + h2).fract();
    (u, v)
}

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

/// The unit direction from `p` towards the light (its `j`-th of `n` samples)
/// and the distance to it (infinite for directional lights).
pub fn sample(kind: &LightKind, p: Vec3, j: u32, n: u32, seed: u32) -> (Vec3, f32) {
    let towards = |q: Vec3| {
        let d = q - p;
        (d.normalize_or_zero(), d.length())
    };
    match *kind {
        LightKind::Directional { direction } => (v3(direction), f32::INFINITY),
        LightKind::Point { position } => towards(v3(position)),
        LightKind::Sphere { position, radius } => {
            // A point of the disc of the sphere's silhouette seen from p.
            let c = v3(position);
            let w = (c - p).normalize_or_zero();
            let a = if w.x.abs() > 0.9 { Vec3::Y } else { Vec3::X };
            let e1 = w.cross(a).normalize_or_zero();
            let e2 = w.cross(e1);
            let (u, v) = lattice(j, n, seed);
            let r = radius as f32 * u.sqrt();
            let phi = std::f32::consts::TAU * v;
            towards(c + e1 * (r * phi.cos()) + e2 * (r * phi.sin()))
        }
        LightKind::Rect { position, u, v } => {
            let (a, b) = lattice(j, n, seed);
            towards(v3(position) + v3(u) * (a - 0.5) + v3(v) * (b - 0.5))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_cover_the_light() {
        let kind = LightKind::Rect {
            position: [0.0, 5.0, 0.0],
            u: [2.0, 0.0, 0.0],
            v: [0.0, 0.0, 1.0],
        };
        let p = Vec3::ZERO;
        let mut xs = Vec::new();
        for j in 0..64 {
            let (l, d) = sample(&kind, p, j, 64, 7);
            let q = l * d;
            assert!(
                (q.y - 5.0).abs() < 1e-4 && q.x.abs() <= 1.0 + 1e-5 && q.z.abs() <= 0.5 + 1e-5,
                "{q}"
            );
            xs.push(q.x);
        }
        let mean = xs.iter().sum::<f32>() / 64.0;
        assert!(mean.abs() < 0.05, "{mean}");
        // The same seed gives the same samples; another seed others.
        assert_eq!(sample(&kind, p, 3, 64, 7), sample(&kind, p, 3, 64, 7));
        assert_ne!(sample(&kind, p, 3, 64, 7), sample(&kind, p, 3, 64, 8));
        let sphere = LightKind::Sphere {
            position: [0.0, 4.0, 0.0],
            radius: 0.5,
        };
        for j in 0..32 {
            let (l, d) = sample(&sphere, p, j, 32, 1);
            let q = l * d;
            assert!((q.y - 4.0).abs() < 1e-4 && q.x.hypot(q.z) <= 0.5 + 1e-5, "{q}");
        }
    }
}
