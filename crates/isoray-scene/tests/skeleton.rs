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

/// The ARM rig as a glTF file: two joints (shoulder, elbow) of a skin, and
/// an animation "Bend" turning the elbow 90° about z over a second
/// (quaternion keys, linear: a slerp), written as a .glb by hand.
fn arm_glb() -> Vec<u8> {
    let s45 = std::f32::consts::FRAC_1_SQRT_2;
    let floats: [f32; 10] = [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, s45, s45];
    let bin: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
    let json = r#"{
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [2]}],
  "nodes": [
    {"name": "shoulder", "translation": [0.0, 1.5, 0.0], "children": [1]},
    {"name": "elbow", "translation": [0.3, 0.0, 0.0]},
    {"name": "rig", "children": [0]}
  ],
  "skins": [{"joints": [0, 1]}],
  "buffers": [{"byteLength": 40}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 8}, {"buffer": 0, "byteOffset": 8, "byteLength": 32}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0.0], "max": [1.0]},
    {"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC4"}
  ],
  "animations": [{"name": "Bend",
    "samplers": [{"input": 0, "output": 1, "interpolation": "LINEAR"}],
    "channels": [{"sampler": 0, "target": {"node": 1, "path": "rotation"}}]}]
}"#;
    let mut j = json.as_bytes().to_vec();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + j.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F_534Au32.to_le_bytes());
    out.extend_from_slice(&j);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes());
    out.extend_from_slice(&bin);
    out
}

#[test]
fn a_gltf_skin_and_animation_move_objects_as_the_same_rig_in_the_file() {
    let dir = std::env::temp_dir().join(format!("isoray-gltf-rig-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("arm.glb"), arm_glb()).unwrap();
    let text = "[skeleton]\ngltf = \"arm.glb\"\nanimation = \"Bend\"\nloop = false\n[[object]]\nbone = \"elbow\"\nshape = \"sphere(p - vec3(0.25, 0.0, 0.0), 0.05)\"\n";
    let path = dir.join("rig.toml");
    std::fs::write(&path, text).unwrap();
    let mut from_gltf = isoray_scene::load(&path, &[]).unwrap_or_else(|e| panic!("{}", e.rendered));
    assert_eq!(
        from_gltf.bones.iter().map(|b| b.name.as_str()).collect::<Vec<_>>(),
        ["shoulder", "elbow"]
    );
    let mut from_toml = scene(ARM);
    for t in [0.0, 0.3, 0.5, 0.8, 1.0] {
        from_gltf.set_time(t).unwrap();
        from_toml.set_time(t).unwrap();
        for q in [[0.55, 1.5, 0.0], [0.3, 1.75, 0.0], [0.45, 1.62, 0.0], [0.0, 0.0, 0.0]] {
            let (a, b) = (from_gltf.distance(q), from_toml.distance(q));
            assert!((a - b).abs() < 1e-6, "t = {t}, {q:?}: {a} vs {b}");
        }
    }
    // Errors name the file and the place.
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[skeleton]\ngltf = \"arm.glb\"\nanimation = \"Run\"\n").unwrap();
    let e = isoray_scene::load(&bad, &[]).unwrap_err();
    assert!(e.message.contains("no animation named \"Run\""), "{}", e.rendered);
    assert!(e.notes.iter().any(|n| n.contains("Bend")), "{:?}", e.notes);
    std::fs::write(&bad, "[skeleton]\ngltf = \"missing.glb\"\n").unwrap();
    let e = isoray_scene::load(&bad, &[]).unwrap_err();
    assert!(e.message.contains("cannot read") && e.io, "{}", e.rendered);
    std::fs::write(&bad, "[skeleton]\ngltf = \"rig.toml\"\n").unwrap();
    let e = isoray_scene::load(&bad, &[]).unwrap_err();
    assert!(e.message.contains("not a glTF file"), "{}", e.rendered);
    std::fs::remove_dir_all(&dir).unwrap();
}
