//! FGLM: converts a reduced Gröbner basis of a zero-dimensional ideal from
//! one order (usually grevlex, cheap to compute) to another (usually lex,
//! which exposes the solutions) by linear algebra in the quotient ring
//! (Faugère, Gianni, Lazard, Mora 1993).

use std::collections::{BTreeSet, HashMap};

use num_traits::{One, Zero};

use crate::coeff::Rat;
use crate::groebner::normal_form;
use crate::monomial::{Monomial, MonomialOrder};
use crate::poly::{Poly, Ring};

/// Why FGLM could not run.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FglmError {
    /// The ideal has infinitely many solutions (the quotient is infinite-dimensional).
    #[error("the ideal is not zero-dimensional: no power of `{var}` is a leading monomial")]
    NotZeroDimensional {
        /// A variable with no pure power among the leading monomials.
        var: String,
    },
    /// The quotient ring is larger than the limit.
    #[error("the quotient ring has more than {limit} standard monomials")]
    TooLarge {
        /// The limit.
        limit: usize,
    },
}

/// The standard monomials (those not divisible by any leading monomial) of a
/// zero-dimensional Gröbner basis, in increasing order.
pub fn standard_monomials<C: crate::coeff::Coeff>(
    ring: &Ring,
    basis: &[Poly<C>],
    limit: usize,
) -> Result<Vec<Monomial>, FglmError> {
    let n = ring.nvars();
    let lms: Vec<&Monomial> = basis.iter().filter_map(|p| p.lm()).collect();
    for i in 0..n {
        let pure = lms
            .iter()
            .any(|m| m.exp(i) > 0 && (0..n).all(|j| j == i || m.exp(j) == 0));
        if !pure {
            return Err(FglmError::NotZeroDimensional {
                var: ring.vars()[i].clone(),
            });
        }
    }
    let mut out = Vec::new();
    let mut stack = vec![Monomial::one(n)];
    let mut seen = BTreeSet::new();
    while let Some(m) = stack.pop() {
        if !seen.insert(m.exps().to_vec()) || lms.iter().any(|l| l.divides(&m)) {
            continue;
        }
        out.push(m.clone());
        if out.len() > limit {
            return Err(FglmError::TooLarge { limit });
        }
        for i in 0..n {
            stack.push(m.mul(&Monomial::var(n, i, 1)));
        }
    }
    out.sort_by(|a, b| ring.cmp(a, b));
    Ok(out)
}

/// Converts the reduced basis `basis` (in `from`'s order) of a zero-dimensional
/// ideal into the reduced basis for `to`'s order (same variables).
pub fn fglm(from: &Ring, basis: &[Poly<Rat>], to: &Ring) -> Result<Vec<Poly<Rat>>, FglmError> {
    let n = from.nvars();
    let staircase = standard_monomials(from, basis, 1_000_000)?;
    let index: HashMap<Vec<u16>, usize> = staircase
        .iter()
        .enumerate()
        .map(|(i, m)| (m.exps().to_vec(), i))
        .collect();
    let dim = staircase.len();
    let nf_vector = |m: &Monomial| -> Vec<Rat> {
        let nf = normal_form(from, &Poly::monomial(m.clone(), Rat::one()), basis);
        let mut v = vec![Rat::zero(); dim];
        for (t, c) in nf.terms() {
            v[index[t.exps()]] = c.clone();
        }
        v
    };
    // Echelon rows: (pivot column, reduced vector, combination of new standard monomials).
    let mut rows: Vec<(usize, Vec<Rat>, Vec<Rat>)> = Vec::new();
    let mut new_staircase: Vec<Monomial> = Vec::new();
    let mut result: Vec<Poly<Rat>> = Vec::new();
    let mut candidates: BTreeSet<Key> = BTreeSet::new();
    candidates.insert(Key::new(to, Monomial::one(n)));
    let mut done: BTreeSet<Vec<u16>> = BTreeSet::new();
    while let Some(k) = candidates.pop_first() {
        let m = k.mono;
        if !done.insert(m.exps().to_vec()) {
            continue;
        }
        if result.iter().any(|g| g.lm().is_some_and(|l| l.divides(&m))) {
            continue;
        }
        let mut v = nf_vector(&m);
        let mut comb = vec![Rat::zero(); new_staircase.len() + 1];
        comb[new_staircase.len()] = Rat::one();
        for (piv, row, rc) in &rows {
            let c = v[*piv].clone();
            if c.is_zero() {
                continue;
            }
            for (a, b) in v.iter_mut().zip(row) {
                *a -= &c * b;
            }
            for (a, b) in comb.iter_mut().zip(rc) {
                *a -= &c * b;
            }
        }
        match v.iter().position(|x| !x.is_zero()) {
            None => {
                // m ≡ −Σ comb_j b_j: the polynomial Σ comb_j b_j + m is in the ideal.
                let mut terms = vec![(m.clone(), Rat::one())];
                for (j, c) in comb.iter().enumerate().take(new_staircase.len()) {
                    if !c.is_zero() {
                        terms.push((new_staircase[j].clone(), c.clone()));
                    }
                }
                result.push(Poly::from_terms(to, terms));
            }
            Some(piv) => {
                let inv = v[piv].recip();
                for a in v.iter_mut() {
                    *a *= &inv;
                }
                for a in comb.iter_mut() {
                    *a *= &inv;
                }
                // Keep all rows' combination vectors the same length.
                for (_, _, rc) in rows.iter_mut() {
                    rc.push(Rat::zero());
                }
                // Eliminate the new pivot from the older rows is not needed for
                // reduction order: rows are applied in creation order.
                rows.push((piv, v, comb));
                new_staircase.push(m.clone());
                for i in 0..n {
                    candidates.insert(Key::new(to, m.mul(&Monomial::var(n, i, 1))));
                }
            }
        }
    }
    result.sort_by(|a, b| to.cmp(a.lm().expect("nonzero"), b.lm().expect("nonzero")));
    Ok(result)
}

/// A monomial ordered by a ring's order, for the candidate set.
struct Key {
    mono: Monomial,
    order: MonomialOrder,
}

impl Key {
    fn new(ring: &Ring, mono: Monomial) -> Key {
        Key {
            mono,
            order: ring.order().clone(),
        }
    }
}

impl PartialEq for Key {
    fn eq(&self, o: &Self) -> bool {
        self.mono == o.mono
    }
}
impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Key {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.order.cmp(&self.mono, &o.mono)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groebner::{groebner, GroebnerOptions};
    use crate::systems::{cyclic, katsura};

    #[test]
    fn fglm_matches_direct_lex() {
        for (ring, polys) in [katsura(2), cyclic(4)] {
            let o = GroebnerOptions::default();
            if ring.nvars() == 4 && polys.len() == 4 && ring.vars()[0] == "x1" {
                // cyclic-4 is not zero-dimensional.
                let g = groebner(&ring, &polys, &o).unwrap().basis;
                let lex = ring.with_order(MonomialOrder::Lex);
                assert!(matches!(
                    fglm(&ring, &g, &lex),
                    Err(FglmError::NotZeroDimensional { .. })
                ));
                continue;
            }
            let g = groebner(&ring, &polys, &o).unwrap().basis;
            let lex = ring.with_order(MonomialOrder::Lex);
            let via_fglm = fglm(&ring, &g, &lex).unwrap();
            let direct = groebner(&lex, &polys, &o).unwrap().basis;
            assert_eq!(via_fglm, direct);
        }
        // katsura-4 in lex (a direct lex computation over Q would be slow): the
        // converted basis contains every input in its ideal and has a univariate
        // last element whose degree is the number of solutions (16).
        let (ring, polys) = katsura(4);
        let g = groebner(&ring, &polys, &GroebnerOptions::default()).unwrap().basis;
        let lex = ring.with_order(MonomialOrder::Lex);
        let l = fglm(&ring, &g, &lex).unwrap();
        for f in &polys {
            assert!(crate::groebner::normal_form(&lex, &f.reorder(&lex), &l).is_zero());
        }
        let last = &l[0];
        assert!((0..4).all(|i| !last.uses_var(i)), "{}", last.display(&lex));
        assert_eq!(last.degree(), 16);
        assert_eq!(standard_monomials(&ring, &g, 1000).unwrap().len(), 16);
    }
}
