//! The evaluator conformance suite: every operation of the IR, the awkward
//! arguments it is checked on, and the rule that decides whether an
//! evaluator's answer agrees with the reference.
//!
//! The reference semantics are [`apply_unary`] and [`apply_binary`] in f64
//! (Rust's `f64` methods: IEEE 754 for + − × ÷ √, the platform libm for the
//! rest). Every evaluator must follow them: the CPU evaluators of
//! [`crate::eval`], the interval rules of [`crate::interval`] and
//! [`crate::lipschitz`] (which must *contain* them), and any later client such
//! as a GPU code generator. `tests/conformance.rs` runs the suite against every
//! evaluator of this crate; a new client calls [`check_unary`] and
//! [`check_binary`] with a closure that evaluates one operation on a list of
//! arguments, and the same for intervals with [`check_unary_intervals`] and
//! [`check_binary_intervals`].
//!
//! Every operation is listed in [`UNARY`] and [`BINARY`], written so that a
//! variant added to [`UnOp`] or [`BinOp`] without being added here is a
//! compile error (the lists also generate an exhaustive `match`), and so are
//! [`unary_info`], [`binary_info`] and the derivative domains.
//!
//! # The arguments
//!
//! [`values`] holds the awkward arguments: ±0, ±∞, NaN, the f64 extremes
//! (largest, smallest normal, smallest subnormal), the f32 extremes (largest,
//! smallest normal, a subnormal, ε), the points where results overflow
//! (`exp` near 88.7 and 709.8, squares near √f32::MAX and √f64::MAX), the
//! branch points (0 and ±1 for `asin`/`acos`, π/2 and its neighbours for
//! `tan`, integers, half-integers and 0.49999999999999994 for
//! `floor`/`round`, 2⁵² + 1 where every float is an integer), values around
//! the interval rules' constants (1e18, 1e-30) and a sweep of ordinary
//! values; more than [`LANES`](crate::eval::LANES) of them, so batch
//! evaluators run a full block and a partial one. [`binary_args`] pairs a
//! smaller list ([`binary_values`]: negative bases, fractional and huge
//! exponents for `pow`, both signs of zero for `atan2`) with itself.
//!
//! # The comparison rule ([`Tolerance::agrees`])
//!
//! * NaN agrees with NaN (any payload) and with nothing else;
//! * an infinity agrees only with the same infinity;
//! * +0 and −0 agree unless the operation is sign-sensitive
//!   ([`OpInfo::zero_sign`]): the IEEE 754 basic operations (−x, |x|, √x, x²,
//!   +, −, ×, ÷), whose zero sign is specified exactly and decides what a later
//!   division by the result gives (a `neg` written as `0 − x` fails here).
//!   Other operations come from libm or GPU built-ins, whose zero sign is an
//!   artefact; `min`/`max` of ±0 may return either (IEEE `minNum`);
//! * finite values agree within `max(abs, rel · |want|)`.
//!
//! For an f32 evaluator ([`Tolerance::f32`]) the arguments are first rounded
//! to f32 (the evaluator can only see those), the reference is computed in f64
//! on the rounded arguments and then rounded to f32 — so a reference beyond
//! f32's range compares as ±∞ and one below its subnormals as ±0.
//!
//! # Tolerances
//!
//! | evaluator | tolerance | why |
//! |---|---|---|
//! | `PointEvaluator<f64>`, `BatchEvaluator<f64>`, the value of `Dual`, the input prologue, `Builder`'s constant folding | [`Tolerance::EXACT`] | they call [`apply_unary`]/[`apply_binary`] in f64 themselves: any difference is a bug |
//! | `PointEvaluator<f32>`, `BatchEvaluator<f32>` | [`Tolerance::F32`]: 4 f32 ulps (rel 2⁻²¹), 4 subnormal ulps absolute | + − × ÷ √ are correctly rounded in f32 and agree exactly (double rounding through f64 is innocuous for them); libm's f32 functions are within an ulp or two of correctly rounded |
//! | `Dual`'s derivatives vs [`Builder::derivative`](crate::ir::Builder::derivative) | [`Tolerance::DERIVATIVE`]: rel 1e-12 | the two write the same formulas, in a slightly different order of roundings |
//! | [`eval_interval`](crate::interval::eval_interval) | [`Containment::RIGOROUS`]: no slack | its rules widen their results by a few ulps themselves |
//! | the DAG interval rules of [`crate::lipschitz`] | [`Containment::dag`]: rel 1e-12 slack, saturated at ±[`BIG`](crate::lipschitz::BIG) | they do not widen for rounding (the renderer runs them in f32 anyway): a few ulps, amplified up to 745-fold by `pow`'s exp(y · ln x); ±BIG stands for ±∞ |
//!
//! A GPU client builds its own [`Tolerance`] with `f32: true`: WGSL allows
//! subnormals to be flushed to zero (use `abs: f32::MIN_POSITIVE as f64`) and
//! gives built-ins such as `sin` only absolute error bounds inside [−π, π]; it
//! may also restrict the arguments with [`check_unary_on`].
//!
//! # Derivatives
//!
//! [`unary_differentiable`] and [`binary_differentiable`] say where the
//! derivative rules (dual numbers and the symbolic derivative) must agree:
//! where the operation is differentiable with finite partial derivatives, and
//! at the kinks where the project has a convention (|x|' = 1 at 0, √x' = 0 at
//! 0, min/max take the derivative of `a` on ties, floor/round/sign have 0,
//! atan2 has 0 at the origin).
//!
//! # Intervals and NaN
//!
//! An interval never holds NaN: [`Interval::new`](crate::interval::Interval::new)
//! turns a NaN end into the whole line, and every rule returns ordered, non-NaN
//! ends (checked). A NaN *point value* — the operation is undefined there
//! (√ of a negative, ∞ − ∞, 0 · ∞, asin 2, a NaN argument) — need not be
//! contained: intervals bound the values an operation takes where it is
//! defined, and a box wholly outside the domain gives some interval (usually
//! the whole line) rather than the empty set. An interval over a box must
//! contain the value at every sample point of the box ([`samples`]: the ends,
//! their neighbours, interior points, 0 when it lies inside, and every listed
//! value inside); the boxes ([`interval_boxes`]) are the point intervals,
//! small and larger boxes on each side of every argument, the boxes between
//! neighbouring arguments and the whole line.
//!
//! The DAG interval rules work on the saturated line [−BIG, BIG] (BIG stands
//! for ∞ and keeps f32 arithmetic NaN-free): their boxes are clamped into it
//! and values and ends are compared after clamping. That a ±BIG end is only
//! approximately absorbing (BIG × 10⁻²⁰ is finite) is a limit of that
//! representation, not checked here.
//!
//! # Deliberate deviations from the reference
//!
//! * [`Builder`](crate::ir::Builder)'s algebraic identities hold up to the
//!   sign of zero: `x + 0 → x` gives −0 at x = −0 where IEEE gives +0, and
//!   `0 − x → −x` gives −0 at x = +0. And `pow(x, ½) → √x` (the meaning of a
//!   power ½ in the shape language) gives NaN at x = −∞ where `powf` gives +∞,
//!   and −0 at x = −0 where `powf` gives +0; `pow(x, 2) → x²` may differ from
//!   libm's `pow` by an ulp. Constant folding itself is exact.
//! * The symbolic derivative cannot test for NaN (a select compares with 0),
//!   so at a NaN operand of min/max it takes `a`'s derivative; the dual
//!   numbers take the derivative of the operand min/max returns.

use crate::ir::{apply_binary, apply_unary, BinOp, UnOp};

/// Lists the variants of an enum as a constant slice and, from the same list,
/// an exhaustive `match`: a variant missing from the list does not compile.
macro_rules! every_op {
    ($(#[$doc:meta])* $ty:ident, $list:ident, $check:ident, [$($v:ident),* $(,)?]) => {
        $(#[$doc])*
        pub const $list: &[$ty] = &[$($ty::$v),*];
        #[allow(dead_code)]
        const fn $check(op: $ty) {
            match op {
                $($ty::$v => {})*
            }
        }
    };
}

every_op!(
    /// Every unary operation.
    UnOp,
    UNARY,
    _every_unary_is_listed,
    [Neg, Abs, Sqrt, Square, Sin, Cos, Tan, Asin, Acos, Atan, Exp, Ln, Floor, Round, Sign]
);
every_op!(
    /// Every binary operation.
    BinOp,
    BINARY,
    _every_binary_is_listed,
    [Add, Sub, Mul, Div, Min, Max, Pow, Atan2]
);

/// What the suite knows about an operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OpInfo {
    /// A short name (the shape language's where it has one).
    pub name: &'static str,
    /// True when the sign of a zero result is part of the semantics (the IEEE
    /// 754 basic operations); otherwise +0 and −0 agree.
    pub zero_sign: bool,
}

const fn info(name: &'static str, zero_sign: bool) -> OpInfo {
    OpInfo { name, zero_sign }
}

/// The name and zero-sign rule of a unary operation.
pub const fn unary_info(op: UnOp) -> OpInfo {
    match op {
        UnOp::Neg => info("neg", true),
        UnOp::Abs => info("abs", true),
        UnOp::Sqrt => info("sqrt", true),
        UnOp::Square => info("square", true),
        UnOp::Sin => info("sin", false),
        UnOp::Cos => info("cos", false),
        UnOp::Tan => info("tan", false),
        UnOp::Asin => info("asin", false),
        UnOp::Acos => info("acos", false),
        UnOp::Atan => info("atan", false),
        UnOp::Exp => info("exp", false),
        UnOp::Ln => info("ln", false),
        UnOp::Floor => info("floor", false),
        UnOp::Round => info("round", false),
        UnOp::Sign => info("sign", false),
    }
}

/// The name and zero-sign rule of a binary operation.
pub const fn binary_info(op: BinOp) -> OpInfo {
    match op {
        BinOp::Add => info("add", true),
        BinOp::Sub => info("sub", true),
        BinOp::Mul => info("mul", true),
        BinOp::Div => info("div", true),
        BinOp::Min => info("min", false),
        BinOp::Max => info("max", false),
        BinOp::Pow => info("pow", false),
        BinOp::Atan2 => info("atan2", false),
    }
}

/// The float after `x` (towards +∞), for finite `x`.
fn next_up(x: f64) -> f64 {
    if x == 0.0 {
        f64::from_bits(1)
    } else if x > 0.0 {
        f64::from_bits(x.to_bits() + 1)
    } else {
        f64::from_bits(x.to_bits() - 1)
    }
}

/// The float before `x` (towards −∞), for finite `x`.
fn next_down(x: f64) -> f64 {
    -next_up(-x)
}

/// The awkward arguments every unary operation is checked on (more than
/// [`LANES`](crate::eval::LANES) of them; see the module documentation).
pub fn values() -> Vec<f64> {
    use std::f64::consts::{FRAC_PI_2, PI, TAU};
    let mut v = vec![
        // Zeros, infinities, NaN.
        0.0,
        -0.0,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        // f64 extremes.
        f64::MAX,
        -f64::MAX,
        1e300,
        -1e300,
        1.3e154, // x² is finite
        1.4e154, // x² overflows
        -1.4e154,
        f64::MIN_POSITIVE,
        -f64::MIN_POSITIVE,
        1e-300,
        -1e-300,
        1e-310, // subnormal
        f64::from_bits(1),
        -f64::from_bits(1),
        // f32 extremes.
        f32::MAX as f64,
        -(f32::MAX as f64),
        f32::MIN_POSITIVE as f64,
        -(f32::MIN_POSITIVE as f64),
        1e-40, // an f32 subnormal
        1e-45, // near the smallest f32 subnormal
        f32::EPSILON as f64,
        1.8e19, // x² is finite in f32
        1.9e19, // x² overflows f32
        -1.9e19,
        // The branch points of asin/acos, floor/round.
        1.0,
        -1.0,
        1.0 + f64::EPSILON,
        -1.0 - f64::EPSILON,
        1.0 - f64::EPSILON / 2.0,
        -(1.0 - f64::EPSILON / 2.0),
        0.5,
        -0.5,
        0.49999999999999994, // round(x) = 0, floor(x + 0.5) = 1
        -0.49999999999999994,
        1.5,
        -1.5,
        2.5,
        -2.5,
        2.0,
        -2.0,
        3.0,
        -3.0,
        4503599627370497.0, // 2⁵² + 1
        -4503599627370497.0,
        1e15 + 0.5,
        // The asymptotes of tan and crests of sin/cos.
        FRAC_PI_2,
        -FRAC_PI_2,
        next_up(FRAC_PI_2),
        next_down(FRAC_PI_2),
        std::f32::consts::FRAC_PI_2 as f64,
        PI,
        -PI,
        3.0 * FRAC_PI_2,
        TAU,
        // exp near overflow and underflow, in f32 and f64.
        88.72,
        89.0,
        -87.3,
        -103.9,
        -110.0,
        709.78,
        710.0,
        -745.1,
        -746.0,
        // Ordinary and large values, and the interval rules' constants.
        0.1,
        -0.7,
        7.3,
        -12.6,
        1e6 + 0.5,
        1e10,
        1e15,
        1e18,
        -1e18,
        1e-30,
        1e-20,
        41.0,
        43.0,
    ];
    // A sweep of ordinary values.
    v.extend((0..16).map(|k| -3.9 + 0.53 * k as f64));
    v
}

/// The values binary operations pair with each other: fewer than
/// [`values`], with negative bases, fractional and huge exponents for `pow`
/// and both zeros for `atan2`.
pub fn binary_values() -> Vec<f64> {
    vec![
        0.0,
        -0.0,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        1.0,
        -1.0,
        0.5,
        -0.5,
        2.0,
        -2.0,
        3.0,
        -3.0,
        2.5,
        -2.5,
        1.0 / 3.0,
        0.1,
        -0.7,
        7.3,
        1e300,
        -1e300,
        1e-300,
        1e-310,
        f32::MAX as f64,
        f32::MIN_POSITIVE as f64,
        1e-40,
        1.9e19,
        -1.9e19,
        std::f64::consts::FRAC_PI_2,
        88.72,
        1e10,
        9007199254740992.0, // 2⁵³: an even integer
        63.0,
        -64.0,
        1e18,
        1.0 + f64::EPSILON,
    ]
}

/// The awkward arguments of unary operations (the same as [`values`]).
pub fn unary_args() -> Vec<f64> {
    values()
}

/// The awkward argument pairs of binary operations: every pair of
/// [`binary_values`].
pub fn binary_args() -> Vec<[f64; 2]> {
    let v = binary_values();
    v.iter().flat_map(|&a| v.iter().map(move |&b| [a, b])).collect()
}

/// How closely an evaluator must follow the reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Relative tolerance on finite values.
    pub rel: f64,
    /// Absolute tolerance on finite values (for results near zero).
    pub abs: f64,
    /// The evaluator computes in f32: its arguments are rounded to f32, and
    /// the reference (f64 on the rounded arguments) is rounded to f32.
    pub f32: bool,
}

impl Tolerance {
    /// Bit for bit (NaN payloads aside): evaluators that compute the
    /// reference in f64 themselves.
    pub const EXACT: Tolerance = Tolerance {
        rel: 0.0,
        abs: 0.0,
        f32: false,
    };
    /// CPU evaluators in f32: 4 f32 ulps, and 4 ulps of the smallest subnormal.
    pub const F32: Tolerance = Tolerance {
        rel: 4.0 * f32::EPSILON as f64,
        abs: 4.0 * 1.401298464324817e-45,
        f32: true,
    };
    /// Dual numbers against the symbolic derivative (both f64).
    pub const DERIVATIVE: Tolerance = Tolerance {
        rel: 1e-12,
        abs: 1e-300,
        f32: false,
    };

    /// The argument an evaluator of this precision is handed for `x`.
    pub fn arg(&self, x: f64) -> f64 {
        if self.f32 {
            x as f32 as f64
        } else {
            x
        }
    }

    /// A reference value at this precision.
    pub fn round(&self, v: f64) -> f64 {
        if self.f32 {
            v as f32 as f64
        } else {
            v
        }
    }

    /// The comparison rule: NaN agrees with NaN, infinities exactly, ±0 as
    /// equal unless `zero_sign`, finite values within `max(abs, rel·|want|)`.
    pub fn agrees(&self, want: f64, got: f64, zero_sign: bool) -> bool {
        if want.is_nan() || got.is_nan() {
            return want.is_nan() && got.is_nan();
        }
        if want.is_infinite() || got.is_infinite() {
            return want == got;
        }
        if want == 0.0 && got == 0.0 {
            return !zero_sign || want.is_sign_negative() == got.is_sign_negative();
        }
        (got - want).abs() <= self.abs.max(self.rel * want.abs())
    }
}

/// The reference value of a unary operation at the precision of `tol`.
pub fn reference_unary(op: UnOp, x: f64, tol: Tolerance) -> f64 {
    tol.round(apply_unary(op, tol.arg(x)))
}

/// The reference value of a binary operation at the precision of `tol`.
pub fn reference_binary(op: BinOp, a: f64, b: f64, tol: Tolerance) -> f64 {
    tol.round(apply_binary(op, tol.arg(a), tol.arg(b)))
}

/// One disagreement with the reference.
#[derive(Debug, Clone, PartialEq)]
pub struct Mismatch {
    /// The evaluator, as the caller named it.
    pub evaluator: String,
    /// The operation's name.
    pub op: &'static str,
    /// The arguments (for intervals: the ends of each box, then the sample point).
    pub args: Vec<f64>,
    /// The reference value.
    pub want: f64,
    /// What the evaluator gave (a value, or an interval's two ends).
    pub got: Vec<f64>,
    /// What was compared.
    pub what: String,
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {}{:?} {}: got {:?}, want {:?}",
            self.evaluator, self.op, self.args, self.what, self.got, self.want
        )
    }
}

/// An evaluator of unary operations: given an operation and arguments, one
/// value per argument.
pub type UnaryFn<'a> = dyn FnMut(UnOp, &[f64]) -> Vec<f64> + 'a;
/// An evaluator of binary operations: one value per pair of arguments.
pub type BinaryFn<'a> = dyn FnMut(BinOp, &[[f64; 2]]) -> Vec<f64> + 'a;
/// An interval as its ends (lo, hi).
pub type Ends = (f64, f64);
/// Interval rules of unary operations: one interval per box.
pub type UnaryIntervalFn<'a> = dyn FnMut(UnOp, &[Ends]) -> Vec<Ends> + 'a;
/// Interval rules of binary operations: one interval per pair of boxes.
pub type BinaryIntervalFn<'a> = dyn FnMut(BinOp, &[[Ends; 2]]) -> Vec<Ends> + 'a;

/// Checks an evaluator of unary operations on [`unary_args`]. `eval` gets an
/// operation and the arguments (already rounded to f32 when `tol.f32`) and
/// returns one value per argument.
pub fn check_unary(name: &str, eval: &mut UnaryFn<'_>, tol: Tolerance) -> Result<(), Vec<Mismatch>> {
    check_unary_on(name, &unary_args(), eval, tol)
}

/// [`check_unary`] on arguments of the caller's choosing.
pub fn check_unary_on(name: &str, args: &[f64], eval: &mut UnaryFn<'_>, tol: Tolerance) -> Result<(), Vec<Mismatch>> {
    check_unary_each(name, args, eval, &|_| tol, &|_, _| true)
}

/// [`check_unary_on`] with a tolerance per operation (`tol`), each
/// operation held only at the arguments `held` accepts (after rounding to
/// its precision): for evaluators whose accuracy differs by operation,
/// such as a GPU's.
pub fn check_unary_each(
    name: &str,
    args: &[f64],
    eval: &mut UnaryFn<'_>,
    tol: &dyn Fn(UnOp) -> Tolerance,
    held: &dyn Fn(UnOp, f64) -> bool,
) -> Result<(), Vec<Mismatch>> {
    let mut bad = Vec::new();
    for &op in UNARY {
        let (info, tol) = (unary_info(op), tol(op));
        let args: Vec<f64> = args.iter().map(|&x| tol.arg(x)).filter(|&x| held(op, x)).collect();
        let got = eval(op, &args);
        if got.len() != args.len() {
            bad.push(count_mismatch(name, info.name, args.len(), got.len()));
            continue;
        }
        let before = bad.len();
        for (&x, &g) in args.iter().zip(&got) {
            let want = reference_unary(op, x, tol);
            if !tol.agrees(want, g, info.zero_sign) && bad.len() - before < MAX_REPORTED {
                bad.push(Mismatch {
                    evaluator: name.to_string(),
                    op: info.name,
                    args: vec![x],
                    want,
                    got: vec![g],
                    what: "value".to_string(),
                });
            }
        }
    }
    done(bad)
}

/// Checks an evaluator of binary operations on [`binary_args`]; `eval` gets
/// an operation and the argument pairs and returns one value per pair.
pub fn check_binary(name: &str, eval: &mut BinaryFn<'_>, tol: Tolerance) -> Result<(), Vec<Mismatch>> {
    check_binary_on(name, &binary_args(), eval, tol)
}

/// [`check_binary`] on arguments of the caller's choosing.
pub fn check_binary_on(
    name: &str,
    args: &[[f64; 2]],
    eval: &mut BinaryFn<'_>,
    tol: Tolerance,
) -> Result<(), Vec<Mismatch>> {
    check_binary_each(name, args, eval, &|_| tol, &|_, _| true)
}

/// [`check_binary_on`] with a tolerance per operation, each held only at
/// the argument pairs `held` accepts (see [`check_unary_each`]).
pub fn check_binary_each(
    name: &str,
    args: &[[f64; 2]],
    eval: &mut BinaryFn<'_>,
    tol: &dyn Fn(BinOp) -> Tolerance,
    held: &dyn Fn(BinOp, [f64; 2]) -> bool,
) -> Result<(), Vec<Mismatch>> {
    let mut bad = Vec::new();
    for &op in BINARY {
        let (info, tol) = (binary_info(op), tol(op));
        let args: Vec<[f64; 2]> = args
            .iter()
            .map(|&[a, b]| [tol.arg(a), tol.arg(b)])
            .filter(|&p| held(op, p))
            .collect();
        let got = eval(op, &args);
        if got.len() != args.len() {
            bad.push(count_mismatch(name, info.name, args.len(), got.len()));
            continue;
        }
        let before = bad.len();
        for (&[a, b], &g) in args.iter().zip(&got) {
            let want = reference_binary(op, a, b, tol);
            if !tol.agrees(want, g, info.zero_sign) && bad.len() - before < MAX_REPORTED {
                bad.push(Mismatch {
                    evaluator: name.to_string(),
                    op: info.name,
                    args: vec![a, b],
                    want,
                    got: vec![g],
                    what: "value".to_string(),
                });
            }
        }
    }
    done(bad)
}

fn count_mismatch(name: &str, op: &'static str, want: usize, got: usize) -> Mismatch {
    Mismatch {
        evaluator: name.to_string(),
        op,
        args: Vec::new(),
        want: want as f64,
        got: vec![got as f64],
        what: "number of results".to_string(),
    }
}

/// At most this many mismatches are reported per operation (and, for
/// intervals, one box may add all of its sample points).
pub const MAX_REPORTED: usize = 100;

fn done(bad: Vec<Mismatch>) -> Result<(), Vec<Mismatch>> {
    if bad.is_empty() {
        Ok(())
    } else {
        Err(bad)
    }
}

/// True where the derivative rules of a unary operation must agree (see the
/// module documentation): a finite argument and value, and a finite
/// derivative or a conventional one.
pub fn unary_differentiable(op: UnOp, x: f64) -> bool {
    if !x.is_finite() || !apply_unary(op, x).is_finite() {
        return false;
    }
    let d = match op {
        // Kinks and jumps have conventional derivatives.
        UnOp::Neg | UnOp::Abs | UnOp::Floor | UnOp::Round | UnOp::Sign => 1.0,
        UnOp::Sin | UnOp::Cos | UnOp::Atan => 1.0,
        // 0 at 0 by convention.
        UnOp::Sqrt => {
            if x > 0.0 {
                0.5 / x.sqrt()
            } else {
                0.0
            }
        }
        UnOp::Square => 2.0 * x,
        UnOp::Tan => 1.0 + x.tan() * x.tan(),
        UnOp::Asin | UnOp::Acos => {
            if x.abs() < 1.0 {
                1.0 / (1.0 - x * x).sqrt()
            } else {
                f64::NAN
            }
        }
        UnOp::Exp => x.exp(),
        UnOp::Ln => {
            if x > 0.0 {
                1.0 / x
            } else {
                f64::NAN
            }
        }
    };
    d.is_finite()
}

/// True where the derivative rules of a binary operation must agree: finite
/// arguments and value, and finite partial derivatives (or conventional
/// ones: min/max on ties, atan2 at the origin). `pow` is differentiable only
/// for a positive base, and the suite asks a normal one (for a subnormal base
/// and exponent 0 the rule b·a^(b−1) is 0·∞).
pub fn binary_differentiable(op: BinOp, a: f64, b: f64) -> bool {
    if !a.is_finite() || !b.is_finite() || !apply_binary(op, a, b).is_finite() {
        return false;
    }
    let d = match op {
        BinOp::Add | BinOp::Sub | BinOp::Min | BinOp::Max | BinOp::Atan2 => [1.0, 1.0],
        BinOp::Mul => [b, a],
        BinOp::Div => {
            if b != 0.0 {
                [1.0 / b, -(a / b) / b]
            } else {
                [f64::NAN; 2]
            }
        }
        BinOp::Pow => {
            if a >= f64::MIN_POSITIVE {
                let da = if b == 0.0 { 0.0 } else { b * a.powf(b - 1.0) };
                [da, a.powf(b) * a.ln()]
            } else {
                [f64::NAN; 2]
            }
        }
    };
    d.iter().all(|v| v.is_finite())
}

/// How interval results are checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Containment {
    /// Slack on each end, relative to its magnitude (0 for rules that widen
    /// their results themselves).
    pub rel: f64,
    /// `Some(big)`: the rules work on the saturated line [−big, big], where
    /// ±big stands for ±∞. Boxes are clamped into it before they are handed
    /// out, and values and ends are clamped into it before comparing.
    pub saturate: Option<f64>,
}

impl Containment {
    /// Rigorous interval arithmetic: no slack, no saturation.
    pub const RIGOROUS: Containment = Containment {
        rel: 0.0,
        saturate: None,
    };
    /// Rules written into the DAG with ±`big` for ±∞, which do not widen for
    /// rounding: 1e-12 relative slack (a few ulps, times the |y ln x| ≤ 745
    /// by which `pow`'s exp(y · ln x) amplifies the rounding of y · ln x).
    pub fn dag(big: f64) -> Containment {
        Containment {
            rel: 1e-12,
            saturate: Some(big),
        }
    }
    /// The boxes of [`interval_boxes`], saturated, without repeats.
    fn boxes(&self, vals: &[f64]) -> Vec<(f64, f64)> {
        let mut seen = std::collections::HashSet::new();
        interval_boxes(vals)
            .into_iter()
            .map(|(lo, hi)| (self.sat(lo), self.sat(hi)))
            .filter(|&(lo, hi)| seen.insert((lo.to_bits(), hi.to_bits())))
            .collect()
    }
    fn sat(&self, v: f64) -> f64 {
        match self.saturate {
            Some(big) if !v.is_nan() => v.clamp(-big, big),
            _ => v,
        }
    }
}

/// The boxes interval rules are checked on, from a list of values: every
/// (non-NaN) value as a point interval, boxes of two sizes on both sides of
/// and around each finite one, the boxes between neighbouring values,
/// [f64::MAX, ∞] and its mirror, and the whole line.
pub fn interval_boxes(values: &[f64]) -> Vec<(f64, f64)> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| !x.is_nan()).collect();
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| a.to_bits() == b.to_bits());
    let mut out = Vec::new();
    for &x in &v {
        out.push((x, x));
        if x.is_finite() {
            for h in [x.abs() * 2f64.powi(-40), (x.abs() * 1e-3).max(1e-3)] {
                if h > 0.0 {
                    out.extend([(x - h, x + h), (x, x + h), (x - h, x)]);
                }
            }
        }
    }
    out.extend(v.windows(2).filter(|w| w[0] < w[1]).map(|w| (w[0], w[1])));
    out.extend([
        (f64::MAX, f64::INFINITY),
        (f64::NEG_INFINITY, -f64::MAX),
        (f64::NEG_INFINITY, f64::INFINITY),
    ]);
    out
}

/// The points of [lo, hi] at which a value must be contained: the ends and
/// their inner neighbours, the midpoint and quarter points, 0 and −0 when
/// inside, the geometric mean of a positive (or negative) box, and every
/// value of `extra` inside.
pub fn samples(lo: f64, hi: f64, extra: &[f64]) -> Vec<f64> {
    let mut s = vec![lo, hi];
    if lo < hi {
        let mid = lo / 2.0 + hi / 2.0;
        s.extend([mid, lo / 2.0 + mid / 2.0, mid / 2.0 + hi / 2.0]);
        if lo.is_finite() {
            s.push(next_up(lo));
        }
        if hi.is_finite() {
            s.push(next_down(hi));
        }
        if lo < 0.0 && hi > 0.0 {
            s.extend([0.0, -0.0]);
        }
        if lo > 0.0 || hi < 0.0 {
            s.push(lo.signum() * (lo.abs().sqrt() * hi.abs().sqrt()));
        }
        s.extend(extra.iter().copied().filter(|&x| lo < x && x < hi));
    }
    s.retain(|&x| !x.is_nan() && lo <= x && x <= hi);
    s.sort_by(f64::total_cmp);
    s.dedup_by(|a, b| a.to_bits() == b.to_bits());
    s
}

/// Checks interval rules of unary operations: for every box of
/// [`interval_boxes`] over [`values`], `eval` gives an interval (lo, hi),
/// which must contain the value at every point of [`samples`].
pub fn check_unary_intervals(name: &str, eval: &mut UnaryIntervalFn<'_>, c: Containment) -> Result<(), Vec<Mismatch>> {
    let mut bad = Vec::new();
    for &op in UNARY {
        let r = check_function_intervals(
            name,
            unary_info(op).name,
            &|x| apply_unary(op, x),
            &mut |boxes| eval(op, boxes),
            c,
        );
        bad.extend(r.err().unwrap_or_default());
    }
    done(bad)
}

/// [`check_unary_intervals`] for one function of one argument `f` (such as
/// x^k for a constant k, which interval rules may treat apart): `eval` gives
/// one interval per box, which must contain `f` at every sample point.
pub fn check_function_intervals(
    name: &str,
    label: &'static str,
    f: &dyn Fn(f64) -> f64,
    eval: &mut dyn FnMut(&[Ends]) -> Vec<Ends>,
    c: Containment,
) -> Result<(), Vec<Mismatch>> {
    let vals = values();
    let boxes = c.boxes(&vals);
    let mut bad = Vec::new();
    let got = eval(&boxes);
    if got.len() != boxes.len() {
        return Err(vec![count_mismatch(name, label, boxes.len(), got.len())]);
    }
    for (&(lo, hi), &g) in boxes.iter().zip(&got) {
        if bad.len() >= MAX_REPORTED {
            break;
        }
        let ps = samples(lo, hi, &vals);
        contain(name, label, &[lo, hi], g, c, &mut bad, ps.iter().map(|&x| (x, f(x))));
    }
    done(bad)
}

/// Checks interval rules of binary operations on every pair of boxes of
/// [`interval_boxes`] over [`binary_values`]; the interval `eval` gives must
/// contain the value at every pair of sample points.
pub fn check_binary_intervals(
    name: &str,
    eval: &mut BinaryIntervalFn<'_>,
    c: Containment,
) -> Result<(), Vec<Mismatch>> {
    let vals = binary_values();
    let boxes = c.boxes(&vals);
    let pts: Vec<Vec<f64>> = boxes.iter().map(|&(lo, hi)| samples(lo, hi, &vals)).collect();
    let pairs: Vec<[(f64, f64); 2]> = boxes.iter().flat_map(|&a| boxes.iter().map(move |&b| [a, b])).collect();
    let mut bad = Vec::new();
    for &op in BINARY {
        let info = binary_info(op);
        let got = eval(op, &pairs);
        if got.len() != pairs.len() {
            bad.push(count_mismatch(name, info.name, pairs.len(), got.len()));
            continue;
        }
        let before = bad.len();
        for (k, (&[(al, ah), (bl, bh)], &g)) in pairs.iter().zip(&got).enumerate() {
            if bad.len() - before >= MAX_REPORTED {
                break;
            }
            let (pa, pb) = (&pts[k / boxes.len()], &pts[k % boxes.len()]);
            let values = pa
                .iter()
                .flat_map(|&a| pb.iter().map(move |&b| (a, b)))
                .map(|(a, b)| ((a, b), apply_binary(op, a, b)));
            contain_pairs(name, info.name, &[al, ah, bl, bh], g, c, &mut bad, values);
        }
    }
    done(bad)
}

/// Pushes a mismatch for every (point, value) that `got` does not contain.
fn contain(
    name: &str,
    op: &'static str,
    ends: &[f64],
    got: (f64, f64),
    c: Containment,
    bad: &mut Vec<Mismatch>,
    values: impl Iterator<Item = (f64, f64)>,
) {
    contain_pairs(name, op, ends, got, c, bad, values.map(|(x, v)| ((x, f64::NAN), v)));
}

fn contain_pairs(
    name: &str,
    op: &'static str,
    ends: &[f64],
    got: (f64, f64),
    c: Containment,
    bad: &mut Vec<Mismatch>,
    values: impl Iterator<Item = ((f64, f64), f64)>,
) {
    let (lo, hi) = (c.sat(got.0), c.sat(got.1));
    let mismatch = |want: f64, point: &[f64], what: &str| Mismatch {
        evaluator: name.to_string(),
        op,
        args: ends.iter().chain(point).copied().collect(),
        want,
        got: vec![got.0, got.1],
        what: what.to_string(),
    };
    if lo.is_nan() || hi.is_nan() || lo > hi {
        bad.push(mismatch(f64::NAN, &[], "is not an interval"));
        return;
    }
    let slack = |x: f64| if x.is_finite() { c.rel * x.abs() } else { 0.0 };
    let (lo_s, hi_s) = (lo - slack(lo), hi + slack(hi));
    for ((x, y), v) in values {
        let v = c.sat(v);
        if v.is_nan() {
            continue; // undefined there: intervals bound the defined values
        }
        if !(lo_s <= v && v <= hi_s) {
            let point: Vec<f64> = if y.is_nan() { vec![x] } else { vec![x, y] };
            bad.push(mismatch(v, &point, "does not contain the value at the point"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comparison_rule() {
        let t = Tolerance::EXACT;
        assert!(t.agrees(f64::NAN, -f64::NAN, true));
        assert!(!t.agrees(f64::NAN, 0.0, false) && !t.agrees(0.0, f64::NAN, false));
        assert!(t.agrees(f64::INFINITY, f64::INFINITY, false));
        assert!(!t.agrees(f64::INFINITY, f64::MAX, false) && !t.agrees(f64::MAX, f64::INFINITY, false));
        assert!(!t.agrees(f64::INFINITY, f64::NEG_INFINITY, false));
        assert!(t.agrees(0.0, -0.0, false) && !t.agrees(0.0, -0.0, true));
        assert!(t.agrees(-0.0, -0.0, true));
        assert!(!t.agrees(1.0, next_up(1.0), false));
        let f = Tolerance::F32;
        assert!(f.agrees(1.0, 1.0 + 4e-7, false) && !f.agrees(1.0, 1.0 + 6e-7, false));
        assert!(f.agrees(0.0, 5e-45, false) && !f.agrees(0.0, 1e-44, false));
        assert_eq!(f.arg(1e300), f64::INFINITY);
        assert_eq!(reference_unary(UnOp::Exp, 100.0, f), f64::INFINITY);
        assert_eq!(reference_unary(UnOp::Exp, 100.0, t), 100f64.exp());
    }

    #[test]
    fn lists_are_complete_and_distinct() {
        let names: std::collections::HashSet<&str> = UNARY
            .iter()
            .map(|&o| unary_info(o).name)
            .chain(BINARY.iter().map(|&o| binary_info(o).name))
            .collect();
        assert_eq!(names.len(), UNARY.len() + BINARY.len());
        assert!(values().len() > crate::eval::LANES);
        assert!(binary_args().len() > crate::eval::LANES);
    }

    #[test]
    fn samples_stay_inside() {
        for (lo, hi) in interval_boxes(&values()) {
            assert!(lo <= hi, "[{lo}, {hi}]");
            let s = samples(lo, hi, &values());
            assert!(s.contains(&lo) && s.contains(&hi));
            assert!(s.iter().all(|&x| lo <= x && x <= hi));
        }
    }
}
