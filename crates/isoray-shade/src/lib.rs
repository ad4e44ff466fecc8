//! # isoray-shade
//!
//! The one shading model of isoray, written once and called by every
//! renderer: the CPU ray tracer (`isoray-render`) and the polygon pipeline
//! (`isoray-raster`); a GPU backend's shader twin is to be checked against it.
//!
//! Everything is a plain function of plain values in f32 (glam's [`Vec3`]),
//! documented with its formula, so that a WGSL twin can be checked against
//! it value by value. Colours are linear RGB; directions are unit vectors.
//!
//! * [`material`]: [`MaterialSample`] (a scene material in f32), its blend
//!   across a smooth union, the 3D checker;
//! * [`phong`]: Phong and Blinn-Phong local illumination, emission and ambient;
//! * [`lights`]: direction, distance and attenuation towards a light, area-light
//!   sampling, radiance per sample;
//! * [`optics`]: reflection, refraction, Fresnel (Schlick and exact), the
//!   energy split, Beer–Lambert absorption;
//! * [`srgb`]: the sRGB encoding applied once, at output.
//!
//! ```
//! use glam::Vec3;
//! use isoray_scene::{Fresnel, Light, LightKind, Material};
//! use isoray_shade::{lights, optics, phong, srgb, MaterialSample};
//!
//! // The default grey Blinn-Phong material, lit by a point light 2 above it.
//! let grey = MaterialSample::from(&Material::default_named("grey"));
//! let light = Light {
//!     kind: LightKind::Point { position: [0.0, 2.0, 0.0] },
//!     color: [1.0; 3],
//!     intensity: 1.0,
//!     size: 0.1,
//!     attenuation: [1.0, 0.0, 0.25],
//!     samples: 1,
//! };
//! let (p, n, v) = (Vec3::ZERO, Vec3::Y, Vec3::Y);
//! let inc = lights::incident(&light, p);
//! assert_eq!((inc.dir, inc.dist), (Vec3::Y, 2.0));
//! assert_eq!(inc.attenuation, 0.5); // 1 / (1 + 0.25 · 2²)
//!
//! // ambient 0.1 + 0.5 · (diffuse 0.8 · N·L + specular 0.5 · (N·H)³²), N·L = N·H = 1
//! let arriving = lights::radiance(&light, 1) * inc.attenuation;
//! let colour = phong::emitted_and_ambient(&grey, Vec3::ONE, 1.0)
//!     + phong::direct_light(&grey, n, v, inc.dir, Vec3::ONE, arriving);
//! assert!((colour - Vec3::splat(0.75)).abs().max_element() < 1e-6);
//! assert_eq!(srgb::to_srgb8(&[colour.to_array()]), vec![225, 225, 225]);
//!
//! // Glass reflects 4 % at normal incidence.
//! assert!((optics::fresnel(Fresnel::Exact, 1.0, 1.0, 1.5) - 0.04).abs() < 1e-6);
//! ```

pub mod lights;
pub mod material;
pub mod optics;
pub mod phong;
pub mod srgb;

use glam::Vec3;
pub use material::MaterialSample;

/// A scene vector (`[f64; 3]`) as an f32 [`Vec3`], each component rounded
/// to the nearest f32.
pub fn to_vec3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_vectors_round_to_f32() {
        assert_eq!(to_vec3([1.0, -2.5, 0.1]), Vec3::new(1.0, -2.5, 0.1f32));
    }
}
