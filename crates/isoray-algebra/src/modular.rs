//! Multi-modular Gröbner bases over Q (Arnold 2003; Idrees, Pfister and
//! Steidel 2011): compute reduced bases modulo several word-size primes, keep
//! the primes whose leading monomials agree with the majority, lift the
//! coefficients by the Chinese remainder theorem and rational reconstruction,
//! and accept the lift only after verifying over Q that it is a Gröbner basis
//! (every S-pair the Gebauer–Möller criteria keep reduces to zero) whose ideal
//! contains the input. With I ⊆ ⟨G⟩ and equal leading ideals (LM(G) is the
//! leading ideal of I mod p for the majority of primes), ⟨G⟩ = I.

use std::collections::HashMap;

use num_integer::Integer;
use num_traits::{One, Zero};

use crate::coeff::{from_zint, is_prime, to_zint, Fp, Int, Rat, ZInt};
use crate::groebner::{
    check_groebner_basis, groebner_in, groebner_replay, groebner_traced, with_stage_prefix, GroebnerError,
    GroebnerOptions, Stats,
};
use crate::monomial::Monomial;
use crate::parse::to_primitive_integer;
use crate::poly::{Poly, Ring};
use dashu_base::{DivRem, Gcd, SquareRoot};
use dashu_int::UBig;

/// The primes used, largest first: primes just below 2^62 (measured: fewer
/// primes beat cheaper arithmetic with 31-bit primes).
fn primes() -> impl Iterator<Item = u64> {
    let mut p = (1u64 << 62) - 1;
    std::iter::from_fn(move || loop {
        p -= 2;
        if is_prime(p) {
            return Some(p);
        }
    })
}

/// r/s ≡ a (mod m) with |r|, s ≤ √(m/2), if it exists (Wang's algorithm).
pub fn rational_reconstruction(a: &Int, m: &Int) -> Option<Rat> {
    Reconstructor::new(m).reconstruct(a)
}

/// Rational reconstruction modulo one modulus m, the bound √(m/2)
/// computed once, with a shortcut for a known denominator. The arithmetic
/// is dashu's (Lehmer's gcd, fast division).
pub struct Reconstructor {
    m: UBig,
    /// `m` as an [`Int`], for [`Reconstructor::reconstruct`]'s residues.
    m_int: Int,
    half: UBig,
    bound: UBig,
}

impl Reconstructor {
    /// For residues modulo `m` (> 1).
    pub fn new(m: &Int) -> Reconstructor {
        let m = UBig::try_from(to_zint(m)).unwrap_or(UBig::ONE);
        Reconstructor::new_u(m)
    }

    /// [`Reconstructor::new`] for a dashu modulus.
    pub(crate) fn new_u(m: UBig) -> Reconstructor {
        let half = &m >> 1;
        Reconstructor {
            bound: half.sqrt(),
            half,
            m_int: from_zint(&ZInt::from(m.clone())),
            m,
        }
    }

    /// r/s ≡ a (mod m) with |r|, s ≤ √(m/2), if it exists: Wang's
    /// algorithm, the half-extended Euclidean algorithm stopped at the bound.
    pub fn reconstruct(&self, a: &Int) -> Option<Rat> {
        let a = to_zint(&a.mod_floor(&self.m_int));
        let a = UBig::try_from(a).unwrap_or(UBig::ZERO);
        self.reconstruct_u(&a).map(|(n, d)| to_rat(&n, &d))
    }

    /// Wang's algorithm for a in 0..m: (numerator, positive denominator).
    pub(crate) fn reconstruct_u(&self, a: &UBig) -> Option<(ZInt, UBig)> {
        let (mut r0, mut r1) = (self.m.clone(), a.clone());
        let (mut s0, mut s1) = (ZInt::ZERO, ZInt::ONE);
        while r1 > self.bound {
            let (q, r2) = (&r0).div_rem(&r1);
            let s2 = &s0 - ZInt::from(q) * &s1;
            r0 = std::mem::replace(&mut r1, r2);
            s0 = std::mem::replace(&mut s1, s2);
        }
        let neg = s1 < ZInt::ZERO;
        let s = UBig::try_from(if neg { -s1 } else { s1 }).ok()?;
        if s.is_zero() || s > self.bound || !(&r1).gcd(&s).is_one() {
            return None;
        }
        let r = ZInt::from(r1);
        Some((if neg { -r } else { r }, s))
    }

    /// As [`Reconstructor::reconstruct_u`], trying the denominator `den`
    /// first: if a·den mod m (symmetric) is within the bound, the fraction
    /// is it over den (the reconstruction within the bounds is unique), at
    /// the cost of one product, one division and one gcd.
    pub(crate) fn reconstruct_with(&self, a: &UBig, den: &UBig) -> Option<(ZInt, UBig)> {
        if !den.is_zero() && *den <= self.bound {
            let c = (a * den) % &self.m;
            let (neg, mag) = if c > self.half { (true, &self.m - c) } else { (false, c) };
            if mag <= self.bound {
                let g = (&mag).gcd(den);
                let (n, d) = if g.is_one() {
                    (mag, den.clone())
                } else {
                    (mag / &g, den / &g)
                };
                let n = ZInt::from(n);
                return Some((if neg { -n } else { n }, d));
            }
        }
        self.reconstruct_u(a)
    }
}

/// n/d as a [`Rat`] (already in lowest terms, d > 0).
pub(crate) fn to_rat(n: &ZInt, d: &UBig) -> Rat {
    Rat::new_raw(from_zint(n), from_zint(&ZInt::from(d.clone())))
}

/// A basis lifted so far: for each element, monomial → residue modulo `modulus`.
struct Lift {
    lms: Vec<Monomial>,
    elems: Vec<HashMap<Monomial, Int>>,
    modulus: Int,
    primes: usize,
}

impl Lift {
    fn from_mod_p(basis: &[Poly<Fp>], p: u64) -> Lift {
        Lift {
            lms: basis.iter().map(|g| g.lm().expect("nonzero").clone()).collect(),
            elems: basis
                .iter()
                .map(|g| {
                    g.terms()
                        .iter()
                        .map(|(m, c)| (m.clone(), Int::from(c.value())))
                        .collect()
                })
                .collect(),
            modulus: Int::from(p),
            primes: 1,
        }
    }

    /// Chinese remaindering with one more prime's basis (same leading monomials).
    fn combine(&mut self, basis: &[Poly<Fp>], p: u64) {
        let pm = Int::from(p);
        // x ≡ a (mod M), x ≡ b (mod p): x = a + M·((b − a)·M⁻¹ mod p).
        let m_inv = mod_inverse(&self.modulus.mod_floor(&pm), &pm);
        for (acc, g) in self.elems.iter_mut().zip(basis) {
            let mut new: HashMap<Monomial, Int> = HashMap::with_capacity(acc.len().max(g.len()));
            let residues: HashMap<&Monomial, u64> = g.terms().iter().map(|(m, c)| (m, c.value())).collect();
            let mut keys: Vec<Monomial> = acc.keys().cloned().collect();
            keys.extend(g.terms().iter().map(|t| t.0.clone()).filter(|m| !acc.contains_key(m)));
            for m in keys {
                let a = acc.get(&m).cloned().unwrap_or_else(Int::zero);
                let b = Int::from(residues.get(&m).copied().unwrap_or(0));
                let t = ((b - &a) * &m_inv).mod_floor(&pm);
                new.insert(m, a + &self.modulus * t);
            }
            *acc = new;
        }
        self.modulus *= pm;
        self.primes += 1;
    }

    /// Rational reconstruction of every coefficient.
    fn reconstruct(&self, ring: &Ring) -> Option<Vec<Poly<Rat>>> {
        let mut out = Vec::with_capacity(self.elems.len());
        for e in &self.elems {
            let mut terms = Vec::with_capacity(e.len());
            for (m, a) in e {
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

/// a⁻¹ mod p.
pub fn mod_inverse(a: &Int, p: &Int) -> Int {
    let e = a.extended_gcd(p);
    e.x.mod_floor(p)
}

/// The reduced Gröbner basis over Q by the multi-modular method; same
/// result as [`crate::groebner::groebner`], verified over Q.
pub fn groebner_modular(
    ring: &Ring,
    polys: &[Poly<Rat>],
    opts: &GroebnerOptions,
) -> Result<(Vec<Poly<Rat>>, Stats), GroebnerError> {
    let start = std::time::Instant::now();
    let ints: Vec<Poly<Int>> = polys
        .iter()
        .filter(|p| !p.is_zero())
        .map(|p| to_primitive_integer(ring, &p.reorder(ring)))
        .collect();
    // Candidate lifts keyed by their leading monomials (majority vote against unlucky primes).
    let mut lifts: Vec<Lift> = Vec::new();
    let mut stats = Stats::default();
    let mut last_failed: Option<usize> = None;
    let mut trace = None;
    let mut used = 0;
    let outer = opts;
    for p in primes() {
        // Skip primes dividing a leading coefficient (they change the leading monomials).
        if ints
            .iter()
            .any(|f| f.lc().is_some_and(|c| (c % Int::from(p)).is_zero()))
        {
            continue;
        }
        used += 1;
        let prefixed = with_stage_prefix(outer, || format!("modular, prime {used}: "));
        let opts: &GroebnerOptions = &prefixed;
        let pm = Int::from(p);
        let mods: Vec<Poly<Fp>> = ints
            .iter()
            .map(|f| {
                let terms = f
                    .terms()
                    .iter()
                    .map(|(m, c)| (m.clone(), Fp::new(0, p).add_int(&c.mod_floor(&pm))))
                    .collect();
                Poly::from_terms(ring, terms)
            })
            .collect();
        // The first prime records its useful S-pairs; later primes replay them.
        let (basis, st) = match &trace {
            None => {
                let (b, st, t) = groebner_traced(ring, &mods, opts)?;
                trace = Some(t);
                (b, st)
            }
            Some(t) => match groebner_replay(ring, &mods, t, opts)? {
                Some(r) => r,
                None => groebner_in(ring, &mods, opts)?,
            },
        };
        stats.add_work(&st);
        let lms: Vec<&Monomial> = basis.iter().map(|g| g.lm().expect("nonzero")).collect();
        let k = match lifts.iter().position(|l| l.lms.iter().collect::<Vec<_>>() == lms) {
            Some(k) => {
                lifts[k].combine(&basis, p);
                k
            }
            None => {
                lifts.push(Lift::from_mod_p(&basis, p));
                lifts.len() - 1
            }
        };
        // Work with the lift backed by the most primes.
        let best = (0..lifts.len()).max_by_key(|&i| lifts[i].primes).expect("nonempty");
        if best != k || last_failed == Some(lifts[best].primes) {
            continue;
        }
        let Some(candidate) = lifts[best].reconstruct(ring) else {
            continue;
        };
        // Cheap test first: the candidate reduces to the basis mod a fresh prime is implied
        // by verification; verification over Q decides.
        let zbasis: Vec<Poly<ZInt>> = candidate
            .iter()
            .map(|g| to_primitive_integer(ring, g).map_coeffs(ring, to_zint))
            .collect();
        let zin: Vec<Poly<ZInt>> = ints.iter().map(|f| f.map_coeffs(ring, to_zint)).collect();
        if check_groebner_basis(ring, &zbasis, &zin, opts)? {
            let mut basis = candidate;
            for g in basis.iter_mut() {
                let lc = g.lc().cloned().unwrap_or_else(Rat::one);
                *g = g.scale(&lc.recip());
            }
            basis.sort_by(|a, b| ring.cmp(a.lm().expect("nonzero"), b.lm().expect("nonzero")));
            stats.basis_size = basis.len();
            stats.time = start.elapsed();
            return Ok((basis, stats));
        }
        last_failed = Some(lifts[best].primes);
    }
    unreachable!("there are infinitely many primes")
}

impl Fp {
    fn add_int(self, x: &Int) -> Fp {
        let v: u64 = x.try_into().unwrap_or(0);
        Fp::new(0, self.modulus()).add_u64(v)
    }
    fn add_u64(self, v: u64) -> Fp {
        use crate::coeff::Coeff;
        let p = self.modulus();
        self.add(&Fp::new((v % p) as i64, p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groebner::groebner;
    use crate::systems::{cyclic, katsura};

    #[test]
    fn rational_reconstruction_recovers_small_fractions() {
        let m = Int::from(1_000_000_007u64) * Int::from(998_244_353u64);
        for (n, d) in [(3i64, 7i64), (-22, 5), (1, 1), (0, 1), (123456, 789)] {
            let r = Rat::new(Int::from(n), Int::from(d));
            let a = (Int::from(n) * mod_inverse(&Int::from(d), &m)).mod_floor(&m);
            assert_eq!(rational_reconstruction(&a, &m), Some(r));
        }
    }

    #[test]
    fn modular_equals_fraction_free() {
        for (ring, polys) in [katsura(4), cyclic(5), katsura(5)] {
            let o = GroebnerOptions::default();
            let (a, _) = groebner_modular(&ring, &polys, &o).unwrap();
            let b = groebner(&ring, &polys, &o).unwrap().basis;
            assert_eq!(a, b);
        }
    }
}
