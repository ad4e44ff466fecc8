//! Evaluators over a [`Tape`]: one point, a batch of points, and gradients.
//!
//! * [`PointEvaluator`] runs the tape on one point, in any [`Num`] (f32, f64,
//!   or a [`Dual`] number for forward-mode automatic differentiation).
//! * [`BatchEvaluator`] is the hot path of rendering: it runs each instruction
//!   over a block of [`LANES`] points stored as structure-of-arrays, so the
//!   inner loops are straight-line arithmetic the compiler vectorises. It
//!   allocates only when it is created.
//! * [`gradient`] and [`BatchEvaluator::gradients`] give the gradient by
//!   automatic differentiation or by finite differences ([`GradientMode`]).
//!
//! Every evaluation takes the runtime inputs as a slice `vars` (index
//! [`TIME`](crate::ir::TIME) is the time, then the scene's parameters; see
//! [`Tape::vars`]). The part of the tape that depends on inputs alone (its
//! [`Prologue`](crate::ir::Prologue)) runs again only when one of the values
//! it reads changed, so moving a slider costs nothing but the new points.
//! A tape that reads no input ignores `vars` (pass `&[]`).

use crate::ir::{apply_binary, apply_unary, BinOp, InputCache, Instr, Tape, UnOp};
use crate::program::{Compiler, Program, Slots};

/// Compiled tapes a [`BatchEvaluator`] keeps at most; past this its cache
/// starts again.
const MAX_PROGRAMS: usize = 1 << 16;

/// Number of points a [`BatchEvaluator`] processes per pass over the tape.
pub const LANES: usize = 64;

/// A number type the point evaluator can run on.
pub trait Num: Copy {
    /// Converts a constant.
    fn from_f64(v: f64) -> Self;
    /// The plain value (used for `select`'s comparison).
    fn value(self) -> f64;
    /// Applies a unary operation.
    fn unary(op: UnOp, a: Self) -> Self;
    /// Applies a binary operation.
    fn binary(op: BinOp, a: Self, b: Self) -> Self;
}

impl Num for f64 {
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn value(self) -> f64 {
        self
    }
    #[inline(always)]
    fn unary(op: UnOp, a: Self) -> Self {
        apply_unary(op, a)
    }
    #[inline(always)]
    fn binary(op: BinOp, a: Self, b: Self) -> Self {
        apply_binary(op, a, b)
    }
}

impl Num for f32 {
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    #[inline(always)]
    fn value(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn unary(op: UnOp, a: Self) -> Self {
        apply_unary(op, a)
    }
    #[inline(always)]
    fn binary(op: BinOp, a: Self, b: Self) -> Self {
        apply_binary(op, a, b)
    }
}

/// A dual number: a value and its partial derivatives with respect to x, y, z.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Dual {
    /// The value.
    pub v: f64,
    /// ∂/∂x, ∂/∂y, ∂/∂z.
    pub d: [f64; 3],
}

impl Dual {
    fn scale(self, k: f64) -> [f64; 3] {
        [self.d[0] * k, self.d[1] * k, self.d[2] * k]
    }
    /// A dual number with value `v` and derivatives `d`.
    pub fn with(v: f64, d: [f64; 3]) -> Dual {
        Dual { v, d }
    }
}

impl Num for Dual {
    fn from_f64(v: f64) -> Self {
        Dual { v, d: [0.0; 3] }
    }
    fn value(self) -> f64 {
        self.v
    }
    #[inline]
    fn unary(op: UnOp, a: Self) -> Self {
        let v = apply_unary(op, a.v);
        let k = match op {
            UnOp::Neg => -1.0,
            UnOp::Abs => {
                if a.v < 0.0 {
                    -1.0
                } else {
                    1.0
                }
            }
            UnOp::Sqrt => {
                if v > 0.0 {
                    0.5 / v
                } else {
                    0.0
                }
            }
            UnOp::Square => 2.0 * a.v,
            UnOp::Sin => a.v.cos(),
            UnOp::Cos => -a.v.sin(),
            UnOp::Tan => 1.0 + v * v,
            UnOp::Asin => 1.0 / (1.0 - a.v * a.v).sqrt(),
            UnOp::Acos => -1.0 / (1.0 - a.v * a.v).sqrt(),
            UnOp::Atan => 1.0 / (1.0 + a.v * a.v),
            UnOp::Exp => v,
            UnOp::Ln => 1.0 / a.v,
            UnOp::Floor | UnOp::Round | UnOp::Sign => 0.0,
        };
        Dual::with(v, a.scale(k))
    }
    #[inline]
    fn binary(op: BinOp, a: Self, b: Self) -> Self {
        let v = apply_binary(op, a.v, b.v);
        let lin = |ka: f64, kb: f64| {
            [
                a.d[0] * ka + b.d[0] * kb,
                a.d[1] * ka + b.d[1] * kb,
                a.d[2] * ka + b.d[2] * kb,
            ]
        };
        let d = match op {
            BinOp::Add => lin(1.0, 1.0),
            BinOp::Sub => lin(1.0, -1.0),
            BinOp::Mul => lin(b.v, a.v),
            // ∂/∂b = −(a/b)/b: no b² to underflow or overflow.
            BinOp::Div => lin(1.0 / b.v, -v / b.v),
            // The derivative of the operand min/max returns: `a` on ties, and
            // the other operand where one is NaN (which the value ignores).
            BinOp::Min => {
                if b.v < a.v || a.v.is_nan() {
                    b.d
                } else {
                    a.d
                }
            }
            BinOp::Max => {
                if b.v > a.v || a.v.is_nan() {
                    b.d
                } else {
                    a.d
                }
            }
            BinOp::Pow => {
                let ka = if b.v == 0.0 { 0.0 } else { b.v * a.v.powf(b.v - 1.0) };
                let kb = if a.v > 0.0 { v * a.v.ln() } else { 0.0 };
                lin(ka, kb)
            }
            BinOp::Atan2 => {
                let r2 = a.v * a.v + b.v * b.v;
                if r2 > 0.0 {
                    lin(b.v / r2, -a.v / r2)
                } else {
                    [0.0; 3]
                }
            }
        };
        Dual::with(v, d)
    }
}

/// Runs a tape on single points.
#[derive(Debug, Clone)]
pub struct PointEvaluator<'t, T: Num> {
    tape: &'t Tape,
    slots: Vec<T>,
    inputs: InputCache,
}

impl<'t, T: Num> PointEvaluator<'t, T> {
    /// An evaluator for `tape` (allocates its slots once).
    pub fn new(tape: &'t Tape) -> Self {
        PointEvaluator {
            tape,
            slots: constant_slots(tape),
            inputs: InputCache::default(),
        }
    }

    /// The value at (x, y, z) with the inputs `vars`.
    pub fn eval(&mut self, vars: &[f64], x: T, y: T, z: T) -> T {
        let tape = self.tape;
        self.run(tape, vars, x, y, z)
    }

    /// The value of `variant`, a rewrite of this evaluator's tape (see
    /// [`BatchEvaluator::eval_variant`]), at (x, y, z): no allocation per
    /// variant.
    ///
    /// # Panics
    /// When `variant` has another number of slots or other constants.
    pub fn eval_variant(&mut self, variant: &Tape, vars: &[f64], x: T, y: T, z: T) -> T {
        assert!(
            variant.same_frame(self.tape),
            "a variant must keep its tape's slots and constants"
        );
        self.run(variant, vars, x, y, z)
    }

    fn run(&mut self, tape: &Tape, vars: &[f64], x: T, y: T, z: T) -> T {
        if self.inputs.changed(self.tape, vars) {
            let mut scratch = std::mem::take(&mut self.inputs.scratch);
            for (slot, v) in self.tape.prologue().run(vars, &mut scratch) {
                self.slots[slot] = T::from_f64(v);
            }
            self.inputs.scratch = scratch;
        }
        let s = &mut self.slots;
        s[0] = x;
        s[1] = y;
        s[2] = z;
        let instrs = tape.instrs();
        let mut k = 0;
        while k < instrs.len() {
            let ins = &instrs[k];
            k += 1;
            match *ins {
                Instr::Skip { c, len } => {
                    if s[c as usize].value() > 0.0 {
                        k += len as usize;
                    }
                }
                Instr::Unary { op, out, a } => s[out as usize] = T::unary(op, s[a as usize]),
                Instr::Binary { op, out, a, b } => s[out as usize] = T::binary(op, s[a as usize], s[b as usize]),
                Instr::Select { out, c, a, b } => {
                    s[out as usize] = if s[c as usize].value() > 0.0 {
                        s[a as usize]
                    } else {
                        s[b as usize]
                    }
                }
            }
        }
        s[tape.output()]
    }
}

/// How a gradient is computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GradientMode {
    /// Forward-mode automatic differentiation (exact up to rounding).
    Dual,
    /// Central differences, 6 evaluations, step `h`.
    Central(f64),
    /// Forward differences, 4 evaluations (f(p) included), step `h`.
    Forward(f64),
    /// The tetrahedron technique, 4 evaluations, step `h`.
    Tetrahedron(f64),
}

/// The four tetrahedron directions (±1, ±1, ±1) with an odd number of minus signs.
pub const TETRAHEDRON: [[f64; 3]; 4] = [[1.0, -1.0, -1.0], [-1.0, -1.0, 1.0], [-1.0, 1.0, -1.0], [1.0, 1.0, 1.0]];

/// The offsets (relative to the point, in units of h) at which a finite
/// difference mode samples, and the weights turning samples into ∂/∂x,y,z:
/// grad_j = Σ_i w_i[j] f(p + h·o_i) / h.
pub fn stencil(mode: GradientMode) -> Vec<([f64; 3], [f64; 3])> {
    match mode {
        GradientMode::Dual => Vec::new(),
        GradientMode::Central(_) => vec![
            ([1.0, 0.0, 0.0], [0.5, 0.0, 0.0]),
            ([-1.0, 0.0, 0.0], [-0.5, 0.0, 0.0]),
            ([0.0, 1.0, 0.0], [0.0, 0.5, 0.0]),
            ([0.0, -1.0, 0.0], [0.0, -0.5, 0.0]),
            ([0.0, 0.0, 1.0], [0.0, 0.0, 0.5]),
            ([0.0, 0.0, -1.0], [0.0, 0.0, -0.5]),
        ],
        GradientMode::Forward(_) => vec![
            ([0.0, 0.0, 0.0], [-1.0, -1.0, -1.0]),
            ([1.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            ([0.0, 1.0, 0.0], [0.0, 1.0, 0.0]),
            ([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]),
        ],
        // Σ_i k_i f(p + h k_i) = 4 h ∇f + O(h³), so the weights are k_i / 4.
        GradientMode::Tetrahedron(_) => TETRAHEDRON
            .iter()
            .map(|k| (*k, [k[0] * 0.25, k[1] * 0.25, k[2] * 0.25]))
            .collect(),
    }
}

impl GradientMode {
    /// The finite-difference step (world units; every stencil offset is at
    /// most this along each axis); 0 for dual numbers.
    pub fn step(self) -> f64 {
        match self {
            GradientMode::Dual => 0.0,
            GradientMode::Central(h) | GradientMode::Forward(h) | GradientMode::Tetrahedron(h) => h,
        }
    }
}

/// The gradient of the tape at one point, with the inputs `vars`.
pub fn gradient(tape: &Tape, vars: &[f64], p: [f64; 3], mode: GradientMode) -> [f64; 3] {
    if mode == GradientMode::Dual {
        let mut e = PointEvaluator::<Dual>::new(tape);
        let x = Dual::with(p[0], [1.0, 0.0, 0.0]);
        let y = Dual::with(p[1], [0.0, 1.0, 0.0]);
        let z = Dual::with(p[2], [0.0, 0.0, 1.0]);
        return e.eval(vars, x, y, z).d;
    }
    let h = mode.step();
    let mut e = PointEvaluator::<f64>::new(tape);
    let mut g = [0.0; 3];
    for (o, w) in stencil(mode) {
        let f = e.eval(vars, p[0] + h * o[0], p[1] + h * o[1], p[2] + h * o[2]);
        for j in 0..3 {
            g[j] += w[j] * f / h;
        }
    }
    g
}

/// Scalar types the batch evaluator runs on (f32 for rendering, f64 for precision).
pub trait BatchNum:
    Num
    + Default
    + PartialOrd
    + std::ops::Add<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + Send
    + Sync
{
}
impl BatchNum for f32 {}
impl BatchNum for f64 {}

/// Runs a tape over many points at once (structure of arrays).
#[derive(Debug, Clone)]
pub struct BatchEvaluator<'t, T: BatchNum> {
    tape: &'t Tape,
    /// Per slot of the tape, its value when it does not depend on the
    /// point (constants and the prologue's values).
    values: Vec<T>,
    /// What the compiler knows of the tape's slots.
    slot_info: Slots<T>,
    /// The tape and its rewrites compiled, by [`Tape::id`].
    programs: rustc_hash::FxHashMap<u64, Program<T>>,
    compiler: Compiler,
    /// The programs' registers, [`LANES`] values each.
    regs: Vec<T>,
    inputs: InputCache,
    /// Scratch for gradient stencils.
    scratch: [Vec<T>; 4],
    /// The dual-number evaluator for exact gradients, made on first use.
    dual: Option<PointEvaluator<'t, Dual>>,
}

impl<'t, T: BatchNum> BatchEvaluator<'t, T> {
    /// An evaluator for `tape`; allocates its working memory once.
    pub fn new(tape: &'t Tape) -> Self {
        BatchEvaluator {
            tape,
            values: constant_slots(tape),
            slot_info: Slots::of(tape),
            programs: rustc_hash::FxHashMap::default(),
            compiler: Compiler::default(),
            regs: Vec::new(),
            inputs: InputCache::default(),
            scratch: Default::default(),
            dual: None,
        }
    }

    /// The tape this evaluator runs.
    pub fn tape(&self) -> &'t Tape {
        self.tape
    }

    /// Runs the prologue when the inputs changed since the last call.
    fn bind(&mut self, vars: &[f64]) {
        if self.inputs.changed(self.tape, vars) {
            let mut scratch = std::mem::take(&mut self.inputs.scratch);
            for (slot, v) in self.tape.prologue().run(vars, &mut scratch) {
                self.values[slot] = T::from_f64(v);
            }
            self.inputs.scratch = scratch;
        }
    }

    /// Evaluates at the points (xs[i], ys[i], zs[i]) with the inputs `vars`
    /// into `out[i]`. All four slices must have the same length (checked in
    /// debug builds; the shortest is used).
    pub fn eval(&mut self, vars: &[f64], xs: &[T], ys: &[T], zs: &[T], out: &mut [T]) {
        debug_assert!(
            xs.len() == ys.len() && ys.len() == zs.len() && zs.len() == out.len(),
            "slices of different lengths"
        );
        let tape = self.tape;
        self.eval_instrs(tape, vars, xs, ys, zs, out);
    }

    /// Evaluates `variant`, a rewrite of this evaluator's tape with the same
    /// constants, prologue and slots (as [`crate::simplify::simplify`]
    /// makes), in this evaluator's storage: no allocation per variant.
    ///
    /// # Panics
    /// When `variant` has another number of slots or other constants.
    pub fn eval_variant(&mut self, variant: &Tape, vars: &[f64], xs: &[T], ys: &[T], zs: &[T], out: &mut [T]) {
        assert!(
            variant.same_frame(self.tape),
            "a variant must keep its tape's slots and constants"
        );
        self.eval_instrs(variant, vars, xs, ys, zs, out);
    }

    /// Runs `tape` (this evaluator's tape or a rewrite of it) over the
    /// points, compiled ([`Program`]) the first time.
    fn eval_instrs(&mut self, tape: &Tape, vars: &[f64], xs: &[T], ys: &[T], zs: &[T], out: &mut [T]) {
        self.bind(vars);
        if self.programs.len() >= MAX_PROGRAMS {
            self.programs.clear();
        }
        let compiler = &mut self.compiler;
        let info = &self.slot_info;
        let prog = self
            .programs
            .entry(tape.id())
            .or_insert_with(|| compiler.compile(tape, info));
        prog.eval(&mut self.regs, &self.values, xs, ys, zs, out);
    }

    /// Gradients at the points by finite differences (or dual numbers) into
    /// `gx, gy, gz`, with the inputs `vars`. `mode` chooses the stencil; for
    /// the finite-difference modes its step is in world units.
    #[allow(clippy::too_many_arguments)]
    pub fn gradients(
        &mut self,
        vars: &[f64],
        xs: &[T],
        ys: &[T],
        zs: &[T],
        mode: GradientMode,
        gx: &mut [T],
        gy: &mut [T],
        gz: &mut [T],
    ) {
        self.gradients_variant(None, vars, xs, ys, zs, mode, gx, gy, gz);
    }

    /// [`Self::gradients`] of `variant`, a rewrite of this evaluator's tape
    /// (see [`Self::eval_variant`]) valid wherever the stencil reaches; the
    /// full tape when `None`. Dual numbers always run the full tape.
    #[allow(clippy::too_many_arguments)]
    pub fn gradients_variant(
        &mut self,
        variant: Option<&Tape>,
        vars: &[f64],
        xs: &[T],
        ys: &[T],
        zs: &[T],
        mode: GradientMode,
        gx: &mut [T],
        gy: &mut [T],
        gz: &mut [T],
    ) {
        let n = xs
            .len()
            .min(ys.len())
            .min(zs.len())
            .min(gx.len())
            .min(gy.len())
            .min(gz.len());
        if mode == GradientMode::Dual {
            let tape = self.tape;
            let e = self.dual.get_or_insert_with(|| PointEvaluator::<Dual>::new(tape));
            for i in 0..n {
                let g = e
                    .eval(
                        vars,
                        Dual::with(xs[i].value(), [1.0, 0.0, 0.0]),
                        Dual::with(ys[i].value(), [0.0, 1.0, 0.0]),
                        Dual::with(zs[i].value(), [0.0, 0.0, 1.0]),
                    )
                    .d;
                gx[i] = T::from_f64(g[0]);
                gy[i] = T::from_f64(g[1]);
                gz[i] = T::from_f64(g[2]);
            }
            return;
        }
        let mut scratch = std::mem::take(&mut self.scratch);
        finite_differences(
            mode,
            [&xs[..n], &ys[..n], &zs[..n]],
            [gx, gy, gz],
            &mut scratch,
            |sx, sy, sz, sf| match variant {
                Some(v) => self.eval_variant(v, vars, sx, sy, sz, sf),
                None => self.eval(vars, sx, sy, sz, sf),
            },
        );
        self.scratch = scratch;
    }
}

/// Finite-difference gradients (a mode other than [`GradientMode::Dual`])
/// at the points `p` into `g`, from the field `eval` writes at a batch of
/// points (x, y, z slices into the last): the stencil's points one offset
/// at a time in `scratch`, grad = Σ w·f(p + h·o)/h summed in the stencil's
/// order. [`BatchEvaluator::gradients`] is this with its own tape; a
/// caller whose field gives the tape's values bit for bit gets its
/// gradients bit for bit.
pub fn finite_differences<T: BatchNum>(
    mode: GradientMode,
    p: [&[T]; 3],
    g: [&mut [T]; 3],
    scratch: &mut [Vec<T>; 4],
    mut eval: impl FnMut(&[T], &[T], &[T], &mut [T]),
) {
    let n = p
        .iter()
        .map(|v| v.len())
        .chain(g.iter().map(|v| v.len()))
        .min()
        .unwrap_or(0);
    let [gx, gy, gz] = g;
    let h = mode.step();
    let inv_h = T::from_f64(1.0 / h);
    gx[..n].fill(T::default());
    gy[..n].fill(T::default());
    gz[..n].fill(T::default());
    for s in scratch.iter_mut() {
        s.resize(n, T::default());
    }
    for (o, w) in stencil(mode) {
        let [sx, sy, sz, sf] = &mut *scratch;
        let (ox, oy, oz) = (T::from_f64(h * o[0]), T::from_f64(h * o[1]), T::from_f64(h * o[2]));
        for i in 0..n {
            sx[i] = p[0][i] + ox;
            sy[i] = p[1][i] + oy;
            sz[i] = p[2][i] + oz;
        }
        eval(&sx[..n], &sy[..n], &sz[..n], &mut sf[..n]);
        let (wx, wy, wz) = (T::from_f64(w[0]), T::from_f64(w[1]), T::from_f64(w[2]));
        for i in 0..n {
            let f = sf[i] * inv_h;
            gx[i] = gx[i] + wx * f;
            gy[i] = gy[i] + wy * f;
            gz[i] = gz[i] + wz * f;
        }
    }
}

/// One value per slot of `tape`: its constants in theirs, 0 elsewhere.
pub(crate) fn constant_slots<T: Num>(tape: &Tape) -> Vec<T> {
    let mut slots = vec![T::from_f64(0.0); tape.slots()];
    for &(s, v) in tape.constants() {
        slots[s as usize] = T::from_f64(v);
    }
    slots
}

/// Block storage for a tape: [`LANES`] values per slot, the constants'
/// blocks filled.
fn block_slots<T: Num>(tape: &Tape) -> Vec<T> {
    let mut slots = vec![T::from_f64(0.0); tape.slots() * LANES];
    for &(s, v) in tape.constants() {
        slots[s as usize * LANES..(s as usize + 1) * LANES].fill(T::from_f64(v));
    }
    slots
}

/// Fills the blocks of the prologue's values when the inputs changed.
fn bind_blocks<T: Num>(tape: &Tape, inputs: &mut InputCache, slots: &mut [T], vars: &[f64]) {
    if inputs.changed(tape, vars) {
        let mut scratch = std::mem::take(&mut inputs.scratch);
        for (slot, v) in tape.prologue().run(vars, &mut scratch) {
            slots[slot * LANES..(slot + 1) * LANES].fill(T::from_f64(v));
        }
        inputs.scratch = scratch;
    }
}

/// Runs `instrs` over the first `m` ≤ [`LANES`] lanes of `slots` (one
/// block of LANES values per slot).
fn run_blocks<T: Num>(slots: &mut [T], instrs: &[Instr], m: usize) {
    debug_assert!(m <= LANES);
    let base = slots.as_mut_ptr();
    let len = slots.len();
    let mut k = 0;
    while k < instrs.len() {
        let ins = &instrs[k];
        k += 1;
        // SAFETY: every slot index is below `tape.slots()` (checked below in
        // debug builds, guaranteed by `Tape::extract` and `Tape::with_instrs`),
        // so each block of LANES elements lies inside `slots`; and no
        // instruction writes a slot it reads (also guaranteed by both), so the
        // mutable block never overlaps the shared ones.
        unsafe {
            let blk = |s: u32| {
                debug_assert!((s as usize + 1) * LANES <= len);
                &*(base.add(s as usize * LANES) as *const [T; LANES])
            };
            let blk_mut = |s: u32| {
                debug_assert!((s as usize + 1) * LANES <= len);
                &mut *(base.add(s as usize * LANES) as *mut [T; LANES])
            };
            match *ins {
                Instr::Unary { op, out, a } => {
                    let (o, a) = (blk_mut(out), blk(a));
                    unary_block(op, &mut o[..m], &a[..m]);
                }
                Instr::Binary { op, out, a, b } => {
                    let (o, a, b) = (blk_mut(out), blk(a), blk(b));
                    binary_block(op, &mut o[..m], &a[..m], &b[..m]);
                }
                Instr::Select { out, c, a, b } => {
                    let (o, c, a, b) = (blk_mut(out), blk(c), blk(a), blk(b));
                    for l in 0..m {
                        o[l] = if c[l].value() > 0.0 { a[l] } else { b[l] };
                    }
                }
                Instr::Skip { c, len } => {
                    if blk(c)[..m].iter().all(|&v| v.value() > 0.0) {
                        k += len as usize;
                    }
                }
            }
        }
    }
}

/// Exact gradients (dual numbers) at many points at once: a tape and its
/// rewrites run block by block, as [`BatchEvaluator`] runs values, so one
/// pass over the instructions serves up to [`LANES`] points.
#[derive(Debug, Clone)]
pub struct DualBatch<'t> {
    tape: &'t Tape,
    slots: Vec<Dual>,
    inputs: InputCache,
}

impl<'t> DualBatch<'t> {
    /// An evaluator for `tape` (and its rewrites).
    pub fn new(tape: &'t Tape) -> Self {
        DualBatch {
            tape,
            slots: block_slots(tape),
            inputs: InputCache::default(),
        }
    }

    /// The gradients of `variant` (this evaluator's tape or a rewrite of
    /// it, see [`Tape::same_frame`]) at the points, with the inputs `vars`,
    /// into `out`.
    ///
    /// # Panics
    /// When `variant` is not a rewrite of this evaluator's tape.
    pub fn gradients(
        &mut self,
        variant: &Tape,
        vars: &[f64],
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        out: &mut [[f64; 3]],
    ) {
        assert!(
            variant.same_frame(self.tape),
            "a variant must keep its tape's slots and constants"
        );
        bind_blocks(self.tape, &mut self.inputs, &mut self.slots, vars);
        let n = xs.len().min(ys.len()).min(zs.len()).min(out.len());
        let o = variant.output() * LANES;
        let mut i = 0;
        while i < n {
            let m = (n - i).min(LANES);
            for l in 0..m {
                self.slots[l] = Dual::with(xs[i + l], [1.0, 0.0, 0.0]);
                self.slots[LANES + l] = Dual::with(ys[i + l], [0.0, 1.0, 0.0]);
                self.slots[2 * LANES + l] = Dual::with(zs[i + l], [0.0, 0.0, 1.0]);
            }
            run_blocks(&mut self.slots, variant.instrs(), m);
            for l in 0..m {
                out[i + l] = self.slots[o + l].d;
            }
            i += m;
        }
    }
}

#[inline(always)]
fn unary_block<T: Num>(op: UnOp, o: &mut [T], a: &[T]) {
    macro_rules! each {
        ($f:expr) => {{
            let f = $f;
            for (o, &a) in o.iter_mut().zip(a) {
                *o = f(a);
            }
        }};
    }
    match op {
        UnOp::Neg => each!(|x| T::unary(UnOp::Neg, x)),
        UnOp::Abs => each!(|x| T::unary(UnOp::Abs, x)),
        UnOp::Sqrt => each!(|x| T::unary(UnOp::Sqrt, x)),
        UnOp::Square => each!(|x| T::unary(UnOp::Square, x)),
        UnOp::Floor => each!(|x| T::unary(UnOp::Floor, x)),
        op => each!(|x| T::unary(op, x)),
    }
}

#[inline(always)]
fn binary_block<T: Num>(op: BinOp, o: &mut [T], a: &[T], b: &[T]) {
    macro_rules! each {
        ($f:expr) => {{
            let f = $f;
            for ((o, &a), &b) in o.iter_mut().zip(a).zip(b) {
                *o = f(a, b);
            }
        }};
    }
    match op {
        BinOp::Add => each!(|x, y| T::binary(BinOp::Add, x, y)),
        BinOp::Sub => each!(|x, y| T::binary(BinOp::Sub, x, y)),
        BinOp::Mul => each!(|x, y| T::binary(BinOp::Mul, x, y)),
        BinOp::Div => each!(|x, y| T::binary(BinOp::Div, x, y)),
        BinOp::Min => each!(|x, y| T::binary(BinOp::Min, x, y)),
        BinOp::Max => each!(|x, y| T::binary(BinOp::Max, x, y)),
        op => each!(|x, y| T::binary(op, x, y)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{compile, Library};

    /// Batched dual numbers give the point evaluator's gradients bit for
    /// bit, over more points than one block, with selects and a parameter.
    #[test]
    fn dual_batch_equals_the_point_evaluator() {
        let sh = compile(
            &Library::new(),
            "smooth_union(torus(rotate_x(p, 0.7), 1.0, 0.3), box(p - vec3(0.5), vec3(0.4)), 0.2) + 0.1 * step(0.2, p.x) * sin(3.0 * p.y)",
        )
        .unwrap();
        let tape = sh.tape();
        let mut batch = DualBatch::new(tape);
        let mut point = PointEvaluator::<Dual>::new(tape);
        let n = LANES * 2 + 5;
        let f = |i: usize, k: f64| (i as f64 * 0.37 + k).sin() * 2.0;
        let (xs, ys, zs): (Vec<f64>, Vec<f64>, Vec<f64>) = (
            (0..n).map(|i| f(i, 0.0)).collect(),
            (0..n).map(|i| f(i, 1.0)).collect(),
            (0..n).map(|i| f(i, 2.0)).collect(),
        );
        let mut g = vec![[0.0; 3]; n];
        batch.gradients(tape, &[], &xs, &ys, &zs, &mut g);
        for i in 0..n {
            let d = point
                .eval(
                    &[],
                    Dual::with(xs[i], [1.0, 0.0, 0.0]),
                    Dual::with(ys[i], [0.0, 1.0, 0.0]),
                    Dual::with(zs[i], [0.0, 0.0, 1.0]),
                )
                .d;
            assert_eq!(g[i].map(f64::to_bits), d.map(f64::to_bits), "point {i}");
        }
    }
}
