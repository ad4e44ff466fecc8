//! The Surfaces panel: a table of the scene's `[surface.*]` entries and a
//! dialog that edits one, with each error shown at the field it is about.
//!
//! The dialog's fields are written into a copy of the file's text
//! ([`candidate`]), which is loaded on a background thread as you type
//! ([`Check`]): the scene loader's own located errors are mapped back to
//! the field whose value they point into ([`field_at`]), and for implicit
//! and parametric surfaces the equation found, its degree and the bound
//! are shown (what `isoray surface` prints). A parametric surface's
//! implicitization runs there with a progress bar and a Cancel button.
//! When the surface loads, the check renders it alone, through the scene's
//! camera and lights ([`PREVIEW`]). Renaming a surface renames its calls
//! in the objects' shapes and the other surfaces' bodies. Save replaces
//! the surface in the document as one undo step; values the dialog did not
//! change keep their text in the file (comments, `'''` strings, layout).

use std::sync::{Arc, Mutex};

use isoray_job::{CancelToken, Progress};
use isoray_scene::SceneError;

/// The size of the dialog's preview of the surface alone, in pixels.
pub const PREVIEW: [u32; 2] = [240, 150];

/// How a surface is given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// `sdf = "…"`: a distance in shape text.
    Sdf,
    /// `implicit = "…"`: an equation f(x, y, z) = 0.
    Implicit,
    /// `parametric = { x, y, z }`: coordinates in s and t.
    Parametric,
}

impl Mode {
    /// The key that holds the body.
    pub fn key(self) -> &'static str {
        match self {
            Mode::Sdf => "sdf",
            Mode::Implicit => "implicit",
            Mode::Parametric => "parametric",
        }
    }
}

/// A field of the dialog, for placing an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Field {
    /// The surface's name.
    Name,
    /// The body (`sdf` or `implicit`).
    Body,
    /// A parametric coordinate: 0, 1, 2 for x, y, z.
    Coord(usize),
    /// `params` as a whole.
    Params,
    /// One row of the parameters' grid (its index).
    Param(usize),
    /// `domain`: 0 for s, 1 for t.
    Domain(usize),
    /// `image_only`.
    ImageOnly,
    /// `bound`.
    Bound,
    /// `lipschitz_factor`.
    LipschitzFactor,
    /// Anything else (shown under the dialog).
    Other,
}

/// One parameter of a surface: a row of the dialog's grid. Its place in
/// the list is its place in a call (after the point).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamRow {
    /// The symbol.
    pub name: String,
    /// The default: a number, or 2 or 3 numbers (`0, 1, 0` or
    /// `[0.0, 1.0, 0.0]`); it fixes the parameter's type.
    pub default: String,
    /// The slider range's low end, or empty for no range.
    pub min: String,
    /// The slider range's high end, or empty for no range.
    pub max: String,
}

/// The dialog's fields.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceForm {
    /// The name (`[surface.NAME]`).
    pub name: String,
    /// The name it had when the dialog opened (None: a new surface).
    pub original: Option<String>,
    /// How it is given.
    pub mode: Mode,
    /// `sdf` or `implicit` text.
    pub body: String,
    /// Parametric x, y, z.
    pub coords: [String; 3],
    /// The parameters, in declaration (call) order.
    pub params: Vec<ParamRow>,
    /// `domain` of s and t (parametric): `[min, max]` texts, empty for
    /// the default `[-1, 1]`.
    pub domain: [[String; 2]; 2],
    /// `image_only` (parametric).
    pub image_only: bool,
    /// `bound`, or empty for the default.
    pub bound: String,
    /// `lipschitz_factor` (implicit and parametric), or empty for 1.
    pub lipschitz_factor: String,
}

impl SurfaceForm {
    /// A new SDF surface, unused name `surface_N`.
    pub fn new(existing: &[Row]) -> SurfaceForm {
        let mut n = 1;
        while existing.iter().any(|r| r.name == format!("surface_{n}")) {
            n += 1;
        }
        SurfaceForm {
            name: format!("surface_{n}"),
            original: None,
            mode: Mode::Sdf,
            body: "length(p) - r".into(),
            coords: ["s".into(), "t".into(), "s * t".into()],
            params: vec![ParamRow {
                name: "r".into(),
                default: "1.0".into(),
                ..ParamRow::default()
            }],
            domain: Default::default(),
            image_only: false,
            bound: String::new(),
            lipschitz_factor: String::new(),
        }
    }
}

/// One row of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Name.
    pub name: String,
    /// SDF, Implicit or Parametric.
    pub mode: Mode,
    /// The parameters' names.
    pub params: Vec<String>,
    /// The input: the body, or the three coordinates.
    pub input: String,
    /// The whole form, for Edit.
    pub form: SurfaceForm,
}

fn string_of(t: &toml_edit::Table, key: &str) -> Option<String> {
    t.get(key).and_then(|v| v.as_str()).map(str::to_string)
}

/// A TOML value's text without its surrounding whitespace and comments.
fn bare_text(v: &toml_edit::Value) -> String {
    let mut v = v.clone();
    v.decor_mut().clear();
    v.to_string()
}

/// A number's text as the dialog shows it (`1.0`, not `1`).
fn number_text(v: &toml_edit::Value) -> String {
    match v {
        toml_edit::Value::Integer(i) => format!("{}.0", i.value()),
        other => bare_text(other),
    }
}

/// The grid rows of a `params` table.
fn param_rows(params: Option<&toml_edit::Item>) -> Vec<ParamRow> {
    let Some(t) = params.and_then(|p| p.as_table_like()) else {
        return Vec::new();
    };
    t.iter()
        .map(|(name, item)| {
            let mut row = ParamRow {
                name: name.to_string(),
                ..ParamRow::default()
            };
            match item.as_value() {
                Some(toml_edit::Value::InlineTable(spec)) => {
                    row.default = spec.get("default").map(number_text).unwrap_or_default();
                    if let Some(r) = spec.get("range").and_then(|r| r.as_array()) {
                        row.min = r.get(0).map(number_text).unwrap_or_default();
                        row.max = r.get(1).map(number_text).unwrap_or_default();
                    }
                }
                Some(v) => row.default = number_text(v),
                None => {}
            }
            row
        })
        .collect()
}

/// The `[surface.*]` entries of a scene file's text, in file order.
pub fn rows(text: &str) -> Vec<Row> {
    let Ok(doc) = text.parse::<toml_edit::DocumentMut>() else {
        return Vec::new();
    };
    let Some(surfaces) = doc.get("surface").and_then(|s| s.as_table_like()) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for (name, item) in surfaces.iter() {
        let Some(t) = item.as_table_like() else { continue };
        let mut table = toml_edit::Table::new();
        for (k, v) in t.iter() {
            table.insert(k, v.clone());
        }
        let (mode, body, coords) = if let Some(b) = string_of(&table, "sdf") {
            (Mode::Sdf, b, Default::default())
        } else if let Some(b) = string_of(&table, "implicit") {
            (Mode::Implicit, b, Default::default())
        } else {
            let c = table.get("parametric").and_then(|p| p.as_table_like());
            let coord = |k: &str| {
                c.and_then(|c| c.get(k))
                    .and_then(|v| v.as_str())
                    .unwrap_or("")
                    .to_string()
            };
            (Mode::Parametric, String::new(), [coord("x"), coord("y"), coord("z")])
        };
        let params = param_rows(table.get("params"));
        let mut domain: [[String; 2]; 2] = Default::default();
        if let Some(d) = table.get("domain").and_then(|d| d.as_table_like()) {
            for (i, k) in ["s", "t"].iter().enumerate() {
                if let Some(r) = d.get(k).and_then(|r| r.as_array()) {
                    for (j, v) in r.iter().take(2).enumerate() {
                        domain[i][j] = number_text(v);
                    }
                }
            }
        }
        let input = match mode {
            Mode::Parametric => format!("({}, {}, {})", coords[0], coords[1], coords[2]),
            _ => body.trim().to_string(),
        };
        out.push(Row {
            name: name.to_string(),
            mode,
            params: params.iter().map(|p| p.name.clone()).collect(),
            input,
            form: SurfaceForm {
                name: name.to_string(),
                original: Some(name.to_string()),
                mode,
                body,
                coords,
                params,
                domain,
                image_only: table.get("image_only").and_then(|v| v.as_bool()).unwrap_or(false),
                bound: string_of(&table, "bound").unwrap_or_default(),
                lipschitz_factor: table
                    .get("lipschitz_factor")
                    .and_then(|v| v.as_value())
                    .map(number_text)
                    .unwrap_or_default(),
            },
        });
    }
    out
}

/// An error of the form, at its field.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldError {
    /// Where.
    pub field: Field,
    /// What is wrong.
    pub message: String,
}

fn is_ident(name: &str) -> bool {
    name.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// A number typed in a field, as a TOML value.
fn number(text: &str, field: Field, what: &str) -> Result<toml_edit::Value, FieldError> {
    let t = text.trim();
    match t.parse::<toml_edit::Value>() {
        Ok(v @ (toml_edit::Value::Float(_) | toml_edit::Value::Integer(_))) => Ok(v),
        _ => Err(FieldError {
            field,
            message: format!("{what}: expected a number, found `{t}`"),
        }),
    }
}

/// The `params` inline table of the grid's rows.
fn params_value(rows: &[ParamRow]) -> Result<toml_edit::InlineTable, FieldError> {
    let mut table = toml_edit::InlineTable::new();
    for (i, row) in rows.iter().enumerate() {
        let field = Field::Param(i);
        let name = row.name.trim();
        if !is_ident(name) {
            return Err(FieldError {
                field,
                message: format!(
                    "parameter {}: a name is an identifier (letters, digits and `_`, not starting with a digit)",
                    i + 1
                ),
            });
        }
        if table.contains_key(name) {
            return Err(FieldError {
                field,
                message: format!("`{name}` is already a parameter of this surface"),
            });
        }
        let d = row.default.trim();
        // `0, 1, 0` is a vector as much as `[0, 1, 0]` is.
        let d = if d.contains(',') && !d.starts_with('[') {
            format!("[{d}]")
        } else {
            d.to_string()
        };
        let default: toml_edit::Value = match d.parse::<toml_edit::Value>() {
            Ok(v @ (toml_edit::Value::Float(_) | toml_edit::Value::Integer(_))) => v,
            Ok(toml_edit::Value::Array(a))
                if (2..=3).contains(&a.len())
                    && a.iter()
                        .all(|x| matches!(x, toml_edit::Value::Float(_) | toml_edit::Value::Integer(_))) =>
            {
                toml_edit::Value::Array(a)
            }
            _ => {
                return Err(FieldError {
                    field,
                    message: format!("`{name}`'s default: expected a number, or 2 or 3 numbers such as `0, 1, 0`"),
                })
            }
        };
        let (lo, hi) = (row.min.trim(), row.max.trim());
        let value = if lo.is_empty() && hi.is_empty() {
            default
        } else {
            if lo.is_empty() || hi.is_empty() {
                return Err(FieldError {
                    field,
                    message: format!("`{name}`'s range: give both ends, or neither"),
                });
            }
            let lo = number(lo, field, &format!("`{name}`'s range"))?;
            let hi = number(hi, field, &format!("`{name}`'s range"))?;
            let mut spec = toml_edit::InlineTable::new();
            spec.insert("default", default);
            spec.insert("range", toml_edit::Value::Array(toml_edit::Array::from_iter([lo, hi])));
            toml_edit::Value::InlineTable(spec)
        };
        table.insert(name, value);
    }
    Ok(table)
}

/// Whether two TOML values hold the same data (whatever their layout,
/// quoting or comments).
fn same_value(a: &toml_edit::Value, b: &toml_edit::Value) -> bool {
    use toml_edit::Value as V;
    let num = |v: &V| match v {
        V::Float(f) => Some(*f.value()),
        V::Integer(i) => Some(*i.value() as f64),
        _ => None,
    };
    match (a, b) {
        (V::String(x), V::String(y)) => x.value() == y.value(),
        (V::Boolean(x), V::Boolean(y)) => x.value() == y.value(),
        (V::Array(x), V::Array(y)) => x.len() == y.len() && x.iter().zip(y.iter()).all(|(p, q)| same_value(p, q)),
        (V::InlineTable(x), V::InlineTable(y)) => {
            x.len() == y.len()
                && x.iter()
                    .zip(y.iter())
                    .all(|((k, p), (l, q))| k == l && same_value(p, q))
        }
        _ => num(a).zip(num(b)).is_some_and(|(p, q)| p == q),
    }
}

/// A string value for shape text: multi-line text as a `'''` literal
/// (as people write bodies by hand), anything else as a basic string.
fn text_value(s: &str) -> toml_edit::Value {
    if s.contains('\n') && !s.contains("'''") && !s.ends_with('\'') {
        if let Ok(v) = format!("'''\n{s}'''").parse::<toml_edit::Value>() {
            return v;
        }
    }
    toml_edit::Value::from(s)
}

/// `text` with every call `old(` renamed `new(` (identifiers followed by
/// an opening parenthesis; comments and the rest untouched), and how many
/// it renamed. Text that does not lex is left as it is.
pub fn rename_calls(text: &str, old: &str, new: &str) -> (String, usize) {
    use isoray_shape::syntax::{lex, Tok};
    let Ok(tokens) = lex(text, 0) else {
        return (text.to_string(), 0);
    };
    let mut out = String::with_capacity(text.len());
    let mut at = 0;
    let mut n = 0;
    for w in tokens.windows(2) {
        if matches!(&w[0].tok, Tok::Ident(s) if s == old) && w[1].tok == Tok::Punct('(') {
            out.push_str(&text[at..w[0].span.start]);
            out.push_str(new);
            at = w[0].span.end;
            n += 1;
        }
    }
    out.push_str(&text[at..]);
    (out, n)
}

/// Renames the calls of surface `old` to `new` in every object's `shape`
/// and every other surface's `sdf` body of `doc`; returns how many.
fn rename_in(doc: &mut toml_edit::DocumentMut, old: &str, new: &str) -> usize {
    let mut n = 0;
    let mut rename = |item: Option<&mut toml_edit::Item>| {
        let Some(v) = item.and_then(|i| i.as_value_mut()) else {
            return;
        };
        let Some(s) = v.as_str() else { return };
        let (renamed, k) = rename_calls(s, old, new);
        if k > 0 {
            let decor = v.decor().clone();
            *v = text_value(&renamed);
            *v.decor_mut() = decor;
            n += k;
        }
    };
    if let Some(objects) = doc.get_mut("object").and_then(|o| o.as_array_of_tables_mut()) {
        for o in objects.iter_mut() {
            rename(o.get_mut("shape"));
        }
    }
    if let Some(surfaces) = doc.get_mut("surface").and_then(|s| s.as_table_like_mut()) {
        for (name, s) in surfaces.iter_mut() {
            if name.get() != old && name.get() != new {
                if let Some(t) = s.as_table_like_mut() {
                    rename(t.get_mut("sdf"));
                }
            }
        }
    }
    n
}

/// How many calls of `old` the objects and other surfaces of `text` make
/// (what a rename would update).
pub fn calls_of(text: &str, old: &str) -> usize {
    let Ok(mut doc) = text.parse::<toml_edit::DocumentMut>() else {
        return 0;
    };
    rename_in(&mut doc, old, old)
}

/// The keys the dialog writes; the others (`material`, …) stay as they were.
const FORM_KEYS: [&str; 8] = [
    "params",
    "sdf",
    "implicit",
    "parametric",
    "domain",
    "image_only",
    "bound",
    "lipschitz_factor",
];

/// The form's keys and values, checked field by field.
fn form_values(form: &SurfaceForm) -> Result<Vec<(&'static str, toml_edit::Value)>, FieldError> {
    let mut out = Vec::new();
    let params = params_value(&form.params)?;
    if !params.is_empty() {
        out.push(("params", toml_edit::Value::InlineTable(params)));
    }
    match form.mode {
        Mode::Sdf | Mode::Implicit => out.push((form.mode.key(), text_value(&form.body))),
        Mode::Parametric => {
            let mut c = toml_edit::InlineTable::new();
            for (k, v) in ["x", "y", "z"].iter().zip(&form.coords) {
                c.insert(*k, v.as_str().into());
            }
            out.push(("parametric", toml_edit::Value::InlineTable(c)));
            if form.domain.iter().flatten().any(|e| !e.trim().is_empty()) {
                let mut d = toml_edit::InlineTable::new();
                for (i, k) in ["s", "t"].iter().enumerate() {
                    let mut ends = Vec::new();
                    for (j, fallback) in ["-1.0", "1.0"].iter().enumerate() {
                        let e = form.domain[i][j].trim();
                        let e = if e.is_empty() { fallback } else { e };
                        ends.push(number(e, Field::Domain(i), &format!("the domain of {k}"))?);
                    }
                    d.insert(*k, toml_edit::Value::Array(toml_edit::Array::from_iter(ends)));
                }
                out.push(("domain", toml_edit::Value::InlineTable(d)));
            }
            if form.image_only {
                out.push(("image_only", true.into()));
            }
        }
    }
    if form.mode != Mode::Sdf {
        if !form.bound.trim().is_empty() {
            out.push(("bound", form.bound.trim().into()));
        }
        if !form.lipschitz_factor.trim().is_empty() {
            out.push((
                "lipschitz_factor",
                number(&form.lipschitz_factor, Field::LipschitzFactor, "lipschitz_factor")?,
            ));
        }
    }
    Ok(out)
}

/// The file's text with the form's surface written in (replacing the one
/// it was opened from, and renaming its calls if the name changed), or the
/// field that cannot be written.
pub fn candidate(text: &str, form: &SurfaceForm) -> Result<String, FieldError> {
    let name = form.name.trim();
    if !is_ident(name) {
        return Err(FieldError {
            field: Field::Name,
            message: "a surface's name is an identifier: letters, digits and `_`, not starting with a digit".into(),
        });
    }
    let mut doc: toml_edit::DocumentMut = text.parse().map_err(|e: toml_edit::TomlError| FieldError {
        field: Field::Other,
        message: format!("the scene is not valid TOML: {}", e.message()),
    })?;
    let taken = doc.get("surface").and_then(|s| s.get(name)).is_some();
    if form.original.as_deref() != Some(name) && taken {
        return Err(FieldError {
            field: Field::Name,
            message: format!("the scene already has a surface named `{name}`"),
        });
    }
    let mut fresh = form_values(form)?;
    let surfaces = doc
        .entry("surface")
        .or_insert_with(|| {
            let mut s = toml_edit::Table::new();
            s.set_implicit(true);
            toml_edit::Item::Table(s)
        })
        .as_table_mut()
        .ok_or_else(|| FieldError {
            field: Field::Other,
            message: "`surface` in the file is not a table".into(),
        })?;
    let mut t = toml_edit::Table::new();
    if let Some(old) = form.original.as_deref().and_then(|o| surfaces.remove(o)) {
        if let Some(old) = old.as_table() {
            // The comments above the table and its place in the file stay,
            // and so do its keys' order and the text of unchanged values.
            *t.decor_mut() = old.decor().clone();
            if let Some(at) = old.position() {
                t.set_position(Some(at));
            }
            for (k, item) in old.iter() {
                if !FORM_KEYS.contains(&k) {
                    t.insert(k, item.clone());
                } else if let Some(i) = fresh.iter().position(|(f, _)| *f == k) {
                    let (_, v) = fresh.remove(i);
                    let unchanged = item.as_value().is_some_and(|o| same_value(o, &v));
                    t.insert(
                        k,
                        if unchanged {
                            item.clone()
                        } else {
                            toml_edit::Item::Value(v)
                        },
                    );
                }
            }
        }
    }
    for (k, v) in fresh {
        t.insert(k, toml_edit::Item::Value(v));
    }
    surfaces.insert(name, toml_edit::Item::Table(t));
    if let Some(old) = form.original.as_deref().filter(|o| *o != name) {
        rename_in(&mut doc, old, name);
    }
    Ok(doc.to_string())
}

/// The index of parameter `param` in surface `name`'s `params` of `text`.
fn param_index(text: &str, name: &str, param: &str) -> Option<usize> {
    let doc = toml_edit::Document::parse(text).ok()?;
    let params = doc.get("surface")?.get(name)?.get("params")?.as_table_like()?;
    let at = params.iter().position(|(k, _)| k == param);
    at
}

/// The field of `form` whose value in the candidate text `text` contains
/// byte `at` (an error's location).
pub fn field_at(text: &str, name: &str, at: usize) -> Field {
    let Ok(doc) = toml_edit::Document::parse(text) else {
        return Field::Other;
    };
    let Some(t) = doc
        .get("surface")
        .and_then(|s| s.get(name))
        .and_then(|t| t.as_table_like())
    else {
        return Field::Other;
    };
    let inside = |s: Option<std::ops::Range<usize>>| s.is_some_and(|s| s.start <= at && at <= s.end);
    let contains = |item: &toml_edit::Item| inside(item.span());
    // The entry of an inline table whose key or value contains `at`.
    let entry = |item: &toml_edit::Item| {
        let c = item.as_table_like()?;
        c.iter()
            .position(|(k, v)| contains(v) || c.get_key_value(k).is_some_and(|(key, _)| inside(key.span())))
    };
    for (key, item) in t.iter() {
        let inner = entry(item);
        match (key, inner) {
            ("parametric", Some(i)) => {
                let k = item.as_table_like().and_then(|c| c.iter().nth(i)).map(|(k, _)| k);
                return Field::Coord(["x", "y", "z"].iter().position(|c| Some(*c) == k).unwrap_or(0));
            }
            ("params", Some(i)) => return Field::Param(i),
            ("domain", Some(i)) => {
                let k = item.as_table_like().and_then(|c| c.iter().nth(i)).map(|(k, _)| k);
                return Field::Domain(usize::from(k == Some("t")));
            }
            _ => {}
        }
        if contains(item) {
            return match key {
                "sdf" | "implicit" => Field::Body,
                "params" => Field::Params,
                "bound" => Field::Bound,
                "parametric" => Field::Coord(0),
                "domain" => Field::Domain(0),
                "image_only" => Field::ImageOnly,
                "lipschitz_factor" => Field::LipschitzFactor,
                _ => Field::Other,
            };
        }
    }
    Field::Other
}

/// Where an error of the loader belongs in the form.
pub fn place_error(text: &str, name: &str, e: &SceneError) -> FieldError {
    let key_field = e.key.as_deref().and_then(|k| {
        let rest = k.strip_prefix(&format!("surface.{name}."))?;
        let mut parts = rest.split('.');
        Some(match (parts.next().unwrap_or(""), parts.next()) {
            ("sdf" | "implicit", _) => Field::Body,
            ("params", Some(p)) => param_index(text, name, p).map_or(Field::Params, Field::Param),
            // The whole table: the span may say which parameter.
            ("params", None) => return None,
            ("bound", _) => Field::Bound,
            ("parametric", Some("y")) => Field::Coord(1),
            ("parametric", Some("z")) => Field::Coord(2),
            ("parametric", _) => Field::Coord(0),
            ("domain", Some("t")) => Field::Domain(1),
            ("domain", _) => Field::Domain(0),
            ("image_only", _) => Field::ImageOnly,
            ("lipschitz_factor", _) => Field::LipschitzFactor,
            _ => Field::Other,
        })
    });
    // An error on the table's header (`[surface.NAME]`) is about the name.
    let on_header = e.span.is_some_and(|s| {
        let line_start = text[..s.start.min(text.len())].rfind('\n').map_or(0, |i| i + 1);
        text.get(s.start..s.end) == Some(name) && text[line_start..].starts_with("[surface.")
    });
    let field = if on_header {
        Field::Name
    } else {
        key_field
            .or_else(|| e.span.map(|s| field_at(text, name, s.start)))
            .unwrap_or(Field::Other)
    };
    FieldError {
        field,
        message: e.message.clone(),
    }
}

/// What a finished check found.
#[derive(Debug, Clone)]
pub enum Outcome {
    /// The surface loads; for implicit and parametric ones, what
    /// `isoray surface` prints (the equation, its degree, the bound).
    Valid(String),
    /// It does not: the error, at its field.
    Invalid(FieldError),
    /// Cancelled before it finished.
    Cancelled,
}

/// What a check has so far.
#[derive(Debug, Clone, Default)]
pub struct Status {
    /// How far the load got (0 to 1, where the loader reports progress).
    pub progress: f64,
    /// The outcome, once the load finished.
    pub outcome: Option<Outcome>,
    /// The surface alone, rendered once it loads: RGBA bytes at
    /// [`PREVIEW`] (None while rendering, or when it did not load).
    pub preview: Option<Arc<Vec<u8>>>,
    /// The check's thread has ended.
    pub finished: bool,
}

type Shared = Arc<Mutex<Status>>;

fn lock(s: &Shared) -> std::sync::MutexGuard<'_, Status> {
    s.lock().unwrap_or_else(|e| e.into_inner())
}

/// A background load of a candidate text, then a render of the surface.
pub struct Check {
    /// The text being checked.
    pub text: String,
    cancel: CancelToken,
    state: Shared,
}

struct Fraction(Shared, Arc<dyn Fn() + Send + Sync>);

impl Progress for Fraction {
    fn update(&self, done: u64, total: u64) {
        if total > 0 {
            lock(&self.0).progress = done as f64 / total as f64;
            (self.1)();
        }
    }
}

impl Check {
    /// Starts loading `text` (read as the file `file`) and describing the
    /// surface `name`, then rendering it alone; `analyses` is the
    /// document's cache of implicitizations (a surface already derived is
    /// not derived again); `wake` is called on progress and at the end.
    pub fn start(
        text: String,
        file: String,
        name: String,
        analyses: Option<isoray_shape::Analyses>,
        wake: impl Fn() + Send + Sync + 'static,
    ) -> Check {
        let cancel = CancelToken::new();
        let state: Shared = Arc::default();
        let (t, c, s) = (text.clone(), cancel.clone(), state.clone());
        std::thread::spawn(move || {
            let wake: Arc<dyn Fn() + Send + Sync> = Arc::new(wake);
            let options = isoray_scene::LoadOptions {
                cancel: Some(c.clone()),
                analyses: analyses.clone(),
                progress: Some(Arc::new(Fraction(s.clone(), wake.clone()))),
                ..Default::default()
            };
            let outcome = match isoray_scene::load_str_with(&t, &file, &[], &options) {
                Ok(scene) => Outcome::Valid(describe(&scene, &name)),
                Err(e) if e.cancelled => Outcome::Cancelled,
                Err(e) => Outcome::Invalid(place_error(&t, &name, &e)),
            };
            let valid = matches!(outcome, Outcome::Valid(_));
            lock(&s).outcome = Some(outcome);
            wake();
            if valid {
                if let Some(rgba) = preview(&t, &file, &name, analyses, &c) {
                    lock(&s).preview = Some(Arc::new(rgba));
                }
            }
            lock(&s).finished = true;
            wake();
        });
        Check { text, cancel, state }
    }

    /// Stops the check.
    pub fn cancel(&self) {
        self.cancel.cancel();
    }

    /// What it has so far.
    pub fn status(&self) -> Status {
        lock(&self.state).clone()
    }

    /// Waits for the outcome (for tests and scripts).
    pub fn wait(&self) -> Outcome {
        loop {
            if let Some(o) = self.status().outcome {
                return o;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }

    /// Waits until the check has finished, preview included, and returns
    /// the preview (None if the surface does not load or the check was
    /// cancelled).
    pub fn wait_preview(&self) -> Option<Arc<Vec<u8>>> {
        loop {
            let s = self.status();
            if s.finished {
                return s.preview;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }
}

/// Surface `name` of the scene `text` rendered alone, `name(p)` as the only
/// object (its own material if it names one), through the scene's camera
/// and lights at [`PREVIEW`], one sample per pixel.
pub fn preview(
    text: &str,
    file: &str,
    name: &str,
    analyses: Option<isoray_shape::Analyses>,
    cancel: &CancelToken,
) -> Option<Vec<u8>> {
    let own_material = toml_edit::Document::parse(text)
        .ok()
        .and_then(|d| d.get("surface")?.get(name)?.get("material").map(|_| ()))
        .is_some();
    let scene =
        crate::graph::thumbs::scene_of_shape(text, file, &format!("{name}(p)"), PREVIEW, !own_material, analyses)?;
    let opts = isoray_render::RenderOptions {
        cancel: Some(cancel.clone()),
        ..Default::default()
    };
    let (img, _) = isoray_render::render_with(&scene, &opts).ok()?;
    Some(crate::preview::rgba(&img.color))
}

/// What `isoray surface SCENE NAME` prints for the loaded scene.
pub fn describe(scene: &isoray_scene::Scene, name: &str) -> String {
    let lib = &scene.library;
    let Some(s) = lib.surface(name) else {
        return String::new();
    };
    if s.mode == isoray_shape::SurfaceMode::Sdf {
        return "the signed distance as written".into();
    }
    match lib.default_analysis(name) {
        Some(Ok(a)) => isoray_shape::surface::describe(name, s, &a),
        Some(Err(d)) => d.message.clone(),
        None => String::new(),
    }
}
