//! Writing scenes back: edits keep the file's comments and layout, load to
//! the same scene as the same `--set` overrides, and writes are atomic.

use std::path::PathBuf;

use isoray_scene::{edit_text, load_str, set_file};

fn example(name: &str) -> (PathBuf, String) {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name);
    let text = std::fs::read_to_string(&p).unwrap();
    (p, text)
}

/// A compact fingerprint of what a scene says (its model, not its text).
fn fingerprint(text: &str, overrides: &[String]) -> String {
    let s = load_str(text, "s.toml", overrides).unwrap_or_else(|e| panic!("{}", e.rendered));
    let objects: Vec<String> = s
        .objects
        .iter()
        .map(|o| format!("{:?} {} {} {:?}", o.name, o.material, o.source, o.shape.tape()))
        .collect();
    format!(
        "{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{objects:?}",
        s.camera, s.render, s.lights, s.materials, s.params, s.inputs
    )
}

#[test]
fn saving_without_edits_is_the_identity() {
    for name in ["csg.toml", "showcase.toml", "surfaces.toml", "placement.toml"] {
        let (_, text) = example(name);
        assert_eq!(edit_text(&text, name, &[]).unwrap(), text, "{name}");
    }
}

#[test]
fn edits_load_like_the_same_overrides_and_keep_comments() {
    let (_, text) = example("csg.toml");
    let edits: Vec<String> = [
        "params.radius=1.2",
        "render.width=100",
        "object.0.material=steel",
        "object.1.shape=sphere(p, 2.0)",
        "light.1.intensity=0.25",
        "camera.fov=35",
        "render.aa=2",
    ]
    .map(String::from)
    .to_vec();
    let out = edit_text(&text, "csg.toml", &edits).unwrap();
    assert_eq!(fingerprint(&out, &[]), fingerprint(&text, &edits));
    // Every comment line of the original is still there, in order.
    let comments: Vec<&str> = text.lines().filter(|l| l.trim_start().starts_with('#')).collect();
    let kept: Vec<&str> = out.lines().filter(|l| l.trim_start().starts_with('#')).collect();
    assert_eq!(comments, kept);
    assert!(out.contains("radius = 1.2                  # the sphere"), "{out}");
    // A parameter with a range keeps it and the edit is checked against it.
    let ranged = "[params]\nk = { default = 1.0, range = [0.5, 2.0] } # knob\n[[object]]\nshape = \"sphere(p, k)\"\n";
    let out = edit_text(ranged, "r.toml", &["params.k=1.5".into()]).unwrap();
    assert_eq!(
        out,
        "[params]\nk = { default = 1.5, range = [0.5, 2.0] } # knob\n[[object]]\nshape = \"sphere(p, k)\"\n"
    );
    let e = edit_text(ranged, "r.toml", &["params.k=7".into()]).unwrap_err();
    assert!(e.message.contains("outside its range [0.5, 2]"), "{}", e.rendered);
    // New tables are created where --set would create them.
    let out = edit_text(
        "[[object]]\nshape = \"sphere(p, 1.0)\"\n",
        "n.toml",
        &["render.width=64".into()],
    )
    .unwrap();
    assert_eq!(load_str(&out, "n.toml", &[]).unwrap().render.width, 64);
}

#[test]
fn a_failed_set_leaves_the_file_intact() {
    let dir = std::env::temp_dir().join(format!("isoray-save-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.toml");
    let text = "# mine\n[[object]]\nshape = \"sphere(p, 1.0)\"  # a ball\n";
    std::fs::write(&path, text).unwrap();
    // A bad value: nothing is written.
    let e = set_file(&path, &["object.0.shape=sphere(p".into()], None).unwrap_err();
    assert!(!e.io, "{}", e.rendered);
    assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
    // An output that cannot be written: the error names it, the scene is intact.
    let bad_out = dir.join("no-such-dir").join("out.toml");
    let e = set_file(&path, &["object.0.shape=sphere(p, 2.0)".into()], Some(&bad_out)).unwrap_err();
    assert!(e.io && e.message.contains("out.toml"), "{}", e.rendered);
    assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
    // In place, with the comments kept and no temporary file left behind.
    set_file(&path, &["object.0.shape=sphere(p, 2.0)".into()], None).unwrap();
    assert_eq!(
        std::fs::read_to_string(&path).unwrap(),
        "# mine\n[[object]]\nshape = \"sphere(p, 2.0)\"  # a ball\n"
    );
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(leftovers.len(), 1, "{leftovers:?}");
}
