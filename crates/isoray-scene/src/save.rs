//! Writing a scene back: `KEY=VALUE` edits applied to the file's own text,
//! with its comments, key order and formatting kept, checked like a load and
//! written atomically.
//!
//! ```
//! let text = "[render]\nwidth = 320   # small\n\n[[object]]\nshape = \"sphere(p, 1.0)\"\n";
//! let out = isoray_scene::edit_text(text, "s.toml", &["render.width=640".into(), "object.0.shape=box(p, vec3(1.0))".into()]).unwrap();
//! assert_eq!(out, "[render]\nwidth = 640   # small\n\n[[object]]\nshape = \"box(p, vec3(1.0))\"\n");
//! ```

use std::path::Path;

use toml_edit::{DocumentMut, InlineTable, Item, Table, Value};

use crate::error::SceneError;

type Result<T> = std::result::Result<T, SceneError>;

/// Applies `KEY=VALUE` edits (the `--set` syntax) to the text of a scene and
/// returns the new text. The edits are first checked exactly as `--set`
/// overrides of a load (errors point at the edit); the new text must then
/// load to the same scene. Comments, key order and formatting are kept; a
/// replaced value keeps the comment after it.
pub fn edit_text(text: &str, name: &str, edits: &[String]) -> Result<String> {
    // Check the edits as a load would (ranges, types, names), located in them.
    crate::load_str(text, name, edits)?;
    let mut doc: DocumentMut = text
        .parse()
        .map_err(|e: toml_edit::TomlError| SceneError::usage(format!("`{name}` is not valid TOML: {}", e.message())))?;
    for (i, edit) in edits.iter().enumerate() {
        apply(doc.as_item_mut(), edit).map_err(|msg| SceneError::usage(format!("--set #{}: {msg}", i + 1)))?;
    }
    let out = doc.to_string();
    crate::load_str(&out, name, &[]).map_err(|e| {
        SceneError::usage(format!(
            "the edited scene does not load (this is a bug in isoray; the file was not written):\n{}",
            e.rendered
        ))
    })?;
    Ok(out)
}

/// What [`set_file`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct SetReport {
    /// The file written.
    pub written: std::path::PathBuf,
    /// Number of edits applied.
    pub edits: usize,
}

/// Applies `edits` to the scene file `path` and writes the result to `out`
/// (or back to `path`), atomically: on any failure the old file is intact.
pub fn set_file(path: &Path, edits: &[String], out: Option<&Path>) -> Result<SetReport> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(&name, "read", &e))?;
    let new = edit_text(&text, &name, edits)?;
    let target = out.unwrap_or(path);
    write_atomic(target, new.as_bytes()).map_err(|e| SceneError::io(&target.display().to_string(), "write", &e))?;
    Ok(SetReport {
        written: target.to_path_buf(),
        edits: edits.len(),
    })
}

/// Writes `bytes` to `path` atomically: readers see the old file or the
/// new one, never a part, and a failure leaves the old file as it was
/// (see [`isoray_job::file`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    isoray_job::file::write_atomic(path, bytes)
}

/// Lets `write` create a temporary file beside `path`, flushes it to disk
/// and renames it over `path`; on any failure the temporary file is removed
/// and the old file is left as it was (see [`isoray_job::file`]).
pub fn replace_atomically(path: &Path, write: impl FnOnce(&Path) -> std::io::Result<()>) -> std::io::Result<()> {
    isoray_job::file::replace_atomically(path, write)
}

/// Applies one `KEY=VALUE` edit to the document.
fn apply(root: &mut Item, edit: &str) -> std::result::Result<(), String> {
    let (key, value_text) = edit
        .split_once('=')
        .ok_or_else(|| format!("`{edit}` must have the form KEY=VALUE"))?;
    let value_text = value_text.trim();
    let value: Value = value_text.parse::<Value>().unwrap_or_else(|_| Value::from(value_text));
    let path: Vec<&str> = key.trim().split('.').collect();
    set_in(root, &path, value, key.trim())
}

/// Sets `path` below `item` to `value`.
fn set_in(item: &mut Item, path: &[&str], value: Value, key: &str) -> std::result::Result<(), String> {
    let seg = path[0];
    let last = path.len() == 1;
    // Arrays (of tables, or inline): the next segment is an index.
    if let Some(n) = array_len(item) {
        let idx: usize = seg
            .parse()
            .map_err(|_| format!("`{key}`: expected an index into an array, found `{seg}`"))?;
        if idx >= n {
            return Err(format!(
                "`{key}`: the array has {n} element(s); index {idx} is out of range"
            ));
        }
        return match item {
            Item::ArrayOfTables(a) => {
                let t = a.get_mut(idx).expect("index checked");
                if last {
                    return Err(format!("`{key}` is a table: set one of its keys"));
                }
                set_in_table(t, &path[1..], value, key)
            }
            Item::Value(Value::Array(a)) => {
                if last {
                    let old = a.get_mut(idx).expect("index checked");
                    replace_value(old, value);
                    return Ok(());
                }
                let elem = a.get_mut(idx).expect("index checked");
                match elem {
                    Value::InlineTable(t) => set_in_inline(t, &path[1..], value, key),
                    _ => Err(format!("`{key}`: element {idx} is not a table")),
                }
            }
            _ => unreachable!("array_len is Some only for arrays"),
        };
    }
    match item {
        Item::Table(t) => set_in_table(t, path, value, key),
        Item::Value(Value::InlineTable(t)) => set_in_inline(t, path, value, key),
        _ => Err(format!("`{key}`: cannot set a key inside a value")),
    }
}

fn array_len(item: &Item) -> Option<usize> {
    match item {
        Item::ArrayOfTables(a) => Some(a.len()),
        Item::Value(Value::Array(a)) => Some(a.len()),
        _ => None,
    }
}

/// True for a parameter written as `{ default = ..., range = [...] }`.
fn is_param_spec(item: &Item) -> bool {
    match item {
        Item::Table(t) => t.contains_key("default"),
        Item::Value(Value::InlineTable(t)) => t.contains_key("default"),
        _ => false,
    }
}

fn set_in_table(t: &mut Table, path: &[&str], value: Value, key: &str) -> std::result::Result<(), String> {
    let seg = path[0];
    if path.len() == 1 {
        match t.get_mut(seg) {
            Some(existing) if is_param_spec(existing) && !value.is_inline_table() => {
                return set_in(existing, &["default"], value, key);
            }
            Some(Item::Value(old)) => replace_value(old, value),
            Some(other @ (Item::Table(_) | Item::ArrayOfTables(_))) => {
                if other.is_array_of_tables() {
                    return Err(format!("`{key}` is an array of tables: set a key of one element"));
                }
                *other = Item::Value(value);
            }
            Some(other) => *other = Item::Value(value),
            None => {
                t.insert(seg, Item::Value(value));
            }
        }
        return Ok(());
    }
    if !t.contains_key(seg) {
        if path[1].parse::<usize>().is_ok() {
            return Err(format!(
                "the scene has no `{seg}` array, so `{}` does not exist",
                path[..2].join(".")
            ));
        }
        let mut sub = Table::new();
        sub.set_implicit(true);
        t.insert(seg, Item::Table(sub));
    }
    let child = t.get_mut(seg).expect("present");
    set_in(child, &path[1..], value, key)
}

fn set_in_inline(t: &mut InlineTable, path: &[&str], value: Value, key: &str) -> std::result::Result<(), String> {
    let seg = path[0];
    if path.len() == 1 {
        match t.get_mut(seg) {
            Some(Value::InlineTable(spec)) if spec.contains_key("default") && !value.is_inline_table() => {
                let old = spec.get_mut("default").expect("present");
                replace_value(old, value);
            }
            Some(old) => replace_value(old, value),
            None => {
                t.insert(seg, value);
            }
        }
        return Ok(());
    }
    if !t.contains_key(seg) {
        t.insert(seg, Value::InlineTable(InlineTable::new()));
    }
    let child = t.get_mut(seg).expect("present");
    let mut item = Item::Value(child.clone());
    set_in(&mut item, &path[1..], value, key)?;
    if let Item::Value(v) = item {
        *child = v;
    }
    Ok(())
}

/// Replaces a value, keeping the spaces and comment around the old one.
fn replace_value(old: &mut Value, mut new: Value) {
    let decor = old.decor().clone();
    *new.decor_mut() = decor;
    *old = new;
}
