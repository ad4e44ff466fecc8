//! Local illumination for the polygon pipeline, with the ray tracer's
//! formulas ([`isoray_render::shade`]): emission + ambient + Σ over lights of
//! colour × intensity × attenuation × visibility × (diffuse + specular),
//! without ambient occlusion. Area lights are lit from their centre point.
//! Visibility (shadows) comes from the caller: shadow buffers or the
//! A-buffered environment map.

use glam::Vec3;
use isoray_render::shade::{direct_parts, Surface};
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
        let v = (self.eye - p).normalize_or_zero();
        self.shade_lit(self.surface(m, p), p, n, v, Vec3::ONE, |_, _, _| 1.0)
    }

    /// The direction toward light `i` from `p` (unit), the distance to it
    /// (infinite for directional lights) and its attenuation there.
    pub fn light_at(&self, i: usize, p: Vec3) -> (Vec3, f32, f32) {
        let light = &self.scene.lights[i];
        let (l, dist) = match light.kind {
            LightKind::Directional { direction } => (v3(direction).normalize_or_zero(), f32::INFINITY),
            LightKind::Point { position } | LightKind::Sphere { position, .. } | LightKind::Rect { position, .. } => {
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
        (l, dist, att)
    }

    /// The ray tracer's local shading of surface `s` at `p` (unit normal
    /// `n`, unit direction `v` toward the viewer): emission + local·ambient +
    /// Σ lights radiance·attenuation·visibility·(local·diffuse + specular),
    /// where `local` is the Fresnel split's local weight (1 for opaque,
    /// non-reflective surfaces) and `visibility(light, l, distance)` the
    /// light's visibility (shadows; 1 without).
    pub fn shade_lit(
        &self,
        s: &Surface,
        p: Vec3,
        n: Vec3,
        v: Vec3,
        local: Vec3,
        visibility: impl Fn(usize, Vec3, f32) -> f32,
    ) -> Vec3 {
        let mut c = s.emission + local * s.ambient;
        for (i, light) in self.scene.lights.iter().enumerate() {
            let (l, dist, att) = self.light_at(i, p);
            if n.dot(l) <= 0.0 {
                continue;
            }
            let vis = visibility(i, l, dist);
            if vis <= 0.0 {
                continue;
            }
            let radiance = v3(light.color) * light.intensity as f32;
            let (diffuse, specular) = direct_parts(s, n, v, l);
            c += radiance * att * vis * (local * diffuse + specular);
        }
        c
    }

    /// The eye (camera position).
    pub fn eye(&self) -> Vec3 {
        self.eye
    }

    /// Opacity of material `m`: 1 − transparency.
    pub fn opacity(&self, m: usize) -> f32 {
        (1.0 - self.surfaces[m].transparency).clamp(0.0, 1.0)
    }
}
