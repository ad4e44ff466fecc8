//! The scene file being edited: its text, the scene it loads to, undo and
//! redo of every edit, and atomic saves.
//!
//! The studio edits the document, not a struct: every change is a list of
//! `KEY=VALUE` edits (the `--set` syntax) applied to the file's own text by
//! [`isoray_scene::edit_text`], so comments, key order and layout survive,
//! and `isoray render` of the saved file renders exactly what the studio
//! showed. Undo and redo restore whole texts, byte for byte.
//!
//! ```
//! use isoray_studio::Document;
//! let mut doc = Document::from_text("[render]\nwidth = 320 # small\n[[object]]\nshape = \"sphere(p, 1.0)\"\n", None).unwrap();
//! doc.apply(&["render.width=640".to_string()]).unwrap();
//! assert!(doc.text().contains("width = 640 # small"));
//! assert!(doc.is_modified());
//! doc.undo();
//! assert!(!doc.is_modified());
//! ```

use std::path::{Path, PathBuf};

use isoray_scene::{LoadOptions, Scene, SceneError};

/// Undo steps kept at most (older ones are dropped).
pub const UNDO_LIMIT: usize = 1000;

/// A scene file being edited.
#[derive(Debug, Clone)]
pub struct Document {
    /// Where it is saved; None for a new scene not yet saved.
    path: Option<PathBuf>,
    /// The text now.
    text: String,
    /// The text as last saved or opened (what is on disk).
    saved: String,
    /// The scene `text` loads to.
    scene: Scene,
    /// Earlier texts, the latest last.
    undo: Vec<String>,
    /// Texts undone, the latest undone last.
    redo: Vec<String>,
    /// Shared by every load of this document.
    caches: Caches,
}

/// The scene of a new document: a sphere on a plane under one light.
pub const NEW_SCENE: &str = r#"# A new isoray scene.

[camera]
position = [0.0, 2.0, 6.0]
target = [0.0, 0.5, 0.0]
fov = 40.0

[render]
width = 640
height = 400
aa = 2
shadows = "soft"
ao = true

[[light]]
kind = "directional"
direction = [-1.0, 2.0, 1.0]
size = 0.1

[material.floor]
diffuse = [0.6, 0.6, 0.6]

[material.red]
diffuse = [0.8, 0.2, 0.15]
specular = [0.5, 0.5, 0.5]
shininess = 40.0

[[object]]
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"
material = "floor"

[[object]]
shape = "sphere(p - vec3(0.0, 1.0, 0.0), 1.0)"
material = "red"
"#;

impl Document {
    /// A new, unsaved scene ([`NEW_SCENE`]).
    pub fn new_scene() -> Document {
        Document::from_text(NEW_SCENE, None).expect("the new scene loads")
    }

    /// Opens the scene file at `path`. A file that does not load is an
    /// error with the loader's located diagnostics.
    pub fn open(path: &Path) -> Result<Document, SceneError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(&name, "read", &e))?;
        Document::from_text(&text, Some(path))
    }

    /// A document of `text`, saved at `path` (None: not yet saved).
    pub fn from_text(text: &str, path: Option<&Path>) -> Result<Document, SceneError> {
        let caches = Caches::default();
        let scene = load(text, path, &caches)?;
        Ok(Document {
            caches,
            path: path.map(Path::to_path_buf),
            text: text.to_string(),
            saved: if path.is_some() {
                text.to_string()
            } else {
                String::new()
            },
            scene,
            undo: Vec::new(),
            redo: Vec::new(),
        })
    }

    /// The file's text now.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The scene the text loads to.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Where the document is saved (None: never saved).
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// The name shown in the title bar: the file name, or "untitled".
    pub fn title(&self) -> String {
        self.path
            .as_ref()
            .and_then(|p| p.file_name())
            .map_or("untitled".to_string(), |n| n.to_string_lossy().into_owned())
    }

    /// True when the text differs from the file on disk (a new document
    /// is modified once it has any edit).
    pub fn is_modified(&self) -> bool {
        if self.path.is_none() {
            return !self.undo.is_empty();
        }
        self.text != self.saved
    }

    /// Applies `KEY=VALUE` edits as one undo step. On an error (a key the
    /// scene does not have, a value out of range, a shape that does not
    /// compile) nothing changes and the error names the edit.
    pub fn apply(&mut self, edits: &[String]) -> Result<(), SceneError> {
        if edits.is_empty() {
            return Ok(());
        }
        let text = isoray_scene::edit_text(&self.text, &self.name(), edits)?;
        self.replace_text(text)
    }

    /// Replaces the whole text (a raw edit of the file) as one undo step;
    /// a text that does not load is an error and changes nothing.
    pub fn replace_text(&mut self, text: String) -> Result<(), SceneError> {
        if text == self.text {
            return Ok(());
        }
        let scene = load(&text, self.path.as_deref(), &self.caches)?;
        let old = std::mem::replace(&mut self.text, text);
        self.scene = scene;
        self.undo.push(old);
        if self.undo.len() > UNDO_LIMIT {
            self.undo.remove(0);
        }
        self.redo.clear();
        Ok(())
    }

    /// Applies `KEY=VALUE` edits and then a change to the file's TOML
    /// itself (tables the scene keys do not reach, such as `[studio]`), as
    /// one undo step. On an error nothing changes.
    pub fn edit_with(
        &mut self,
        edits: &[String],
        change: impl FnOnce(&mut toml_edit::DocumentMut),
    ) -> Result<(), SceneError> {
        let text = if edits.is_empty() {
            self.text.clone()
        } else {
            isoray_scene::edit_text(&self.text, &self.name(), edits)?
        };
        let mut doc = parse_toml(&text)?;
        change(&mut doc);
        self.replace_text(doc.to_string())
    }

    /// Appends an entry to the array of tables `array` (`light`,
    /// `object`, …) with `entries` (key, value as TOML text), as one undo
    /// step. The rest of the file, comments included, is untouched.
    pub fn push_table(&mut self, array: &str, entries: &[(&str, &str)]) -> Result<(), SceneError> {
        let mut doc = self.parsed()?;
        let mut table = toml_edit::Table::new();
        for (key, text) in entries {
            let value: toml_edit::Value = text
                .parse()
                .map_err(|_| SceneError::usage(format!("`{array}.{key}`: `{text}` is not a TOML value")))?;
            table.insert(key, toml_edit::Item::Value(value));
        }
        let root = doc.as_table_mut();
        if !root.contains_key(array) {
            root.insert(array, toml_edit::Item::ArrayOfTables(Default::default()));
        }
        let Some(list) = root.get_mut(array).and_then(|i| i.as_array_of_tables_mut()) else {
            return Err(SceneError::usage(format!(
                "`{array}` in the file is not an array of tables ([[{array}]])"
            )));
        };
        list.push(table);
        self.replace_text(doc.to_string())
    }

    /// Removes entry `index` of the array of tables `array`, as one undo step.
    pub fn remove_table(&mut self, array: &str, index: usize) -> Result<(), SceneError> {
        let mut doc = self.parsed()?;
        let list = doc.get_mut(array).and_then(|i| i.as_array_of_tables_mut());
        let n = list.as_ref().map_or(0, |l| l.len());
        match list {
            Some(l) if index < n => {
                l.remove(index);
                if l.is_empty() {
                    doc.remove(array);
                }
            }
            _ => {
                return Err(SceneError::usage(format!(
                    "the scene has {n} [[{array}]] entries: there is no `{array}.{index}`"
                )))
            }
        }
        self.replace_text(doc.to_string())
    }

    /// The text as a TOML document (it always parses: it loaded).
    fn parsed(&self) -> Result<toml_edit::DocumentMut, SceneError> {
        parse_toml(&self.text)
    }

    /// True when there is an edit to undo.
    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    /// True when there is an undone edit to redo.
    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    /// Returns to the text before the last edit; false when there is none.
    pub fn undo(&mut self) -> bool {
        let Some(prev) = self.undo.pop() else { return false };
        let now = std::mem::replace(&mut self.text, prev);
        self.redo.push(now);
        self.reload();
        true
    }

    /// Redoes the last undone edit; false when there is none.
    pub fn redo(&mut self) -> bool {
        let Some(next) = self.redo.pop() else { return false };
        let now = std::mem::replace(&mut self.text, next);
        self.undo.push(now);
        self.reload();
        true
    }

    /// Saves to the document's path, atomically: a failed save leaves the
    /// old file intact. A document never saved has no path: use [`Document::save_as`].
    pub fn save(&mut self) -> Result<PathBuf, SceneError> {
        let Some(path) = self.path.clone() else {
            return Err(SceneError::usage(
                "the scene has no file yet: save it as a new file".to_string(),
            ));
        };
        self.save_as(&path)
    }

    /// Saves to `path`, atomically, and makes it the document's path.
    pub fn save_as(&mut self, path: &Path) -> Result<PathBuf, SceneError> {
        isoray_scene::write_atomic(path, self.text.as_bytes())
            .map_err(|e| SceneError::io(&path.display().to_string(), "write", &e))?;
        if self.path.as_deref() != Some(path) {
            // Relative paths in the scene (environment maps) now resolve
            // from the new place.
            self.path = Some(path.to_path_buf());
            self.reload();
        }
        self.saved = self.text.clone();
        Ok(path.to_path_buf())
    }

    fn name(&self) -> String {
        self.path
            .as_ref()
            .map_or("untitled.toml".to_string(), |p| p.display().to_string())
    }

    /// The scene of the text with `overrides` (`KEY=VALUE` edits, as
    /// `--set` takes them) applied, loaded with this document's caches;
    /// the document does not change. The studio uses it for previews of
    /// edits in progress.
    pub fn variant(&self, overrides: &[String]) -> Result<Scene, SceneError> {
        load_with(&self.text, self.path.as_deref(), &self.caches, overrides)
    }

    /// The implicitizations this document's loads share (a handle: loads
    /// through it fill the same cache).
    pub fn analyses(&self) -> isoray_shape::Analyses {
        self.caches.analyses.clone()
    }

    /// Loads the scene again after undo or redo (texts on the stacks all
    /// loaded once; a file they name may have gone since, and then the
    /// scene stays as it was).
    fn reload(&mut self) {
        if let Ok(scene) = load(&self.text, self.path.as_deref(), &self.caches) {
            self.scene = scene;
        }
    }
}

/// `text` as a TOML document to edit.
fn parse_toml(text: &str) -> Result<toml_edit::DocumentMut, SceneError> {
    text.parse()
        .map_err(|e: toml_edit::TomlError| SceneError::usage(format!("the scene is not valid TOML: {}", e.message())))
}

/// Loads `text` as the scene file `path` (relative paths resolve from its
/// folder) or as an unsaved scene, reusing the analyses and compiled
/// objects of `caches` (so an edit recompiles only what it changed).
fn load(text: &str, path: Option<&Path>, caches: &Caches) -> Result<Scene, SceneError> {
    load_with(text, path, caches, &[])
}

/// [`load`] with `--set` overrides.
fn load_with(text: &str, path: Option<&Path>, caches: &Caches, overrides: &[String]) -> Result<Scene, SceneError> {
    let name = path.map_or("untitled.toml".to_string(), |p| p.display().to_string());
    let options = LoadOptions {
        analyses: Some(caches.analyses.clone()),
        objects: Some(caches.objects.clone()),
        ..Default::default()
    };
    isoray_scene::load_str_with(text, &name, overrides, &options)
}

/// What loads of one document share.
#[derive(Debug, Clone, Default)]
struct Caches {
    analyses: isoray_shape::Analyses,
    objects: isoray_scene::ObjectCache,
}
