//! The studio's window: a menu bar, the playground panel of controls bound
//! to scene keys, and the live preview with an orbit camera.

use std::path::PathBuf;
use std::time::Instant;

use eframe::egui;
use isoray_scene::Scene;
use isoray_shape::Value;

mod midi_menu;
pub mod playground;
pub mod timeline;

use crate::document::Document;
use crate::graph::GraphEditor;
use crate::orbit::Orbit;
use crate::preview::{Frame, Preview, PreviewChoice};
use crate::surfaces::{candidate, Check, Field, FieldError, Mode, Outcome, ParamRow, SurfaceForm};

/// How the studio was started.
#[derive(Debug, Clone, Default)]
pub struct StudioOptions {
    /// The scene file to open (None: a new scene).
    pub scene: Option<PathBuf>,
    /// Which renderer draws the preview (`--cpu`, `--gpu`; by default the
    /// GPU renderer on a hardware adapter, the CPU renderer otherwise).
    pub renderer: PreviewChoice,
    /// Write a screenshot of the window here once the preview has
    /// converged, then exit.
    pub screenshot: Option<PathBuf>,
}

/// A file dialog in progress: the path typed so far.
#[derive(Debug, Clone)]
enum FileDialog {
    Open(String),
    SaveAs(String),
    /// File ▸ Export: an image (.png, .exr) or a mesh (.stl, .obj, .ply, .glb).
    Export(String),
}

/// The preview frame on screen (for tests and benchmarks).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shown {
    /// The request it answers (see [`Studio::wanted`]).
    pub id: u64,
    /// True when it is the request's final image (not a partial pass).
    pub done: bool,
    /// How long the renderer took for it, ms.
    pub ms: f64,
    /// Its size in pixels (smaller than the panel while dragging when a
    /// full frame is slow).
    pub width: u32,
    /// Its size in pixels.
    pub height: u32,
    /// When the UI put it on screen.
    pub at: Instant,
}

/// The navigation keys held over the preview this frame: arrows orbit
/// (pan with Shift), + and − or Page Up and Page Down zoom. Each frame a
/// key is held turns, pans or zooms by its rate times the frame's time.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct NavKeys {
    /// Right minus left, up minus down (−1, 0 or 1).
    x: f64,
    y: f64,
    /// Out minus in.
    zoom: f64,
    /// Shift held: the arrows pan.
    pan: bool,
    /// The frame's time, seconds.
    dt: f64,
    /// Any navigation key is down.
    held: bool,
}

impl NavKeys {
    /// Radians a second an arrow key turns the orbit.
    const TURN: f64 = 1.5;
    /// Distances to the target a second an arrow key pans.
    const PAN: f64 = 0.5;
    /// Doublings of the distance a second the zoom keys make.
    const ZOOM: f64 = 1.0;

    fn read(i: &egui::InputState) -> NavKeys {
        use egui::Key;
        let down = |k: Key| if i.key_down(k) { 1.0 } else { 0.0 };
        let x = down(Key::ArrowRight) - down(Key::ArrowLeft);
        let y = down(Key::ArrowUp) - down(Key::ArrowDown);
        let zoom = down(Key::Minus) + down(Key::PageDown) - down(Key::Plus) - down(Key::Equals) - down(Key::PageUp);
        NavKeys {
            x,
            y,
            zoom,
            pan: i.modifiers.shift,
            // A long stall (a slow frame) moves no further than 1/10 s.
            dt: (i.stable_dt as f64).clamp(0.0, 0.1),
            held: x != 0.0 || y != 0.0 || zoom != 0.0,
        }
    }

    fn any(&self) -> bool {
        self.held
    }

    fn apply(&self, o: &mut Orbit) {
        if !self.held {
            return;
        }
        // A key moves the view as a drag the same way would: the scene
        // follows the arrow.
        if self.pan {
            o.pan(-self.x * Self::PAN * self.dt, -self.y * Self::PAN * self.dt);
        } else {
            o.rotate(-self.x * Self::TURN * self.dt, -self.y * Self::TURN * self.dt);
        }
        o.zoom((self.zoom * Self::ZOOM * self.dt).exp2());
    }
}

/// What to do once unsaved changes are dealt with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pending {
    Close,
    New,
}

/// The application state.
pub struct Studio {
    doc: Document,
    preview: Preview,
    options: StudioOptions,
    texture: Option<egui::TextureHandle>,
    /// The last frame shown.
    shown: Option<Shown>,
    /// The request that answers the document as it is now.
    wanted: u64,
    /// The camera while the user drags it (committed on release).
    orbit: Option<Orbit>,
    /// A live value while a slider is dragged: (key, value) shown in the
    /// preview and committed as one edit on release.
    live: Option<(String, f64)>,
    /// A live vector while a direction is dragged: (key, value).
    live_vec: Option<(String, [f64; 3])>,
    /// A node's value while it is dragged in the graph.
    slot_drag: Option<SlotDrag>,
    /// The export running, if any.
    export: Option<crate::export::Export>,
    /// Status line: the last error or message.
    status: String,
    dialog: Option<FileDialog>,
    confirm: Option<Pending>,
    allow_close: bool,
    screenshot_asked: bool,
    started: Instant,
    /// The preview panel on screen, in points.
    preview_rect: egui::Rect,
    /// The timeline's time and play state (scenes with an `[animation]`).
    timeline: timeline::Timeline,
    /// A key being dragged in the timeline's curve editor.
    curve_drag: Option<timeline::CurveDrag>,
    /// Live MIDI input, learn and recording.
    midi: crate::midi::MidiLive,
    /// The last MIDI take written.
    last_take: Option<std::path::PathBuf>,
    /// The slider MIDI learn just mapped, until its button is released.
    learn_hold: Option<String>,
    /// Preview size (pixels of the central panel, scaled).
    preview_size: (u32, u32),
    /// How long the last full-resolution frame took, ms.
    full_frame_ms: f64,
    /// Requests made while interacting (drawn at a reduced size).
    reduced: std::collections::HashSet<u64>,
    /// The node graph of the objects' shapes.
    graph: GraphEditor,
    /// Whether the graph panel is shown.
    show_graph: bool,
    /// The right panel's tab: the playground (false) or the surfaces.
    surfaces_tab: bool,
    /// The surface dialog, when open: its fields and the check of them.
    surface_dialog: Option<(SurfaceForm, Option<Check>)>,
    /// The dialog's preview texture and the candidate text it shows.
    surface_preview: Option<(String, egui::TextureHandle)>,
}

/// A node value being dragged in the graph. The preview shows the scene
/// with that slot read from a hidden parameter (compiled once, when the
/// drag starts), so each new value is a runtime input: no shape is
/// compiled again, and the GPU keeps its pipeline. On release the number
/// is written into the shape text as one edit.
struct SlotDrag {
    node: egui_snarl::NodeId,
    input: usize,
    /// The hidden parameter's name.
    param: String,
    /// The scene with the slot bound to `param`; None when the slot cannot
    /// be a parameter (then the preview waits for the release).
    scene: Option<Scene>,
    /// The value the preview was last asked for.
    value: Option<Value>,
}

/// The frame time a drag aims at, ms.
const INTERACTIVE_MS: f64 = 50.0;

/// The linear scale of the preview while dragging, from the time of the
/// last full frame (at one sample per pixel the time falls with the pixels).
pub fn interactive_scale(full_frame_ms: f64) -> f64 {
    if full_frame_ms <= INTERACTIVE_MS {
        1.0
    } else {
        (INTERACTIVE_MS / full_frame_ms).sqrt().clamp(0.1, 1.0)
    }
}

impl Studio {
    /// Opens the scene of `options` (or a new one) and starts the preview.
    pub fn new(ctx: &egui::Context, options: StudioOptions) -> Studio {
        let mut status = String::new();
        let doc = match &options.scene {
            Some(p) => match Document::open(p) {
                Ok(d) => d,
                Err(e) => {
                    status = format!("could not open {}: {}", p.display(), e.rendered);
                    Document::new_scene()
                }
            },
            None => Document::new_scene(),
        };
        let graph = GraphEditor::of(&doc);
        let wake_ctx = ctx.clone();
        let preview = Preview::start(options.renderer, move || wake_ctx.request_repaint());
        Studio {
            doc,
            preview,
            options,
            texture: None,
            shown: None,
            wanted: 0,
            orbit: None,
            live: None,
            live_vec: None,
            slot_drag: None,
            export: None,
            status,
            dialog: None,
            confirm: None,
            allow_close: false,
            screenshot_asked: false,
            started: Instant::now(),
            preview_rect: egui::Rect::NOTHING,
            timeline: Default::default(),
            curve_drag: None,
            midi: Default::default(),
            last_take: None,
            learn_hold: None,
            preview_size: (0, 0),
            full_frame_ms: 0.0,
            reduced: Default::default(),
            graph,
            show_graph: true,
            surfaces_tab: false,
            surface_dialog: None,
            surface_preview: None,
        }
    }

    /// The document (for tests).
    pub fn document(&self) -> &Document {
        &self.doc
    }

    /// The preview frame on screen, if any (for tests and benchmarks).
    pub fn shown(&self) -> Option<Shown> {
        self.shown
    }

    /// The id of the preview request that answers the document and the
    /// drag in progress as they are now: the preview has caught up when
    /// [`Studio::shown`] answers it.
    pub fn wanted(&self) -> u64 {
        self.wanted
    }

    /// The renderer the user chose for the preview (View ▸ Preview
    /// renderer, `--gpu`, `--cpu`).
    pub fn renderer_choice(&self) -> PreviewChoice {
        self.options.renderer
    }

    /// Which renderer draws the preview (None until it has started).
    pub fn backend(&self) -> Option<crate::preview::Backend> {
        self.preview.backend()
    }

    /// The preview panel's rectangle on screen, in points (for tests and
    /// benchmarks that drag in it).
    pub fn preview_rect(&self) -> egui::Rect {
        self.preview_rect
    }

    /// The graph panel's state (for tests).
    pub fn graph(&self) -> &GraphEditor {
        &self.graph
    }

    /// The scene the preview should show: the document's, with the drag in
    /// progress (camera, slider or node value) and the preview's size.
    pub fn preview_scene(&self) -> Scene {
        let bound = self.slot_drag.as_ref().and_then(|d| Some((d, d.scene.as_ref()?)));
        let mut scene = match bound {
            Some((d, scene)) => {
                let mut scene = scene.clone();
                if let Some(v) = d.value {
                    let _ = scene.set_param(&d.param, v);
                }
                scene
            }
            None => self.doc.scene().clone(),
        };
        // The timeline's time: tracks, bones and expressions of t move,
        // nothing is compiled.
        if scene.animation.is_some() && scene.time().to_bits() != self.timeline.time.to_bits() {
            let _ = scene.set_time(self.timeline.time);
        }
        // Live MIDI values (runtime inputs, like the time).
        self.midi.apply(&mut scene);
        if let Some(o) = &self.orbit {
            o.apply(&mut scene.camera);
        }
        if let Some((key, v)) = &self.live {
            // A parameter is a runtime input; any other numeric key (a
            // light's intensity or size, the camera's fov) is a value of
            // the scene: neither rebuilds anything.
            match key.strip_prefix("params.") {
                Some(name) => {
                    let _ = scene.set_param(name, Value::Float(*v));
                }
                None => {
                    let _ = scene.set_value(key, &[*v]);
                }
            }
        }
        if let Some((key, v)) = &self.live_vec {
            let _ = scene.set_value(key, v);
        }
        let (w, h) = self.preview_size;
        if w > 0 && h > 0 {
            // While the user drags, frames must keep up: one sample per
            // pixel, and fewer pixels when the last full frame was slow.
            let scale = if self.interacting() {
                let samples = (scene.render.aa * scene.render.aa) as f64;
                scene.render.aa = 1;
                interactive_scale(self.full_frame_ms / samples)
            } else {
                1.0
            };
            scene.render.width = ((w as f64 * scale).round() as u32).max(8);
            scene.render.height = ((h as f64 * scale).round() as u32).max(8);
        }
        scene
    }

    /// True while a drag (camera or slider) is in progress.
    fn interacting(&self) -> bool {
        self.orbit.is_some()
            || self.live.is_some()
            || self.live_vec.is_some()
            || self.slot_drag.is_some()
            || self.timeline.playing
            || self.timeline.scrubbing
    }

    /// Follows a drag of a node's value (`dragging`: the slot dragged this
    /// frame, if any): binds the slot to a hidden parameter when the drag
    /// starts, asks for a frame when the value moves, and lets go when the
    /// drag ends.
    fn follow_slot_drag(&mut self, dragging: Option<(egui_snarl::NodeId, usize)>) {
        let Some((node, input)) = dragging else {
            if self.slot_drag.take().is_some() {
                self.request_preview();
            }
            return;
        };
        if self.slot_drag.as_ref().map(|d| (d.node, d.input)) != Some((node, input)) {
            self.slot_drag = Some(self.bind_slot(node, input));
        }
        let value = self.graph.slot_value(node, input);
        let d = self.slot_drag.as_mut().expect("bound above");
        if d.scene.is_some() && d.value != value {
            d.value = value;
            self.request_preview();
        }
    }

    /// The scene with slot `input` of `node` read from a new hidden
    /// parameter holding its value.
    fn bind_slot(&mut self, node: egui_snarl::NodeId, input: usize) -> SlotDrag {
        let names = &self.graph.names;
        let param = (0..)
            .map(|i| {
                if i == 0 {
                    "studio_drag".to_string()
                } else {
                    format!("studio_drag{i}")
                }
            })
            .find(|n| !names.params.contains(n) && !names.surfaces.contains_key(n))
            .expect("a free name");
        let value = self.graph.slot_value(node, input);
        let shapes = self.graph.shapes_with_slot(node, input, &param);
        let scene = value.filter(|_| !shapes.is_empty()).and_then(|v| {
            let mut overrides: Vec<String> = shapes
                .iter()
                .map(|(i, text)| crate::graph::shape_edit(*i, text))
                .collect();
            overrides.push(format!("params.{param}={}", v.toml_text()));
            self.doc.variant(&overrides).ok()
        });
        SlotDrag {
            node,
            input,
            param,
            scene,
            value: None,
        }
    }

    fn request_preview(&mut self) {
        let scene = self.preview_scene();
        self.wanted = self.preview.request(scene);
        if self.interacting() {
            self.reduced.insert(self.wanted);
        }
    }

    /// Applies edits as one undo step; an error goes to the status line.
    fn edit(&mut self, edits: Vec<String>) {
        let r = self.doc.apply(&edits);
        self.done(r);
    }

    /// After a document edit: its error to the status line, a new preview.
    fn done(&mut self, result: Result<(), isoray_scene::SceneError>) {
        match result {
            Ok(()) => self.status.clear(),
            Err(e) => self.status = e.rendered,
        }
        self.request_preview();
    }

    fn undo(&mut self) {
        if self.doc.undo() {
            self.request_preview();
        }
    }

    fn redo(&mut self) {
        if self.doc.redo() {
            self.request_preview();
        }
    }

    fn save(&mut self) {
        if self.doc.path().is_none() {
            self.dialog = Some(FileDialog::SaveAs("scene.toml".into()));
            return;
        }
        match self.doc.save() {
            Ok(p) => self.status = format!("saved {}", p.display()),
            Err(e) => self.status = e.rendered,
        }
    }

    fn title(&self) -> String {
        let mark = if self.doc.is_modified() { "● " } else { "" };
        format!("{mark}{} — isoray studio", self.doc.title())
    }

    fn menu_bar(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("New").clicked() {
                    self.ask(Pending::New, ui.ctx());
                }
                if ui.button("Open…").clicked() {
                    self.dialog = Some(FileDialog::Open(String::new()));
                }
                if ui.button("Save  (Ctrl+S)").clicked() {
                    self.save();
                }
                if ui.button("Save as…").clicked() {
                    let name = self.doc.path().map_or("scene.toml".into(), |p| p.display().to_string());
                    self.dialog = Some(FileDialog::SaveAs(name));
                }
                if ui
                    .add_enabled(self.export.is_none(), egui::Button::new("Export…"))
                    .on_hover_text("the final image (.png, .exr) through the CPU renderer, or the objects as a mesh (.stl, .obj, .ply, .glb)")
                    .clicked()
                {
                    let stem = self
                        .doc
                        .path()
                        .map_or("scene".into(), |p| p.with_extension("").display().to_string());
                    self.dialog = Some(FileDialog::Export(format!("{stem}.png")));
                }
                ui.separator();
                if ui.button("Quit").clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("View", |ui| {
                ui.checkbox(&mut self.show_graph, "Graph");
                ui.checkbox(&mut self.graph.thumbs.enabled, "Node thumbnails");
                ui.separator();
                ui.label("Preview renderer");
                let now = self.preview.choice();
                for c in [PreviewChoice::Auto, PreviewChoice::Gpu, PreviewChoice::Cpu] {
                    if ui.radio(now == c, c.label()).clicked() && now != c {
                        self.choose_renderer(c);
                    }
                }
            });
            self.midi_menu(ui);
            ui.menu_button("Edit", |ui| {
                if ui
                    .add_enabled(self.doc.can_undo(), egui::Button::new("Undo  (Ctrl+Z)"))
                    .clicked()
                {
                    self.undo();
                }
                if ui
                    .add_enabled(self.doc.can_redo(), egui::Button::new("Redo  (Ctrl+Shift+Z)"))
                    .clicked()
                {
                    self.redo();
                }
            });
        });
    }

    /// Switches the preview's renderer and draws the scene again with it.
    pub fn choose_renderer(&mut self, choice: PreviewChoice) {
        self.options.renderer = choice;
        self.preview.choose(choice);
        self.request_preview();
    }

    /// Runs `what` now, or first asks about unsaved changes.
    fn ask(&mut self, what: Pending, ctx: &egui::Context) {
        if self.doc.is_modified() {
            self.confirm = Some(what);
        } else {
            self.proceed(what, ctx);
        }
    }

    fn proceed(&mut self, what: Pending, ctx: &egui::Context) {
        match what {
            Pending::Close => {
                self.allow_close = true;
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
            Pending::New => {
                self.doc = Document::new_scene();
                self.request_preview();
            }
        }
    }

    /// The graph panel: a toolbar, then the node editor.
    fn graph_panel(&mut self, ui: &mut egui::Ui) {
        self.graph.sync(&self.doc);
        ui.horizontal(|ui| {
            ui.strong("Graph");
            if ui
                .button("Add object")
                .on_hover_text("a new [[object]]: a sphere, with the material of the last object")
                .clicked()
            {
                // The material of the last object, as a new object most
                // often goes with the ones before it.
                let scene = self.doc.scene();
                let material = scene
                    .objects
                    .last()
                    .and_then(|o| scene.materials.get(o.material))
                    .filter(|m| m.name != "default")
                    .map(|m| format!("\"{}\"", m.name));
                let mut entries = vec![("shape", "\"sphere(p, 0.5)\"")];
                if let Some(m) = &material {
                    entries.push(("material", m.as_str()));
                }
                let r = self.doc.push_table("object", &entries);
                self.done(r);
                self.graph.sync(&self.doc);
            }
            ui.label(
                egui::RichText::new("right-click: add a node · drag pins: connect · + on an input: connect it")
                    .weak()
                    .small(),
            );
        });
        let scene_text = self.doc.text().to_string();
        let scene_name = self
            .doc
            .path()
            .map_or("untitled.toml".to_string(), |p| p.display().to_string());
        let crate::graph::GraphEditor {
            snarl,
            names,
            errors,
            search,
            thumbs,
            ..
        } = &mut self.graph;
        let mut viewer = crate::graph::view::Viewer {
            names,
            errors,
            thumbs,
            scene_text: &scene_text,
            scene_name: &scene_name,
            search,
            changed: false,
            dragging: None,
        };
        let style = egui_snarl::ui::SnarlStyle {
            collapsible: Some(true),
            ..egui_snarl::ui::SnarlStyle::new()
        };
        egui_snarl::ui::SnarlWidget::new()
            .id(egui::Id::new("isoray-graph"))
            .style(style)
            .show(snarl, &mut viewer, ui);
        let released = ui.input(|i| i.pointer.any_released());
        let (changed, dragging) = (viewer.changed, viewer.dragging);
        if changed || (released && self.graph.layout_changed()) {
            self.slot_drag = None;
            let r = self.graph.commit(&mut self.doc).map(|_| ());
            self.done(r);
        } else {
            self.follow_slot_drag(dragging);
        }
    }

    /// The table of `[surface.*]` entries: name, type, parameters, input;
    /// Edit, Delete and New.
    fn surfaces_table(&mut self, ui: &mut egui::Ui) {
        let rows = crate::surfaces::rows(self.doc.text());
        if ui.button("New surface").clicked() {
            self.surface_dialog = Some((SurfaceForm::new(&rows), None));
        }
        if rows.is_empty() {
            ui.label("The scene has no [surface.NAME] tables.");
        }
        let mut delete = None;
        egui::ScrollArea::vertical().show(ui, |ui| {
            egui::Grid::new("surfaces").striped(true).show(ui, |ui| {
                for h in ["name", "type", "parameters", ""] {
                    ui.strong(h);
                }
                ui.end_row();
                for r in &rows {
                    ui.label(&r.name).on_hover_text(&r.input);
                    ui.label(match r.mode {
                        Mode::Sdf => "SDF",
                        Mode::Implicit => "implicit",
                        Mode::Parametric => "parametric",
                    });
                    ui.label(r.params.join(", "));
                    ui.horizontal(|ui| {
                        if ui.small_button("Edit").clicked() {
                            self.surface_dialog = Some((r.form.clone(), None));
                        }
                        if ui.small_button("Delete").clicked() {
                            delete = Some(r.name.clone());
                        }
                    });
                    ui.end_row();
                }
            });
        });
        if let Some(name) = delete {
            let r = self.doc.edit_with(&[], |toml| {
                if let Some(s) = toml.get_mut("surface").and_then(|s| s.as_table_mut()) {
                    s.remove(&name);
                }
            });
            self.done(r);
        }
    }

    /// The surface dialog: each field with its error under it, checked on
    /// a background thread as you type; Save when the surface is valid.
    fn surface_window(&mut self, ctx: &egui::Context) {
        let Some((mut form, mut check)) = self.surface_dialog.take() else {
            return;
        };
        let mut open = true;
        let mut save = None;
        let prepared = candidate(self.doc.text(), &form);
        // A new candidate: cancel the old check, start one on this text.
        if let Ok(text) = &prepared {
            if check.as_ref().is_none_or(|c| &c.text != text) {
                if let Some(c) = &check {
                    c.cancel();
                }
                let file = self
                    .doc
                    .path()
                    .map_or("untitled.toml".to_string(), |p| p.display().to_string());
                let wake = ctx.clone();
                check = Some(Check::start(
                    text.clone(),
                    file,
                    form.name.trim().to_string(),
                    Some(self.doc.analyses()),
                    move || wake.request_repaint(),
                ));
            }
        }
        let status = check.as_ref().map(|c| c.status()).unwrap_or_default();
        let (progress, outcome) = (status.progress, status.outcome.clone());
        let preview = match (&check, &status.preview) {
            (Some(c), Some(rgba)) => {
                if self.surface_preview.as_ref().is_none_or(|(t, _)| t != &c.text) {
                    let [w, h] = crate::surfaces::PREVIEW;
                    let image = egui::ColorImage::from_rgba_unmultiplied([w as usize, h as usize], rgba);
                    let tex = ctx.load_texture("surface preview", image, egui::TextureOptions::LINEAR);
                    self.surface_preview = Some((c.text.clone(), tex));
                }
                self.surface_preview.as_ref().map(|(_, t)| t.clone())
            }
            _ => None,
        };
        let renames = form
            .original
            .as_deref()
            .filter(|o| *o != form.name.trim())
            .map_or(0, |o| crate::surfaces::calls_of(self.doc.text(), o));
        let error: Option<FieldError> = match (&prepared, &outcome) {
            (Err(e), _) => Some(e.clone()),
            (Ok(_), Some(Outcome::Invalid(e))) => Some(e.clone()),
            _ => None,
        };
        let at = |f: Field, ui: &mut egui::Ui| {
            if let Some(e) = error.as_ref().filter(|e| e.field == f) {
                ui.colored_label(egui::Color32::from_rgb(0xe0, 0x60, 0x50), &e.message);
            }
        };
        let title = form
            .original
            .clone()
            .map_or("New surface".to_string(), |n| format!("Surface {n}"));
        egui::Window::new(title)
            .open(&mut open)
            .collapsible(false)
            .show(ctx, |ui| {
                ui.horizontal(|ui| {
                    ui.label("name");
                    ui.text_edit_singleline(&mut form.name);
                });
                at(Field::Name, ui);
                if renames > 0 {
                    ui.weak(format!(
                        "saving renames {renames} call{} in the objects and surfaces",
                        if renames == 1 { "" } else { "s" }
                    ));
                }
                ui.horizontal(|ui| {
                    ui.selectable_value(&mut form.mode, Mode::Sdf, "SDF");
                    ui.selectable_value(&mut form.mode, Mode::Implicit, "Implicit");
                    ui.selectable_value(&mut form.mode, Mode::Parametric, "Parametric");
                });
                match form.mode {
                    Mode::Sdf | Mode::Implicit => {
                        ui.label(if form.mode == Mode::Sdf {
                            "distance (shape text in p and the parameters)"
                        } else {
                            "equation f = 0 in x, y, z and the parameters"
                        });
                        ui.add(egui::TextEdit::multiline(&mut form.body).code_editor().desired_rows(3));
                        at(Field::Body, ui);
                    }
                    Mode::Parametric => {
                        for (i, c) in ["x", "y", "z"].iter().enumerate() {
                            ui.horizontal(|ui| {
                                ui.label(format!("{c}(s, t)"));
                                ui.text_edit_singleline(&mut form.coords[i]);
                            });
                            at(Field::Coord(i), ui);
                        }
                    }
                }
                params_grid(ui, &mut form.params, error.as_ref());
                at(Field::Params, ui);
                if form.mode == Mode::Parametric {
                    for (i, v) in ["s", "t"].iter().enumerate() {
                        ui.horizontal(|ui| {
                            ui.label(format!("domain of {v}"));
                            for (j, hint) in ["-1.0", "1.0"].iter().enumerate() {
                                ui.add(
                                    egui::TextEdit::singleline(&mut form.domain[i][j])
                                        .hint_text(*hint)
                                        .desired_width(56.0),
                                );
                            }
                        });
                        at(Field::Domain(i), ui);
                    }
                    ui.checkbox(&mut form.image_only, "image only")
                        .on_hover_text("keep only the points with a real preimage in the domain");
                    at(Field::ImageOnly, ui);
                }
                if form.mode != Mode::Sdf {
                    egui::ComboBox::from_label("bound")
                        .selected_text(if form.bound.is_empty() {
                            "auto"
                        } else {
                            form.bound.as_str()
                        })
                        .show_ui(ui, |ui| {
                            for b in ["", "taylor", "lipschitz", "first-order"] {
                                ui.selectable_value(
                                    &mut form.bound,
                                    b.to_string(),
                                    if b.is_empty() { "auto" } else { b },
                                );
                            }
                        });
                    at(Field::Bound, ui);
                    ui.horizontal(|ui| {
                        ui.label("lipschitz factor");
                        ui.add(
                            egui::TextEdit::singleline(&mut form.lipschitz_factor)
                                .hint_text("1.0")
                                .desired_width(56.0),
                        )
                        .on_hover_text("the traced distance is divided by it (≥ 1)");
                    });
                    at(Field::LipschitzFactor, ui);
                }
                at(Field::Other, ui);
                ui.separator();
                match &outcome {
                    None if prepared.is_ok() => {
                        ui.horizontal(|ui| {
                            ui.spinner();
                            ui.add(egui::ProgressBar::new(progress as f32).desired_width(160.0));
                            if ui.button("Cancel").clicked() {
                                if let Some(c) = &check {
                                    c.cancel();
                                }
                            }
                        });
                    }
                    Some(Outcome::Valid(d)) => {
                        ui.label(egui::RichText::new(d).monospace().small());
                        match &preview {
                            Some(tex) => {
                                let [w, h] = crate::surfaces::PREVIEW;
                                ui.image((tex.id(), egui::vec2(w as f32, h as f32)))
                                    .on_hover_text("the surface alone, through the scene's camera and lights");
                            }
                            None if !status.finished => {
                                ui.horizontal(|ui| {
                                    ui.spinner();
                                    ui.label("rendering the surface…");
                                });
                            }
                            None => {}
                        }
                    }
                    Some(Outcome::Cancelled) => {
                        ui.label("check cancelled: edit a field to check again");
                    }
                    _ => {}
                }
                let valid = matches!(outcome, Some(Outcome::Valid(_))) && prepared.is_ok();
                if ui.add_enabled(valid, egui::Button::new("Save")).clicked() {
                    save = prepared.clone().ok();
                }
            });
        if let Some(text) = save {
            let r = self.doc.replace_text(text);
            self.done(r);
            return;
        }
        if open {
            self.surface_dialog = Some((form, check));
        } else if let Some(c) = &check {
            c.cancel();
        }
    }

    /// The preview: the latest frame, scaled to the panel; drag to orbit,
    /// right- or middle-drag (or Shift-drag) to pan, scroll to zoom; with
    /// the preview clicked or hovered, the arrow keys orbit (Shift: pan)
    /// and + / − zoom. The camera is written to the file on release.
    fn preview_panel(&mut self, ui: &mut egui::Ui) {
        let avail = ui.available_size();
        let ppp = ui.ctx().pixels_per_point();
        let size = ((avail.x * ppp).max(16.0) as u32, (avail.y * ppp).max(16.0) as u32);
        if size != self.preview_size {
            self.preview_size = size;
            self.request_preview();
        }
        if let Some(f) = self.preview.take_frame() {
            self.show(ui.ctx(), f);
        }
        let (rect, response) = ui.allocate_exact_size(avail, egui::Sense::click_and_drag());
        self.preview_rect = rect;
        if let Some(t) = &self.texture {
            ui.painter().image(
                t.id(),
                rect,
                egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
                egui::Color32::WHITE,
            );
        }
        if response.clicked() || response.drag_started() {
            // Keys navigate the preview once it has been clicked.
            response.request_focus();
        }
        if response.has_focus() {
            // The arrows are ours, not egui's focus moves.
            let filter = egui::EventFilter {
                horizontal_arrows: true,
                vertical_arrows: true,
                ..Default::default()
            };
            ui.memory_mut(|m| m.set_focus_lock_filter(response.id, filter));
        }
        let scroll = if response.hovered() {
            ui.input(|i| i.smooth_scroll_delta.y)
        } else {
            0.0
        };
        let keys = if response.has_focus() || (response.hovered() && !ui.ctx().egui_wants_keyboard_input()) {
            ui.input(NavKeys::read)
        } else {
            NavKeys::default()
        };
        let d = response.drag_delta();
        let moved = d != egui::Vec2::ZERO || scroll != 0.0 || keys.any();
        if moved {
            let o = self.orbit.get_or_insert_with(|| Orbit::of(&self.doc.scene().camera));
            // Primary drag orbits; the secondary or middle button, or Shift
            // with the primary, pans; the wheel zooms. Arrow keys orbit
            // (with Shift they pan), + and − (or Page Up/Down) zoom.
            let panning = response.dragged_by(egui::PointerButton::Secondary)
                || response.dragged_by(egui::PointerButton::Middle)
                || ui.input(|i| i.modifiers.shift);
            let h = rect.height().max(1.0) as f64;
            if panning {
                o.pan(-d.x as f64 / h, d.y as f64 / h);
            } else {
                o.rotate(-d.x as f64 * 0.01, d.y as f64 * 0.01);
            }
            o.zoom((-scroll as f64 * 0.002).exp());
            keys.apply(o);
            // A pointer held still asks for nothing new (a request would
            // cancel the frame being drawn for the same camera).
            self.request_preview();
        }
        if keys.held {
            ui.ctx().request_repaint();
        }
        let navigating = response.dragged() || keys.held;
        if !navigating && self.orbit.is_some() {
            let o = self.orbit.take().expect("orbiting");
            let was = &self.doc.scene().camera;
            let mut edits = vec![];
            if o.target != was.target {
                edits.push(playground::vec3_edit("camera.target", o.target));
            }
            edits.push(playground::vec3_edit("camera.position", o.position()));
            self.edit(edits);
        }
    }

    fn show(&mut self, ctx: &egui::Context, f: Frame) {
        let img = egui::ColorImage::from_rgba_unmultiplied([f.width as usize, f.height as usize], &f.rgba);
        match &mut self.texture {
            Some(t) => t.set(img, egui::TextureOptions::LINEAR),
            None => self.texture = Some(ctx.load_texture("preview", img, egui::TextureOptions::LINEAR)),
        }
        if f.done && !self.reduced.remove(&f.id) {
            self.full_frame_ms = f.ms;
        }
        self.shown = Some(Shown {
            id: f.id,
            done: f.done,
            ms: f.ms,
            width: f.width,
            height: f.height,
            at: Instant::now(),
        });
    }

    fn status_bar(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            if let Some(b) = self.preview.backend() {
                ui.label(b.describe());
            }
            if let Some(Shown { id, done, ms, .. }) = self.shown {
                let state = if id != self.wanted || self.preview.busy() {
                    "rendering…"
                } else if done {
                    "done"
                } else {
                    "refining…"
                };
                ui.label(format!("frame {ms:.0} ms, {state}"));
            }
            if let Some(e) = self.preview.error() {
                ui.colored_label(egui::Color32::RED, e);
            }
            self.midi_status(ui);
            if let Some(x) = &self.export {
                match x.end() {
                    Some(end) => {
                        self.status = match end {
                            crate::export::ExportEnd::Done(s) => s,
                            crate::export::ExportEnd::Cancelled => format!("export of {} cancelled", x.path.display()),
                            crate::export::ExportEnd::Failed(e) => format!("export failed: {e}"),
                        };
                        self.export = None;
                    }
                    None => {
                        let (f, stage) = x.progress();
                        ui.add(
                            egui::ProgressBar::new(f)
                                .desired_width(160.0)
                                .text(format!("export: {stage}")),
                        );
                        if ui.button("Cancel export").clicked() {
                            x.cancel();
                        }
                        ui.ctx().request_repaint_after(std::time::Duration::from_millis(100));
                    }
                }
            }
            if !self.status.is_empty() {
                ui.label(&self.status);
            }
        });
    }

    fn dialogs(&mut self, ctx: &egui::Context) {
        if let Some(d) = self.dialog.clone() {
            let (title, mut path) = match &d {
                FileDialog::Open(p) => ("Open scene", p.clone()),
                FileDialog::SaveAs(p) => ("Save scene as", p.clone()),
                FileDialog::Export(p) => ("Export", p.clone()),
            };
            let mut close = false;
            let mut go = false;
            egui::Window::new(title).collapsible(false).show(ctx, |ui| {
                ui.label(if matches!(d, FileDialog::Export(_)) {
                    "Path of the file: .png or .exr (the image, CPU renderer), .stl, .obj, .ply or .glb (a mesh of the bounded objects):"
                } else {
                    "Path of the scene file:"
                });
                let r = ui.text_edit_singleline(&mut path);
                if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                    go = true;
                }
                ui.horizontal(|ui| {
                    go |= ui.button("OK").clicked();
                    close |= ui.button("Cancel").clicked();
                });
            });
            self.dialog = Some(match d {
                FileDialog::Open(_) => FileDialog::Open(path.clone()),
                FileDialog::SaveAs(_) => FileDialog::SaveAs(path.clone()),
                FileDialog::Export(_) => FileDialog::Export(path.clone()),
            });
            if go {
                let p = PathBuf::from(&path);
                match d {
                    FileDialog::Open(_) => match Document::open(&p) {
                        Ok(doc) => {
                            self.doc = doc;
                            self.status = format!("opened {}", p.display());
                            self.request_preview();
                            close = true;
                        }
                        Err(e) => self.status = e.rendered,
                    },
                    FileDialog::SaveAs(_) => match self.doc.save_as(&p) {
                        Ok(p) => {
                            self.status = format!("saved {}", p.display());
                            close = true;
                        }
                        Err(e) => self.status = e.rendered,
                    },
                    FileDialog::Export(_) => match crate::export::Export::start(self.doc.scene().clone(), p) {
                        Ok(x) => {
                            self.export = Some(x);
                            close = true;
                        }
                        Err(e) => self.status = e,
                    },
                }
            }
            if close {
                self.dialog = None;
            }
        }
        if let Some(what) = self.confirm {
            egui::Window::new("Unsaved changes").collapsible(false).show(ctx, |ui| {
                ui.label(format!("{} has changes that are not saved.", self.doc.title()));
                ui.horizontal(|ui| {
                    if ui.button("Save").clicked() {
                        self.save();
                        self.confirm = None;
                        if !self.doc.is_modified() {
                            self.proceed(what, ctx);
                        }
                    }
                    if ui.button("Discard").clicked() {
                        self.confirm = None;
                        self.proceed(what, ctx);
                    }
                    if ui.button("Cancel").clicked() {
                        self.confirm = None;
                    }
                });
            });
        }
    }

    fn shortcuts(&mut self, ctx: &egui::Context) {
        let (undo, redo, save) = ctx.input_mut(|i| {
            let redo = i.consume_key(egui::Modifiers::COMMAND | egui::Modifiers::SHIFT, egui::Key::Z)
                || i.consume_key(egui::Modifiers::COMMAND, egui::Key::Y);
            let undo = i.consume_key(egui::Modifiers::COMMAND, egui::Key::Z);
            let save = i.consume_key(egui::Modifiers::COMMAND, egui::Key::S);
            (undo, redo, save)
        });
        if undo {
            self.undo();
        }
        if redo {
            self.redo();
        }
        if save {
            self.save();
        }
    }

    /// With `--screenshot`: once the preview shows the final frame of the
    /// latest request, asks for a screenshot; writes it when it comes.
    fn screenshot(&mut self, ctx: &egui::Context) {
        let Some(out) = self.options.screenshot.clone() else {
            return;
        };
        let converged = self.shown.is_some_and(|f| f.id == self.wanted && f.done)
            && !self.preview.busy()
            && (!self.show_graph || self.graph.thumbs.pending() == 0);
        let failed = self.preview.error().is_some() || self.started.elapsed().as_secs() > 600;
        if (converged || failed) && !self.screenshot_asked {
            self.screenshot_asked = true;
            ctx.send_viewport_cmd(egui::ViewportCommand::Screenshot(Default::default()));
        }
        let shot = ctx.input(|i| {
            i.events.iter().find_map(|e| match e {
                egui::Event::Screenshot { image, .. } => Some(image.clone()),
                _ => None,
            })
        });
        if let Some(img) = shot {
            match crate::write_screenshot(&out, &img) {
                Ok(()) => eprintln!("screenshot: {}", out.display()),
                Err(e) => eprintln!("error: could not write the screenshot {}: {e}", out.display()),
            }
            self.allow_close = true;
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }
}

impl eframe::App for Studio {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.frame_ui(ui, &ctx);
    }
}

impl Studio {
    /// One pass of the whole window (the eframe app's `ui`, and tests).
    pub fn frame_ui(&mut self, ui: &mut egui::Ui, ctx: &egui::Context) {
        if self.wanted == 0 && self.preview_size != (0, 0) {
            self.request_preview();
        }
        self.shortcuts(ctx);
        self.poll_midi(ctx);
        if ctx.input(|i| i.viewport().close_requested()) && !self.allow_close && self.doc.is_modified() {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.confirm = Some(Pending::Close);
        }
        ctx.send_viewport_cmd(egui::ViewportCommand::Title(self.title()));
        egui::Panel::top("menu").show(ui, |ui| self.menu_bar(ui));
        egui::Panel::bottom("status").show(ui, |ui| self.status_bar(ui));
        if self.doc.scene().animation.is_some() {
            egui::Panel::bottom("timeline").show(ui, |ui| self.timeline_panel(ui));
        }
        if self.show_graph {
            egui::Panel::left("graph")
                .default_size(560.0)
                .resizable(true)
                .show(ui, |ui| self.graph_panel(ui));
        }
        egui::Panel::right("playground").default_size(300.0).show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.selectable_value(&mut self.surfaces_tab, false, "Playground");
                ui.selectable_value(&mut self.surfaces_tab, true, "Surfaces");
            });
            ui.separator();
            if self.surfaces_tab {
                self.surfaces_table(ui);
            } else {
                self.playground(ui);
            }
        });
        egui::CentralPanel::default()
            .frame(egui::Frame::NONE)
            .show(ui, |ui| self.preview_panel(ui));
        self.dialogs(ctx);
        self.surface_window(ctx);
        self.screenshot(ctx);
        if self.preview.busy() {
            ctx.request_repaint_after(std::time::Duration::from_millis(50));
        }
    }
}

/// The surface dialog's grid of parameters: symbol, default and slider
/// range per row, in call order (move a row up or down, remove it, add
/// one); a row with an error is marked and the message follows the grid.
fn params_grid(ui: &mut egui::Ui, params: &mut Vec<ParamRow>, error: Option<&FieldError>) {
    ui.label("parameters (in call order, after the point)");
    let mut action = None;
    egui::Grid::new("surface parameters").num_columns(5).show(ui, |ui| {
        for h in ["symbol", "default", "min", "max", ""] {
            ui.weak(h);
        }
        ui.end_row();
        let n = params.len();
        for (i, row) in params.iter_mut().enumerate() {
            let bad = error.is_some_and(|e| e.field == Field::Param(i));
            let edit = |ui: &mut egui::Ui, text: &mut String, hint: &str, width: f32, label: String| {
                let mut t = egui::TextEdit::singleline(text).hint_text(hint).desired_width(width);
                if bad {
                    t = t.text_color(egui::Color32::from_rgb(0xe0, 0x60, 0x50));
                }
                let r = ui.add(t);
                r.widget_info(|| egui::WidgetInfo::labeled(egui::WidgetType::TextEdit, true, &label));
            };
            edit(ui, &mut row.name, "name", 56.0, format!("parameter {} symbol", i + 1));
            edit(
                ui,
                &mut row.default,
                "1.0 or 0, 1, 0",
                96.0,
                format!("parameter {} default", i + 1),
            );
            edit(ui, &mut row.min, "", 48.0, format!("parameter {} min", i + 1));
            edit(ui, &mut row.max, "", 48.0, format!("parameter {} max", i + 1));
            ui.horizontal(|ui| {
                if ui.add_enabled(i > 0, egui::Button::new("up").small()).clicked() {
                    action = Some((i, -1));
                }
                if ui.add_enabled(i + 1 < n, egui::Button::new("down").small()).clicked() {
                    action = Some((i, 1));
                }
                if ui
                    .small_button("remove")
                    .on_hover_text("remove the parameter")
                    .clicked()
                {
                    action = Some((i, 0));
                }
            });
            ui.end_row();
        }
    });
    match action {
        Some((i, 0)) => {
            params.remove(i);
        }
        Some((i, d)) => params.swap(i, (i as isize + d) as usize),
        None => {}
    }
    if ui.small_button("Add parameter").clicked() {
        params.push(ParamRow {
            name: format!("a{}", params.len() + 1),
            default: "1.0".into(),
            ..ParamRow::default()
        });
    }
    if let Some(e) = error.filter(|e| matches!(e.field, Field::Param(_))) {
        ui.colored_label(egui::Color32::from_rgb(0xe0, 0x60, 0x50), &e.message);
    }
}
