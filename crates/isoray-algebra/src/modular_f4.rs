//! Gröbner bases over Q by multi-modular F4: the reduced basis modulo
//! primes below 2³¹, the first prime's F4 trace replayed on the others
//! (only the rows that mattered are built), Chinese remaindering, rational
//! reconstruction when the reconstruction of a few probe coefficients has
//! settled, and a check of the candidate.
//!
//! # The check
//!
//! * [`Verify::Exact`]: the certificate of [`crate::modular`]: every
//!   S-pair the Gebauer–Möller criteria keep, and every input, reduces to
//!   zero over Q (with equal leading ideals this proves ⟨G⟩ = I).
//! * [`Verify::Probabilistic`] (the default): a fresh prime q is drawn at
//!   random among the primes in (2³⁰, 2³¹ − 2²⁰); the reduced basis of I
//!   modulo q is computed by a full F4 run (not a replay) and must equal the
//!   candidate reduced modulo q, term for term. A wrong candidate passes
//!   only if q is unlucky for I or divides the numerator of a difference
//!   between a coefficient of the candidate and the true one: with B the
//!   bits of the largest such numerator, at most B / 30 of the ≈ 4.8·10⁷
//!   primes in the range, so the chance of a wrong answer is below
//!   B / 1.4·10⁹ (10⁻⁶ for coefficients of a thousand bits) per check, and
//!   a rejected candidate only costs more primes.

use std::collections::HashMap;
use std::hash::{BuildHasher, Hasher};
use std::time::Instant;

use num_integer::Integer;
use num_traits::{One, ToPrimitive, Zero};

use crate::coeff::{is_prime, to_zint, Fp, Int, Rat, ZInt};
use crate::f4::{f4_learn, f4_modp, f4_replay, inv_mod, F4Trace};
use crate::groebner::{check_groebner_basis, prefixed_progress, GroebnerError, GroebnerOptions, Stats};
use crate::modular::rational_reconstruction;
use crate::monomial::Monomial;
use crate::parse::to_primitive_integer;
use crate::poly::{Poly, Ring};

/// How a multi-modular result is checked before it is returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Verify {
    /// Compared with a full F4 run modulo a random fresh prime (see the
    /// module's documentation for the failure probability).
    #[default]
    Probabilistic,
    /// Proved over Q: every S-pair and input reduces to zero.
    Exact,
}

/// The primes used for lifting: the largest below 2³¹, downwards.
fn primes() -> impl Iterator<Item = u64> {
    let mut p = 1u64 << 31;
    std::iter::from_fn(move || loop {
        p -= 1;
        if is_prime(p) {
            return Some(p);
        }
    })
}

/// A prime drawn at random from (2³⁰, 2³¹ − 2²⁰), below the lifting primes.
fn random_prime(avoid: impl Fn(u64) -> bool) -> u64 {
    let lo = 1u64 << 30;
    let span = (1u64 << 30) - (1 << 20);
    let mut seed = std::collections::hash_map::RandomState::new().build_hasher().finish();
    loop {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut q = lo + (seed >> 11) % span;
        while !is_prime(q) {
            q += 1;
        }
        if !avoid(q) {
            return q;
        }
    }
}

/// The inputs modulo p.
fn reduce_mod(ring: &Ring, ints: &[Poly<Int>], p: u64) -> Vec<Poly<Fp>> {
    let pm = Int::from(p);
    ints.iter()
        .map(|f| {
            let terms = f
                .terms()
                .iter()
                .map(|(m, c)| (m.clone(), Fp::new(c.mod_floor(&pm).to_i64().expect("below p"), p)))
                .filter(|(_, c)| c.value() != 0)
                .collect();
            Poly::from_terms(ring, terms)
        })
        .collect()
}

/// A basis lifted so far: per element its monomials and the residues of
/// their coefficients modulo `modulus` (the product of `primes` primes).
struct Lift {
    lms: Vec<Monomial>,
    monos: Vec<Vec<Monomial>>,
    index: Vec<HashMap<Monomial, usize>>,
    res: Vec<Vec<Int>>,
    modulus: Int,
    primes: usize,
    /// The probes' last reconstruction.
    probes: Option<Vec<Rat>>,
}

impl Lift {
    fn new(basis: &[Poly<Fp>]) -> Lift {
        Lift {
            lms: basis.iter().map(|g| g.lm().expect("nonzero").clone()).collect(),
            monos: vec![Vec::new(); basis.len()],
            index: vec![HashMap::new(); basis.len()],
            res: vec![Vec::new(); basis.len()],
            modulus: Int::one(),
            primes: 0,
            probes: None,
        }
    }

    /// Chinese remaindering with one more prime's basis (same leading monomials).
    fn combine(&mut self, basis: &[Poly<Fp>], p: u64) {
        let pm = Int::from(p);
        let m_mod_p = self.modulus.mod_floor(&pm).to_u64().expect("below p");
        let m_inv = if self.primes == 0 { 1 } else { inv_mod(m_mod_p, p) };
        for (e, g) in basis.iter().enumerate() {
            let mut b = vec![0u64; self.monos[e].len()];
            for (m, c) in g.terms() {
                let k = match self.index[e].get(m) {
                    Some(&k) => k,
                    None => {
                        // New here: zero modulo the primes so far.
                        self.index[e].insert(m.clone(), self.monos[e].len());
                        self.monos[e].push(m.clone());
                        self.res[e].push(Int::zero());
                        b.push(0);
                        self.monos[e].len() - 1
                    }
                };
                b[k] = c.value();
            }
            for (a, &bv) in self.res[e].iter_mut().zip(&b) {
                let am = if self.primes == 0 {
                    0
                } else {
                    a.mod_floor(&pm).to_u64().expect("below p")
                };
                let t = (bv + p - am) % p * m_inv % p;
                if t != 0 {
                    *a += &self.modulus * Int::from(t);
                }
            }
        }
        self.modulus *= pm;
        self.primes += 1;
    }

    /// The probe coefficients (each element's last and first tail term)
    /// reconstructed, if they all are.
    fn probe(&self) -> Option<Vec<Rat>> {
        let mut out = Vec::new();
        for r in &self.res {
            for a in [r.get(1), r.last()].into_iter().flatten() {
                out.push(rational_reconstruction(a, &self.modulus)?);
            }
        }
        Some(out)
    }

    /// Every coefficient reconstructed, elements monic.
    fn reconstruct(&self, ring: &Ring) -> Option<Vec<Poly<Rat>>> {
        let mut out = Vec::with_capacity(self.res.len());
        for (monos, res) in self.monos.iter().zip(&self.res) {
            let mut terms = Vec::with_capacity(res.len());
            for (m, a) in monos.iter().zip(res) {
                if a.is_zero() {
                    continue;
                }
                terms.push((m.clone(), rational_reconstruction(a, &self.modulus)?));
            }
            out.push(Poly::from_terms(ring, terms));
        }
        Some(out)
    }
}

/// The candidate modulo q, if no denominator vanishes there.
fn candidate_mod(ring: &Ring, basis: &[Poly<Rat>], q: u64) -> Option<Vec<Poly<Fp>>> {
    basis
        .iter()
        .map(|g| {
            let terms = g
                .terms()
                .iter()
                .map(|(m, c)| Fp::from_rat(c, q).map(|v| (m.clone(), v)))
                .collect::<Option<Vec<_>>>()?;
            Some(Poly::from_terms(
                ring,
                terms.into_iter().filter(|t| t.1.value() != 0).collect(),
            ))
        })
        .collect()
}

/// The reduced Gröbner basis over Q by multi-modular F4, checked as
/// `verify` says; monic, by increasing leading monomial. The budget and
/// interrupt of `opts` cover the whole computation; progress stages are
/// `modular, prime K: f4` (or `f4 replay`) and `verification`.
pub fn groebner_f4_rational(
    ring: &Ring,
    polys: &[Poly<Rat>],
    opts: &GroebnerOptions,
    verify: Verify,
) -> Result<(Vec<Poly<Rat>>, Stats), GroebnerError> {
    let start = Instant::now();
    let ints: Vec<Poly<Int>> = polys
        .iter()
        .filter(|p| !p.is_zero())
        .map(|p| to_primitive_integer(ring, &p.reorder(ring)))
        .collect();
    let mut stats = Stats::default();
    if ints.is_empty() {
        return Ok((Vec::new(), stats));
    }
    let divides_lc = |p: u64| {
        let pm = Int::from(p);
        ints.iter().any(|f| f.lc().is_some_and(|c| c.mod_floor(&pm).is_zero()))
    };
    // Options for one prime: the time left, stages prefixed.
    let sub = |label: String| -> GroebnerOptions {
        let mut o = GroebnerOptions {
            progress: prefixed_progress(&opts.progress, || label),
            ..opts.clone()
        };
        if let Some(t) = o.budget.time {
            o.budget.time = Some(t.saturating_sub(start.elapsed()));
        }
        o
    };
    let mut trace: Option<(F4Trace, Vec<Monomial>)> = None;
    let mut lifts: Vec<Lift> = Vec::new();
    let mut used = Vec::new();
    for p in primes() {
        if divides_lc(p) {
            continue;
        }
        used.push(p);
        let o = sub(format!("modular, prime {}: ", used.len()));
        let mods = reduce_mod(ring, &ints, p);
        let basis = match &trace {
            None => {
                let mut t = F4Trace::default();
                let (b, st) = f4_learn(ring, &mods, &o, Some(&mut t))?;
                stats.add_work(&st);
                trace = Some((t, b.iter().map(|g| g.lm().expect("nonzero").clone()).collect()));
                b
            }
            Some((t, _)) => match f4_replay(ring, &mods, t, &o)? {
                Ok((b, st)) => {
                    stats.add_work(&st);
                    b
                }
                Err(_) => {
                    let (b, st) = f4_modp(ring, &mods, &o)?;
                    stats.add_work(&st);
                    b
                }
            },
        };
        let lms: Vec<Monomial> = basis.iter().map(|g| g.lm().expect("nonzero").clone()).collect();
        let k = match lifts.iter().position(|l| l.lms == lms) {
            Some(k) => k,
            None => {
                lifts.push(Lift::new(&basis));
                lifts.len() - 1
            }
        };
        lifts[k].combine(&basis, p);
        // Work with the lift backed by the most primes; relearn the trace
        // when another lift overtakes the trace's (its prime was unlucky).
        let best = (0..lifts.len()).max_by_key(|&i| lifts[i].primes).expect("nonempty");
        if best != k {
            continue;
        }
        if trace.as_ref().is_some_and(|(_, l)| *l != lms) {
            trace = None;
        }
        let lift = &mut lifts[best];
        let probes = lift.probe();
        let settled = probes.is_some() && probes == lift.probes;
        lift.probes = probes;
        if !settled {
            continue;
        }
        let Some(mut candidate) = lift.reconstruct(ring) else {
            continue;
        };
        for g in candidate.iter_mut() {
            let lc = g.lc().cloned().unwrap_or_else(Rat::one);
            *g = g.scale(&lc.recip());
        }
        let vo = sub("verification: ".into());
        let ok = match verify {
            Verify::Exact => {
                let zbasis: Vec<Poly<ZInt>> = candidate
                    .iter()
                    .map(|g| to_primitive_integer(ring, g).map_coeffs(ring, to_zint))
                    .collect();
                let zin: Vec<Poly<ZInt>> = ints.iter().map(|f| f.map_coeffs(ring, to_zint)).collect();
                check_groebner_basis(ring, &zbasis, &zin, &vo)?
            }
            Verify::Probabilistic => {
                let q = random_prime(|q| used.contains(&q) || divides_lc(q));
                match candidate_mod(ring, &candidate, q) {
                    None => false,
                    Some(c) => {
                        let (b, st) = f4_modp(ring, &reduce_mod(ring, &ints, q), &vo)?;
                        stats.add_work(&st);
                        b == c
                    }
                }
            }
        };
        if ok {
            candidate.sort_by(|a, b| ring.cmp(a.lm().expect("nonzero"), b.lm().expect("nonzero")));
            stats.basis_size = candidate.len();
            stats.time = start.elapsed();
            return Ok((candidate, stats));
        }
        // Rejected: wait for the probes to change and settle again.
        lifts[best].probes = None;
    }
    unreachable!("there are infinitely many primes")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groebner::groebner_fraction_free;
    use crate::monomial::MonomialOrder;
    use crate::systems::{cyclic, katsura};

    /// Multi-modular F4 gives the fraction-free Buchberger basis over Q,
    /// with either check: katsura-4, 5 and cyclic-5 in grevlex, katsura-3
    /// in lex (coefficients of dozens of digits).
    #[test]
    fn multimodular_f4_equals_fraction_free() {
        let (k3, k3p) = katsura(3);
        let lex = k3.with_order(MonomialOrder::Lex);
        let lexp: Vec<_> = k3p.iter().map(|f| f.reorder(&lex)).collect();
        for (ring, polys) in [katsura(4), cyclic(5), katsura(5), (lex, lexp)] {
            let o = GroebnerOptions::default();
            let want = groebner_fraction_free(&ring, &polys, &o).unwrap().basis;
            for v in [Verify::Probabilistic, Verify::Exact] {
                let (have, _) = groebner_f4_rational(&ring, &polys, &o, v).unwrap();
                assert_eq!(have, want, "{:?} {v:?}", ring.order());
            }
        }
    }
}
