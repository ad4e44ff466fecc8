//! fidget's `.vm` tape format, read as shape text.
//!
//! A `.vm` file (the format of fidget's and MPR's benchmark models) is one
//! clause per line, `NAME OPCODE ARGS...`, in SSA form: every clause names a
//! new value computed from constants, the coordinates and earlier clauses,
//! and the last clause is the output. `#` starts a comment. Each clause
//! becomes a `let` binding of shape text (section 4 of docs/SCENE.md), so a
//! model renders, meshes and compiles for the GPU like any other surface
//! body, and the IR builder shares and folds its values as usual.
//!
//! | opcode | shape text |
//! |---|---|
//! | `var-x`, `var-y`, `var-z` | `p.x`, `p.y`, `p.z` |
//! | `const C` | the number C |
//! | `add sub mul div` | `a + b`, `a - b`, `a * b`, `a / b` |
//! | `min max` | `min(a, b)`, `max(a, b)` |
//! | `neg square recip` | `-a`, `a * a`, `1.0 / a` |
//! | `sqrt abs sin cos tan asin acos atan exp floor ceil round` | the built-in of that name |
//! | `ln` | `log(a)` |
//! | `atan2` | `atan(a, b)` |
//! | `compare` | `sign(a - b)` (−1, 0 or 1) |
//! | `mod` | `mod(a, b)`: GLSL's, the same as fidget's Euclidean remainder for b > 0 |
//!
//! The logical opcodes `and`, `or` and `not` have no counterpart (shape text
//! has no conditionals) and are reported as such; any other opcode is an
//! error naming its line and column.
//!
//! ```
//! use isoray_shape::vm::vm_to_shape_text;
//! let text = vm_to_shape_text("# a unit circle\n_0 var-x\n_1 square _0\n_2 var-y\n_3 square _2\n_4 add _1 _3\n_5 sqrt _4\n_6 const 1\n_7 sub _5 _6\n").unwrap();
//! assert!(text.ends_with("v7\n"));
//! ```

use std::collections::HashMap;
use std::fmt::Write;

/// A problem in a `.vm` text, at a 1-based line and column.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("line {line}, column {column}: {message}")]
pub struct VmError {
    /// The line (from 1).
    pub line: usize,
    /// The column (from 1, in characters).
    pub column: usize,
    /// What is wrong and what was expected.
    pub message: String,
}

/// The opcodes understood, for error messages.
const KNOWN: &str = "var-x var-y var-z const add sub mul div min max neg square recip sqrt abs sin cos tan asin acos atan exp ln floor ceil round atan2 compare mod";

/// Writes an opcode's value from its operands' names.
type Writer = fn(&[String]) -> String;

/// How many operands an opcode takes and how it is written; `None` for an
/// unknown opcode.
fn form(op: &str) -> Option<(usize, Writer)> {
    Some(match op {
        "var-x" => (0, |_| "p.x".into()),
        "var-y" => (0, |_| "p.y".into()),
        "var-z" => (0, |_| "p.z".into()),
        "add" => (2, |a| format!("{} + {}", a[0], a[1])),
        "sub" => (2, |a| format!("{} - {}", a[0], a[1])),
        "mul" => (2, |a| format!("{} * {}", a[0], a[1])),
        "div" => (2, |a| format!("{} / {}", a[0], a[1])),
        "min" => (2, |a| format!("min({}, {})", a[0], a[1])),
        "max" => (2, |a| format!("max({}, {})", a[0], a[1])),
        "atan2" => (2, |a| format!("atan({}, {})", a[0], a[1])),
        "compare" => (2, |a| format!("sign({} - {})", a[0], a[1])),
        "mod" => (2, |a| format!("mod({}, {})", a[0], a[1])),
        "neg" => (1, |a| format!("-{}", a[0])),
        "square" => (1, |a| format!("{} * {}", a[0], a[0])),
        "recip" => (1, |a| format!("1.0 / {}", a[0])),
        "ln" => (1, |a| format!("log({})", a[0])),
        "sqrt" => (1, |a| format!("sqrt({})", a[0])),
        "abs" => (1, |a| format!("abs({})", a[0])),
        "sin" => (1, |a| format!("sin({})", a[0])),
        "cos" => (1, |a| format!("cos({})", a[0])),
        "tan" => (1, |a| format!("tan({})", a[0])),
        "asin" => (1, |a| format!("asin({})", a[0])),
        "acos" => (1, |a| format!("acos({})", a[0])),
        "atan" => (1, |a| format!("atan({})", a[0])),
        "exp" => (1, |a| format!("exp({})", a[0])),
        "floor" => (1, |a| format!("floor({})", a[0])),
        "ceil" => (1, |a| format!("ceil({})", a[0])),
        "round" => (1, |a| format!("round({})", a[0])),
        _ => return None,
    })
}

/// Translates a `.vm` text into shape text (`let` bindings `v0`, `v1`, …,
/// one per clause, and the last clause's value), or the first problem.
pub fn vm_to_shape_text(text: &str) -> Result<String, VmError> {
    let mut out = String::new();
    let mut names: HashMap<&str, usize> = HashMap::new();
    let mut last: Option<usize> = None;
    for (ln, line) in text.lines().enumerate() {
        let body = line.split('#').next().unwrap_or("");
        // Words with their 1-based character columns.
        let mut words: Vec<(usize, &str)> = Vec::new();
        let mut start: Option<usize> = None;
        for (i, c) in body.char_indices().chain(std::iter::once((body.len(), ' '))) {
            match (c.is_whitespace(), start) {
                (true, Some(s)) => {
                    words.push((s, &body[s..i]));
                    start = None;
                }
                (false, None) => start = Some(i),
                _ => {}
            }
        }
        if words.is_empty() {
            continue;
        }
        let err = |at: usize, message: String| VmError {
            line: ln + 1,
            column: body[..at].chars().count() + 1,
            message,
        };
        let end = body.trim_end().len();
        let (name_at, name) = words[0];
        let Some(&(op_at, op)) = words.get(1) else {
            return Err(err(
                end,
                format!("clause `{name}` has no opcode; expected `NAME OPCODE ARGS...`"),
            ));
        };
        if names.contains_key(name) {
            return Err(err(name_at, format!("`{name}` is defined twice (the format is SSA)")));
        }
        let k = names.len();
        let args = &words[2..];
        let value = if op == "const" {
            let [(at, c)] = args else {
                return Err(err(
                    op_at,
                    format!("`const` takes one number, found {} arguments", args.len()),
                ));
            };
            let v: f64 = c
                .parse()
                .map_err(|_| err(*at, format!("expected a number after `const`, found `{c}`")))?;
            if !v.is_finite() {
                return Err(err(*at, format!("the constant `{c}` is not finite")));
            }
            if v < 0.0 || (v == 0.0 && v.is_sign_negative()) {
                format!("-{:?}", -v)
            } else {
                format!("{v:?}")
            }
        } else {
            if matches!(op, "and" | "or" | "not") {
                return Err(err(
                    op_at,
                    format!("the logical opcode `{op}` is not supported (shape text has no conditionals)"),
                ));
            }
            let Some((arity, write)) = form(op) else {
                return Err(err(op_at, format!("unknown opcode `{op}`; expected one of {KNOWN}")));
            };
            if args.len() != arity {
                return Err(err(
                    op_at,
                    format!("`{op}` takes {arity} argument(s), found {}", args.len()),
                ));
            }
            let operands: Vec<String> = args
                .iter()
                .map(|&(at, a)| {
                    names
                        .get(a)
                        .map(|i| format!("v{i}"))
                        .ok_or_else(|| err(at, format!("`{a}` is not defined by an earlier clause")))
                })
                .collect::<Result<_, _>>()?;
            write(&operands)
        };
        names.insert(name, k);
        writeln!(out, "let v{k} = {value};").expect("writing to a string");
        last = Some(k);
    }
    let Some(last) = last else {
        return Err(VmError {
            line: text.lines().count().max(1),
            column: 1,
            message: "the file has no clauses; expected lines `NAME OPCODE ARGS...`".into(),
        });
    };
    writeln!(out, "v{last}").expect("writing to a string");
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clauses_become_bindings() {
        let t = vm_to_shape_text("_0 var-x\n_1 const -0.5\n_2 max _0 _1 # comment\n\n").unwrap();
        assert_eq!(t, "let v0 = p.x;\nlet v1 = -0.5;\nlet v2 = max(v0, v1);\nv2\n");
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = vm_to_shape_text("_0 var-x\n_1  frobnicate _0\n").unwrap_err();
        assert_eq!((e.line, e.column), (2, 5));
        assert!(e.message.contains("unknown opcode `frobnicate`"), "{e}");
        let e = vm_to_shape_text("_0 var-x\n_1 add _0 _9\n").unwrap_err();
        assert_eq!((e.line, e.column), (2, 11));
        assert!(e.message.contains("`_9` is not defined"), "{e}");
        let e = vm_to_shape_text("_0 const x1\n").unwrap_err();
        assert_eq!((e.line, e.column), (1, 10));
        let e = vm_to_shape_text("_0 var-x\n_1 sqrt _0 _0\n").unwrap_err();
        assert!(e.message.contains("takes 1 argument"), "{e}");
        let e = vm_to_shape_text("_0 var-x\n_0 var-y\n").unwrap_err();
        assert!(e.message.contains("defined twice"), "{e}");
        let e = vm_to_shape_text("_0 var-x\n_1 not _0\n").unwrap_err();
        assert!(e.message.contains("not supported"), "{e}");
        assert!(vm_to_shape_text("# nothing\n").is_err());
    }
}
