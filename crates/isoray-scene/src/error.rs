//! Scene errors: what went wrong, and exactly where.

use isoray_shape::diag::{line_col, render_snippet};
use isoray_shape::Span;

use crate::doc::Origin;

/// An error in a scene, located in its file or in a `--set` override.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{rendered}")]
pub struct SceneError {
    /// One line: what went wrong and what was expected.
    pub message: String,
    /// The file (or `--set`) the error is in.
    pub file: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// 1-based column, when known.
    pub column: Option<usize>,
    /// The full report with the offending line and a caret under it.
    pub rendered: String,
    /// True when the error is an I/O failure rather than bad input.
    pub io: bool,
    /// True when the load was cancelled (see `LoadOptions::cancel`).
    pub cancelled: bool,
    /// The dotted key the error is about (`render.aa`, `light.0.intensity`),
    /// when it is about one: for an editor to show the error at its field.
    pub key: Option<String>,
    /// The bytes of the file the error points at, when it points into it.
    pub span: Option<Span>,
    /// A short label for the place (shown under the caret).
    pub label: Option<String>,
    /// Notes and help lines.
    pub notes: Vec<String>,
}

impl SceneError {
    /// The error, about the dotted key `key`.
    pub fn with_key(mut self, key: impl Into<String>) -> SceneError {
        self.key = Some(key.into());
        self
    }
}

/// The texts errors can point into.
#[derive(Debug, Clone, PartialEq)]
pub struct Sources {
    /// The scene file's name as given.
    pub path: String,
    /// Its text.
    pub text: String,
    /// The `--set KEY=VALUE` overrides, in order.
    pub overrides: Vec<String>,
}

impl Sources {
    /// An error at `origin` (and, for file origins, a sub-span).
    pub fn error(
        &self,
        origin: Origin,
        message: impl Into<String>,
        label: Option<&str>,
        notes: &[String],
    ) -> SceneError {
        let message = message.into();
        match origin {
            Origin::File(span) => self.error_at(span, &message, label, notes),
            Origin::Override(i) => {
                let text = self.overrides.get(i).cloned().unwrap_or_default();
                let start = text.find('=').map(|e| e + 1).unwrap_or(0);
                let rendered = render_snippet(
                    &format!("--set #{}", i + 1),
                    &text,
                    Span::new(start, text.len()),
                    &message,
                    label,
                    notes,
                );
                SceneError {
                    message,
                    file: "--set".into(),
                    line: None,
                    column: Some(start + 1),
                    rendered: rendered.trim_end().to_string(),
                    io: false,
                    cancelled: false,
                    key: None,
                    span: None,
                    label: label.map(str::to_string),
                    notes: notes.to_vec(),
                }
            }
            Origin::Implicit => {
                let mut rendered = format!("error: {message}\n  --> {}", self.path);
                for n in notes {
                    rendered.push_str(&format!("\n   = {n}"));
                }
                SceneError {
                    message,
                    file: self.path.clone(),
                    line: None,
                    column: None,
                    rendered,
                    io: false,
                    cancelled: false,
                    key: None,
                    span: None,
                    label: label.map(str::to_string),
                    notes: notes.to_vec(),
                }
            }
        }
    }

    /// An error at a byte span of the file.
    pub fn error_at(&self, span: Span, message: &str, label: Option<&str>, notes: &[String]) -> SceneError {
        let (line, col) = line_col(&self.text, span.start);
        let rendered = render_snippet(&self.path, &self.text, span, message, label, notes);
        SceneError {
            message: message.to_string(),
            file: self.path.clone(),
            line: Some(line),
            column: Some(col),
            rendered: rendered.trim_end().to_string(),
            io: false,
            cancelled: false,
            key: None,
            span: Some(span),
            label: label.map(str::to_string),
            notes: notes.to_vec(),
        }
    }
}

impl SceneError {
    /// Bad input that belongs to no place in the file (a command-line value).
    pub fn usage(message: impl Into<String>) -> SceneError {
        let message = message.into();
        SceneError {
            rendered: format!("error: {message}"),
            message,
            file: String::new(),
            line: None,
            column: None,
            io: false,
            cancelled: false,
            key: None,
            span: None,
            label: None,
            notes: Vec::new(),
        }
    }

    /// An error reading or writing a file.
    pub fn io(path: &str, what: &str, err: &std::io::Error) -> SceneError {
        let message = format!("cannot {what} `{path}`: {err}");
        SceneError {
            rendered: format!("error: {message}"),
            message,
            file: path.to_string(),
            line: None,
            column: None,
            io: true,
            cancelled: false,
            key: None,
            span: None,
            label: None,
            notes: Vec::new(),
        }
    }
}
