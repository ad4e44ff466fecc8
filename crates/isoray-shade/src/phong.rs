//! Local illumination: Phong and Blinn-Phong.
//!
//! The light leaving a point towards the viewer is
//!
//! ```text
//! emission + local·ambient·ao + Σ_lights E · (local·diffuse·(N·L) + specular·f(c, n))
//! ```
//!
//! with `E` the light arriving along `L` (radiance × attenuation ×
//! visibility), `local` the weight the Fresnel split leaves to local shading
//! ([`crate::optics::split`]; 1 for opaque, non-reflective surfaces), `ao`
//! the ambient occlusion (1 without), `c` the specular cosine (R·V for
//! Phong, N·H for Blinn-Phong) and `f` the [`specular_factor`]. Renderers
//! sum [`emitted_and_ambient`] and one [`direct_light`] per light (sample).
//!
//! All directions are unit vectors: `n` the normal on the side the viewer
//! sees, `v` towards the viewer, `l` towards the light.

use glam::Vec3;
use isoray_scene::{ShadingModel, SpecularFunction};

use crate::MaterialSample;

/// The specular factor for a cosine `c` (clamped to [0, 1]) and shininess
/// `n`: `c^n`, or Schlick's rational approximation `c / (n − n·c + c)`.
pub fn specular_factor(f: SpecularFunction, c: f32, n: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    match f {
        SpecularFunction::Pow => c.powf(n),
        SpecularFunction::Schlick => c / (n - n * c + c),
    }
}

/// Diffuse plus specular from one light of unit radiance arriving from
/// unit direction `l`, seen from unit direction `v` (towards the eye), at
/// unit normal `n`: the sum of [`direct_parts`].
pub fn direct(s: &MaterialSample, n: Vec3, v: Vec3, l: Vec3) -> Vec3 {
    let (d, sp) = direct_parts(s, n, v, l);
    d + sp
}

/// The diffuse and the specular parts of [`direct`]: (diffuse·(N·L),
/// specular·f(c, shininess)) with c = R·V, R = 2(N·L)N − L (Phong), or
/// c = N·H, H = normalize(L + V) (Blinn-Phong; H = 0 when L = −V). Both
/// are zero when N·L ≤ 0 (the light is behind the surface).
pub fn direct_parts(s: &MaterialSample, n: Vec3, v: Vec3, l: Vec3) -> (Vec3, Vec3) {
    let ndl = n.dot(l);
    if ndl <= 0.0 {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let c = match s.model {
        ShadingModel::Phong => {
            let r = 2.0 * ndl * n - l;
            r.dot(v)
        }
        ShadingModel::BlinnPhong => n.dot((l + v).normalize_or_zero()),
    };
    let mut specular = s.specular * specular_factor(s.specular_function, c, s.shininess);
    if s.specular_fresnel {
        specular *= specular_fresnel(v, l);
    }
    (s.diffuse * ndl, specular)
}

/// The Granada thesis's Fresnel–Schlick weight of the highlight (Listing
/// 3.3): 0.04 + 0.96·(1 − h·l)⁵ with h the half vector of `l` and `v`.
pub fn specular_fresnel(v: Vec3, l: Vec3) -> f32 {
    let h = (l + v).normalize_or_zero();
    let x = (1.0 - h.dot(l).max(0.0)).clamp(0.0, 1.0);
    let x2 = x * x;
    0.04 + 0.96 * (x2 * x2 * x)
}

/// The light of one light (sample) reflected towards `v`:
/// `arriving · (local·diffuse + specular)` with the parts of
/// [`direct_parts`]. `arriving` is what reaches the point along `l`:
/// the light's radiance × attenuation × visibility (× transmission), and
/// `local` the Fresnel split's local weight, which scales only the diffuse
/// part (the highlight is a reflection, not local scattering).
pub fn direct_light(s: &MaterialSample, n: Vec3, v: Vec3, l: Vec3, local: Vec3, arriving: Vec3) -> Vec3 {
    let (diffuse, specular) = direct_parts(s, n, v, l);
    arriving * (local * diffuse + specular)
}

/// The unshadowed terms: `emission + local·ambient·ao`, with `local` the
/// Fresnel split's local weight and `ao` the ambient occlusion in [0, 1]
/// (1 without occlusion).
pub fn emitted_and_ambient(s: &MaterialSample, local: Vec3, ao: f32) -> Vec3 {
    s.emission + local * s.ambient * ao
}

#[cfg(test)]
mod tests {
    use super::*;
    use isoray_scene::Fresnel;

    fn surf(model: ShadingModel) -> MaterialSample {
        MaterialSample {
            ambient: Vec3::ZERO,
            diffuse: Vec3::splat(1.0),
            specular: Vec3::splat(1.0),
            shininess: 10.0,
            emission: Vec3::ZERO,
            model,
            specular_function: SpecularFunction::Pow,
            reflectivity: Vec3::ZERO,
            transparency: 0.0,
            ior: 1.5,
            absorption: Vec3::ZERO,
            fresnel: Fresnel::Schlick,
            specular_fresnel: false,
        }
    }

    /// The Granada thesis's Fresnel–Schlick weight: 0.04 face-on (h·l = 1),
    /// 0.04 + 0.96/32 where h·l = ½ (l and v 120° apart), and it scales only
    /// the specular part.
    #[test]
    fn specular_fresnel_weights_the_highlight() {
        let n = Vec3::Z;
        assert!((specular_fresnel(n, n) - 0.04).abs() < 1e-6);
        let (l, v) = (
            Vec3::new(0.75f32.sqrt(), 0.0, 0.5),
            Vec3::new(-(0.75f32.sqrt()), 0.0, 0.5),
        );
        assert!((specular_fresnel(v, l) - (0.04 + 0.96 / 32.0)).abs() < 1e-6);
        let mut s = surf(ShadingModel::BlinnPhong);
        let (d0, s0) = direct_parts(&s, n, n, n);
        s.specular_fresnel = true;
        let (d1, s1) = direct_parts(&s, n, n, n);
        assert_eq!(d0, d1);
        assert!((s1 - s0 * 0.04).length() < 1e-6, "{s0} {s1}");
    }

    #[test]
    fn lambert_and_highlights() {
        let n = Vec3::Y;
        let l = Vec3::new(1.0, 1.0, 0.0).normalize();
        let v = Vec3::new(-1.0, 1.0, 0.0).normalize();
        // Mirror configuration: both models give a full highlight.
        for m in [ShadingModel::Phong, ShadingModel::BlinnPhong] {
            let c = direct(&surf(m), n, v, l);
            assert!((c.x - (l.y + 1.0)).abs() < 1e-5, "{m:?}: {c}");
        }
        // Light below the horizon: nothing.
        assert_eq!(direct(&surf(ShadingModel::Phong), n, v, -l), Vec3::ZERO);
        // Away from the mirror direction, Phong's lobe is narrower than Blinn's.
        let v2 = Vec3::new(-0.2, 1.0, 0.0).normalize();
        let p = direct(&surf(ShadingModel::Phong), n, v2, l).x;
        let b = direct(&surf(ShadingModel::BlinnPhong), n, v2, l).x;
        assert!(p < b);
    }

    #[test]
    fn lambert_cosine_law() {
        // Diffuse only: N·L = cos 60° = 1/2.
        let mut s = surf(ShadingModel::Phong);
        s.specular = Vec3::ZERO;
        let l = Vec3::new(60f32.to_radians().sin(), 60f32.to_radians().cos(), 0.0);
        let (d, sp) = direct_parts(&s, Vec3::Y, Vec3::Y, l);
        assert!((d - Vec3::splat(0.5)).abs().max_element() < 1e-6, "{d}");
        assert_eq!(sp, Vec3::ZERO);
        // Phong at the mirror direction: R·V = 1, so the factor is 1 for any n.
        let s = surf(ShadingModel::Phong);
        let (_, sp) = direct_parts(&s, Vec3::Y, Vec3::new(-l.x, l.y, 0.0), l);
        assert!((sp - Vec3::ONE).abs().max_element() < 1e-5, "{sp}");
    }

    #[test]
    fn the_terms_combine_as_documented() {
        let mut s = surf(ShadingModel::BlinnPhong);
        s.ambient = Vec3::splat(0.2);
        s.emission = Vec3::new(0.1, 0.0, 0.0);
        s.diffuse = Vec3::splat(0.5);
        s.specular = Vec3::splat(0.25);
        let local = Vec3::splat(0.5);
        assert_eq!(emitted_and_ambient(&s, local, 0.5), Vec3::new(0.15, 0.05, 0.05));
        assert_eq!(emitted_and_ambient(&s, Vec3::ONE, 1.0), Vec3::new(0.3, 0.2, 0.2));
        // n = v = l: N·L = 1 and N·H = 1: E·(local·0.5 + 0.25).
        let c = direct_light(&s, Vec3::Y, Vec3::Y, Vec3::Y, local, Vec3::splat(2.0));
        assert_eq!(c, Vec3::splat(1.0));
        assert_eq!(
            direct_light(&s, Vec3::Y, Vec3::Y, -Vec3::Y, local, Vec3::ONE),
            Vec3::ZERO
        );
    }

    #[test]
    fn schlick_approximates_pow() {
        for n in [5.0f32, 20.0, 80.0] {
            assert_eq!(specular_factor(SpecularFunction::Schlick, 1.0, n), 1.0);
            assert_eq!(specular_factor(SpecularFunction::Schlick, 0.0, n), 0.0);
            assert_eq!(specular_factor(SpecularFunction::Pow, 1.0, n), 1.0);
            // Schlick (1994): t/(n − n t + t) is close to t^n at the half-width.
            let c = 0.5f32.powf(1.0 / n); // pow gives 0.5 here
            let s = specular_factor(SpecularFunction::Schlick, c, n);
            assert!((s - 0.5).abs() < 0.1, "n={n}: {s}");
        }
        // Cosines outside [0, 1] are clamped.
        assert_eq!(specular_factor(SpecularFunction::Pow, -0.5, 4.0), 0.0);
        assert_eq!(specular_factor(SpecularFunction::Pow, 1.5, 4.0), 1.0);
    }
}
