//! The playground panel: parameter sliders, render settings, lights,
//! materials and the camera, each control bound to the scene key it edits
//! (its accessible name is that key).
//!
//! Controls of numbers show their value in the preview while dragged
//! (through `Scene::set_value` or `Scene::set_param`: nothing is compiled
//! again and the GPU keeps its pipeline), and become one edit of the file
//! on release. Choices, switches and integers are one edit each.

use eframe::egui;
use isoray_scene::schema::{KeySpec, Kind, Named};
use isoray_scene::{Camera, Light, LightKind, Scene};
use isoray_shape::Value;

use super::Studio;

/// The kinds of light, as the file names them.
pub const LIGHT_KINDS: [&str; 4] = ["directional", "point", "sphere", "rect"];

impl Studio {
    /// The playground: parameters, render settings, lights, materials and
    /// camera.
    pub(super) fn playground(&mut self, ui: &mut egui::Ui) {
        let scene = self.doc.scene().clone();
        egui::ScrollArea::vertical().show(ui, |ui| {
            type Section = fn(&mut Studio, &mut egui::Ui, &Scene);
            let sections: [(&str, bool, Section); 5] = [
                ("Parameters", true, Studio::parameters),
                ("Render", true, Studio::render_settings),
                ("Lights", true, Studio::lights),
                ("Materials", false, Studio::materials),
                ("Camera", false, |s, ui, scene| s.camera(ui, &scene.camera)),
            ];
            for (title, open, show) in sections {
                egui::CollapsingHeader::new(title)
                    .default_open(open)
                    .show(ui, |ui| show(self, ui, &scene));
            }
        });
    }

    fn parameters(&mut self, ui: &mut egui::Ui, scene: &Scene) {
        let params = scene.library.params().to_vec();
        if params.is_empty() {
            ui.label("The scene has no [params].");
        }
        for (name, value) in params {
            let Value::Float(v) = value else {
                ui.label(format!("{name} = {value:?} (vectors are edited in the file)"));
                continue;
            };
            let key = format!("params.{name}");
            let range = scene
                .param_ranges
                .iter()
                .find(|r| r.key == key)
                .map(|r| r.range)
                .unwrap_or([v.min(0.0) - 1.0, v.max(0.0) + 1.0]);
            self.slider(ui, &name, &key, v, range[0]..=range[1]);
        }
    }

    /// A slider for `key`: the preview follows while dragging (no shader
    /// rebuild), and release commits one edit.
    pub(super) fn slider(
        &mut self,
        ui: &mut egui::Ui,
        label: &str,
        key: &str,
        value: f64,
        range: std::ops::RangeInclusive<f64>,
    ) -> egui::Response {
        self.slider_with(ui, label, key, value, range, egui::SliderClamping::Always)
    }

    /// [`Studio::slider`] with a clamping rule: a key with no upper bound
    /// takes typed values past the slider's end.
    fn slider_with(
        &mut self,
        ui: &mut egui::Ui,
        label: &str,
        key: &str,
        value: f64,
        range: std::ops::RangeInclusive<f64>,
        clamping: egui::SliderClamping,
    ) -> egui::Response {
        let mut v = match &self.live {
            Some((k, x)) if k == key => *x,
            _ => value,
        };
        let bounds = [*range.start(), *range.end()];
        let r = ui.add(egui::Slider::new(&mut v, range).clamping(clamping).text(label));
        named(&r, egui::WidgetType::Slider, key);
        if self.learn_on(&r, key, bounds) {
            return r;
        }
        if r.changed() {
            self.live = Some((key.to_string(), v));
            self.request_preview();
        }
        if r.drag_stopped() || (r.changed() && !r.dragged()) {
            self.live = None;
            self.edit(vec![format!("{key}={v}")]);
        }
        r
    }

    /// An integer slider for `key`, one edit on release.
    fn int_slider(
        &mut self,
        ui: &mut egui::Ui,
        label: &str,
        key: &str,
        value: u32,
        range: std::ops::RangeInclusive<u32>,
    ) {
        let mut v = match &self.live {
            Some((k, x)) if k == key => *x as u32,
            _ => value,
        };
        let r = ui.add(egui::Slider::new(&mut v, range).logarithmic(true).text(label));
        named(&r, egui::WidgetType::Slider, key);
        if r.changed() {
            self.live = Some((key.to_string(), v as f64));
        }
        if r.drag_stopped() || (r.changed() && !r.dragged()) {
            self.live = None;
            self.edit(vec![format!("{key}={v}")]);
        }
    }

    /// A colour button for `key`: the preview follows while the picker is
    /// dragged, and the colour is one edit when the pointer is released.
    fn colour(&mut self, ui: &mut egui::Ui, label: &str, key: &str, value: [f64; 3]) {
        let v = match &self.live_vec {
            Some((k, x)) if k == key => *x,
            _ => value,
        };
        let mut rgb = [v[0] as f32, v[1] as f32, v[2] as f32];
        let r = ui.horizontal(|ui| {
            let r = ui.color_edit_button_rgb(&mut rgb);
            ui.label(label);
            r
        });
        let r = r.inner;
        named(&r, egui::WidgetType::ColorButton, key);
        let changed = r.changed();
        if changed {
            self.live_vec = Some((key.to_string(), rgb.map(|c| c as f64)));
            self.request_preview();
        }
        let held = ui.input(|i| i.pointer.any_down());
        if !changed && !held && self.live_vec.as_ref().is_some_and(|(k, _)| k == key) {
            let (_, v) = self.live_vec.take().expect("checked");
            self.edit(vec![vec3_edit(key, v)]);
        }
    }

    /// A direction as azimuth and elevation sliders (the thesis's knobs),
    /// shown live while dragged and written as `[x, y, z]` on release.
    fn direction(&mut self, ui: &mut egui::Ui, key: &str, value: [f64; 3]) {
        let d = match &self.live_vec {
            Some((k, v)) if k == key => *v,
            _ => value,
        };
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-12);
        let mut azimuth = d[2].atan2(d[0]).to_degrees();
        let mut elevation = (d[1] / n).clamp(-1.0, 1.0).asin().to_degrees();
        let a = ui.add(egui::Slider::new(&mut azimuth, -180.0..=180.0).text("azimuth °"));
        named(&a, egui::WidgetType::Slider, &format!("{key} azimuth"));
        let e = ui.add(egui::Slider::new(&mut elevation, -90.0..=90.0).text("elevation °"));
        named(&e, egui::WidgetType::Slider, &format!("{key} elevation"));
        if a.changed() || e.changed() {
            let (az, el) = (azimuth.to_radians(), elevation.to_radians());
            let v = [el.cos() * az.cos(), el.sin(), el.cos() * az.sin()];
            self.live_vec = Some((key.to_string(), v));
            self.request_preview();
        }
        let released = |r: &egui::Response| r.drag_stopped() || (r.changed() && !r.dragged());
        if released(&a) || released(&e) {
            if let Some((_, v)) = self.live_vec.take() {
                self.edit(vec![vec3_edit(key, v)]);
            }
        }
    }

    /// A vector as three drag values (accessible names `KEY.x`, `.y`,
    /// `.z`), shown live while dragged and written on release.
    fn vector(&mut self, ui: &mut egui::Ui, label: &str, key: &str, value: [f64; 3]) {
        let mut v = match &self.live_vec {
            Some((k, x)) if k == key => *x,
            _ => value,
        };
        let mut changed = false;
        let mut done = false;
        ui.horizontal(|ui| {
            for (c, axis) in v.iter_mut().zip(["x", "y", "z"]) {
                let r = ui.add(egui::DragValue::new(c).speed(0.05).max_decimals(4));
                named(&r, egui::WidgetType::DragValue, &format!("{key}.{axis}"));
                changed |= r.changed();
                done |= r.drag_stopped() || r.lost_focus() || (r.changed() && !r.dragged() && !r.has_focus());
            }
            ui.label(label);
        });
        if changed {
            self.live_vec = Some((key.to_string(), v));
            self.request_preview();
        }
        if done {
            if let Some((_, v)) = self.live_vec.take() {
                self.edit(vec![vec3_edit(key, v)]);
            }
        }
    }

    fn render_settings(&mut self, ui: &mut egui::Ui, scene: &Scene) {
        let r = &scene.render;
        let mut shadows = r.shadows;
        choice(ui, "Shadows", &mut shadows);
        if shadows != r.shadows {
            self.edit(vec![format!("render.shadows={}", name_of(shadows))]);
        }
        let mut ao = r.ao;
        if ui.checkbox(&mut ao, "Ambient occlusion").changed() {
            self.edit(vec![format!("render.ao={ao}")]);
        }
        let mut aa = r.aa;
        if ui
            .add(egui::Slider::new(&mut aa, 1..=4).text("Supersampling"))
            .changed()
        {
            self.edit(vec![format!("render.aa={aa}")]);
        }
        let mut view = r.view;
        choice(ui, "View", &mut view);
        if view != r.view {
            self.edit(vec![format!("render.view={}", name_of(view))]);
        }
        let mut normals = r.normals;
        choice(ui, "Normals", &mut normals);
        if normals != r.normals {
            self.edit(vec![format!("render.normals={}", name_of(normals))]);
        }
        self.slider(ui, "blend (smooth union k)", "render.blend", r.blend, 0.0..=1.0);
    }

    fn lights(&mut self, ui: &mut egui::Ui, scene: &Scene) {
        if scene.lights.is_empty() {
            ui.label("No lights.");
        }
        if ui.button("Add light").clicked() {
            let r = self.doc.push_table(
                "light",
                &[("kind", "\"directional\""), ("direction", "[-1.0, 2.0, 1.0]")],
            );
            self.done(r);
        }
        for (i, light) in scene.lights.iter().enumerate() {
            ui.push_id(i, |ui| {
                ui.separator();
                ui.horizontal(|ui| {
                    ui.strong(format!("Light {i}"));
                    let now = kind_name(&light.kind);
                    let mut kind = now;
                    let combo = egui::ComboBox::from_id_salt("kind")
                        .selected_text(kind)
                        .show_ui(ui, |ui| {
                            for k in LIGHT_KINDS {
                                ui.selectable_value(&mut kind, k, k);
                            }
                        });
                    named(&combo.response, egui::WidgetType::ComboBox, &format!("light.{i}.kind"));
                    if kind != now {
                        let target = scene.camera.target;
                        let reach = distance(scene.camera.position, target).max(1.0);
                        let r = self
                            .doc
                            .edit_with(&[], |toml| set_light_kind(toml, i, light, kind, target, reach));
                        self.done(r);
                    }
                    if ui.small_button("Remove").clicked() {
                        let r = self.doc.remove_table("light", i);
                        self.done(r);
                    }
                });
                let key = |k: &str| format!("light.{i}.{k}");
                self.slider(ui, "intensity", &key("intensity"), light.intensity, 0.0..=4.0);
                self.slider(ui, "size", &key("size"), light.size, 0.01..=2.0)
                    .on_hover_text("penumbra of soft shadows: k = 1/size");
                self.colour(ui, "colour", &key("color"), light.color);
                match light.kind {
                    LightKind::Directional { direction } => self.direction(ui, &key("direction"), direction),
                    LightKind::Point { position } => self.vector(ui, "position", &key("position"), position),
                    LightKind::Sphere { position, radius } => {
                        self.vector(ui, "position", &key("position"), position);
                        self.slider(ui, "radius", &key("radius"), radius, 0.01..=4.0);
                    }
                    LightKind::Rect { position, u, v } => {
                        self.vector(ui, "position", &key("position"), position);
                        self.vector(ui, "u edge", &key("u"), u);
                        self.vector(ui, "v edge", &key("v"), v);
                    }
                }
                if matches!(light.kind, LightKind::Sphere { .. } | LightKind::Rect { .. }) {
                    self.int_slider(ui, "samples", &key("samples"), light.samples, 1..=1024);
                }
                if !matches!(light.kind, LightKind::Directional { .. }) {
                    self.vector(ui, "attenuation [c, l, q]", &key("attenuation"), light.attenuation);
                }
            });
        }
    }

    /// Every material the scene defines (and `default` when an object
    /// uses it), each value key a control: numbers as sliders, colours as
    /// colour buttons, choices and switches.
    fn materials(&mut self, ui: &mut egui::Ui, scene: &Scene) {
        let used = |i: usize| scene.objects.iter().any(|o| o.material == i);
        for (i, m) in scene.materials.iter().enumerate() {
            if m.name == "default" && !used(i) {
                continue;
            }
            egui::CollapsingHeader::new(&m.name)
                .id_salt(("material", i))
                .show(ui, |ui| {
                    for spec in isoray_scene::material_value_keys() {
                        let Some(text) = m.value_text(spec.name) else { continue };
                        let key = format!("material.{}.{}", m.name, spec.name);
                        self.key_control(ui, spec, &key, &text);
                    }
                });
        }
    }

    /// The control of one key described by `spec`, whose value is now
    /// `text` (as the file writes it).
    fn key_control(&mut self, ui: &mut egui::Ui, spec: &KeySpec, key: &str, text: &str) {
        let label = spec.name.replace('_', " ");
        let numbers = numbers(text);
        match &spec.kind {
            Kind::Num(range) => {
                let v = numbers.first().copied().unwrap_or(0.0);
                let hi = if range.hi.is_finite() {
                    range.hi
                } else {
                    (4.0 * v).max(range.lo + 1.0).max(1.0)
                };
                let lo = if range.lo_included {
                    range.lo
                } else {
                    range.lo + (hi - range.lo) * 1e-3
                };
                let clamping = if range.hi.is_finite() {
                    egui::SliderClamping::Always
                } else {
                    egui::SliderClamping::Never
                };
                self.slider_with(ui, &label, key, v, lo..=hi, clamping)
                    .on_hover_text(spec.doc);
            }
            Kind::Colour | Kind::UnitColour if numbers.len() == 3 => {
                self.colour(ui, &label, key, [numbers[0], numbers[1], numbers[2]]);
            }
            Kind::Vector if numbers.len() == 3 => self.vector(ui, &label, key, [numbers[0], numbers[1], numbers[2]]),
            Kind::Int { lo, hi } => {
                let v = numbers.first().copied().unwrap_or(*lo as f64) as u32;
                self.int_slider(ui, &label, key, v, *lo..=*hi);
            }
            Kind::Bool => {
                let mut b = text == "true";
                let r = ui.checkbox(&mut b, &label).on_hover_text(spec.doc);
                named(&r, egui::WidgetType::Checkbox, key);
                if r.changed() {
                    self.edit(vec![format!("{key}={b}")]);
                }
            }
            Kind::Choice(names) => {
                let now = text.trim_matches('"');
                let mut picked = now.to_string();
                ui.horizontal(|ui| {
                    let r = egui::ComboBox::from_id_salt(key).selected_text(now).show_ui(ui, |ui| {
                        for n in names {
                            ui.selectable_value(&mut picked, n.to_string(), *n);
                        }
                    });
                    named(&r.response, egui::WidgetType::ComboBox, key);
                    ui.label(&label).on_hover_text(spec.doc);
                });
                if picked != now {
                    self.edit(vec![format!("{key}={picked}")]);
                }
            }
            _ => {
                ui.label(format!("{label} = {text}"));
            }
        }
    }

    fn camera(&mut self, ui: &mut egui::Ui, c: &Camera) {
        self.slider(ui, "fov", "camera.fov", c.fov, 5.0..=120.0);
        self.vector(ui, "position", "camera.position", c.position);
        self.vector(ui, "target", "camera.target", c.target);
        self.vector(ui, "up", "camera.up", c.up);
        ui.horizontal(|ui| {
            if ui
                .button("Copy as [camera] TOML")
                .on_hover_text("the camera as it is now, for pasting into a scene file")
                .clicked()
            {
                let mut shown = c.clone();
                if let Some(o) = &self.orbit {
                    o.apply(&mut shown);
                }
                ui.ctx().copy_text(camera_toml(&shown));
                self.status = "copied the [camera] table".into();
            }
        });
        ui.label("Drag the preview to orbit, scroll to zoom.");
    }
}

/// The `[camera]` table of `c`: position, target, up and fov, which load
/// back to the same camera.
pub fn camera_toml(c: &Camera) -> String {
    let v = |a: [f64; 3]| format!("[{:?}, {:?}, {:?}]", a[0], a[1], a[2]);
    format!(
        "[camera]\nposition = {}\ntarget = {}\nup = {}\nfov = {:?}\n",
        v(c.position),
        v(c.target),
        v(c.up),
        c.fov
    )
}

/// The file's name of a light's kind.
pub fn kind_name(kind: &LightKind) -> &'static str {
    match kind {
        LightKind::Directional { .. } => "directional",
        LightKind::Point { .. } => "point",
        LightKind::Sphere { .. } => "sphere",
        LightKind::Rect { .. } => "rect",
    }
}

/// Makes light `index` of the file a light of kind `to`: `kind` is set,
/// the keys of its old kind that the new one rejects are removed, and the
/// keys it needs are written from the old light: a directional light
/// becomes a light `reach` from `target` in its direction; a point or area
/// light becomes a directional light from `target` towards it; a rect
/// light gets 1 × 1 edges in the horizontal plane. Other keys (colour,
/// intensity, comments) stay.
pub fn set_light_kind(
    toml: &mut toml_edit::DocumentMut,
    index: usize,
    light: &Light,
    to: &str,
    target: [f64; 3],
    reach: f64,
) {
    let table = match toml.get_mut("light") {
        Some(toml_edit::Item::ArrayOfTables(a)) => a.get_mut(index),
        Some(toml_edit::Item::Table(t)) if index == 0 => Some(t),
        _ => None,
    };
    let Some(table) = table else { return };
    let position = match light.kind {
        LightKind::Directional { direction } => {
            let n = distance(direction, [0.0; 3]).max(1e-12);
            [0, 1, 2].map(|k| target[k] + direction[k] / n * reach)
        }
        LightKind::Point { position } | LightKind::Sphere { position, .. } | LightKind::Rect { position, .. } => {
            position
        }
    };
    for k in ["direction", "position", "radius", "u", "v"] {
        table.remove(k);
    }
    let array = |a: [f64; 3]| {
        let mut arr = toml_edit::Array::new();
        for x in a {
            arr.push(x);
        }
        toml_edit::value(arr)
    };
    table["kind"] = toml_edit::value(to);
    match to {
        "directional" => {
            let d = [0, 1, 2].map(|k| position[k] - target[k]);
            let d = if distance(d, [0.0; 3]) < 1e-9 {
                [-1.0, 2.0, 1.0]
            } else {
                d
            };
            table["direction"] = array(d);
        }
        "rect" => {
            table["position"] = array(position);
            table["u"] = array([1.0, 0.0, 0.0]);
            table["v"] = array([0.0, 0.0, 1.0]);
        }
        _ => table["position"] = array(position),
    }
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The numbers of a value as the file writes it (`1.5`, `[0.1, 0.2, 0.3]`).
fn numbers(text: &str) -> Vec<f64> {
    text.trim_matches(|c| c == '[' || c == ']')
        .split(',')
        .filter_map(|s| s.trim().parse().ok())
        .collect()
}

/// Names a widget for screen readers (and UI tests): the scene key it
/// edits.
fn named(r: &egui::Response, kind: egui::WidgetType, key: &str) {
    r.widget_info(|| egui::WidgetInfo::labeled(kind, true, key));
}

/// A combo box over every value of a named choice.
fn choice<T: Named + std::fmt::Debug>(ui: &mut egui::Ui, label: &str, value: &mut T) {
    egui::ComboBox::from_label(label)
        .selected_text(name_of(*value))
        .show_ui(ui, |ui| {
            for (name, v) in T::NAMES {
                ui.selectable_value(value, *v, *name);
            }
        });
}

/// The file's name of a choice's value.
fn name_of<T: Named>(value: T) -> &'static str {
    T::NAMES.iter().find(|(_, v)| *v == value).map_or("?", |(n, _)| n)
}

/// The edit (`--set` syntax) that sets the three-component `key` to `v`.
pub(crate) fn vec3_edit<T: std::fmt::Display>(key: &str, v: [T; 3]) -> String {
    let [x, y, z] = v;
    format!("{key}=[{x}, {y}, {z}]")
}
