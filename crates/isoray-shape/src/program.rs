//! Tapes compiled for the batch evaluator.
//!
//! A [`Tape`] names its values by slots of the whole tape: a tape
//! simplified for a small region (see [`crate::simplify`]) keeps the slot
//! numbers of the full one, so its few dozen instructions read operands
//! scattered over thousands of slots, and every constant is a block of
//! [`LANES`] copies of itself. Evaluated block by block, that is memory
//! traffic: for a fold of a thousand spheres the constants' blocks alone
//! are three quarters of a megabyte, more than a core's L2 cache.
//!
//! A [`Program`] is the same instructions, one for one, over registers
//! renumbered densely by a linear scan (a register is reused once the
//! last instruction that reads its value has run), with the constants of
//! the common arithmetic (+, −, ×, ÷, min, max) as immediate operands
//! and every other value that does not depend on the point (constants
//! elsewhere, the prologue's values) loaded into a register once per
//! block. Each operation is the same f32 (or f64) operation in the same
//! order as the tape's, so the values are the same, bit for bit.

use crate::eval::{Num, LANES};
use crate::ir::{BinOp, Instr, Tape, UnOp};

/// What an instruction of a [`Program`] does: one code per operation and
/// operand form, so that running it is one dispatch.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Code {
    Add,
    Sub,
    Mul,
    Div,
    Min,
    Max,
    /// a + imm, a − imm, imm − b, a × imm, a ÷ imm, imm ÷ b, min(a, imm),
    /// max(a, imm).
    AddI,
    SubI,
    ISub,
    MulI,
    DivI,
    IDiv,
    MinI,
    MaxI,
    Neg,
    Abs,
    Sqrt,
    Square,
    Unary(UnOp),
    Binary(BinOp),
    /// out = c > 0 ? a : b
    Select,
    /// Skip the next `b` instructions when register `a` is > 0 at every
    /// point of the block.
    Skip,
    /// out = imm (a value that does not depend on the point, in a program
    /// put together from several: [`Assembler`]).
    Fill,
    /// The eight operations of `Builder::smooth_union` of a (the fold so
    /// far) and b (an object) with width imm, `c` the register holding
    /// 0.25 / imm: d = a − b, h = max(imm − |d|, 0), then min(a, b) (or
    /// min(b, a) for `SmoothUnionBA`) − h² · c, each the same operation
    /// as the tape's in the same order.
    SmoothUnionAB,
    SmoothUnionBA,
    /// `SmoothUnionBA` of a and the sphere `Sphere` would have computed
    /// into b (centre `data[d..d + 3]`, radius `data[d + 3]`, from the
    /// point in registers 0, 1, 2): one operation per sphere of a fold.
    SphereUnion,
    /// The ten operations of a sphere's distance from the point in
    /// registers a, b, c: √((Δx² + Δy²) + Δz²) − imm, Δ = coordinate −
    /// centre (`data[d..d + 3]`), each the same operation as the tape's in
    /// the same order (a tape without the subtraction of a centre
    /// coordinate of 0 gives the same values: x − 0 is x).
    Sphere,
}

/// One instruction of a [`Program`].
#[derive(Debug, Clone, Copy)]
struct Op<T> {
    code: Code,
    out: u32,
    a: u32,
    b: u32,
    c: u32,
    imm: T,
    /// `Sphere`, `SphereUnion`: where its centre's three coordinates (and
    /// for `SphereUnion` then its radius) are in `data`.
    d: u32,
}

/// A tape compiled for [`crate::BatchEvaluator`] (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct Program<T> {
    ops: Vec<Op<T>>,
    /// Registers it uses; 0, 1 and 2 hold x, y and z.
    pub(crate) regs: usize,
    /// (slot, register): the values that do not depend on the point,
    /// loaded before each block (from the evaluator's values by slot).
    pub(crate) loads: Vec<(u32, u32)>,
    /// The register holding the result.
    pub(crate) output: u32,
    /// Operands of fused operations (spheres' centres and radii).
    data: Vec<T>,
    /// When the whole program is a sphere's distance from the point: its
    /// centre and radius (see [`Program::sphere_form`]).
    sphere: Option<([T; 3], T)>,
}

/// What the compiler knows of a tape's slots (shared by its rewrites).
#[derive(Debug, Clone)]
pub(crate) struct Slots<T> {
    /// Per slot: its value when it holds a constant.
    constant: Vec<Option<T>>,
    /// Per slot: whether it holds a value that does not depend on the
    /// point (a constant or a prologue value).
    uniform: Vec<bool>,
}

impl<T: Num> Slots<T> {
    pub(crate) fn of(tape: &Tape) -> Self {
        let mut constant = vec![None; tape.slots()];
        let mut uniform = vec![false; tape.slots()];
        for &(s, v) in tape.constants() {
            constant[s as usize] = Some(T::from_f64(v));
            uniform[s as usize] = true;
        }
        for &(_, s) in tape.prologue().outputs() {
            uniform[s as usize] = true;
        }
        Slots { constant, uniform }
    }
}

/// Working memory of [`compile`], kept between calls.
#[derive(Debug, Clone, Default)]
pub(crate) struct Compiler {
    /// Per slot: read later (backward pass); per slot: its register.
    seen: Vec<bool>,
    reg_of: Vec<u32>,
    /// Per uniform slot: its load register, or `NONE`.
    load_of: Vec<u32>,
    /// Per instruction: which operands (a = 1, b = 2, c = 4) are the last
    /// reads of their values, and 8 when its result is never read.
    last: Vec<u8>,
    free: Vec<u32>,
}

const NONE: u32 = u32::MAX;

/// The slots an instruction reads, as (a, b, c) with `NONE` for none.
fn operands(ins: &Instr) -> [u32; 3] {
    match *ins {
        Instr::Unary { a, .. } => [a, NONE, NONE],
        Instr::Binary { a, b, .. } => [a, b, NONE],
        Instr::Select { c, a, b, .. } => [a, b, c],
        Instr::Skip { c, .. } => [c, NONE, NONE],
    }
}

fn written(ins: &Instr) -> Option<u32> {
    match *ins {
        Instr::Unary { out, .. } | Instr::Binary { out, .. } | Instr::Select { out, .. } => Some(out),
        Instr::Skip { .. } => None,
    }
}

impl Compiler {
    /// `tape` (a tape whose slots `slots` describes, or a rewrite of it)
    /// as a [`Program`].
    pub(crate) fn compile<T: Num>(&mut self, tape: &Tape, slots: &Slots<T>) -> Program<T> {
        let instrs = tape.instrs();
        let n = tape.slots();
        let temp = |s: u32| s >= 3 && !slots.uniform[s as usize];
        // Backwards: the last read of each value, and results never read.
        self.seen.clear();
        self.seen.resize(n, false);
        self.seen[tape.output()] = true;
        self.last.clear();
        self.last.resize(instrs.len(), 0);
        for (i, ins) in instrs.iter().enumerate().rev() {
            let mut mask = 0u8;
            if let Some(w) = written(ins) {
                if !std::mem::replace(&mut self.seen[w as usize], false) {
                    mask |= 8;
                }
            }
            for (k, &r) in operands(ins).iter().enumerate() {
                if r != NONE && temp(r) && !self.seen[r as usize] {
                    self.seen[r as usize] = true;
                    mask |= 1 << k;
                }
            }
            self.last[i] = mask;
        }
        // Forwards: registers from a free list.
        self.reg_of.clear();
        self.reg_of.resize(n, NONE);
        self.load_of.clear();
        self.load_of.resize(n, NONE);
        self.free.clear();
        let mut regs = 3u32;
        let mut loads = Vec::new();
        let mut ops = Vec::with_capacity(instrs.len());
        let zero = T::from_f64(0.0);
        for (i, ins) in instrs.iter().enumerate() {
            let mut reg = |s: u32, this: &mut Compiler, regs: &mut u32| -> u32 {
                if s < 3 {
                    s
                } else if slots.uniform[s as usize] {
                    if this.load_of[s as usize] == NONE {
                        this.load_of[s as usize] = *regs;
                        loads.push((s, *regs));
                        *regs += 1;
                    }
                    this.load_of[s as usize]
                } else {
                    this.reg_of[s as usize]
                }
            };
            let konst = |s: u32| if s >= 3 { slots.constant[s as usize] } else { None };
            let mut op = Op {
                code: Code::Skip,
                out: NONE,
                a: NONE,
                b: NONE,
                c: NONE,
                imm: zero,
                d: 0,
            };
            match *ins {
                Instr::Unary { op: u, a, .. } => {
                    op.code = match u {
                        UnOp::Neg => Code::Neg,
                        UnOp::Abs => Code::Abs,
                        UnOp::Sqrt => Code::Sqrt,
                        UnOp::Square => Code::Square,
                        u => Code::Unary(u),
                    };
                    op.a = reg(a, self, &mut regs);
                }
                Instr::Binary { op: bo, a, b, .. } => {
                    let imm_form = |bo: BinOp, left: bool| -> Option<Code> {
                        Some(match (bo, left) {
                            (BinOp::Add, _) => Code::AddI,
                            (BinOp::Sub, false) => Code::SubI,
                            (BinOp::Sub, true) => Code::ISub,
                            (BinOp::Mul, _) => Code::MulI,
                            (BinOp::Div, false) => Code::DivI,
                            (BinOp::Div, true) => Code::IDiv,
                            (BinOp::Min, _) => Code::MinI,
                            (BinOp::Max, _) => Code::MaxI,
                            _ => return None,
                        })
                    };
                    // Commutative forms keep the operand order of the tape:
                    // min and max of a NaN depend on it, so imm op b
                    // becomes an `I` form only where the order is free.
                    let commutes = |bo: BinOp| matches!(bo, BinOp::Add | BinOp::Mul);
                    match (konst(a), konst(b)) {
                        (None, Some(v)) if imm_form(bo, false).is_some() => {
                            op.code = imm_form(bo, false).unwrap_or(Code::Binary(bo));
                            op.a = reg(a, self, &mut regs);
                            op.imm = v;
                        }
                        (Some(v), None) if matches!(bo, BinOp::Sub | BinOp::Div) => {
                            op.code = imm_form(bo, true).unwrap_or(Code::Binary(bo));
                            op.b = reg(b, self, &mut regs);
                            op.imm = v;
                        }
                        (Some(v), None) if commutes(bo) => {
                            op.code = imm_form(bo, true).unwrap_or(Code::Binary(bo));
                            op.a = reg(b, self, &mut regs);
                            op.imm = v;
                        }
                        _ => {
                            op.code = match bo {
                                BinOp::Add => Code::Add,
                                BinOp::Sub => Code::Sub,
                                BinOp::Mul => Code::Mul,
                                BinOp::Div => Code::Div,
                                BinOp::Min => Code::Min,
                                BinOp::Max => Code::Max,
                                bo => Code::Binary(bo),
                            };
                            op.a = reg(a, self, &mut regs);
                            op.b = reg(b, self, &mut regs);
                        }
                    }
                }
                Instr::Select { c, a, b, .. } => {
                    op.code = Code::Select;
                    op.a = reg(a, self, &mut regs);
                    op.b = reg(b, self, &mut regs);
                    op.c = reg(c, self, &mut regs);
                }
                Instr::Skip { c, len } => {
                    op.code = Code::Skip;
                    op.a = reg(c, self, &mut regs);
                    op.b = len;
                }
            }
            if let Some(w) = written(ins) {
                let r = self.free.pop().unwrap_or_else(|| {
                    regs += 1;
                    regs - 1
                });
                op.out = r;
                // The value w held before is dead (its register was freed
                // at its last read, or below when it had none).
                self.reg_of[w as usize] = r;
                if self.last[i] & 8 != 0 && w as usize != tape.output() {
                    self.free.push(r);
                }
            }
            // Registers whose values this instruction read last.
            let ops_in = operands(ins);
            for (k, &s) in ops_in.iter().enumerate() {
                if self.last[i] & (1 << k) != 0 {
                    self.free.push(self.reg_of[s as usize]);
                }
            }
            ops.push(op);
        }
        let o = tape.output() as u32;
        let output = if o < 3 {
            o
        } else if slots.uniform[o as usize] {
            if self.load_of[o as usize] == NONE {
                self.load_of[o as usize] = regs;
                loads.push((o, regs));
                regs += 1;
            }
            self.load_of[o as usize]
        } else {
            self.reg_of[o as usize]
        };
        let mut prog = Program {
            ops,
            regs: regs as usize,
            loads,
            output,
            data: Vec::new(),
            sphere: None,
        };
        prog.sphere = prog.sphere_form();
        prog
    }
}

/// When `tape` is exactly a sphere's distance from the point, the
/// operations `sphere(p - vec3(c), r)` compiles to with constant centre
/// and radius (ten, fewer where a centre coordinate is 0): the centre and
/// the radius, read from the tape (no sampling: the structure is the
/// proof).
pub fn sphere_form(tape: &Tape) -> Option<([f64; 3], f64)> {
    if tape.len() > 10 || !tape.prologue().is_empty() {
        return None;
    }
    Compiler::default().compile(tape, &Slots::<f64>::of(tape)).sphere
}

/// The operations [`Assembler::op`] appends (a fold's own arithmetic).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum FoldOp {
    /// min(a, b)
    Min,
    /// max(a, a): a copy
    Copy,
    /// `imm` into register a (out)
    Fill,
}

/// Puts a program together from several compiled ones and a few
/// operations of its own ([`crate::fold`]).
#[derive(Debug, Clone)]
pub(crate) struct Assembler<T> {
    prog: Program<T>,
}

impl<T: Num> Assembler<T> {
    pub(crate) fn new() -> Self {
        Assembler {
            prog: Program {
                ops: Vec::new(),
                regs: 3,
                loads: Vec::new(),
                output: 0,
                data: Vec::new(),
                sphere: None,
            },
        }
    }

    /// Appends `p`'s instructions, its registers from 3 on moved to
    /// `base` on, after filling its loads' registers from `values` (its
    /// values by slot: the registers are shared with what runs before, so
    /// they are filled here, not once per block). Returns the register
    /// holding its result.
    pub(crate) fn append(&mut self, p: &Program<T>, values: &[T], base: u32) -> u32 {
        let map = |r: u32| if r < 3 || r == NONE { r } else { r - 3 + base };
        if let Some((c, r)) = p.sphere {
            // One operation for the whole program.
            let out = base;
            self.prog.ops.push(Op {
                code: Code::Sphere,
                out,
                a: 0,
                b: 1,
                c: 2,
                imm: r,
                d: self.prog.data.len() as u32,
            });
            self.prog.data.extend(c);
            self.prog.regs = self.prog.regs.max(out as usize + 1);
            return out;
        }
        for &(s, r) in &p.loads {
            self.prog.ops.push(Op {
                code: Code::Fill,
                out: map(r),
                a: NONE,
                b: NONE,
                c: NONE,
                imm: values[s as usize],
                d: 0,
            });
        }
        for op in &p.ops {
            let mut o = *op;
            o.out = map(o.out);
            o.a = map(o.a);
            if o.code != Code::Skip {
                o.b = map(o.b);
            }
            o.c = map(o.c);
            self.prog.ops.push(o);
        }
        self.prog.regs = self.prog.regs.max(map(p.regs as u32 - 1) as usize + 1);
        map(p.output)
    }

    /// Appends `out = op(a, b)` (or with the immediate `imm`).
    pub(crate) fn op(&mut self, op: FoldOp, out: u32, a: u32, b: u32, imm: T) {
        let (code, b) = match op {
            FoldOp::Min => (Code::Min, b),
            FoldOp::Copy => (Code::Max, a),
            FoldOp::Fill => (Code::Fill, NONE),
        };
        let a = if code == Code::Fill { NONE } else { a };
        debug_assert!(out != a && out != b, "an operation never writes what it reads");
        self.prog.ops.push(Op {
            code,
            out,
            a,
            b,
            c: NONE,
            imm,
            d: 0,
        });
        let top = [out, a, b].into_iter().filter(|&r| r != NONE).max().unwrap_or(0);
        self.prog.regs = self.prog.regs.max(top as usize + 1);
    }

    /// Appends `out` = the smooth union of the fold so far `a` and the
    /// object `b` with width `k`, register `c` holding 0.25 / k; `min`'s
    /// operands as (a, b) when `ab`, else as (b, a).
    pub(crate) fn smooth_union(&mut self, ab: bool, out: u32, a: u32, b: u32, c: u32, k: T) {
        let code = if ab { Code::SmoothUnionAB } else { Code::SmoothUnionBA };
        debug_assert!(out != a && out != b && out != c);
        // A sphere just computed into b for this union alone: one operation
        // for both (its centre's data are the last three values).
        if let Some(last) = self.prog.ops.last_mut() {
            let fresh = last.code == Code::Sphere && last.out == b && last.d as usize + 3 == self.prog.data.len();
            if fresh && !ab && b != a && b != c {
                let r = last.imm;
                *last = Op {
                    code: Code::SphereUnion,
                    out,
                    a,
                    b: NONE,
                    c,
                    imm: k,
                    d: last.d,
                };
                self.prog.data.push(r);
                self.prog.regs = self.prog.regs.max(out.max(a).max(c) as usize + 1);
                return;
            }
        }
        self.prog.ops.push(Op {
            code,
            out,
            a,
            b,
            c,
            imm: k,
            d: 0,
        });
        self.prog.regs = self.prog.regs.max(out.max(a).max(b).max(c) as usize + 1);
    }

    /// The program, its result in register `output`.
    pub(crate) fn finish(mut self, output: u32) -> Program<T> {
        self.prog.output = output;
        self.prog.regs = self.prog.regs.max(output as usize + 1);
        self.prog
    }
}

impl<T: Num> Program<T> {
    /// When the whole program is a sphere's distance from the point
    /// (x, y, z), compiled as `sphere(p - vec3(c), r)` is — √((Δx² + Δy²) +
    /// Δz²) − r, Δ = coordinate − centre, the subtraction absent for a
    /// centre coordinate of 0 (x − 0 is x, bit for bit) — the centre and
    /// the radius. Followed value by value through the registers, so their
    /// reuse does not matter; the sums must be associated as written (the
    /// fused operation adds in that order), either operand first.
    fn sphere_form(&self) -> Option<([T; 3], T)> {
        /// What a register holds.
        #[derive(Clone, Copy)]
        enum V<T> {
            /// Coordinate k less a centre (None: nothing subtracted yet).
            Delta(usize, Option<T>),
            /// Its square.
            Square(usize, T),
            /// Δx² + Δy², then + Δz².
            Sum2(T, T),
            Sum3([T; 3]),
            Root([T; 3]),
            Distance([T; 3], T),
        }
        if self.ops.len() > 10 || !self.loads.is_empty() {
            return None;
        }
        let mut regs: Vec<Option<V<T>>> = (0..self.regs).map(|r| (r < 3).then_some(V::Delta(r, None))).collect();
        let zero = T::from_f64(0.0);
        for op in &self.ops {
            let a = *regs.get(op.a as usize)?;
            let v = match (op.code, a) {
                (Code::SubI, Some(V::Delta(k, None))) => V::Delta(k, Some(op.imm)),
                (Code::Square, Some(V::Delta(k, c))) => V::Square(k, c.unwrap_or(zero)),
                (Code::Add, Some(x)) => match (x, *regs.get(op.b as usize)?) {
                    (V::Square(0, cx), Some(V::Square(1, cy))) | (V::Square(1, cy), Some(V::Square(0, cx))) => {
                        V::Sum2(cx, cy)
                    }
                    (V::Sum2(cx, cy), Some(V::Square(2, cz))) | (V::Square(2, cz), Some(V::Sum2(cx, cy))) => {
                        V::Sum3([cx, cy, cz])
                    }
                    _ => return None,
                },
                (Code::Sqrt, Some(V::Sum3(c))) => V::Root(c),
                (Code::SubI, Some(V::Root(c))) => V::Distance(c, op.imm),
                _ => return None,
            };
            *regs.get_mut(op.out as usize)? = Some(v);
        }
        match regs.get(self.output as usize).copied().flatten()? {
            V::Distance(c, r) => Some((c, r)),
            _ => None,
        }
    }

    /// Instructions per point.
    pub(crate) fn len(&self) -> usize {
        self.ops.len()
    }

    /// Evaluates the program at the points (xs[i], ys[i], zs[i]) into
    /// `out[i]`, block by block in `regs` (grown as needed), its loads
    /// taken from `values` (by slot).
    pub(crate) fn eval(&self, regs: &mut Vec<T>, values: &[T], xs: &[T], ys: &[T], zs: &[T], out: &mut [T]) {
        self.eval_by(Self::run, regs, values, [xs, ys, zs], out);
    }

    /// [`Self::eval`] with `run` running the program over each block.
    fn eval_by(
        &self,
        run: impl Fn(&Self, &mut [T], usize),
        regs: &mut Vec<T>,
        values: &[T],
        p: [&[T]; 3],
        out: &mut [T],
    ) {
        let [xs, ys, zs] = p;
        if regs.len() < self.regs * LANES {
            regs.resize(self.regs * LANES, T::from_f64(0.0));
        }
        let n = xs.len().min(ys.len()).min(zs.len()).min(out.len());
        let mut i = 0;
        while i < n {
            let m = (n - i).min(LANES);
            regs[..m].copy_from_slice(&xs[i..i + m]);
            regs[LANES..LANES + m].copy_from_slice(&ys[i..i + m]);
            regs[2 * LANES..2 * LANES + m].copy_from_slice(&zs[i..i + m]);
            // The lanes the program computes (whole groups of 8).
            let w = (m.div_ceil(8) * 8).min(LANES);
            for &(s, r) in &self.loads {
                let r = r as usize * LANES;
                regs[r..r + w].fill(values[s as usize]);
            }
            run(self, regs, m);
            let o = self.output as usize * LANES;
            out[i..i + m].copy_from_slice(&regs[o..o + m]);
            i += m;
        }
    }

    /// Runs the program over the first `m` ≤ [`LANES`] lanes of `regs`
    /// (one block of [`LANES`] values per register; x, y, z and the loads
    /// already in place).
    fn run(&self, regs: &mut [T], m: usize) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.run_avx2(regs, m) };
        }
        self.run_any(regs, m)
    }

    /// [`Self::run`] compiled for AVX2: a block of 8 lanes is one
    /// instruction per operation instead of two. The same IEEE operations
    /// lane by lane (nothing is fused), so the same values bit for bit.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn run_avx2(&self, regs: &mut [T], m: usize) {
        self.run_any(regs, m)
    }

    /// [`Self::run`] for whatever the build targets (inlined into the
    /// variants compiled for wider vectors).
    #[inline(always)]
    fn run_any(&self, regs: &mut [T], m: usize) {
        assert!(m <= LANES && regs.len() >= self.regs * LANES);
        // The arithmetic runs over whole groups of 8 lanes (the lanes past
        // `m` hold whatever they held: nothing reads them).
        let w = m.div_ceil(8).max(1) * 8;
        let w = w.min(LANES);
        let base = regs.as_mut_ptr();
        let mut k = 0;
        while k < self.ops.len() {
            let op = self.ops[k];
            k += 1;
            // SAFETY: every register is below `self.regs` (the compiler
            // numbers them so), so each block lies inside `regs`, checked
            // by the assertion above; the output register is never one the
            // instruction reads (it is taken from the free list before the
            // operands' registers are returned to it), so the mutable
            // block does not overlap the shared ones.
            unsafe {
                let blk = |r: u32| &*(base.add(r as usize * LANES) as *const [T; LANES]);
                let out = |r: u32| &mut *(base.add(r as usize * LANES) as *mut [T; LANES]);
                macro_rules! un {
                    ($f:expr) => {{
                        let (o, a) = (out(op.out), blk(op.a));
                        for l in 0..w {
                            o[l] = $f(a[l]);
                        }
                    }};
                }
                macro_rules! bin {
                    ($f:expr) => {{
                        let (o, a, b) = (out(op.out), blk(op.a), blk(op.b));
                        for l in 0..w {
                            o[l] = $f(a[l], b[l]);
                        }
                    }};
                }
                macro_rules! imm {
                    ($f:expr) => {{
                        let (o, a) = (out(op.out), blk(op.a));
                        let v = op.imm;
                        for l in 0..w {
                            o[l] = $f(a[l], v);
                        }
                    }};
                }
                macro_rules! immb {
                    ($f:expr) => {{
                        let (o, b) = (out(op.out), blk(op.b));
                        let v = op.imm;
                        for l in 0..w {
                            o[l] = $f(v, b[l]);
                        }
                    }};
                }
                match op.code {
                    Code::Add => bin!(|x, y| T::binary(BinOp::Add, x, y)),
                    Code::Sub => bin!(|x, y| T::binary(BinOp::Sub, x, y)),
                    Code::Mul => bin!(|x, y| T::binary(BinOp::Mul, x, y)),
                    Code::Div => bin!(|x, y| T::binary(BinOp::Div, x, y)),
                    Code::Min => bin!(|x, y| T::binary(BinOp::Min, x, y)),
                    Code::Max => bin!(|x, y| T::binary(BinOp::Max, x, y)),
                    Code::AddI => imm!(|x, v| T::binary(BinOp::Add, x, v)),
                    Code::SubI => imm!(|x, v| T::binary(BinOp::Sub, x, v)),
                    Code::MulI => imm!(|x, v| T::binary(BinOp::Mul, x, v)),
                    Code::DivI => imm!(|x, v| T::binary(BinOp::Div, x, v)),
                    Code::MinI => imm!(|x, v| T::binary(BinOp::Min, x, v)),
                    Code::MaxI => imm!(|x, v| T::binary(BinOp::Max, x, v)),
                    Code::ISub => immb!(|v, y| T::binary(BinOp::Sub, v, y)),
                    Code::IDiv => immb!(|v, y| T::binary(BinOp::Div, v, y)),
                    Code::Neg => un!(|x| T::unary(UnOp::Neg, x)),
                    Code::Abs => un!(|x| T::unary(UnOp::Abs, x)),
                    Code::Sqrt => un!(|x| T::unary(UnOp::Sqrt, x)),
                    Code::Square => un!(|x| T::unary(UnOp::Square, x)),
                    Code::Unary(u) => un!(|x| T::unary(u, x)),
                    Code::Binary(bo) => bin!(|x, y| T::binary(bo, x, y)),
                    Code::Select => {
                        let (o, c, a, b) = (out(op.out), blk(op.c), blk(op.a), blk(op.b));
                        for l in 0..w {
                            o[l] = if c[l].value() > 0.0 { a[l] } else { b[l] };
                        }
                    }
                    Code::Skip => {
                        if blk(op.a)[..m].iter().all(|&v| v.value() > 0.0) {
                            k += op.b as usize;
                        }
                    }
                    Code::Fill => {
                        let o = out(op.out);
                        o[..w].fill(op.imm);
                    }
                    Code::Sphere => {
                        let (o, x, y, z) = (out(op.out), blk(op.a), blk(op.b), blk(op.c));
                        let d = op.d as usize;
                        let s = [self.data[d], self.data[d + 1], self.data[d + 2]];
                        for l in 0..w {
                            o[l] = sphere(x[l], y[l], z[l], s, op.imm);
                        }
                    }
                    Code::SmoothUnionAB | Code::SmoothUnionBA => {
                        let (o, a, b, c) = (out(op.out), blk(op.a), blk(op.b), blk(op.c));
                        let ab = op.code == Code::SmoothUnionAB;
                        for l in 0..w {
                            o[l] = smooth_union(ab, a[l], b[l], op.imm, c[l]);
                        }
                    }
                    Code::SphereUnion => {
                        let (o, a, c) = (out(op.out), blk(op.a), blk(op.c));
                        let (x, y, z) = (blk(0), blk(1), blk(2));
                        let d = op.d as usize;
                        let s = [self.data[d], self.data[d + 1], self.data[d + 2]];
                        let r = self.data[d + 3];
                        for l in 0..w {
                            let b = sphere(x[l], y[l], z[l], s, r);
                            o[l] = smooth_union(false, a[l], b, op.imm, c[l]);
                        }
                    }
                }
            }
        }
    }
}

/// A sphere's distance from (x, y, z): the ten operations of
/// `sphere(p - vec3(c), r)`'s tape, in its order.
#[inline(always)]
fn sphere<T: Num>(x: T, y: T, z: T, c: [T; 3], r: T) -> T {
    let dx = T::binary(BinOp::Sub, x, c[0]);
    let dy = T::binary(BinOp::Sub, y, c[1]);
    let dz = T::binary(BinOp::Sub, z, c[2]);
    let s = T::binary(BinOp::Add, T::unary(UnOp::Square, dx), T::unary(UnOp::Square, dy));
    let s = T::binary(BinOp::Add, s, T::unary(UnOp::Square, dz));
    T::binary(BinOp::Sub, T::unary(UnOp::Sqrt, s), r)
}

/// The eight operations of `Builder::smooth_union(a, b, k)` in its order,
/// `c` = 0.25 / k; `min`'s operands as (a, b) when `ab`, else (b, a).
#[inline(always)]
fn smooth_union<T: Num>(ab: bool, a: T, b: T, k: T, c: T) -> T {
    let d = T::binary(BinOp::Sub, a, b);
    let ad = T::unary(UnOp::Abs, d);
    let kd = T::binary(BinOp::Sub, k, ad);
    let h = T::binary(BinOp::Max, kd, T::from_f64(0.0));
    let h2 = T::unary(UnOp::Square, h);
    let corr = T::binary(BinOp::Mul, h2, c);
    let m = if ab {
        T::binary(BinOp::Min, a, b)
    } else {
        T::binary(BinOp::Min, b, a)
    };
    T::binary(BinOp::Sub, m, corr)
}

#[cfg(test)]
mod tests {
    use crate::interval::{eval_interval_choices, Interval};
    use crate::simplify::simplify;
    use crate::{compile, BatchEvaluator, Library, PointEvaluator};

    /// Compiled programs give the point evaluator's values bit for bit,
    /// for full tapes and simplified ones, over every count of points
    /// around the block sizes, with parameters, selects and lazy regions.
    #[test]
    fn programs_equal_the_point_evaluator() {
        let lib = Library::new();
        let shapes = [
            "smooth_union(smooth_union(sphere(p - vec3(1.0, 0.0, 0.0), 0.5), box(p + vec3(1.0, 0.0, 0.0), 0.4), 0.3), torus(p - vec3(0.0, 1.5, 0.0), 0.6, 0.2), 0.2)",
            "min(sphere(p, 0.5) + 0.2 * step(0.3, p.x), max(box(p - vec3(0.0, 1.0, 0.0), 0.3), -sphere(p - vec3(0.0, 1.2, 0.0), 0.2)))",
            "octahedron(twist_y(p, 2.0), 1.0) + 0.1 * sin(7.0 * p.x) - 2.0 / (3.0 + p.y * p.y) + pow(abs(p.z) + 0.1, 1.5)",
            "sphere(p, 1.0 + 0.25 * sin(t)) - min(0.1, p.x) + max(p.y, -0.3) / 4.0",
            "p.x",
            "0.25",
        ];
        let mut seed = 5u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % 1_000_000) as f64 / 1_000_000.0
        };
        for src in shapes {
            let sh = compile(&lib, src).unwrap_or_else(|e| panic!("{src}: {e:?}"));
            let full = sh.tape();
            let vars = [0.7];
            let mut variants = vec![full.clone()];
            for _ in 0..20 {
                let c: [f64; 3] = std::array::from_fn(|_| rnd() * 3.0 - 1.5);
                let b: [Interval; 3] = std::array::from_fn(|k| Interval::new(c[k] - 0.3, c[k] + 0.3));
                let mut choices = Vec::new();
                eval_interval_choices(full, &vars, b, Some(&mut choices));
                if let Some(t) = simplify(full, &choices) {
                    variants.push(t);
                }
            }
            let mut batch = BatchEvaluator::<f32>::new(full);
            let mut point = PointEvaluator::<f32>::new(full);
            for v in &variants {
                for n in [1usize, 3, 8, 9, 63, 64, 65, 130] {
                    let pts: Vec<[f32; 3]> = (0..n)
                        .map(|_| std::array::from_fn(|_| (rnd() * 3.0 - 1.5) as f32))
                        .collect();
                    let (xs, ys, zs): (Vec<f32>, Vec<f32>, Vec<f32>) = (
                        pts.iter().map(|p| p[0]).collect(),
                        pts.iter().map(|p| p[1]).collect(),
                        pts.iter().map(|p| p[2]).collect(),
                    );
                    let mut out = vec![0.0f32; n];
                    batch.eval_variant(v, &vars, &xs, &ys, &zs, &mut out);
                    for (i, p) in pts.iter().enumerate() {
                        // The variant holds near its box only; compare with
                        // the variant itself run point by point.
                        let want = point.eval_variant(v, &vars, p[0], p[1], p[2]);
                        assert_eq!(out[i].to_bits(), want.to_bits(), "{src}: point {p:?} of {n}");
                    }
                }
            }
        }
    }

    /// `src`'s program in f32 and its values by slot (constants only).
    fn compiled(lib: &Library, src: &str) -> (super::Program<f32>, Vec<f32>) {
        let sh = compile(lib, src).unwrap();
        let t = sh.tape();
        let prog = super::Compiler::default().compile(t, &super::Slots::<f32>::of(t));
        (prog, crate::eval::constant_slots(t))
    }

    /// A sphere's program joins an assembled one as a single operation
    /// with the same values; other programs are copied as they are.
    #[test]
    fn spheres_run_as_one_operation() {
        let lib = Library::new();
        let mut seed = 17u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            ((seed % 1_000_000) as f64 / 1_000_000.0 * 8.0 - 4.0) as f32
        };
        for (src, fused) in [
            ("sphere(p - vec3(1.0, -2.0, 0.37), 0.22)", true),
            ("length(p - vec3(0.5, 0.25, -3.0)) - 1.5", true),
            ("sphere(p - vec3(0.0, 1.5, 0.0), 0.75)", true),
            ("sphere(p, 0.5)", true),
            ("sphere(p * 2.0, 1.0)", false),
            ("box(p, vec3(0.5))", false),
        ] {
            let (prog, values) = compiled(&lib, src);
            let mut asm = super::Assembler::<f32>::new();
            let out = asm.append(&prog, &values, 3);
            let joined = asm.finish(out);
            assert_eq!(joined.len() == 1, fused, "{src}: {} operations", joined.len());
            let n = 200;
            let p: [Vec<f32>; 3] = std::array::from_fn(|_| (0..n).map(|_| rnd()).collect());
            let (mut a, mut b) = (vec![0.0f32; n], vec![0.0f32; n]);
            joined.eval(&mut Vec::new(), &[], &p[0], &p[1], &p[2], &mut a);
            prog.eval(&mut Vec::new(), &values, &p[0], &p[1], &p[2], &mut b);
            for i in 0..n {
                assert_eq!(a[i].to_bits(), b[i].to_bits(), "{src} at point {i}");
            }
        }
    }

    /// The program run as compiled for AVX2 (where the CPU has it) gives
    /// the portable build's values bit for bit, transcendental functions,
    /// selects and fused operations included.
    #[test]
    fn wide_vectors_change_no_value() {
        let lib = Library::new();
        let mut seed = 23u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            ((seed % 1_000_000) as f64 / 1_000_000.0 * 6.0 - 3.0) as f32
        };
        for src in [
            "smooth_union(sphere(p - vec3(1.0, 0.0, 0.0), 0.5), torus(p, 0.6, 0.2), 0.3) + 0.1 * sin(7.0 * p.x)",
            "min(box(p, vec3(0.5)) + 0.2 * step(0.3, p.y), pow(abs(p.z) + 0.1, 1.5) - exp(-p.x * p.x))",
            "sphere(p - vec3(1.0, -2.0, 0.37), 0.22)",
        ] {
            let (prog, values) = compiled(&lib, src);
            for n in [1usize, 7, 8, 9, 64, 100] {
                let p: [Vec<f32>; 3] = std::array::from_fn(|_| (0..n).map(|_| rnd()).collect());
                let (mut a, mut b) = (vec![0.0f32; n], vec![0.0f32; n]);
                let ps = [&p[0][..], &p[1][..], &p[2][..]];
                prog.eval_by(super::Program::run, &mut Vec::new(), &values, ps, &mut a);
                prog.eval_by(super::Program::run_any, &mut Vec::new(), &values, ps, &mut b);
                for i in 0..n {
                    assert_eq!(a[i].to_bits(), b[i].to_bits(), "{src} at point {i} of {n}");
                }
            }
        }
    }

    /// A sphere's tape is recognised from its operations, with its centre
    /// and radius; anything else is not.
    #[test]
    fn sphere_forms_are_read_from_tapes() {
        let lib = Library::new();
        let form = |src: &str| super::sphere_form(compile(&lib, src).unwrap().tape());
        assert_eq!(
            form("sphere(p - vec3(1.0, -2.0, 0.375), 0.25)"),
            Some(([1.0, -2.0, 0.375], 0.25))
        );
        assert_eq!(
            form("length(p - vec3(0.5, 0.25, -3.0)) - 1.5"),
            Some(([0.5, 0.25, -3.0], 1.5))
        );
        // Centre coordinates of 0 subtract nothing.
        assert_eq!(
            form("sphere(p - vec3(0.0, -1000.0, 0.0), 999.0)"),
            Some(([0.0, -1000.0, 0.0], 999.0))
        );
        assert_eq!(form("sphere(p, 0.5)"), Some(([0.0; 3], 0.5)));
        for other in [
            "sphere(p - vec3(1.0, 2.0, 3.0), 0.25) + 0.0 * sin(p.x)",
            "sphere(p * 2.0, 1.0)",
            "length(p - vec3(1.0, 2.0, 3.0)) + 0.5",
            "box(p - vec3(1.0, 2.0, 3.0), vec3(0.5))",
            "sphere(p - vec3(1.0, 2.0, 3.0), 0.25 + 0.1 * t)",
            // Summed in another order: other roundings.
            "sqrt((p.x - 1.0) * (p.x - 1.0) + ((p.y - 2.0) * (p.y - 2.0) + (p.z - 3.0) * (p.z - 3.0))) - 0.5",
        ] {
            assert_eq!(form(other), None, "{other}");
        }
    }

    /// A short tape simplified out of a long one runs in a few registers,
    /// not over the long tape's thousands of slots.
    #[test]
    fn simplified_tapes_run_in_few_registers() {
        let lib = Library::new();
        let mut src = String::from("sphere(p, 0.2)");
        for i in 1..120 {
            // Distinct centres: a constant slot each.
            let x = (i % 10) as f64 - 4.5 + 0.001 * i as f64;
            let y = ((i / 10) % 20) as f64 - 9.5 + 0.0007 * i as f64;
            src = format!("smooth_union({src}, sphere(p - vec3({x:.4}, {y:.4}, 0.0), 0.2), 0.1)");
        }
        let sh = compile(&lib, &src).unwrap();
        let full = sh.tape();
        assert!(full.slots() > 200, "{} slots", full.slots());
        let b = [
            Interval::new(0.4, 0.6),
            Interval::new(0.4, 0.6),
            Interval::new(-0.1, 0.1),
        ];
        let mut choices = Vec::new();
        eval_interval_choices(full, &[], b, Some(&mut choices));
        let short = simplify(full, &choices).unwrap();
        assert!(short.len() < 60, "{} instructions", short.len());
        let prog = super::Compiler::default().compile(&short, &super::Slots::<f32>::of(full));
        assert!(prog.regs < 24, "{} registers", prog.regs);
    }
}
