//! Local illumination for the polygon pipeline, with the ray tracer's
//! formulas ([`isoray_render::shade`]): emission + ambient + Σ over lights of
//! colour × intensity × attenuation × (diffuse + specular), without shadows
//! or ambient occlusion. Area lights are lit from their centre point.

use glam::Vec3;
use isoray_render::shade::{direct, Surface};
use isoray_scene::{LightKind, Scene};

/// How polygons are shaded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shading {
    /// One colour per triangle: lit at its centroid with its face normal.
    Flat,
    /// Colours lit at the vertices, interpolated across the triangle.
    Gouraud,
    /// Normals interpolated across the triangle, renormalised, lit per fragment.
    #[default]
    Phong,
}

/// What shading needs from the scene, prepared once.
#[derive(Debug, Clone)]
pub struct Lighting<'s> {
    scene: &'s Scene,
    surfaces: Vec<Surface>,
    eye: Vec3,
}

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

impl<'s> Lighting<'s> {
    /// Prepares the materials and the eye position of `scene`.
    pub fn new(scene: &'s Scene) -> Self {
        Lighting {
            scene,
            surfaces: scene.materials.iter().map(Surface::from).collect(),
            eye: v3(scene.camera.position),
        }
    }

    /// The surface of material `m` at world point `p` (checkers applied).
    pub fn surface(&self, m: usize, p: Vec3) -> &Surface {
        if let Some((other, size)) = self.scene.materials[m].checker {
            let inv = 1.0 / size as f32;
            let cell = (p.x * inv).floor() + (p.y * inv).floor() + (p.z * inv).floor();
            if (cell as i64).rem_euclid(2) == 1 {
                return &self.surfaces[other];
            }
        }
        &self.surfaces[m]
    }

    /// Linear RGB leaving world point `p` with unit normal `n`, of material `m`, towards the eye.
    pub fn shade(&self, m: usize, p: Vec3, n: Vec3) -> Vec3 {
        let s = self.surface(m, p);
        let v = (self.eye - p).normalize_or_zero();
        let mut c = s.emission + s.ambient;
        for light in &self.scene.lights {
            let (l, dist) = match light.kind {
                LightKind::Directional { direction } => (v3(direction).normalize_or_zero(), f32::INFINITY),
                LightKind::Point { position }
                | LightKind::Sphere { position, .. }
                | LightKind::Rect { position, .. } => {
                    let d = v3(position) - p;
                    (d.normalize_or_zero(), d.length())
                }
            };
            let a = light.attenuation;
            let att = if dist.is_finite() {
                1.0 / (a[0] as f32 + a[1] as f32 * dist + a[2] as f32 * dist * dist).max(1e-12)
            } else {
                1.0
            };
            let radiance = v3(light.color) * light.intensity as f32;
            c += radiance * att * direct(s, n, v, l);
        }
        c
    }

    /// Opacity of material `m`: 1 − transparency.
    pub fn opacity(&self, m: usize) -> f32 {
        (1.0 - self.surfaces[m].transparency).clamp(0.0, 1.0)
    }
}
