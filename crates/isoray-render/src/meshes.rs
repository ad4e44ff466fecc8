//! Rays against the scene's triangle meshes (`[[mesh]]`): the nearest
//! triangle along each ray, which caps the ray's march through the
//! distance field, and shadow rays blocked by any triangle.

use isoray_scene::meshes::MeshObject;

use crate::trace::Rays;

/// The nearest triangle a ray meets, over all meshes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshHit {
    /// Distance along the ray.
    pub t: f32,
    /// The mesh, by index in [`isoray_scene::Scene::meshes`].
    pub mesh: u32,
    /// The triangle and where on it.
    pub hit: isoray_mesh::bvh::TriangleHit,
}

/// The nearest mesh hit of each ray (empty when there are no meshes).
pub fn closest_hits(meshes: &[MeshObject], rays: &Rays) -> Vec<Option<MeshHit>> {
    if meshes.is_empty() {
        return Vec::new();
    }
    (0..rays.len())
        .map(|i| closest(meshes, rays.origin(i), rays.direction(i), f32::INFINITY))
        .collect()
}

/// The nearest triangle of any mesh on the ray o + t·d, 0 < t < tmax.
pub fn closest(meshes: &[MeshObject], o: [f32; 3], d: [f32; 3], tmax: f32) -> Option<MeshHit> {
    let mut best: Option<MeshHit> = None;
    for (k, m) in meshes.iter().enumerate() {
        let (lo, ld) = m.to_local(o, d);
        let far = best.map_or(tmax, |b| b.t);
        if let Some(hit) = m.bvh().closest(lo, ld, 0.0, far) {
            best = Some(MeshHit {
                t: hit.t,
                mesh: k as u32,
                hit,
            });
        }
    }
    best
}

/// The world-space unit normal at a mesh hit (the interpolated vertex
/// normals, or the triangle's own).
pub fn normal(meshes: &[MeshObject], h: &MeshHit) -> [f32; 3] {
    let m = &meshes[h.mesh as usize];
    m.normal_to_world(isoray_mesh::bvh::hit_normal(m.mesh(), &h.hit))
}

/// Sets the visibility of every shadow ray that a triangle blocks before
/// its `tmax` to 0.
pub fn occlude(meshes: &[MeshObject], rays: &Rays, tmax: &[f32], vis: &mut [f32]) {
    if meshes.is_empty() {
        return;
    }
    for (i, v) in vis.iter_mut().enumerate() {
        if *v <= 0.0 {
            continue;
        }
        let (o, d) = (rays.origin(i), rays.direction(i));
        if meshes.iter().any(|m| {
            let (lo, ld) = m.to_local(o, d);
            m.bvh().any(lo, ld, 0.0, tmax[i])
        }) {
            *v = 0.0;
        }
    }
}
