//! Interval arithmetic over a [`Tape`]: bounds of a shape's value over a box.
//!
//! Every operation returns an interval containing all values the operation
//! takes on its argument intervals (results are widened by a few ulps to
//! absorb rounding). Used for guaranteed distance bounds (Lipschitz bounds
//! over a ball) and for skipping empty space.

use crate::ir::{BinOp, Instr, Tape, UnOp};

/// A closed interval [lo, hi]; `lo > hi` never occurs. Infinite ends are allowed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

const WHOLE: Interval = Interval {
    lo: f64::NEG_INFINITY,
    hi: f64::INFINITY,
};

#[inline(always)]
fn down(x: f64) -> f64 {
    if x.is_finite() {
        x - (x.abs() * 4.0 * f64::EPSILON + f64::MIN_POSITIVE)
    } else {
        x
    }
}

#[inline(always)]
fn up(x: f64) -> f64 {
    if x.is_finite() {
        x + (x.abs() * 4.0 * f64::EPSILON + f64::MIN_POSITIVE)
    } else {
        x
    }
}

impl Interval {
    /// [lo, hi] (swapped if given in the wrong order; NaN gives the whole line).
    #[inline(always)]
    pub fn new(lo: f64, hi: f64) -> Interval {
        if lo.is_nan() || hi.is_nan() {
            return WHOLE;
        }
        Interval {
            lo: lo.min(hi),
            hi: lo.max(hi),
        }
    }
    /// The point interval [x, x].
    pub fn point(x: f64) -> Interval {
        Interval::new(x, x)
    }
    /// True when x lies in the interval.
    pub fn contains(&self, x: f64) -> bool {
        self.lo <= x && x <= self.hi
    }
    /// hi − lo.
    pub fn width(&self) -> f64 {
        self.hi - self.lo
    }
    #[inline(always)]
    fn widen(lo: f64, hi: f64) -> Interval {
        Interval::new(down(lo), up(hi))
    }
    fn hull(a: Interval, b: Interval) -> Interval {
        Interval::new(a.lo.min(b.lo), a.hi.max(b.hi))
    }
    fn monotone(self, f: impl Fn(f64) -> f64) -> Interval {
        Interval::widen(f(self.lo), f(self.hi))
    }

    /// A unary operation.
    #[inline(always)]
    pub fn unary(op: UnOp, a: Interval) -> Interval {
        match op {
            UnOp::Neg => Interval::new(-a.hi, -a.lo),
            UnOp::Abs => a.abs(),
            UnOp::Sqrt => {
                if a.hi < 0.0 {
                    return Interval::point(f64::NAN).nan_to_whole();
                }
                Interval::widen(a.lo.max(0.0).sqrt(), a.hi.sqrt()).clamp_lo(0.0)
            }
            UnOp::Square => {
                let m = a.abs();
                Interval::widen(m.lo * m.lo, m.hi * m.hi).clamp_lo(0.0)
            }
            UnOp::Sin => trig(a, f64::sin, std::f64::consts::FRAC_PI_2),
            UnOp::Cos => trig(a, f64::cos, 0.0),
            UnOp::Tan => {
                // Monotone between the asymptotes at π/2 + kπ; the whole line
                // when one lies in the interval or within rounding of it.
                if !a.lo.is_finite() || !a.hi.is_finite() || a.width() >= std::f64::consts::PI {
                    WHOLE
                } else if let Some((k0, k1)) = extrema(a, std::f64::consts::FRAC_PI_2) {
                    if k0 <= k1 {
                        WHOLE
                    } else {
                        a.monotone(f64::tan)
                    }
                } else {
                    WHOLE
                }
            }
            UnOp::Asin => Interval::new(a.lo.max(-1.0), a.hi.min(1.0)).monotone(f64::asin),
            UnOp::Acos => {
                let c = Interval::new(a.lo.max(-1.0), a.hi.min(1.0));
                Interval::widen(c.hi.acos(), c.lo.acos())
            }
            UnOp::Atan => a.monotone(f64::atan),
            UnOp::Exp => a.monotone(f64::exp).clamp_lo(0.0),
            UnOp::Ln => {
                if a.hi <= 0.0 {
                    return WHOLE;
                }
                Interval::widen(if a.lo > 0.0 { a.lo.ln() } else { f64::NEG_INFINITY }, a.hi.ln())
            }
            UnOp::Floor => Interval::new(a.lo.floor(), a.hi.floor()),
            UnOp::Round => Interval::new(a.lo.round(), a.hi.round()),
            UnOp::Sign => Interval::new(crate::ir::sign(a.lo), crate::ir::sign(a.hi)),
        }
    }

    /// A binary operation.
    #[inline(always)]
    pub fn binary(op: BinOp, a: Interval, b: Interval) -> Interval {
        match op {
            BinOp::Add => Interval::widen(a.lo + b.lo, a.hi + b.hi),
            BinOp::Sub => Interval::widen(a.lo - b.hi, a.hi - b.lo),
            BinOp::Mul => {
                let ps = [a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi];
                if ps.iter().any(|p| p.is_nan()) {
                    return WHOLE; // 0 × ∞
                }
                Interval::widen(
                    ps.iter().copied().fold(f64::INFINITY, f64::min),
                    ps.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                )
            }
            BinOp::Div => {
                if b.lo <= 0.0 && b.hi >= 0.0 {
                    return WHOLE;
                }
                // Monotone in each argument where b keeps its sign: the
                // extremes are quotients of ends (not a × 1/b, whose 1/b
                // overflows for a subnormal b even where a/b is moderate).
                let qs = [a.lo / b.lo, a.lo / b.hi, a.hi / b.lo, a.hi / b.hi];
                if qs.iter().any(|q| q.is_nan()) {
                    return WHOLE; // ∞ / ∞
                }
                Interval::widen(
                    qs.iter().copied().fold(f64::INFINITY, f64::min),
                    qs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                )
            }
            BinOp::Min => Interval::new(a.lo.min(b.lo), a.hi.min(b.hi)),
            BinOp::Max => Interval::new(a.lo.max(b.lo), a.hi.max(b.hi)),
            BinOp::Pow => {
                if b.lo == b.hi && b.lo.fract() == 0.0 && b.lo.abs() < 64.0 {
                    let n = b.lo as i32;
                    if n == 0 {
                        return Interval::point(1.0);
                    }
                    let base = if n % 2 == 0 { a.abs() } else { a };
                    // Decreasing for n < 0: order the ends before widening
                    // them. powf, as the reference: powi's repeated squaring
                    // is off by up to |n| ulps.
                    let (p, q) = (base.lo.powf(b.lo), base.hi.powf(b.lo));
                    let r = Interval::widen(p.min(q), p.max(q));
                    if n < 0 && a.contains(0.0) {
                        return WHOLE;
                    }
                    return r;
                }
                if a.lo > 0.0 {
                    // a^b = exp(b ln a).
                    let l = unary_call(UnOp::Ln, a);
                    return unary_call(UnOp::Exp, binary_call(BinOp::Mul, b, l));
                }
                WHOLE
            }
            BinOp::Atan2 => Interval::new(-std::f64::consts::PI, std::f64::consts::PI),
        }
    }

    #[inline(always)]
    fn abs(self) -> Interval {
        if self.lo >= 0.0 {
            self
        } else if self.hi <= 0.0 {
            Interval::new(-self.hi, -self.lo)
        } else {
            Interval::new(0.0, (-self.lo).max(self.hi))
        }
    }

    #[inline(always)]
    fn clamp_lo(self, lo: f64) -> Interval {
        Interval::new(self.lo.max(lo), self.hi.max(lo))
    }

    fn nan_to_whole(self) -> Interval {
        if self.lo.is_nan() || self.hi.is_nan() {
            WHOLE
        } else {
            self
        }
    }
}

/// The range k0..=k1 of the k for which `first + kπ` lies in the interval
/// or within rounding of it (the points are computed in f64, a few ulps of
/// the interval's magnitude off); `None` when k is too large for its parity
/// to be known.
fn extrema(a: Interval, first: f64) -> Option<(f64, f64)> {
    use std::f64::consts::PI;
    let margin = 8.0 * f64::EPSILON * a.lo.abs().max(a.hi.abs()) + 4.0 * f64::EPSILON;
    let k0 = ((a.lo - margin - first) / PI).ceil();
    let k1 = ((a.hi + margin - first) / PI).floor();
    (k0.abs().max(k1.abs()) < 2f64.powi(52)).then_some((k0, k1))
}

/// sin or cos (`f`) over an interval: the values at the ends, and ±1 where a
/// crest or trough `first + kπ` (a crest for even k) may lie inside.
fn trig(a: Interval, f: fn(f64) -> f64, first: f64) -> Interval {
    use std::f64::consts::TAU;
    const UNIT: Interval = Interval { lo: -1.0, hi: 1.0 };
    if !a.lo.is_finite() || !a.hi.is_finite() || a.width() >= TAU {
        return UNIT;
    }
    let Some((k0, k1)) = extrema(a, first) else {
        return UNIT;
    };
    if k1 - k0 >= 1.0 {
        return UNIT; // a crest and a trough
    }
    let (fl, fh) = (f(a.lo), f(a.hi));
    let (mut mn, mut mx) = (fl.min(fh), fl.max(fh));
    if k0 == k1 {
        if k0.rem_euclid(2.0) == 0.0 {
            mx = 1.0;
        } else {
            mn = -1.0;
        }
    }
    Interval::new(down(mn).max(-1.0), up(mx).min(1.0))
}

/// Bounds of a tape over the box x × y × z, with the inputs `vars`.
pub fn eval_interval(tape: &Tape, vars: &[f64], x: Interval, y: Interval, z: Interval) -> Interval {
    eval_interval_choices(tape, vars, [x, y, z], None)
}

/// Which operands of a `min`, `max` or select can give its value over a box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Choice {
    /// Either (or another instruction than min, max and select).
    Both,
    /// Only the left operand (of a select: the `c > 0` branch): its
    /// interval lies strictly on the winning side.
    Left,
    /// Only the right operand (of a select: the other branch).
    Right,
}

/// [`eval_interval`] over the box `xyz`, also recording in `choices` (one
/// entry per instruction, when given) which operands of each `min`, `max`
/// and select can give its value anywhere in the box:
/// [`crate::simplify::simplify`] drops the others. Allocates its working
/// memory; [`IntervalEvaluator`] reuses it over many boxes.
pub fn eval_interval_choices(
    tape: &Tape,
    vars: &[f64],
    xyz: [Interval; 3],
    choices: Option<&mut Vec<Choice>>,
) -> Interval {
    IntervalEvaluator::new(tape, vars).eval(tape, xyz, choices)
}

/// Interval evaluation of one tape and its rewrites (the simplified tapes
/// of [`crate::simplify::simplify`]) over many boxes, with the inputs fixed
/// when it is made: the constants and the prologue's values are written
/// once, and each box costs only the instructions of the tape evaluated.
#[derive(Debug, Clone)]
pub struct IntervalEvaluator<'t> {
    tape: &'t Tape,
    slots: Vec<Interval>,
    /// Scratch for finding smooth minimums.
    blends: Blends,
    /// The smooth minimums of each tape evaluated so far, by [`Tape::id`]
    /// (a renderer evaluates each of its simplified tapes over up to eight
    /// boxes, its cells' children, at different times).
    tables: rustc_hash::FxHashMap<u64, BlendTable>,
    /// The operands' bounds of each smooth minimum of the tape being
    /// evaluated, saved at its `min` for its last instruction.
    args: Vec<(Interval, Interval)>,
    /// Whether the tape has a smooth minimum (its rewrites, which only drop
    /// and forward instructions, are not searched when it has none).
    any_blends: bool,
}

/// Tables kept at most; past this the cache starts again.
const MAX_TABLES: usize = 1 << 16;

/// The smooth minimums of one tape: the positions of their `min`
/// instructions, ascending, and of their last instructions, ascending,
/// each with its `min`'s number in the first list and its k.
#[derive(Debug, Clone, Default)]
struct BlendTable {
    mins: Vec<u32>,
    ends: Vec<(u32, u32, f64)>,
}

impl BlendTable {
    fn of(blends: &Blends) -> BlendTable {
        // Ascending, as the instructions come.
        let mins: Vec<u32> = (0..blends.role.len() as u32)
            .filter(|&i| blends.role[i as usize] == 1)
            .collect();
        let ends = (0..blends.role.len() as u32)
            .filter(|&i| blends.role[i as usize] == 2)
            .map(|i| {
                let (m, k) = blends.ends[i as usize];
                let at = mins.binary_search(&m).expect("every end has its min") as u32;
                (i, at, k)
            })
            .collect();
        BlendTable { mins, ends }
    }
}

/// The smooth minimums of a tape, found by their instructions, which
/// interval arithmetic bounds far too loosely: min(a, b) − h²/(4k) with
/// h = max(k − |a − b|, 0) loses that h is large only where a and b are
/// close, so each one lowers the lower bound by k/4, and a fold of a
/// thousand objects (a scene's `render.blend`) by hundreds of k. The
/// function is nondecreasing in a and in b, so its exact range over a box
/// is [f(a.lo, b.lo), f(a.hi, b.hi)]: the evaluator intersects the
/// instructions' bound with that.
#[derive(Debug, Clone, Default)]
struct Blends {
    /// Per slot: the instruction that last wrote it, or [`UNWRITTEN`].
    defs: Vec<u32>,
    /// Per instruction: the writers of its operands a and b.
    ops: Vec<[u32; 2]>,
    /// Per instruction: 0; 1 for the `min` of a smooth minimum; 2 for
    /// its last instruction (`ends` says which `min` and which k).
    role: Vec<u8>,
    ends: Vec<(u32, f64)>,
}

/// A slot no instruction writes (an input, constant or prologue value).
const UNWRITTEN: u32 = u32::MAX;

/// The quadratic smooth minimum min(a, b) − max(k − |a − b|, 0)²/(4k).
fn smooth_min(a: f64, b: f64, k: f64) -> f64 {
    let h = (k - (a - b).abs()).max(0.0);
    a.min(b) - h * h * (0.25 / k)
}

impl Blends {
    /// Finds the smooth minimums of `instrs`; `slots` holds the values of
    /// the slots no instruction writes.
    fn find(&mut self, instrs: &[Instr], slots: &[Interval]) {
        let n = instrs.len();
        self.defs.clear();
        self.defs.resize(slots.len(), UNWRITTEN);
        self.ops.clear();
        self.role.clear();
        self.role.resize(n, 0);
        self.ends.clear();
        self.ends.resize(n, (0, 0.0));
        for (i, ins) in instrs.iter().enumerate() {
            let (out, a, b) = match *ins {
                Instr::Unary { out, a, .. } => (out, a, a),
                Instr::Binary { out, a, b, .. } => (out, a, b),
                Instr::Select { out, a, b, .. } => (out, a, b),
                Instr::Skip { .. } => {
                    self.ops.push([UNWRITTEN; 2]);
                    continue;
                }
            };
            self.ops.push([self.defs[a as usize], self.defs[b as usize]]);
            self.defs[out as usize] = i as u32;
            if let Some((m, k)) = self.matches(instrs, slots, i) {
                self.role[m as usize] = 1;
                self.role[i] = 2;
                self.ends[i] = (m, k);
            }
        }
    }

    /// Whether instruction `i` ends a smooth minimum: Some((its `min`, k)).
    fn matches(&self, instrs: &[Instr], slots: &[Interval], i: usize) -> Option<(u32, f64)> {
        let ops = &self.ops;
        // A constant or prologue value (no instruction writes it, and it
        // is not x, y or z), known exactly.
        let known = |slot: u32, def: u32| {
            let v = slots[slot as usize];
            (slot >= 3 && def == UNWRITTEN && v.lo == v.hi).then_some(v.lo)
        };
        let binary = |i: u32, want: BinOp| match instrs.get(i as usize) {
            Some(&Instr::Binary { op, a, b, .. }) if op == want => Some((a, b, ops[i as usize])),
            _ => None,
        };
        let unary = |i: u32, want: UnOp| match instrs.get(i as usize) {
            Some(&Instr::Unary { op, .. }) if op == want => Some(ops[i as usize][0]),
            _ => None,
        };
        // m − c·h² with m = min(x, y)
        let (_, _, [m, corr]) = binary(i as u32, BinOp::Sub)?;
        let (_, _, xy) = binary(m, BinOp::Min)?;
        let (ca, cb, [da, db]) = binary(corr, BinOp::Mul)?;
        let (c, h2) = match (known(ca, da), known(cb, db)) {
            (Some(c), None) => (c, db),
            (None, Some(c)) => (c, da),
            _ => return None,
        };
        // h = max(k − |d|, 0)
        let h = unary(h2, UnOp::Square)?;
        let (ha, hb, [dha, dhb]) = binary(h, BinOp::Max)?;
        let kd = match (known(ha, dha), known(hb, dhb)) {
            (None, Some(0.0)) => dha,
            (Some(0.0), None) => dhb,
            _ => return None,
        };
        let (ks, _, [dk, ad]) = binary(kd, BinOp::Sub)?;
        let k = known(ks, dk).filter(|&k| k > 0.0 && k.is_finite())?;
        // d = x − y or y − x
        let d = unary(ad, UnOp::Abs)?;
        let (_, _, ab) = binary(d, BinOp::Sub)?;
        let same = ab == xy || ab == [xy[1], xy[0]];
        (same && (c * 4.0 * k - 1.0).abs() < 1e-12).then_some((m, k))
    }
}

/// How far apart two operands' intervals must be for one to win a `min` or
/// `max` over the whole box: a relative margin, so that the f32 evaluators
/// (whose rounding differs from these f64 bounds by far less) make the
/// same choice at every point of the box.
fn separated(below: f64, above: f64) -> bool {
    below < above - 1e-5 * (below.abs() + above.abs())
}

impl<'t> IntervalEvaluator<'t> {
    /// An evaluator of `tape` (and its rewrites) with the inputs `vars`.
    pub fn new(tape: &'t Tape, vars: &[f64]) -> Self {
        let mut s = vec![WHOLE; tape.slots()];
        for &(k, v) in tape.constants() {
            s[k as usize] = Interval::point(v);
        }
        let mut scratch = Vec::new();
        for (k, v) in tape.prologue().run(vars, &mut scratch) {
            s[k] = Interval::point(v);
        }
        let mut blends = Blends::default();
        blends.find(tape.instrs(), &s);
        let table = BlendTable::of(&blends);
        let any_blends = !table.ends.is_empty();
        let mut tables = rustc_hash::FxHashMap::default();
        tables.insert(tape.id(), table);
        IntervalEvaluator {
            tape,
            slots: s,
            blends,
            tables,
            args: Vec::new(),
            any_blends,
        }
    }

    /// The tape it was made for.
    pub fn tape(&self) -> &'t Tape {
        self.tape
    }

    /// Bounds of `variant` (this evaluator's tape or a rewrite of it, see
    /// [`Tape::same_frame`]) over the box `xyz`, recording the choices of
    /// its min, max and select instructions in `choices` when given (see
    /// [`eval_interval_choices`]).
    ///
    /// # Panics
    /// When `variant` is not a rewrite of this evaluator's tape.
    pub fn eval(&mut self, variant: &Tape, xyz: [Interval; 3], mut choices: Option<&mut Vec<Choice>>) -> Interval {
        assert!(
            variant.same_frame(self.tape),
            "a variant must keep its tape's slots and constants"
        );
        let instrs = variant.instrs();
        if self.any_blends && !self.tables.contains_key(&variant.id()) {
            if self.tables.len() >= MAX_TABLES {
                self.tables.clear();
            }
            self.blends.find(instrs, &self.slots);
            self.tables.insert(variant.id(), BlendTable::of(&self.blends));
        }
        const EMPTY: &BlendTable = &BlendTable {
            mins: Vec::new(),
            ends: Vec::new(),
        };
        let table = match self.any_blends {
            true => self.tables.get(&variant.id()).unwrap_or(EMPTY),
            false => EMPTY,
        };
        let args = &mut self.args;
        args.clear();
        args.resize(table.mins.len(), (WHOLE, WHOLE));
        let (mut mi, mut ei) = (0usize, 0usize);
        let at = |v: Option<u32>| v.map_or(usize::MAX, |i| i as usize);
        let mut next_min = at(table.mins.first().copied());
        let mut next_end = at(table.ends.first().map(|e| e.0));
        let s = &mut self.slots;
        s[..3].copy_from_slice(&xyz);
        if let Some(c) = choices.as_deref_mut() {
            c.clear();
            c.resize(instrs.len(), Choice::Both);
        }
        for (i, ins) in instrs.iter().enumerate() {
            match *ins {
                // Lazy regions are evaluated: their select takes the hull where c may be ≤ 0.
                Instr::Skip { .. } => {}
                Instr::Unary { op, out, a } => {
                    let ia = s[a as usize];
                    s[out as usize] = match op {
                        UnOp::Neg => Interval::unary(UnOp::Neg, ia),
                        UnOp::Abs => Interval::unary(UnOp::Abs, ia),
                        UnOp::Sqrt => Interval::unary(UnOp::Sqrt, ia),
                        UnOp::Square => Interval::unary(UnOp::Square, ia),
                        op => unary_call(op, ia),
                    }
                }
                Instr::Binary { op, out, a, b } => {
                    let (ia, ib) = (s[a as usize], s[b as usize]);
                    let choice = match op {
                        BinOp::Min if separated(ia.hi, ib.lo) => Choice::Left,
                        BinOp::Min if separated(ib.hi, ia.lo) => Choice::Right,
                        BinOp::Max if separated(ib.hi, ia.lo) => Choice::Left,
                        BinOp::Max if separated(ia.hi, ib.lo) => Choice::Right,
                        _ => Choice::Both,
                    };
                    let mut r = match op {
                        BinOp::Add => Interval::binary(BinOp::Add, ia, ib),
                        BinOp::Sub => Interval::binary(BinOp::Sub, ia, ib),
                        BinOp::Mul => Interval::binary(BinOp::Mul, ia, ib),
                        BinOp::Min => Interval::binary(BinOp::Min, ia, ib),
                        BinOp::Max => Interval::binary(BinOp::Max, ia, ib),
                        op => binary_call(op, ia, ib),
                    };
                    if i == next_min {
                        args[mi] = (ia, ib);
                        mi += 1;
                        next_min = at(table.mins.get(mi).copied());
                    }
                    if i == next_end {
                        let (_, m, k) = table.ends[ei];
                        let (a, b) = args[m as usize];
                        r = tighter(r, a, b, k);
                        ei += 1;
                        next_end = at(table.ends.get(ei).map(|e| e.0));
                    }
                    s[out as usize] = r;
                    if choice != Choice::Both {
                        if let Some(c) = choices.as_deref_mut() {
                            c[i] = choice;
                        }
                    }
                }
                Instr::Select { out, c, a, b } => {
                    let ci = s[c as usize];
                    let choice;
                    (s[out as usize], choice) = if ci.lo > 0.0 {
                        (s[a as usize], Choice::Left)
                    } else if ci.hi <= 0.0 {
                        (s[b as usize], Choice::Right)
                    } else {
                        (Interval::hull(s[a as usize], s[b as usize]), Choice::Both)
                    };
                    if let Some(c) = choices.as_deref_mut() {
                        c[i] = choice;
                    }
                }
            }
        }
        s[variant.output()]
    }
}

/// The operations without a fast path, out of line.
#[inline(never)]
fn unary_call(op: UnOp, a: Interval) -> Interval {
    Interval::unary(op, a)
}

#[inline(never)]
fn binary_call(op: BinOp, a: Interval, b: Interval) -> Interval {
    Interval::binary(op, a, b)
}

/// `r` (a bound of a smooth minimum of width `k` of operands bounded by
/// `a` and `b`) intersected with the function's exact range.
fn tighter(r: Interval, a: Interval, b: Interval, k: f64) -> Interval {
    let (lo, hi) = (smooth_min(a.lo, b.lo, k), smooth_min(a.hi, b.hi, k));
    // Rounding of the few operations, relative to their operands' size.
    let slack = |m: f64| 16.0 * f64::EPSILON * (m.abs() + k) + f64::MIN_POSITIVE;
    let lo = if lo.is_nan() {
        f64::NEG_INFINITY
    } else {
        lo - slack(a.lo.min(b.lo))
    };
    let hi = if hi.is_nan() {
        f64::INFINITY
    } else {
        hi + slack(a.hi.min(b.hi))
    };
    if lo.max(r.lo) <= hi.min(r.hi) {
        Interval::new(lo.max(r.lo), hi.min(r.hi))
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{compile, Library};

    #[test]
    fn tight_on_simple_functions() {
        let sq = Interval::unary(UnOp::Square, Interval::new(-1.0, 2.0));
        assert!(sq.lo == 0.0 && (sq.hi - 4.0).abs() < 1e-12);
        let s = Interval::unary(UnOp::Sin, Interval::new(0.0, 3.0));
        assert!((s.hi - 1.0).abs() < 1e-12 && s.lo.abs() < 1e-12);
        let c = Interval::unary(UnOp::Cos, Interval::new(-0.5, 0.5));
        assert!((c.hi - 1.0).abs() < 1e-12 && (c.lo - 0.5f64.cos()).abs() < 1e-12);
        assert_eq!(
            Interval::binary(BinOp::Div, Interval::point(1.0), Interval::new(-1.0, 1.0)),
            WHOLE
        );
        // The sphere's distance over a box away from it.
        let sh = compile(&Library::new(), "sphere(p, 1.0)").unwrap();
        let r = eval_interval(
            sh.tape(),
            &[],
            Interval::new(2.0, 3.0),
            Interval::new(0.0, 0.0),
            Interval::new(0.0, 0.0),
        );
        assert!(r.lo >= 1.0 - 1e-9 && r.hi <= 2.0 + 1e-9, "{r:?}");
    }

    /// Regressions the conformance suite found (tests/conformance.rs).
    #[test]
    fn awkward_arguments() {
        use std::f64::consts::FRAC_PI_2;
        let p = Interval::point;
        // sin/cos of a huge point terminate (the crest search used to loop
        // forever once k + 1 = k) and contain the value; cos is not a shifted
        // sine, which is an ulp of the shifted argument off.
        for x in [1e300, 4503599627370497.0, 1e10, -746.0] {
            assert!(Interval::unary(UnOp::Sin, p(x)).contains(x.sin()), "sin {x}");
            assert!(Interval::unary(UnOp::Cos, p(x)).contains(x.cos()), "cos {x}");
        }
        // tan over an interval that straddles π/2 (FRAC_PI_2 lies below it).
        let up1 = f64::from_bits(FRAC_PI_2.to_bits() + 1);
        assert_eq!(Interval::unary(UnOp::Tan, Interval::new(FRAC_PI_2, up1 + 1e-15)), WHOLE);
        // a / b with a subnormal b: 1/b overflows, a/b does not.
        let q = Interval::binary(BinOp::Div, p(1e-310), p(1e-310));
        assert!(q.contains(1.0), "{q:?}");
        // Negative powers decrease: the widening goes outwards.
        let r = Interval::binary(BinOp::Pow, Interval::new(1.0, 2.0), p(-1.0));
        assert!(r.contains(1.0) && r.contains(0.5), "{r:?}");
        // High integer powers are as accurate as powf.
        let x: f64 = -2.997;
        assert!(Interval::binary(BinOp::Pow, p(x), p(63.0)).contains(x.powf(63.0)));
    }

    #[test]
    fn contains_every_sampled_value() {
        let lib = Library::new();
        let srcs = [
            "smooth_union(torus(rotate_x(p, 0.7), 1.0, 0.3), box(p - vec3(0.5), vec3(0.4)), 0.2)",
            "octahedron(twist_y(p, 2.0), 1.0) + displace(p, 0.1, 7.0)",
            "cone(p, 0.5, 1.0) / (1.0 + abs(p.x)) + pow(abs(p.y) + 0.1, 1.5) - exp(-p.z)",
            "sphere(repeat_limited(p, 0.7, 2.0), 0.2) + tan(p.x * 0.3) + atan(p.y, p.z)",
        ];
        let mut seed = 99u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for src in srcs {
            let sh = compile(&lib, src).unwrap();
            for _ in 0..300 {
                let c = [rnd() * 6.0 - 3.0, rnd() * 6.0 - 3.0, rnd() * 6.0 - 3.0];
                let h = rnd() * 0.8;
                let bx = Interval::new(c[0] - h, c[0] + h);
                let by = Interval::new(c[1] - h, c[1] + h);
                let bz = Interval::new(c[2] - h, c[2] + h);
                let r = eval_interval(sh.tape(), &[], bx, by, bz);
                for _ in 0..20 {
                    let p = [
                        c[0] + (rnd() * 2.0 - 1.0) * h,
                        c[1] + (rnd() * 2.0 - 1.0) * h,
                        c[2] + (rnd() * 2.0 - 1.0) * h,
                    ];
                    let v = sh.eval(p);
                    assert!(
                        v.is_nan() || r.contains(v),
                        "{src}: {v} not in {r:?} over box at {c:?} ± {h}"
                    );
                }
            }
        }
    }

    /// A chain of smooth unions as a scene's `render.blend` builds it
    /// ([`crate::ir::Builder::smooth_union`]) of spheres of radius
    /// `r` at `centres`.
    fn blended_spheres(centres: &[[f64; 3]], r: f64, k: f64) -> Tape {
        use crate::ir::Builder;
        let mut b = Builder::new();
        let (x, y, z) = (b.x(), b.y(), b.z());
        let mut acc = None;
        for c in centres {
            let dx = b.add_c(x, -c[0]);
            let dy = b.add_c(y, -c[1]);
            let dz = b.add_c(z, -c[2]);
            let (sx, sy, sz) = (b.square(dx), b.square(dy), b.square(dz));
            let sxy = b.add(sx, sy);
            let s = b.add(sxy, sz);
            let len = b.sqrt(s);
            let d = b.add_c(len, -r);
            acc = Some(match acc {
                None => d,
                Some(a) => b.smooth_union(a, d, k),
            });
        }
        b.tape(acc.unwrap())
    }

    /// Bounds of a fold of smooth unions stay within k of the nearest
    /// object's (plain interval arithmetic loses k/4 per object), and
    /// contain every sampled value.
    #[test]
    fn smooth_union_folds_are_bounded_tightly() {
        let mut seed = 5u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let centres: Vec<[f64; 3]> = (0..60).map(|_| [0.0; 3].map(|_: f64| rnd() * 4.0 - 2.0)).collect();
        let (r, k) = (0.3, 0.4);
        let tape = blended_spheres(&centres, r, k);
        let mut ev = IntervalEvaluator::new(&tape, &[]);
        let point = |p: [f64; 3]| {
            let mut e = crate::PointEvaluator::<f64>::new(&tape);
            e.eval(&[], p[0], p[1], p[2])
        };
        for round in 0..200 {
            let c = [0.0; 3].map(|_: f64| rnd() * 10.0 - 5.0);
            let h = if round % 2 == 0 { 0.05 } else { rnd() * 1.5 };
            let bx = c.map(|v| Interval::new(v - h, v + h));
            let got = ev.eval(&tape, bx, None);
            // The nearest sphere's distance over the box, exactly.
            let near = centres
                .iter()
                .map(|q| {
                    let d2: f64 = (0..3).map(|i| (q[i] - c[i]).abs().max(h) - h).map(|v| v * v).sum();
                    d2.sqrt() - r
                })
                .fold(f64::INFINITY, f64::min);
            assert!(got.lo >= near - k - 1e-9, "lower bound {} far below {near} - k", got.lo);
            for _ in 0..10 {
                let p: [f64; 3] = std::array::from_fn(|i| c[i] + (rnd() * 2.0 - 1.0) * h);
                assert!(got.contains(point(p)), "{} not in {got:?}", point(p));
            }
        }
    }
}
