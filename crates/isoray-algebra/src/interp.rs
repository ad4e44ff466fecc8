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

use num_integer::Integer;
use num_traits::{ToPrimitive, Zero};

use crate::coeff::{is_prime, Int, Rat};
use crate::implicit::{coordinate_names, parse_parametrization, Implicit, ImplicitError};
use crate::modular::{mod_inverse, rational_reconstruction};
use crate::monomial::{Monomial, MonomialOrder};
use crate::parse::{to_primitive_integer, RatFunc};
use crate::poly::{Poly, Ring};

/// Options of [`implicitize_interpolation`].
#[derive(Debug, Clone)]
pub struct InterpolationOptions {
    /// Largest implicit degree tried (degrees 1, 2, … are tried in turn).
    pub max_degree: u32,
    /// Wall-clock limit.
    pub time: Option<std::time::Duration>,
}

impl Default for InterpolationOptions {
    fn default() -> Self {
        InterpolationOptions {
            max_degree: 24,
            time: None,
        }
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

/// The nullspace of a K×N matrix mod p when it is one-dimensional: the vector
/// with its last nonzero entry 1. `Ok(None)` for a trivial nullspace,
/// `Err(dim)` for a larger one.
fn nullspace_1(mut a: Vec<Vec<u64>>, n: usize, p: u64) -> Result<Option<Vec<u64>>, usize> {
    let mut pivots = Vec::new(); // pivot column of each row
    let mut row = 0;
    for col in 0..n {
        let Some(r) = (row..a.len()).find(|&r| a[r][col] != 0) else {
            continue;
        };
        a.swap(row, r);
        let inv = powmod(a[row][col], p - 2, p);
        for x in a[row][col..].iter_mut() {
            *x = mulmod(*x, inv, p);
        }
        let pivot_row = a[row].clone();
        for (r2, other) in a.iter_mut().enumerate() {
            if r2 != row && other[col] != 0 {
                let f = other[col];
                for (x, y) in other[col..].iter_mut().zip(&pivot_row[col..]) {
                    *x = (*x + p - mulmod(f, *y, p)) % p;
                }
            }
        }
        pivots.push(col);
        row += 1;
        if row == a.len() {
            break;
        }
    }
    let free: Vec<usize> = (0..n).filter(|c| !pivots.contains(c)).collect();
    match free.len() {
        0 => Ok(None),
        1 => {
            let f = free[0];
            let mut v = vec![0u64; n];
            v[f] = 1;
            for (r, &c) in pivots.iter().enumerate() {
                v[c] = (p - a[r][f]) % p;
            }
            // Normalise: last nonzero entry 1.
            if let Some(last) = v.iter().rposition(|&x| x != 0) {
                let inv = powmod(v[last], p - 2, p);
                for x in v.iter_mut() {
                    *x = mulmod(*x, inv, p);
                }
            }
            Ok(Some(v))
        }
        k => Err(k),
    }
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
    let nc = coords.len();
    let np = params.len();
    let mut seed = 0x2545F4914F6CDD1Du64;
    let mut rnd = move |m: u64| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed % m
    };
    for d in 1..=opts.max_degree {
        let mons = monomials(nc, d);
        let n = mons.len();
        // Primes just below 2^61, largest first.
        let mut p = (1u64 << 61) - 1;
        let mut acc: Option<(Vec<Int>, Int, usize)> = None; // residues, modulus, pivot (last nonzero)
        let mut attempts = 0;
        loop {
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
            let mut rows = Vec::with_capacity(n + 8);
            let mut tries = 0;
            while rows.len() < n + 8 && tries < 10 * (n + 8) {
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
                rows.push(
                    mons.iter()
                        .map(|e| {
                            e.iter()
                                .zip(&pt)
                                .fold(1u64, |acc, (&k, &x)| mulmod(acc, powmod(x, k as u64, p), p))
                        })
                        .collect::<Vec<u64>>(),
                );
            }
            let v = match nullspace_1(rows, n, p) {
                Ok(None) => break,  // no equation of degree d (mod p): try d + 1
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
            if verify(&f, &funcs, d, np) {
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

/// Exact check over Q that F vanishes on the parametrization: G = F(φ)·Πq_i^d is
/// a polynomial of degree ≤ D_j in parameter j; it is zero iff it vanishes on a
/// grid of D_j + 1 integer values per parameter.
fn verify(f: &Poly<Int>, funcs: &[RatFunc], d: u32, np: usize) -> bool {
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
    if total > 200_000 {
        return false;
    }
    let eval_q = |p: &Poly<Rat>, vals: &[Int]| -> Rat {
        let mut acc = Rat::zero();
        for (m, c) in p.terms() {
            let mut t = c.clone();
            for (i, &e) in m.exps().iter().enumerate() {
                if e > 0 {
                    t *= Rat::from_integer(num_traits::pow(vals[i].clone(), e as usize));
                }
            }
            acc += t;
        }
        acc
    };
    let mut idx = vec![0u64; np];
    loop {
        let vals: Vec<Int> = idx
            .iter()
            .map(|&i| Int::from(i as i64) - Int::from((bounds[0] / 2) as i64))
            .collect();
        let nums: Vec<Rat> = funcs.iter().map(|g| eval_q(&g.num, &vals)).collect();
        let dens: Vec<Rat> = funcs.iter().map(|g| eval_q(&g.den, &vals)).collect();
        let mut g = Rat::zero();
        for (m, c) in f.terms() {
            let mut t = Rat::from_integer(c.clone());
            for (i, &e) in m.exps().iter().enumerate() {
                t *= num_traits::pow(nums[i].clone(), e as usize)
                    * num_traits::pow(dens[i].clone(), (d as usize).saturating_sub(e as usize));
            }
            g += t;
        }
        if !g.is_zero() {
            return false;
        }
        // Next grid point.
        let mut k = 0;
        loop {
            if k == np {
                return true;
            }
            idx[k] += 1;
            if idx[k] <= bounds[k] {
                break;
            }
            idx[k] = 0;
            k += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
