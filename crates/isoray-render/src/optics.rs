//! Geometric optics at a surface: mirror reflection, refraction by Snell's
//! law (vector form), total internal reflection, and the Fresnel split.
//!
//! Conventions: `i` is the unit direction of the incoming ray, `n` the unit
//! normal on the side the ray comes from (n·i ≤ 0), `eta` = n₁/n₂ the ratio
//! of the indices of refraction of the side the ray comes from and the side
//! it enters.

use glam::Vec3;
use isoray_scene::Fresnel;

/// Mirror reflection R = I − 2(N·I)N.
pub fn reflect(i: Vec3, n: Vec3) -> Vec3 {
    i - 2.0 * n.dot(i) * n
}

/// Refraction by Snell's law, n₁ sin θ₁ = n₂ sin θ₂: T = η I + (η cos θ₁ − cos θ₂) N,
/// with cos θ₂ = √(1 − η²(1 − cos² θ₁)); None on total internal reflection.
pub fn refract(i: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos1 = (-n.dot(i)).clamp(-1.0, 1.0);
    let k = 1.0 - eta * eta * (1.0 - cos1 * cos1);
    if k < 0.0 {
        return None;
    }
    Some((eta * i + (eta * cos1 - k.sqrt()) * n).normalize_or_zero())
}

/// The fraction of unpolarised light reflected at an interface from index `n1`
/// into index `n2`, at incidence cosine `cos1` (1 on total internal reflection).
pub fn fresnel(model: Fresnel, cos1: f32, n1: f32, n2: f32) -> f32 {
    let cos1 = cos1.clamp(0.0, 1.0);
    let sin2 = n1 / n2 * (1.0 - cos1 * cos1).max(0.0).sqrt();
    if sin2 >= 1.0 {
        return 1.0;
    }
    let cos2 = (1.0 - sin2 * sin2).sqrt();
    match model {
        Fresnel::Off => 0.0,
        Fresnel::Schlick => {
            let r0 = ((n1 - n2) / (n1 + n2)).powi(2);
            // Going into the optically thinner side, the transmitted angle is the larger one.
            let c = if n1 > n2 { cos2 } else { cos1 };
            r0 + (1.0 - r0) * (1.0 - c).powi(5)
        }
        Fresnel::Exact => {
            let rs = (n1 * cos1 - n2 * cos2) / (n1 * cos1 + n2 * cos2);
            let rp = (n1 * cos2 - n2 * cos1) / (n1 * cos2 + n2 * cos1);
            0.5 * (rs * rs + rp * rp)
        }
    }
}

/// How the light arriving at a surface point splits: into the mirror
/// direction, through the surface, and into local (diffuse) shading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Split {
    /// Weight of the reflected ray.
    pub reflect: Vec3,
    /// Weight of the refracted ray (zero on total internal reflection).
    pub transmit: Vec3,
    /// Weight of the local shading (ambient and diffuse).
    pub local: Vec3,
}

/// The split for reflectivity `kr`, transparency `tau` and Fresnel reflectance
/// `f` (0 when Fresnel is off): reflect = kr + (1 − kr)·f, transmit =
/// τ·(1 − reflect), local = (1 − τ)(1 − reflect); they sum to 1 per channel.
/// On total internal reflection the transmitted part is reflected.
pub fn split(kr: Vec3, tau: f32, f: f32, tir: bool) -> Split {
    let reflect = kr + (Vec3::ONE - kr) * f;
    let rest = Vec3::ONE - reflect;
    let (reflect, transmit) = if tir {
        (reflect + rest * tau, Vec3::ZERO)
    } else {
        (reflect, rest * tau)
    };
    Split {
        reflect,
        transmit,
        local: rest * (1.0 - tau),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deg(x: f32) -> f32 {
        x.to_degrees()
    }

    /// A unit direction at angle `theta` (radians) from −N = (0, −1, 0), in the xy plane.
    fn incoming(theta: f32) -> Vec3 {
        Vec3::new(theta.sin(), -theta.cos(), 0.0)
    }

    #[test]
    fn snell_air_to_glass_at_30_degrees() {
        let t = refract(incoming(30f32.to_radians()), Vec3::Y, 1.0 / 1.5).unwrap();
        let angle = deg(t.x.atan2(-t.y));
        assert!((angle - 19.47).abs() < 0.01, "{angle}");
        assert!((t.length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn total_internal_reflection_beyond_the_critical_angle() {
        let critical = deg((1.0f32 / 1.5).asin());
        assert!((critical - 41.81).abs() < 0.01, "{critical}");
        assert!(refract(incoming((critical - 0.1).to_radians()), Vec3::Y, 1.5).is_some());
        assert!(refract(incoming((critical + 0.1).to_radians()), Vec3::Y, 1.5).is_none());
        assert_eq!(
            fresnel(Fresnel::Schlick, (critical + 1.0).to_radians().cos(), 1.5, 1.0),
            1.0
        );
        assert_eq!(
            fresnel(Fresnel::Exact, (critical + 1.0).to_radians().cos(), 1.5, 1.0),
            1.0
        );
    }

    #[test]
    fn reflection_mirrors_the_angle() {
        let i = incoming(0.3);
        let r = reflect(i, Vec3::Y);
        assert!((r - Vec3::new(i.x, -i.y, 0.0)).length() < 1e-6);
    }

    #[test]
    fn fresnel_at_normal_incidence_is_four_percent() {
        for m in [Fresnel::Schlick, Fresnel::Exact] {
            assert!((fresnel(m, 1.0, 1.0, 1.5) - 0.04).abs() < 1e-6, "{m:?}");
            assert!((fresnel(m, 1.0, 1.5, 1.0) - 0.04).abs() < 1e-6, "{m:?}");
            // Grazing incidence reflects everything.
            assert!(fresnel(m, 1e-4, 1.0, 1.5) > 0.99, "{m:?}");
        }
        // Schlick stays close to the exact equations below the critical angle.
        for k in 0..80 {
            let c = (k as f32 * 1.1f32.to_radians()).cos();
            let (s, e) = (
                fresnel(Fresnel::Schlick, c, 1.0, 1.5),
                fresnel(Fresnel::Exact, c, 1.0, 1.5),
            );
            assert!((s - e).abs() < 0.06, "{k}: {s} {e}");
        }
        // Brewster's angle (56.31°): the p-polarised reflectance vanishes and
        // Rs = ((cos 56.31° − 1.5 cos 33.69°)/(cos 56.31° + 1.5 cos 33.69°))² = 0.1479,
        // so unpolarised light reflects Rs/2 = 0.0740.
        let b = 1.5f32.atan();
        let e = fresnel(Fresnel::Exact, b.cos(), 1.0, 1.5);
        assert!((e - 0.0740).abs() < 5e-4, "{e}");
    }

    #[test]
    fn energy_is_conserved() {
        for kr in [0.0, 0.3, 1.0] {
            for tau in [0.0, 0.5, 1.0] {
                for f in [0.0, 0.04, 0.5, 1.0] {
                    for tir in [false, true] {
                        let s = split(Vec3::splat(kr), tau, f, tir);
                        let total = s.reflect + s.transmit + s.local;
                        assert!(
                            (total - Vec3::ONE).abs().max_element() < 1e-6,
                            "{kr} {tau} {f} {tir}: {s:?}"
                        );
                        assert!(s.reflect.min_element() >= 0.0 && s.transmit.min_element() >= 0.0);
                    }
                }
            }
        }
    }
}
