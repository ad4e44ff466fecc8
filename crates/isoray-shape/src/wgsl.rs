//! WGSL for the shape IR: every operation's code, beside the operation
//! table it must match ([`apply_unary`](crate::ir::apply_unary) and
//! [`apply_binary`](crate::ir::apply_binary), the reference semantics), and
//! a [`Tape`] written as a WGSL function for the GPU renderer.
//!
//! The matches over [`UnOp`] and [`BinOp`] are exhaustive, so an operation
//! cannot be added to the IR without its WGSL. Where WGSL's built-in
//! differs from the reference (rounding halves to even, `sign` of ±0,
//! `min`/`max` with a NaN, `pow` of a negative base, `asin`/`acos`/`sqrt`/
//! `log` outside their domain, which WGSL leaves indeterminate), the code
//! calls a helper of [`PRELUDE`] that follows the reference.
//!
//! A tape's constants are written as literals (f32, rounded as the f32
//! evaluator rounds them); the values its [`Prologue`](crate::ir::Prologue)
//! computes from the inputs (parameters, time, placements) are read from a
//! storage buffer, so changing an input rewrites the buffer and never the
//! shader:
//!
//! ```
//! use isoray_shape::{ir::Builder, wgsl};
//! let mut b = Builder::new();
//! let (x, r) = (b.x(), b.input(1));
//! let d = b.sub(x, r);
//! let f = wgsl::emit_tape(&b.tape(d), "dist", "iso_in", 0);
//! assert!(f.code.contains("fn dist(p: vec3<f32>) -> f32"));
//! assert_eq!(f.uniform_slots.len(), 1); // r comes from iso_in[0]
//! ```

use crate::ir::{BinOp, Instr, Tape, UnOp};

/// WGSL helpers the emitted code calls (once per shader module).
pub const PRELUDE: &str = r#"// isoray: reference semantics of the shape IR in WGSL.
fn iso_nan() -> f32 { return bitcast<f32>(0x7fc00000u); }
fn iso_inf() -> f32 { return bitcast<f32>(0x7f800000u); }
fn iso_is_nan(x: f32) -> bool { return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u; }
// Halves away from zero (WGSL's round() takes halves to even); x − trunc(x) is exact.
fn iso_round(x: f32) -> f32 {
    let t = trunc(x);
    return select(t, t + sign(x), abs(x - t) >= 0.5);
}
// -1, 0 or 1; ±0 and NaN stay as they are.
fn iso_sign(x: f32) -> f32 { return select(select(x, -1.0, x < 0.0), 1.0, x > 0.0); }
// The other operand when one is NaN (IEEE minNum / maxNum).
fn iso_min(a: f32, b: f32) -> f32 { return select(select(min(a, b), a, iso_is_nan(b)), b, iso_is_nan(a)); }
fn iso_max(a: f32, b: f32) -> f32 { return select(select(max(a, b), a, iso_is_nan(b)), b, iso_is_nan(a)); }
fn iso_sqrt(x: f32) -> f32 { return select(sqrt(x), iso_nan(), x < 0.0); }
fn iso_ln(x: f32) -> f32 {
    if (x < 0.0 || iso_is_nan(x)) { return iso_nan(); }
    if (x == 0.0) { return -iso_inf(); }
    return log(x);
}
// Through atan2 (GPU asin/acos are coarse approximations); NaN outside [-1, 1].
fn iso_asin(x: f32) -> f32 {
    return select(iso_atan2(x, sqrt((1.0 - x) * (1.0 + x))), iso_nan(), abs(x) > 1.0 || iso_is_nan(x));
}
fn iso_acos(x: f32) -> f32 {
    return select(iso_atan2(sqrt((1.0 - x) * (1.0 + x)), x), iso_nan(), abs(x) > 1.0 || iso_is_nan(x));
}
fn iso_atan(x: f32) -> f32 { return select(atan(x), x, iso_is_nan(x)); }
// IEEE atan2 at zeros, infinities and NaN; WGSL's atan2 elsewhere.
fn iso_atan2(y: f32, x: f32) -> f32 {
    let pi = 3.14159265358979;
    if (iso_is_nan(x) || iso_is_nan(y)) { return iso_nan(); }
    let x_neg = bitcast<u32>(x) >= 0x80000000u;
    let y_sign = select(1.0, -1.0, bitcast<u32>(y) >= 0x80000000u);
    if (y == 0.0) { return select(y, y_sign * pi, x_neg); }
    if (x == 0.0) { return y_sign * pi * 0.5; }
    let xi = abs(x) == iso_inf();
    let yi = abs(y) == iso_inf();
    if (xi && yi) { return y_sign * select(pi * 0.25, pi * 0.75, x_neg); }
    if (yi) { return y_sign * pi * 0.5; }
    if (xi) { return select(y_sign * 0.0, y_sign * pi, x_neg); }
    return atan2(y, x);
}
// powf: x^0 = 1 and 1^y = 1 even for NaN; negative bases need whole
// exponents (odd ones keep the sign); signed zeros and infinities as IEEE pow.
fn iso_odd(b: f32) -> bool { return b == floor(b) && abs(b) < 16777216.0 && (i32(abs(b)) & 1) == 1; }
fn iso_pow(a: f32, b: f32) -> f32 {
    if (b == 0.0 || a == 1.0) { return 1.0; }
    if (iso_is_nan(a) || iso_is_nan(b)) { return iso_nan(); }
    if (b == 1.0) { return a; }
    let neg = bitcast<u32>(a) >= 0x80000000u;
    let odd = iso_odd(b);
    if (a == 0.0) {
        if (b < 0.0) { return select(iso_inf(), select(iso_inf(), -iso_inf(), neg), odd); }
        return select(0.0, a, odd);
    }
    if (a == -iso_inf()) {
        if (b < 0.0) { return select(0.0, -0.0, odd); }
        return select(iso_inf(), -iso_inf(), odd);
    }
    if (a == -1.0 && abs(b) == iso_inf()) { return 1.0; }
    let m = exp2(b * log2(abs(a)));
    if (!neg) { return m; }
    if (b != floor(b)) { return iso_nan(); }
    return select(m, -m, odd);
}
"#;

/// The WGSL of `op` applied to the expression `a`, following
/// [`apply_unary`](crate::ir::apply_unary).
pub fn unary(op: UnOp, a: &str) -> String {
    match op {
        UnOp::Neg => format!("-({a})"),
        UnOp::Abs => format!("abs({a})"),
        UnOp::Sqrt => format!("iso_sqrt({a})"),
        UnOp::Square => format!("({a}) * ({a})"),
        UnOp::Sin => format!("sin({a})"),
        UnOp::Cos => format!("cos({a})"),
        UnOp::Tan => format!("tan({a})"),
        UnOp::Asin => format!("iso_asin({a})"),
        UnOp::Acos => format!("iso_acos({a})"),
        UnOp::Atan => format!("iso_atan({a})"),
        UnOp::Exp => format!("exp({a})"),
        UnOp::Ln => format!("iso_ln({a})"),
        UnOp::Floor => format!("floor({a})"),
        UnOp::Round => format!("iso_round({a})"),
        UnOp::Sign => format!("iso_sign({a})"),
    }
}

/// The WGSL of `op` applied to the expressions `a` and `b`, following
/// [`apply_binary`](crate::ir::apply_binary).
pub fn binary(op: BinOp, a: &str, b: &str) -> String {
    match op {
        BinOp::Add => format!("({a}) + ({b})"),
        BinOp::Sub => format!("({a}) - ({b})"),
        BinOp::Mul => format!("({a}) * ({b})"),
        BinOp::Div => format!("({a}) / ({b})"),
        BinOp::Min => format!("iso_min({a}, {b})"),
        BinOp::Max => format!("iso_max({a}, {b})"),
        BinOp::Pow => format!("iso_pow({a}, {b})"),
        BinOp::Atan2 => format!("iso_atan2({a}, {b})"),
    }
}

/// A number as a WGSL f32 expression: the literal of its nearest f32
/// (which the f32 evaluator uses too), or a bit pattern for infinities and NaN.
pub fn literal(v: f64) -> String {
    let f = v as f32;
    if f.is_nan() {
        "iso_nan()".to_string()
    } else if f.is_infinite() {
        if f > 0.0 {
            "iso_inf()".to_string()
        } else {
            "(-iso_inf())".to_string()
        }
    } else if f == 0.0 && f.is_sign_negative() {
        "(-0.0f)".to_string()
    } else {
        // Rust prints the shortest decimal that reads back as this f32.
        let text = format!("{f:e}");
        if f < 0.0 {
            format!("({text}f)")
        } else {
            format!("{text}f")
        }
    }
}

/// A tape written as a WGSL function.
#[derive(Debug, Clone, PartialEq)]
pub struct WgslFunction {
    /// `fn NAME(p: vec3<f32>) -> f32 { … }`.
    pub code: String,
    /// For each element `k` of the function's part of the input buffer
    /// (`BUFFER[base + k]`), the tape slot whose prologue value goes there
    /// (see [`WgslFunction::fill`]).
    pub uniform_slots: Vec<u32>,
}

impl WgslFunction {
    /// The values of the function's part of the input buffer at the inputs
    /// `vars`: the tape's prologue run in f64, each value rounded to f32.
    pub fn fill(&self, tape: &Tape, vars: &[f64]) -> Vec<f32> {
        let mut scratch = Vec::new();
        let values: Vec<(usize, f64)> = tape.prologue().run(vars, &mut scratch).collect();
        self.uniform_slots
            .iter()
            .map(|&slot| {
                values
                    .iter()
                    .rev()
                    .find(|(s, _)| *s == slot as usize)
                    .map(|&(_, v)| v as f32)
                    .unwrap_or(f32::NAN)
            })
            .collect()
    }
}

/// Writes `tape` as `fn NAME(p: vec3<f32>) -> f32`, reading its
/// input-derived values from `BUFFER[base + k]` (a module-scope
/// `array<f32>` the caller declares). Each slot is a `var`; a lazy region
/// is an `if` that skips it where the tape would skip it.
pub fn emit_tape(tape: &Tape, name: &str, buffer: &str, base: u32) -> WgslFunction {
    let mut code = format!("fn {name}(p: vec3<f32>) -> f32 {{\n");
    let slots = tape.slots();
    let s = |k: u32| format!("s{k}");
    for k in 0..slots {
        code.push_str(&format!("    var s{k}: f32;\n"));
    }
    code.push_str("    s0 = p.x;\n    s1 = p.y;\n    s2 = p.z;\n");
    for &(slot, v) in tape.constants() {
        code.push_str(&format!("    s{slot} = {};\n", literal(v)));
    }
    let mut uniform_slots = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for &(_, slot) in tape.prologue().outputs() {
        if seen.insert(slot) {
            code.push_str(&format!(
                "    s{slot} = {buffer}[{}];\n",
                base + uniform_slots.len() as u32
            ));
            uniform_slots.push(slot);
        }
    }
    // Lazy regions: `Skip { c, len }` skips the next `len` instructions when c > 0.
    let instrs = tape.instrs();
    let mut ends: Vec<usize> = Vec::new();
    let mut depth = 1usize;
    for (k, ins) in instrs.iter().enumerate() {
        while ends.last() == Some(&k) {
            ends.pop();
            depth -= 1;
            code.push_str(&format!("{}}}\n", "    ".repeat(depth)));
        }
        let pad = "    ".repeat(depth);
        match *ins {
            Instr::Skip { c, len } => {
                code.push_str(&format!("{pad}if (!({} > 0.0)) {{\n", s(c)));
                ends.push(k + 1 + len as usize);
                depth += 1;
            }
            Instr::Unary { op, out, a } => {
                code.push_str(&format!("{pad}{} = {};\n", s(out), unary(op, &s(a))));
            }
            Instr::Binary { op, out, a, b } => {
                code.push_str(&format!("{pad}{} = {};\n", s(out), binary(op, &s(a), &s(b))));
            }
            Instr::Select { out, c, a, b } => {
                code.push_str(&format!(
                    "{pad}{} = select({}, {}, {} > 0.0);\n",
                    s(out),
                    s(b),
                    s(a),
                    s(c)
                ));
            }
        }
    }
    while ends.pop().is_some() {
        depth -= 1;
        code.push_str(&format!("{}}}\n", "    ".repeat(depth)));
    }
    code.push_str(&format!("    return s{};\n}}\n", tape.output()));
    WgslFunction { code, uniform_slots }
}
