//! An impact's dents: for each dentable object of the pair, the thesis's
//! model decides the depth (t·κ·max(0, |j| − ε/(1 − ε)) with the struck
//! object's material), and the other object, pushed that deep into it, is
//! imprinted into its height map (`dents = "bump"`) or cut out of its
//! geometry (`"sdf"`). `"auto"` cuts a dent that is deep (a quarter of the
//! map's `range` or more: half of what the map can hold) or that would
//! saturate the map (the ortho imprints measure deeper than the depth at
//! steep tilts), and imprints the others.

use std::sync::Arc;
use std::time::Instant;

use isoray_dent::imprint::{overlap_bound, reach_of, ImprintMethod, Sphere};
use isoray_dent::Rect;
use isoray_scene::{DentMode, Scene, SceneError, SdfDent};

use crate::Impact;

/// What an impact did to one of its objects.
#[derive(Debug, Clone, PartialEq)]
pub struct DentRecord {
    /// The struck object.
    pub object: usize,
    /// The object that struck it.
    pub impactor: usize,
    /// Its yield impulse ε/(1 − ε), N·s.
    pub yield_impulse: f64,
    /// The dent's depth t·κ·max(0, |j| − Y), scene units (0: no dent).
    pub depth: f64,
    /// Texels lowered.
    pub texels: u64,
    /// The rectangle of the height map written.
    pub rect: Option<Rect>,
    /// Texels saturated (clamped at the bottom of the map's range) so far.
    pub saturated: u64,
    /// The imprint's time, ms.
    pub imprint_ms: f64,
    /// The normal map's update, ms.
    pub normals_ms: f64,
    /// Whether the dent was cut into the geometry (an `[[object.sdf_dent]]`)
    /// rather than imprinted in the maps; `imprint_ms` is then the cut's
    /// time (the scene compiled again).
    pub geometry: bool,
}

/// Dents the dentable objects of `impact` in `scene` (their maps created
/// when they have none), the impactor at its pose in `scene` pushed so
/// that it overlaps the struck object by the dent's depth. Returns one
/// record per dentable object of the pair (depth 0 below the yield or for
/// a separating contact). An error only when a cut dent does not compile.
pub fn dent_impact(scene: &mut Scene, impact: &Impact, method: ImprintMethod) -> Result<Vec<DentRecord>, SceneError> {
    let mut out = Vec::new();
    for (struck, other, sign) in [(impact.a, impact.b, 1.0), (impact.b, impact.a, -1.0)] {
        let o = &scene.objects[struck];
        let mode = o.physics.dents;
        if mode == DentMode::None {
            continue;
        }
        let material = &scene.materials[o.material];
        let y = isoray_dent::impulse::yield_impulse(material.restitution);
        let depth = if impact.approaching {
            isoray_dent::impulse::dent_depth(
                material.thickness,
                material.dent_compliance,
                impact.impulse,
                material.restitution,
            )
        } else {
            0.0
        };
        let mut record = DentRecord {
            object: struck,
            impactor: other,
            yield_impulse: y,
            depth,
            texels: 0,
            rect: None,
            saturated: 0,
            imprint_ms: 0.0,
            normals_ms: 0.0,
            geometry: false,
        };
        if depth <= 0.0 {
            out.push(record);
            continue;
        }
        // The normal from the struck object towards the impactor.
        let n = impact.normal.map(|c| c * sign);
        // How far the impactor already overlaps the struck object along
        // n, measured on their fields (the solver's penetration of a mesh
        // collider can be off by its contact margin), then pushed the rest.
        let overlap = overlap_along(
            scene,
            struck,
            other,
            impact.point,
            n,
            impact.penetration.abs().max(depth),
        )
        .unwrap_or(impact.penetration);
        let shift = depth - overlap;
        let deep = depth >= 0.25 * o.physics.dent_map.range;
        if mode == DentMode::Sdf || (mode == DentMode::Auto && deep) {
            cut(scene, impact, struck, other, n, shift, &mut record)?;
            out.push(record);
            continue;
        }
        let Ok(mut maps) = o.physics.current_maps() else {
            out.push(record);
            continue;
        };
        let saturated_before = maps.height.saturated();
        let place = scene.placement(struck);
        let s = place.scale;
        let inputs = &scene.inputs;
        let a_shape = &o.shape;
        let b_shape = &scene.objects[other].shape;
        let a_local = |q: [f64; 3]| a_shape.eval_with(inputs, place.to_world(q)) / s;
        let b_world =
            |p: [f64; 3]| b_shape.eval_with(inputs, [p[0] + n[0] * shift, p[1] + n[1] * shift, p[2] + n[2] * shift]);
        let b_local = |q: [f64; 3]| b_world(place.to_world(q)) / s;
        let start: [f64; 3] = std::array::from_fn(|k| impact.point[k] - n[k] * 0.5 * depth);
        let cap = 4.0 * o.physics.dent_map.extent * s;
        let reach_world = reach_of(&b_world, start, cap, depth);
        let reach = Sphere {
            centre: place.to_local(reach_world.centre),
            radius: reach_world.radius / s,
        };
        let pixel = o.physics.dent_map.extent / maps.height.width() as f64;
        let started = Instant::now();
        let imprint = maps.imprint(
            method,
            &a_local,
            &b_local,
            place.to_local(impact.point),
            place.dir_to_local(n),
            reach,
            pixel,
        );
        record.imprint_ms = started.elapsed().as_secs_f64() * 1e3;
        let started = Instant::now();
        maps.update_normals();
        record.normals_ms = started.elapsed().as_secs_f64() * 1e3;
        if mode == DentMode::Auto && maps.height.saturated() > saturated_before {
            // The map cannot hold this dent: cut it instead (the maps stay as they were).
            record.normals_ms = 0.0;
            cut(scene, impact, struck, other, n, shift, &mut record)?;
            out.push(record);
            continue;
        }
        record.texels = imprint.lowered;
        record.rect = imprint.rect;
        record.saturated = maps.height.saturated();
        scene.objects[struck].physics.maps = Some(Arc::new(maps));
        out.push(record);
    }
    Ok(out)
}

/// The overlap of object `other` into object `struck` along the line
/// through `p` with direction `n` (from `struck` towards `other`): A's
/// surface on the line minus B's lowest point on it, both found by sphere
/// tracing from `reach`·10 away (positive when they overlap, negative for
/// a gap). None when either is not found.
fn overlap_along(scene: &Scene, struck: usize, other: usize, p: [f64; 3], n: [f64; 3], reach: f64) -> Option<f64> {
    use isoray_dent::field::{first_hit, March};
    let r = 10.0 * reach + 1e-6;
    let inputs = &scene.inputs;
    let (a, b) = (&scene.objects[struck].shape, &scene.objects[other].shape);
    let fa = |q: [f64; 3]| a.eval_with(inputs, q);
    let fb = |q: [f64; 3]| b.eval_with(inputs, q);
    let at = |s: f64| -> [f64; 3] { std::array::from_fn(|k| p[k] + s * n[k]) };
    let down = n.map(|c| -c);
    let s_a = r - first_hit(&fa, at(r), down, 2.0 * r, March::default())?;
    let s_b = -r + first_hit(&fb, at(-r), n, 2.0 * r, March::default())?;
    Some(s_a - s_b)
}

/// Cuts the impactor `other`, pushed `shift` along −`n` from its pose in
/// `scene`, out of `struck`'s geometry: an `[[object.sdf_dent]]` in the
/// struck object's own coordinates, bounded by the overlap of the two.
fn cut(
    scene: &mut Scene,
    impact: &Impact,
    struck: usize,
    other: usize,
    n: [f64; 3],
    shift: f64,
    record: &mut DentRecord,
) -> Result<(), SceneError> {
    let started = Instant::now();
    let place = scene.placement(struck);
    let mut pushed = scene.placement(other);
    for (k, c) in pushed.position.iter_mut().enumerate() {
        *c -= n[k] * shift;
    }
    let inputs = &scene.inputs;
    let a_shape = &scene.objects[struck].shape;
    let b_shape = &scene.objects[other].shape;
    let a_world = |p: [f64; 3]| a_shape.eval_with(inputs, p);
    let b_world =
        |p: [f64; 3]| b_shape.eval_with(inputs, [p[0] + n[0] * shift, p[1] + n[1] * shift, p[2] + n[2] * shift]);
    let s = place.scale;
    let o = &scene.objects[struck];
    let rim = o.physics.dent_rim;
    let cap = 4.0 * o.physics.dent_map.extent * s;
    let depth = record.depth;
    let bound = overlap_bound(&a_world, &b_world, impact.point, n, depth, cap, rim * s + 1e-9).unwrap_or_else(|| {
        // No overlap where expected: bound the impactor near the contact.
        let start: [f64; 3] = std::array::from_fn(|k| impact.point[k] - n[k] * 0.5 * depth);
        let r = reach_of(&b_world, start, cap, depth);
        Sphere {
            centre: r.centre,
            radius: r.radius + rim * s,
        }
    });
    let c = place.to_local(bound.centre);
    let dent = SdfDent {
        shape: scene.objects[other].source.clone(),
        placement: pushed.relative_to(&place),
        rim,
        bound: [c[0], c[1], c[2], bound.radius / s],
    };
    scene.add_sdf_dents(struck, &[dent])?;
    record.geometry = true;
    record.imprint_ms = started.elapsed().as_secs_f64() * 1e3;
    Ok(())
}
