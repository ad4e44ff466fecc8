//! Geometric optics at a surface: mirror reflection, refraction by Snell's
//! law (vector form), total internal reflection, the Fresnel equations, the
//! energy split between reflection, transmission and local shading, and
//! Beer–Lambert absorption.
//!
//! Conventions: `i` is the unit direction of the incoming ray, `n` the unit
//! normal on the side the ray comes from (n·i ≤ 0), `eta` = n₁/n₂ the ratio
//! of the indices of refraction of the side the ray comes from and the side
//! it enters, `cos1` = −n·i the cosine of the angle of incidence.

use glam::Vec3;
use isoray_scene::Fresnel;

use crate::MaterialSample;

/// Mirror reflection R = I − 2(N·I)N.
pub fn reflect(i: Vec3, n: Vec3) -> Vec3 {
    i - 2.0 * n.dot(i) * n
}

/// Refraction by Snell's law, n₁ sin θ₁ = n₂ sin θ₂: T = η I + (η cos θ₁ − cos θ₂) N,
/// normalised, with cos θ₁ = clamp(−N·I, −1, 1) and
/// cos θ₂ = √k, k = 1 − η²(1 − cos² θ₁); `None` on total internal reflection (k < 0).
pub fn refract(i: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos1 = (-n.dot(i)).clamp(-1.0, 1.0);
    let k = 1.0 - eta * eta * (1.0 - cos1 * cos1);
    if k < 0.0 {
        return None;
    }
    Some((eta * i + (eta * cos1 - k.sqrt()) * n).normalize_or_zero())
}

/// cos θ₁ clamped to [0, 1] and cos θ₂ = √(1 − sin² θ₂) with
/// sin θ₂ = (n₁/n₂)·√max(1 − cos² θ₁, 0); `None` when sin θ₂ ≥ 1 (total
/// internal reflection).
fn cosines(cos1: f32, n1: f32, n2: f32) -> Option<(f32, f32)> {
    let cos1 = cos1.clamp(0.0, 1.0);
    let sin2 = n1 / n2 * (1.0 - cos1 * cos1).max(0.0).sqrt();
    if sin2 >= 1.0 {
        return None;
    }
    Some((cos1, (1.0 - sin2 * sin2).sqrt()))
}

/// The Fresnel amplitude coefficients (r_s, r_p) of light going from index
/// `n1` into index `n2` at incidence cosine `cos1` (clamped to [0, 1]):
/// r_s = (n₁ cos θ₁ − n₂ cos θ₂)/(n₁ cos θ₁ + n₂ cos θ₂),
/// r_p = (n₁ cos θ₂ − n₂ cos θ₁)/(n₁ cos θ₂ + n₂ cos θ₁);
/// `None` on total internal reflection. r_p vanishes at Brewster's angle,
/// tan θ₁ = n₂/n₁.
pub fn fresnel_amplitudes(cos1: f32, n1: f32, n2: f32) -> Option<(f32, f32)> {
    let (cos1, cos2) = cosines(cos1, n1, n2)?;
    Some(amplitudes(cos1, cos2, n1, n2))
}

/// (r_s, r_p) from both cosines (see [`fresnel_amplitudes`]).
fn amplitudes(cos1: f32, cos2: f32, n1: f32, n2: f32) -> (f32, f32) {
    let rs = (n1 * cos1 - n2 * cos2) / (n1 * cos1 + n2 * cos2);
    let rp = (n1 * cos2 - n2 * cos1) / (n1 * cos2 + n2 * cos1);
    (rs, rp)
}

/// The fraction of unpolarised light reflected at an interface from index
/// `n1` into index `n2`, at incidence cosine `cos1` (clamped to [0, 1]):
/// 1 on total internal reflection (whatever the model); otherwise
/// * `Off`: 0;
/// * `Schlick`: R₀ + (1 − R₀)(1 − c)⁵, R₀ = ((n₁ − n₂)/(n₁ + n₂))², with
///   c = cos θ₁ entering a denser medium and c = cos θ₂ leaving one
///   (the larger angle's cosine);
/// * `Exact`: (r_s² + r_p²)/2 with the amplitudes of [`fresnel_amplitudes`].
pub fn fresnel(model: Fresnel, cos1: f32, n1: f32, n2: f32) -> f32 {
    let Some((cos1, cos2)) = cosines(cos1, n1, n2) else {
        return 1.0;
    };
    match model {
        Fresnel::Off => 0.0,
        Fresnel::Schlick => {
            let r0 = ((n1 - n2) / (n1 + n2)).powi(2);
            // Going into the optically thinner side, the transmitted angle is the larger one.
            let c = if n1 > n2 { cos2 } else { cos1 };
            r0 + (1.0 - r0) * (1.0 - c).powi(5)
        }
        Fresnel::Exact => {
            let (rs, rp) = amplitudes(cos1, cos2, n1, n2);
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
/// On total internal reflection (`tir`) the transmitted part is reflected:
/// reflect += τ·(1 − reflect), transmit = 0.
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

/// What happens to a ray meeting a surface: the energy split and the
/// refracted direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interface {
    /// The weights of reflection, transmission and local shading.
    pub split: Split,
    /// The refracted unit direction; `None` for opaque surfaces and on
    /// total internal reflection.
    pub refracted: Option<Vec3>,
}

/// The interface of material `s` for a ray along `i` meeting unit normal
/// `n` (facing the ray), from index `n1` into index `n2`, with incidence
/// cosine `cos1` = −n·i (given separately so that a caller holding the
/// directions in f64 can pass its more precise value):
/// refracted = [`refract`]`(i, n, n1/n2)` when the transparency τ > 0;
/// split = [`split`]`(reflectivity, τ, `[`fresnel`]`(s.fresnel, cos1, n1, n2), tir)`,
/// tir when τ > 0 and the ray cannot refract.
pub fn interface(s: &MaterialSample, i: Vec3, n: Vec3, cos1: f32, n1: f32, n2: f32) -> Interface {
    let refracted = if s.transparency > 0.0 {
        refract(i, n, n1 / n2)
    } else {
        None
    };
    let f = fresnel(s.fresnel, cos1, n1, n2);
    Interface {
        split: split(
            s.reflectivity,
            s.transparency,
            f,
            s.transparency > 0.0 && refracted.is_none(),
        ),
        refracted,
    }
}

/// Beer–Lambert transmittance over a path of `length` inside a medium of
/// per-channel `absorption` σ: exp(−σ·length).
pub fn beer_lambert(absorption: Vec3, length: f32) -> Vec3 {
    (-absorption * length).exp()
}

#[cfg(test)]
mod tests {
    use super::*;
    use isoray_scene::Material;

    fn deg(x: f32) -> f32 {
        x.to_degrees()
    }

    /// A unit direction at angle `theta` (radians) from −N = (0, −1, 0), in the xy plane.
    fn incoming(theta: f32) -> Vec3 {
        Vec3::new(theta.sin(), -theta.cos(), 0.0)
    }

    #[test]
    fn snell_air_to_glass_at_30_degrees() {
        // sin θ₂ = sin 30° / 1.5 = 1/3: θ₂ = 19.47°, a deviation of 10.53°.
        let t = refract(incoming(30f32.to_radians()), Vec3::Y, 1.0 / 1.5).unwrap();
        let angle = deg(t.x.atan2(-t.y));
        assert!((angle - 19.47).abs() < 0.01, "{angle}");
        assert!((t.length() - 1.0).abs() < 1e-6);
        // Snell's law holds at every angle, both ways.
        for k in 0..40 {
            let theta1 = (k as f32 * 1.0).to_radians();
            let t = refract(incoming(theta1), Vec3::Y, 1.0 / 1.5).unwrap();
            assert!((theta1.sin() - 1.5 * t.x).abs() < 1e-5, "{k}");
            let back = refract(incoming(t.x.asin()), Vec3::Y, 1.5).unwrap();
            assert!((back.x - theta1.sin()).abs() < 1e-5, "{k}");
        }
        // Normal incidence goes straight through.
        let t = refract(-Vec3::Y, Vec3::Y, 1.0 / 1.5).unwrap();
        assert!((t + Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn total_internal_reflection_beyond_the_critical_angle() {
        let critical = deg((1.0f32 / 1.5).asin());
        assert!((critical - 41.81).abs() < 0.01, "{critical}");
        assert!(refract(incoming((critical - 0.1).to_radians()), Vec3::Y, 1.5).is_some());
        assert!(refract(incoming((critical + 0.1).to_radians()), Vec3::Y, 1.5).is_none());
        for m in [Fresnel::Off, Fresnel::Schlick, Fresnel::Exact] {
            assert_eq!(fresnel(m, (critical + 1.0).to_radians().cos(), 1.5, 1.0), 1.0);
        }
        assert_eq!(fresnel_amplitudes((critical + 1.0).to_radians().cos(), 1.5, 1.0), None);
        // Just below it the exact reflectance climbs steeply towards 1:
        // 0.463 half a degree below, 0.702 a tenth of a degree below.
        let below = |d: f32| fresnel(Fresnel::Exact, (critical - d).to_radians().cos(), 1.5, 1.0);
        assert!((below(0.5) - 0.4628).abs() < 5e-3, "{}", below(0.5));
        assert!((below(0.1) - 0.7018).abs() < 2e-2, "{}", below(0.1));
    }

    #[test]
    fn reflection_mirrors_the_angle() {
        let i = incoming(0.3);
        let r = reflect(i, Vec3::Y);
        assert!((r - Vec3::new(i.x, -i.y, 0.0)).length() < 1e-6);
        assert_eq!(reflect(-Vec3::Y, Vec3::Y), Vec3::Y);
    }

    #[test]
    fn fresnel_at_normal_incidence_is_four_percent() {
        // R₀ = ((n₁ − n₂)/(n₁ + n₂))² = (0.5/2.5)² = 0.04 for n = 1.5.
        for m in [Fresnel::Schlick, Fresnel::Exact] {
            assert!((fresnel(m, 1.0, 1.0, 1.5) - 0.04).abs() < 1e-6, "{m:?}");
            assert!((fresnel(m, 1.0, 1.5, 1.0) - 0.04).abs() < 1e-6, "{m:?}");
            // Grazing incidence reflects everything.
            assert!(fresnel(m, 1e-4, 1.0, 1.5) > 0.99, "{m:?}");
        }
        assert_eq!(fresnel(Fresnel::Off, 1.0, 1.0, 1.5), 0.0);
        // At normal incidence both amplitudes are (n₁ − n₂)/(n₁ + n₂) = −0.2 in this sign convention.
        let (rs, rp) = fresnel_amplitudes(1.0, 1.0, 1.5).unwrap();
        assert!((rs + 0.2).abs() < 1e-6 && (rp + 0.2).abs() < 1e-6, "{rs} {rp}");
        // Schlick stays close to the exact equations below the critical angle.
        for k in 0..80 {
            let c = (k as f32 * 1.1f32.to_radians()).cos();
            let (s, e) = (
                fresnel(Fresnel::Schlick, c, 1.0, 1.5),
                fresnel(Fresnel::Exact, c, 1.0, 1.5),
            );
            assert!((s - e).abs() < 0.06, "{k}: {s} {e}");
        }
    }

    #[test]
    fn brewster_angle_has_no_p_reflection() {
        // Brewster's angle, tan θ_B = n₂/n₁ = 1.5: θ_B = 56.31°.
        let b = 1.5f32.atan();
        assert!((deg(b) - 56.31).abs() < 0.01);
        let (rs, rp) = fresnel_amplitudes(b.cos(), 1.0, 1.5).unwrap();
        assert!(rp.abs() < 1e-6, "{rp}");
        // Rs = ((cos 56.31° − 1.5 cos 33.69°)/(cos 56.31° + 1.5 cos 33.69°))² = 0.1479,
        // so unpolarised light reflects Rs/2 = 0.0740.
        assert!((rs * rs - 0.1479).abs() < 5e-4, "{rs}");
        let e = fresnel(Fresnel::Exact, b.cos(), 1.0, 1.5);
        assert!((e - 0.0740).abs() < 5e-4, "{e}");
        assert_eq!(e, 0.5 * (rs * rs + rp * rp));
        // From inside, Brewster's angle is the complement: tan θ = 1/1.5.
        let (_, rp) = fresnel_amplitudes((1.0f32 / 1.5).atan().cos(), 1.5, 1.0).unwrap();
        assert!(rp.abs() < 1e-6, "{rp}");
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
        // Glass (τ = 1, no mirror) at normal incidence: 4 % reflected, 96 % transmitted.
        let s = split(Vec3::ZERO, 1.0, 0.04, false);
        assert_eq!(
            (s.reflect, s.transmit, s.local),
            (Vec3::splat(0.04), Vec3::splat(0.96), Vec3::ZERO)
        );
    }

    #[test]
    fn interfaces_refract_or_reflect_totally() {
        let mut m = Material::default_named("glass");
        m.transparency = 1.0;
        let glass = MaterialSample::from(&m);
        // Entering at normal incidence: straight through, 4 % reflected.
        let at = interface(&glass, -Vec3::Y, Vec3::Y, 1.0, 1.0, 1.5);
        assert!((at.refracted.unwrap() + Vec3::Y).length() < 1e-6);
        assert!((at.split.reflect - Vec3::splat(0.04)).abs().max_element() < 1e-6);
        // Leaving beyond the critical angle: everything reflects.
        let i = incoming(50f32.to_radians());
        let at = interface(&glass, i, Vec3::Y, -i.y, 1.5, 1.0);
        assert_eq!(at.refracted, None);
        assert_eq!(at.split.reflect, Vec3::ONE);
        assert_eq!(at.split.transmit, Vec3::ZERO);
        // Opaque surfaces never refract, and keep their local shading.
        let plastic = MaterialSample::from(&Material::default_named("plastic"));
        let at = interface(&plastic, i, Vec3::Y, -i.y, 1.0, 1.5);
        assert_eq!(at.refracted, None);
        assert!(at.split.local.min_element() > 0.5);
    }

    #[test]
    fn beer_lambert_halves_over_ln2() {
        let t = beer_lambert(Vec3::new(0.0, 1.0, 2.0), std::f32::consts::LN_2);
        assert!((t - Vec3::new(1.0, 0.5, 0.25)).abs().max_element() < 1e-6, "{t}");
    }
}
