//! Every evaluator against the conformance suite (`isoray_shape::conformance`):
//! the point evaluators in f64, f32 and dual numbers, the batch evaluators in
//! f32 and f64, interval arithmetic, the interval rules the Lipschitz bound
//! writes into the DAG, the input prologue and the builder's constant folding.
//! Each operation's tape is built with `Builder` from the coordinates
//! (x = X, y = Y).

use isoray_shape::conformance::{
    self, binary_args, binary_differentiable, binary_info, unary_args, unary_differentiable, unary_info, Containment,
    Mismatch, Tolerance, BINARY, UNARY,
};
use isoray_shape::eval::{BatchEvaluator, Dual, PointEvaluator, LANES};
use isoray_shape::interval::{eval_interval, Interval};
use isoray_shape::ir::{apply_binary, apply_unary, BinOp, Builder, Node, Tape, UnOp};
use isoray_shape::lipschitz::{interval_extension, BIG};

fn unary_tape(op: UnOp) -> Tape {
    let mut b = Builder::new();
    let x = b.x();
    let n = b.unary(op, x);
    b.tape(n)
}

fn binary_tape(op: BinOp) -> Tape {
    let mut b = Builder::new();
    let (x, y) = (b.x(), b.y());
    let n = b.binary(op, x, y);
    b.tape(n)
}

/// Fails with the first few mismatches of each operation (and how many there were).
fn assert_ok(r: Result<(), Vec<Mismatch>>) {
    if let Err(bad) = r {
        let mut per_op = std::collections::HashMap::new();
        let shown: Vec<String> = bad
            .iter()
            .filter(|m| {
                let n = per_op.entry(m.op).or_insert(0);
                *n += 1;
                *n <= 4
            })
            .map(|m| m.to_string())
            .collect();
        panic!("{} mismatches:\n{}", bad.len(), shown.join("\n"));
    }
}

#[test]
fn the_arguments_fill_more_than_one_block() {
    assert!(unary_args().len() > LANES && unary_args().len() < 2 * LANES + 40);
    assert!(binary_args().len() > LANES);
    let v = unary_args();
    assert!(v.iter().any(|x| x.is_nan()));
    assert!(v.iter().any(|&x| x == 0.0 && x.is_sign_negative()));
    assert!(v.contains(&f64::INFINITY) && v.contains(&f64::NEG_INFINITY));
}

#[test]
fn point_evaluator_f64() {
    assert_ok(conformance::check_unary(
        "PointEvaluator<f64>",
        &mut |op, xs| {
            let t = unary_tape(op);
            let mut e = PointEvaluator::<f64>::new(&t);
            xs.iter().map(|&x| e.eval(&[], x, 0.0, 0.0)).collect()
        },
        Tolerance::EXACT,
    ));
    assert_ok(conformance::check_binary(
        "PointEvaluator<f64>",
        &mut |op, ps| {
            let t = binary_tape(op);
            let mut e = PointEvaluator::<f64>::new(&t);
            ps.iter().map(|&[a, b]| e.eval(&[], a, b, 0.0)).collect()
        },
        Tolerance::EXACT,
    ));
}

#[test]
fn point_evaluator_f32() {
    assert_ok(conformance::check_unary(
        "PointEvaluator<f32>",
        &mut |op, xs| {
            let t = unary_tape(op);
            let mut e = PointEvaluator::<f32>::new(&t);
            xs.iter().map(|&x| e.eval(&[], x as f32, 0.0, 0.0) as f64).collect()
        },
        Tolerance::F32,
    ));
    assert_ok(conformance::check_binary(
        "PointEvaluator<f32>",
        &mut |op, ps| {
            let t = binary_tape(op);
            let mut e = PointEvaluator::<f32>::new(&t);
            ps.iter()
                .map(|&[a, b]| e.eval(&[], a as f32, b as f32, 0.0) as f64)
                .collect()
        },
        Tolerance::F32,
    ));
}

/// Runs a batch evaluator over the points (xs, ys), with z = 0.
fn batch<T: isoray_shape::eval::BatchNum>(t: &Tape, xs: &[T], ys: &[T]) -> Vec<T> {
    let zs = vec![T::from_f64(0.0); xs.len()];
    let mut out = vec![T::from_f64(0.0); xs.len()];
    BatchEvaluator::<T>::new(t).eval(&[], xs, ys, &zs, &mut out);
    out
}

#[test]
fn batch_evaluator_f32() {
    assert_ok(conformance::check_unary(
        "BatchEvaluator<f32>",
        &mut |op, xs| {
            let xs: Vec<f32> = xs.iter().map(|&x| x as f32).collect();
            let ys = vec![0.0; xs.len()];
            batch(&unary_tape(op), &xs, &ys).into_iter().map(f64::from).collect()
        },
        Tolerance::F32,
    ));
    assert_ok(conformance::check_binary(
        "BatchEvaluator<f32>",
        &mut |op, ps| {
            let xs: Vec<f32> = ps.iter().map(|p| p[0] as f32).collect();
            let ys: Vec<f32> = ps.iter().map(|p| p[1] as f32).collect();
            batch(&binary_tape(op), &xs, &ys).into_iter().map(f64::from).collect()
        },
        Tolerance::F32,
    ));
}

#[test]
fn batch_evaluator_f64() {
    assert_ok(conformance::check_unary(
        "BatchEvaluator<f64>",
        &mut |op, xs| batch(&unary_tape(op), xs, &vec![0.0; xs.len()]),
        Tolerance::EXACT,
    ));
    assert_ok(conformance::check_binary(
        "BatchEvaluator<f64>",
        &mut |op, ps| {
            let xs: Vec<f64> = ps.iter().map(|p| p[0]).collect();
            let ys: Vec<f64> = ps.iter().map(|p| p[1]).collect();
            batch(&binary_tape(op), &xs, &ys)
        },
        Tolerance::EXACT,
    ));
}

fn seeds(x: f64, y: f64) -> [Dual; 3] {
    [
        Dual::with(x, [1.0, 0.0, 0.0]),
        Dual::with(y, [0.0, 1.0, 0.0]),
        Dual::with(0.0, [0.0, 0.0, 1.0]),
    ]
}

/// The dual evaluator's derivatives against the symbolic derivative of
/// `n` (∂/∂x, ∂/∂y, ∂/∂z, each its own tape) at (x, y, 0).
fn compare_derivatives(
    b: &mut Builder,
    n: Node,
    name: &'static str,
    points: &[[f64; 2]],
    bad: &mut Vec<Mismatch>,
) -> usize {
    let t = b.tape(n);
    let grads: Vec<Tape> = (0..3)
        .map(|v| {
            let d = b.derivative(n, v);
            b.tape(d)
        })
        .collect();
    let mut dual = PointEvaluator::<Dual>::new(&t);
    let mut sym: Vec<PointEvaluator<f64>> = grads.iter().map(PointEvaluator::new).collect();
    for &[x, y] in points {
        let [dx, dy, dz] = seeds(x, y);
        let d = dual.eval(&[], dx, dy, dz).d;
        for v in 0..3 {
            let s = sym[v].eval(&[], x, y, 0.0);
            if !Tolerance::DERIVATIVE.agrees(s, d[v], false) {
                bad.push(Mismatch {
                    evaluator: "Dual".into(),
                    op: name,
                    args: vec![x, y],
                    want: s,
                    got: vec![d[v]],
                    what: format!("∂/∂{} (want: Builder::derivative)", ["x", "y", "z"][v]),
                });
            }
        }
    }
    points.len()
}

#[test]
fn dual_numbers_values_and_derivatives() {
    assert_ok(conformance::check_unary(
        "Dual (value)",
        &mut |op, xs| {
            let t = unary_tape(op);
            let mut e = PointEvaluator::<Dual>::new(&t);
            xs.iter()
                .map(|&x| {
                    let [a, b, c] = seeds(x, 0.0);
                    e.eval(&[], a, b, c).v
                })
                .collect()
        },
        Tolerance::EXACT,
    ));
    assert_ok(conformance::check_binary(
        "Dual (value)",
        &mut |op, ps| {
            let t = binary_tape(op);
            let mut e = PointEvaluator::<Dual>::new(&t);
            ps.iter()
                .map(|&[x, y]| {
                    let [a, b, c] = seeds(x, y);
                    e.eval(&[], a, b, c).v
                })
                .collect()
        },
        Tolerance::EXACT,
    ));
    let mut bad = Vec::new();
    let mut compared = 0;
    for &op in UNARY {
        let pts: Vec<[f64; 2]> = unary_args()
            .into_iter()
            .filter(|&x| unary_differentiable(op, x))
            .map(|x| [x, 0.0])
            .collect();
        let mut b = Builder::new();
        let x = b.x();
        let n = b.unary(op, x);
        compared += compare_derivatives(&mut b, n, unary_info(op).name, &pts, &mut bad);
    }
    for &op in BINARY {
        let pts: Vec<[f64; 2]> = binary_args()
            .into_iter()
            .filter(|&[a, c]| binary_differentiable(op, a, c))
            .collect();
        let mut b = Builder::new();
        let (x, y) = (b.x(), b.y());
        let n = b.binary(op, x, y);
        compared += compare_derivatives(&mut b, n, binary_info(op).name, &pts, &mut bad);
    }
    assert!(compared > 5000, "{compared}");
    assert_ok(if bad.is_empty() { Ok(()) } else { Err(bad) });
}

/// min and max take the derivative of the operand they return, NaN operands
/// included (which the value ignores), and of `a` on ties.
#[test]
fn dual_min_max_follow_the_operand_they_return() {
    for op in [BinOp::Min, BinOp::Max] {
        let t = binary_tape(op);
        let mut e = PointEvaluator::<Dual>::new(&t);
        for [x, y] in binary_args() {
            let [a, b, c] = seeds(x, y);
            let r = e.eval(&[], a, b, c);
            let v = apply_binary(op, x, y);
            if x.is_nan() && y.is_nan() {
                continue;
            }
            let from_a = v.to_bits() == x.to_bits() || (v == x && v == y);
            let want = if from_a { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
            assert_eq!(r.d, want, "{op:?}({x}, {y}) = {v}");
        }
    }
}

#[test]
fn interval_arithmetic_contains_every_value() {
    assert_ok(conformance::check_unary_intervals(
        "eval_interval",
        &mut |op, boxes| {
            let t = unary_tape(op);
            boxes
                .iter()
                .map(|&(lo, hi)| {
                    let r = eval_interval(
                        &t,
                        &[],
                        Interval::new(lo, hi),
                        Interval::point(0.0),
                        Interval::point(0.0),
                    );
                    (r.lo, r.hi)
                })
                .collect()
        },
        Containment::RIGOROUS,
    ));
    assert_ok(conformance::check_binary_intervals(
        "eval_interval",
        &mut |op, boxes| {
            let t = binary_tape(op);
            boxes
                .iter()
                .map(|&[(al, ah), (bl, bh)]| {
                    let r = eval_interval(
                        &t,
                        &[],
                        Interval::new(al, ah),
                        Interval::new(bl, bh),
                        Interval::point(0.0),
                    );
                    (r.lo, r.hi)
                })
                .collect()
        },
        Containment::RIGOROUS,
    ));
}

/// The interval rules of the Lipschitz bound for the node `n` of `src`, over
/// the box x ∈ [X, Y], y ∈ [Z, input 1] of the destination's coordinates:
/// the tapes of the low and high ends.
fn dag_interval(src: &Builder, n: Node) -> (Tape, Tape) {
    let mut dst = Builder::new();
    let (x, y, z, w) = (dst.x(), dst.y(), dst.z(), dst.input(1));
    let zero = dst.constant(0.0);
    let (lo, hi) = interval_extension(src, n, &mut dst, [(x, y), (z, w), (zero, zero)]);
    (dst.tape(lo), dst.tape(hi))
}

fn run_dag(ends: &(Tape, Tape), boxes: &[[(f64, f64); 2]]) -> Vec<(f64, f64)> {
    let mut lo = PointEvaluator::<f64>::new(&ends.0);
    let mut hi = PointEvaluator::<f64>::new(&ends.1);
    boxes
        .iter()
        .map(|&[(al, ah), (bl, bh)]| {
            let vars = [0.0, bh];
            (lo.eval(&vars, al, ah, bl), hi.eval(&vars, al, ah, bl))
        })
        .collect()
}

#[test]
fn lipschitz_interval_rules_contain_every_value() {
    assert_ok(conformance::check_unary_intervals(
        "lipschitz interval rules",
        &mut |op, boxes| {
            let mut src = Builder::new();
            let x = src.x();
            let n = src.unary(op, x);
            let ends = dag_interval(&src, n);
            let boxes: Vec<_> = boxes.iter().map(|&b| [b, (0.0, 0.0)]).collect();
            run_dag(&ends, &boxes)
        },
        Containment::dag(BIG),
    ));
    assert_ok(conformance::check_binary_intervals(
        "lipschitz interval rules",
        &mut |op, boxes| {
            let mut src = Builder::new();
            let (x, y) = (src.x(), src.y());
            let n = src.binary(op, x, y);
            run_dag(&dag_interval(&src, n), boxes)
        },
        Containment::dag(BIG),
    ));
}

/// x^k for a constant k has its own rule (the exponent is known).
#[test]
fn lipschitz_power_rule_contains_every_value() {
    let exponents: Vec<f64> = conformance::binary_values()
        .into_iter()
        .chain([-1.0, -2.0, -0.5, 4.0, 5.0, 1.5, -1.5, 0.0])
        .filter(|k| k.is_finite())
        .collect();
    let mut bad = Vec::new();
    for k in exponents {
        let mut src = Builder::new();
        let x = src.x();
        let kc = src.constant(k);
        let n = src.binary(BinOp::Pow, x, kc);
        let ends = dag_interval(&src, n);
        let r = conformance::check_function_intervals(
            &format!("lipschitz x^{k} rule"),
            "pow(x, k)",
            &|x| x.powf(k),
            &mut |boxes| {
                let boxes: Vec<_> = boxes.iter().map(|&b| [b, (0.0, 0.0)]).collect();
                run_dag(&ends, &boxes)
            },
            Containment::dag(BIG),
        );
        bad.extend(r.err().unwrap_or_default());
    }
    assert_ok(if bad.is_empty() { Ok(()) } else { Err(bad) });
}

/// The same operation with its arguments as inputs (computed by the
/// prologue), as coordinates, one of each, and as constants (folded by the
/// builder) gives the same bits; in f32, the prologue's value is the f64
/// reference rounded once.
#[test]
fn inputs_coordinates_and_constant_folding_agree() {
    // Bit for bit, but min/max of ±0 may return either (the builder orders
    // the operands of commutative operations).
    let same = |op: &str, a: f64, b: f64| {
        a.to_bits() == b.to_bits()
            || (a.is_nan() && b.is_nan())
            || (a == 0.0 && b == 0.0 && (op == "min" || op == "max"))
    };
    let mut bad = Vec::new();
    let mut check = |what: &str, op: &str, args: &[f64], want: f64, got: f64| {
        if !same(op, want, got) {
            bad.push(format!("{what}: {op}{args:?} = {got:?}, want {want:?}"));
        }
    };
    for &op in UNARY {
        let name = unary_info(op).name;
        let mut b = Builder::new();
        let v = b.input(1);
        let n = b.unary(op, v);
        let t = b.tape(n);
        assert!(t.is_empty() && t.reads(1), "{name}: a value of the inputs alone");
        let mut pe = PointEvaluator::<f64>::new(&t);
        let mut pf = PointEvaluator::<f32>::new(&t);
        let mut be = BatchEvaluator::<f32>::new(&t);
        let xs = vec![0.0f32; LANES + 3];
        let mut out = vec![0.0f32; xs.len()];
        for x in unary_args() {
            let want = apply_unary(op, x);
            let vars = [0.0, x];
            check("prologue f64", name, &[x], want, pe.eval(&vars, 0.0, 0.0, 0.0));
            check(
                "prologue f32",
                name,
                &[x],
                want as f32 as f64,
                pf.eval(&vars, 0.0, 0.0, 0.0) as f64,
            );
            be.eval(&vars, &xs, &xs, &xs, &mut out);
            for &o in &out {
                check("prologue batch f32", name, &[x], want as f32 as f64, o as f64);
            }
            check("uniform_value", name, &[x], want, b.uniform_value(n, &vars).unwrap());
            let mut fb = Builder::new();
            let c = fb.constant(x);
            let folded = fb.unary(op, c);
            check("constant folding", name, &[x], want, fb.const_value(folded).unwrap());
            let ct = unary_tape(op);
            check(
                "coordinates",
                name,
                &[x],
                want,
                PointEvaluator::<f64>::new(&ct).eval(&[], x, 0.0, 0.0),
            );
        }
    }
    for &op in BINARY {
        let name = binary_info(op).name;
        let mut b = Builder::new();
        let (x, y, u, v) = (b.x(), b.y(), b.input(1), b.input(2));
        let both = b.binary(op, u, v);
        let left = b.binary(op, u, y);
        let right = b.binary(op, x, v);
        let tapes = [b.tape(both), b.tape(left), b.tape(right)];
        assert!(tapes[0].is_empty() && tapes[0].vars() == [1, 2], "{name}");
        let mut es: Vec<PointEvaluator<f64>> = tapes.iter().map(PointEvaluator::new).collect();
        let mut pf = PointEvaluator::<f32>::new(&tapes[0]);
        let ct = binary_tape(op);
        let mut coords = PointEvaluator::<f64>::new(&ct);
        for [p, q] in binary_args() {
            let want = apply_binary(op, p, q);
            let vars = [0.0, p, q];
            check("prologue f64", name, &[p, q], want, es[0].eval(&vars, 0.0, 0.0, 0.0));
            check("input, coordinate", name, &[p, q], want, es[1].eval(&vars, 0.0, q, 0.0));
            check("coordinate, input", name, &[p, q], want, es[2].eval(&vars, p, 0.0, 0.0));
            check("coordinates", name, &[p, q], want, coords.eval(&[], p, q, 0.0));
            check(
                "prologue f32",
                name,
                &[p, q],
                want as f32 as f64,
                pf.eval(&vars, 0.0, 0.0, 0.0) as f64,
            );
            let mut fb = Builder::new();
            let (cp, cq) = (fb.constant(p), fb.constant(q));
            let folded = fb.binary(op, cp, cq);
            check("constant folding", name, &[p, q], want, fb.const_value(folded).unwrap());
        }
    }
    assert!(
        bad.is_empty(),
        "{} mismatches:\n{}",
        bad.len(),
        bad[..bad.len().min(40)].join("\n")
    );
}

/// With one constant operand the builder applies algebraic identities
/// (x + 0 → x, x · 1 → x, x / 4 → x · 0.25, pow(x, 2) → x², …): they must
/// agree with the reference up to the documented exceptions (the sign of a
/// zero, pow(x, ½) → √x at −∞ and −0, pow(x, 2) → x² within an ulp).
#[test]
fn builder_identities_with_one_constant_operand() {
    let vals = conformance::binary_values();
    let mut bad = Vec::new();
    for &op in BINARY {
        let name = binary_info(op).name;
        for &k in &vals {
            for const_first in [false, true] {
                let mut b = Builder::new();
                let (x, c) = (b.x(), b.constant(k));
                let n = if const_first {
                    b.binary(op, c, x)
                } else {
                    b.binary(op, x, c)
                };
                let t = b.tape(n);
                let mut e = PointEvaluator::<f64>::new(&t);
                for &v in &vals {
                    let (p, q) = if const_first { (k, v) } else { (v, k) };
                    let want = apply_binary(op, p, q);
                    let got = e.eval(&[], v, 0.0, 0.0);
                    let sqrt_rule = op == BinOp::Pow && q == 0.5 && (p == f64::NEG_INFINITY || p == 0.0);
                    let tol = if op == BinOp::Pow && q == 2.0 {
                        Tolerance {
                            rel: f64::EPSILON,
                            ..Tolerance::EXACT
                        }
                    } else {
                        Tolerance::EXACT
                    };
                    // Identities hold up to the sign of zero: compare zeros unsigned.
                    if !sqrt_rule && !tol.agrees(want, got, false) {
                        bad.push(format!("{name}({p:?}, {q:?}) = {got:?}, want {want:?}"));
                    }
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "{} mismatches:\n{}",
        bad.len(),
        bad[..bad.len().min(40)].join("\n")
    );
}

/// The suite has teeth: plausible but wrong evaluators fail it.
#[test]
fn wrong_evaluators_are_caught() {
    // neg as 0 − x (wrong sign of zero), round as floor(x + 0.5).
    let r = conformance::check_unary(
        "wrong",
        &mut |op, xs| {
            xs.iter()
                .map(|&x| match op {
                    UnOp::Neg => 0.0 - x,
                    UnOp::Round => (x + 0.5).floor(),
                    _ => apply_unary(op, x),
                })
                .collect()
        },
        Tolerance::EXACT,
    );
    let bad = r.unwrap_err();
    assert!(bad.iter().any(|m| m.op == "neg" && m.args[0] == 0.0));
    assert!(bad.iter().any(|m| m.op == "round" && m.args[0] == 0.49999999999999994));
    // An f32 evaluator that computes in f64 and rounds only at the end is
    // caught where f32 overflows in the middle (x·y / y).
    let r = conformance::check_binary(
        "wrong f32",
        &mut |op, ps| {
            ps.iter()
                .map(|&[a, b]| match op {
                    BinOp::Mul => (a * b * 1.0000001) as f32 as f64,
                    _ => apply_binary(op, a as f32, b as f32) as f64,
                })
                .collect()
        },
        Tolerance::F32,
    );
    assert!(r.unwrap_err().iter().all(|m| m.op == "mul"));
    // An interval rule that forgets a crest.
    let r = conformance::check_unary_intervals(
        "wrong intervals",
        &mut |op, boxes| {
            boxes
                .iter()
                .map(|&(lo, hi)| match op {
                    UnOp::Sin => {
                        let (a, b) = (lo.sin(), hi.sin());
                        (a.min(b), a.max(b))
                    }
                    _ => (f64::NEG_INFINITY, f64::INFINITY),
                })
                .collect()
        },
        Containment::RIGOROUS,
    );
    assert!(r.unwrap_err().iter().all(|m| m.op == "sin"));
}
