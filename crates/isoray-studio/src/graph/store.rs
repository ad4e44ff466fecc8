//! The graph's layout in the scene file: the `[studio]` table, which
//! `isoray render` ignores.
//!
//! ```toml
//! [[studio.graph]]
//! object = 1                              # the [[object]] it lays out (0 is the first)
//! nodes = [[380.0, 0.0], [190.0, 0.0]]    # node positions, in the graph's order
//! collapsed = [1]                         # indices into `nodes` shown collapsed
//! ```
//!
//! `nodes` lists the object's node first, then the nodes feeding it, depth
//! first, inputs in order, each node once ([`super::model::preorder`]).
//! When the shape was edited elsewhere and its graph has a different
//! number of nodes, the stored positions do not apply and the studio lays
//! the object out afresh.

use egui_snarl::{NodeId, Snarl};

use super::model::{preorder, GraphNode};

/// The stored layout of one object's graph.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectLayout {
    /// The object's index.
    pub object: usize,
    /// Node positions, in [`preorder`].
    pub nodes: Vec<[f32; 2]>,
    /// Indices into `nodes` of the collapsed nodes.
    pub collapsed: Vec<usize>,
}

/// Reads the `[[studio.graph]]` tables of a scene file's text; entries
/// that are not well formed are skipped (the layout is a convenience, never
/// a reason not to open a file).
pub fn read(text: &str) -> Vec<ObjectLayout> {
    let Ok(doc) = text.parse::<toml_edit::DocumentMut>() else {
        return Vec::new();
    };
    let Some(list) = doc
        .get("studio")
        .and_then(|s| s.get("graph"))
        .and_then(|g| g.as_array_of_tables())
    else {
        return Vec::new();
    };
    list.iter()
        .filter_map(|t| {
            let object = usize::try_from(t.get("object")?.as_integer()?).ok()?;
            let nodes = t
                .get("nodes")?
                .as_array()?
                .iter()
                .map(|v| {
                    let a = v.as_array()?;
                    let x = number(a.get(0)?)?;
                    let y = number(a.get(1)?)?;
                    Some([x, y])
                })
                .collect::<Option<Vec<_>>>()?;
            let collapsed = match t.get("collapsed") {
                None => Vec::new(),
                Some(c) => c
                    .as_array()?
                    .iter()
                    .map(|v| v.as_integer().and_then(|i| usize::try_from(i).ok()))
                    .collect::<Option<Vec<_>>>()?,
            };
            Some(ObjectLayout {
                object,
                nodes,
                collapsed,
            })
        })
        .collect()
}

fn number(v: &toml_edit::Value) -> Option<f32> {
    v.as_float()
        .or_else(|| v.as_integer().map(|i| i as f64))
        .map(|f| f as f32)
}

/// Puts stored positions and collapsed states on the graph, for each
/// object whose node count matches.
pub fn apply(snarl: &mut Snarl<GraphNode>, objects: &[NodeId], layouts: &[ObjectLayout]) {
    for l in layouts {
        let Some(&o) = objects.get(l.object) else { continue };
        let order = preorder(snarl, o);
        if order.len() != l.nodes.len() {
            continue;
        }
        for (i, (id, [x, y])) in order.iter().zip(&l.nodes).enumerate() {
            if let Some(info) = snarl.get_node_info_mut(*id) {
                info.pos = egui::pos2(*x, *y);
                info.open = !l.collapsed.contains(&i);
            }
        }
    }
}

/// The layout of each object's graph as it is now.
pub fn capture(snarl: &Snarl<GraphNode>, objects: &[NodeId]) -> Vec<ObjectLayout> {
    objects
        .iter()
        .enumerate()
        .map(|(object, &o)| {
            let order = preorder(snarl, o);
            let infos: Vec<_> = order.iter().filter_map(|&n| snarl.get_node_info(n)).collect();
            ObjectLayout {
                object,
                nodes: infos.iter().map(|i| [round(i.pos.x), round(i.pos.y)]).collect(),
                collapsed: infos
                    .iter()
                    .enumerate()
                    .filter(|(_, i)| !i.open)
                    .map(|(k, _)| k)
                    .collect(),
            }
        })
        .collect()
}

/// Positions are kept to a tenth of a point, so files stay readable.
fn round(v: f32) -> f32 {
    (v * 10.0).round() / 10.0
}

/// Writes `layouts` into the TOML document as its `[[studio.graph]]`
/// tables, replacing the old ones; other `[studio]` keys are kept.
pub fn write(doc: &mut toml_edit::DocumentMut, layouts: &[ObjectLayout]) {
    let mut list = toml_edit::ArrayOfTables::new();
    for l in layouts {
        let mut t = toml_edit::Table::new();
        t.insert("object", toml_edit::value(l.object as i64));
        let mut nodes = toml_edit::Array::new();
        for [x, y] in &l.nodes {
            let mut p = toml_edit::Array::new();
            p.push(f64::from(*x));
            p.push(f64::from(*y));
            nodes.push(p);
        }
        t.insert("nodes", toml_edit::value(nodes));
        if !l.collapsed.is_empty() {
            let c: toml_edit::Array = l.collapsed.iter().map(|&i| i as i64).collect();
            t.insert("collapsed", toml_edit::value(c));
        }
        list.push(t);
    }
    if let Some(first) = list.get_mut(0) {
        first
            .decor_mut()
            .set_prefix("\n# isoray-studio's node-graph layout; `isoray render` ignores [studio].\n");
    }
    let root = doc.as_table_mut();
    if !root.contains_key("studio") {
        let mut studio = toml_edit::Table::new();
        studio.set_implicit(true);
        root.insert("studio", toml_edit::Item::Table(studio));
    }
    if let Some(studio) = root.get_mut("studio").and_then(|s| s.as_table_mut()) {
        if list.is_empty() {
            studio.remove("graph");
        } else {
            studio.insert("graph", toml_edit::Item::ArrayOfTables(list));
        }
    }
}
