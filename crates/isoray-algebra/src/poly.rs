//! Sparse multivariate polynomials over a [`Coeff`] domain, in a [`Ring`]
//! that names the variables and fixes the monomial order.

use std::cmp::Ordering;
use std::fmt::Write as _;

use crate::coeff::{Coeff, Domain, Field};
use crate::monomial::{Monomial, MonomialOrder};

/// The polynomial ring: variable names (x₀ > x₁ > …) and a monomial order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ring {
    vars: Vec<String>,
    order: MonomialOrder,
}

impl Ring {
    /// A ring with these variables and order.
    pub fn new<S: AsRef<str>>(vars: &[S], order: MonomialOrder) -> Ring {
        Ring {
            vars: vars.iter().map(|s| s.as_ref().to_string()).collect(),
            order,
        }
    }
    /// Variable names.
    pub fn vars(&self) -> &[String] {
        &self.vars
    }
    /// Number of variables.
    pub fn nvars(&self) -> usize {
        self.vars.len()
    }
    /// The monomial order.
    pub fn order(&self) -> &MonomialOrder {
        &self.order
    }
    /// Index of a variable by name.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.vars.iter().position(|v| v == name)
    }
    /// Compares monomials in this ring's order.
    pub fn cmp(&self, a: &Monomial, b: &Monomial) -> Ordering {
        self.order.cmp(a, b)
    }
    /// The same variables with another order.
    pub fn with_order(&self, order: MonomialOrder) -> Ring {
        Ring {
            vars: self.vars.clone(),
            order,
        }
    }
}

/// A polynomial: terms with nonzero coefficients, sorted by decreasing monomial
/// in the order of the ring it was built in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Poly<C> {
    terms: Vec<(Monomial, C)>,
}

impl<C: Coeff> Poly<C> {
    /// The zero polynomial.
    pub fn zero() -> Self {
        Poly { terms: Vec::new() }
    }

    /// From terms in any order; like terms are combined and zeros dropped.
    pub fn from_terms(ring: &Ring, mut terms: Vec<(Monomial, C)>) -> Self {
        terms.sort_by(|a, b| ring.cmp(&b.0, &a.0));
        let mut out: Vec<(Monomial, C)> = Vec::with_capacity(terms.len());
        for (m, c) in terms {
            match out.last_mut() {
                Some((lm, lc)) if *lm == m => *lc = lc.add(&c),
                _ => out.push((m, c)),
            }
            if out.last().is_some_and(|t| t.1.is_zero()) {
                out.pop();
            }
        }
        Poly { terms: out }
    }

    /// From terms already sorted by decreasing monomial, distinct, nonzero.
    pub fn from_sorted(terms: Vec<(Monomial, C)>) -> Self {
        Poly { terms }
    }

    /// The constant `c`.
    pub fn constant(ring: &Ring, c: C) -> Self {
        if c.is_zero() {
            return Poly::zero();
        }
        Poly {
            terms: vec![(Monomial::one(ring.nvars()), c)],
        }
    }

    /// The monomial c·m.
    pub fn monomial(m: Monomial, c: C) -> Self {
        if c.is_zero() {
            return Poly::zero();
        }
        Poly { terms: vec![(m, c)] }
    }

    /// The terms, largest first.
    pub fn terms(&self) -> &[(Monomial, C)] {
        &self.terms
    }

    /// Consumes the polynomial into its terms.
    pub fn into_terms(self) -> Vec<(Monomial, C)> {
        self.terms
    }

    /// True for 0.
    pub fn is_zero(&self) -> bool {
        self.terms.is_empty()
    }

    /// Number of terms.
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// True for 0 (no terms).
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// Leading monomial.
    pub fn lm(&self) -> Option<&Monomial> {
        self.terms.first().map(|t| &t.0)
    }

    /// Leading coefficient.
    pub fn lc(&self) -> Option<&C> {
        self.terms.first().map(|t| &t.1)
    }

    /// True when the polynomial is a nonzero constant.
    pub fn is_constant(&self) -> bool {
        self.terms.len() == 1 && self.terms[0].0.is_one() || self.terms.is_empty()
    }

    /// Total degree (−1 for 0).
    pub fn degree(&self) -> i64 {
        self.terms.iter().map(|t| t.0.degree() as i64).max().unwrap_or(-1)
    }

    /// Degree in variable `i` (−1 for 0).
    pub fn degree_in(&self, i: usize) -> i64 {
        self.terms.iter().map(|t| t.0.exp(i) as i64).max().unwrap_or(-1)
    }

    /// True when variable `i` occurs.
    pub fn uses_var(&self, i: usize) -> bool {
        self.terms.iter().any(|t| t.0.exp(i) > 0)
    }

    /// −self
    pub fn neg(&self) -> Self {
        Poly {
            terms: self.terms.iter().map(|(m, c)| (m.clone(), c.neg())).collect(),
        }
    }

    /// c·self
    pub fn scale(&self, c: &C) -> Self {
        if c.is_zero() {
            return Poly::zero();
        }
        Poly {
            terms: self.terms.iter().map(|(m, x)| (m.clone(), x.mul(c))).collect(),
        }
    }

    /// c·m·self (the order is preserved by multiplying by a monomial).
    pub fn mul_term(&self, m: &Monomial, c: &C) -> Self {
        if c.is_zero() {
            return Poly::zero();
        }
        Poly {
            terms: self.terms.iter().map(|(t, x)| (t.mul(m), x.mul(c))).collect(),
        }
    }

    /// a·self + b·other, merged in one pass (b = None means b = 1).
    pub fn lin_comb(&self, ring: &Ring, a: Option<&C>, other: &Self, b: Option<&C>) -> Self {
        let mut out = Vec::with_capacity(self.terms.len() + other.terms.len());
        let (mut i, mut j) = (0, 0);
        let sa = |c: &C| a.map_or_else(|| c.clone(), |a| c.mul(a));
        let sb = |c: &C| b.map_or_else(|| c.clone(), |b| c.mul(b));
        while i < self.terms.len() && j < other.terms.len() {
            match ring.cmp(&self.terms[i].0, &other.terms[j].0) {
                Ordering::Greater => {
                    out.push((self.terms[i].0.clone(), sa(&self.terms[i].1)));
                    i += 1;
                }
                Ordering::Less => {
                    out.push((other.terms[j].0.clone(), sb(&other.terms[j].1)));
                    j += 1;
                }
                Ordering::Equal => {
                    let c = sa(&self.terms[i].1).add(&sb(&other.terms[j].1));
                    if !c.is_zero() {
                        out.push((self.terms[i].0.clone(), c));
                    }
                    i += 1;
                    j += 1;
                }
            }
        }
        out.extend(self.terms[i..].iter().map(|(m, c)| (m.clone(), sa(c))));
        out.extend(other.terms[j..].iter().map(|(m, c)| (m.clone(), sb(c))));
        Poly { terms: out }
    }

    /// self + o
    pub fn add(&self, ring: &Ring, o: &Self) -> Self {
        self.lin_comb(ring, None, o, None)
    }

    /// self − o
    pub fn sub(&self, ring: &Ring, o: &Self) -> Self {
        match o.lc() {
            None => self.clone(),
            Some(c) => {
                let m1 = c.one_like().neg();
                self.lin_comb(ring, None, o, Some(&m1))
            }
        }
    }

    /// self · o
    pub fn mul(&self, ring: &Ring, o: &Self) -> Self {
        if self.is_zero() || o.is_zero() {
            return Poly::zero();
        }
        let (small, big) = if self.len() <= o.len() { (self, o) } else { (o, self) };
        let mut terms = Vec::with_capacity(small.len() * big.len());
        for (m, c) in &small.terms {
            for (n, d) in &big.terms {
                terms.push((m.mul(n), c.mul(d)));
            }
        }
        Poly::from_terms(ring, terms)
    }

    /// self^e (for self = 0 the result is 0, even for e = 0).
    pub fn pow(&self, ring: &Ring, mut e: u32) -> Self {
        let Some(c) = self.lc() else {
            // 0^e = 0; 0^0 has no coefficient to build 1 from, callers handle it.
            return Poly::zero();
        };
        let mut acc = Poly::constant(ring, c.one_like());
        let mut base = self.clone();
        while e > 0 {
            if e & 1 == 1 {
                acc = acc.mul(ring, &base);
            }
            e >>= 1;
            if e > 0 {
                base = base.mul(ring, &base);
            }
        }
        acc
    }

    /// ∂/∂x_i
    pub fn derivative(&self, ring: &Ring, i: usize) -> Self {
        let terms = self
            .terms
            .iter()
            .filter(|(m, _)| m.exp(i) > 0)
            .map(|(m, c)| {
                let mut e = m.exps().to_vec();
                let k = e[i];
                e[i] -= 1;
                (Monomial::new(&e), c.mul(&c.int_like(k as i64)))
            })
            .filter(|(_, c)| !c.is_zero())
            .collect();
        Poly::from_terms(ring, terms)
    }

    /// Substitutes polynomials for variables (`values[i]` for x_i; `None`
    /// keeps x_i), in the ring `ring`.
    pub fn substitute(&self, ring: &Ring, values: &[Option<Poly<C>>]) -> Self {
        let mut acc = Poly::zero();
        let mut powers: Vec<Vec<Poly<C>>> = vec![Vec::new(); ring.nvars()];
        for (m, c) in &self.terms {
            let mut keep = vec![0u16; ring.nvars()];
            let mut term = Poly::constant(ring, c.clone());
            for (i, v) in values.iter().enumerate().take(ring.nvars()) {
                let e = m.exp(i) as usize;
                match v {
                    Some(v) if e > 0 => {
                        while powers[i].len() < e {
                            let next = match powers[i].last() {
                                None => v.clone(),
                                Some(last) => last.mul(ring, v),
                            };
                            powers[i].push(next);
                        }
                        term = term.mul(ring, &powers[i][e - 1]);
                    }
                    _ => keep[i] = e as u16,
                }
            }
            let kept = Monomial::new(&keep);
            term = term.mul_term(&kept, &c.one_like());
            acc = acc.add(ring, &term);
        }
        acc
    }

    /// Converts coefficients.
    pub fn map_coeffs<D: Coeff>(&self, ring: &Ring, f: impl Fn(&C) -> D) -> Poly<D> {
        Poly::from_terms(ring, self.terms.iter().map(|(m, c)| (m.clone(), f(c))).collect())
    }

    /// The same polynomial re-sorted for another order on the same variables.
    pub fn reorder(&self, ring: &Ring) -> Self {
        let mut terms = self.terms.clone();
        terms.sort_by(|a, b| ring.cmp(&b.0, &a.0));
        Poly { terms }
    }

    /// Moves the polynomial into a ring whose variables are a superset, given
    /// the target index of each of this ring's variables.
    pub fn embed(&self, target: &Ring, map: &[usize]) -> Self {
        let terms = self
            .terms
            .iter()
            .map(|(m, c)| {
                let mut e = vec![0u16; target.nvars()];
                for (i, &j) in map.iter().enumerate() {
                    e[j] = m.exp(i);
                }
                (Monomial::new(&e), c.clone())
            })
            .collect();
        Poly::from_terms(target, terms)
    }

    /// Prints in the usual syntax: `x^2*y - 3/2*z + 1`.
    pub fn display(&self, ring: &Ring) -> String {
        if self.terms.is_empty() {
            return "0".to_string();
        }
        let mut s = String::new();
        for (k, (m, c)) in self.terms.iter().enumerate() {
            let neg = c.is_negative();
            let abs = if neg { c.neg() } else { c.clone() };
            if k == 0 {
                if neg {
                    s.push('-');
                }
            } else {
                s.push_str(if neg { " - " } else { " + " });
            }
            let mono = monomial_text(ring, m);
            if mono.is_empty() {
                let _ = write!(s, "{abs}");
            } else if abs.is_one() {
                s.push_str(&mono);
            } else {
                let _ = write!(s, "{abs}*{mono}");
            }
        }
        s
    }
}

impl<C: Domain> Poly<C> {
    /// Normalised copy: monic over a field, primitive with positive leading coefficient over Z.
    pub fn normalized(mut self) -> Self {
        let mut cs: Vec<C> = self.terms.iter().map(|t| t.1.clone()).collect();
        C::normalize(&mut cs);
        for (t, c) in self.terms.iter_mut().zip(cs) {
            t.1 = c;
        }
        self
    }
}

impl<C: Field> Poly<C> {
    /// Monic copy (leading coefficient 1).
    pub fn monic(&self) -> Self {
        match self.lc() {
            None => Poly::zero(),
            Some(c) => self.scale(&c.inv()),
        }
    }
}

fn monomial_text(ring: &Ring, m: &Monomial) -> String {
    let mut parts = Vec::new();
    for (i, &e) in m.exps().iter().enumerate() {
        if e == 0 {
            continue;
        }
        let name = ring.vars().get(i).map(|s| s.as_str()).unwrap_or("?");
        parts.push(if e == 1 {
            name.to_string()
        } else {
            format!("{name}^{e}")
        });
    }
    parts.join("*")
}

/// Multivariate division with remainder over a field: f = Σ qᵢ·gᵢ + r where no
/// term of r is divisible by any leading monomial of the gᵢ (Cox–Little–O'Shea,
/// §2.3: the divisors are tried in the given order).
pub fn divide<C: Field>(ring: &Ring, f: &Poly<C>, gs: &[Poly<C>]) -> (Vec<Poly<C>>, Poly<C>) {
    let mut qs: Vec<Vec<(Monomial, C)>> = vec![Vec::new(); gs.len()];
    let mut rem: Vec<(Monomial, C)> = Vec::new();
    let mut p = f.clone();
    while let Some((lm, lc)) = p.terms.first().cloned() {
        let mut divided = false;
        for (i, g) in gs.iter().enumerate() {
            let (Some(glm), Some(glc)) = (g.lm(), g.lc()) else {
                continue;
            };
            if let Some(q) = glm.quotient(&lm) {
                let c = lc.div(glc);
                p = p.sub(ring, &g.mul_term(&q, &c));
                qs[i].push((q, c));
                divided = true;
                break;
            }
        }
        if !divided {
            rem.push((lm, lc));
            p.terms.remove(0);
        }
    }
    (
        qs.into_iter().map(|t| Poly::from_terms(ring, t)).collect(),
        Poly { terms: rem },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coeff::Rat;
    use crate::parse::parse_poly;

    fn r(vars: &[&str], order: MonomialOrder) -> Ring {
        Ring::new(vars, order)
    }

    #[test]
    fn arithmetic_and_printing() {
        let ring = r(&["x", "y", "z"], MonomialOrder::DegRevLex);
        let p = |s: &str| parse_poly(&ring, s).unwrap();
        let a = p("x^2*y - 3/2*z + 1");
        assert_eq!(a.display(&ring), "x^2*y - 3/2*z + 1");
        let b = p("(x + y)^2");
        assert_eq!(b.display(&ring), "x^2 + 2*x*y + y^2");
        assert_eq!(b.sub(&ring, &b), Poly::zero());
        assert_eq!(p("(x - y)*(x + y)"), p("x^2 - y^2"));
        assert_eq!(p("x^3*y").derivative(&ring, 0), p("3*x^2*y"));
        // Substitution: x -> y + 1 in x^2.
        let s = p("x^2").substitute(&ring, &[Some(p("y + 1")), None, None]);
        assert_eq!(s, p("y^2 + 2*y + 1"));
        assert_eq!(p("-x").display(&ring), "-x");
        assert_eq!(p("0").display(&ring), "0");
    }

    #[test]
    fn division_textbook() {
        // Cox–Little–O'Shea §2.3 Example 2: f = x^2 y + x y^2 + y^2 by (xy - 1, y^2 - 1), lex x > y:
        // q1 = x + y, q2 = 1, r = x + y + 1.
        let ring = r(&["x", "y"], MonomialOrder::Lex);
        let p = |s: &str| parse_poly(&ring, s).unwrap();
        let (q, rem) = divide::<Rat>(&ring, &p("x^2*y + x*y^2 + y^2"), &[p("x*y - 1"), p("y^2 - 1")]);
        assert_eq!(q, vec![p("x + y"), p("1")]);
        assert_eq!(rem, p("x + y + 1"));
        // With the divisors swapped: q1 = x + 1, q2 = x, r = 2x + 1.
        let (q, rem) = divide::<Rat>(&ring, &p("x^2*y + x*y^2 + y^2"), &[p("y^2 - 1"), p("x*y - 1")]);
        assert_eq!(q, vec![p("x + 1"), p("x")]);
        assert_eq!(rem, p("2*x + 1"));
    }
}
