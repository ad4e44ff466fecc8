//! The studio's window, driven headlessly (egui_kittest): each playground
//! control edits the scene key it claims, exactly as `isoray set` of that
//! key would; undo returns the previous bytes; Ctrl+S saves them. And end
//! to end, by UI actions alone: add an object, make it a smooth union of a
//! sphere and a box through the graph's menus, set k, add a light, save;
//! `isoray render` of the saved file is byte-identical to rendering a
//! reference scene file written by hand.

use egui_kittest::kittest::{NodeT, Queryable};
use egui_kittest::Harness;
use isoray_studio::graph::GraphNode;
use isoray_studio::{Studio, StudioOptions};

#[allow(dead_code)] // each test file uses part of it
mod common;

fn studio_on(path: &std::path::Path) -> Harness<'static, Studio> {
    studio_sized(path, egui::Vec2::new(900.0, 600.0))
}

fn studio_sized(path: &std::path::Path, size: egui::Vec2) -> Harness<'static, Studio> {
    let options = StudioOptions {
        scene: Some(path.to_path_buf()),
        renderer: isoray_studio::preview::PreviewChoice::Cpu,
        screenshot: None,
    };
    let mut h = Harness::builder()
        .with_size(size)
        .build_eframe(move |cc| Studio::new(&cc.egui_ctx, options));
    h.run_steps(3);
    h
}

/// A copy of the example `name` in a temporary directory: the directory,
/// the copy's path and its text.
fn example_copy(name: &str) -> (tempfile::TempDir, std::path::PathBuf, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::copy(common::examples_dir().join(name), &path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    (dir, path, text)
}

/// The text `isoray set FILE KEY=VALUE…` would write.
fn set(text: &str, edits: &[&str]) -> String {
    let edits: Vec<String> = edits.iter().map(|s| s.to_string()).collect();
    isoray_scene::edit_text(text, "scene.toml", &edits).unwrap()
}

#[test]
fn the_playground_edits_the_keys_it_claims_and_undo_restores_the_bytes() {
    let (_dir, path, original) = example_copy("lighting.toml");
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

    // The normals method: render.normals (one more undo step, taken back
    // at once).
    h.get_by_label("Normals").click();
    h.run_steps(2);
    h.get_by_label("analytic").click();
    h.run_steps(2);
    assert_eq!(
        h.state().document().text(),
        set(&after_shadows, &["render.normals=analytic"])
    );
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
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

/// Sets a slider or drag value by its accessible name, as a screen reader
/// would (an accessibility SetValue action).
/// Picks `item` from the combo box named `combo`, then closes its list.
/// (The list is drawn last: a material header of the same name comes
/// before it.)
fn pick(h: &mut Harness<'_, Studio>, combo: &str, item: &str) {
    h.get_by_label(combo).click_accesskit();
    h.run_steps(2);
    h.get_all_by_label(item).last().unwrap().click_accesskit();
    h.run_steps(3);
    if h.query_all_by_label(item).count() > 0 {
        h.key_press(egui::Key::Escape);
        h.run_steps(2);
    }
}

fn set_value(h: &Harness<'_, Studio>, label: &str, v: f64) {
    use egui_kittest::kittest::NodeT;
    let (target_node, target_tree) = h.get_by_label(label).accesskit_node().locate();
    h.event(egui::Event::AccessKitActionRequest(egui::accesskit::ActionRequest {
        action: egui::accesskit::Action::SetValue,
        target_node,
        target_tree,
        data: Some(egui::accesskit::ActionData::NumericValue(v)),
    }));
}

#[test]
fn light_kinds_materials_and_the_camera_edit_their_keys() {
    let (_dir, path, original) = example_copy("lighting.toml");
    let mut h = studio_on(&path);
    let scene = h.state().document().scene().clone();
    let isoray_scene::LightKind::Directional { direction } = scene.lights[0].kind else {
        panic!("light 0 of lighting.toml is directional");
    };

    // Light 0 becomes a point light: `kind` changes, `direction` goes, and
    // `position` is the camera's distance from the target, towards where
    // the light was. Nothing else in the file changes.
    h.get_by_label("Materials").click_accesskit();
    h.run_steps(2);
    pick(&mut h, "light.0.kind", "point");
    let text = h.state().document().text().to_string();
    let reach = {
        let (p, t) = (scene.camera.position, scene.camera.target);
        ((p[0] - t[0]).powi(2) + (p[1] - t[1]).powi(2) + (p[2] - t[2]).powi(2)).sqrt()
    };
    let isoray_scene::LightKind::Point { position } = h.state().document().scene().lights[0].kind else {
        panic!("a point light now:\n{text}");
    };
    for k in 0..3 {
        let want = scene.camera.target[k] + direction[k] * reach;
        assert!((position[k] - want).abs() < 1e-9, "{position:?}");
    }
    assert!(!text.contains("direction = [-1.0, 1.5, 1.0]"), "{text}");
    assert!(text.contains("# warm key light"), "comments stay");
    assert_eq!(text.lines().count(), original.lines().count());
    assert_eq!(h.state().document().scene().lights[1..], scene.lights[1..]);

    // And back: a directional light in the same direction.
    pick(&mut h, "light.0.kind", "directional");
    let isoray_scene::LightKind::Directional { direction: back } = h.state().document().scene().lights[0].kind else {
        panic!("directional again");
    };
    for k in 0..3 {
        assert!((back[k] - direction[k]).abs() < 1e-9, "{back:?} {direction:?}");
    }
    // A rect light gets its edges and a samples control.
    pick(&mut h, "light.3.kind", "rect");
    let light = &h.state().document().scene().lights[3];
    assert!(matches!(light.kind, isoray_scene::LightKind::Rect { .. }));
    let before = h.state().document().text().to_string();
    set_value(&h, "light.3.samples", 64.0);
    h.run_steps(3);
    assert_eq!(h.state().document().text(), set(&before, &["light.3.samples=64"]));

    // Undo three times: the original bytes.
    for _ in 0..4 {
        h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
        h.run_steps(2);
    }
    assert_eq!(h.state().document().text(), original);

    // Materials: every value key is a control named by its key.
    h.get_by_label("floor").click_accesskit();
    h.run_steps(2);
    set_value(&h, "material.floor.shininess", 64.0);
    h.run_steps(3);
    assert_eq!(
        h.state().document().text(),
        set(&original, &["material.floor.shininess=64"])
    );
    pick(&mut h, "material.floor.model", "phong");
    assert_eq!(
        h.state().document().text(),
        set(
            &original,
            &["material.floor.shininess=64", "material.floor.model=phong"]
        )
    );

    // The camera's target, by its x field.
    h.get_by_label("Camera").click_accesskit();
    h.run_steps(2);
    let before = h.state().document().text().to_string();
    set_value(&h, "camera.target.x", 0.5);
    h.run_steps(3);
    assert_eq!(h.state().document().scene().camera.target[0], 0.5);
    let t = h.state().document().scene().camera.target;
    assert_eq!(
        h.state().document().text(),
        set(&before, &[&format!("camera.target=[{}, {}, {}]", t[0], t[1], t[2])])
    );
}

#[test]
fn the_copied_camera_table_loads_back_to_the_same_camera() {
    let scene = isoray_scene::load(&common::examples_dir().join("showcase.toml"), &[]).unwrap();
    let mut c = scene.camera.clone();
    c.position = [1.0 / 3.0, 2.5, -7.125];
    c.up = [0.1, 1.0, 0.0];
    let table = isoray_studio::app::playground::camera_toml(&c);
    let text = format!("{table}\n[[object]]\nshape = \"sphere(p, 1.0)\"\n");
    let back = isoray_scene::load_str(&text, "camera.toml", &[]).unwrap().camera;
    assert_eq!(
        (back.position, back.target, back.up, back.fov),
        (c.position, c.target, c.up, c.fov)
    );
}

const BASE: &str = r#"# built in the studio
[camera]
position = [0.0, 2.0, 5.0]
target = [0.0, 0.4, 0.0]
fov = 40.0

[render]
width = 96
height = 64
aa = 1
shadows = "hard"

[[light]]
kind = "directional"
direction = [1.0, 2.0, 1.0]
intensity = 0.6

[material.clay]
diffuse = [0.7, 0.5, 0.4]

[[object]]
material = "clay"
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.5)"
"#;

/// The scene the UI actions should make, written by hand.
const REFERENCE: &str = r#"[camera]
position = [0.0, 2.0, 5.0]
target = [0.0, 0.4, 0.0]
fov = 40.0

[render]
width = 96
height = 64
aa = 1
shadows = "hard"

[[light]]
kind = "directional"
direction = [1.0, 2.0, 1.0]
intensity = 0.6

[[light]]
kind = "directional"
direction = [-1.0, 2.0, 1.0]

[material.clay]
diffuse = [0.7, 0.5, 0.4]

[[object]]
material = "clay"
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.5)"

[[object]]
material = "clay"
shape = "smooth_union(sphere(p, 0.5), box(p, vec3(0.5, 0.5, 0.5)), 0.3)"
"#;

fn node_titled(h: &Harness<'_, Studio>, title: &str) -> usize {
    let g = h.state().graph();
    let found: Vec<usize> = g
        .snarl
        .node_ids()
        .filter(|(_, n)| n.title() == title && !matches!(n, GraphNode::Object { .. }))
        .map(|(id, _)| id.0)
        .collect();
    assert_eq!(found.len(), 1, "one `{title}` node: {found:?}");
    found[0]
}

#[test]
fn a_scene_built_by_ui_actions_renders_as_the_reference_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, BASE).unwrap();
    let mut h = studio_sized(&path, egui::Vec2::new(1400.0, 900.0));

    // A new object: a sphere.
    h.get_by_label("Add object").click();
    h.run_steps(3);
    assert_eq!(h.state().document().scene().objects.len(), 2);
    let object = h.state().graph().objects[1].0;

    // Its input gets a new smooth_union node, from the palette's search.
    h.get_by_label(&format!("object 1 #{object} input shape"))
        .click_accesskit();
    h.run_steps(2);
    h.get_by_label("new node ⏵").click_accesskit();
    h.run_steps(2);
    h.get_by_label("search nodes").type_text("smooth_union");
    h.run_steps(2);
    h.get_by_label("smooth_union").click_accesskit();
    h.run_steps(3);
    let union = node_titled(&h, "smooth_union");

    // Input a: the sphere already in the graph; input b: a new box.
    let sphere = node_titled(&h, "sphere");
    h.get_by_label(&format!("smooth_union #{union} input a"))
        .click_accesskit();
    h.run_steps(2);
    h.get_by_label(&format!("sphere #{sphere}")).click_accesskit();
    h.run_steps(3);
    h.get_by_label(&format!("smooth_union #{union} input b"))
        .click_accesskit();
    h.run_steps(2);
    h.get_by_label("new node ⏵").click_accesskit();
    h.run_steps(2);
    h.get_by_label("search nodes").type_text("box");
    h.run_steps(2);
    h.get_by_label("box").click_accesskit();
    h.run_steps(3);
    assert_eq!(
        h.state().document().scene().objects[1].source,
        "smooth_union(sphere(p, 0.5), box(p, vec3(0.5, 0.5, 0.5)), 0.25)"
    );

    // k = 0.3, typed into its field.
    // (The graph is drawn scaled, so its widgets are reached through
    // accessibility actions rather than pointer positions.)
    h.get_by_label(&format!("smooth_union #{union} k")).focus();
    h.run_steps(2);
    h.get_by_label(&format!("smooth_union #{union} k")).type_text("0.3");
    h.key_press(egui::Key::Enter);
    h.run_steps(3);
    assert_eq!(
        h.state().document().scene().objects[1].source,
        "smooth_union(sphere(p, 0.5), box(p, vec3(0.5, 0.5, 0.5)), 0.3)"
    );

    // A light, then save.
    let before_light = h.state().document().text().to_string();
    h.get_by_label("Add light").click();
    h.run_steps(3);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::S);
    h.run_steps(2);
    let saved = std::fs::read_to_string(&path).unwrap();
    assert!(saved.starts_with("# built in the studio\n"), "comments kept:\n{saved}");
    assert!(saved.contains("[[studio.graph]]"), "the layout is saved:\n{saved}");

    // Undo takes back the light: the bytes before it.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(h.state().document().text(), before_light);

    // Rendered, the saved file and the reference are the same image.
    let ours = isoray_scene::load(&path, &[]).unwrap();
    let reference = isoray_scene::load_str(REFERENCE, "reference.toml", &[]).unwrap();
    let opts = isoray_render::RenderOptions::default();
    let (a, _) = isoray_render::render(&ours, &opts);
    let (b, _) = isoray_render::render(&reference, &opts);
    assert_eq!(a.color.len(), 96 * 64);
    assert!(
        a.color == b.color,
        "the saved scene renders as the reference; saved:\n{saved}"
    );
    // And the image is not empty: the union is in it.
    let background = a.color[0];
    assert!(a.color.iter().filter(|c| **c != background).count() > 500);
}

#[test]
fn dragging_a_node_value_moves_the_preview_without_a_new_shape_and_release_writes_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, isoray_studio::document::NEW_SCENE).unwrap();
    let mut h = studio_sized(&path, egui::Vec2::new(1400.0, 900.0));
    let original = h.state().document().text().to_string();
    let sphere = node_titled(&h, "sphere");
    // The graph is drawn scaled: its layer's transform maps the widget's
    // rectangle to the screen.
    let to_screen = h.ctx.memory(|m| {
        assert_eq!(m.to_global.len(), 1, "one transformed layer, the graph's");
        *m.to_global.values().next().unwrap()
    });
    let r = to_screen * h.get_by_label(&format!("sphere #{sphere} r")).rect().center();

    // Press on the sphere's radius and drag right in two steps.
    h.hover_at(r);
    h.run_steps(1);
    h.drag_at(r);
    h.run_steps(1);
    h.hover_at(r + egui::vec2(20.0, 0.0));
    h.run_steps(2);
    let first = h.state().preview_scene();
    h.hover_at(r + egui::vec2(50.0, 0.0));
    h.run_steps(2);
    let second = h.state().preview_scene();

    // While dragging the file is untouched, the preview reads the radius
    // from a hidden parameter, and its shape (the tape the GPU compiles)
    // is the same at both values: only a runtime input moved.
    assert_eq!(h.state().document().text(), original);
    assert!(
        second.objects[1].source.contains("studio_drag"),
        "{}",
        second.objects[1].source
    );
    assert!(first.objects[1].shape.tape() == second.objects[1].shape.tape());
    let value = |s: &isoray_scene::Scene| match s.params.iter().find(|(n, _)| n == "studio_drag") {
        Some((_, isoray_shape::Value::Float(v))) => *v,
        other => panic!("a number parameter, found {other:?}"),
    };
    let (v1, v2) = (value(&first), value(&second));
    assert!(v2 > v1 && v1 > 1.0, "the radius grows with the drag: {v1}, {v2}");

    // Release: one edit writes the number into the shape text, and the
    // file's scene renders exactly as the preview did at that value.
    let during = h.state().preview_scene();
    h.drop_at(r + egui::vec2(50.0, 0.0));
    h.run_steps(3);
    let text = h.state().document().scene().objects[1].source.clone();
    let written: f64 = text
        .trim_end_matches(')')
        .rsplit(", ")
        .next()
        .unwrap()
        .parse()
        .unwrap_or_else(|_| panic!("a radius in {text}"));
    assert!((written - v2).abs() < 1e-9, "{text} holds {v2}");
    assert!(!h.state().preview_scene().objects[1].source.contains("studio_drag"));
    let small = |s: &isoray_scene::Scene| {
        let mut s = s.clone();
        s.render.width = 80;
        s.render.height = 50;
        s.render.aa = 1;
        isoray_render::render(&s, &isoray_render::RenderOptions::default())
            .0
            .color
    };
    assert!(small(&during) == small(h.state().document().scene()));
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(h.state().document().text(), original);
}

#[test]
fn the_surfaces_tab_lists_the_scene_surfaces_and_opens_one_in_the_dialog() {
    let (_dir, path, original) = example_copy("surfaces.toml");
    let mut h = studio_sized(&path, egui::Vec2::new(1400.0, 900.0));
    let rows = isoray_studio::surfaces::rows(&original);
    let before: Vec<usize> = rows.iter().map(|r| h.query_all_by_label(&r.name).count()).collect();
    h.get_by_label("Surfaces").click();
    h.run_steps(2);
    // Each surface has a row (a label more than the graph's nodes had).
    for (r, n) in rows.iter().zip(before) {
        assert_eq!(h.query_all_by_label(&r.name).count(), n + 1, "{}", r.name);
    }
    // One Edit per row, and the menu bar's.
    assert_eq!(h.get_all_by_label("Edit").count(), rows.len() + 1);
    h.get_all_by_label("Edit").nth(1).unwrap().click();
    // The check runs in the background; the dialog's Save waits for it.
    for _ in 0..200 {
        h.run_steps(1);
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    h.get_by_label("Save").click();
    h.run_steps(2);
    // Save was enabled (the check passed) and closed the dialog ...
    assert!(h.query_by_label("Save").is_none(), "the surface was valid and saved");
    // ... and saving an unchanged surface changes nothing.
    assert_eq!(h.state().document().text(), original);
}

#[test]
#[ignore = "writes a picture of the surface dialog to $ISORAY_SHOT for a person to look at"]
fn picture_of_the_surface_dialog() {
    // $ISORAY_SHOT_SCENE is the scene (examples/surfaces.toml when unset),
    // $ISORAY_SHOT_ROW picks the surface (1 = the first), $ISORAY_SHOT_MS
    // how long the check runs before the picture.
    let row = std::env::var("ISORAY_SHOT_ROW").map_or(1, |s| s.parse().unwrap());
    let ms = std::env::var("ISORAY_SHOT_MS").map_or(4000, |s| s.parse().unwrap());
    let (_dir, path, _) = example_copy("surfaces.toml");
    let path = std::env::var("ISORAY_SHOT_SCENE").map_or(path, std::path::PathBuf::from);
    let mut h = studio_sized(&path, egui::Vec2::new(1400.0, 900.0));
    h.get_by_label("Surfaces").click();
    h.run_steps(2);
    h.get_all_by_label("Edit").nth(row).unwrap().click();
    settle(&mut h, ms);
    let img = h.render().unwrap();
    img.save(std::env::var("ISORAY_SHOT").unwrap()).unwrap();
}

/// Runs the harness for about `ms` milliseconds of wall time, so the
/// dialog's background check can finish.
fn settle(h: &mut Harness<'_, Studio>, ms: u64) {
    for _ in 0..ms / 10 {
        h.run_steps(1);
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

/// Replaces the whole text of the field labelled `label` with `text`.
fn retype(h: &mut Harness<'_, Studio>, label: &str, text: &str) {
    h.get_by_label(label).focus();
    h.run_steps(2);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::A);
    h.run_steps(1);
    h.get_by_label(label).type_text(text);
    h.run_steps(2);
}

#[test]
fn a_parameter_default_typed_into_the_grid_is_checked_and_saved_as_its_key() {
    let (_dir, path, original) = example_copy("surfaces.toml");
    let mut h = studio_sized(&path, egui::Vec2::new(1400.0, 900.0));
    h.get_by_label("Surfaces").click();
    h.run_steps(2);
    // sphere_eq, the first surface: params = { r = 0.9 }.
    h.get_all_by_label("Edit").nth(1).unwrap().click();
    settle(&mut h, 1500);
    assert_eq!(h.get_by_label("parameter 1 symbol").value().as_deref(), Some("r"));
    assert_eq!(h.get_by_label("parameter 1 default").value().as_deref(), Some("0.9"));

    // Not a number: the check fails at the row and Save stays disabled.
    retype(&mut h, "parameter 1 default", "0.7x");
    settle(&mut h, 1500);
    assert!(
        h.get_by_label("Save").accesskit_node().is_disabled(),
        "a bad default cannot be saved"
    );
    h.get_by_label("Save").click();
    h.run_steps(2);
    assert_eq!(h.state().document().text(), original, "nothing was written");

    // A number: the check passes and Save writes exactly that key.
    retype(&mut h, "parameter 1 default", "0.7");
    settle(&mut h, 1500);
    assert!(!h.get_by_label("Save").accesskit_node().is_disabled());
    h.get_by_label("Save").click();
    h.run_steps(3);
    assert!(h.query_by_label("Save").is_none(), "the dialog closed");
    assert_eq!(
        h.state().document().text(),
        set(&original, &["surface.sphere_eq.params.r=0.7"]),
        "the save is the edit `isoray set` would make"
    );
    // One undo step returns the file.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(h.state().document().text(), original);
}

#[test]
fn an_orbit_asks_for_a_frame_per_move_and_none_while_the_pointer_is_still() {
    let (_dir, path, original) = example_copy("showcase.toml");
    let mut h = studio_on(&path);
    h.run_steps(3);
    let c = h.state().preview_rect().center();
    h.hover_at(c);
    h.run_steps(1);
    h.drag_at(c);
    h.run_steps(1);
    h.hover_at(c + egui::vec2(10.0, 0.0));
    h.run_steps(1);
    let moved = h.state().wanted();
    // Held still: no new request would cancel the frame being drawn.
    h.run_steps(5);
    assert_eq!(h.state().wanted(), moved);
    h.hover_at(c + egui::vec2(20.0, 0.0));
    h.run_steps(1);
    assert_eq!(h.state().wanted(), moved + 1, "one request per move");
    assert_eq!(h.state().document().text(), original, "nothing written while dragging");
    h.drop_at(c + egui::vec2(20.0, 0.0));
    h.run_steps(2);
    assert_ne!(h.state().document().text(), original, "the release writes the camera");
}

/// The camera of the scene in the studio's document.
fn camera_of(h: &Harness<'_, Studio>) -> isoray_scene::Camera {
    h.state().document().scene().camera.clone()
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

#[test]
fn shift_drag_pans_the_target_and_the_eye_together_as_one_edit() {
    let (_dir, path, _) = example_copy("showcase.toml");
    let mut h = studio_on(&path);
    let before = camera_of(&h);
    let c = h.state().preview_rect().center();
    h.hover_at(c);
    h.run_steps(1);
    h.event(egui::Event::ModifiersChanged(egui::Modifiers::SHIFT));
    h.drag_at(c);
    h.run_steps(1);
    h.hover_at(c + egui::vec2(40.0, 0.0));
    h.run_steps(1);
    h.drop_at(c + egui::vec2(40.0, 0.0));
    h.event(egui::Event::ModifiersChanged(egui::Modifiers::default()));
    h.run_steps(2);
    let after = camera_of(&h);
    // A pan moves both points by the same vector, sideways to the view.
    let dt: Vec<f64> = (0..3).map(|k| after.target[k] - before.target[k]).collect();
    let dp: Vec<f64> = (0..3).map(|k| after.position[k] - before.position[k]).collect();
    assert!(
        dt.iter().map(|v| v * v).sum::<f64>().sqrt() > 1e-3,
        "the target moved: {dt:?}"
    );
    for k in 0..3 {
        assert!((dt[k] - dp[k]).abs() < 1e-6, "{dt:?} vs {dp:?}");
    }
    let view: Vec<f64> = (0..3).map(|k| before.target[k] - before.position[k]).collect();
    let dot: f64 = (0..3).map(|k| dt[k] * view[k]).sum();
    assert!(dot.abs() < 1e-6, "a pan is across the view, not along it");
    // One undo step puts both back.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(camera_of(&h).target, before.target);
    assert_eq!(camera_of(&h).position, before.position);
}

#[test]
fn arrow_keys_over_the_preview_orbit_and_minus_zooms_out() {
    let (_dir, path, original) = example_copy("showcase.toml");
    let mut h = studio_on(&path);
    let before = camera_of(&h);
    let c = h.state().preview_rect().center();
    h.hover_at(c);
    h.run_steps(1);
    h.key_down(egui::Key::ArrowLeft);
    h.run_steps(5);
    assert_eq!(
        h.state().document().text(),
        original,
        "nothing written while a key is held"
    );
    h.key_up(egui::Key::ArrowLeft);
    h.run_steps(2);
    let turned = camera_of(&h);
    // An orbit keeps the target and the distance to it.
    assert_eq!(turned.target, before.target);
    let (d0, d1) = (
        distance(before.position, before.target),
        distance(turned.position, turned.target),
    );
    assert!((d0 - d1).abs() < 1e-6, "{d0} vs {d1}");
    assert!(distance(turned.position, before.position) > 1e-3, "the eye moved");
    // Minus zooms out: the same direction, farther away.
    h.key_down(egui::Key::Minus);
    h.run_steps(5);
    h.key_up(egui::Key::Minus);
    h.run_steps(2);
    let out = camera_of(&h);
    assert!(distance(out.position, out.target) > d1 + 1e-3);
}

/// The value of the first parameter in the scene the preview draws.
fn preview_param(h: &Harness<'_, Studio>) -> f64 {
    match h.state().preview_scene().params[0].1 {
        isoray_shape::Value::Float(x) => x,
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_timeline_plays_steps_and_jumps_to_keys_without_touching_the_file() {
    let (_dir, path, original) = example_copy("tracks.toml");
    let mut h = studio_on(&path);
    let track = h.state().document().scene().tracks[0].clone();
    assert_eq!(track.target, "params.r");
    // Next frame: t = 1/4 (4 fps); the preview's scene is at that time.
    h.get_by_label("Next frame").click();
    h.run_steps(2);
    assert_eq!(h.state().timeline().time, 0.25);
    let scene = h.state().preview_scene();
    assert_eq!(scene.time(), 0.25);
    assert_eq!(preview_param(&h), track.sample(0.25).unwrap()[0]);
    // A key's marker takes the time to the key.
    h.get_by_label("params.r key 2").click();
    h.run_steps(2);
    assert_eq!(h.state().timeline().time, 1.0);
    assert_eq!(preview_param(&h), 0.5, "the key's value");
    // Play moves the time on; pause holds it; the file never changes.
    h.get_by_label("Play").click();
    h.run_steps(4);
    let t = h.state().timeline();
    assert!(t.playing && t.time != 1.0, "{t:?}");
    h.get_by_label("Pause").click();
    h.run_steps(1);
    let held = h.state().timeline().time;
    h.run_steps(3);
    assert_eq!(h.state().timeline().time, held);
    assert!(!h.state().timeline().playing);
    h.get_by_label("Start").click();
    h.run_steps(2);
    assert_eq!(h.state().timeline().time, 0.0);
    assert_eq!(h.state().document().text(), original);
    assert!(!h.state().document().is_modified());
}

/// `clicks` presses and releases of `button` at `pos` (the harness runs
/// a frame, 1/4 s, per event).
fn click_at(h: &mut Harness<'_, Studio>, pos: egui::Pos2, button: egui::PointerButton, clicks: usize) {
    for _ in 0..clicks {
        for pressed in [true, false] {
            h.event(egui::Event::PointerButton {
                pos,
                button,
                pressed,
                modifiers: egui::Modifiers::default(),
            });
        }
    }
    h.step();
}

/// The keys of the scene's first track.
fn first_track_keys(h: &Harness<'_, Studio>) -> Vec<(f64, Vec<f64>)> {
    h.state().document().scene().tracks[0].keys.clone()
}

#[test]
fn track_keys_are_dragged_added_and_deleted_on_the_curves_one_undo_step_each() {
    let (_dir, path, original) = example_copy("tracks.toml");
    let mut h = studio_sized(&path, egui::Vec2::new(1100.0, 800.0));
    // The harness runs 1/4 s per event: a double click's four events
    // take more than egui's 0.3 s.
    h.ctx.options_mut(|o| o.input_options.max_double_click_delay = 2.0);
    let before = first_track_keys(&h);
    h.get_by_label("params.r track").click();
    h.run_steps(2);
    // Drag key 1 (t = 0.5, r = 0.9) right and up.
    let key = h.get_by_label("params.r curve key 1").rect().center();
    h.hover_at(key);
    h.run_steps(1);
    h.drag_at(key);
    h.run_steps(1);
    h.hover_at(key + egui::vec2(15.0, -10.0));
    h.run_steps(1);
    assert_eq!(h.state().document().text(), original, "nothing written while dragging");
    h.hover_at(key + egui::vec2(30.0, -20.0));
    h.run_steps(1);
    h.drop_at(key + egui::vec2(30.0, -20.0));
    h.run_steps(2);
    let moved = first_track_keys(&h);
    assert_eq!(moved.len(), before.len());
    assert!(moved[1].0 > before[1].0 && moved[1].1[0] > before[1].1[0], "{moved:?}");
    assert!(moved[1].0 < moved[2].0, "times stay increasing");
    assert_eq!((&moved[0], &moved[2], &moved[3]), (&before[0], &before[2], &before[3]));
    // The file holds exactly the track's new keys, written as `isoray set` would.
    let edit = isoray_studio::curves::keys_edit(0, &moved);
    assert_eq!(h.state().document().text(), set(&original, &[edit.as_str()]));
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(h.state().document().text(), original, "one undo step");
    // Double-click the curves between keys 2 and 3: a key on the curve.
    let area = h.get_by_label("params.r curves").rect();
    let x = area.left() + 6.0 + (area.width() - 12.0) * (1.25 / 1.5) as f32;
    let p = egui::pos2(x, area.center().y);
    h.hover_at(p);
    h.run_steps(1);
    click_at(&mut h, p, egui::PointerButton::Primary, 2);
    h.run_steps(2);
    let added = first_track_keys(&h);
    assert_eq!(added.len(), before.len() + 1, "{added:?}");
    assert!((added[3].0 - 1.25).abs() < 0.01, "{added:?}");
    // Right-click the new key: deleted again, the keys as they were.
    let new_key = h.get_by_label("params.r curve key 3").rect().center();
    h.hover_at(new_key);
    h.run_steps(1);
    click_at(&mut h, new_key, egui::PointerButton::Secondary, 1);
    h.run_steps(2);
    assert_eq!(first_track_keys(&h), before);
    // Undo twice: the added key comes back, then the original file.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(first_track_keys(&h).len(), before.len() + 1);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(h.state().document().text(), original);
}

#[test]
#[ignore = "writes a picture of the timeline's curve editor to $ISORAY_SHOT for a person to look at"]
fn picture_of_the_curve_editor() {
    // $ISORAY_SHOT_TRACK: the track's label (object.1.position by default).
    let track = std::env::var("ISORAY_SHOT_TRACK").unwrap_or_else(|_| "object.1.position".into());
    let (_dir, path, _) = example_copy("tracks.toml");
    let mut h = studio_sized(&path, egui::Vec2::new(1400.0, 900.0));
    h.get_by_label(&format!("{track} track")).click();
    settle(&mut h, 3000);
    let img = h.render().unwrap();
    img.save(std::env::var("ISORAY_SHOT").unwrap()).unwrap();
}

/// Sends raw MIDI bytes to the studio as its input port would.
fn send_midi(h: &mut Harness<'_, Studio>, bytes: &[u8]) {
    h.state()
        .midi()
        .sender()
        .send((std::time::Instant::now(), bytes.to_vec()))
        .unwrap();
    h.run_steps(2);
}

/// The preview's value of parameter `name`.
fn preview_value(h: &Harness<'_, Studio>, name: &str) -> f64 {
    let scene = h.state().preview_scene();
    match scene.params.iter().find(|(n, _)| n == name).unwrap().1 {
        isoray_shape::Value::Float(x) => x,
        ref other => panic!("{other:?}"),
    }
}

#[test]
fn midi_learn_maps_the_last_control_to_the_clicked_slider_and_a_take_is_recorded() {
    let (dir, path, original) = example_copy("placement.toml");
    let mut h = studio_sized(&path, egui::Vec2::new(1100.0, 800.0));
    h.get_by_label("MIDI").click();
    h.run_steps(1);
    h.get_by_label("MIDI learn").click();
    h.run_steps(1);
    assert!(h.state().midi().learning());
    // Turn a knob: CC 21 on channel 2 (status 0xB1).
    send_midi(&mut h, &[0xB1, 21, 30]);
    h.get_by_label("params.speed").click();
    h.run_steps(2);
    let scene = h.state().document().scene().clone();
    assert_eq!(scene.midi.len(), 1, "{}", h.state().document().text());
    let m = &scene.midi[0];
    assert_eq!(
        (m.source, m.channel, m.target.as_str(), m.range),
        (isoray_scene::midi::Source::Cc(21), Some(2), "params.speed", [-1.0, 2.0])
    );
    assert!(!h.state().midi().learning());
    // The knob now moves the parameter in the preview, not in the file.
    send_midi(&mut h, &[0xB1, 21, 127]);
    assert_eq!(preview_value(&h, "speed"), 2.0);
    send_midi(&mut h, &[0xB1, 21, 0]);
    assert_eq!(preview_value(&h, "speed"), -1.0);
    // Another channel is not heard.
    send_midi(&mut h, &[0xB0, 21, 127]);
    assert_eq!(preview_value(&h, "speed"), -1.0);
    // Record a take of a ramp; it is written beside the scene.
    h.get_by_label("MIDI").click();
    h.run_steps(1);
    h.get_by_label("Record take").click();
    h.run_steps(1);
    for v in [10u8, 64, 120] {
        send_midi(&mut h, &[0xB1, 21, v]);
    }
    h.get_by_label("MIDI").click();
    h.run_steps(1);
    h.get_by_label("Stop recording").click();
    h.run_steps(1);
    let take = dir.path().join("scene-take-1.mid");
    let events = isoray_scene::midi::read_midi_file(&take).unwrap();
    let values: Vec<u8> = events
        .iter()
        .filter_map(|e| match e.kind {
            isoray_scene::midi::Message::Cc { value, .. } => Some(value),
            _ => None,
        })
        .collect();
    assert_eq!(values, [10, 64, 120]);
    // One undo (Edit menu) removes the learned mapping.
    // One undo removes the learned mapping (the click that learned wrote nothing).
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(h.state().document().text(), original);
}

/// View ▸ Preview renderer switches the preview's renderer, and the status
/// bar's backend follows (the GPU renderer where there is an adapter).
#[test]
fn the_view_menu_switches_the_preview_renderer() {
    use isoray_studio::preview::{Backend, PreviewChoice};
    let (_dir, path, _) = example_copy("showcase.toml");
    let mut h = studio_on(&path);
    assert_eq!(h.state().renderer_choice(), PreviewChoice::Cpu);
    let choose = |h: &mut Harness<'static, Studio>, label: &str| {
        // The menu bar's View (the playground has a "View" choice too).
        h.get_all_by_label("View").next().unwrap().click();
        h.run_steps(2);
        h.get_by_label(label).click();
        h.run_steps(2);
    };
    let wait_for = |h: &mut Harness<'static, Studio>, gpu: bool| {
        let start = std::time::Instant::now();
        while start.elapsed() < std::time::Duration::from_secs(120) {
            h.run_steps(1);
            match h.state().backend() {
                Some(Backend::Gpu(_)) if gpu => return true,
                Some(Backend::Cpu(_)) if !gpu => return true,
                _ => std::thread::sleep(std::time::Duration::from_millis(20)),
            }
        }
        false
    };
    choose(&mut h, "GPU renderer");
    assert_eq!(h.state().renderer_choice(), PreviewChoice::Gpu);
    if isoray_gpu::GpuRenderer::new().is_ok() {
        assert!(wait_for(&mut h, true), "the preview moved to the GPU renderer");
    }
    choose(&mut h, "CPU renderer");
    assert_eq!(h.state().renderer_choice(), PreviewChoice::Cpu);
    assert!(wait_for(&mut h, false), "and back to the CPU renderer");
}
