//! Normal mapping of dented objects: at a hit on an object whose dent maps
//! exist (`dents = "bump"` or `"auto"`), the normal is tilted by the
//! normal map (isoray-dent's `DentMaps`), in the tangent frame of the
//! object's uv mapping, so the dents shade without changing the geometry.

use isoray_scene::{DentMode, Scene};

use crate::HitSet;

/// Tilts the normals of the hits on dented objects (`objects[k]`: the
/// object hit by hit k, meshes past the objects).
pub(crate) fn perturb(scene: &Scene, hs: &mut HitSet, objects: &[usize]) {
    for (k, &o) in objects.iter().enumerate() {
        let Some(obj) = scene.objects.get(o) else { continue };
        if !matches!(obj.physics.dents, DentMode::Bump | DentMode::Auto) {
            continue;
        }
        let Some(maps) = &obj.physics.maps else { continue };
        let place = scene.placement(o);
        let p = [hs.px[k] as f64, hs.py[k] as f64, hs.pz[k] as f64];
        let n = [hs.nx[k] as f64, hs.ny[k] as f64, hs.nz[k] as f64];
        let q = place.to_local(p);
        let nl = place.dir_to_local(n);
        if !maps.mapping.faces(q, nl) {
            continue;
        }
        let Some(uv) = maps.mapping.uv(q) else { continue };
        let (t, b) = maps.mapping.frame(q, nl);
        let ts = maps.normal_at(uv);
        let local: [f64; 3] = std::array::from_fn(|i| ts[0] * t[i] + ts[1] * b[i] + ts[2] * nl[i]);
        let w = place.dir_to_world(local);
        let l = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        if l > 0.0 && l.is_finite() {
            hs.nx[k] = (w[0] / l) as f32;
            hs.ny[k] = (w[1] / l) as f32;
            hs.nz[k] = (w[2] / l) as f32;
        }
    }
}
