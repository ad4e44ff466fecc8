//! Implicitization by interpolation, for surfaces too large for elimination.
//!
//! For a trial degree d, the implicit polynomial F = Σ c_α x^α (|α| ≤ d) must
//! vanish at every point of the parametrization. Sampling the parametrization
//! at random parameter values modulo a prime p gives a linear system whose
//! nullspace, when one-dimensional, holds F mod p. Several primes are combined
//! by the Chinese remainder theorem and rational reconstruction, and the
//! result is verified over Q exactly: F(x(s,t), …)·(q₁q₂q₃)^d is a polynomial in
//! (s, t) of known bidegree, and it is zero because it vanishes on a grid one
//! larger than that bidegree in each parameter.

use std::sync::Arc;

use isoray_job::{CancelToken, Progress};
use num_integer::Integer;
use num_traits::{One, ToPrimitive, Zero};

use crate::coeff::{is_prime, to_zint, Int, Rat, ZInt};
use crate::implicit::{coordinate_names, parse_parametrization, Implicit, ImplicitError};
use crate::modular::{mod_inverse, rational_reconstruction};
use crate::monomial::{Monomial, MonomialOrder};
use crate::parse::{to_primitive_integer, RatFunc};
use crate::poly::{Poly, Ring};

/// Options of [`implicitize_interpolation`].
#[derive(Clone)]
pub struct InterpolationOptions {
    /// Largest implicit degree tried (degrees 1, 2, … are tried in turn).
    pub max_degree: u32,
    /// Wall-clock limit.
    pub time: Option<std::time::Duration>,
    /// Cancelled to stop (checked once per prime, and while verifying).
    pub interrupt: Option<CancelToken>,
    /// Told how far the computation got (none by default): per trial degree
    /// and prime a stage `interpolation (degree D)` whose units are the
    /// sample points (the rows of the linear system), then the columns of
    /// its elimination; per verification over Q a stage `certificate` whose
    /// units are the points of its grid. `done` never decreases within a
    /// stage and equals `total` when a stage completes (a verification that
    /// fails stops short).
    pub progress: Option<Arc<dyn Progress + Send>>,
    /// A degree to try first (measured, as `--method auto` does, or known):
    /// if its nullspace is not one-dimensional, degrees 1, 2, … follow.
    pub degree_hint: Option<u32>,
}

impl Default for InterpolationOptions {
    fn default() -> Self {
        InterpolationOptions {
            degree_hint: None,
            max_degree: 24,
            time: None,
            interrupt: None,
            progress: None,
        }
    }
}

impl std::fmt::Debug for InterpolationOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("InterpolationOptions")
            .field("max_degree", &self.max_degree)
            .field("time", &self.time)
            .field("interrupt", &self.interrupt)
            .field("progress", &self.progress.is_some())
            .field("degree_hint", &self.degree_hint)
            .finish()
    }
}

/// Exponent vectors of all monomials in `n` variables of total degree ≤ d, in a fixed order.
fn monomials(n: usize, d: u32) -> Vec<Vec<u16>> {
    let mut out = Vec::new();
    let mut cur = vec![0u16; n];
    fn rec(i: usize, left: u32, cur: &mut Vec<u16>, out: &mut Vec<Vec<u16>>) {
        if i == cur.len() {
            out.push(cur.clone());
            return;
        }
        for e in 0..=left {
            cur[i] = e as u16;
            rec(i + 1, left - e, cur, out);
        }
        cur[i] = 0;
    }
    rec(0, d, &mut cur, &mut out);
    out
}

fn mulmod(a: u64, b: u64, p: u64) -> u64 {
    ((a as u128 * b as u128) % p as u128) as u64
}

fn powmod(mut b: u64, mut e: u64, p: u64) -> u64 {
    let mut r = 1 % p;
    while e > 0 {
        if e & 1 == 1 {
            r = mulmod(r, b, p);
        }
        b = mulmod(b, b, p);
        e >>= 1;
    }
    r
}

/// Evaluates a polynomial over Q at integer point values modulo p (None if a denominator vanishes).
fn eval_mod(p: &Poly<Rat>, vals: &[u64], m: u64) -> Option<u64> {
    let mut acc = 0u64;
    let pm = Int::from(m);
    for (mono, c) in p.terms() {
        let num = c.numer().mod_floor(&pm).to_u64()?;
        let den = c.denom().mod_floor(&pm).to_u64()?;
        if den == 0 {
            return None;
        }
        let mut t = mulmod(num, powmod(den, m - 2, m), m);
        for (i, &e) in mono.exps().iter().enumerate() {
            if e > 0 {
                t = mulmod(t, powmod(vals[i], e as u64, m), m);
            }
        }
        acc = (acc + t) % m;
    }
    Some(acc)
}

/// Barrett reduction modulo a prime below 2^31.
#[derive(Clone, Copy)]
struct Barrett {
    p: u64,
    m: u128,
}

impl Barrett {
    fn new(p: u64) -> Self {
        Barrett {
            p,
            m: (1u128 << 64) / p as u128,
        }
    }
    /// a mod p for a < 2^64.
    #[inline(always)]
    fn reduce(&self, a: u64) -> u64 {
        let q = ((a as u128 * self.m) >> 64) as u64;
        let mut r = a - q * self.p;
        while r >= self.p {
            r -= self.p;
        }
        r
    }
}

/// The nullspace of a K×N matrix mod p (p < 2^31, row-major, entries < p)
/// when it is one-dimensional: the vector with its last nonzero entry 1.
/// `Ok(None)` for a trivial nullspace, `Err(dim)` for a larger one.
/// `columns_done(c)` is told after the elimination of each column c + 1.
fn nullspace_1(
    mut a: Vec<u64>,
    k: usize,
    n: usize,
    p: u64,
    columns_done: &dyn Fn(usize),
) -> Result<Option<Vec<u64>>, usize> {
    use rayon::prelude::*;
    let br = Barrett::new(p);
    let mut pivots: Vec<usize> = Vec::new();
    let mut row = 0;
    for col in 0..n {
        if row == k {
            break;
        }
        let Some(r) = (row..k).find(|&r| a[r * n + col] != 0) else {
            columns_done(col + 1);
            continue;
        };
        if r != row {
            for c in col..n {
                a.swap(row * n + c, r * n + c);
            }
        }
        let inv = powmod(a[row * n + col], p - 2, p);
        for x in a[row * n + col..(row + 1) * n].iter_mut() {
            *x = br.reduce(*x * inv);
        }
        // Forward elimination of the rows below, in parallel.
        let (top, rest) = a.split_at_mut((row + 1) * n);
        let prow = &top[row * n + col..(row + 1) * n];
        rest.par_chunks_mut(n).for_each(|other| {
            let f = other[col];
            if f != 0 {
                for (x, y) in other[col..].iter_mut().zip(prow) {
                    // x − f·y mod p, kept in 0..p: p² < 2^62 keeps the sum positive.
                    *x = br.reduce(*x + p * p - f * y);
                }
            }
        });
        pivots.push(col);
        row += 1;
        columns_done(col + 1);
    }
    let free: Vec<usize> = (0..n).filter(|c| pivots.binary_search(c).is_err()).collect();
    match free.len() {
        0 => Ok(None),
        1 => {
            // Back substitution with the free variable set to 1.
            let f = free[0];
            let mut v = vec![0u64; n];
            v[f] = 1;
            for (r, &c) in pivots.iter().enumerate().rev() {
                let mut acc = 0u64;
                for j in c + 1..n {
                    if v[j] != 0 {
                        acc = br.reduce(acc + a[r * n + j] * v[j]);
                    }
                }
                v[c] = (p - acc) % p;
            }
            if let Some(last) = v.iter().rposition(|&x| x != 0) {
                let inv = powmod(v[last], p - 2, p);
                for x in v.iter_mut() {
                    *x = mulmod(*x, inv, p);
                }
            }
            Ok(Some(v))
        }
        d => Err(d),
    }
}

/// For a polynomial surface patch of bidegree (m, n) the implicit degree is at most 2mn.
fn degree_bound(funcs: &[RatFunc], np: usize) -> Option<u32> {
    if np != 2 || funcs.iter().any(|f| !f.den.is_constant()) {
        return None;
    }
    let m = funcs.iter().map(|f| f.num.degree_in(0)).max()?.max(0) as u32;
    let n = funcs.iter().map(|f| f.num.degree_in(1)).max()?.max(0) as u32;
    (m > 0 && n > 0).then_some(2 * m * n)
}

/// Implicitizes by interpolation: see the module documentation.
pub fn implicitize_interpolation(
    coords: &[&str],
    params: &[&str],
    opts: &InterpolationOptions,
) -> Result<Implicit, ImplicitError> {
    let start = std::time::Instant::now();
    let funcs = parse_parametrization(coords, params)?;
    let names = coordinate_names(coords.len());
    let progress = opts.progress.as_deref();
    let report = |done: usize, total: usize| {
        if let Some(p) = progress {
            p.update(done as u64, total as u64);
        }
    };
    let nc = coords.len();
    let np = params.len();
    let mut seed = 0x2545F4914F6CDD1Du64;
    let mut rnd = move |m: u64| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed % m
    };
    // A known bound is tried first; if its nullspace is not one-dimensional the
    // true degree is lower, and degrees are tried in increasing order.
    let bound = opts
        .degree_hint
        .or_else(|| degree_bound(&funcs, np))
        .filter(|&b| (1..=opts.max_degree).contains(&b));
    let order: Vec<u32> = bound
        .into_iter()
        .chain((1..=opts.max_degree).filter(|d| Some(*d) != bound))
        .collect();
    for d in order {
        let mons = monomials(nc, d);
        let n = mons.len();
        // Primes just below 2^31, largest first (products of two residues fit in 64 bits).
        let mut p = (1u64 << 31) - 1;
        let mut acc: Option<(Vec<Int>, Int, usize)> = None; // residues, modulus, pivot (last nonzero)
        let mut attempts = 0;
        loop {
            if opts.interrupt.as_ref().is_some_and(|c| c.is_cancelled()) {
                return Err(ImplicitError::Cancelled);
            }
            if let Some(t) = opts.time {
                if start.elapsed() > t {
                    return Err(ImplicitError::Interpolation(format!(
                        "time limit of {:.1} s exceeded at degree {d}",
                        t.as_secs_f64()
                    )));
                }
            }
            loop {
                p -= 2;
                if is_prime(p) {
                    break;
                }
            }
            attempts += 1;
            if attempts > 200 {
                return Err(ImplicitError::Interpolation(format!(
                    "no stable solution at degree {d} after 200 primes"
                )));
            }
            // Sample points mod p.
            let k_rows = n + 8;
            // Progress units: the sample points, then the columns eliminated.
            let units = k_rows + n;
            if let Some(p) = progress {
                p.stage(&format!("interpolation (degree {d})"));
            }
            report(0, units);
            let mut rows: Vec<u64> = Vec::with_capacity(k_rows * n);
            let mut got = 0;
            let mut tries = 0;
            while got < k_rows && tries < 10 * k_rows {
                tries += 1;
                let vals: Vec<u64> = (0..np).map(|_| rnd(p)).collect();
                let mut pt = Vec::with_capacity(nc);
                let mut ok = true;
                for f in &funcs {
                    match (eval_mod(&f.num, &vals, p), eval_mod(&f.den, &vals, p)) {
                        (Some(a), Some(b)) if b != 0 => pt.push(mulmod(a, powmod(b, p - 2, p), p)),
                        _ => {
                            ok = false;
                            break;
                        }
                    }
                }
                if !ok {
                    continue;
                }
                // Powers of each coordinate, then one product per monomial.
                let powers: Vec<Vec<u64>> = pt
                    .iter()
                    .map(|&x| {
                        let mut v = vec![1u64; d as usize + 1];
                        for e in 1..=d as usize {
                            v[e] = (v[e - 1] * x) % p;
                        }
                        v
                    })
                    .collect();
                rows.extend(mons.iter().map(|e| {
                    e.iter()
                        .zip(&powers)
                        .fold(1u64, |acc, (&k, pw)| (acc * pw[k as usize]) % p)
                }));
                got += 1;
                report(got, units);
            }
            report(k_rows, units);
            let columns_done = |c: usize| report(k_rows + c, units);
            let solved = nullspace_1(rows, got, n, p, &columns_done);
            report(units, units);
            let v = match solved {
                Ok(None) => break, // no equation of degree d (mod p): try another degree
                Err(_) if Some(d) == bound && acc.is_none() => break, // degree below the bound
                Err(_) => continue, // unlucky prime or sampling: try another prime
                Ok(Some(v)) => v,
            };
            let last = v.iter().rposition(|&x| x != 0).unwrap_or(0);
            let pm = Int::from(p);
            acc = Some(match acc.take() {
                None => (v.iter().map(|&x| Int::from(x)).collect(), pm, last),
                Some((res, m, piv)) if piv == last => {
                    let inv = mod_inverse(&m.mod_floor(&pm), &pm);
                    let res = res
                        .iter()
                        .zip(&v)
                        .map(|(a, &b)| {
                            let t = ((Int::from(b) - a) * &inv).mod_floor(&pm);
                            a + &m * t
                        })
                        .collect();
                    (res, m * pm, piv)
                }
                Some(other) => other, // normalisation differs: unlucky, skip this prime
            });
            let (res, m, _) = acc.as_ref().expect("just set");
            let rec: Option<Vec<Rat>> = res
                .iter()
                .map(|a| {
                    if a.is_zero() {
                        Some(Rat::zero())
                    } else {
                        rational_reconstruction(a, m)
                    }
                })
                .collect();
            let Some(coefs) = rec else { continue };
            let out_ring = Ring::new(names, MonomialOrder::DegRevLex);
            let fq = Poly::from_terms(
                &out_ring,
                mons.iter()
                    .zip(&coefs)
                    .filter(|(_, c)| !c.is_zero())
                    .map(|(e, c)| (Monomial::new(e), c.clone()))
                    .collect(),
            );
            let f = to_primitive_integer(&out_ring, &fq);
            if verify(&f, &funcs, d, np, progress, opts.interrupt.as_ref()) {
                return Ok(Implicit {
                    ring: out_ring,
                    poly: f,
                    stats: crate::groebner::Stats {
                        time: start.elapsed(),
                        ..Default::default()
                    },
                });
            }
        }
    }
    Err(ImplicitError::Interpolation(format!(
        "no implicit equation of degree ≤ {}",
        opts.max_degree
    )))
}

/// A polynomial as (exponents, integer coefficient) pairs.
type IntTerms = Vec<(Vec<u16>, ZInt)>;

/// Exact check over Q that F vanishes on the parametrization: G = F(φ)·Πq_i^d is
/// a polynomial of degree ≤ D_j in parameter j; it is zero iff it vanishes on a
/// grid of D_j + 1 integer values per parameter. Coordinates are scaled to
/// integer numerators and denominators so that the grid is evaluated in exact
/// integer arithmetic, in parallel, a block of points at a time: `progress`
/// hears a stage `certificate` (grid points checked of all of them) and a
/// cancelled `interrupt` stops the check (false).
fn verify(
    f: &Poly<Int>,
    funcs: &[RatFunc],
    d: u32,
    np: usize,
    progress: Option<&(dyn Progress + Send)>,
    interrupt: Option<&CancelToken>,
) -> bool {
    use rayon::prelude::*;
    let deg = |p: &Poly<Rat>, j: usize| p.degree_in(j).max(0) as u64;
    let bounds: Vec<u64> = (0..np)
        .map(|j| {
            let q: u64 = funcs.iter().map(|g| deg(&g.den, j)).sum();
            let gain = funcs
                .iter()
                .map(|g| deg(&g.num, j) as i64 - deg(&g.den, j) as i64)
                .max()
                .unwrap_or(0)
                .max(0) as u64;
            d as u64 * (q + gain)
        })
        .collect();
    let total: u64 = bounds.iter().map(|b| b + 1).product();
    if total > 1_000_000 {
        return false;
    }
    // Integer numerator and denominator of each coordinate (scaled by the lcm of all denominators).
    let int_pair: Vec<(IntTerms, IntTerms)> = funcs
        .iter()
        .map(|g| {
            let mut l = Int::one();
            for (_, c) in g.num.terms().iter().chain(g.den.terms()) {
                l = l.lcm(c.denom());
            }
            let conv = |p: &Poly<Rat>| -> IntTerms {
                p.terms()
                    .iter()
                    .map(|(m, c)| {
                        (
                            m.exps().to_vec(),
                            to_zint(&(c * Rat::from_integer(l.clone())).to_integer()),
                        )
                    })
                    .collect()
            };
            (conv(&g.num), conv(&g.den))
        })
        .collect();
    let fz: Vec<(Vec<u16>, ZInt)> = f.terms().iter().map(|(m, c)| (m.exps().to_vec(), to_zint(c))).collect();
    let eval = |p: &[(Vec<u16>, ZInt)], vals: &[ZInt]| -> ZInt {
        let mut acc = ZInt::ZERO;
        for (e, c) in p {
            let mut t = c.clone();
            for (k, &x) in e.iter().enumerate() {
                if x > 0 {
                    t *= vals[k].pow(x as usize);
                }
            }
            acc += t;
        }
        acc
    };
    let d = d as usize;
    let offset = ZInt::from((bounds[0] / 2) as i64);
    let vanishes = |mut flat: u64| {
        let mut vals = Vec::with_capacity(np);
        for b in &bounds {
            vals.push(ZInt::from((flat % (b + 1)) as i64) - &offset);
            flat /= b + 1;
        }
        // Powers n_i^k and q_i^k for k ≤ d.
        let tables: Vec<(Vec<ZInt>, Vec<ZInt>)> = int_pair
            .iter()
            .map(|(num, den)| {
                let (n, q) = (eval(num, &vals), eval(den, &vals));
                let mut pn = vec![ZInt::ONE; d + 1];
                let mut pq = vec![ZInt::ONE; d + 1];
                for k in 1..=d {
                    pn[k] = &pn[k - 1] * &n;
                    pq[k] = &pq[k - 1] * &q;
                }
                (pn, pq)
            })
            .collect();
        let mut g = ZInt::ZERO;
        for (e, c) in &fz {
            let mut t = c.clone();
            for (i, &a) in e.iter().enumerate() {
                let a = a as usize;
                t = t * &tables[i].0[a] * &tables[i].1[d - a];
            }
            g += t;
        }
        g == ZInt::ZERO
    };
    if let Some(p) = progress {
        p.stage("certificate");
        p.update(0, total);
    }
    // Blocks of points, so that progress and cancellation are heard between them.
    const BLOCK: u64 = 1024;
    let mut lo = 0;
    while lo < total {
        if interrupt.is_some_and(CancelToken::is_cancelled) {
            return false;
        }
        let hi = (lo + BLOCK).min(total);
        if !(lo..hi).into_par_iter().all(vanishes) {
            return false;
        }
        lo = hi;
        if let Some(p) = progress {
            p.update(lo, total);
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn progress_counts_rows_columns_and_grid_points() {
        use crate::testing::Recorder;
        for (x, y, z) in [("s", "t", "s^3 - 3*s*t^2"), ("s/t", "s/t^2", "(s+t)/s")] {
            let coords = [x, y, z];
            let plain = implicitize_interpolation(&coords, &["s", "t"], &InterpolationOptions::default()).unwrap();
            let recorder = Arc::new(Recorder::default());
            let opts = InterpolationOptions {
                progress: Some(recorder.clone()),
                ..Default::default()
            };
            let watched = implicitize_interpolation(&coords, &["s", "t"], &opts).unwrap();
            assert_eq!(watched.poly, plain.poly);
            // Interpolation stages always complete; only the last certificate need (a failed one stops short).
            let stages = recorder.check(|name| name.starts_with("interpolation"));
            assert!(stages[0].0.starts_with("interpolation (degree "), "{stages:?}");
            let (last, updates) = stages.last().unwrap();
            assert_eq!(last, "certificate");
            let (d, t) = *updates.last().unwrap();
            assert!(
                d == t && t > 0,
                "the accepted certificate checked its whole grid: {d} of {t}"
            );
            // An interpolation stage counts n + 8 sample rows and n columns for n monomials.
            let degree = watched.poly.degree() as usize;
            let n = (degree + 1) * (degree + 2) * (degree + 3) / 6;
            let name = format!("interpolation (degree {degree})");
            let (_, ups) = stages
                .iter()
                .rev()
                .find(|(s, _)| *s == name)
                .expect("the final degree's stage");
            assert_eq!(ups.last().unwrap().1 as usize, 2 * n + 8);
        }
        // The job crate's Counter.
        let counter = Arc::new(isoray_job::Counter::default());
        let opts = InterpolationOptions {
            progress: Some(counter.clone()),
            ..Default::default()
        };
        implicitize_interpolation(&["(1-t^2)/(1+t^2)", "2t/(1+t^2)"], &["t"], &opts).unwrap();
        assert!(counter.total() > 0 && counter.done() == counter.total());
    }

    #[test]
    fn interpolation_matches_elimination() {
        let cases: &[(&str, &str, &str)] = &[
            ("s+t", "s", "t"),
            ("2s/(s^2+t^2+1)", "2t/(s^2+t^2+1)", "(s^2+t^2-1)/(s^2+t^2+1)"),
            ("s/t", "s/t^2", "(s+t)/s"),
            ("(t-s^2)/(st)", "s^2/3", "s"),
            ("s", "t", "s^3 - 3*s*t^2"),
        ];
        for (x, y, z) in cases {
            let a = implicitize_interpolation(&[x, y, z], &["s", "t"], &InterpolationOptions::default())
                .unwrap_or_else(|e| panic!("{x},{y},{z}: {e}"));
            let b = crate::implicit::implicitize_groebner(&[x, y, z], &["s", "t"], &Default::default()).unwrap();
            assert_eq!(a.poly, b.poly, "{x}, {y}, {z}");
        }
        let c = implicitize_interpolation(
            &["(1-t^2)/(1+t^2)", "2t/(1+t^2)"],
            &["t"],
            &InterpolationOptions::default(),
        )
        .unwrap();
        assert_eq!(c.display(), "x^2 + y^2 - 1");
    }
}
