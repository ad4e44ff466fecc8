//! Local illumination for the polygon pipeline, with the ray tracer's
//! shading model ([`isoray_shade`]): emission + ambient + Σ over lights of
//! colour × intensity × attenuation × visibility × (diffuse + specular),
//! without ambient occlusion. Area lights are lit from their centre point
//! ([`isoray_shade::lights::incident`]). Visibility (shadows) comes from the
//! caller: shadow buffers or the A-buffered environment map.

use glam::Vec3;
use isoray_scene::Scene;
use isoray_shade::lights::{self, Incident};
use isoray_shade::material::checker;
use isoray_shade::{phong, to_vec3, MaterialSample};

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
    surfaces: Vec<MaterialSample>,
    eye: Vec3,
}

impl<'s> Lighting<'s> {
    /// Prepares the materials and the eye position of `scene`.
    pub fn new(scene: &'s Scene) -> Self {
        Lighting {
            scene,
            surfaces: scene.materials.iter().map(MaterialSample::from).collect(),
            eye: to_vec3(scene.camera.position),
        }
    }

    /// The surface of material `m` at world point `p` (checkers applied).
    pub fn surface(&self, m: usize, p: Vec3) -> &MaterialSample {
        let m = checker(&self.scene.materials[m], p).unwrap_or(m);
        &self.surfaces[m]
    }

    /// Linear RGB leaving world point `p` with unit normal `n`, of material `m`, towards the eye.
    pub fn shade(&self, m: usize, p: Vec3, n: Vec3) -> Vec3 {
        let v = (self.eye - p).normalize_or_zero();
        self.shade_lit(self.surface(m, p), p, n, v, Vec3::ONE, |_, _, _| 1.0)
    }

    /// The direction toward light `i` from `p` (unit), the distance to it
    /// (infinite for directional lights) and its attenuation there, area
    /// lights seen at their centre ([`lights::incident`]).
    pub fn light_at(&self, i: usize, p: Vec3) -> Incident {
        lights::incident(&self.scene.lights[i], p)
    }

    /// The ray tracer's local shading of surface `s` at `p` (unit normal
    /// `n`, unit direction `v` toward the viewer): emission + local·ambient +
    /// Σ lights radiance·attenuation·visibility·(local·diffuse + specular),
    /// where `local` is the Fresnel split's local weight (1 for opaque,
    /// non-reflective surfaces) and `visibility(light, l, distance)` the
    /// light's visibility (shadows; 1 without).
    pub fn shade_lit(
        &self,
        s: &MaterialSample,
        p: Vec3,
        n: Vec3,
        v: Vec3,
        local: Vec3,
        visibility: impl Fn(usize, Vec3, f32) -> f32,
    ) -> Vec3 {
        let mut c = phong::emitted_and_ambient(s, local, 1.0);
        for (i, light) in self.scene.lights.iter().enumerate() {
            let Incident {
                dir: l,
                dist,
                attenuation,
            } = self.light_at(i, p);
            if n.dot(l) <= 0.0 {
                continue;
            }
            let vis = visibility(i, l, dist);
            if vis <= 0.0 {
                continue;
            }
            let arriving = lights::radiance(light, 1) * attenuation * vis;
            c += phong::direct_light(s, n, v, l, local, arriving);
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
