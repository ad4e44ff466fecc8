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

pub mod interval;

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

/// Where an emitted function reads its input-derived values: element k
/// of its part of the buffer is `BUFFER[base + k]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputBuffer<'a> {
    /// An `array<f32>` of that name (a storage buffer): `NAME[i]`.
    Floats(&'a str),
    /// An `array<vec4<f32>, N>` of that name, four values an element (a
    /// uniform buffer, whose arrays' elements are 16 bytes apart):
    /// `NAME[i / 4][i % 4]`. On lavapipe a storage-buffer read inside
    /// divergent control flow is a loop over the lanes, a uniform one a
    /// single load: the tracer's marching loops read their inputs this way.
    Vec4s(&'a str),
}

impl InputBuffer<'_> {
    /// The WGSL expression of element `i` of the buffer.
    pub fn read(&self, i: u32) -> String {
        match self {
            InputBuffer::Floats(name) => format!("{name}[{i}]"),
            InputBuffer::Vec4s(name) => format!("{name}[{}u][{}u]", i / 4, i % 4),
        }
    }
}

impl<'a> From<&'a str> for InputBuffer<'a> {
    fn from(name: &'a str) -> Self {
        InputBuffer::Floats(name)
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
/// `array<f32>` the caller declares; or, given an [`InputBuffer::Vec4s`],
/// a uniform `array<vec4<f32>, N>`). Each slot is a `var`; a lazy region
/// is an `if` that skips it where the tape would skip it.
pub fn emit_tape<'a>(tape: &Tape, name: &str, buffer: impl Into<InputBuffer<'a>>, base: u32) -> WgslFunction {
    emit(tape, name, buffer.into(), base, false)
}

/// Writes `tape`'s value and gradient by forward-mode automatic
/// differentiation as `fn NAME(p: vec3<f32>) -> vec4<f32>` (x the value,
/// yzw ∂/∂x, ∂/∂y, ∂/∂z), following the CPU's dual numbers
/// ([`Dual`](crate::eval::Dual)) rule for rule: the derivative of the
/// operand `min`/`max` returns, 0 for `floor`, `round` and `sign`, the
/// derivative of √ taken as 0 where √ is 0. It reads the same buffer
/// values as [`emit_tape`] (the same [`WgslFunction::uniform_slots`]).
///
/// ```
/// use isoray_shape::{ir::Builder, wgsl};
/// let mut b = Builder::new();
/// let (x, y) = (b.x(), b.y());
/// let d = b.mul(x, y);
/// let g = wgsl::emit_tape_dual(&b.tape(d), "grad", "iso_in", 0);
/// assert!(g.code.contains("fn grad(p: vec3<f32>) -> vec4<f32>"));
/// ```
pub fn emit_tape_dual<'a>(tape: &Tape, name: &str, buffer: impl Into<InputBuffer<'a>>, base: u32) -> WgslFunction {
    emit(tape, name, buffer.into(), base, true)
}

/// The derivative factor k of a unary operation (d(op a) = k·da) as WGSL,
/// with `a` the argument's value and `v` the result, as [`Dual`](crate::eval::Dual) has it.
fn unary_slope(op: UnOp, a: &str, v: &str) -> String {
    match op {
        UnOp::Neg => "-1.0".into(),
        UnOp::Abs => format!("select(1.0, -1.0, {a} < 0.0)"),
        UnOp::Sqrt => format!("select(0.0, 0.5 / {v}, {v} > 0.0)"),
        UnOp::Square => format!("2.0 * {a}"),
        UnOp::Sin => format!("cos({a})"),
        UnOp::Cos => format!("-sin({a})"),
        UnOp::Tan => format!("1.0 + {v} * {v}"),
        UnOp::Asin => format!("1.0 / sqrt(1.0 - {a} * {a})"),
        UnOp::Acos => format!("-1.0 / sqrt(1.0 - {a} * {a})"),
        UnOp::Atan => format!("1.0 / (1.0 + {a} * {a})"),
        UnOp::Exp => v.into(),
        UnOp::Ln => format!("1.0 / {a}"),
        UnOp::Floor | UnOp::Round | UnOp::Sign => "0.0".into(),
    }
}

/// The gradient of a binary operation as WGSL (a `vec3<f32>`), with `a`
/// and `b` the operands as dual `vec4`s and `v` the result's value.
fn binary_gradient(op: BinOp, a: &str, b: &str, v: &str) -> String {
    let lin = |ka: &str, kb: &str| format!("{a}.yzw * ({ka}) + {b}.yzw * ({kb})");
    match op {
        BinOp::Add => format!("{a}.yzw + {b}.yzw"),
        BinOp::Sub => format!("{a}.yzw - {b}.yzw"),
        BinOp::Mul => lin(&format!("{b}.x"), &format!("{a}.x")),
        BinOp::Div => lin(&format!("1.0 / {b}.x"), &format!("-{v} / {b}.x")),
        BinOp::Min => format!("select({a}.yzw, {b}.yzw, {b}.x < {a}.x || iso_is_nan({a}.x))"),
        BinOp::Max => format!("select({a}.yzw, {b}.yzw, {b}.x > {a}.x || iso_is_nan({a}.x))"),
        BinOp::Pow => lin(
            &format!("select({b}.x * iso_pow({a}.x, {b}.x - 1.0), 0.0, {b}.x == 0.0)"),
            &format!("select(0.0, {v} * iso_ln({a}.x), {a}.x > 0.0)"),
        ),
        BinOp::Atan2 => format!(
            "select(vec3<f32>(0.0), {}, {a}.x * {a}.x + {b}.x * {b}.x > 0.0)",
            lin(
                &format!("{b}.x / ({a}.x * {a}.x + {b}.x * {b}.x)"),
                &format!("-{a}.x / ({a}.x * {a}.x + {b}.x * {b}.x)"),
            )
        ),
    }
}

fn emit(tape: &Tape, name: &str, buffer: InputBuffer<'_>, base: u32, dual: bool) -> WgslFunction {
    let (ty, ret) = if dual {
        ("vec4<f32>", "vec4<f32>")
    } else {
        ("f32", "f32")
    };
    let mut code = format!("fn {name}(p: vec3<f32>) -> {ret} {{\n");
    let slots = tape.slots();
    let s = |k: u32| format!("s{k}");
    let val = |k: u32| if dual { format!("s{k}.x") } else { format!("s{k}") };
    let constant = |e: String| {
        if dual {
            format!("vec4<f32>({e}, 0.0, 0.0, 0.0)")
        } else {
            e
        }
    };
    for k in 0..slots {
        code.push_str(&format!("    var s{k}: {ty};\n"));
    }
    if dual {
        code.push_str(
            "    s0 = vec4<f32>(p.x, 1.0, 0.0, 0.0);\n    s1 = vec4<f32>(p.y, 0.0, 1.0, 0.0);\n    \
             s2 = vec4<f32>(p.z, 0.0, 0.0, 1.0);\n",
        );
    } else {
        code.push_str("    s0 = p.x;\n    s1 = p.y;\n    s2 = p.z;\n");
    }
    for &(slot, v) in tape.constants() {
        code.push_str(&format!("    s{slot} = {};\n", constant(literal(v))));
    }
    let (reads, uniform_slots) = buffer_reads(tape, buffer, base);
    for (slot, e) in reads {
        code.push_str(&format!("    s{slot} = {};\n", constant(e)));
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
                code.push_str(&format!("{pad}if (!({} > 0.0)) {{\n", val(c)));
                ends.push(k + 1 + len as usize);
                depth += 1;
            }
            Instr::Unary { op, out, a } if dual => {
                let v = unary(op, &val(a));
                let slope = unary_slope(op, "a.x", "v");
                code.push_str(&format!(
                    "{pad}{{ let a = {}; let v = {v}; {} = vec4<f32>(v, a.yzw * ({slope})); }}\n",
                    s(a),
                    s(out)
                ));
            }
            Instr::Binary { op, out, a, b } if dual => {
                let v = binary(op, "a.x", "b.x");
                let g = binary_gradient(op, "a", "b", "v");
                code.push_str(&format!(
                    "{pad}{{ let a = {}; let b = {}; let v = {v}; {} = vec4<f32>(v, {g}); }}\n",
                    s(a),
                    s(b),
                    s(out)
                ));
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
                    val(c)
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

/// The tape slots whose prologue values the function reads from the input
/// buffer, each with its WGSL expression `BUFFER[base + k]`, and the
/// [`WgslFunction::uniform_slots`] they make (one element per slot).
fn buffer_reads(tape: &Tape, buffer: InputBuffer<'_>, base: u32) -> (Vec<(u32, String)>, Vec<u32>) {
    let uniform_slots = input_slots(tape);
    let reads = (uniform_slots.iter().enumerate())
        .map(|(k, &slot)| (slot, buffer.read(base + k as u32)))
        .collect();
    (reads, uniform_slots)
}

/// The tape slots an emitted function reads from the input buffer, in
/// buffer order (its [`WgslFunction::uniform_slots`]): how many elements
/// of the buffer it takes.
pub fn input_slots(tape: &Tape) -> Vec<u32> {
    let mut seen = std::collections::HashSet::new();
    (tape.prologue().outputs().iter())
        .map(|&(_, slot)| slot)
        .filter(|&slot| seen.insert(slot))
        .collect()
}

/// The largest slot count a tape may have to run on [`interpreter`]
/// (each slot is a register of 16 bytes per lane in the caller's
/// register buffer).
pub const MAX_INTERPRETED_SLOTS: usize = 4096;

/// Opcode of the first binary operation (`32 + position in BINARY`);
/// unary operations are their position in [`UNARY`](crate::conformance::UNARY).
const BINARY_BASE: u32 = 32;
/// `out = c > 0 ? a : b` (operands c, a, b).
const OP_SELECT: u32 = 64;
/// Skip the next `len` instructions when c > 0 (operands c, len).
const OP_SKIP: u32 = 65;
/// `out = f32::from_bits(w1)`.
const OP_CONST: u32 = 66;
/// `out = INPUTS[w1]`.
const OP_INPUT: u32 = 67;

fn unary_code(op: UnOp) -> u32 {
    crate::conformance::UNARY
        .iter()
        .position(|&o| o == op)
        .expect("every unary operation is listed") as u32
}

fn binary_code(op: BinOp) -> u32 {
    BINARY_BASE
        + crate::conformance::BINARY
            .iter()
            .position(|&o| o == op)
            .expect("every binary operation is listed") as u32
}

/// A tape as the program of the WGSL [`interpreter`]: four words per
/// instruction (`op | out << 8`, then up to three operands), the constants
/// and the input-buffer reads first, then the tape's instructions one for one.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// The instructions, four words each.
    pub code: Vec<u32>,
    /// The slot holding the result.
    pub output: u32,
    /// Slots used (registers needed).
    pub slots: usize,
    /// As [`WgslFunction::uniform_slots`]: the tape slot whose prologue
    /// value goes to `INPUTS[base + k]`.
    pub uniform_slots: Vec<u32>,
}

impl Program {
    /// Instructions (four words each).
    pub fn len(&self) -> usize {
        self.code.len() / 4
    }

    /// True for a program of no instructions.
    pub fn is_empty(&self) -> bool {
        self.code.is_empty()
    }

    /// The program's part of the input buffer at the inputs `vars` (as [`WgslFunction::fill`]).
    pub fn fill(&self, tape: &Tape, vars: &[f64]) -> Vec<f32> {
        WgslFunction {
            code: String::new(),
            uniform_slots: self.uniform_slots.clone(),
        }
        .fill(tape, vars)
    }
}

/// Encodes `tape` for the [`interpreter`], its inputs read from
/// `INPUTS[base + k]`. None when it has more than
/// [`MAX_INTERPRETED_SLOTS`] slots.
pub fn encode_tape(tape: &Tape, base: u32) -> Option<Program> {
    if tape.slots() > MAX_INTERPRETED_SLOTS {
        return None;
    }
    let mut code = Vec::new();
    let mut put = |op: u32, out: u32, w: [u32; 3]| code.extend([op | out << 8, w[0], w[1], w[2]]);
    for &(slot, v) in tape.constants() {
        put(OP_CONST, slot, [(v as f32).to_bits(), 0, 0]);
    }
    let uniform_slots = input_slots(tape);
    for (k, &slot) in uniform_slots.iter().enumerate() {
        put(OP_INPUT, slot, [base + k as u32, 0, 0]);
    }
    for ins in tape.instrs() {
        match *ins {
            Instr::Skip { c, len } => put(OP_SKIP, 0, [c, len, 0]),
            Instr::Unary { op, out, a } => put(unary_code(op), out, [a, 0, 0]),
            Instr::Binary { op, out, a, b } => put(binary_code(op), out, [a, b, 0]),
            Instr::Select { out, c, a, b } => put(OP_SELECT, out, [c, a, b]),
        }
    }
    Some(Program {
        code,
        output: tape.output() as u32,
        slots: tape.slots(),
        uniform_slots,
    })
}

/// A WGSL interpreter of [`Program`]s read from the `array<u32>` named
/// `code` (the caller declares it and `inputs`, an `array<f32>`):
/// `fn iso_run(start: u32, len: u32, out: u32, p: vec3<f32>) -> f32` runs
/// the `len` instructions from word `start` on the point and returns slot
/// `out`; `iso_run_dual` does the same with dual numbers (value and
/// gradient, as [`emit_tape_dual`]). Every operation's case is written
/// from [`unary`] and [`binary`], the same code the compiled functions use.
///
/// The registers are the lane's slots of a read-write storage buffer the
/// caller declares, `iso_regs: array<vec4<f32>>`, from the private
/// `iso_reg_base: u32` the caller sets per lane (a program with `slots`
/// slots uses `iso_reg_base .. iso_reg_base + slots`; values use `.x`).
/// Not a private array: lavapipe compiles a private register file indexed
/// at run time slowly, and inside the tracer it gave wrong values.
pub fn interpreter(code: &str, inputs: &str) -> String {
    let r = |s: &str| format!("iso_regs[iso_reg_base + {s}]");
    let mut value_cases = Vec::new();
    let mut dual_cases = Vec::new();
    for &op in crate::conformance::UNARY {
        let k = unary_code(op);
        value_cases.push((k, format!("v = {};", unary(op, &format!("{}.x", r("a"))))));
        dual_cases.push((
            k,
            format!(
                "let x = {}; let v = {}; d = vec4<f32>(v, x.yzw * ({}));",
                r("a"),
                unary(op, "x.x"),
                unary_slope(op, "x.x", "v")
            ),
        ));
    }
    for &op in crate::conformance::BINARY {
        let k = binary_code(op);
        value_cases.push((
            k,
            format!(
                "v = {};",
                binary(op, &format!("{}.x", r("a")), &format!("{}.x", r("b")))
            ),
        ));
        dual_cases.push((
            k,
            format!(
                "let x = {}; let y = {}; let v = {}; d = vec4<f32>(v, {});",
                r("a"),
                r("b"),
                binary(op, "x.x", "y.x"),
                binary_gradient(op, "x", "y", "v")
            ),
        ));
    }
    let skip = format!("write = false; if ({}.x > 0.0) {{ pc += 4u * b; }}", r("a"));
    value_cases.extend([
        (
            OP_SELECT,
            format!("v = select({}.x, {}.x, {}.x > 0.0);", r("c"), r("b"), r("a")),
        ),
        (OP_SKIP, skip.clone()),
        (OP_CONST, "v = bitcast<f32>(a);".to_string()),
        (OP_INPUT, format!("v = {inputs}[a];")),
    ]);
    dual_cases.extend([
        (
            OP_SELECT,
            format!("d = select({}, {}, {}.x > 0.0);", r("c"), r("b"), r("a")),
        ),
        (OP_SKIP, skip),
        (OP_CONST, "d = vec4<f32>(bitcast<f32>(a), 0.0, 0.0, 0.0);".to_string()),
        (OP_INPUT, format!("d = vec4<f32>({inputs}[a], 0.0, 0.0, 0.0);")),
    ]);
    let value_dispatch = dispatch_tree(&mut value_cases, 2);
    let dual_dispatch = dispatch_tree(&mut dual_cases, 2);
    // The loop head both interpreters share: fetch and decode one instruction.
    let fetch = format!(
        "    var pc = start;
    let end = start + 4u * len;
    while (pc < end) {{
        let w0 = {code}[pc];
        let op = w0 & 0xffu;
        let o = w0 >> 8u;
        let a = {code}[pc + 1u];
        let b = {code}[pc + 2u];
        let c = {code}[pc + 3u];
        pc += 4u;
"
    );
    format!(
        r#"fn iso_run(start: u32, len: u32, out: u32, p: vec3<f32>) -> f32 {{
    iso_regs[iso_reg_base].x = p.x;
    iso_regs[iso_reg_base + 1u].x = p.y;
    iso_regs[iso_reg_base + 2u].x = p.z;
{fetch}        var v = 0.0;
        var write = true;
{value_dispatch}        if (write) {{ iso_regs[iso_reg_base + o].x = v; }}
    }}
    return iso_regs[iso_reg_base + out].x;
}}
fn iso_run_dual(start: u32, len: u32, out: u32, p: vec3<f32>) -> vec4<f32> {{
    iso_regs[iso_reg_base] = vec4<f32>(p.x, 1.0, 0.0, 0.0);
    iso_regs[iso_reg_base + 1u] = vec4<f32>(p.y, 0.0, 1.0, 0.0);
    iso_regs[iso_reg_base + 2u] = vec4<f32>(p.z, 0.0, 0.0, 1.0);
{fetch}        var d = vec4<f32>(0.0);
        var write = true;
{dual_dispatch}        if (write) {{ iso_regs[iso_reg_base + o] = d; }}
    }}
    return iso_regs[iso_reg_base + out];
}}
"#
    )
}

/// The interpreter's dispatch on `op` over `cases` (opcode, statement): a
/// binary tree of `if`s, so that control flow nests about log2(cases)
/// deep, not once per case as a `switch` lowered to an if-else chain does
/// (lavapipe runs out of its nesting stack on such a chain inside the
/// tracer's loops and then draws wrong pixels). An opcode not in `cases`
/// writes nothing.
fn dispatch_tree(cases: &mut [(u32, String)], depth: usize) -> String {
    cases.sort_by_key(|c| c.0);
    fn tree(cases: &[(u32, String)], depth: usize, out: &mut String) {
        let pad = "    ".repeat(depth);
        if let [(k, body)] = cases {
            out.push_str(&format!(
                "{pad}if (op == {k}u) {{ {body} }} else {{ write = false; }}\n"
            ));
            return;
        }
        let mid = cases.len() / 2;
        out.push_str(&format!("{pad}if (op < {}u) {{\n", cases[mid].0));
        tree(&cases[..mid], depth + 1, out);
        out.push_str(&format!("{pad}}} else {{\n"));
        tree(&cases[mid..], depth + 1, out);
        out.push_str(&format!("{pad}}}\n"));
    }
    let mut out = String::new();
    tree(cases, depth, &mut out);
    out
}
