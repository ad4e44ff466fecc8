//! Gröbner bases over Q by multi-modular F4: a full F4 run modulo a random
//! prime q learns the trace; the trace is replayed modulo the lifting
//! primes (the primes below 2³¹, downwards; a replay builds only the rows
//! that mattered, with no symbolic work); their bases are combined by the
//! Chinese remainder theorem in Garner's mixed radix; rational
//! reconstruction runs when the reconstruction of a few probe coefficients
//! has settled (same value two primes in a row); then the candidate is
//! checked.
//!
//! # The check
//!
//! * [`Verify::Exact`]: the certificate of [`crate::modular`]: every
//!   S-pair the Gebauer–Möller criteria keep, and every input, reduces to
//!   zero over Q (with equal leading ideals this proves ⟨G⟩ = I).
//! * [`Verify::Probabilistic`] (the default): the candidate reduced modulo
//!   q must equal, term for term, the reduced basis of the full run modulo
//!   q (the learning run, which took no part in the lifting; after a
//!   rejection, a full run modulo a fresh random prime). q is drawn at
//!   random among the primes in (2³⁰, 2³¹ − 2²⁰). A wrong candidate passes
//!   only if q is unlucky for I (it divides one of the finitely many
//!   integers whose vanishing changes F4's run over Q: a pivot, or a row
//!   the run over Q does not reduce to zero; an unlucky learning prime can
//!   make every replay miss the same element) or divides the numerator of
//!   a difference between a coefficient of the candidate and the true one:
//!   with B the bits of the product of those integers, at most B / 30 of
//!   the ≈ 4.8·10⁷ primes in the range, so the chance of a wrong answer is
//!   below B / 1.4·10⁹ (10⁻⁶ for B = 1400) per check, and a rejected
//!   candidate only costs more primes.
//!
//! Set the environment variable `F4_DEBUG` to print each prime's timings
//! (and [`crate::f4`]'s matrices) on standard error.

use std::hash::{BuildHasher, Hasher};
use std::time::Instant;

use num_integer::Integer;
use num_traits::{One, ToPrimitive, Zero};

use crate::coeff::{is_prime, to_zint, Fp, Int, Rat, ZInt};
use crate::f4::{f4_learn, f4_modp, f4_replay_coefs, inv_mod, F4Trace};
use crate::groebner::{check_groebner_basis, prefixed_progress, GroebnerError, GroebnerOptions, Stats};
use crate::modular::{to_rat, Reconstructor};
use crate::monomial::Monomial;
use crate::parse::to_primitive_integer;
use crate::poly::{Poly, Ring};
use dashu_base::Gcd;
use dashu_int::UBig;

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
pub(crate) fn primes() -> impl Iterator<Item = u64> {
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

/// A basis lifted so far: per element its monomials and the mixed-radix
/// digits of their coefficients (Garner's form of the Chinese remainder
/// theorem: c = d₀ + p₀(d₁ + p₁(d₂ + …)), each digit below its prime), so
/// adding a prime costs word operations only and a coefficient becomes an
/// integer only when it is reconstructed.
struct Lift {
    lms: Vec<Monomial>,
    monos: Vec<Vec<Monomial>>,
    /// Per element, digit k of term t at `k * len + t`.
    digits: Vec<Vec<u32>>,
    primes: Vec<u64>,
    /// The probes' last reconstruction.
    probes: Option<Vec<Rat>>,
}

/// One prime's reduced basis: per element its monomials (from the leading
/// one down) and their residues (zeros allowed).
type ModBasis<'a> = Vec<(&'a [Monomial], &'a [u32])>;

impl Lift {
    fn new(basis: &ModBasis) -> Lift {
        Lift {
            lms: basis.iter().map(|(m, _)| m[0].clone()).collect(),
            monos: basis.iter().map(|(m, _)| m.to_vec()).collect(),
            digits: vec![Vec::new(); basis.len()],
            primes: Vec::new(),
            probes: None,
        }
    }

    /// Adds one more prime's basis (same leading monomials); false, and
    /// nothing changed, if a term lies outside the lift's supports.
    fn combine(&mut self, ring: &Ring, basis: &ModBasis, p: u64) -> bool {
        let mut aligned: Vec<std::borrow::Cow<[u32]>> = Vec::with_capacity(basis.len());
        for ((monos, coefs), have) in basis.iter().zip(&self.monos) {
            if *monos == have.as_slice() {
                aligned.push((*coefs).into());
                continue;
            }
            let mut out = vec![0u32; have.len()];
            for (m, &c) in monos.iter().zip(coefs.iter()) {
                if c == 0 {
                    continue;
                }
                match have.binary_search_by(|h| ring.cmp(m, h)) {
                    Ok(k) => out[k] = c,
                    Err(_) => return false,
                }
            }
            aligned.push(out.into());
        }
        let modulus_mod_p = self.primes.iter().fold(1u64, |a, &q| a * (q % p) % p);
        let inv = inv_mod(modulus_mod_p, p);
        let n = self.primes.len();
        let mut acc = Vec::new();
        for (digits, res) in self.digits.iter_mut().zip(&aligned) {
            let len = res.len();
            // The lifted value modulo p, by Horner's rule on the digits.
            acc.clear();
            acc.resize(len, 0u64);
            for k in (0..n).rev() {
                let pk = self.primes[k] % p;
                for (a, &d) in acc.iter_mut().zip(&digits[k * len..(k + 1) * len]) {
                    *a = (*a * pk + d as u64) % p;
                }
            }
            digits.extend(
                acc.iter()
                    .zip(res.iter())
                    .map(|(&a, &r)| ((r as u64 + p - a) % p * inv % p) as u32),
            );
        }
        self.primes.push(p);
        true
    }

    /// The product of the primes.
    fn modulus(&self) -> UBig {
        self.primes.iter().fold(UBig::ONE, |m, &p| m * p)
    }

    /// Coefficient t of element e, in 0..modulus.
    fn value(&self, e: usize, t: usize) -> UBig {
        let len = self.monos[e].len();
        let mut v = UBig::ZERO;
        for k in (0..self.primes.len()).rev() {
            v *= self.primes[k];
            v += self.digits[e][k * len + t];
        }
        v
    }

    /// The probe coefficients (each element's last and first tail term)
    /// reconstructed, if they all are.
    fn probe(&self) -> Option<Vec<Rat>> {
        let rec = Reconstructor::new_u(self.modulus());
        let mut out = Vec::new();
        for (e, monos) in self.monos.iter().enumerate() {
            let len = monos.len();
            for t in [1, len - 1] {
                if t < len {
                    let (n, d) = rec.reconstruct_u(&self.value(e, t))?;
                    out.push(to_rat(&n, &d));
                }
            }
        }
        Some(out)
    }

    /// Every coefficient reconstructed, elements monic.
    fn reconstruct(&self, ring: &Ring) -> Option<Vec<Poly<Rat>>> {
        let rec = Reconstructor::new_u(self.modulus());
        let mut out = Vec::with_capacity(self.monos.len());
        for (e, monos) in self.monos.iter().enumerate() {
            let mut terms = Vec::with_capacity(monos.len());
            // Coefficients of one element often share a denominator: the
            // lcm of those found so far is tried first.
            let mut den = UBig::ONE;
            for (t, m) in monos.iter().enumerate() {
                let a = self.value(e, t);
                if a.is_zero() {
                    continue;
                }
                let (n, d) = rec.reconstruct_with(&a, &den)?;
                if !(&den % &d).is_zero() {
                    let g = (&den).gcd(&d);
                    den = &den / g * &d;
                }
                terms.push((m.clone(), to_rat(&n, &d)));
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
    // The trace is learned by a full run modulo a random prime q, which
    // stays out of the lifting: its basis is the probabilistic check.
    let mut used: Vec<u64> = Vec::new();
    let mut learned: Option<Learned> = None;
    let mut lifts: Vec<Lift> = Vec::new();
    let mut lifting = primes();
    loop {
        if learned.is_none() {
            let q = random_prime(|q| used.contains(&q) || divides_lc(q));
            used.push(q);
            let o = sub("modular, learning: ".into());
            let mut trace = F4Trace::default();
            let (basis, st) = f4_learn(ring, &reduce_mod(ring, &ints, q), &o, Some(&mut trace))?;
            stats.add_work(&st);
            let lms = basis.iter().map(|g| g.lm().expect("nonzero").clone()).collect();
            learned = Some(Learned { q, trace, basis, lms });
        }
        let l = learned.as_ref().expect("learned");
        let p = lifting
            .find(|&p| !divides_lc(p))
            .expect("there are infinitely many primes");
        used.push(p);
        let o = sub(format!(
            "modular, prime {}: ",
            lifts.iter().map(|l| l.primes.len()).sum::<usize>() + 1
        ));
        let mods = reduce_mod(ring, &ints, p);
        // This prime's basis: replayed coefficients on the trace's
        // monomials, or (when the replay fails) a full run's polynomials.
        let (full, replayed) = match f4_replay_coefs(ring, &mods, &l.trace, &o)? {
            Ok((c, st)) => {
                stats.add_work(&st);
                (None, Some(c))
            }
            Err(_) => {
                let (b, st) = f4_modp(ring, &mods, &o)?;
                stats.add_work(&st);
                (Some(b), None)
            }
        };
        let owned: Vec<(Vec<Monomial>, Vec<u32>)>;
        let basis: ModBasis = match (&full, &replayed) {
            (Some(b), _) => {
                owned = b
                    .iter()
                    .map(|g| g.terms().iter().map(|(m, c)| (m.clone(), c.value() as u32)).unzip())
                    .collect();
                owned.iter().map(|(m, c)| (m.as_slice(), c.as_slice())).collect()
            }
            (None, Some(c)) => l.trace.output_monomials().zip(c.iter().map(|c| &c[..])).collect(),
            _ => unreachable!("a basis was computed"),
        };
        let lms: Vec<Monomial> = basis.iter().map(|(m, _)| m[0].clone()).collect();
        let k = match lifts.iter().position(|l| l.lms == lms) {
            Some(k) => k,
            None => {
                lifts.push(Lift::new(&basis));
                lifts.len() - 1
            }
        };
        if !lifts[k].combine(ring, &basis, p) {
            // Another support with these leading monomials: start again from it.
            lifts[k] = Lift::new(&basis);
            lifts[k].combine(ring, &basis, p);
        }
        // Work with the lift backed by the most primes; learn again when
        // another lift overtakes the trace's (its prime was unlucky).
        let best = (0..lifts.len())
            .max_by_key(|&i| lifts[i].primes.len())
            .expect("nonempty");
        if best != k {
            continue;
        }
        if l.lms != lms {
            learned = None;
            continue;
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
            if !lc.is_one() {
                *g = g.scale(&lc.recip());
            }
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
                let ok = candidate_mod(ring, &candidate, l.q).is_some_and(|c| c == l.basis);
                if !ok {
                    // A fresh random prime's full run checks the next candidate.
                    let q = random_prime(|q| used.contains(&q) || divides_lc(q));
                    used.push(q);
                    let (b, st) = f4_modp(ring, &reduce_mod(ring, &ints, q), &vo)?;
                    stats.add_work(&st);
                    if let Some(l) = learned.as_mut() {
                        l.q = q;
                        l.basis = b;
                    }
                }
                ok
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
}

/// The trace of a full run modulo a random prime q, and its basis (the
/// check of the probabilistic verification).
struct Learned {
    q: u64,
    trace: F4Trace,
    basis: Vec<Poly<Fp>>,
    lms: Vec<Monomial>,
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
