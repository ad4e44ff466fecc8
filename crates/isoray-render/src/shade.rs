//! Local illumination: Phong and Blinn-Phong with ambient occlusion and shadows.

use glam::Vec3;
use isoray_scene::{Fresnel, Material, ShadingModel, SpecularFunction};

/// A material in f32, possibly blended from several objects' materials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surface {
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
}

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

impl From<&Material> for Surface {
    fn from(m: &Material) -> Self {
        Surface {
            ambient: v3(m.ambient),
            diffuse: v3(m.diffuse),
            specular: v3(m.specular),
            shininess: m.shininess as f32,
            emission: v3(m.emission),
            model: m.model,
            specular_function: m.specular_function,
            reflectivity: v3(m.reflectivity),
            transparency: m.transparency as f32,
            ior: m.ior as f32,
            absorption: v3(m.absorption),
            fresnel: m.fresnel,
        }
    }
}

impl Surface {
    /// Linear interpolation towards `other` by `h` (models switch at h = 0.5).
    pub fn mix(&self, other: &Surface, h: f32) -> Surface {
        Surface {
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
        }
    }

    /// True when rays leave this surface (reflection or refraction).
    pub fn is_optical(&self) -> bool {
        self.reflectivity.max_element() > 0.0 || self.transparency > 0.0
    }
}

/// The specular factor for a cosine `c` in [0, 1] and shininess `n`:
/// `c^n`, or Schlick's approximation `c / (n − n·c + c)`.
pub fn specular_factor(f: SpecularFunction, c: f32, n: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    match f {
        SpecularFunction::Pow => c.powf(n),
        SpecularFunction::Schlick => c / (n - n * c + c),
    }
}

/// Diffuse plus specular from one light arriving from unit direction `l`,
/// seen from unit direction `v` (towards the eye), at unit normal `n`.
pub fn direct(s: &Surface, n: Vec3, v: Vec3, l: Vec3) -> Vec3 {
    let (d, sp) = direct_parts(s, n, v, l);
    d + sp
}

/// The diffuse and the specular parts of [`direct`].
pub fn direct_parts(s: &Surface, n: Vec3, v: Vec3, l: Vec3) -> (Vec3, Vec3) {
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
    (
        s.diffuse * ndl,
        s.specular * specular_factor(s.specular_function, c, s.shininess),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn surf(model: ShadingModel) -> Surface {
        Surface {
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
        }
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
    fn schlick_approximates_pow() {
        for n in [5.0f32, 20.0, 80.0] {
            assert_eq!(specular_factor(SpecularFunction::Schlick, 1.0, n), 1.0);
            assert_eq!(specular_factor(SpecularFunction::Schlick, 0.0, n), 0.0);
            // Schlick (1994): t/(n - n t + t) is close to t^n and never above... at the half-width.
            let c = 0.5f32.powf(1.0 / n); // pow gives 0.5 here
            let s = specular_factor(SpecularFunction::Schlick, c, n);
            assert!((s - 0.5).abs() < 0.1, "n={n}: {s}");
        }
    }
}
