//! Material samples: a scene [`Material`] in f32, blended across a smooth
//! union of objects, and the 3D checker that swaps in another material.

use glam::Vec3;
use isoray_scene::{Fresnel, Material, ShadingModel, SpecularFunction};

use crate::to_vec3;

/// A material in f32 as a renderer shades it at one point: a scene
/// material, possibly blended from several objects' materials
/// ([`MaterialSample::mix`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaterialSample {
    /// Ambient reflectance.
    pub ambient: Vec3,
    /// Diffuse reflectance.
    pub diffuse: Vec3,
    /// Specular reflectance.
    pub specular: Vec3,
    /// Specular exponent.
    pub shininess: f32,
    /// Emitted light.
    pub emission: Vec3,
    /// Phong or Blinn-Phong.
    pub model: ShadingModel,
    /// Pow or Schlick.
    pub specular_function: SpecularFunction,
    /// Mirror reflectance.
    pub reflectivity: Vec3,
    /// Transmitted fraction of the light not reflected.
    pub transparency: f32,
    /// Index of refraction.
    pub ior: f32,
    /// Beer–Lambert absorption per unit distance inside.
    pub absorption: Vec3,
    /// Fresnel weighting.
    pub fresnel: Fresnel,
    /// Fresnel–Schlick weighting of the specular term.
    pub specular_fresnel: bool,
}

impl From<&Material> for MaterialSample {
    /// Every number rounded to the nearest f32; the checker is not part of a
    /// sample (see [`checker`]).
    fn from(m: &Material) -> Self {
        MaterialSample {
            ambient: to_vec3(m.ambient),
            diffuse: to_vec3(m.diffuse),
            specular: to_vec3(m.specular),
            shininess: m.shininess as f32,
            emission: to_vec3(m.emission),
            model: m.model,
            specular_function: m.specular_function,
            reflectivity: to_vec3(m.reflectivity),
            transparency: m.transparency as f32,
            ior: m.ior as f32,
            absorption: to_vec3(m.absorption),
            fresnel: m.fresnel,
            specular_fresnel: m.specular_fresnel,
        }
    }
}

impl MaterialSample {
    /// Linear interpolation towards `other` by `h`: colours (vectors) by
    /// `Vec3::lerp`, x·(1 − h) + y·h per channel; shininess, transparency and
    /// ior as x + (y − x)·h; the shading model, specular function and
    /// Fresnel weightings switch to `other`'s at h ≥ 0.5. Exact at the
    /// ends: h ≤ 0 gives `self` and h ≥ 1 gives `other`, bit for bit (the
    /// renderer relies on both to skip objects that cannot change a blend).
    pub fn mix(&self, other: &MaterialSample, h: f32) -> MaterialSample {
        if h <= 0.0 {
            return *self;
        }
        if h >= 1.0 {
            return *other;
        }
        MaterialSample {
            ambient: self.ambient.lerp(other.ambient, h),
            diffuse: self.diffuse.lerp(other.diffuse, h),
            specular: self.specular.lerp(other.specular, h),
            shininess: self.shininess + (other.shininess - self.shininess) * h,
            emission: self.emission.lerp(other.emission, h),
            model: if h < 0.5 { self.model } else { other.model },
            specular_function: if h < 0.5 {
                self.specular_function
            } else {
                other.specular_function
            },
            reflectivity: self.reflectivity.lerp(other.reflectivity, h),
            transparency: self.transparency + (other.transparency - self.transparency) * h,
            ior: self.ior + (other.ior - self.ior) * h,
            absorption: self.absorption.lerp(other.absorption, h),
            fresnel: if h < 0.5 { self.fresnel } else { other.fresnel },
            specular_fresnel: if h < 0.5 {
                self.specular_fresnel
            } else {
                other.specular_fresnel
            },
        }
    }

    /// True when rays leave this surface (reflection or refraction):
    /// some reflectivity channel > 0 or transparency > 0.
    pub fn is_optical(&self) -> bool {
        self.reflectivity.max_element() > 0.0 || self.transparency > 0.0
    }

    /// What a straight shadow ray keeps crossing this surface (refraction
    /// not followed): τ·(1 − k_r) per channel, τ the transparency and k_r
    /// the reflectivity.
    pub fn interface_transmittance(&self) -> Vec3 {
        Vec3::splat(self.transparency) * (Vec3::ONE - self.reflectivity)
    }
}

/// The weight of `b`'s material where a smooth union of width `k` (> 0)
/// joins a surface at distance `a` and one at distance `b`:
/// h = clamp(½ + ½·(a − b)/k, 0, 1), 0 where `a` is the nearer by k or
/// more, 1 where `b` is, ½ where they are equally near. Mix with
/// [`MaterialSample::mix`]; `k` is the union's width times
/// `render.material_blend`.
pub fn blend_weight(a: f32, b: f32, k: f32) -> f32 {
    (0.5 + 0.5 * (a - b) / k).clamp(0.0, 1.0)
}

/// The quadratic smooth minimum of width `k` (> 0) in f32,
/// min(a, b) − max(k − |a − b|, 0)²·¼ / k: the scene's
/// `smooth_union(a, b, k)` (n = 2), which the material blend folds over
/// the objects in file order.
pub fn smooth_min(a: f32, b: f32, k: f32) -> f32 {
    let h = (k - (a - b).abs()).max(0.0);
    a.min(b) - h * h * 0.25 / k
}

/// True when `p` lies in an odd cell of a 3D checker of cell size `size`:
/// ⌊x/s⌋ + ⌊y/s⌋ + ⌊z/s⌋ is odd, computed as ⌊x·(1/s)⌋ + … in f32.
pub fn checker_odd(p: Vec3, size: f32) -> bool {
    let inv = 1.0 / size;
    let cell = (p * inv).floor();
    ((cell.x + cell.y + cell.z) as i64).rem_euclid(2) == 1
}

/// The material that replaces `m` at `p`: `Some(other)` when `m` is a
/// checker (`Material::checker` = (other, size)) and `p` is in an odd cell
/// ([`checker_odd`]), `None` where `m` itself applies.
pub fn checker(m: &Material, p: Vec3) -> Option<usize> {
    let (other, size) = m.checker?;
    checker_odd(p, size as f32).then_some(other)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checker_parity_at_known_points() {
        // Cell (0, 0, 0) is even; one step along any axis is odd; two are even.
        assert!(!checker_odd(Vec3::new(0.5, 0.5, 0.5), 1.0));
        assert!(checker_odd(Vec3::new(1.5, 0.5, 0.5), 1.0));
        assert!(checker_odd(Vec3::new(0.5, 0.5, -0.5), 1.0));
        assert!(!checker_odd(Vec3::new(1.5, -0.5, 0.5), 1.0));
        // Negative coordinates floor down: ⌊−0.1⌋ = −1.
        assert!(checker_odd(Vec3::new(-0.1, 0.2, 0.2), 1.0));
        assert!(!checker_odd(Vec3::new(-0.1, -0.2, 0.2), 1.0));
        // Cell size 2: (3, 0, 0) is in cell (1, 0, 0).
        assert!(checker_odd(Vec3::new(3.0, 0.0, 0.0), 2.0));
        assert!(!checker_odd(Vec3::new(1.9, 1.9, 1.9), 2.0));
        // A point on a cell boundary belongs to the cell above it.
        assert!(checker_odd(Vec3::new(1.0, 0.0, 0.0), 1.0));

        let mut m = Material::default_named("floor");
        assert_eq!(checker(&m, Vec3::new(1.5, 0.5, 0.5)), None);
        m.checker = Some((3, 0.5));
        assert_eq!(checker(&m, Vec3::new(0.75, 0.25, 0.25)), Some(3));
        assert_eq!(checker(&m, Vec3::new(0.75, 0.75, 0.25)), None);
    }

    #[test]
    fn blending_follows_the_smooth_union() {
        assert_eq!(blend_weight(0.0, 0.0, 1.0), 0.5);
        assert_eq!(blend_weight(1.0, 0.0, 1.0), 1.0);
        assert_eq!(blend_weight(-1.0, 0.0, 1.0), 0.0);
        assert_eq!(blend_weight(0.25, 0.0, 1.0), 0.625);
        // Far apart: the minimum. Equal: min − k/4.
        assert_eq!(smooth_min(0.0, 2.0, 1.0), 0.0);
        assert_eq!(smooth_min(0.5, 0.5, 1.0), 0.25);
        // |a − b| = k/2: min − (k/2)²/(4k) = min − k/16.
        assert_eq!(smooth_min(0.0, 0.5, 1.0), -0.0625);
        let grey = MaterialSample::from(&Material::default_named("a"));
        let mut red = grey;
        red.diffuse = Vec3::new(1.0, 0.0, 0.0);
        red.model = ShadingModel::Phong;
        let half = grey.mix(&red, 0.5);
        assert!((half.diffuse - Vec3::new(0.9, 0.4, 0.4)).abs().max_element() < 1e-6);
        assert_eq!(half.model, ShadingModel::Phong);
        assert_eq!(grey.mix(&red, 0.49).model, ShadingModel::BlinnPhong);
        assert_eq!(grey.mix(&red, 0.0), grey);
        assert_eq!(grey.mix(&red, 1.0), red);
    }

    #[test]
    fn samples_round_the_material() {
        let mut m = Material::default_named("glass");
        m.transparency = 0.9;
        m.reflectivity = [0.1, 0.2, 0.0];
        let s = MaterialSample::from(&m);
        assert_eq!(s.ambient, Vec3::splat(0.1));
        assert_eq!(s.shininess, 32.0);
        assert_eq!(s.ior, 1.5);
        assert!(s.is_optical());
        assert!(!MaterialSample::from(&Material::default_named("m")).is_optical());
        let t = s.interface_transmittance();
        assert!((t - Vec3::new(0.81, 0.72, 0.9)).abs().max_element() < 1e-6, "{t}");
    }
}
