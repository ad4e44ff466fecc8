//! Drawing and editing the graph: the egui-snarl viewer.
//!
//! Each node shows its inputs with their names; an input with no wire
//! edits its slot in place (a number as a drag value, `vec3(…)` of numbers
//! as three, anything else as text) and has a `+` menu that connects it to
//! a node of the graph or to a new one from the palette (so every edit can
//! be made without dragging). Right-click on the background opens the
//! palette, searchable by name, with each function's documentation as its
//! tooltip; right-click on a node removes or duplicates it. Variadic
//! booleans grow an input when their last one is connected and close the
//! gap when one is disconnected.

use std::collections::HashMap;

use egui::{Color32, Ui};
use egui_snarl::ui::{AnyPins, PinInfo, SnarlViewer};
use egui_snarl::{InPin, InPinId, NodeId, OutPin, OutPinId, Snarl};
use isoray_shape::library::{signature_text, Category, FUNCTIONS};
use isoray_shape::syntax::{number_text, BinaryOp};

use super::model::{self, is_variadic, preorder, Form, GraphNode, Names};
use super::thumbs::{Thumb, Thumbnails, SIZE};

/// Wire and pin colour of distances.
const DISTANCE: Color32 = Color32::from_rgb(0x4a, 0x9e, 0xe8);
/// Pin colour of an input with no wire and no value.
const MISSING: Color32 = Color32::from_rgb(0xd0, 0x50, 0x40);

/// The viewer of one frame.
pub struct Viewer<'a> {
    /// Parameter and surface names.
    pub names: &'a Names,
    /// Errors per node.
    pub errors: &'a HashMap<NodeId, String>,
    /// Thumbnail cache.
    pub thumbs: &'a mut Thumbnails,
    /// The document text thumbnails are rendered in.
    pub scene_text: &'a str,
    /// The file name it is read as.
    pub scene_name: &'a str,
    /// The palette's search text.
    pub search: &'a mut String,
    /// Set when an edit should be written back to the document.
    pub changed: bool,
    /// The slot (node, input) whose value is being dragged this frame.
    pub dragging: Option<(NodeId, usize)>,
}

/// One palette entry: its label, tooltip and the node it makes.
pub struct Entry {
    /// Shown on the button.
    pub label: String,
    /// Section it is listed under.
    pub section: &'static str,
    /// Tooltip: signature and documentation.
    pub doc: String,
    /// The node created.
    pub node: GraphNode,
}

/// Every node the palette offers for a scene with `names`.
pub fn palette(names: &Names) -> Vec<Entry> {
    let mut out = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for s in FUNCTIONS {
        let section = match s.category {
            Category::Primitive => "Primitives",
            Category::Operator => "Booleans and distance operators",
            Category::Domain => "Transforms, deformations and repetition",
            Category::Builtin => continue,
        };
        if !seen.insert(s.name) {
            continue;
        }
        if let Some(node) = model::new_call(s.name) {
            out.push(Entry {
                label: s.name.to_string(),
                section,
                doc: format!("{}\n{}", signature_text(s), s.doc),
                node,
            });
        }
    }
    let mut surfaces: Vec<_> = names.surfaces.iter().collect();
    surfaces.sort();
    for (name, params) in surfaces {
        out.push(Entry {
            label: name.clone(),
            section: "User surfaces",
            doc: format!(
                "the scene's [surface.{name}]: {name}(p{})",
                params.iter().map(|p| format!(", {p}")).collect::<String>()
            ),
            node: model::new_surface_call(name, params.len()),
        });
    }
    for name in &names.params {
        out.push(Entry {
            label: name.clone(),
            section: "Parameters",
            doc: format!("the scene parameter `{name}` ([params]); its slider is in the Playground"),
            node: GraphNode::Param { name: name.clone() },
        });
    }
    for (op, doc) in [
        (
            BinaryOp::Add,
            "a + b: adds a distance term (a displacement) or moves a point",
        ),
        (BinaryOp::Sub, "a - b: p - vec3(…) moves a shape"),
        (BinaryOp::Mul, "a * b: scales (shape(p / s) * s is a uniform scale)"),
        (BinaryOp::Div, "a / b"),
    ] {
        out.push(Entry {
            label: format!("a {} b", op.symbol()),
            section: "Arithmetic",
            doc: doc.into(),
            node: GraphNode::Op {
                form: Form::Binary(op),
                slots: vec![String::new(), String::new()],
            },
        });
    }
    out.push(Entry {
        label: "code".into(),
        section: "Code",
        doc: "free-form shape text: any expression of p and the parameters".into(),
        node: GraphNode::Code {
            text: "length(p) - 1.0".into(),
        },
    });
    out
}

/// The palette's entries whose label contains `search` (any case).
pub fn matching<'e>(entries: &'e [Entry], search: &str) -> Vec<&'e Entry> {
    let s = search.trim().to_lowercase();
    entries
        .iter()
        .filter(|e| s.is_empty() || e.label.to_lowercase().contains(&s))
        .collect()
}

impl Viewer<'_> {
    /// Shows the palette; returns the node picked.
    fn pick(&mut self, ui: &mut Ui) -> Option<GraphNode> {
        let entries = palette(self.names);
        let r = ui.add(
            egui::TextEdit::singleline(self.search)
                .hint_text("search nodes")
                .desired_width(180.0),
        );
        name_widget(&r, egui::WidgetType::TextEdit, "search nodes");
        r.request_focus();
        let found = matching(&entries, self.search);
        let mut picked = None;
        egui::ScrollArea::vertical().max_height(360.0).show(ui, |ui| {
            let mut section = "";
            for e in &found {
                if e.section != section {
                    section = e.section;
                    ui.label(egui::RichText::new(section).small().weak());
                }
                if ui.button(&e.label).on_hover_text(&e.doc).clicked() {
                    picked = Some(e.node.clone());
                }
            }
            if found.is_empty() {
                ui.label("no node by that name");
            }
        });
        // Enter takes the first match.
        if picked.is_none() && r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
            picked = found.first().map(|e| e.node.clone());
        }
        if picked.is_some() {
            self.search.clear();
            ui.close();
        }
        picked
    }

    /// The menu of an input with no wire: connect it to a node of the
    /// graph, or to a new node.
    fn connect_menu(&mut self, ui: &mut Ui, to: InPinId, snarl: &mut Snarl<GraphNode>) {
        let upstream_of_target: Vec<NodeId> = snarl
            .node_ids()
            .map(|(id, _)| id)
            .filter(|&id| id != to.node && snarl[id].outputs() > 0 && !preorder(snarl, id).contains(&to.node))
            .collect();
        ui.menu_button("new node", |ui| {
            if let Some(node) = self.pick(ui) {
                let pos = snarl.get_node_info(to.node).map_or(egui::Pos2::ZERO, |n| n.pos)
                    + egui::vec2(-model::LAYOUT_STEP.0, 90.0 * to.input as f32);
                let id = snarl.insert_node(pos, node);
                self.attach(OutPinId { node: id, output: 0 }, to, snarl);
            }
        });
        if !snarl.in_pin(to).remotes.is_empty() && ui.button("disconnect").clicked() {
            snarl.drop_inputs(to);
            compact(snarl, to.node, to.input);
            self.changed = true;
            ui.close();
        }
        if !upstream_of_target.is_empty() {
            ui.separator();
            ui.label(egui::RichText::new("connect").small().weak());
        }
        for id in upstream_of_target {
            let label = format!("{} #{}", snarl[id].title(), id.0);
            if ui.button(label).clicked() {
                self.attach(OutPinId { node: id, output: 0 }, to, snarl);
                ui.close();
            }
        }
    }

    /// Connects `from` to `to`: replaces `to`'s wire, grows a variadic
    /// node, refuses a cycle.
    fn attach(&mut self, from: OutPinId, to: InPinId, snarl: &mut Snarl<GraphNode>) -> bool {
        if from.node == to.node || preorder(snarl, from.node).contains(&to.node) {
            return false;
        }
        snarl.drop_inputs(to);
        if let GraphNode::Op { form, slots } = &mut snarl[to.node] {
            if is_variadic(form) && to.input == slots.len() {
                slots.push(String::new());
            }
        }
        snarl.connect(from, to);
        self.changed = true;
        true
    }
}

/// After input `input` of `node` lost its wire: a variadic node with more
/// than two inputs drops that input, and the later inputs move up one.
pub fn compact(snarl: &mut Snarl<GraphNode>, node: NodeId, input: usize) {
    let GraphNode::Op { form, slots } = &snarl[node] else {
        return;
    };
    if !is_variadic(form) || slots.len() <= 2 || input >= slots.len() || !slots[input].trim().is_empty() {
        return;
    }
    let n = slots.len();
    for j in input + 1..n {
        let pin = InPinId { node, input: j };
        let remotes = snarl.in_pin(pin).remotes;
        snarl.drop_inputs(pin);
        for r in remotes {
            snarl.connect(r, InPinId { node, input: j - 1 });
        }
    }
    if let GraphNode::Op { slots, .. } = &mut snarl[node] {
        slots.remove(input);
    }
}

/// Names a widget for screen readers (and UI tests) apart from what it
/// shows: the node's title and number, and the input.
fn name_widget(r: &egui::Response, kind: egui::WidgetType, name: &str) {
    r.widget_info(|| egui::WidgetInfo::labeled(kind, true, name));
}

/// What a slot editor did this frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SlotEdit {
    /// The edit is finished (a drag released, a field left): write it back.
    pub done: bool,
    /// A value is being dragged (the text holds the value so far).
    pub dragging: bool,
}

/// Edits a slot's text in place. `name` is the accessible name of the
/// widgets (`NAME`, or `NAME.x`… for a vector).
pub fn slot_editor(ui: &mut Ui, text: &mut String, name: &str) -> SlotEdit {
    let trimmed = text.trim().to_string();
    let finished = |r: &egui::Response| {
        r.drag_stopped() || (r.lost_focus() && !r.dragged()) || (r.changed() && !r.dragged() && !r.has_focus())
    };
    if let Ok(mut v) = trimmed.parse::<f64>() {
        let r = ui.add(egui::DragValue::new(&mut v).speed(0.01).max_decimals(4));
        name_widget(&r, egui::WidgetType::DragValue, name);
        if r.changed() {
            *text = number_text(v);
        }
        return SlotEdit {
            done: finished(&r),
            dragging: r.dragged() && !r.drag_stopped(),
        };
    }
    if let Some(mut vs) = numeric_vec(&trimmed) {
        let mut edit = SlotEdit::default();
        let mut changed = false;
        for (v, c) in vs.iter_mut().zip(["x", "y", "z"]) {
            let r = ui.add(egui::DragValue::new(v).speed(0.01).max_decimals(4));
            name_widget(&r, egui::WidgetType::DragValue, &format!("{name}.{c}"));
            changed |= r.changed();
            edit.done |= finished(&r);
            edit.dragging |= r.dragged() && !r.drag_stopped();
        }
        if changed {
            let inner: Vec<String> = vs.iter().map(|v| number_text(*v)).collect();
            *text = format!("vec{}({})", if vs.len() == 2 { 2 } else { 3 }, inner.join(", "));
        }
        return edit;
    }
    let r = ui.add(egui::TextEdit::singleline(text).desired_width(120.0).hint_text("value"));
    name_widget(&r, egui::WidgetType::TextEdit, name);
    SlotEdit {
        done: r.lost_focus(),
        dragging: false,
    }
}

/// The numbers of `vec3(a, b, c)`, `vec3(a)` or `vec2(a, b)` written with
/// numbers only.
pub fn numeric_vec(text: &str) -> Option<Vec<f64>> {
    let p = isoray_shape::syntax::parse(text, 0).ok()?;
    if !p.lets.is_empty() {
        return None;
    }
    let isoray_shape::syntax::ExprKind::Call { name, args, .. } = &p.body.kind else {
        return None;
    };
    if !matches!(name.as_str(), "vec2" | "vec3") {
        return None;
    }
    let vs: Option<Vec<f64>> = args.iter().map(number_of).collect();
    let vs = vs?;
    let ok = match name.as_str() {
        "vec2" => vs.len() == 2,
        _ => vs.len() == 3 || vs.len() == 1,
    };
    ok.then_some(vs)
}

fn number_of(e: &isoray_shape::syntax::Expr) -> Option<f64> {
    use isoray_shape::syntax::ExprKind;
    match &e.kind {
        ExprKind::Num(v) => Some(*v),
        ExprKind::Neg(a) => match &a.kind {
            ExprKind::Num(v) => Some(-v),
            _ => None,
        },
        _ => None,
    }
}

impl SnarlViewer<GraphNode> for Viewer<'_> {
    fn title(&mut self, node: &GraphNode) -> String {
        node.title()
    }

    fn inputs(&mut self, node: &GraphNode) -> usize {
        node.inputs()
    }

    fn outputs(&mut self, node: &GraphNode) -> usize {
        node.outputs()
    }

    fn show_header(&mut self, node: NodeId, _: &[InPin], _: &[OutPin], ui: &mut Ui, snarl: &mut Snarl<GraphNode>) {
        let value = &snarl[node];
        let title = value.title();
        let doc = match value {
            GraphNode::Op {
                form: Form::Call(name),
                slots,
            } => model::signature(name, slots.len()).map(|s| format!("{}\n{}", signature_text(s), s.doc)),
            _ => None,
        };
        let r = ui.label(egui::RichText::new(title).strong());
        if let Some(d) = doc {
            r.on_hover_text(d);
        }
    }

    fn show_input(
        &mut self,
        pin: &InPin,
        ui: &mut Ui,
        snarl: &mut Snarl<GraphNode>,
    ) -> impl egui_snarl::ui::SnarlPin + 'static {
        let id = pin.id;
        let connected = !pin.remotes.is_empty();
        let title = snarl[id.node].title();
        let (label, editable, extra) = match &snarl[id.node] {
            GraphNode::Object { .. } => ("shape".to_string(), false, false),
            GraphNode::Op { form, slots } => {
                let extra = id.input >= slots.len();
                let names = model::slot_names(form, &self.names.surfaces, slots.len());
                let label = if extra {
                    "+".to_string()
                } else {
                    names[id.input].clone()
                };
                (label, !extra, extra)
            }
            _ => (String::new(), false, false),
        };
        ui.label(&label);
        let mut missing = !connected && !editable;
        if !connected && editable {
            if let GraphNode::Op { slots, .. } = &mut snarl[id.node] {
                let edit = slot_editor(ui, &mut slots[id.input], &format!("{title} #{} {label}", id.node.0));
                missing = slots[id.input].trim().is_empty();
                self.changed |= edit.done;
                if edit.dragging {
                    self.dragging = Some((id.node, id.input));
                }
            }
        }
        let r = ui
            .button(if connected { "…" } else { "+" })
            .on_hover_text("connect this input to a new node or to one of the graph");
        name_widget(
            &r,
            egui::WidgetType::Button,
            &format!("{title} #{} input {label}", id.node.0),
        );
        egui::Popup::menu(&r).show(|ui| self.connect_menu(ui, id, snarl));
        if extra {
            missing = false;
        }
        PinInfo::circle().with_fill(if missing { MISSING } else { DISTANCE })
    }

    fn show_output(
        &mut self,
        _pin: &OutPin,
        _ui: &mut Ui,
        _snarl: &mut Snarl<GraphNode>,
    ) -> impl egui_snarl::ui::SnarlPin + 'static {
        PinInfo::circle().with_fill(DISTANCE)
    }

    fn has_body(&mut self, node: &GraphNode) -> bool {
        matches!(node, GraphNode::Code { .. }) || (self.thumbs.enabled && matches!(node, GraphNode::Op { .. }))
    }

    fn show_body(&mut self, node: NodeId, _: &[InPin], _: &[OutPin], ui: &mut Ui, snarl: &mut Snarl<GraphNode>) {
        ui.vertical(|ui| {
            if let GraphNode::Code { text } = &mut snarl[node] {
                let r = ui.add(
                    egui::TextEdit::multiline(text)
                        .code_editor()
                        .desired_rows(2)
                        .desired_width(240.0),
                );
                if r.lost_focus() {
                    self.changed = true;
                }
            }
            if !self.thumbs.enabled {
                return;
            }
            let text = model::node_text(snarl, node, self.names).ok();
            let size = egui::vec2(SIZE[0] as f32, SIZE[1] as f32);
            match text.map(|t| self.thumbs.get(&t, self.scene_text, self.scene_name, ui.ctx())) {
                Some(Thumb::Image(_, Some(tex))) => {
                    ui.image((tex.id(), size));
                }
                Some(Thumb::Pending) => {
                    ui.add_sized(size, egui::Spinner::new());
                }
                _ => {}
            }
        });
    }

    fn has_footer(&mut self, _node: &GraphNode) -> bool {
        true
    }

    fn show_footer(&mut self, node: NodeId, _: &[InPin], _: &[OutPin], ui: &mut Ui, _snarl: &mut Snarl<GraphNode>) {
        if let Some(e) = self.errors.get(&node) {
            ui.set_max_width(240.0);
            ui.colored_label(MISSING, format!("⚠ {e}"));
        }
    }

    fn connect(&mut self, from: &OutPin, to: &InPin, snarl: &mut Snarl<GraphNode>) {
        self.attach(from.id, to.id, snarl);
    }

    fn disconnect(&mut self, from: &OutPin, to: &InPin, snarl: &mut Snarl<GraphNode>) {
        snarl.disconnect(from.id, to.id);
        compact(snarl, to.id.node, to.id.input);
        self.changed = true;
    }

    fn drop_inputs(&mut self, pin: &InPin, snarl: &mut Snarl<GraphNode>) {
        snarl.drop_inputs(pin.id);
        compact(snarl, pin.id.node, pin.id.input);
        self.changed = true;
    }

    fn drop_outputs(&mut self, pin: &OutPin, snarl: &mut Snarl<GraphNode>) {
        let mut remotes = pin.remotes.clone();
        snarl.drop_outputs(pin.id);
        // Later inputs first, so that compaction does not move the others.
        remotes.sort_by_key(|r| std::cmp::Reverse(r.input));
        for r in remotes {
            compact(snarl, r.node, r.input);
        }
        self.changed = true;
    }

    fn has_graph_menu(&mut self, _pos: egui::Pos2, _snarl: &mut Snarl<GraphNode>) -> bool {
        true
    }

    fn show_graph_menu(&mut self, pos: egui::Pos2, ui: &mut Ui, snarl: &mut Snarl<GraphNode>) {
        ui.label("Add a node");
        if let Some(node) = self.pick(ui) {
            snarl.insert_node(pos, node);
        }
    }

    fn has_dropped_wire_menu(&mut self, _src: AnyPins, _snarl: &mut Snarl<GraphNode>) -> bool {
        true
    }

    fn show_dropped_wire_menu(&mut self, pos: egui::Pos2, ui: &mut Ui, src: AnyPins, snarl: &mut Snarl<GraphNode>) {
        ui.label("Add a node and connect it");
        let Some(node) = self.pick(ui) else { return };
        let inputs = node.inputs();
        let id = snarl.insert_node(pos, node);
        match src {
            AnyPins::Out(outs) => {
                // Into the new node's first input that wants a connection.
                let first = match &snarl[id] {
                    GraphNode::Op { slots, .. } => {
                        slots.iter().position(|s| s.trim().is_empty() || s == "p").unwrap_or(0)
                    }
                    _ => 0,
                };
                if inputs > 0 {
                    for o in outs {
                        self.attach(*o, InPinId { node: id, input: first }, snarl);
                    }
                }
            }
            AnyPins::In(ins) => {
                for i in ins {
                    self.attach(OutPinId { node: id, output: 0 }, *i, snarl);
                }
            }
        }
    }

    fn has_node_menu(&mut self, node: &GraphNode) -> bool {
        !matches!(node, GraphNode::Object { .. })
    }

    fn show_node_menu(
        &mut self,
        node: NodeId,
        _: &[InPin],
        outputs: &[OutPin],
        ui: &mut Ui,
        snarl: &mut Snarl<GraphNode>,
    ) {
        if ui.button("Duplicate").clicked() {
            let value = snarl[node].clone();
            let pos = snarl.get_node_info(node).map_or(egui::Pos2::ZERO, |n| n.pos) + egui::vec2(30.0, 30.0);
            snarl.insert_node(pos, value);
            ui.close();
        }
        if ui.button("Remove").clicked() {
            let fed: Vec<InPinId> = outputs.iter().flat_map(|o| o.remotes.clone()).collect();
            snarl.remove_node(node);
            let mut fed = fed;
            fed.sort_by_key(|r| std::cmp::Reverse(r.input));
            for r in fed {
                compact(snarl, r.node, r.input);
            }
            self.changed = true;
            ui.close();
        }
    }
}
