//! A fold of objects specialised to boxes at the level of objects.
//!
//! A scene's distance is the fold, in file order, of its objects' distances
//! by `min` or by [`Builder::smooth_union`](crate::Builder::smooth_union)
//! of width k. Over a box, [`Fold::specialise`] keeps of a list of objects
//! only those that can change the fold's value there, from interval bounds
//! of each object's own tape: an object at least k above the fold so far
//! leaves it as it is (`su(acc, n) = acc` exactly when n − acc ≥ k: the
//! correction is 0² · c = 0), and one at least k below everything before
//! it restarts it (`su(acc, n) = n` exactly). The kept objects' compiled
//! programs are then put together with the fold's own operations, in the
//! order and with the operands the scene's tape has, so a box's program
//! gives the scene tape's value bit for bit at every point of the box.
//! This is what [`crate::simplify`] does for the fold, object by object
//! instead of instruction by instruction: several times cheaper, which is
//! what makes small boxes worth specialising for.

use crate::interval::{Interval, IntervalEvaluator};
use crate::program::{Assembler, Compiler, FoldOp, Program, Slots};
use crate::{BatchEvaluator, Tape};

/// One object of a fold.
#[derive(Debug)]
struct Part<'t> {
    program: Program<f32>,
    /// Its values by slot (constants and the prologue's, at the inputs).
    values: Vec<f32>,
    bounds: IntervalEvaluator<'t>,
    /// Its centre and radius when its distance is a sphere's: bounded in
    /// closed form.
    sphere: Option<([f64; 3], f64)>,
}

/// The fold of objects' distances (see the module docs), ready to
/// specialise to boxes and evaluate.
#[derive(Debug)]
pub struct Fold<'t> {
    parts: Vec<Part<'t>>,
    /// The smooth union's width (0: `min`).
    k: f64,
    regs: Vec<f32>,
}

/// A fold specialised to a box: the objects kept, in order, and their
/// program.
#[derive(Debug, Clone)]
pub struct FoldCell {
    objects: Vec<u32>,
    program: Program<f32>,
}

impl FoldCell {
    /// The objects it runs, in file order.
    pub fn objects(&self) -> &[u32] {
        &self.objects
    }

    /// Instructions it runs per point.
    pub fn len(&self) -> usize {
        self.program.len()
    }

    /// True when it runs nothing (never: a fold has an object).
    pub fn is_empty(&self) -> bool {
        self.program.len() == 0
    }
}

/// The fold so far (and 4: each operation writes the other).
const ACC: u32 = 3;
/// 0.25 / k, the smooth union's constant factor.
const CORR: u32 = 5;
/// The first register of the objects' own.
const BASE: u32 = CORR + 1;

impl<'t> Fold<'t> {
    /// The fold of the objects' `tapes` in order with width `k` (0: by
    /// `min`), at the inputs `vars`, checked against `scene` (the scene's
    /// tape of that fold) at sample points of the cube of half-size `half`
    /// around `center`: None unless every value is the scene tape's bit for
    /// bit (then the caller simplifies the scene's tape instead), or when
    /// there are no objects or a tape has lazy regions. `spheres` gives,
    /// per object (or none), the centre and radius of the sphere its
    /// distance is (as recognised for closed-form intersection): such an
    /// object is bounded over a box in closed form, a few operations
    /// instead of its tape's interval arithmetic.
    pub fn new(
        tapes: &[&'t Tape],
        spheres: &[Option<([f64; 3], f64)>],
        k: f64,
        vars: &[f64],
        scene: &Tape,
        center: [f64; 3],
        half: f64,
    ) -> Option<Self> {
        if tapes.is_empty() || !(k >= 0.0 && k.is_finite()) {
            return None;
        }
        let mut compiler = Compiler::default();
        let mut parts = Vec::with_capacity(tapes.len());
        for (j, &t) in tapes.iter().enumerate() {
            if t.instrs().iter().any(|i| matches!(i, crate::ir::Instr::Skip { .. })) {
                return None;
            }
            let slots = Slots::<f32>::of(t);
            let mut values: Vec<f32> = crate::eval::constant_slots(t);
            let mut scratch = Vec::new();
            for (s, v) in t.prologue().run(vars, &mut scratch) {
                values[s] = v as f32;
            }
            parts.push(Part {
                program: compiler.compile(t, &slots),
                values,
                bounds: IntervalEvaluator::new(t, vars),
                sphere: spheres
                    .get(j)
                    .copied()
                    .flatten()
                    .filter(|(c, r)| r.is_finite() && c.iter().all(|x| x.is_finite())),
            });
        }
        let mut fold = Fold {
            parts,
            k,
            regs: Vec::new(),
        };
        // The whole fold against the scene's tape.
        let all = fold.whole();
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let n = 64;
        let mut p: [Vec<f32>; 3] = Default::default();
        for _ in 0..n {
            for (k, v) in p.iter_mut().enumerate() {
                // Half the points near the centre, where objects are.
                let r = if v.len() % 2 == 0 { half } else { half / 16.0 };
                v.push((center[k] + (2.0 * rnd() - 1.0) * r) as f32);
            }
        }
        let mut want = vec![0.0f32; n];
        BatchEvaluator::<f32>::new(scene).eval(vars, &p[0], &p[1], &p[2], &mut want);
        let mut got = vec![0.0f32; n];
        fold.eval(&all, &p[0], &p[1], &p[2], &mut got);
        want.iter()
            .zip(&got)
            .all(|(a, b)| a.to_bits() == b.to_bits())
            .then_some(fold)
    }

    /// The fold of every object.
    pub fn whole(&self) -> FoldCell {
        let objects: Vec<u32> = (0..self.parts.len() as u32).collect();
        let program = self.assemble(&objects);
        FoldCell { objects, program }
    }

    /// `cell` specialised to the box `bx` (within the cell's own): None
    /// when every object of it may still matter there.
    pub fn specialise(&mut self, cell: &FoldCell, bx: [Interval; 3]) -> Option<FoldCell> {
        let k = self.k;
        // How far apart two bounds must be for the f32 evaluation to make
        // the same choice at every point: relative to the values and to
        // the box's coordinates (the objects' rounding grows with them).
        let size = bx.iter().fold(1.0f64, |m, i| m.max(i.lo.abs()).max(i.hi.abs()));
        let margin = |a: f64, b: f64| 1e-5 * (a.abs() + b.abs() + k + size);
        let mut kept: Vec<u32> = Vec::new();
        let mut acc: Option<Interval> = None;
        for &j in &cell.objects {
            let part = &mut self.parts[j as usize];
            let n = match part.sphere {
                Some((c, r)) => sphere_bound(c, r, bx),
                None => {
                    let t = part.bounds.tape();
                    part.bounds.eval(t, bx, None)
                }
            };
            if n.lo.is_nan() || n.hi.is_nan() {
                return None;
            }
            let Some(a) = acc else {
                acc = Some(n);
                kept.push(j);
                continue;
            };
            if n.lo - a.hi >= k + margin(n.lo, a.hi) {
                // At least k above everything so far: the fold goes on as it is.
                continue;
            }
            if a.lo - n.hi >= k + margin(a.lo, n.hi) {
                // At least k below: the fold restarts at this object.
                kept.clear();
                kept.push(j);
                acc = Some(n);
                continue;
            }
            kept.push(j);
            acc = Some(fold_bound(a, n, k));
        }
        if kept.len() == cell.objects.len() {
            return None;
        }
        let program = self.assemble(&kept);
        Some(FoldCell { objects: kept, program })
    }

    /// The program of the fold of `objects` (file order), restarting at
    /// the first.
    fn assemble(&self, objects: &[u32]) -> Program<f32> {
        let mut a = Assembler::<f32>::new();
        let k = self.k;
        let (kk, c) = (k as f32, (0.25 / k) as f32);
        let mut acc = ACC;
        if k > 0.0 && objects.len() > 1 {
            a.op(FoldOp::Fill, CORR, CORR, CORR, c);
        }
        for (i, &j) in objects.iter().enumerate() {
            let part = &self.parts[j as usize];
            let n = a.append(&part.program, &part.values, BASE);
            if i == 0 {
                a.op(FoldOp::Copy, acc, n, n, 0.0);
                continue;
            }
            let next = if acc == ACC { ACC + 1 } else { ACC };
            // The scene's tape orders min's operands by node: the first
            // two objects as they come, later objects before the fold.
            let ab = j == 1;
            if k > 0.0 {
                // One operation for the smooth union's eight (CORR holds
                // 0.25 / k).
                a.smooth_union(ab, next, acc, n, CORR, kk);
            } else {
                let (m0, m1) = if ab { (acc, n) } else { (n, acc) };
                a.op(FoldOp::Min, next, m0, m1, 0.0);
            }
            acc = next;
        }
        a.finish(acc)
    }

    /// The fold's value at the points, with `cell`'s program (valid in
    /// its box).
    pub fn eval(&mut self, cell: &FoldCell, xs: &[f32], ys: &[f32], zs: &[f32], out: &mut [f32]) {
        cell.program.eval(&mut self.regs, &[], xs, ys, zs, out);
    }
}

/// Of the objects `candidates` (in file order) of a fold with smooth-union
/// width `k` (0: `min`), whose distances over a box are bounded by
/// `bound(j)`, those that can change the fold anywhere in the box, from
/// the last one that restarts it there; with `width` ≥ k the same holds
/// for a material blend of width `width` folded beside it (the nearest
/// object and the blend weights too). An object is left out when at every
/// point it lies above the nearest object so far and at least `width`
/// above the fold so far (the smooth union's correction is then 0 and the
/// blend weight 0: nothing changes), and it restarts the fold when it lies
/// below the nearest object so far and at least `width` below the fold so
/// far (the union is then the object, and its weight 1). `scale`, the
/// box's largest coordinate, sizes the margin that the f32 evaluation's
/// rounding needs. Also returns a bound of the fold over the box (of the
/// objects kept).
pub fn cull(
    candidates: &[u32],
    k: f64,
    width: f64,
    scale: f64,
    mut bound: impl FnMut(u32) -> Interval,
) -> (Vec<u32>, Interval) {
    // a < b at every point of the box, whatever the f32 evaluation's rounding.
    let below = |a: f64, b: f64| a < b - 1e-5 * (a.abs() + b.abs() + scale) - 1e-6;
    let width = width.max(k);
    let mut kept: Vec<u32> = Vec::new();
    let (mut acc, mut best) = (Interval::point(0.0), Interval::point(0.0));
    for &j in candidates {
        let iv = bound(j);
        if !kept.is_empty() {
            let after = below(best.hi, iv.lo) && (k == 0.0 || below(acc.hi + width, iv.lo));
            if after {
                continue; // changes nothing here
            }
            let before = below(iv.hi, best.lo) && (k == 0.0 || below(iv.hi + width, acc.lo));
            if before {
                kept.clear(); // restarts the fold here
            }
        }
        if kept.is_empty() {
            kept.push(j);
            (acc, best) = (iv, iv);
            continue;
        }
        kept.push(j);
        best = Interval::new(best.lo.min(iv.lo), best.hi.min(iv.hi));
        acc = if k > 0.0 {
            // min(a, b) − h²/(4k) with 0 ≤ h ≤ k.
            Interval::new(acc.lo.min(iv.lo) - 0.25 * k, acc.hi.min(iv.hi))
        } else {
            best
        };
    }
    (kept, acc)
}

/// Bounds of |p − c| − r over the box: the distances from c to the box's
/// nearest and furthest points, padded for rounding (and for the centre
/// and radius being recognised, to ~1e-9, rather than read).
pub fn sphere_bound(c: [f64; 3], r: f64, bx: [Interval; 3]) -> Interval {
    let (mut near, mut far) = (0.0f64, 0.0f64);
    for k in 0..3 {
        let (lo, hi) = (bx[k].lo - c[k], bx[k].hi - c[k]);
        // The gap to the box along this axis (0 when c is within it);
        // without branches, which the descent cannot predict.
        let n = lo.max(0.0) + (-hi).max(0.0);
        let f = lo.abs().max(hi.abs());
        near += n * n;
        far += f * f;
    }
    let size = c.iter().fold(r.abs(), |m, x| m.max(x.abs())) + far.sqrt();
    let pad = 1e-7 * (1.0 + size);
    Interval::new(near.sqrt() - r - pad, far.sqrt() - r + pad)
}

/// Bounds of the smooth union of width k (min for k = 0) of operands
/// bounded by `a` and `b`: the function is nondecreasing in both, so its
/// range is that of the ends, padded for rounding.
fn fold_bound(a: Interval, b: Interval, k: f64) -> Interval {
    let f = |x: f64, y: f64| {
        if k > 0.0 {
            let h = (k - (x - y).abs()).max(0.0);
            x.min(y) - h * h * (0.25 / k)
        } else {
            x.min(y)
        }
    };
    let slack = |m: f64| 16.0 * f64::EPSILON * (m.abs() + k) + f64::MIN_POSITIVE;
    let lo = f(a.lo, b.lo);
    let hi = f(a.hi, b.hi);
    let lo = if lo.is_nan() { f64::NEG_INFINITY } else { lo - slack(lo) };
    let hi = if hi.is_nan() { f64::INFINITY } else { hi + slack(hi) };
    Interval::new(lo, hi)
}
