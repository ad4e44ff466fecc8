//! Skeletons: `[[bone]]` tables (a name, a parent, a rest position and
//! rotation in the parent's frame), forward kinematics, and objects carried
//! by a bone (`bone = "NAME"`): the object's own placement is in the bone's
//! frame, and its world placement is computed whenever the time changes, as
//! the seven placement inputs of the object. Tracks drive a bone's
//! `rotation` (Euler degrees, or quaternions `[x, y, z, w]`) and
//! `position`.
//!
//! Rotations follow the objects' convention: Euler angles in degrees,
//! turned about x, then y, then z, in world axes: R = Rz·Ry·Rx.
//!
//! ```
//! use isoray_scene::skeleton::{euler_to_quat, quat_to_euler};
//! let q = euler_to_quat([10.0, 20.0, 30.0]);
//! let e = quat_to_euler(q);
//! assert!((e[0] - 10.0).abs() < 1e-9 && (e[1] - 20.0).abs() < 1e-9 && (e[2] - 30.0).abs() < 1e-9);
//! ```

use glam::{DQuat, DVec3, EulerRot};

use crate::doc::{Located, Origin};
use crate::error::{SceneError, Sources};
use crate::reader::Reader;
use crate::schema::{key, key_without_default, KeySpec, Kind};

type Result<T> = std::result::Result<T, SceneError>;

/// A bone: its rest placement relative to its parent.
#[derive(Debug, Clone, PartialEq)]
pub struct Bone {
    /// Its name (objects and tracks name it).
    pub name: String,
    /// Its parent's index; parents come before their children.
    pub parent: Option<usize>,
    /// The rest position in the parent's frame (the world's for a root).
    pub position: [f64; 3],
    /// The rest rotation in the parent's frame, a unit quaternion [x, y, z, w].
    pub rotation: [f64; 4],
    pub(crate) origin: Origin,
}

/// A placement: rotate, then move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// The rotation.
    pub rotation: DQuat,
    /// Where the origin goes.
    pub position: DVec3,
}

impl Frame {
    /// The frame `local` placed inside this one.
    pub fn then(&self, local: &Frame) -> Frame {
        Frame {
            rotation: (self.rotation * local.rotation).normalize(),
            position: self.position + self.rotation * local.position,
        }
    }
}

/// The quaternion of Euler angles in degrees (about x, then y, then z, in
/// world axes).
pub fn euler_to_quat(deg: [f64; 3]) -> DQuat {
    let r = deg.map(f64::to_radians);
    DQuat::from_euler(EulerRot::ZYX, r[2], r[1], r[0])
}

/// The Euler angles in degrees of a rotation ([`euler_to_quat`] inverted).
pub fn quat_to_euler(q: DQuat) -> [f64; 3] {
    let (z, y, x) = q.normalize().to_euler(EulerRot::ZYX);
    [x.to_degrees(), y.to_degrees(), z.to_degrees()]
}

/// A rotation from a track's or file's numbers: 3 Euler angles in degrees,
/// or a quaternion [x, y, z, w] (normalised).
pub(crate) fn rotation_of(v: &[f64]) -> DQuat {
    match *v {
        [x, y, z, w] => {
            let q = DQuat::from_xyzw(x, y, z, w);
            if q.length_squared() > 0.0 {
                q.normalize()
            } else {
                DQuat::IDENTITY
            }
        }
        [x, y, z] => euler_to_quat([x, y, z]),
        _ => DQuat::IDENTITY,
    }
}

/// The keys of a `[[bone]]`.
pub fn bone_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key_without_default("name", Kind::Str, "required", "the bone's name: objects (`bone = \"NAME\"`) and tracks (`bone.NAME.rotation`) name it"),
            key_without_default("parent", Kind::Str, "none (a root)", "the name of the bone it hangs from, written before it"),
            key("position", Kind::Vector, "[0.0, 0.0, 0.0]", "the rest position of its joint in the parent's frame (the world's for a root)"),
            key(
                "rotation",
                Kind::Vector,
                "[0.0, 0.0, 0.0]",
                "the rest rotation in the parent's frame: degrees about x, then y, then z (or a quaternion `[x, y, z, w]`)",
            ),
        ]
    });
    &KEYS
}

/// Reads the `[[bone]]` tables: names unique, parents named before their
/// children.
pub(crate) fn read_bones(src: &Sources, v: &Located) -> Result<Vec<Bone>> {
    let items = crate::read::array_of_tables(src, v, "bone", false)?;
    let mut bones: Vec<Bone> = Vec::new();
    for (i, bv) in items.into_iter().enumerate() {
        let ctx = format!("bone.{i}");
        let mut r = Reader::new(src, bv, &ctx)?;
        let Some((name, name_loc)) = r.string("name")? else {
            return Err(src
                .error(
                    bv.origin,
                    format!("`{ctx}` needs a `name`"),
                    Some("add name = \"hips\""),
                    &[],
                )
                .with_key(format!("{ctx}.name")));
        };
        if bones.iter().any(|b| b.name == name) {
            return Err(src
                .error(
                    name_loc.origin,
                    format!("`{ctx}.name`: a bone named \"{name}\" is defined already"),
                    Some("a second bone of this name"),
                    &[],
                )
                .with_key(format!("{ctx}.name")));
        }
        let parent = match r.string("parent")? {
            None => None,
            Some((p, loc)) => match bones.iter().position(|b| b.name == p) {
                Some(k) => Some(k),
                None => {
                    let mut notes = vec!["a parent must be written before its children".to_string()];
                    if let Some(s) = isoray_shape::diag::suggest(p, bones.iter().map(|b| b.name.as_str())) {
                        notes.insert(0, format!("did you mean \"{s}\"?"));
                    }
                    return Err(src
                        .error(
                            loc.origin,
                            format!("`{ctx}.parent`: no bone named \"{p}\" before this one"),
                            Some("unknown parent"),
                            &notes,
                        )
                        .with_key(format!("{ctx}.parent")));
                }
            },
        };
        let position = r.vec3("position", [0.0; 3])?;
        let rotation = match r.get("rotation") {
            None => DQuat::IDENTITY,
            Some(rv) => {
                let nums = crate::animation::numbers(rv)
                    .filter(|n| n.len() == 3 || n.len() == 4)
                    .ok_or_else(|| r.err(rv, "rotation", "[x, y, z] degrees or a quaternion [x, y, z, w]"))?;
                rotation_of(&nums)
            }
        };
        r.finish_keys(bone_keys())?;
        bones.push(Bone {
            name: name.to_string(),
            parent,
            position,
            rotation: rotation.to_array(),
            origin: name_loc.origin,
        });
    }
    Ok(bones)
}

/// Each bone's world frame, from local frames (parents before children).
pub fn world_frames(bones: &[Bone], locals: &[Frame]) -> Vec<Frame> {
    let mut world: Vec<Frame> = Vec::with_capacity(bones.len());
    for (b, local) in bones.iter().zip(locals) {
        let w = match b.parent {
            Some(p) => world[p].then(local),
            None => *local,
        };
        world.push(w);
    }
    world
}

/// The rest frames of the bones.
pub(crate) fn rest_frames(bones: &[Bone]) -> Vec<Frame> {
    bones
        .iter()
        .map(|b| Frame {
            rotation: DQuat::from_array(b.rotation),
            position: DVec3::from_array(b.position),
        })
        .collect()
}

/// An object's seven placement values (position, Euler rotation, scale)
/// in its bone's frame `bone`, made world values in place.
pub(crate) fn carry(bone: &Frame, placement: &mut [f64]) {
    let local = Frame {
        rotation: euler_to_quat([placement[3], placement[4], placement[5]]),
        position: DVec3::new(placement[0], placement[1], placement[2]),
    };
    let w = bone.then(&local);
    placement[..3].copy_from_slice(&w.position.to_array());
    placement[3..6].copy_from_slice(&quat_to_euler(w.rotation));
}

/// The keys of `[skeleton]`.
pub fn skeleton_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key_without_default(
                "gltf",
                Kind::Str,
                "required",
                "a glTF file (`.glb`, or `.gltf` with external `.bin` buffers), relative to the scene file: its skin's joints become bones",
            ),
            key("skin", Kind::Int { lo: 0, hi: 65535 }, "0", "which of the file's skins"),
            key_without_default(
                "animation",
                Kind::Str,
                "the file's first",
                "the name of the animation whose rotation and translation channels on the joints become tracks; `\"none\"` for the rest pose",
            ),
            key("loop", Kind::Bool, "true", "the animation's tracks repeat with its length"),
        ]
    });
    &KEYS
}

/// Reads `[skeleton]`: the bones of a glTF skin (named after their nodes,
/// at their nodes' rest placements; ancestors that are not joints are
/// folded into the roots) and the tracks of one of its animations on
/// them. Scales are not read (bones are rigid). `dir` is the scene file's
/// directory.
pub(crate) fn read_gltf_skeleton(
    src: &Sources,
    v: &Located,
    dir: &std::path::Path,
) -> Result<(Vec<Bone>, Vec<crate::animation::Track>)> {
    let mut r = Reader::new(src, v, "skeleton")?;
    let Some((file, file_loc)) = r.string("gltf")? else {
        return Err(src
            .error(
                v.origin,
                "`skeleton` needs a `gltf` file",
                Some("add gltf = \"rig.glb\""),
                &[],
            )
            .with_key("skeleton.gltf"));
    };
    let skin_index = r.int("skin", 0, 0, 65535)? as usize;
    let wanted = r.string("animation")?.map(|(s, loc)| (s.to_string(), loc.origin));
    let looped = r.boolean("loop", true)?;
    r.finish_keys(skeleton_keys())?;
    let fail = |message: String| {
        src.error(
            file_loc.origin,
            format!("`skeleton.gltf`: {message}"),
            Some("this file"),
            &[],
        )
        .with_key("skeleton.gltf")
    };
    let path = dir.join(file);
    let bytes = std::fs::read(&path).map_err(|e| {
        let mut err = fail(format!("cannot read `{}`: {e}", path.display()));
        err.io = true;
        err
    })?;
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| fail(format!("not a glTF file: {e}")))?;
    // Buffers: the GLB's binary chunk, or files beside the glTF.
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for b in gltf.buffers() {
        let data = match b.source() {
            gltf::buffer::Source::Bin => gltf
                .blob
                .clone()
                .ok_or_else(|| fail("the file has no binary chunk for its buffer".into()))?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                return Err(fail(
                    "buffers embedded as data URIs are not read: save the file as .glb, or with an external .bin"
                        .into(),
                ))
            }
            gltf::buffer::Source::Uri(uri) => {
                let p = path.parent().unwrap_or(dir).join(uri);
                std::fs::read(&p).map_err(|e| fail(format!("cannot read its buffer `{}`: {e}", p.display())))?
            }
        };
        buffers.push(data);
    }
    let skin = gltf.skins().nth(skin_index).ok_or_else(|| {
        fail(format!(
            "the file has {} skin(s), so there is no skin {skin_index}",
            gltf.skins().count()
        ))
    })?;
    let joints: Vec<usize> = skin.joints().map(|n| n.index()).collect();
    let nodes: Vec<gltf::Node> = gltf.nodes().collect();
    let mut parent_of = vec![None; nodes.len()];
    for n in &nodes {
        for c in n.children() {
            parent_of[c.index()] = Some(n.index());
        }
    }
    let local = |n: usize| {
        let (t, q, _) = nodes[n].transform().decomposed();
        Frame {
            rotation: DQuat::from_array(q.map(f64::from)).normalize(),
            position: DVec3::from_array(t.map(f64::from)),
        }
    };
    // Each joint's parent joint, and the frame of its non-joint ancestors.
    let mut info: Vec<(Option<usize>, Frame)> = Vec::new();
    for &n in &joints {
        let mut above = Frame {
            rotation: DQuat::IDENTITY,
            position: DVec3::ZERO,
        };
        let mut p = parent_of[n];
        let mut parent = None;
        while let Some(a) = p {
            if let Some(j) = joints.iter().position(|&x| x == a) {
                parent = Some(j);
                break;
            }
            above = local(a).then(&above);
            p = parent_of[a];
        }
        let rest = if parent.is_some() {
            local(n)
        } else {
            above.then(&local(n))
        };
        info.push((parent, rest));
    }
    // Parents before children.
    let mut order: Vec<usize> = Vec::new();
    while order.len() < joints.len() {
        let before = order.len();
        for (j, (parent, _)) in info.iter().enumerate() {
            if !order.contains(&j) && parent.is_none_or(|p| order.contains(&p)) {
                order.push(j);
            }
        }
        if order.len() == before {
            return Err(fail("the skin's joints form a cycle".into()));
        }
    }
    let name_of = |j: usize| {
        nodes[joints[j]]
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("joint_{j}"))
    };
    let mut bones: Vec<Bone> = Vec::new();
    for &j in &order {
        let name = name_of(j);
        if bones.iter().any(|b| b.name == name) {
            return Err(fail(format!("two joints are named \"{name}\"")));
        }
        let (parent, rest) = info[j];
        bones.push(Bone {
            name,
            parent: parent.map(|p| order.iter().position(|&o| o == p).expect("ordered")),
            position: rest.position.to_array(),
            rotation: rest.rotation.to_array(),
            origin: file_loc.origin,
        });
    }
    // The animation's channels on joints.
    let animation =
        match &wanted {
            Some((name, _)) if name == "none" => None,
            Some((name, origin)) => Some(gltf.animations().find(|a| a.name() == Some(name.as_str())).ok_or_else(
                || {
                    let names: Vec<String> = gltf.animations().filter_map(|a| a.name().map(str::to_string)).collect();
                    src.error(
                        *origin,
                        format!("`skeleton.animation`: the file has no animation named \"{name}\""),
                        Some("unknown animation"),
                        &[format!("its animations: {}", names.join(", "))],
                    )
                    .with_key("skeleton.animation")
                },
            )?),
            None => gltf.animations().next(),
        };
    let mut tracks = Vec::new();
    if let Some(anim) = animation {
        for ch in anim.channels() {
            let node = ch.target().node().index();
            let Some(j) = joints.iter().position(|&x| x == node) else {
                continue;
            };
            let property = ch.target().property();
            let reader = ch.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let times: Vec<f64> = reader
                .read_inputs()
                .ok_or_else(|| fail("an animation channel has no times".into()))?
                .map(f64::from)
                .collect();
            let values: Vec<Vec<f64>> = match reader.read_outputs() {
                Some(gltf::animation::util::ReadOutputs::Rotations(r)) => {
                    r.into_f32().map(|q| q.map(f64::from).to_vec()).collect()
                }
                Some(gltf::animation::util::ReadOutputs::Translations(t)) => {
                    t.map(|p| p.map(f64::from).to_vec()).collect()
                }
                _ => continue, // scales and morph weights: not bones' business
            };
            let rotation = property == gltf::animation::Property::Rotation;
            let name = name_of(j);
            let (keys, interpolation) = gltf_keys(ch.sampler().interpolation(), &times, &values, rotation)
                .map_err(|m| fail(format!("the channel on \"{name}\": {m}")))?;
            let part = if rotation { "rotation" } else { "position" };
            let mut t = crate::animation::Track::new(&format!("bone.{name}.{part}"), keys, interpolation, looped);
            t.origin = file_loc.origin;
            t.label = format!("the glTF animation's channel on bone.{name}.{part}");
            tracks.push(t);
        }
    }
    Ok((bones, tracks))
}

/// A glTF sampler's keys as a track's: step and linear as they are, a
/// cubic spline (in-tangent, value, out-tangent per key) sampled at 60
/// keys a second and joined linearly.
fn gltf_keys(
    how: gltf::animation::Interpolation,
    times: &[f64],
    values: &[Vec<f64>],
    rotation: bool,
) -> std::result::Result<(crate::animation::Keys, crate::animation::Interpolation), String> {
    use crate::animation::Interpolation as I;
    let increasing = times.windows(2).all(|w| w[0] < w[1]);
    if times.is_empty() || !increasing {
        return Err("its times must increase".into());
    }
    match how {
        gltf::animation::Interpolation::Step | gltf::animation::Interpolation::Linear => {
            if values.len() != times.len() {
                return Err(format!("{} values for {} times", values.len(), times.len()));
            }
            let i = if how == gltf::animation::Interpolation::Step {
                I::Step
            } else {
                I::Linear
            };
            Ok((times.iter().copied().zip(values.iter().cloned()).collect(), i))
        }
        gltf::animation::Interpolation::CubicSpline => {
            if values.len() != 3 * times.len() {
                return Err(format!(
                    "{} values for {} cubic-spline times (3 each)",
                    values.len(),
                    times.len()
                ));
            }
            let (a, b) = (times[0], times[times.len() - 1]);
            let steps = (((b - a) * 60.0).ceil() as usize).max(1);
            let mut keys = Vec::with_capacity(steps + 1);
            for s in 0..=steps {
                let t = a + (b - a) * s as f64 / steps as f64;
                let k = times
                    .partition_point(|&x| x <= t)
                    .saturating_sub(1)
                    .min(times.len() - 1);
                let v = if k + 1 >= times.len() {
                    values[3 * k + 1].clone()
                } else {
                    let td = times[k + 1] - times[k];
                    let u = (t - times[k]) / td;
                    let (p0, m0) = (&values[3 * k + 1], &values[3 * k + 2]);
                    let (p1, m1) = (&values[3 * (k + 1) + 1], &values[3 * (k + 1)]);
                    let (u2, u3) = (u * u, u * u * u);
                    (0..p0.len())
                        .map(|c| {
                            (2.0 * u3 - 3.0 * u2 + 1.0) * p0[c]
                                + (u3 - 2.0 * u2 + u) * td * m0[c]
                                + (-2.0 * u3 + 3.0 * u2) * p1[c]
                                + (u3 - u2) * td * m1[c]
                        })
                        .collect()
                };
                let v = if rotation {
                    rotation_of(&v).to_array().to_vec()
                } else {
                    v
                };
                keys.push((t, v));
            }
            Ok((keys, I::Linear))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn euler_angles_follow_the_objects_convention() {
        // About x, then y, then z, in world axes: R = Rz·Ry·Rx.
        let q = euler_to_quat([90.0, 0.0, 0.0]);
        let v = q * DVec3::Y;
        assert!((v - DVec3::Z).length() < 1e-12, "x by 90° takes y to z: {v}");
        let q = euler_to_quat([90.0, 90.0, 0.0]);
        // y → z (about x), then z → x (about y).
        assert!((q * DVec3::Y - DVec3::X).length() < 1e-12);
        for e in [[10.0, -35.0, 120.0], [0.0, 89.0, 5.0], [-170.0, 20.0, 3.0]] {
            let back = quat_to_euler(euler_to_quat(e));
            let (a, b) = (euler_to_quat(e), euler_to_quat(back));
            assert!(a.dot(b).abs() > 1.0 - 1e-12, "{e:?} → {back:?}");
        }
    }

    #[test]
    fn an_elbow_at_ninety_degrees_puts_the_hand_where_trigonometry_does() {
        // Shoulder at (0, 1.5, 0); upper arm 0.3 along x; the elbow bent 90° about z.
        let bones = vec![
            Bone {
                name: "shoulder".into(),
                parent: None,
                position: [0.0, 1.5, 0.0],
                rotation: DQuat::IDENTITY.to_array(),
                origin: Origin::Implicit,
            },
            Bone {
                name: "elbow".into(),
                parent: Some(0),
                position: [0.3, 0.0, 0.0],
                rotation: euler_to_quat([0.0, 0.0, 90.0]).to_array(),
                origin: Origin::Implicit,
            },
        ];
        let world = world_frames(&bones, &rest_frames(&bones));
        // A hand 0.25 along the forearm's x.
        let hand = world[1].then(&Frame {
            rotation: DQuat::IDENTITY,
            position: DVec3::new(0.25, 0.0, 0.0),
        });
        assert!(
            (hand.position - DVec3::new(0.3, 1.75, 0.0)).length() < 1e-12,
            "{}",
            hand.position
        );
    }
}
