//! The studio's window, driven headlessly (egui_kittest): each playground
//! control edits the scene key it claims, exactly as `isoray set` of that
//! key would; undo returns the previous bytes; Ctrl+S saves them.

use egui_kittest::kittest::Queryable;
use egui_kittest::Harness;
use isoray_studio::{Studio, StudioOptions};

fn studio_on(path: &std::path::Path) -> Harness<'static, Studio> {
    let options = StudioOptions {
        scene: Some(path.to_path_buf()),
        cpu_only: true,
        screenshot: None,
    };
    let mut h = Harness::builder()
        .with_size(egui::Vec2::new(900.0, 600.0))
        .build_eframe(move |cc| Studio::new(&cc.egui_ctx, options));
    h.run_steps(3);
    h
}

/// The text `isoray set FILE KEY=VALUE…` would write.
fn set(text: &str, edits: &[&str]) -> String {
    let edits: Vec<String> = edits.iter().map(|s| s.to_string()).collect();
    isoray_scene::edit_text(text, "scene.toml", &edits).unwrap()
}

#[test]
fn the_playground_edits_the_keys_it_claims_and_undo_restores_the_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    let examples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    std::fs::copy(examples.join("lighting.toml"), &path).unwrap();
    let original = std::fs::read_to_string(&path).unwrap();
    let mut h = studio_on(&path);

    // A checkbox: render.ao.
    h.get_by_label("Ambient occlusion").click();
    h.run_steps(2);
    let after_ao = set(&original, &["render.ao=false"]);
    assert_eq!(h.state().document().text(), after_ao);
    assert!(h.state().document().is_modified());

    // A choice: render.shadows.
    h.get_by_label("Shadows").click();
    h.run_steps(2);
    h.get_by_label("hard").click();
    h.run_steps(2);
    let after_shadows = set(&after_ao, &["render.shadows=hard"]);
    assert_eq!(h.state().document().text(), after_shadows);

    // Undo twice: the original bytes; redo once: the first edit's.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(h.state().document().text(), after_ao);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(h.state().document().text(), original);
    assert!(!h.state().document().is_modified());
    h.key_press_modifiers(egui::Modifiers::COMMAND | egui::Modifiers::SHIFT, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(h.state().document().text(), after_ao);

    // Ctrl+S writes exactly the document's bytes.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::S);
    h.run_steps(2);
    assert_eq!(std::fs::read_to_string(&path).unwrap(), after_ao);
    assert!(!h.state().document().is_modified());
}
