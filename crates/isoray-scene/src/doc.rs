//! A located document tree: TOML values that remember where they were written
//! (a span in the scene file, or a `--set` override), so that every error can
//! point at its source.

use isoray_shape::Span;
use toml::de::{DeTable, DeValue};

/// Where a value came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// Bytes of the scene file.
    File(Span),
    /// The value part of the override with this index (`--set KEY=VALUE`).
    Override(usize),
    /// Not written anywhere (a default, or a table created by an override).
    Implicit,
}

/// A value of the document.
#[derive(Debug, Clone, PartialEq)]
pub enum Item {
    /// A table with keys in the order written.
    Table(Vec<Entry>),
    /// An array.
    Array(Vec<Located>),
    /// A string, with a map from each content byte to its byte in the file
    /// (for locating errors inside shape text); `map.len() == s.len() + 1`.
    Str(String, Vec<usize>),
    /// A number (integers are converted to f64; `is_int` remembers which).
    Num(f64, bool),
    /// A boolean.
    Bool(bool),
    /// A date or time (no scene key takes one).
    Other(&'static str),
}

/// A value with its origin.
#[derive(Debug, Clone, PartialEq)]
pub struct Located {
    /// The value.
    pub item: Item,
    /// Where it was written.
    pub origin: Origin,
}

/// A key of a table with its value.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// The key.
    pub key: String,
    /// Where the key was written.
    pub key_origin: Origin,
    /// The value.
    pub value: Located,
}

impl Item {
    /// The TOML type's name, for messages.
    pub fn type_name(&self) -> &'static str {
        match self {
            Item::Table(_) => "a table",
            Item::Array(_) => "an array",
            Item::Str(..) => "a string",
            Item::Num(_, true) => "an integer",
            Item::Num(_, false) => "a float",
            Item::Bool(_) => "a boolean",
            Item::Other(t) => t,
        }
    }
}

/// The value at a dotted key (`camera.fov`, `light.0.intensity`,
/// `object.2.position.1`): tables are entered by key, arrays by index.
pub fn find<'a>(entries: &'a [Entry], key: &str) -> Option<&'a Located> {
    let mut parts = key.split('.');
    let first = parts.next()?;
    let mut at = &entries.iter().rev().find(|e| e.key == first)?.value;
    for part in parts {
        at = match &at.item {
            Item::Table(es) => &es.iter().rev().find(|e| e.key == part)?.value,
            Item::Array(items) => items.get(part.parse::<usize>().ok()?)?,
            _ => return None,
        };
    }
    Some(at)
}

fn span(r: std::ops::Range<usize>) -> Span {
    Span::new(r.start, r.end)
}

/// Converts a parsed TOML table into a located tree. `text` is the file.
pub fn from_toml(table: &DeTable<'_>, text: &str) -> Vec<Entry> {
    table
        .iter()
        .map(|(k, v)| Entry {
            key: k.get_ref().to_string(),
            key_origin: Origin::File(span(k.span())),
            value: convert(v.get_ref(), span(v.span()), text, Origin::File(span(v.span()))),
        })
        .collect()
}

/// Converts one value; `origin` is given to it and to its children
/// (children parsed from the file carry their own spans).
pub fn convert(v: &DeValue<'_>, sp: Span, text: &str, origin: Origin) -> Located {
    let child_origin = |s: Span| match origin {
        Origin::File(_) => Origin::File(s),
        o => o,
    };
    let item = match v {
        DeValue::String(s) => {
            let map = match origin {
                Origin::File(_) => string_map(text, sp, s.len()),
                _ => (0..=s.len()).collect(),
            };
            Item::Str(s.to_string(), map)
        }
        DeValue::Integer(i) => {
            let digits: String = i.as_str().chars().filter(|c| *c != '_').collect();
            let v = i64::from_str_radix(
                digits
                    .trim_start_matches("0x")
                    .trim_start_matches("0o")
                    .trim_start_matches("0b"),
                i.radix(),
            )
            .map(|v| v as f64)
            .unwrap_or(f64::NAN);
            Item::Num(v, true)
        }
        DeValue::Float(f) => {
            let s: String = f.as_str().chars().filter(|c| *c != '_').collect();
            Item::Num(s.parse().unwrap_or(f64::NAN), false)
        }
        DeValue::Boolean(b) => Item::Bool(*b),
        DeValue::Datetime(_) => Item::Other("a date-time"),
        DeValue::Array(a) => Item::Array(
            a.iter()
                .map(|e| {
                    let s = span(e.span());
                    convert(e.get_ref(), s, text, child_origin(s))
                })
                .collect(),
        ),
        DeValue::Table(t) => Item::Table(
            t.iter()
                .map(|(k, e)| {
                    let s = span(e.span());
                    Entry {
                        key: k.get_ref().to_string(),
                        key_origin: child_origin(span(k.span())),
                        value: convert(e.get_ref(), s, text, child_origin(s)),
                    }
                })
                .collect(),
        ),
    };
    Located { item, origin }
}

/// Maps each byte of a TOML string's decoded content to its byte in `text`,
/// where `sp` is the span of the string token (quotes included).
/// Escapes map all their decoded bytes to the escape's first byte.
pub fn string_map(text: &str, sp: Span, content_len: usize) -> Vec<usize> {
    let raw = text.get(sp.start..sp.end).unwrap_or("");
    let fallback = || (0..=content_len).map(|i| sp.start + 1 + i).collect::<Vec<_>>();
    let (delim, literal) = if raw.starts_with("\"\"\"") {
        (3, false)
    } else if raw.starts_with("'''") {
        (3, true)
    } else if raw.starts_with('"') {
        (1, false)
    } else if raw.starts_with('\'') {
        (1, true)
    } else {
        return fallback();
    };
    if raw.len() < 2 * delim {
        return fallback();
    }
    let body = &raw[delim..raw.len() - delim];
    let base = sp.start + delim;
    let bytes = body.as_bytes();
    let mut map = Vec::with_capacity(content_len + 1);
    let mut i = 0;
    // A newline right after the opening delimiter of a multi-line string is trimmed.
    if delim == 3 {
        if body.starts_with("\r\n") {
            i = 2;
        } else if body.starts_with('\n') {
            i = 1;
        }
    }
    while i < bytes.len() {
        if !literal && bytes[i] == b'\\' {
            let next = bytes.get(i + 1).copied().unwrap_or(b' ');
            match next {
                b'u' | b'U' => {
                    let n = if next == b'u' { 4 } else { 8 };
                    let hex = body.get(i + 2..i + 2 + n).unwrap_or("0");
                    let ch = u32::from_str_radix(hex, 16)
                        .ok()
                        .and_then(char::from_u32)
                        .unwrap_or('?');
                    map.extend(std::iter::repeat_n(base + i, ch.len_utf8()));
                    i += 2 + n;
                }
                b' ' | b'\t' | b'\n' | b'\r' if delim == 3 => {
                    // Line-ending backslash: skip it and all following whitespace.
                    i += 1;
                    while i < bytes.len() && bytes[i].is_ascii_whitespace() {
                        i += 1;
                    }
                }
                _ => {
                    map.push(base + i);
                    i += 2;
                }
            }
        } else {
            map.push(base + i);
            i += 1;
        }
    }
    map.push(base + bytes.len());
    if map.len() != content_len + 1 {
        return fallback();
    }
    map
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str) {
        let t = DeTable::parse(text).unwrap();
        let entries = from_toml(t.get_ref(), text);
        let Item::Str(s, map) = &entries[0].value.item else {
            panic!()
        };
        // Every plain character of the content maps to the same character in the file.
        for (i, ch) in s.char_indices() {
            if ch.is_ascii_alphanumeric() && text.as_bytes()[map[i]] != b'\\' {
                assert_eq!(text.as_bytes()[map[i]] as char, ch, "{text:?} at {i}");
            }
        }
    }

    #[test]
    fn string_maps() {
        check("s = \"sphere(p, 1.0)\"");
        check("s = 'sphere(p, 1.0)'");
        check("s = \"a\\tb\\u0041c\"");
        check("s = \"\"\"\nlet r = 1.0;\nsphere(p, r)\"\"\"");
        check("s = '''\nlet r = 1.0;\r\nsphere(p, r)'''");
        check("s = \"\"\"a \\\n    b\"\"\"");
    }
}
