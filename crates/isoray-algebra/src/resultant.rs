//! Sylvester resultants with polynomial coefficients, and implicitization of
//! plane curves by resultant.

use crate::coeff::{Int, Rat};
use crate::monomial::{Monomial, MonomialOrder};
use crate::parse::to_primitive_integer;
use crate::poly::{divide, Poly, Ring};

/// The coefficients of f as a polynomial in variable `v`: `out[k]` is the
/// coefficient of v^k (a polynomial in the other variables).
pub fn coefficients_in(ring: &Ring, f: &Poly<Rat>, v: usize) -> Vec<Poly<Rat>> {
    let deg = f.degree_in(v).max(0) as usize;
    let mut buckets: Vec<Vec<(Monomial, Rat)>> = vec![Vec::new(); deg + 1];
    for (m, c) in f.terms() {
        let k = m.exp(v) as usize;
        let mut e = m.exps().to_vec();
        e[v] = 0;
        buckets[k].push((Monomial::new(&e), c.clone()));
    }
    buckets.into_iter().map(|t| Poly::from_terms(ring, t)).collect()
}

/// The Sylvester matrix of f and g with respect to variable `v`.
pub fn sylvester_matrix(ring: &Ring, f: &Poly<Rat>, g: &Poly<Rat>, v: usize) -> Vec<Vec<Poly<Rat>>> {
    let (a, b) = (coefficients_in(ring, f, v), coefficients_in(ring, g, v));
    let (m, n) = (a.len() - 1, b.len() - 1);
    let size = m + n;
    let mut rows = vec![vec![Poly::zero(); size]; size];
    for i in 0..n {
        for (k, c) in a.iter().rev().enumerate() {
            rows[i][i + k] = c.clone();
        }
    }
    for i in 0..m {
        for (k, c) in b.iter().rev().enumerate() {
            rows[n + i][i + k] = c.clone();
        }
    }
    rows
}

/// The determinant of a square matrix of polynomials by fraction-free
/// (Bareiss) elimination: every division is exact.
pub fn determinant(ring: &Ring, mut m: Vec<Vec<Poly<Rat>>>) -> Poly<Rat> {
    let n = m.len();
    if n == 0 {
        return Poly::constant(ring, Rat::from_integer(Int::from(1)));
    }
    let mut sign = false;
    let mut prev = Poly::constant(ring, Rat::from_integer(Int::from(1)));
    for k in 0..n - 1 {
        if m[k][k].is_zero() {
            let Some(r) = (k + 1..n).find(|&r| !m[r][k].is_zero()) else {
                return Poly::zero();
            };
            m.swap(k, r);
            sign = !sign;
        }
        for i in k + 1..n {
            for j in k + 1..n {
                let t = m[k][k].mul(ring, &m[i][j]).sub(ring, &m[i][k].mul(ring, &m[k][j]));
                let (q, r) = divide(ring, &t, std::slice::from_ref(&prev));
                debug_assert!(r.is_zero(), "Bareiss divisions are exact");
                m[i][j] = q.into_iter().next().unwrap_or_else(Poly::zero);
            }
        }
        prev = m[k][k].clone();
    }
    let d = m[n - 1][n - 1].clone();
    if sign {
        d.neg()
    } else {
        d
    }
}

/// Res_v(f, g): the Sylvester resultant with respect to variable `v`.
pub fn resultant(ring: &Ring, f: &Poly<Rat>, g: &Poly<Rat>, v: usize) -> Poly<Rat> {
    if f.is_zero() || g.is_zero() {
        return Poly::zero();
    }
    if f.degree_in(v) <= 0 && g.degree_in(v) <= 0 {
        return Poly::constant(ring, Rat::from_integer(Int::from(1)));
    }
    determinant(ring, sylvester_matrix(ring, f, g, v))
}

/// Implicitizes a plane curve x = f₁/q₁, y = f₂/q₂ (in one parameter) by
/// Res_t(q₁x − f₁, q₂y − f₂), as a primitive integer polynomial in (x, y).
/// The resultant is a power of the implicit equation when the
/// parametrization is not proper (it covers the curve k times); the repeated
/// factors are stripped with [`crate::gcd::squarefree`].
pub fn implicitize_curve_resultant(x: &str, y: &str, param: &str) -> Result<Poly<Int>, crate::implicit::ImplicitError> {
    let funcs = crate::implicit::parse_parametrization(&[x, y], &[param])?;
    let ring = Ring::new(&[param, "x", "y"], MonomialOrder::DegRevLex);
    let lift = |p: &Poly<Rat>| p.embed(&ring, &[0]);
    let one = Rat::from_integer(Int::from(1));
    let xv = Poly::monomial(Monomial::var(3, 1, 1), one.clone());
    let yv = Poly::monomial(Monomial::var(3, 2, 1), one);
    let f = lift(&funcs[0].den).mul(&ring, &xv).sub(&ring, &lift(&funcs[0].num));
    let g = lift(&funcs[1].den).mul(&ring, &yv).sub(&ring, &lift(&funcs[1].num));
    let r = resultant(&ring, &f, &g, 0);
    let out = Ring::new(&["x", "y"], MonomialOrder::DegRevLex);
    let projected = Poly::from_terms(
        &out,
        r.terms()
            .iter()
            .map(|(m, c)| (Monomial::new(&m.exps()[1..]), c.clone()))
            .collect(),
    );
    Ok(to_primitive_integer(&out, &projected))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parse::parse_poly;

    #[test]
    fn univariate_resultants() {
        let ring = Ring::new(&["x"], MonomialOrder::DegRevLex);
        let p = |s: &str| parse_poly(&ring, s).unwrap();
        // Res(x^2 - 1, x - 2) = (2)^2 - 1 = 3 (product of f over the roots of g, sign +).
        assert_eq!(resultant(&ring, &p("x^2 - 1"), &p("x - 2"), 0), p("3"));
        // Common root: zero.
        assert_eq!(resultant(&ring, &p("x^2 - 1"), &p("x - 1"), 0), p("0"));
        // Res(ax^2+bx+c, 2ax+b) = -a * discriminant: for x^2 - 3x + 2: -(9 - 8) = -1.
        assert_eq!(resultant(&ring, &p("x^2 - 3*x + 2"), &p("2*x - 3"), 0), p("-1"));
    }

    #[test]
    fn bivariate_resultant_eliminates() {
        // Res_y(x^2 + y^2 - 1, x - y) = 2x^2 - 1.
        let ring = Ring::new(&["x", "y"], MonomialOrder::DegRevLex);
        let p = |s: &str| parse_poly(&ring, s).unwrap();
        assert_eq!(resultant(&ring, &p("x^2 + y^2 - 1"), &p("x - y"), 1), p("2*x^2 - 1"));
    }
}
