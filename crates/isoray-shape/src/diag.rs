//! Source spans and located diagnostics.
//!
//! Every error the shape language reports carries the byte span of the
//! offending text inside the snippet it came from, and the id of that snippet.
//! The caller (the scene loader, the CLI) knows where each snippet lives in a
//! file and turns the span into `file:line:column` with [`render_snippet`].

use std::fmt;

/// A half-open byte range `start..end` inside one source snippet.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Span {
    /// First byte.
    pub start: usize,
    /// One past the last byte.
    pub end: usize,
}

impl Span {
    /// A span from `start` to `end`.
    pub fn new(start: usize, end: usize) -> Self {
        Span { start, end }
    }
    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span::new(self.start.min(other.start), self.end.max(other.end))
    }
}

/// Identifies which source snippet a span refers to (an object's shape, a
/// surface's body, ...). Assigned by whoever hands text to the compiler.
pub type SourceId = usize;

/// A located error in shape text.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// What went wrong, and what was expected.
    pub message: String,
    /// The snippet the span refers to.
    pub source: SourceId,
    /// Where in that snippet.
    pub span: Span,
    /// A short label printed under the caret.
    pub label: Option<String>,
    /// Extra lines of help.
    pub notes: Vec<String>,
}

impl Diagnostic {
    /// A diagnostic with a message at a span.
    pub fn new(source: SourceId, span: Span, message: impl Into<String>) -> Self {
        Diagnostic {
            message: message.into(),
            source,
            span,
            label: None,
            notes: Vec::new(),
        }
    }
    /// Adds a label under the caret.
    pub fn with_label(mut self, label: impl Into<String>) -> Self {
        self.label = Some(label.into());
        self
    }
    /// Adds a note line.
    pub fn with_note(mut self, note: impl Into<String>) -> Self {
        self.notes.push(note.into());
        self
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Diagnostic {}

/// 1-based line and column (in characters) of byte `offset` in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let mut line = 1;
    let mut line_start = 0;
    for (i, b) in text.bytes().enumerate() {
        if i >= offset {
            break;
        }
        if b == b'\n' {
            line += 1;
            line_start = i + 1;
        }
    }
    let col = text
        .get(line_start..offset)
        .map(|s| s.chars().count())
        .unwrap_or(offset - line_start)
        + 1;
    (line, col)
}

/// Renders `message` located at byte span `span` of `text` (the whole file),
/// in the familiar compiler layout:
///
/// ```text
/// error: cannot add `vec3` and `vec2`
///   --> scene.toml:12:19
///    |
/// 12 | shape = "sphere(p + vec2(1.0, 2.0), 1.0)"
///    |                 ^^^^^^^^^^^^^^^^^^^^ vec3 + vec2
/// ```
pub fn render_snippet(
    file: &str,
    text: &str,
    span: Span,
    message: &str,
    label: Option<&str>,
    notes: &[String],
) -> String {
    let (line, col) = line_col(text, span.start);
    let line_text = text.lines().nth(line - 1).unwrap_or("");
    let gutter = line.to_string().len();
    let pad = " ".repeat(gutter);
    let mut out = format!("error: {message}\n{pad}--> {file}:{line}:{col}\n{pad} |\n");
    out.push_str(&format!("{line} | {line_text}\n"));
    // Caret run: from col to the end of the span, clipped to this line.
    let line_start = span.start + 1 - col.min(span.start + 1);
    let caret_start: usize = text.get(line_start..span.start).map(|s| s.chars().count()).unwrap_or(0);
    let line_end = line_start + line_text.len();
    let span_end = span.end.clamp(span.start, line_end.max(span.start));
    let caret_len = text
        .get(span.start..span_end)
        .map(|s| s.chars().count())
        .unwrap_or(1)
        .max(1);
    let indent: String = line_text
        .chars()
        .take(caret_start)
        .map(|c| if c == '\t' { '\t' } else { ' ' })
        .collect();
    out.push_str(&format!("{pad} | {indent}{}", "^".repeat(caret_len)));
    if let Some(l) = label {
        out.push(' ');
        out.push_str(l);
    }
    out.push('\n');
    for n in notes {
        out.push_str(&format!("{pad} = {n}\n"));
    }
    out
}

/// Edit distance with adjacent transpositions (optimal string alignment),
/// for "did you mean" suggestions.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let w = b.len() + 1;
    let mut d = vec![0usize; (a.len() + 1) * w];
    for i in 0..=a.len() {
        for j in 0..=b.len() {
            d[i * w + j] = if i == 0 {
                j
            } else if j == 0 {
                i
            } else {
                let cost = usize::from(a[i - 1] != b[j - 1]);
                let mut v = (d[(i - 1) * w + j] + 1)
                    .min(d[i * w + j - 1] + 1)
                    .min(d[(i - 1) * w + j - 1] + cost);
                if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                    v = v.min(d[(i - 2) * w + j - 2] + 1);
                }
                v
            };
        }
    }
    d[a.len() * w + b.len()]
}

/// The closest candidate to `name`, if it is close enough to be a likely typo.
pub fn suggest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (edit_distance(name, c), c))
        .filter(|(d, c)| *d <= (name.len().max(c.len()) / 3).max(1))
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column() {
        let t = "ab\ncd\nef";
        assert_eq!(line_col(t, 0), (1, 1));
        assert_eq!(line_col(t, 4), (2, 2));
        assert_eq!(line_col(t, 6), (3, 1));
    }

    #[test]
    fn caret_under_span() {
        let t = "x = 1\nshape = \"foo(p)\"\n";
        let start = t.find("foo").unwrap();
        let r = render_snippet("s.toml", t, Span::new(start, start + 3), "unknown", Some("here"), &[]);
        assert!(r.contains("--> s.toml:2:10"), "{r}");
        assert!(r.contains("  |          ^^^ here"), "{r}");
    }

    #[test]
    fn suggestions() {
        assert_eq!(suggest("sphre", ["sphere", "box"]), Some("sphere"));
        assert_eq!(suggest("zzzz", ["sphere", "box"]), None);
        assert_eq!(suggest("widht", ["width", "height"]), Some("width"));
    }
}
