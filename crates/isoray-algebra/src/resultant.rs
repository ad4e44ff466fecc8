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

/// Homogenizes f with respect to the variables `vars` using the variable `h`
/// (thesis §1.7: ʰf = h^D·f(x/h)): every term c·m gets the factor
/// h^(D − deg_vars m), where D is `degree` or, when `None`, the largest degree
/// of a term in `vars`. `h` must not occur in f and must not be one of `vars`;
/// a `degree` below the largest term degree is raised to it.
pub fn homogenize(ring: &Ring, f: &Poly<Rat>, vars: &[usize], h: usize, degree: Option<u32>) -> Poly<Rat> {
    let deg = |m: &Monomial| vars.iter().map(|&v| m.exp(v) as u32).sum::<u32>();
    let top = f.terms().iter().map(|(m, _)| deg(m)).max().unwrap_or(0);
    let d = degree.unwrap_or(top).max(top);
    let terms = f
        .terms()
        .iter()
        .map(|(m, c)| {
            let mut e = m.exps().to_vec();
            e[h] += (d - deg(m)) as u16;
            (Monomial::new(&e), c.clone())
        })
        .collect();
    Poly::from_terms(ring, terms)
}

/// The resultant of n + 1 polynomials of degree ≤ 1 in the n variables
/// `vars` (thesis Thm 1.11): the determinant of their coefficient matrix,
/// row i holding the constant term of `polys[i]` and then its coefficients of
/// `vars` in order. Zero exactly when the linear system has a common solution
/// (for coefficients in a field), or the polynomials are not of degree ≤ 1.
/// Returns `None` when the count is not `vars.len() + 1` or a polynomial has a
/// term of degree > 1 in `vars`.
pub fn linear_resultant(ring: &Ring, polys: &[Poly<Rat>], vars: &[usize]) -> Option<Poly<Rat>> {
    if polys.len() != vars.len() + 1 {
        return None;
    }
    let mut rows = Vec::with_capacity(polys.len());
    for f in polys {
        let mut row = vec![Vec::new(); vars.len() + 1];
        for (m, c) in f.terms() {
            let used: Vec<usize> = (0..vars.len()).filter(|&k| m.exp(vars[k]) > 0).collect();
            let col = match used.as_slice() {
                [] => 0,
                [k] if m.exp(vars[*k]) == 1 => k + 1,
                _ => return None,
            };
            let mut e = m.exps().to_vec();
            if col > 0 {
                e[vars[col - 1]] = 0;
            }
            row[col].push((Monomial::new(&e), c.clone()));
        }
        rows.push(row.into_iter().map(|t| Poly::from_terms(ring, t)).collect());
    }
    Some(determinant(ring, rows))
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
    fn linear_resultant_of_example_1_3() {
        // Thesis Ex. 1.3: x = s + t, y = s, z = t; the auxiliary system
        // s + t − x, s − y, t − z has coefficient matrix [[−x, 1, 1], [−y, 1, 0], [−z, 0, 1]]
        // whose determinant is −x + y + z.
        let ring = Ring::new(&["s", "t", "x", "y", "z"], MonomialOrder::DegRevLex);
        let p = |s: &str| parse_poly(&ring, s).unwrap();
        let polys = [p("s + t - x"), p("s - y"), p("t - z")];
        assert_eq!(linear_resultant(&ring, &polys, &[0, 1]), Some(p("-x + y + z")));
        // The same determinant written out.
        let m = vec![
            vec![p("-x"), p("1"), p("1")],
            vec![p("-y"), p("1"), p("0")],
            vec![p("-z"), p("0"), p("1")],
        ];
        assert_eq!(determinant(&ring, m), p("-x + y + z"));
        // Not linear, or the wrong count: no linear resultant.
        assert_eq!(
            linear_resultant(&ring, &[p("s^2 - x"), p("s - y"), p("t")], &[0, 1]),
            None
        );
        assert_eq!(
            linear_resultant(&ring, &[p("s*t - x"), p("s - y"), p("t")], &[0, 1]),
            None
        );
        assert_eq!(linear_resultant(&ring, &[p("s - y"), p("t")], &[0, 1]), None);
    }

    #[test]
    fn homogenization() {
        let ring = Ring::new(&["s", "t", "u"], MonomialOrder::DegRevLex);
        let p = |s: &str| parse_poly(&ring, s).unwrap();
        assert_eq!(
            homogenize(&ring, &p("s^2 + t + 1"), &[0, 1], 2, None),
            p("s^2 + t*u + u^2")
        );
        assert_eq!(homogenize(&ring, &p("s - 1"), &[0, 1], 2, Some(3)), p("s*u^2 - u^3"));
        // Dehomogenizing (u = 1) gives f back.
        let f = p("3*s^3*t - s*t + 7");
        let h = homogenize(&ring, &f, &[0, 1], 2, None);
        assert_eq!(h.substitute(&ring, &[None, None, Some(p("1"))]), f);
    }

    #[test]
    fn bivariate_resultant_eliminates() {
        // Res_y(x^2 + y^2 - 1, x - y) = 2x^2 - 1.
        let ring = Ring::new(&["x", "y"], MonomialOrder::DegRevLex);
        let p = |s: &str| parse_poly(&ring, s).unwrap();
        assert_eq!(resultant(&ring, &p("x^2 + y^2 - 1"), &p("x - y"), 1), p("2*x^2 - 1"));
    }
}
