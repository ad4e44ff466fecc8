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
