//! The studio's document: edits keep the file's comments and layout, undo
//! and redo restore the exact bytes, saves are atomic, and every edit the
//! playground makes renders as `isoray render --set` of the same key would.

use isoray_studio::orbit::Orbit;
use isoray_studio::Document;

fn examples() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

#[test]
fn undo_and_redo_return_the_exact_bytes_of_each_step() {
    let path = examples().join("lighting.toml");
    let original = std::fs::read_to_string(&path).unwrap();
    let mut doc = Document::open(&path).unwrap();
    assert!(!doc.is_modified());
    doc.apply(&["render.shadows=hard".into()]).unwrap();
    let one = doc.text().to_string();
    doc.apply(&["light.1.intensity=2.5".into(), "render.ao=false".into()])
        .unwrap();
    let two = doc.text().to_string();
    assert!(doc.is_modified());
    // Comments and the rest of the layout survive the edits.
    assert_eq!(original.lines().count(), two.lines().count());
    assert!(two.contains("# red point light at the left"));
    assert!(two.contains("intensity = 2.5"));
    assert_eq!(doc.scene().lights[1].intensity, 2.5);
    assert!(doc.undo());
    assert_eq!(doc.text(), one);
    assert_eq!(doc.scene().lights[1].intensity, 1.4);
    assert!(doc.undo());
    assert_eq!(doc.text(), original);
    assert!(!doc.is_modified());
    assert!(!doc.undo());
    assert!(doc.redo());
    assert!(doc.redo());
    assert_eq!(doc.text(), two);
    assert!(!doc.redo());
    // A new edit after an undo drops the redo steps.
    doc.undo();
    doc.apply(&["render.aa=1".into()]).unwrap();
    assert!(!doc.can_redo());
}

#[test]
fn a_bad_edit_changes_nothing_and_names_the_key() {
    let mut doc = Document::open(&examples().join("showcase.toml")).unwrap();
    let before = doc.text().to_string();
    let err = doc.apply(&["render.shadows=fuzzy".into()]).unwrap_err();
    assert!(err.rendered.contains("shadows"), "{}", err.rendered);
    let err = doc.apply(&["render.aa=0".into()]).unwrap_err();
    assert!(err.rendered.contains("aa"), "{}", err.rendered);
    assert_eq!(doc.text(), before);
    assert!(!doc.can_undo());
}

#[test]
fn saves_are_atomic_and_a_failed_save_keeps_the_old_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::copy(examples().join("csg.toml"), &path).unwrap();
    let mut doc = Document::open(&path).unwrap();
    doc.apply(&["render.aa=3".into()]).unwrap();
    doc.save().unwrap();
    assert!(!doc.is_modified());
    assert_eq!(std::fs::read_to_string(&path).unwrap(), doc.text());
    // Saving into a folder that does not exist fails and leaves the
    // document's file and path as they were.
    doc.apply(&["render.aa=2".into()]).unwrap();
    let bad = dir.path().join("missing").join("scene.toml");
    assert!(doc.save_as(&bad).is_err());
    assert_eq!(doc.path(), Some(path.as_path()));
    assert!(doc.is_modified());
    assert!(std::fs::read_to_string(&path).unwrap().contains("aa = 3"));
    // No temporary files are left beside it.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "{names:?}");
}

#[test]
fn a_new_scene_is_unsaved_and_modified_after_an_edit() {
    let mut doc = Document::new_scene();
    assert_eq!(doc.title(), "untitled");
    assert!(!doc.is_modified());
    assert!(doc.save().is_err());
    doc.apply(&["render.ao=false".into()]).unwrap();
    assert!(doc.is_modified());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("new.toml");
    doc.save_as(&path).unwrap();
    assert!(!doc.is_modified());
    assert_eq!(doc.title(), "new.toml");
    // What was saved loads to the same scene the studio shows.
    let again = isoray_scene::load(&path, &[]).unwrap();
    assert_eq!(again.render.ao, doc.scene().render.ao);
}

#[test]
fn an_orbit_keeps_the_camera_where_it_is_until_it_turns() {
    let scene = isoray_scene::load(&examples().join("showcase.toml"), &[]).unwrap();
    let o = Orbit::of(&scene.camera);
    let p = o.position();
    for k in 0..3 {
        assert!(
            (p[k] - scene.camera.position[k]).abs() < 1e-9,
            "{p:?} vs {:?}",
            scene.camera.position
        );
    }
    // Half a turn about the vertical mirrors x and z about the target.
    let mut half = o;
    half.rotate(std::f64::consts::PI, 0.0);
    let q = half.position();
    let t = scene.camera.target;
    assert!((q[0] - (2.0 * t[0] - p[0])).abs() < 1e-9);
    assert!((q[2] - (2.0 * t[2] - p[2])).abs() < 1e-9);
    assert!((q[1] - p[1]).abs() < 1e-9);
    // Zoom scales the distance; pitch stops short of the pole.
    let mut z = o;
    z.zoom(2.0);
    assert!((z.distance - 2.0 * o.distance).abs() < 1e-9);
    z.rotate(0.0, 10.0);
    assert!(z.pitch < std::f64::consts::FRAC_PI_2);
}

#[test]
fn lights_are_added_and_removed_as_tables_of_the_file() {
    let path = examples().join("showcase.toml");
    let original = std::fs::read_to_string(&path).unwrap();
    let mut doc = Document::open(&path).unwrap();
    let n = doc.scene().lights.len();
    doc.push_table(
        "light",
        &[
            ("kind", "\"point\""),
            ("position", "[1.0, 3.0, 2.0]"),
            ("intensity", "0.5"),
        ],
    )
    .unwrap();
    assert_eq!(doc.scene().lights.len(), n + 1);
    assert_eq!(doc.scene().lights[n].intensity, 0.5);
    // Every line of the old text is still there, in order: the new table
    // is inserted (after the other lights), nothing else changes.
    let mut new_lines = doc.text().lines();
    for line in original.lines() {
        assert!(new_lines.any(|l| l == line), "lost `{line}`:\n{}", doc.text());
    }
    // A bad value is refused, naming the key, and changes nothing.
    let before = doc.text().to_string();
    let err = doc.push_table("light", &[("intensity", "lots")]).unwrap_err();
    assert!(err.rendered.contains("light.intensity"), "{}", err.rendered);
    assert_eq!(doc.text(), before);
    doc.remove_table("light", n).unwrap();
    assert_eq!(doc.scene().lights.len(), n);
    assert!(doc.remove_table("light", 99).unwrap_err().rendered.contains("light.99"));
    // Both edits undo to the original bytes.
    doc.undo();
    doc.undo();
    assert_eq!(doc.text(), original);
}

#[test]
fn the_keys_the_playground_sliders_drag_are_values_set_without_reloading() {
    // While a slider is dragged the preview shows the scene with the key
    // set as a value (Scene::set_value): no reload, no shader rebuild.
    let doc =
        Document::open(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/showcase.toml")).unwrap();
    let mut scene = doc.scene().clone();
    for (key, v) in [("light.0.intensity", 0.5), ("light.0.size", 0.3), ("camera.fov", 55.0)] {
        scene
            .set_value(key, &[v])
            .unwrap_or_else(|e| panic!("{key}: {}", e.rendered));
    }
    assert_eq!(scene.lights[0].intensity, 0.5);
    assert_eq!(scene.lights[0].size, 0.3);
    assert_eq!(scene.camera.fov, 55.0);
    // On release the same keys are edits of the file.
    let mut doc = doc;
    doc.apply(&["light.0.size=0.3".to_string(), "camera.fov=55".to_string()])
        .unwrap();
    assert_eq!(doc.scene().lights[0].size, 0.3);
    assert_eq!(doc.scene().camera.fov, 55.0);
}
