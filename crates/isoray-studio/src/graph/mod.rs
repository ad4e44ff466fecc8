//! The Graph panel: the scene's shapes as a node graph (egui-snarl), two
//! views of one thing with the shape text.
//!
//! [`model`] turns shape text into nodes and nodes back into shape text;
//! [`store`] keeps the layout in the file's `[studio]` table; [`view`]
//! draws and edits the graph; [`thumbs`] renders the nodes' thumbnails.
//! [`GraphEditor`] ties them to the [`Document`]: it opens the document's
//! objects as a graph, and after an edit of the graph writes the objects
//! whose shape changed (and the layout) back as one undo step.

pub mod model;
pub mod store;
pub mod thumbs;
pub mod view;

use std::collections::HashMap;

use egui_snarl::{NodeId, Snarl};
use isoray_scene::SceneError;
use isoray_shape::Value;

use crate::Document;
pub use model::{Form, GraphError, GraphNode, Names, ObjectText};

/// The graph of a document's objects and what the panel keeps between
/// frames.
pub struct GraphEditor {
    /// The nodes and wires.
    pub snarl: Snarl<GraphNode>,
    /// The node of each `[[object]]`, in order.
    pub objects: Vec<NodeId>,
    /// Parameter and surface names of the scene.
    pub names: Names,
    /// The document text the graph shows (built from, or last written).
    synced: String,
    /// Why each node at fault does not print.
    pub errors: HashMap<NodeId, String>,
    /// The palette's search text.
    pub search: String,
    /// Node thumbnails.
    pub thumbs: thumbs::Thumbnails,
    /// Each object's shape text as the graph last read or wrote it.
    shapes: Vec<String>,
    /// The layout as last read or written.
    layout: Vec<store::ObjectLayout>,
}

impl GraphEditor {
    /// The graph of `doc`'s objects, laid out as its `[studio]` table says
    /// (or automatically).
    pub fn of(doc: &Document) -> GraphEditor {
        let mut g = GraphEditor {
            snarl: Snarl::new(),
            objects: Vec::new(),
            names: Names::default(),
            synced: String::new(),
            errors: HashMap::new(),
            search: String::new(),
            thumbs: thumbs::Thumbnails::default(),
            shapes: Vec::new(),
            layout: Vec::new(),
        };
        g.rebuild(doc);
        g
    }

    /// Follows `doc` after a change the graph did not make (an undo, a
    /// redo, an edit from another panel, an open): when an object's shape,
    /// the object list or the scene's names changed, the graph is rebuilt
    /// from the text (dropping nodes connected to no object); otherwise it
    /// keeps its nodes and takes the stored layout.
    pub fn sync(&mut self, doc: &Document) {
        if doc.text() == self.synced {
            return;
        }
        self.thumbs.clear();
        let names = Names::of(doc.scene());
        if shapes_of(doc) != self.shapes || names.params != self.names.params || names.surfaces != self.names.surfaces {
            self.rebuild(doc);
            return;
        }
        let layouts = store::read(doc.text());
        store::apply(&mut self.snarl, &self.objects, &layouts);
        self.layout = store::capture(&self.snarl, &self.objects);
        self.synced = doc.text().to_string();
    }

    fn rebuild(&mut self, doc: &Document) {
        self.names = Names::of(doc.scene());
        let objects = ObjectText::of_scene(doc.scene());
        let (mut snarl, nodes) = model::from_objects(&objects, &self.names);
        store::apply(&mut snarl, &nodes, &store::read(doc.text()));
        self.snarl = snarl;
        self.objects = nodes;
        self.shapes = objects.into_iter().map(|o| o.shape).collect();
        self.layout = store::capture(&self.snarl, &self.objects);
        self.synced = doc.text().to_string();
        self.check();
    }

    /// True when nodes were moved, collapsed or opened since the layout
    /// was last read or written.
    pub fn layout_changed(&self) -> bool {
        store::capture(&self.snarl, &self.objects) != self.layout
    }

    /// Prints every object, recording the errors; returns each object's
    /// text (None where it does not print).
    pub fn check(&mut self) -> Vec<Option<String>> {
        self.errors.clear();
        let mut texts = Vec::new();
        for &o in &self.objects {
            match model::object_text(&self.snarl, o, &self.names) {
                Ok(t) => texts.push(Some(t)),
                Err(GraphError { node, message }) => {
                    self.errors.insert(node, message);
                    texts.push(None);
                }
            }
        }
        texts
    }

    /// Writes the graph back into `doc` as one undo step: the `shape` of
    /// every object whose graph prints to a different expression than its
    /// text, and the layout. Objects whose graph does not print keep their
    /// text (their node shows why). Returns whether the document changed.
    pub fn commit(&mut self, doc: &mut Document) -> Result<bool, SceneError> {
        let texts = self.check();
        let current = shapes_of(doc);
        let mut edits = Vec::new();
        for (i, text) in texts.iter().enumerate() {
            let (Some(new), Some(old)) = (text, current.get(i)) else {
                continue;
            };
            if !same_shape(new, old) {
                edits.push(shape_edit(i, new));
            }
        }
        let layouts = store::capture(&self.snarl, &self.objects);
        let before = doc.text().to_string();
        doc.edit_with(&edits, |toml| store::write(toml, &layouts))?;
        self.synced = doc.text().to_string();
        self.shapes = shapes_of(doc);
        self.layout = layouts;
        Ok(doc.text() != before)
    }
}

impl GraphEditor {
    /// The value slot `input` of `node` holds when it is a number or a
    /// vector of numbers (what a drag edits).
    pub fn slot_value(&self, node: NodeId, input: usize) -> Option<Value> {
        let GraphNode::Op { slots, .. } = self.snarl.get_node(node)? else {
            return None;
        };
        let text = slots.get(input)?.trim();
        if let Ok(v) = text.parse::<f64>() {
            return Some(Value::Float(v));
        }
        match view::numeric_vec(text)?.as_slice() {
            [x, y] => Some(Value::Vec2([*x, *y])),
            [x, y, z] => Some(Value::Vec3([*x, *y, *z])),
            _ => None,
        }
    }

    /// The objects' shapes with slot `input` of `node` reading `name`
    /// instead of its text: (object index, shape text) for every object
    /// whose shape that changes. The graph is left as it was.
    pub fn shapes_with_slot(&mut self, node: NodeId, input: usize, name: &str) -> Vec<(usize, String)> {
        let before = self.texts();
        let Some(GraphNode::Op { slots, .. }) = self.snarl.get_node_mut(node) else {
            return Vec::new();
        };
        let Some(slot) = slots.get_mut(input) else {
            return Vec::new();
        };
        let kept = std::mem::replace(slot, name.to_string());
        let after = self.texts();
        if let Some(GraphNode::Op { slots, .. }) = self.snarl.get_node_mut(node) {
            slots[input] = kept;
        }
        before
            .into_iter()
            .zip(after)
            .enumerate()
            .filter_map(|(i, (b, a))| match (b, a) {
                (Some(b), Some(a)) if a != b => Some((i, a)),
                _ => None,
            })
            .collect()
    }

    /// Each object's printed shape text (`None` where it does not print),
    /// leaving the nodes' errors alone.
    fn texts(&self) -> Vec<Option<String>> {
        self.objects
            .iter()
            .map(|&o| model::object_text(&self.snarl, o, &self.names).ok())
            .collect()
    }
}

/// The edit (`--set` syntax) that sets object `i`'s shape to `text`.
pub fn shape_edit(i: usize, text: &str) -> String {
    let quoted = toml_edit::Value::from(text).to_string();
    format!("object.{i}.shape={}", quoted.trim())
}

/// Each object's shape text, as written in `doc`.
fn shapes_of(doc: &Document) -> Vec<String> {
    doc.scene().objects.iter().map(|o| o.source.clone()).collect()
}

/// True when two shape texts parse to the same expression (or are the
/// same text).
pub fn same_shape(a: &str, b: &str) -> bool {
    if a == b {
        return true;
    }
    match (isoray_shape::syntax::parse(a, 0), isoray_shape::syntax::parse(b, 0)) {
        (Ok(x), Ok(y)) => {
            x.lets.is_empty()
                && y.lets.is_empty()
                && isoray_shape::syntax::without_spans(&x.body) == isoray_shape::syntax::without_spans(&y.body)
        }
        _ => false,
    }
}
