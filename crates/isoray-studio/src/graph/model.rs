//! The node graph of a scene's shapes, as data: how shape text opens as a
//! graph and how a graph prints back as shape text.
//!
//! Every `[[object]]` is an [`GraphNode::Object`] node with one input, the
//! object's distance. The shape text is cut at its *structural* parts: a
//! call of a primitive, operator, domain operator or user surface is a
//! node, and so is a scene parameter and any arithmetic (`+`, `-`, `*`,
//! `/`, `^`, unary minus, swizzle, built-in math) that has a structural
//! part below it, or that moves the point (`p - vec3(…)`). What is left
//! (numbers, `vec3(…)` of numbers, `p`, closed sub-expressions such as
//! `PI / 2`) stays in the node's input slots as text, edited in place. A
//! shape with `let` bindings, or one that does not parse, is one
//! [`GraphNode::Code`] node holding its text verbatim.
//!
//! Printing a graph gives ordinary shape text that parses to the same
//! expression the graph was made from ([`object_text`]); a code node that
//! feeds an object directly prints verbatim, comments included.

use std::collections::{BTreeSet, HashMap, HashSet};

use egui_snarl::{InPinId, NodeId, OutPinId, Snarl};
use isoray_shape::library::{Category, Param, FUNCTIONS};
use isoray_shape::syntax::{self, BinaryOp, Expr, ExprKind};
use isoray_shape::Span;

/// What an operation node computes.
#[derive(Debug, Clone, PartialEq)]
pub enum Form {
    /// A call: a primitive, operator, domain operator, user surface or
    /// built-in, by name.
    Call(String),
    /// `a op b`.
    Binary(BinaryOp),
    /// `-a`.
    Neg,
    /// `a.xyz`.
    Swizzle(String),
}

/// One node of the graph.
#[derive(Debug, Clone, PartialEq)]
pub enum GraphNode {
    /// `[[object]]` number `index`; its one input is the object's distance.
    Object {
        /// Index of the object in the scene.
        index: usize,
        /// What the node's header says (the object's name or number).
        label: String,
    },
    /// An operation; input `i` is connected, or else slot `i` is its text.
    Op {
        /// What it computes.
        form: Form,
        /// Shape text used for each input that has no connection (`""`:
        /// none, an error unless the input is optional).
        slots: Vec<String>,
    },
    /// A scene parameter (`[params]`), by name.
    Param {
        /// The parameter's name.
        name: String,
    },
    /// Free-form shape text: any expression, or at an object's input a
    /// whole program with `let` bindings.
    Code {
        /// The text, as written.
        text: String,
    },
}

impl GraphNode {
    /// The number of input pins the node shows. A variadic call (`union`,
    /// `intersection`, `smooth_union_n`) shows one more, empty, which
    /// grows a new slot when connected.
    pub fn inputs(&self) -> usize {
        match self {
            GraphNode::Object { .. } => 1,
            GraphNode::Op { form, slots } => slots.len() + usize::from(is_variadic(form)),
            GraphNode::Param { .. } | GraphNode::Code { .. } => 0,
        }
    }

    /// The number of output pins (objects have none).
    pub fn outputs(&self) -> usize {
        usize::from(!matches!(self, GraphNode::Object { .. }))
    }

    /// The name a palette and a header use.
    pub fn title(&self) -> String {
        match self {
            GraphNode::Object { label, .. } => label.clone(),
            GraphNode::Op { form, .. } => match form {
                Form::Call(n) => n.clone(),
                Form::Binary(op) => format!("a {} b", op.symbol()),
                Form::Neg => "-a".into(),
                Form::Swizzle(s) => format!("a.{s}"),
            },
            GraphNode::Param { name } => name.clone(),
            GraphNode::Code { .. } => "code".into(),
        }
    }
}

/// True for the calls that take any number of distances.
pub fn is_variadic(form: &Form) -> bool {
    matches!(form, Form::Call(n) if matches!(n.as_str(), "union" | "intersection" | "smooth_union_n"))
}

/// The names of a node's input slots, as its pins are labelled; `None`
/// for a name the library does not know (a user surface's slots come from
/// its parameters: the point, then each parameter).
pub fn slot_names(form: &Form, surfaces: &HashMap<String, Vec<String>>, count: usize) -> Vec<String> {
    let listed: Vec<String> = match form {
        Form::Call(name) => {
            if let Some(params) = surfaces.get(name) {
                std::iter::once("p".to_string()).chain(params.iter().cloned()).collect()
            } else {
                signature(name, count).map_or_else(Vec::new, |s| s.params.iter().map(|(n, _)| n.to_string()).collect())
            }
        }
        Form::Binary(_) => vec!["a".into(), "b".into()],
        Form::Neg | Form::Swizzle(_) => vec!["a".into()],
    };
    (0..count)
        .map(|i| {
            listed.get(i).cloned().unwrap_or_else(|| {
                if is_variadic(form) {
                    format!("d{}", i + 1)
                } else {
                    format!("arg {}", i + 1)
                }
            })
        })
        .collect()
}

/// The library signature a call of `name` with `count` arguments uses.
pub fn signature(name: &str, count: usize) -> Option<&'static isoray_shape::library::Signature> {
    let mut all = FUNCTIONS.iter().filter(|s| s.name == name);
    let first = all.next()?;
    Some(
        std::iter::once(first)
            .chain(all)
            .find(|s| (s.params.len() - s.optional..=s.params.len()).contains(&count))
            .unwrap_or(first),
    )
}

/// How many trailing slots of a call may be left empty (and are then
/// omitted from the text).
fn optional_slots(form: &Form, count: usize) -> usize {
    match form {
        Form::Call(name) => signature(name, count).map_or(0, |s| {
            let required = s.params.len() - s.optional;
            count.saturating_sub(required)
        }),
        _ => 0,
    }
}

/// True when a call of `name` is structural: anything but the built-in
/// math and the `vec2`/`vec3`/`float` constructors (so primitives,
/// operators, domain operators and user surfaces).
pub fn is_structural_call(name: &str) -> bool {
    if matches!(name, "vec2" | "vec3" | "float") {
        return false;
    }
    let mut listed = FUNCTIONS.iter().filter(|s| s.name == name).peekable();
    // Not in the library: a user surface. `round` is both built-in math
    // (one argument) and an operator on distances (two): structural.
    listed.peek().is_none() || listed.any(|s| s.category != Category::Builtin)
}

/// The scene facts a graph needs: parameter names and each user
/// surface's parameter names.
#[derive(Debug, Clone, Default)]
pub struct Names {
    /// The `[params]` names.
    pub params: BTreeSet<String>,
    /// Each `[surface.*]` by name, with its parameters' names in order.
    pub surfaces: HashMap<String, Vec<String>>,
}

impl Names {
    /// The names of `scene`.
    pub fn of(scene: &isoray_scene::Scene) -> Names {
        Names {
            params: scene.params.iter().map(|(n, _)| n.clone()).collect(),
            surfaces: scene
                .library
                .surface_names()
                .iter()
                .filter_map(|n| scene.library.surface(n))
                .map(|s| (s.name.clone(), s.params.iter().map(|(n, _)| n.clone()).collect()))
                .collect(),
        }
    }
}

/// What an input of a node is, once read from text.
enum Piece {
    /// A node's output.
    Node(NodeId),
    /// Text kept in the slot.
    Text(String),
}

/// True when `e` becomes a node (see the module documentation).
fn structural(e: &Expr, names: &Names) -> bool {
    match &e.kind {
        ExprKind::Num(_) => false,
        ExprKind::Var(n) => names.params.contains(n),
        ExprKind::Call { name, args, .. } => is_structural_call(name) || args.iter().any(|a| structural(a, names)),
        ExprKind::Binary(op, a, b) => {
            let moves_p =
                matches!(op, BinaryOp::Add | BinaryOp::Sub) && matches!(&a.kind, ExprKind::Var(n) if n == "p");
            moves_p || structural(a, names) || structural(b, names)
        }
        ExprKind::Neg(a) | ExprKind::Swizzle(a, _) => structural(a, names),
    }
}

/// Builds the nodes of `e` into `snarl` (parameters shared through
/// `params`), returning what the parent's input gets.
fn build(e: &Expr, names: &Names, snarl: &mut Snarl<GraphNode>, params: &mut HashMap<String, NodeId>) -> Piece {
    if !structural(e, names) {
        return Piece::Text(syntax::print_expr(e));
    }
    let (form, args): (Form, Vec<&Expr>) = match &e.kind {
        ExprKind::Var(n) => {
            let id = *params
                .entry(n.clone())
                .or_insert_with(|| snarl.insert_node(egui::Pos2::ZERO, GraphNode::Param { name: n.clone() }));
            return Piece::Node(id);
        }
        ExprKind::Call { name, args, .. } => (Form::Call(name.clone()), args.iter().collect()),
        ExprKind::Binary(op, a, b) => (Form::Binary(*op), vec![a, b]),
        ExprKind::Neg(a) => (Form::Neg, vec![a]),
        ExprKind::Swizzle(a, s) => (Form::Swizzle(s.clone()), vec![a]),
        ExprKind::Num(_) => unreachable!("numbers are never structural"),
    };
    let id = snarl.insert_node(
        egui::Pos2::ZERO,
        GraphNode::Op {
            form,
            slots: vec![String::new(); args.len()],
        },
    );
    for (i, a) in args.into_iter().enumerate() {
        match build(a, names, snarl, params) {
            Piece::Node(from) => {
                snarl.connect(OutPinId { node: from, output: 0 }, InPinId { node: id, input: i });
            }
            Piece::Text(t) => {
                if let GraphNode::Op { slots, .. } = &mut snarl[id] {
                    slots[i] = t;
                }
            }
        }
    }
    Piece::Node(id)
}

/// One object as the graph needs it: its label and shape text.
#[derive(Debug, Clone)]
pub struct ObjectText {
    /// The header of its node.
    pub label: String,
    /// Its `shape`, as written in the file.
    pub shape: String,
}

impl ObjectText {
    /// The objects of a scene file's text, in order (the text must load).
    pub fn of_scene(scene: &isoray_scene::Scene) -> Vec<ObjectText> {
        scene
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| ObjectText {
                label: o
                    .name
                    .clone()
                    .map_or_else(|| format!("object {i}"), |n| format!("object {i}: {n}")),
                shape: o.source.clone(),
            })
            .collect()
    }
}

/// The graph of a scene's objects, each object's nodes laid out as a tree
/// right to left, objects one under another. Returns the graph and each
/// object's node.
pub fn from_objects(objects: &[ObjectText], names: &Names) -> (Snarl<GraphNode>, Vec<NodeId>) {
    let mut snarl = Snarl::new();
    let mut outputs = Vec::new();
    for (index, o) in objects.iter().enumerate() {
        let out = snarl.insert_node(
            egui::Pos2::ZERO,
            GraphNode::Object {
                index,
                label: o.label.clone(),
            },
        );
        let piece = match syntax::parse(&o.shape, 0) {
            Ok(p) if p.lets.is_empty() => {
                let mut params = HashMap::new();
                match build(&p.body, names, &mut snarl, &mut params) {
                    Piece::Node(id) => Some(id),
                    Piece::Text(_) => None,
                }
            }
            _ => None,
        };
        let input =
            piece.unwrap_or_else(|| snarl.insert_node(egui::Pos2::ZERO, GraphNode::Code { text: o.shape.clone() }));
        snarl.connect(OutPinId { node: input, output: 0 }, InPinId { node: out, input: 0 });
        outputs.push(out);
    }
    layout(&mut snarl, &outputs);
    (snarl, outputs)
}

/// Column width and the gap between rows of the automatic layout (points).
pub const LAYOUT_STEP: (f32, f32) = (300.0, 24.0);

/// About how tall a node is drawn (points): header, one row per input,
/// and the thumbnail.
fn node_height(node: &GraphNode) -> f32 {
    let rows = node.inputs().max(1) as f32;
    let thumb = if matches!(node, GraphNode::Param { .. }) {
        0.0
    } else {
        70.0
    };
    36.0 + 24.0 * rows + thumb
}

/// Lays out each object's nodes as a tree: the object on the right, its
/// inputs in columns to the left by depth, leaves one under another;
/// objects are stacked. A node shared by several parents stays where it
/// was first placed.
pub fn layout(snarl: &mut Snarl<GraphNode>, objects: &[NodeId]) {
    let mut placed = HashSet::new();
    let mut y = 0.0_f32;
    for &o in objects {
        let depth = tree_depth(snarl, o, &mut HashSet::new());
        place(snarl, o, 0, depth, &mut y, &mut placed);
        y += LAYOUT_STEP.1;
    }
}

fn tree_depth(snarl: &Snarl<GraphNode>, node: NodeId, seen: &mut HashSet<NodeId>) -> usize {
    if !seen.insert(node) {
        return 0;
    }
    let d = inputs_of(snarl, node)
        .into_iter()
        .flatten()
        .map(|n| 1 + tree_depth(snarl, n, seen))
        .max()
        .unwrap_or(0);
    seen.remove(&node);
    d
}

/// Places `node` at column `depth` (counted from the right of `max`),
/// returning its top; a leaf takes the next free place at `y`, a parent
/// sits level with its first input.
fn place(
    snarl: &mut Snarl<GraphNode>,
    node: NodeId,
    depth: usize,
    max: usize,
    y: &mut f32,
    placed: &mut HashSet<NodeId>,
) -> f32 {
    if !placed.insert(node) {
        return snarl.get_node_info(node).map_or(*y, |n| n.pos.y);
    }
    let children: Vec<NodeId> = inputs_of(snarl, node).into_iter().flatten().collect();
    let tops: Vec<f32> = children
        .iter()
        .map(|&c| place(snarl, c, depth + 1, max, y, placed))
        .collect();
    let height = snarl.get_node(node).map_or(60.0, node_height);
    let top = match tops.first() {
        Some(&t) => {
            *y = y.max(t + height + LAYOUT_STEP.1);
            t
        }
        None => {
            let t = *y;
            *y += height + LAYOUT_STEP.1;
            t
        }
    };
    if let Some(info) = snarl.get_node_info_mut(node) {
        info.pos = egui::pos2((max - depth.min(max)) as f32 * LAYOUT_STEP.0, top);
    }
    top
}

/// The node connected to each input of `node` (None where there is none).
pub fn inputs_of(snarl: &Snarl<GraphNode>, node: NodeId) -> Vec<Option<NodeId>> {
    let n = snarl.get_node(node).map_or(0, GraphNode::inputs);
    (0..n)
        .map(|input| snarl.in_pin(InPinId { node, input }).remotes.first().map(|o| o.node))
        .collect()
}

/// Why a graph does not print: the node at fault and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct GraphError {
    /// The node the message is about.
    pub node: NodeId,
    /// What is wrong, for a badge on that node.
    pub message: String,
}

/// The shape text of the object node `object`: ordinary shape text that
/// `isoray render` reads. A code node feeding the object directly prints
/// verbatim; everything else prints through [`syntax::print_expr`].
pub fn object_text(snarl: &Snarl<GraphNode>, object: NodeId, names: &Names) -> Result<String, GraphError> {
    let Some(input) = inputs_of(snarl, object).first().copied().flatten() else {
        return Err(GraphError {
            node: object,
            message: "the object has no shape: connect a node to its input".into(),
        });
    };
    if let Some(GraphNode::Code { text }) = snarl.get_node(input) {
        return match syntax::parse(text, 0) {
            Ok(_) => Ok(text.clone()),
            Err(d) => Err(GraphError {
                node: input,
                message: format!("the code does not parse: {}", d.message),
            }),
        };
    }
    let e = node_expr(snarl, input, names, &mut Vec::new())?;
    Ok(syntax::print_expr(&e))
}

/// The shape text of what `node` computes (a distance, a point, any
/// value), as [`object_text`] would print it inside an object.
pub fn node_text(snarl: &Snarl<GraphNode>, node: NodeId, names: &Names) -> Result<String, GraphError> {
    node_expr(snarl, node, names, &mut Vec::new()).map(|e| syntax::print_expr(&e))
}

fn at(kind: ExprKind) -> Expr {
    Expr {
        kind,
        span: Span::default(),
    }
}

/// The expression node `node` computes; `path` holds the nodes being
/// printed, to report a cycle.
fn node_expr(
    snarl: &Snarl<GraphNode>,
    node: NodeId,
    names: &Names,
    path: &mut Vec<NodeId>,
) -> Result<Expr, GraphError> {
    if path.contains(&node) {
        return Err(GraphError {
            node,
            message: "this node feeds itself (a cycle): remove one of the connections".into(),
        });
    }
    let err = |message: String| GraphError { node, message };
    let Some(value) = snarl.get_node(node) else {
        return Err(err("the node was removed".into()));
    };
    match value {
        GraphNode::Object { .. } => Err(err("an object has no output".into())),
        GraphNode::Param { name } => Ok(at(ExprKind::Var(name.clone()))),
        GraphNode::Code { text } => {
            let p = syntax::parse(text, 0).map_err(|d| err(format!("the code does not parse: {}", d.message)))?;
            if !p.lets.is_empty() {
                return Err(err(
                    "code with `let` bindings can only feed an object directly; write it as one expression here".into(),
                ));
            }
            Ok(p.body)
        }
        GraphNode::Op { form, slots } => {
            path.push(node);
            let inputs = inputs_of(snarl, node);
            let optional = optional_slots(form, slots.len());
            let labels = slot_names(form, &names.surfaces, slots.len());
            let mut args = Vec::new();
            let mut omitted = None;
            for (i, text) in slots.iter().enumerate() {
                let arg = match inputs.get(i).copied().flatten() {
                    Some(from) => Some(node_expr(snarl, from, names, path)?),
                    None if text.trim().is_empty() => None,
                    None => Some(slot_expr(text).map_err(|m| err(format!("input `{}`: {m}", labels[i])))?),
                };
                match arg {
                    Some(a) => {
                        if let Some(j) = omitted {
                            return Err(err(format!(
                                "input `{}` is empty but a later input is set: fill it in or clear the later ones",
                                labels[j]
                            )));
                        }
                        args.push(a);
                    }
                    None if i >= slots.len() - optional || (is_variadic(form) && i >= 2) => {
                        omitted.get_or_insert(i);
                    }
                    None => return Err(err(format!("input `{}` needs a connection or a value", labels[i]))),
                }
            }
            path.pop();
            let kind = match form {
                Form::Call(name) => ExprKind::Call {
                    name: name.clone(),
                    name_span: Span::default(),
                    args,
                },
                Form::Binary(op) => {
                    let mut it = args.into_iter();
                    let (a, b) = (it.next().expect("two inputs"), it.next().expect("two inputs"));
                    ExprKind::Binary(*op, Box::new(a), Box::new(b))
                }
                Form::Neg => ExprKind::Neg(Box::new(args.into_iter().next().expect("one input"))),
                Form::Swizzle(s) => ExprKind::Swizzle(Box::new(args.into_iter().next().expect("one input")), s.clone()),
            };
            Ok(at(kind))
        }
    }
}

/// A slot's text as an expression: one expression, no `let`.
fn slot_expr(text: &str) -> Result<Expr, String> {
    let p = syntax::parse(text, 0).map_err(|d| format!("`{text}` does not parse: {}", d.message))?;
    if !p.lets.is_empty() {
        return Err("a value cannot have `let` bindings".into());
    }
    Ok(p.body)
}

/// The text a new node's slot starts with: the point for a point
/// argument, nothing for a distance (it wants a connection), and a small
/// value otherwise.
pub fn default_slot(name: &str, param: &str, kind: Param, category: Category) -> String {
    match (category, param, kind) {
        (_, _, Param::P) => "p".into(),
        (Category::Operator, "a" | "b" | "d", _) => String::new(),
        (_, "n", _) if name.starts_with("smooth_") => String::new(),
        (_, "k", _) => "0.25".into(),
        (_, _, Param::V) => "vec3(0.5, 0.5, 0.5)".into(),
        _ => "0.5".into(),
    }
}

/// A new node for the library function `name` (its first signature),
/// with [`default_slot`] texts.
pub fn new_call(name: &str) -> Option<GraphNode> {
    let s = FUNCTIONS.iter().find(|s| s.name == name)?;
    let count = s.params.len() - s.optional;
    Some(GraphNode::Op {
        form: Form::Call(name.into()),
        slots: s.params[..count]
            .iter()
            .map(|(p, k)| default_slot(name, p, *k, s.category))
            .chain(s.params[count..].iter().map(|_| String::new()))
            .collect(),
    })
}

/// A new node calling the user surface `name` with parameters `params`:
/// the point, then each parameter left to its default (an empty,
/// optional slot).
pub fn new_surface_call(name: &str, params: usize) -> GraphNode {
    GraphNode::Op {
        form: Form::Call(name.into()),
        slots: std::iter::once("p".to_string())
            .chain((0..params).map(|_| String::new()))
            .collect(),
    }
}

/// The nodes reachable from `object` through inputs, in depth-first
/// order (each once): the order the `[studio]` layout lists positions in.
pub fn preorder(snarl: &Snarl<GraphNode>, object: NodeId) -> Vec<NodeId> {
    fn walk(snarl: &Snarl<GraphNode>, n: NodeId, out: &mut Vec<NodeId>) {
        if out.contains(&n) {
            return;
        }
        out.push(n);
        for c in inputs_of(snarl, n).into_iter().flatten() {
            walk(snarl, c, out);
        }
    }
    let mut out = Vec::new();
    walk(snarl, object, &mut out);
    out
}
