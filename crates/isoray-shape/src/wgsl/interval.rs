//! Interval arithmetic of the shape IR in WGSL: a [`Tape`]'s bounds over
//! a box, written as a WGSL function, beside the value and dual-number
//! emitters of [`crate::wgsl`].
//!
//! Every rule follows the CPU's [`Interval`](crate::interval::Interval)
//! (the same case analysis: sin's crests, tan's asymptotes, pow's whole
//! exponents, the whole line for a division by an interval holding 0), in
//! f32 and made safe for what a GPU does to f32 (WGSL leaves directed
//! rounding out, transcendental functions are approximations, subnormal
//! numbers are flushed to zero): each computed end is moved outward by a
//! relative margin, a few ulps for the correctly rounded operations and the
//! measured error of the approximations beyond it (see isoray-gpu's
//! `accuracy`), plus the smallest normal f32. So the interval contains
//! the reference value (f64) of the tape at every point of the box, which
//! the evaluator conformance suite checks on the GPU
//! (`isoray-gpu/tests/conformance.rs`); it is not always as tight as the
//! CPU's, which also tightens smooth minimums.
//!
//! ```
//! use isoray_shape::{ir::Builder, wgsl};
//! let mut b = Builder::new();
//! let (x, y) = (b.x(), b.y());
//! let d = b.mul(x, y);
//! let f = wgsl::interval::emit_tape_interval(&b.tape(d), "bounds", "iso_in", 0);
//! assert!(f.code.contains("fn bounds(lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32>"));
//! // The function calls the rules of the interval prelude.
//! assert!(f.code.contains("iv_mul("));
//! assert!(wgsl::interval::INTERVAL_PRELUDE.contains("fn iv_mul("));
//! ```

use super::{buffer_reads, literal, InputBuffer, WgslFunction};
use crate::ir::{BinOp, Instr, Tape, UnOp};

/// WGSL interval rules (after [`PRELUDE`](crate::wgsl::PRELUDE), whose
/// helpers they call): an interval is a `vec2<f32>`, x the low end, y the
/// high end, never NaN; `iv_whole()` is the whole line.
pub const INTERVAL_PRELUDE: &str = r#"// isoray: interval arithmetic of the shape IR in WGSL (x: low end, y: high end).
// Four f32 epsilons: the margin of the correctly rounded operations.
const IV_ULPS: f32 = 4.76837158e-7;
// The smallest normal f32: absorbs results flushed to zero.
const IV_TINY: f32 = 1.17549435e-38;
// π rounded up, and π/2 below it.
const IV_PI: f32 = 3.14159274;
const IV_HALF_PI: f32 = 1.57079637;
fn iv_whole() -> vec2<f32> { return vec2<f32>(-iso_inf(), iso_inf()); }
fn iv_finite(x: f32) -> bool { return abs(x) < iso_inf(); }
// [lo, hi] in order; the whole line when an end is NaN.
fn iv(lo: f32, hi: f32) -> vec2<f32> {
    if (iso_is_nan(lo) || iso_is_nan(hi)) { return iv_whole(); }
    return vec2<f32>(min(lo, hi), max(lo, hi));
}
// [lo, hi] in order with finite ends moved out by rel·|end| + abs_ (at
// least the smallest normal); the whole line when an end is NaN.
// Every computed end goes through here.
fn iv_out(lo: f32, hi: f32, rel: f32, abs_: f32) -> vec2<f32> {
    if (iso_is_nan(lo) || iso_is_nan(hi)) { return iv_whole(); }
    let a = min(lo, hi);
    let b = max(lo, hi);
    let m = max(abs_, IV_TINY);
    // An end that overflowed to ∞ on the inside stands for one beyond the
    // largest f32: the low end is at most that, the high end at least its negative.
    let big = bitcast<f32>(0x7f7fffffu);
    let l = select(a, a - (abs(a) * rel + m), iv_finite(a));
    let h = select(b, b + (abs(b) * rel + m), iv_finite(b));
    return vec2<f32>(min(l, big), max(h, -big));
}
// A correctly rounded operation's ends.
fn iv_widen(lo: f32, hi: f32) -> vec2<f32> { return iv_out(lo, hi, IV_ULPS, IV_TINY); }
fn iv_hull(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> { return vec2<f32>(min(a.x, b.x), max(a.y, b.y)); }
fn iv_clamp_lo(a: vec2<f32>, lo: f32) -> vec2<f32> { return vec2<f32>(max(a.x, lo), max(a.y, lo)); }
fn iv_neg(a: vec2<f32>) -> vec2<f32> { return vec2<f32>(-a.y, -a.x); }
fn iv_abs(a: vec2<f32>) -> vec2<f32> {
    if (a.x >= 0.0) { return a; }
    if (a.y <= 0.0) { return vec2<f32>(-a.y, -a.x); }
    return vec2<f32>(0.0, max(-a.x, a.y));
}
fn iv_sqrt(a: vec2<f32>) -> vec2<f32> {
    if (a.y < 0.0) { return iv_whole(); }
    return iv_clamp_lo(iv_widen(sqrt(max(a.x, 0.0)), sqrt(a.y)), 0.0);
}
fn iv_square(a: vec2<f32>) -> vec2<f32> {
    let m = iv_abs(a);
    return iv_clamp_lo(iv_widen(m.x * m.x, m.y * m.y), 0.0);
}
// The k of the points first + kπ in or near the interval (first ≤ k ≤ last),
// with a margin for the f32 arithmetic that finds them.
fn iv_crests(a: vec2<f32>, first: f32, margin: f32) -> vec2<f32> {
    let k0 = ceil((a.x - margin - first) / IV_PI);
    let k1 = floor((a.y + margin - first) / IV_PI);
    return vec2<f32>(k0, k1);
}
// sin (cosine false) or cos over the interval: the ends' values, and ±1
// where a crest (even k) or trough (odd k) may lie inside. The GPU's sin
// and cos are held only for |x| ≤ 2^16: beyond, [−1, 1].
fn iv_trig(a: vec2<f32>, cosine: bool) -> vec2<f32> {
    let unit = vec2<f32>(-1.0, 1.0);
    let big = max(abs(a.x), abs(a.y));
    if (!(big <= 65536.0) || a.y - a.x >= 2.0 * IV_PI) { return unit; }
    let k = iv_crests(a, select(IV_HALF_PI, 0.0, cosine), 2e-6 * big + 1e-6);
    if (k.y - k.x >= 1.0) { return unit; }
    var fl: f32;
    var fh: f32;
    if (cosine) {
        fl = cos(a.x);
        fh = cos(a.y);
    } else {
        fl = sin(a.x);
        fh = sin(a.y);
    }
    var mn = min(fl, fh);
    var mx = max(fl, fh);
    if (k.x == k.y) {
        if (k.x - 2.0 * floor(k.x * 0.5) == 0.0) { mx = 1.0; } else { mn = -1.0; }
    }
    return vec2<f32>(max(mn - 4e-6, -1.0), min(mx + 4e-6, 1.0));
}
// Monotone between the asymptotes π/2 + kπ; the whole line near one (the
// GPU's tan loses its relative accuracy there) or beyond |x| = 2^16.
fn iv_tan(a: vec2<f32>) -> vec2<f32> {
    let big = max(abs(a.x), abs(a.y));
    if (!(big <= 65536.0) || a.y - a.x >= IV_PI) { return iv_whole(); }
    let k = iv_crests(a, IV_HALF_PI, 0.05 + 2e-6 * big);
    if (k.x <= k.y) { return iv_whole(); }
    return iv_out(tan(a.x), tan(a.y), 1e-4, 1e-5);
}
fn iv_asin(a: vec2<f32>) -> vec2<f32> {
    let c = iv(max(a.x, -1.0), min(a.y, 1.0));
    return iv_out(iso_asin(c.x), iso_asin(c.y), 6e-5, IV_TINY);
}
fn iv_acos(a: vec2<f32>) -> vec2<f32> {
    let c = iv(max(a.x, -1.0), min(a.y, 1.0));
    return iv_out(iso_acos(c.y), iso_acos(c.x), 6e-5, 1e-7);
}
fn iv_atan(a: vec2<f32>) -> vec2<f32> { return iv_out(iso_atan(a.x), iso_atan(a.y), 6e-5, IV_TINY); }
fn iv_exp(a: vec2<f32>) -> vec2<f32> { return iv_clamp_lo(iv_out(exp(a.x), exp(a.y), 4e-5, IV_TINY), 0.0); }
// ln: −∞ below the smallest normal (a subnormal argument may be flushed).
fn iv_ln(a: vec2<f32>) -> vec2<f32> {
    if (a.y <= 0.0) { return iv_whole(); }
    let lo = select(-iso_inf(), iso_ln(a.x), a.x >= IV_TINY);
    return iv_out(lo, iso_ln(max(a.y, IV_TINY)), 16.0 * IV_ULPS, 1e-6);
}
fn iv_floor(a: vec2<f32>) -> vec2<f32> { return vec2<f32>(floor(a.x), floor(a.y)); }
fn iv_round(a: vec2<f32>) -> vec2<f32> { return vec2<f32>(iso_round(a.x), iso_round(a.y)); }
fn iv_sign(a: vec2<f32>) -> vec2<f32> { return vec2<f32>(iso_sign(a.x), iso_sign(a.y)); }
fn iv_add(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> { return iv_widen(a.x + b.x, a.y + b.y); }
fn iv_sub(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> { return iv_widen(a.x - b.y, a.y - b.x); }
fn iv_any_nan(p: vec4<f32>) -> bool { return iso_is_nan(p.x) || iso_is_nan(p.y) || iso_is_nan(p.z) || iso_is_nan(p.w); }
fn iv_ends(p: vec4<f32>) -> vec2<f32> {
    if (iv_any_nan(p)) { return iv_whole(); } // 0 × ∞, ∞ / ∞
    return iv_widen(min(min(p.x, p.y), min(p.z, p.w)), max(max(p.x, p.y), max(p.z, p.w)));
}
fn iv_mul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return iv_ends(vec4<f32>(a.x * b.x, a.x * b.y, a.y * b.x, a.y * b.y));
}
fn iv_div(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    if (b.x <= 0.0 && b.y >= 0.0) { return iv_whole(); }
    return iv_ends(vec4<f32>(a.x / b.x, a.x / b.y, a.y / b.x, a.y / b.y));
}
fn iv_min(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> { return vec2<f32>(min(a.x, b.x), min(a.y, b.y)); }
fn iv_max(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> { return vec2<f32>(max(a.x, b.x), max(a.y, b.y)); }
// A whole exponent below 64 in magnitude: powf of the ends (of |a| for an
// even one); a positive base: exp(b·ln a); else the whole line.
fn iv_pow(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    if (b.x == b.y && b.x == floor(b.x) && abs(b.x) < 64.0) {
        let n = i32(b.x);
        if (n == 0) { return vec2<f32>(1.0, 1.0); }
        if (n < 0 && a.x <= 0.0 && a.y >= 0.0) { return iv_whole(); }
        var base = a;
        if (n % 2 == 0) { base = iv_abs(a); }
        return iv_out(iso_pow(base.x, b.x), iso_pow(base.y, b.x), 1e-4, IV_TINY);
    }
    if (a.x > 0.0) { return iv_exp(iv_mul(b, iv_ln(a))); }
    return iv_whole();
}
fn iv_atan2(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> { return vec2<f32>(-IV_PI, IV_PI); }
// select(c > 0 ? a : b): one branch where c keeps its sign, else both.
fn iv_select(c: vec2<f32>, a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    if (c.x > 0.0) { return a; }
    if (c.y <= 0.0) { return b; }
    return iv_hull(a, b);
}
"#;

/// The WGSL interval rule of `op` (a function of [`INTERVAL_PRELUDE`]).
pub fn unary_rule(op: UnOp) -> &'static str {
    match op {
        UnOp::Neg => "iv_neg",
        UnOp::Abs => "iv_abs",
        UnOp::Sqrt => "iv_sqrt",
        UnOp::Square => "iv_square",
        UnOp::Sin => "iv_sin",
        UnOp::Cos => "iv_cos",
        UnOp::Tan => "iv_tan",
        UnOp::Asin => "iv_asin",
        UnOp::Acos => "iv_acos",
        UnOp::Atan => "iv_atan",
        UnOp::Exp => "iv_exp",
        UnOp::Ln => "iv_ln",
        UnOp::Floor => "iv_floor",
        UnOp::Round => "iv_round",
        UnOp::Sign => "iv_sign",
    }
}

/// The WGSL interval rule of `op` (a function of [`INTERVAL_PRELUDE`]).
pub fn binary_rule(op: BinOp) -> &'static str {
    match op {
        BinOp::Add => "iv_add",
        BinOp::Sub => "iv_sub",
        BinOp::Mul => "iv_mul",
        BinOp::Div => "iv_div",
        BinOp::Min => "iv_min",
        BinOp::Max => "iv_max",
        BinOp::Pow => "iv_pow",
        BinOp::Atan2 => "iv_atan2",
    }
}

/// A number as a WGSL interval expression containing it: the point of its
/// f32 where that is the number (a normal or zero f32), else that f32
/// widened; the whole line for NaN.
fn constant(v: f64) -> String {
    if v.is_nan() {
        return "iv_whole()".to_string();
    }
    let f = v as f32;
    let exact = f as f64 == v && (f == 0.0 || f.abs() >= f32::MIN_POSITIVE || !f.is_finite());
    let l = literal(v);
    if exact {
        format!("vec2<f32>({l}, {l})")
    } else {
        format!("iv_widen({l}, {l})")
    }
}

/// Writes `tape`'s interval extension as `fn NAME(lo: vec3<f32>, hi:
/// vec3<f32>) -> vec2<f32>`: bounds of its value over the box lo..hi (the
/// box's ends as f32 numbers below and above the box the caller means;
/// subnormal ends are best given as 0 or the smallest normal). It reads
/// the input-derived values from `BUFFER[base + k]` as [`emit_tape`](super::emit_tape)
/// does (the same [`WgslFunction::uniform_slots`] and fill), each widened
/// by its f32 rounding. Lazy regions are evaluated (as the CPU's interval
/// evaluator does: their select takes both branches where the condition
/// may change sign). A NaN constant gives the whole line where it is read.
pub fn emit_tape_interval<'a>(tape: &Tape, name: &str, buffer: impl Into<InputBuffer<'a>>, base: u32) -> WgslFunction {
    let mut code = format!("fn {name}(lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {{\n");
    for k in 0..tape.slots() {
        code.push_str(&format!("    var s{k}: vec2<f32>;\n"));
    }
    code.push_str("    s0 = iv(lo.x, hi.x);\n    s1 = iv(lo.y, hi.y);\n    s2 = iv(lo.z, hi.z);\n");
    for &(slot, v) in tape.constants() {
        code.push_str(&format!("    s{slot} = {};\n", constant(v)));
    }
    let (reads, uniform_slots) = buffer_reads(tape, buffer.into(), base);
    for (slot, e) in reads {
        code.push_str(&format!("    s{slot} = iv_widen({e}, {e});\n"));
    }
    for ins in tape.instrs() {
        match *ins {
            Instr::Skip { .. } => {}
            Instr::Unary { op, out, a } => {
                let call = match op {
                    UnOp::Sin => format!("iv_trig(s{a}, false)"),
                    UnOp::Cos => format!("iv_trig(s{a}, true)"),
                    op => format!("{}(s{a})", unary_rule(op)),
                };
                code.push_str(&format!("    s{out} = {call};\n"));
            }
            Instr::Binary { op, out, a, b } => {
                code.push_str(&format!("    s{out} = {}(s{a}, s{b});\n", binary_rule(op)));
            }
            Instr::Select { out, c, a, b } => {
                code.push_str(&format!("    s{out} = iv_select(s{c}, s{a}, s{b});\n"));
            }
        }
    }
    code.push_str(&format!("    return s{};\n}}\n", tape.output()));
    WgslFunction { code, uniform_slots }
}

/// The box `lo..=hi` (f64) as f32 ends for an interval function: the
/// largest f32 at most `lo` and the smallest at least `hi`, with a
/// subnormal end moved out to 0 or the smallest normal f32 (a GPU may
/// flush a subnormal to zero, on the wrong side of the box).
pub fn box_ends(lo: f64, hi: f64) -> (f32, f32) {
    (f32_below(lo), -f32_below(-hi))
}

/// The box x × y × z (f64 ends) as the f32 corners an interval function
/// takes (low, then high), each end as [`box_ends`] moves it.
pub fn f32_box(b: &[(f64, f64); 3]) -> [[f32; 3]; 2] {
    let e = b.map(|(lo, hi)| box_ends(lo, hi));
    [[e[0].0, e[1].0, e[2].0], [e[0].1, e[1].1, e[2].1]]
}

/// The largest normal (or zero, or infinite) f32 at most `x`; NaN stays NaN.
pub fn f32_below(x: f64) -> f32 {
    if x.is_nan() {
        return f32::NAN;
    }
    let mut f = x as f32;
    if f as f64 > x {
        f = next_down(f);
    }
    if f != 0.0 && f.abs() < f32::MIN_POSITIVE {
        f = if f > 0.0 { 0.0 } else { -f32::MIN_POSITIVE };
    }
    f
}

fn next_down(f: f32) -> f32 {
    if f.is_nan() || f == f32::NEG_INFINITY {
        f
    } else if f == 0.0 {
        -f32::from_bits(1)
    } else if f > 0.0 {
        f32::from_bits(f.to_bits() - 1)
    } else {
        f32::from_bits(f.to_bits() + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_ends_hold_the_box() {
        let cases = [
            (0.1, 0.2),
            (-0.1, 0.1),
            (1e-310, 1e-300),
            (-1e-310, -1e-320),
            (1e300, f64::INFINITY),
            (f64::NEG_INFINITY, -1e300),
            (1.0, 1.0),
            (0.0, 0.0),
        ];
        for (lo, hi) in cases {
            let (a, b) = box_ends(lo, hi);
            assert!(a as f64 <= lo && hi <= b as f64, "[{lo}, {hi}] -> [{a}, {b}]");
            for e in [a, b] {
                assert!(e == 0.0 || e.abs() >= f32::MIN_POSITIVE, "{e} is subnormal");
            }
        }
        assert_eq!(box_ends(1.0, 1.0), (1.0, 1.0));
        assert_eq!(box_ends(1e-310, 1e-310), (0.0, f32::MIN_POSITIVE));
        assert_eq!(box_ends(1e300, 1e300), (f32::MAX, f32::INFINITY));
        assert!((f32_below(0.1) as f64) < 0.1);
    }

    #[test]
    fn constants_are_contained() {
        assert_eq!(constant(0.5), "vec2<f32>(5e-1f, 5e-1f)");
        assert!(constant(0.1).starts_with("iv_widen("));
        assert!(constant(1e-40).starts_with("iv_widen("));
    }
}
