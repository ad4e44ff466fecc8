//! No input, however malformed, makes the compiler or evaluators panic.

use isoray_shape::{compile, Library};
use proptest::prelude::*;

const WORDS: &[&str] = &[
    "p",
    "p.x",
    "p.xz",
    "p.zyx",
    ".w",
    "sphere",
    "box",
    "torus",
    "smooth_union",
    "union",
    "round",
    "vec2",
    "vec3",
    "float",
    "let",
    "return",
    "q",
    "=",
    ";",
    ",",
    "(",
    ")",
    "+",
    "-",
    "*",
    "/",
    "1.0",
    "0",
    "1e40",
    "-0.0",
    "2.5",
    "length",
    "dot",
    "cross",
    "normalize",
    "mix",
    "clamp",
    "atan",
    "pow",
    "mod",
    "step",
    "smoothstep",
    "octahedron",
    "cone",
    "repeat",
    "rotate",
    "twist_y",
    "PI",
    "//",
    "/*",
    "*/",
    "\n",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    #[test]
    fn token_soup_never_panics(words in proptest::collection::vec(0..WORDS.len(), 0..40)) {
        let text: Vec<&str> = words.iter().map(|&i| WORDS[i]).collect();
        let text = text.join(" ");
        if let Ok(shape) = compile(&Library::new(), &text) {
            // Whatever compiles also evaluates, at ordinary and extreme points.
            for p in [[0.0, 0.0, 0.0], [1.0, -2.0, 3.0], [1e30, -1e30, f64::NAN]] {
                let _ = shape.eval(p);
            }
        }
    }

    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,80}") {
        let _ = compile(&Library::new(), &text);
    }
}
