//! Polynomial equations as distance bounds.
//!
//! An implicit equation that turns out to be a polynomial in (x, y, z) is
//! traced through a *guaranteed* bound rather than the first-order estimate
//! f / |∇f|: at a point p, with the Taylor coefficients c_α(p) = ∂^α f(p) / α!,
//!
//! ```text
//! |f(p + δu)| ≥ |f(p)| − Σ_k M_k δ^k,   M_k = sqrt( Σ_{|α|=k} c_α(p)² · α!/k! )
//! ```
//!
//! for every unit vector u (Cauchy–Schwarz against the multinomial expansion
//! of (u·u)^k = 1), so no zero of f lies closer than the smallest positive
//! root δ* of Σ M_k δ^k = |f(p)|. M_1 = |∇f(p)|, so near a regular point δ*
//! is the first-order estimate; near singular points and far away it is
//! smaller, as it must be. This module converts shape DAGs to rational
//! functions, takes the square-free part (for f = g^k, f/|∇f| is the
//! distance divided by k), and writes δ* into the DAG as a lower bound that
//! is refined by Newton (upper) and chord (lower) steps of the convex
//! polynomial Σ M_k δ^k.

use std::collections::HashMap;

use isoray_algebra::gcd::squarefree;
use isoray_algebra::{Budget, GroebnerOptions, Int, Monomial, MonomialOrder, Poly, Rat, RatFunc, Ring};
use num_traits::{One, ToPrimitive};

use crate::ir::{BinOp, Builder, Node, Op, UnOp};

/// The largest integer exponent expanded when converting `a ^ k`.
const MAX_POWER: f64 = 64.0;

/// The largest degree a converted expression may reach.
pub const MAX_CONVERT_DEGREE: i64 = 32;

/// The most terms a product may have while converting (bounds time and memory:
/// exact rational arithmetic on larger expansions takes seconds).
const MAX_CONVERT_TERMS: usize = 3_000;

/// The most monomials a polynomial of degree d in three variables can have.
pub fn dense_terms(d: i64) -> usize {
    let d = d.max(0) as usize;
    (d + 1) * (d + 2) * (d + 3) / 6
}

/// Newton/chord refinements of the Taylor-root bound.
const ROOT_REFINEMENTS: usize = 2;

/// The Taylor-root bound never exceeds this (keeps the refinement finite).
pub const TAYLOR_CAP: f64 = 1e6;

/// The rational number a constant stands for: the simplest fraction within
/// a few units in the last place of `v` when one has a small denominator
/// (so 1.16 − 1 ulp, from folding `R^2 - r^2` with R = 1, r = 0.4, becomes
/// 29/25), else the exact value of the shortest decimal that round-trips to
/// `v` (so `0.1` becomes 1/10, not the binary fraction nearest to it).
pub fn rat_from_f64(v: f64) -> Option<Rat> {
    if !v.is_finite() {
        return None;
    }
    if let Some(r) = simple_fraction(v) {
        return Some(r);
    }
    let text = format!("{v}");
    let (neg, digits) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text.as_str()),
    };
    let (int_part, frac_part) = digits.split_once('.').unwrap_or((digits, ""));
    let num: Int = format!("{int_part}{frac_part}").parse().ok()?;
    let den = num_traits::pow(Int::from(10), frac_part.len());
    let r = Rat::new(num, den);
    Some(if neg { -r } else { r })
}

/// The first continued-fraction convergent p/q of `v` with q ≤ 10⁶ that is
/// within 4 ulp of it.
fn simple_fraction(v: f64) -> Option<Rat> {
    let tol = 4.0 * f64::EPSILON * v.abs().max(f64::MIN_POSITIVE);
    let (mut p0, mut q0, mut p1, mut q1) = (0i128, 1i128, 1i128, 0i128);
    let mut x = v.abs();
    for _ in 0..40 {
        let a = x.floor();
        if a > 1e12 {
            return None;
        }
        let a = a as i128;
        let (p2, q2) = (a * p1 + p0, a * q1 + q0);
        if q2 > 1_000_000 {
            return None;
        }
        if ((p2 as f64) / (q2 as f64) - v.abs()).abs() <= tol {
            let r = Rat::new(Int::from(p2), Int::from(q2));
            return Some(if v < 0.0 { -r } else { r });
        }
        (p0, q0, p1, q1) = (p1, q1, p2, q2);
        let frac = x - a as f64;
        if frac == 0.0 {
            return None;
        }
        x = 1.0 / frac;
    }
    None
}

/// Converts a DAG node to a rational function in `ring`, mapping the point
/// coordinates X, Y, Z to the ring variables `vars` (None: the coordinate may
/// not appear). Fails with the name of the first operation that is not
/// rational (`sin`, `sqrt`, `min`, a non-integer power, …).
pub fn to_rational(b: &Builder, root: Node, vars: [Option<usize>; 3], ring: &Ring) -> Result<RatFunc, String> {
    let mut memo: HashMap<Node, RatFunc> = HashMap::new();
    convert(b, root, vars, ring, &mut memo)
}

fn constant(ring: &Ring, c: Rat) -> RatFunc {
    RatFunc {
        num: Poly::constant(ring, c),
        den: Poly::constant(ring, Rat::one()),
    }
}

/// Folds a constant denominator into the numerator.
fn normalize(ring: &Ring, f: RatFunc) -> RatFunc {
    if f.den.is_constant() {
        let c = f.den.lc().cloned().unwrap_or_else(Rat::one);
        if !c.is_one() {
            return RatFunc {
                num: f.num.scale(&(Rat::one() / c)),
                den: Poly::constant(ring, Rat::one()),
            };
        }
    }
    f
}

fn rf_add(ring: &Ring, a: &RatFunc, c: &RatFunc, sub: bool) -> Result<RatFunc, String> {
    let minus = |p: &Poly<Rat>| if sub { p.neg() } else { p.clone() };
    if a.den == c.den {
        return Ok(RatFunc {
            num: a.num.add(ring, &minus(&c.num)),
            den: a.den.clone(),
        });
    }
    let deg = (a.num.degree() + c.den.degree()).max(a.den.degree() + c.den.degree());
    check_size(
        deg,
        (a.num.len() * c.den.len())
            .max(a.den.len() * c.den.len())
            .min(dense_terms(deg)),
    )?;
    Ok(RatFunc {
        num: a.num.mul(ring, &c.den).add(ring, &minus(&c.num.mul(ring, &a.den))),
        den: a.den.mul(ring, &c.den),
    })
}

/// Refuses products that would be too large to expand.
fn check_size(deg: i64, terms: usize) -> Result<(), String> {
    if deg > MAX_CONVERT_DEGREE {
        return Err(format!(
            "an expression of degree {deg} (more than {MAX_CONVERT_DEGREE}, too large to expand)"
        ));
    }
    if terms > MAX_CONVERT_TERMS {
        return Err(format!("an expression too large to expand (about {terms} terms)"));
    }
    Ok(())
}

fn rf_mul(ring: &Ring, a: &RatFunc, c: &RatFunc) -> Result<RatFunc, String> {
    let deg = (a.num.degree() + c.num.degree()).max(a.den.degree() + c.den.degree());
    check_size(
        deg,
        (a.num.len() * c.num.len())
            .max(a.den.len() * c.den.len())
            .min(dense_terms(deg)),
    )?;
    Ok(normalize(
        ring,
        RatFunc {
            num: a.num.mul(ring, &c.num),
            den: a.den.mul(ring, &c.den),
        },
    ))
}

fn rf_inv(ring: &Ring, a: &RatFunc) -> Result<RatFunc, String> {
    if a.num.is_zero() {
        return Err("division by zero".into());
    }
    Ok(normalize(
        ring,
        RatFunc {
            num: a.den.clone(),
            den: a.num.clone(),
        },
    ))
}

fn rf_pow(ring: &Ring, a: &RatFunc, k: i64) -> Result<RatFunc, String> {
    let base = if k < 0 { rf_inv(ring, a)? } else { a.clone() };
    let e = k.unsigned_abs() as u32;
    let deg = base.num.degree().max(base.den.degree()) * e as i64;
    let terms = base
        .num
        .len()
        .max(base.den.len())
        .saturating_pow(e.min(16))
        .min(dense_terms(deg.min(1 << 20)));
    check_size(deg, terms)?;
    Ok(RatFunc {
        num: base.num.pow(ring, e),
        den: base.den.pow(ring, e),
    })
}

fn convert(
    b: &Builder,
    n: Node,
    vars: [Option<usize>; 3],
    ring: &Ring,
    memo: &mut HashMap<Node, RatFunc>,
) -> Result<RatFunc, String> {
    if let Some(r) = memo.get(&n) {
        return Ok(r.clone());
    }
    let var = |i: usize| -> Result<RatFunc, String> {
        let name = ["x", "y", "z"][i];
        let v = vars[i].ok_or_else(|| format!("the coordinate `{name}`"))?;
        Ok(RatFunc {
            num: Poly::monomial(Monomial::var(ring.nvars(), v, 1), Rat::one()),
            den: Poly::constant(ring, Rat::one()),
        })
    };
    let r = match b.op(n) {
        Op::Const(v) => constant(ring, rat_from_f64(v).ok_or_else(|| format!("the constant {v}"))?),
        Op::Input(_) => return Err("a runtime input (a parameter or the time)".to_string()),
        Op::X => var(0)?,
        Op::Y => var(1)?,
        Op::Z => var(2)?,
        Op::Unary(op, a) => {
            let a = convert(b, a, vars, ring, memo)?;
            match op {
                UnOp::Neg => RatFunc {
                    num: a.num.neg(),
                    den: a.den,
                },
                UnOp::Square => rf_mul(ring, &a, &a)?,
                other => return Err(unary_name(other).to_string()),
            }
        }
        Op::Binary(op, x, y) => {
            if op == BinOp::Pow {
                let k = b
                    .const_value(y)
                    .filter(|k| k.fract() == 0.0 && k.abs() <= MAX_POWER)
                    .ok_or_else(|| "a power with a non-integer or non-constant exponent".to_string())?;
                let base = convert(b, x, vars, ring, memo)?;
                rf_pow(ring, &base, k as i64)?
            } else {
                let (p, q) = (convert(b, x, vars, ring, memo)?, convert(b, y, vars, ring, memo)?);
                match op {
                    BinOp::Add => rf_add(ring, &p, &q, false)?,
                    BinOp::Sub => rf_add(ring, &p, &q, true)?,
                    BinOp::Mul => rf_mul(ring, &p, &q)?,
                    BinOp::Div => rf_mul(ring, &p, &rf_inv(ring, &q)?)?,
                    BinOp::Min => return Err("min".into()),
                    BinOp::Max => return Err("max".into()),
                    BinOp::Atan2 => return Err("atan2".into()),
                    BinOp::Pow => unreachable!("handled above"),
                }
            }
        }
        Op::Select(..) => return Err("a conditional (select)".into()),
    };
    memo.insert(n, r.clone());
    Ok(r)
}

/// The name a user writes for a unary operation.
fn unary_name(op: UnOp) -> &'static str {
    match op {
        UnOp::Neg => "negation",
        UnOp::Abs => "abs",
        UnOp::Sqrt => "sqrt",
        UnOp::Square => "square",
        UnOp::Sin => "sin",
        UnOp::Cos => "cos",
        UnOp::Tan => "tan",
        UnOp::Asin => "asin",
        UnOp::Acos => "acos",
        UnOp::Atan => "atan",
        UnOp::Exp => "exp",
        UnOp::Ln => "log",
        UnOp::Floor => "floor",
        UnOp::Round => "round",
        UnOp::Sign => "sign",
    }
}

/// The ring Q[x, y, z] (grevlex) in which surface equations live.
pub fn xyz_ring() -> Ring {
    Ring::new(&["x", "y", "z"], MonomialOrder::DegRevLex)
}

/// The square-free part of a polynomial and the largest multiplicity removed.
#[derive(Debug, Clone)]
pub struct SquareFree {
    /// The square-free part, monic.
    pub poly: Poly<Rat>,
    /// True when f had a repeated factor (so the square-free part differs from f).
    pub reduced: bool,
}

/// The Mersenne prime 2⁶¹ − 1, for the modular square-free test.
const P61: u64 = (1 << 61) - 1;

fn mulm(a: u64, b: u64) -> u64 {
    ((a as u128 * b as u128) % P61 as u128) as u64
}

fn powm(mut a: u64, mut e: u64) -> u64 {
    let mut r = 1;
    while e > 0 {
        if e & 1 == 1 {
            r = mulm(r, a);
        }
        a = mulm(a, a);
        e >>= 1;
    }
    r
}

fn rat_mod(c: &Rat) -> Option<u64> {
    let p = Int::from(P61);
    let n = ((c.numer() % &p + &p) % &p).to_u64()?;
    let d = ((c.denom() % &p + &p) % &p).to_u64()?;
    (d != 0).then(|| mulm(n, powm(d, P61 - 2)))
}

/// Dense univariate polynomial mod P61: remainder of a by b (b's leading coefficient nonzero).
fn rem_mod(mut a: Vec<u64>, b: &[u64]) -> Vec<u64> {
    let inv = powm(*b.last().expect("nonzero"), P61 - 2);
    while a.len() >= b.len() {
        let q = mulm(*a.last().expect("nonempty"), inv);
        let shift = a.len() - b.len();
        for (i, &bi) in b.iter().enumerate() {
            a[shift + i] = (a[shift + i] + P61 - mulm(q, bi)) % P61;
        }
        a.pop();
        while a.last() == Some(&0) {
            a.pop();
        }
    }
    a
}

/// True when `f` has no repeated factor, decided quickly with probability ≈ 1:
/// a repeated factor g² of f, with g involving the variable v, stays a
/// repeated factor of f restricted to a random line parallel to the v axis,
/// which a univariate gcd with the derivative modulo a large prime detects.
/// False means "maybe not square-free".
pub fn probably_squarefree(f: &Poly<Rat>) -> bool {
    let nv = f.terms().first().map(|(m, _)| m.nvars()).unwrap_or(0);
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    for v in 0..nv {
        let deg = f.terms().iter().map(|(m, _)| m.exp(v)).max().unwrap_or(0) as usize;
        if deg == 0 {
            continue;
        }
        let point: Vec<u64> = (0..nv)
            .map(|_| {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                seed % P61
            })
            .collect();
        let mut u = vec![0u64; deg + 1];
        for (m, c) in f.terms() {
            let Some(mut t) = rat_mod(c) else { return false };
            for (w, &x) in point.iter().enumerate() {
                if w != v {
                    t = mulm(t, powm(x, m.exp(w) as u64));
                }
            }
            let k = m.exp(v) as usize;
            u[k] = (u[k] + t) % P61;
        }
        while u.last() == Some(&0) {
            u.pop();
        }
        if u.len() < 2 {
            return false; // degenerate restriction: no conclusion
        }
        let mut du: Vec<u64> = (1..u.len()).map(|k| mulm(u[k], k as u64 % P61)).collect();
        while du.last() == Some(&0) {
            du.pop();
        }
        // gcd(u, u') by Euclid.
        let (mut a, mut b) = (u, du);
        while !b.is_empty() {
            let r = rem_mod(a, &b);
            a = b;
            b = r;
        }
        if a.len() > 1 {
            return false;
        }
    }
    true
}

/// The square-free part of `f` within `time`; on a timeout, `f` itself.
pub fn squarefree_part(ring: &Ring, f: &Poly<Rat>, time: std::time::Duration) -> SquareFree {
    if probably_squarefree(f) {
        return SquareFree {
            poly: f.monic(),
            reduced: false,
        };
    }
    let opts = GroebnerOptions {
        budget: Budget {
            time: Some(time),
            ..Default::default()
        },
        ..Default::default()
    };
    match squarefree(ring, f, &opts) {
        Ok(g) => {
            let reduced = g.degree() < f.degree();
            SquareFree { poly: g, reduced }
        }
        Err(_) => SquareFree {
            poly: f.clone(),
            reduced: false,
        },
    }
}

/// A polynomial in (x, y, z) with f64 coefficients, as (exponents, coefficient).
type FloatPoly = Vec<([u16; 3], f64)>;

/// The Taylor coefficients c_α = ∂^α f / α! for 1 ≤ |α| ≤ deg f, grouped by |α|,
/// each with its weight α!/|α|!.
fn taylor_coefficients(ring: &Ring, f: &Poly<Rat>) -> Vec<Vec<(FloatPoly, f64)>> {
    let n = f.degree().max(0) as usize;
    let mut by_alpha: HashMap<[u16; 3], Poly<Rat>> = HashMap::new();
    by_alpha.insert([0, 0, 0], f.clone());
    let mut levels: Vec<Vec<[u16; 3]>> = vec![vec![[0, 0, 0]]];
    for k in 1..=n {
        let mut level = Vec::new();
        for alpha in &levels[k - 1] {
            for i in 0..3 {
                let mut beta = *alpha;
                beta[i] += 1;
                if by_alpha.contains_key(&beta) {
                    continue;
                }
                let d = by_alpha[alpha].derivative(ring, i);
                let d = d.scale(&Rat::new(Int::one(), Int::from(beta[i])));
                by_alpha.insert(beta, d);
                level.push(beta);
            }
        }
        levels.push(level);
    }
    let fact = |m: u16| (1..=m as u32).map(f64::from).product::<f64>();
    levels
        .iter()
        .enumerate()
        .skip(1)
        .map(|(k, level)| {
            level
                .iter()
                .filter(|a| !by_alpha[*a].is_zero())
                .map(|a| {
                    let w = fact(a[0]) * fact(a[1]) * fact(a[2]) / fact(k as u16);
                    (to_float(&by_alpha[a]), w)
                })
                .collect()
        })
        .collect()
}

fn to_float(p: &Poly<Rat>) -> FloatPoly {
    p.terms()
        .iter()
        .map(|(m, c)| ([m.exp(0), m.exp(1), m.exp(2)], c.to_f64().unwrap_or(f64::NAN)))
        .collect()
}

/// Writes a float polynomial at the point `p` into the DAG, sharing powers.
fn build_poly(b: &mut Builder, f: &FloatPoly, p: [Node; 3], powers: &mut HashMap<(usize, u16), Node>) -> Node {
    let mut acc: Option<Node> = None;
    for (e, c) in f {
        let mut term: Option<Node> = None;
        for (i, &ei) in e.iter().enumerate() {
            if ei == 0 {
                continue;
            }
            let pw = power(b, p[i], i, ei, powers);
            term = Some(match term {
                None => pw,
                Some(t) => b.mul(t, pw),
            });
        }
        let node = match term {
            None => b.constant(*c),
            Some(t) if *c == 1.0 => t,
            Some(t) => b.mul_c(t, *c),
        };
        acc = Some(match acc {
            None => node,
            Some(a) => b.add(a, node),
        });
    }
    acc.unwrap_or_else(|| b.constant(0.0))
}

fn power(b: &mut Builder, x: Node, i: usize, e: u16, powers: &mut HashMap<(usize, u16), Node>) -> Node {
    if e == 1 {
        return x;
    }
    if let Some(&n) = powers.get(&(i, e)) {
        return n;
    }
    let half = power(b, x, i, e / 2, powers);
    let mut n = b.square(half);
    if e % 2 == 1 {
        n = b.mul(n, x);
    }
    powers.insert((i, e), n);
    n
}

/// Writes the polynomial `f` (in Q[x, y, z]) at the point `p` into the DAG.
pub fn build_equation(b: &mut Builder, f: &Poly<Rat>, p: [Node; 3]) -> Node {
    build_poly(b, &to_float(f), p, &mut HashMap::new())
}

/// A polynomial in up to three variables evaluated in f64: its value and
/// the sum of the absolute values of its terms (the scale of rounding errors).
pub fn eval_with_scale(f: &Poly<Rat>, at: &[f64]) -> (f64, f64) {
    let mut v = 0.0;
    let mut scale = 0.0;
    for (m, c) in f.terms() {
        let mut t = c.to_f64().unwrap_or(f64::NAN);
        for (i, &x) in at.iter().enumerate().take(m.nvars()) {
            t *= x.powi(m.exp(i) as i32);
        }
        v += t;
        scale += t.abs();
    }
    (v, scale)
}

/// Σ_k M_k δ^k and its derivative Σ_k k·M_k δ^{k−1} (Horner), for m = [M_1, …, M_n].
fn series(b: &mut Builder, m: &[Node], d: Node) -> (Node, Node) {
    let mut h = b.constant(0.0);
    let mut dh = b.constant(0.0);
    for (i, &mk) in m.iter().enumerate().rev() {
        let t = b.mul(h, d);
        h = b.add(t, mk);
        let dt = b.mul(dh, d);
        let km = b.mul_c(mk, (i + 1) as f64);
        dh = b.add(dt, km);
    }
    (b.mul(h, d), dh)
}

/// The number of Taylor coefficient polynomials the bound of `f` evaluates,
/// and their total number of terms.
pub fn taylor_size(ring: &Ring, f: &Poly<Rat>) -> (usize, usize) {
    let levels = taylor_coefficients(ring, f);
    let polys = levels.iter().map(Vec::len).sum();
    let terms = levels.iter().flatten().map(|(p, _)| p.len()).sum();
    (polys, terms)
}

/// Writes the signed Taylor-root bound of the polynomial `f` (in `ring` =
/// Q[x, y, z]) at the point `p` into the DAG: sign(f(p)) · δ with δ no larger
/// than the distance from p to the zero set of f.
pub fn taylor_bound(b: &mut Builder, ring: &Ring, f: &Poly<Rat>, p: [Node; 3]) -> Node {
    let mut powers = HashMap::new();
    let value = build_poly(b, &to_float(f), p, &mut powers);
    let levels = taylor_coefficients(ring, f);
    // Representable in f32 (renders evaluate in f32).
    let tiny = b.constant(1e-30);
    let mut m = Vec::new();
    for level in &levels {
        let mut acc: Option<Node> = None;
        for (c, w) in level {
            let cn = build_poly(b, c, p, &mut powers);
            let sq = b.square(cn);
            let t = b.mul_c(sq, *w);
            acc = Some(match acc {
                None => t,
                Some(a) => b.add(a, t),
            });
        }
        m.push(match acc {
            None => b.constant(0.0),
            Some(a) => b.sqrt(a),
        });
    }
    let big_f = b.abs(value);
    let terms = m.iter().filter(|&&mk| b.const_value(mk) != Some(0.0)).count().max(1) as f64;
    // δ₀ = min_k (F / (n·M_k))^{1/k}: each term of the series is then ≤ F/n.
    let mut d = b.constant(TAYLOR_CAP);
    for (k, &mk) in m.iter().enumerate() {
        if b.const_value(mk) == Some(0.0) {
            continue;
        }
        let den = b.max(mk, tiny);
        let den = b.mul_c(den, terms);
        let q = b.div(big_f, den);
        let r = if k == 0 {
            q
        } else {
            let e = b.constant(1.0 / (k + 1) as f64);
            b.binary(BinOp::Pow, q, e)
        };
        d = b.min(d, r);
    }
    // Refine: Newton from below overshoots the root of the convex series
    // (an upper bound u); the chord from (δ, g(δ)) to (u, g(u)) lies above
    // the series, so where it reaches F is again a lower bound.
    for _ in 0..ROOT_REFINEMENTS {
        let (g, dg) = series(b, &m, d);
        // Rounding can put δ a hair past the root: then there is nothing to add.
        let gap = b.sub(big_f, g);
        let zero = b.constant(0.0);
        let gap = b.max(gap, zero);
        let slope = b.max(dg, tiny);
        let step = b.div(gap, slope);
        let u = b.add(d, step);
        let (gu, _) = series(b, &m, u);
        let run = b.sub(u, d);
        // By convexity g(u) − g(δ) ≥ g'(δ)·(u − δ); enforcing it keeps the
        // chord step at most the Newton step when the difference rounds to 0.
        let rise = b.sub(gu, g);
        let least = b.mul(run, slope);
        let rise = b.max(rise, least);
        let rise = b.max(rise, tiny);
        let frac = b.div(run, rise);
        let inc = b.mul(gap, frac);
        d = b.add(d, inc);
    }
    let neg = b.neg(d);
    b.select(value, d, neg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::PointEvaluator;
    use isoray_algebra::parse_poly;

    fn bound_at(text: &str, pts: &[[f64; 3]]) -> Vec<f64> {
        let ring = xyz_ring();
        let f = parse_poly(&ring, text).unwrap();
        let mut b = Builder::new();
        let p = [b.x(), b.y(), b.z()];
        let n = taylor_bound(&mut b, &ring, &f, p);
        let tape = b.tape(n);
        let mut e = PointEvaluator::<f64>::new(&tape);
        pts.iter().map(|q| e.eval(&[], q[0], q[1], q[2])).collect()
    }

    #[test]
    fn decimals_are_exact() {
        assert_eq!(rat_from_f64(0.1), Some(Rat::new(1.into(), 10.into())));
        assert_eq!(rat_from_f64(-2.5), Some(Rat::new((-5).into(), 2.into())));
        assert_eq!(rat_from_f64(3.0), Some(Rat::from_integer(3.into())));
        assert_eq!(rat_from_f64(f64::NAN), None);
        // Folded constants come back as the fractions they stand for.
        assert_eq!(rat_from_f64(1.16), Some(Rat::new(29.into(), 25.into())));
        assert_eq!(rat_from_f64(0.7 * 0.7 - 0.3 * 0.3), Some(Rat::new(2.into(), 5.into())));
        assert_eq!(rat_from_f64(1.0 / 3.0), Some(Rat::new(1.into(), 3.into())));
        // Irrational constants keep their decimal value.
        let phi = rat_from_f64(1.618033988749895).unwrap();
        assert!(phi.denom() > &Int::from(1_000_000));
    }

    #[test]
    fn modular_squarefree_test() {
        let ring = xyz_ring();
        let yes = [
            "x^2 + y^2 + z^2 - 1",
            "x^4 - 5x^2 + y^4 - 5y^2 + z^4 - 5z^2 + 10",
            "x*y*z",
            "x - 1",
        ];
        let no = ["(x^2 + y^2 + z^2 - 1)^2", "x^2*y", "(x - y)^3*(z + 1)", "(y + z)^2"];
        for t in yes {
            assert!(probably_squarefree(&parse_poly(&ring, t).unwrap()), "{t}");
        }
        for t in no {
            assert!(!probably_squarefree(&parse_poly(&ring, t).unwrap()), "{t}");
        }
    }

    #[test]
    fn plane_bound_is_the_distance() {
        // A linear polynomial: the bound is exact everywhere.
        let v = bound_at("x + 2y - 2z - 3", &[[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [3.0, 0.0, 0.0]]);
        assert!((v[0] - -1.0).abs() < 1e-12, "{v:?}");
        assert!((v[1] - 0.0).abs() < 1e-12, "{v:?}");
        assert!((v[2] - 0.0).abs() < 1e-12, "{v:?}");
    }

    #[test]
    fn sphere_bound_never_exceeds_the_distance() {
        let pts: Vec<[f64; 3]> = (0..200)
            .map(|i| {
                let t = i as f64 * 0.37;
                let r = 0.05 + 0.03 * i as f64;
                [r * t.cos() * t.sin(), r * (1.3 * t).cos(), r * t.sin() * t.sin()]
            })
            .collect();
        let v = bound_at("x^2 + y^2 + z^2 - 1", &pts);
        for (q, d) in pts.iter().zip(&v) {
            let r = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
            let exact = r - 1.0;
            assert!(d.abs() <= exact.abs() + 1e-12, "at {q:?}: bound {d}, distance {exact}");
            assert_eq!(d.signum(), exact.signum());
            // And it is useful: at least a third of the distance.
            assert!(d.abs() >= exact.abs() / 3.0, "at {q:?}: bound {d}, distance {exact}");
        }
    }
}
