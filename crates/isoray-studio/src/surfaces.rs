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
//! Save replaces the surface in the document as one undo step.

use std::sync::{Arc, Mutex};

use isoray_job::{CancelToken, Progress};
use isoray_scene::SceneError;

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
    /// `params`.
    Params,
    /// `bound`.
    Bound,
    /// Anything else (shown under the dialog).
    Other,
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
    /// `params` as an inline table's text (`{ r = 1.0 }`), or empty.
    pub params: String,
    /// `bound`, or empty for the default.
    pub bound: String,
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
            params: "{ r = 1.0 }".into(),
            bound: String::new(),
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
        let params_item = table.get("params");
        let params: Vec<String> = params_item
            .and_then(|p| p.as_table_like())
            .map(|p| p.iter().map(|(k, _)| k.to_string()).collect())
            .unwrap_or_default();
        let params_text = params_item
            .and_then(|p| p.as_value())
            .map(|v| v.to_string().trim().to_string())
            .unwrap_or_default();
        let input = match mode {
            Mode::Parametric => format!("({}, {}, {})", coords[0], coords[1], coords[2]),
            _ => body.trim().to_string(),
        };
        out.push(Row {
            name: name.to_string(),
            mode,
            params,
            input,
            form: SurfaceForm {
                name: name.to_string(),
                original: Some(name.to_string()),
                mode,
                body,
                coords,
                params: params_text,
                bound: string_of(&table, "bound").unwrap_or_default(),
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

/// The file's text with the form's surface written in (replacing the one
/// it was opened from), or the field that cannot be written.
pub fn candidate(text: &str, form: &SurfaceForm) -> Result<String, FieldError> {
    let name = form.name.trim();
    let ident = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !ident {
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
    let mut t = toml_edit::Table::new();
    if !form.params.trim().is_empty() {
        let v: toml_edit::Value = form.params.trim().parse().map_err(|_| FieldError {
            field: Field::Params,
            message: "expected an inline table of parameters, such as `{ r = 1.0, k = { default = 0.5, range = [0.0, 1.0] } }`".into(),
        })?;
        if !v.is_inline_table() {
            return Err(FieldError {
                field: Field::Params,
                message: "expected an inline table `{ name = default, … }`".into(),
            });
        }
        t.insert("params", toml_edit::Item::Value(v));
    }
    match form.mode {
        Mode::Sdf | Mode::Implicit => {
            t.insert(form.mode.key(), toml_edit::value(form.body.as_str()));
        }
        Mode::Parametric => {
            let mut c = toml_edit::InlineTable::new();
            for (k, v) in ["x", "y", "z"].iter().zip(&form.coords) {
                c.insert(*k, v.as_str().into());
            }
            t.insert("parametric", toml_edit::value(c));
        }
    }
    if !form.bound.trim().is_empty() {
        t.insert("bound", toml_edit::value(form.bound.trim()));
    }
    // Keys the dialog does not edit (material, domain, …) stay as they were.
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
    if let Some(old) = form.original.as_deref().and_then(|o| surfaces.remove(o)) {
        if let Some(old) = old.as_table() {
            // The comments above the table and its place in the file stay.
            *t.decor_mut() = old.decor().clone();
            if let Some(at) = old.position() {
                t.set_position(Some(at));
            }
            for (k, v) in old.iter() {
                if !matches!(k, "params" | "sdf" | "implicit" | "parametric" | "bound") {
                    t.insert(k, v.clone());
                }
            }
        }
    }
    surfaces.insert(name, toml_edit::Item::Table(t));
    Ok(doc.to_string())
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
    let contains = |item: &toml_edit::Item| item.span().is_some_and(|s| s.start <= at && at <= s.end);
    for (key, item) in t.iter() {
        if key == "parametric" {
            if let Some(c) = item.as_table_like() {
                for (i, k) in ["x", "y", "z"].iter().enumerate() {
                    if c.get(k).is_some_and(contains) {
                        return Field::Coord(i);
                    }
                }
            }
        }
        if contains(item) {
            return match key {
                "sdf" | "implicit" => Field::Body,
                "params" => Field::Params,
                "bound" => Field::Bound,
                "parametric" => Field::Coord(0),
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
        Some(match rest.split('.').next().unwrap_or("") {
            "sdf" | "implicit" => Field::Body,
            "params" => Field::Params,
            "bound" => Field::Bound,
            "parametric" => match rest {
                "parametric.y" => Field::Coord(1),
                "parametric.z" => Field::Coord(2),
                _ => Field::Coord(0),
            },
            _ => Field::Other,
        })
    });
    let field = key_field
        .or_else(|| e.span.map(|s| field_at(text, name, s.start)))
        .unwrap_or(Field::Other);
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

/// A background load of a candidate text.
pub struct Check {
    /// The text being checked.
    pub text: String,
    cancel: CancelToken,
    state: Arc<Mutex<(f64, Option<Outcome>)>>,
}

struct Fraction(Arc<Mutex<(f64, Option<Outcome>)>>, Box<dyn Fn() + Send + Sync>);

impl Progress for Fraction {
    fn update(&self, done: u64, total: u64) {
        if total > 0 {
            self.0.lock().unwrap_or_else(|e| e.into_inner()).0 = done as f64 / total as f64;
            (self.1)();
        }
    }
}

impl Check {
    /// Starts loading `text` (read as the file `file`) and describing the
    /// surface `name`; `wake` is called on progress and at the end.
    pub fn start(text: String, file: String, name: String, wake: impl Fn() + Send + Sync + 'static) -> Check {
        let cancel = CancelToken::new();
        let state = Arc::new(Mutex::new((0.0, None)));
        let (t, c, s) = (text.clone(), cancel.clone(), state.clone());
        std::thread::spawn(move || {
            let wake: Arc<dyn Fn() + Send + Sync> = Arc::new(wake);
            let w = wake.clone();
            let options = isoray_scene::LoadOptions {
                cancel: Some(c),
                progress: Some(Arc::new(Fraction(s.clone(), Box::new(move || w())))),
                ..Default::default()
            };
            let outcome = match isoray_scene::load_str_with(&t, &file, &[], &options) {
                Ok(scene) => Outcome::Valid(describe(&scene, &name)),
                Err(e) if e.cancelled => Outcome::Cancelled,
                Err(e) => Outcome::Invalid(place_error(&t, &name, &e)),
            };
            s.lock().unwrap_or_else(|e| e.into_inner()).1 = Some(outcome);
            wake();
        });
        Check { text, cancel, state }
    }

    /// Stops the check.
    pub fn cancel(&self) {
        self.cancel.cancel();
    }

    /// How far it got (0 to 1, where the loader reports progress) and its
    /// outcome once finished.
    pub fn status(&self) -> (f64, Option<Outcome>) {
        self.state.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// Waits for the outcome (for tests and scripts).
    pub fn wait(&self) -> Outcome {
        loop {
            if let (_, Some(o)) = self.status() {
                return o;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }
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
