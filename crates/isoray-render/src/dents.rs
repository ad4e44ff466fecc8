//! Normal mapping of dented objects: at a hit on an object whose dent maps
//! exist (`dents = "bump"` or `"auto"`), the normal is tilted by the
//! normal map ([`isoray_scene::Scene::dent_normal`]), so the dents shade
//! without changing the geometry.

use isoray_scene::Scene;

use crate::trace::Rays;
use crate::HitSet;

/// Tilts the normals of the hits on dented objects (`objects[k]`: the
/// object hit by hit k, meshes past the objects), seen along `rays`
/// (for parallax mapping).
pub(crate) fn perturb(scene: &Scene, hs: &mut HitSet, objects: &[usize], rays: &Rays) {
    if scene.objects.iter().all(|o| o.physics.maps.is_none()) {
        return;
    }
    for (k, &o) in objects.iter().enumerate() {
        let p = [hs.px[k] as f64, hs.py[k] as f64, hs.pz[k] as f64];
        let n = [hs.nx[k] as f64, hs.ny[k] as f64, hs.nz[k] as f64];
        let i = hs.idx[k];
        let to_eye = [-rays.dx[i] as f64, -rays.dy[i] as f64, -rays.dz[i] as f64];
        if let Some(w) = scene.dent_normal(o, p, n, to_eye) {
            hs.nx[k] = w[0] as f32;
            hs.ny[k] = w[1] as f32;
            hs.nz[k] = w[2] as f32;
        }
    }
}
