//! A guaranteed distance bound for any implicit equation: the Lipschitz
//! bound of the field over a ball, by interval arithmetic written into the DAG.
//!
//! If |∇f| ≤ L on the ball B(p, r), then f has no zero closer to p than
//! min(|f(p)| / L, r). The bound L comes from the interval extension of the
//! exact symbolic gradient over the cube [p − r, p + r]³ (which contains the
//! ball), evaluated as ordinary DAG nodes so the renderer's batch evaluator
//! runs it. The radius is the first-order estimate r = |f|/|∇f(p)|: near the
//! surface the box is small, L ≈ |∇f(p)| and the step is nearly r. Near
//! critical points of f, where that radius is far too large, a second radius
//! (the geometric mean of r and the step it gave) recovers a useful step.

use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_2, PI};

use crate::ir::{BinOp, Builder, Node, Op, UnOp};

/// Stands for ±∞ in the ends of the intervals written into the DAG (finite
/// so f32 arithmetic stays NaN-free): the rules work on the saturated line
/// [−BIG, BIG].
pub const BIG: f64 = 1e18;

/// exp's argument is clamped here: exp 42 ≈ 1.7e18 is beyond [`BIG`], so a
/// larger argument still gives a saturated end, and is finite in f32.
const EXP_CLAMP: f64 = 42.0;

/// Copies the DAG of `n` from `src` into `dst`, with the coordinates X, Y, Z
/// of `src` replaced by the nodes `p`.
pub fn import(src: &Builder, n: Node, dst: &mut Builder, p: [Node; 3], memo: &mut HashMap<Node, Node>) -> Node {
    if let Some(&m) = memo.get(&n) {
        return m;
    }
    let out = match src.op(n) {
        Op::Const(v) => dst.constant(v),
        Op::Input(v) => dst.input(v),
        Op::X => p[0],
        Op::Y => p[1],
        Op::Z => p[2],
        Op::Unary(op, a) => {
            let a = import(src, a, dst, p, memo);
            dst.unary(op, a)
        }
        Op::Binary(op, a, b) => {
            let a = import(src, a, dst, p, memo);
            let b = import(src, b, dst, p, memo);
            dst.binary(op, a, b)
        }
        Op::Select(c, a, b) => {
            let c = import(src, c, dst, p, memo);
            let a = import(src, a, dst, p, memo);
            let b = import(src, b, dst, p, memo);
            dst.select(c, a, b)
        }
    };
    memo.insert(n, out);
    out
}

/// An interval as a pair of DAG nodes.
#[derive(Debug, Clone, Copy)]
struct Iv {
    lo: Node,
    hi: Node,
}

/// Writes the interval extension of `n` (from `src`) over the box `bx` into `dst`.
struct IntervalWriter<'a> {
    src: &'a Builder,
    bx: [Iv; 3],
    memo: HashMap<Node, Iv>,
}

impl IntervalWriter<'_> {
    fn point(b: &mut Builder, v: f64) -> Iv {
        let c = b.constant(v);
        Iv { lo: c, hi: c }
    }

    fn monotone(b: &mut Builder, op: UnOp, a: Iv) -> Iv {
        Iv {
            lo: b.unary(op, a.lo),
            hi: b.unary(op, a.hi),
        }
    }

    /// The interval of |a|: [max(0, lo, −hi), max(|lo|, |hi|)].
    fn abs(b: &mut Builder, a: Iv) -> Iv {
        let zero = b.constant(0.0);
        let nhi = b.neg(a.hi);
        let m = b.max(a.lo, nhi);
        let lo = b.max(m, zero);
        let al = b.abs(a.lo);
        let ah = b.abs(a.hi);
        Iv { lo, hi: b.max(al, ah) }
    }

    fn clamp(b: &mut Builder, a: Iv, lo: f64, hi: f64) -> Iv {
        let (l, h) = (b.constant(lo), b.constant(hi));
        Iv {
            lo: b.clamp(a.lo, l, h),
            hi: b.clamp(a.hi, l, h),
        }
    }

    fn mul(b: &mut Builder, x: Iv, y: Iv) -> Iv {
        let p = [
            b.mul(x.lo, y.lo),
            b.mul(x.lo, y.hi),
            b.mul(x.hi, y.lo),
            b.mul(x.hi, y.hi),
        ];
        let (m1, m2) = (b.min(p[0], p[1]), b.min(p[2], p[3]));
        let (n1, n2) = (b.max(p[0], p[1]), b.max(p[2], p[3]));
        Iv {
            lo: b.min(m1, m2),
            hi: b.max(n1, n2),
        }
    }

    /// sin or cos (`op`) over [lo, hi]: ±1 where the interval contains a
    /// crest or trough (at `crest` + 2πk and `crest` + π + 2πk), else the
    /// values at the ends. The ends are evaluated with `op` itself: cos as a
    /// shifted sine is off by an ulp of the shifted argument, which is far
    /// more than an ulp of the result for large arguments.
    fn trig(b: &mut Builder, a: Iv, op: UnOp, crest: f64) -> Iv {
        let (lo, hi) = (a.lo, a.hi);
        let (sl, sh) = (b.unary(op, lo), b.unary(op, hi));
        let ends_lo = b.min(sl, sh);
        let ends_hi = b.max(sl, sh);
        // A point φ + 2πk lies in (lo, hi] when ⌊(hi − φ)/2π⌋ > ⌊(lo − φ)/2π⌋.
        let contains = |b: &mut Builder, phase: f64| {
            let u = b.add_c(hi, -phase);
            let u = b.mul_c(u, 1.0 / (2.0 * PI));
            let u = b.unary(UnOp::Floor, u);
            let v = b.add_c(lo, -phase);
            let v = b.mul_c(v, 1.0 / (2.0 * PI));
            let v = b.unary(UnOp::Floor, v);
            b.sub(u, v)
        };
        let has_crest = contains(b, crest);
        let has_trough = contains(b, crest - PI);
        let (one, minus) = (b.constant(1.0), b.constant(-1.0));
        Iv {
            lo: b.select(has_trough, minus, ends_lo),
            hi: b.select(has_crest, one, ends_hi),
        }
    }

    /// ln over [lo, hi] (clamped to [0, BIG]), with −BIG for ln 0 = −∞.
    fn ln(b: &mut Builder, a: Iv) -> Iv {
        let c = Self::clamp(b, a, 0.0, BIG);
        let l = Self::monotone(b, UnOp::Ln, c);
        let m = b.constant(-BIG);
        Iv {
            lo: b.max(l.lo, m),
            hi: b.max(l.hi, m),
        }
    }

    /// exp over [lo, hi]: the arguments are clamped at 42, where exp is
    /// beyond BIG already (exp 42 ≈ 1.7e18), so the result saturates.
    fn exp(b: &mut Builder, a: Iv) -> Iv {
        let c = Self::clamp(b, a, -BIG, EXP_CLAMP);
        Self::monotone(b, UnOp::Exp, c)
    }

    fn whole(b: &mut Builder) -> Iv {
        Iv {
            lo: b.constant(-BIG),
            hi: b.constant(BIG),
        }
    }

    fn write(&mut self, b: &mut Builder, n: Node) -> Iv {
        if let Some(&v) = self.memo.get(&n) {
            return v;
        }
        let out = match self.src.op(n) {
            Op::Const(v) => Self::point(b, v),
            Op::Input(v) => {
                let n = b.input(v);
                Iv { lo: n, hi: n }
            }
            Op::X => self.bx[0],
            Op::Y => self.bx[1],
            Op::Z => self.bx[2],
            Op::Unary(op, a) => {
                let a = self.write(b, a);
                match op {
                    UnOp::Neg => Iv {
                        lo: b.neg(a.hi),
                        hi: b.neg(a.lo),
                    },
                    UnOp::Abs => Self::abs(b, a),
                    UnOp::Square => {
                        let m = Self::abs(b, a);
                        Iv {
                            lo: b.square(m.lo),
                            hi: b.square(m.hi),
                        }
                    }
                    UnOp::Sqrt => {
                        let c = Self::clamp(b, a, 0.0, BIG);
                        Self::monotone(b, UnOp::Sqrt, c)
                    }
                    UnOp::Sin => Self::trig(b, a, UnOp::Sin, FRAC_PI_2),
                    UnOp::Cos => Self::trig(b, a, UnOp::Cos, 0.0),
                    UnOp::Tan => Self::whole(b),
                    UnOp::Asin => {
                        let c = Self::clamp(b, a, -1.0, 1.0);
                        Self::monotone(b, UnOp::Asin, c)
                    }
                    UnOp::Acos => {
                        let c = Self::clamp(b, a, -1.0, 1.0);
                        Iv {
                            lo: b.unary(UnOp::Acos, c.hi),
                            hi: b.unary(UnOp::Acos, c.lo),
                        }
                    }
                    UnOp::Exp => Self::exp(b, a),
                    UnOp::Ln => Self::ln(b, a),
                    UnOp::Atan | UnOp::Floor | UnOp::Round | UnOp::Sign => Self::monotone(b, op, a),
                }
            }
            Op::Binary(op, x, y) => {
                let xi = self.write(b, x);
                if op == BinOp::Pow {
                    if let Some(k) = self.src.const_value(y) {
                        return self.power(b, n, xi, k);
                    }
                }
                let yi = self.write(b, y);
                match op {
                    BinOp::Add => Iv {
                        lo: b.add(xi.lo, yi.lo),
                        hi: b.add(xi.hi, yi.hi),
                    },
                    BinOp::Sub => Iv {
                        lo: b.sub(xi.lo, yi.hi),
                        hi: b.sub(xi.hi, yi.lo),
                    },
                    BinOp::Mul => Self::mul(b, xi, yi),
                    BinOp::Div => {
                        // 1/y when y keeps one sign, else everything.
                        let one = b.constant(1.0);
                        let inv = Iv {
                            lo: b.div(one, yi.hi),
                            hi: b.div(one, yi.lo),
                        };
                        let q = Self::mul(b, xi, inv);
                        let same_sign = b.mul(yi.lo, yi.hi);
                        let w = Self::whole(b);
                        Iv {
                            lo: b.select(same_sign, q.lo, w.lo),
                            hi: b.select(same_sign, q.hi, w.hi),
                        }
                    }
                    BinOp::Min => Iv {
                        lo: b.min(xi.lo, yi.lo),
                        hi: b.min(xi.hi, yi.hi),
                    },
                    BinOp::Max => Iv {
                        lo: b.max(xi.lo, yi.lo),
                        hi: b.max(xi.hi, yi.hi),
                    },
                    BinOp::Pow => {
                        // x^y = exp(y · ln x) for x > 0; a base that may be
                        // 0 or negative (where integer exponents give
                        // values of either sign) gives everything.
                        let lx = Self::ln(b, xi);
                        let e = Self::mul(b, yi, lx);
                        let r = Self::exp(b, e);
                        let w = Self::whole(b);
                        Iv {
                            lo: b.select(xi.lo, r.lo, w.lo),
                            hi: b.select(xi.lo, r.hi, w.hi),
                        }
                    }
                    BinOp::Atan2 => Iv {
                        lo: b.constant(-PI),
                        hi: b.constant(PI),
                    },
                }
            }
            Op::Select(c, x, y) => {
                let ci = self.write(b, c);
                let xi = self.write(b, x);
                let yi = self.write(b, y);
                // c > 0 throughout: x; c ≤ 0 throughout: y; else the hull.
                let hull_lo = b.min(xi.lo, yi.lo);
                let hull_hi = b.max(xi.hi, yi.hi);
                let mixed_lo = b.select(ci.hi, hull_lo, yi.lo);
                let mixed_hi = b.select(ci.hi, hull_hi, yi.hi);
                Iv {
                    lo: b.select(ci.lo, xi.lo, mixed_lo),
                    hi: b.select(ci.lo, xi.hi, mixed_hi),
                }
            }
        };
        self.memo.insert(n, out);
        out
    }

    /// x^k for a constant k.
    fn power(&mut self, b: &mut Builder, n: Node, x: Iv, k: f64) -> Iv {
        let e = b.constant(k);
        let integer = k.fract() == 0.0;
        let even = integer && k % 2.0 == 0.0;
        let out = if k >= 0.0 {
            // Increasing on the base: |x| for even powers, x ≥ 0 for real ones.
            let base = if even {
                Self::abs(b, x)
            } else if integer {
                x
            } else {
                Self::clamp(b, x, 0.0, BIG)
            };
            Iv {
                lo: b.binary(BinOp::Pow, base.lo, e),
                hi: b.binary(BinOp::Pow, base.hi, e),
            }
        } else if even || !integer {
            // Decreasing on the base (|x|, or x ≥ 0), with a pole at 0: BIG at
            // a base end at or below TINY, where x^k may be as large as it likes.
            let base = if even {
                Self::abs(b, x)
            } else {
                Self::clamp(b, x, 0.0, BIG)
            };
            let c = Self::clamp(b, base, TINY, BIG);
            let big = b.constant(BIG);
            let (pl, ph) = (b.binary(BinOp::Pow, c.lo, e), b.binary(BinOp::Pow, c.hi, e));
            let (pl, ph) = (b.min(pl, big), b.min(ph, big));
            let above = b.add_c(base.lo, -TINY);
            Iv {
                lo: ph,
                hi: b.select(above, pl, big),
            }
        } else {
            // Odd negative powers: decreasing on each side of the pole at 0,
            // odd; everything when the interval reaches 0.
            let c = Self::clamp(b, x, -BIG, BIG);
            let (pl, ph) = (b.binary(BinOp::Pow, c.lo, e), b.binary(BinOp::Pow, c.hi, e));
            let r = Self::clamp(b, Iv { lo: ph, hi: pl }, -BIG, BIG);
            let same_sign = b.mul(x.lo, x.hi);
            let w = Self::whole(b);
            Iv {
                lo: b.select(same_sign, r.lo, w.lo),
                hi: b.select(same_sign, r.hi, w.hi),
            }
        };
        self.memo.insert(n, out);
        out
    }
}

/// Bases at or below this count as 0 for negative powers (finite in f32).
const TINY: f64 = 1e-30;

/// Writes the interval extension of `n` (a node of `src`) into `dst`, over the
/// box whose x, y and z ranges are the `(lo, hi)` node pairs `bx` of `dst`,
/// with the rules the Lipschitz bound uses; returns the `(lo, hi)` nodes.
/// Ends of ±[`BIG`] stand for ±∞. Public so that the interval rules can be
/// checked one operation at a time (see [`crate::conformance`]).
pub fn interval_extension(src: &Builder, n: Node, dst: &mut Builder, bx: [(Node, Node); 3]) -> (Node, Node) {
    let mut w = IntervalWriter {
        src,
        bx: bx.map(|(lo, hi)| Iv { lo, hi }),
        memo: HashMap::new(),
    };
    let iv = w.write(dst, n);
    (iv.lo, iv.hi)
}

/// Writes the sup of |∇f| over the cube of half-width `r` around `p`.
fn gradient_sup(src: &Builder, grad: [Node; 3], dst: &mut Builder, p: [Node; 3], r: Node) -> Node {
    let bx = p.map(|c| Iv {
        lo: dst.sub(c, r),
        hi: dst.add(c, r),
    });
    let mut w = IntervalWriter {
        src,
        bx,
        memo: HashMap::new(),
    };
    let mut acc = dst.constant(0.0);
    for g in grad {
        let iv = w.write(dst, g);
        let m = IntervalWriter::abs(dst, iv);
        let sq = dst.square(m.hi);
        acc = dst.add(acc, sq);
    }
    dst.sqrt(acc)
}

/// An equation f(x, y, z) in its own builder, with its symbolic gradient.
#[derive(Debug, Clone)]
pub struct Field {
    /// The builder holding f and ∇f in its coordinates X, Y, Z.
    pub builder: Builder,
    /// f.
    pub f: Node,
    /// ∂f/∂x, ∂f/∂y, ∂f/∂z.
    pub grad: [Node; 3],
}

impl Field {
    /// Takes f from `builder` and adds its gradient.
    pub fn new(mut builder: Builder, f: Node) -> Field {
        let grad = [0, 1, 2].map(|i| builder.derivative(f, i));
        Field { builder, f, grad }
    }
}

/// Writes the signed Lipschitz bound of the field at the point `p` into `dst`.
pub fn lipschitz_bound(field: &Field, dst: &mut Builder, p: [Node; 3]) -> Node {
    let (src, f, grad) = (&field.builder, field.f, field.grad);
    let mut memo = HashMap::new();
    let value = import(src, f, dst, p, &mut memo);
    let g: Vec<Node> = grad.iter().map(|&g| import(src, g, dst, p, &mut memo)).collect();
    let mut n2 = dst.square(g[0]);
    for &c in &g[1..] {
        let sq = dst.square(c);
        n2 = dst.add(n2, sq);
    }
    let norm = dst.sqrt(n2);
    let tiny = dst.constant(1e-30);
    let big_f = dst.abs(value);
    let norm = dst.max(norm, tiny);
    let r1 = dst.div(big_f, norm);
    let cap = dst.constant(1e6);
    let r1 = dst.min(r1, cap);
    let r1 = dst.max(r1, tiny);
    // First at r₁; where |∇f(p)| understates the gradient nearby (near a
    // critical point of f) that gives a tiny step d₁, and the geometric mean
    // √(d₁·r₁) is tried as well.
    let zero = dst.constant(0.0);
    let step = |dst: &mut Builder, r: Node| {
        let l = gradient_sup(src, grad, dst, p, r);
        let l = dst.max(l, tiny);
        let d = dst.div(big_f, l);
        let d = dst.min(d, r);
        // A NaN (an interval that overflowed) gives no step.
        dst.select(d, d, zero)
    };
    let d1 = step(dst, r1);
    let floor = dst.mul_c(r1, 1e-12);
    let d1f = dst.max(d1, floor);
    let m = dst.mul(d1f, r1);
    let r2 = dst.sqrt(m);
    let d2 = step(dst, r2);
    let best = dst.max(d1, d2);
    let neg = dst.neg(best);
    dst.select(value, best, neg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::PointEvaluator;
    use crate::lower::Library;

    /// Lowers an equation in x, y, z and builds its Lipschitz bound.
    fn bound(text: &str) -> crate::ir::Tape {
        let lib = Library::new();
        let mut src = Builder::new();
        let f = lib
            .compile(&mut src, &format!("let x = p.x; let y = p.y; let z = p.z; {text}"), 0)
            .unwrap();
        let field = Field::new(std::mem::take(&mut src), f);
        let mut dst = Builder::new();
        let p = [dst.x(), dst.y(), dst.z()];
        let n = lipschitz_bound(&field, &mut dst, p);
        dst.tape(n)
    }

    #[test]
    fn plane_wave_bound_is_safe_and_useful() {
        // f = y − 0.5 sin(3x) sin(3z): the surface is within 0.5 of y = 0.
        let tape = bound("y - 0.5 * sin(3.0 * x) * sin(3.0 * z)");
        let mut e = PointEvaluator::<f64>::new(&tape);
        for i in 0..200 {
            let x = -2.0 + 0.02 * i as f64;
            let z = 0.3 * x + 0.1;
            for y in [3.0, 1.5, 0.8, 0.6, -0.7, -2.0] {
                let d = e.eval(&[], x, y, z);
                assert_eq!(d.signum(), y.signum());
                // Brute force: no zero within |d| of the point along a few directions.
                for k in 0..16 {
                    let a = k as f64 * 0.39;
                    let dir = [a.cos() * 0.6, (a * 1.7).sin(), a.sin() * 0.8];
                    let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
                    for s in 1..=20 {
                        let t = d.abs() * s as f64 / 20.0 / n;
                        let q = [x + dir[0] * t, y + dir[1] * t, z + dir[2] * t];
                        let fq = q[1] - 0.5 * (3.0 * q[0]).sin() * (3.0 * q[2]).sin();
                        assert_eq!(fq.signum(), y.signum(), "zero inside the bound at {q:?}");
                    }
                }
            }
        }
        // Far from the surface the step is a good fraction of the distance.
        assert!(e.eval(&[], 0.0, 3.0, 0.0) > 0.5);
    }

    #[test]
    fn critical_points_still_give_useful_steps() {
        // The centre of the sphere is a critical point of |p|² − 1: the
        // first-order radius is huge there, the second radius is not.
        let tape = bound("x^2 + y^2 + z^2 - 1");
        let mut e = PointEvaluator::<f64>::new(&tape);
        let d = e.eval(&[], 0.0, 0.0, 0.0);
        assert!((-1.0..=-0.2).contains(&d), "{d}");
        for r in [0.5, 0.9, 1.1, 2.0, 5.0] {
            let d = e.eval(&[], r, 0.0, 0.0);
            assert!(
                d.abs() <= (r - 1.0f64).abs() + 1e-12 && d.signum() == (r - 1.0f64).signum(),
                "{r}: {d}"
            );
        }
    }

    #[test]
    fn interval_sine_covers_crests() {
        // f = sin(x) − 2 never vanishes; its bound is positive everywhere.
        let tape = bound("sin(x) + 0.0 * y - 2.0");
        let mut e = PointEvaluator::<f64>::new(&tape);
        for i in 0..100 {
            let v = e.eval(&[], i as f64 * 0.3, 0.0, 0.0);
            assert!(v < 0.0 && v.is_finite(), "{v}");
        }
    }
}
