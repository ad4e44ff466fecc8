//! `[[bone]]` skeletons: objects carried by bones, tracks on bone
//! rotations (Euler angles or quaternions, slerped), known answers from
//! trigonometry, and errors at their place.

use isoray_scene::{load_str, Scene, SceneError};

fn scene(text: &str) -> Scene {
    load_str(text, "rig.toml", &[]).unwrap_or_else(|e| panic!("{}", e.rendered))
}

fn error(text: &str) -> SceneError {
    match load_str(text, "rig.toml", &[]) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e,
    }
}

/// A shoulder at (0, 1.5, 0) and an elbow 0.3 along its x; a forearm
/// capsule from the elbow 0.25 along the forearm's x; the elbow turns about
/// z from 0° to 90° over one second.
const ARM: &str = r#"
[[bone]]
name = "shoulder"
position = [0.0, 1.5, 0.0]
[[bone]]
name = "elbow"
parent = "shoulder"
position = [0.3, 0.0, 0.0]
[[object]]
bone = "elbow"
shape = "sphere(p - vec3(0.25, 0.0, 0.0), 0.05)"
[[track]]
target = "bone.elbow.rotation"
keys = [[0.0, [0.0, 0.0, 0.0]], [1.0, [0.0, 0.0, 90.0]]]
"#;

#[test]
fn an_elbow_at_ninety_degrees_puts_the_hand_at_the_analytic_point() {
    let mut s = scene(ARM);
    assert!(
        s.objects[0].transform.is_some(),
        "a carried object gets placement inputs"
    );
    // At rest the hand is at (0.55, 1.5, 0).
    assert!(s.distance([0.55, 1.5, 0.0]) + 0.05 < 1e-9);
    let tape = s.objects[0].shape.tape().clone();
    s.set_time(1.0).unwrap();
    assert_eq!(s.objects[0].shape.tape(), &tape, "nothing recompiled");
    // Bent 90° about z: the forearm points up, the hand at (0.3, 1.75, 0).
    let d = s.distance([0.3, 1.75, 0.0]);
    assert!((d + 0.05).abs() < 1e-9, "{d}");
    // Halfway, 45°: at the elbow plus 0.25·(cos 45°, sin 45°).
    s.set_time(0.5).unwrap();
    let h = 0.25 * std::f64::consts::FRAC_1_SQRT_2;
    assert!((s.distance([0.3 + h, 1.5 + h, 0.0]) + 0.05).abs() < 1e-9);
}

#[test]
fn quaternion_keys_are_slerped() {
    // About y by 0° and 120°: halfway is exactly 60° (a slerp, not a lerp
    // of the components, which would not be unit length).
    let (s60, c60) = (60f64.to_radians().sin(), 60f64.to_radians().cos());
    let half = |deg: f64| ((deg / 2.0).to_radians().sin(), (deg / 2.0).to_radians().cos());
    let (sy, cw) = half(120.0);
    let text = format!(
        "[[bone]]\nname = \"b\"\n[[object]]\nbone = \"b\"\nshape = \"sphere(p - vec3(1.0, 0.0, 0.0), 0.1)\"\n[[track]]\ntarget = \"bone.b.rotation\"\nkeys = [[0.0, [0.0, 0.0, 0.0, 1.0]], [2.0, [0.0, {sy}, 0.0, {cw}]]]\n"
    );
    let mut s = scene(&text);
    s.set_time(1.0).unwrap();
    // (1, 0, 0) turned 60° about y: (cos 60°, 0, −sin 60°).
    let d = s.distance([c60, 0.0, -s60]);
    assert!((d + 0.1).abs() < 1e-9, "{d}");
}

#[test]
fn a_rest_pose_places_objects_as_the_same_placements_written_in_world() {
    let rig = r#"
[[bone]]
name = "hips"
position = [0.0, 1.0, 0.0]
rotation = [0.0, 30.0, 0.0]
[[bone]]
name = "thigh"
parent = "hips"
position = [0.2, -0.1, 0.0]
rotation = [-20.0, 0.0, 10.0]
[[object]]
bone = "thigh"
shape = "box(p, vec3(0.1, 0.25, 0.1))"
position = [0.0, -0.25, 0.0]
rotation = [5.0, 0.0, 0.0]
"#;
    let s = scene(rig);
    // The same box placed in world: the composition of the three frames.
    use isoray_scene::skeleton::{euler_to_quat, quat_to_euler};
    let (qh, qt, qo) = (
        euler_to_quat([0.0, 30.0, 0.0]),
        euler_to_quat([-20.0, 0.0, 10.0]),
        euler_to_quat([5.0, 0.0, 0.0]),
    );
    let p = glam::DVec3::new(0.0, 1.0, 0.0)
        + qh * (glam::DVec3::new(0.2, -0.1, 0.0) + qt * glam::DVec3::new(0.0, -0.25, 0.0));
    let e = quat_to_euler(qh * qt * qo);
    let world = format!(
        "[[object]]\nshape = \"box(p, vec3(0.1, 0.25, 0.1))\"\nposition = [{}, {}, {}]\nrotation = [{}, {}, {}]\n",
        p.x, p.y, p.z, e[0], e[1], e[2]
    );
    let w = scene(&world);
    for q in [[0.2, 0.6, 0.1], [0.3, 0.9, -0.2], [0.0, 0.0, 0.0], [0.25, 0.5, 0.05]] {
        let (a, b) = (s.distance(q), w.distance(q));
        assert!((a - b).abs() < 1e-9, "{q:?}: {a} vs {b}");
    }
}

#[test]
fn bad_bones_are_errors_at_their_place() {
    let cases = [
        (
            "[[bone]]\nname = \"a\"\nparent = \"b\"\n[[bone]]\nname = \"b\"\n",
            "no bone named \"b\" before this one",
            3,
        ),
        ("[[bone]]\nname = \"a\"\n[[bone]]\nname = \"a\"\n", "defined already", 4),
        ("[[bone]]\nposition = [0, 0, 0]\n", "needs a `name`", 1),
        ("[[bone]]\nname = \"a\"\nrotation = [1, 2]\n", "a quaternion", 3),
        (
            "[[bone]]\nname = \"arm\"\n[[object]]\nshape = \"sphere(p, 1.0)\"\nbone = \"amr\"\n",
            "did you mean",
            5,
        ),
        (
            "[[bone]]\nname = \"arm\"\n[[track]]\ntarget = \"bone.arm.scale\"\nkeys = [[0.0, 1.0]]\n",
            "`rotation` or `position`, not `scale`",
            4,
        ),
        (
            "[[bone]]\nname = \"arm\"\n[[track]]\ntarget = \"bone.leg.rotation\"\nkeys = [[0.0, [0, 0, 0]]]\n",
            "no bone named \"leg\"",
            4,
        ),
        (
            "[[bone]]\nname = \"arm\"\n[[track]]\ntarget = \"bone.arm.rotation\"\nkeys = [[0.0, [0, 0]]]\n",
            "found 2 component(s)",
            4,
        ),
    ];
    for (text, want, line) in cases {
        let e = error(text);
        let all = format!("{} {}", e.message, e.notes.join(" "));
        assert!(all.contains(want), "{text}: expected `{want}` in {}", e.rendered);
        assert_eq!(e.line, Some(line), "{text}: {}", e.rendered);
    }
}
