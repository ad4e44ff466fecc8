//! Exact division, multivariate gcd and square-free parts over Q.
//!
//! The gcd uses the identity gcd(f, g) = f·g / lcm(f, g), where lcm(f, g)
//! generates the principal ideal ⟨f⟩ ∩ ⟨g⟩, found by elimination
//! ([`crate::ideal::intersection`]). Square-free parts divide by the gcd with
//! all partial derivatives (characteristic 0).

use num_traits::One;

use crate::coeff::Rat;
use crate::groebner::{GroebnerError, GroebnerOptions};
use crate::ideal::intersection;
use crate::poly::{divide, Poly, Ring};

/// f / g when g divides f exactly, else `None`.
pub fn exact_div(ring: &Ring, f: &Poly<Rat>, g: &Poly<Rat>) -> Option<Poly<Rat>> {
    if g.is_zero() {
        return None;
    }
    let (q, r) = divide(ring, f, std::slice::from_ref(g));
    r.is_zero().then(|| q.into_iter().next().unwrap_or_else(Poly::zero))
}

/// The monic greatest common divisor of f and g (0 when both are 0).
pub fn gcd(ring: &Ring, f: &Poly<Rat>, g: &Poly<Rat>, opts: &GroebnerOptions) -> Result<Poly<Rat>, GroebnerError> {
    if f.is_zero() {
        return Ok(g.monic());
    }
    if g.is_zero() {
        return Ok(f.monic());
    }
    if f.is_constant() || g.is_constant() {
        return Ok(Poly::constant(ring, Rat::one()));
    }
    let l = intersection(ring, std::slice::from_ref(f), std::slice::from_ref(g), opts)?;
    let lcm = l
        .into_iter()
        .next()
        .expect("the intersection of two principal ideals is principal and nonzero");
    let prod = f.mul(ring, g);
    Ok(exact_div(ring, &prod, &lcm).expect("lcm divides f·g").monic())
}

/// The square-free part of f: f divided by gcd(f, ∂f/∂x₁, …, ∂f/∂xₙ), monic.
pub fn squarefree(ring: &Ring, f: &Poly<Rat>, opts: &GroebnerOptions) -> Result<Poly<Rat>, GroebnerError> {
    let mut g = f.monic();
    for i in 0..ring.nvars() {
        let d = f.derivative(ring, i);
        if !d.is_zero() {
            g = gcd(ring, &g, &d, opts)?;
        }
        if g.is_constant() {
            return Ok(f.monic());
        }
    }
    Ok(exact_div(ring, f, &g).expect("the gcd divides f").monic())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::monomial::MonomialOrder;
    use crate::parse::parse_poly;

    #[test]
    fn gcd_and_squarefree() {
        let ring = Ring::new(&["x", "y", "z"], MonomialOrder::DegRevLex);
        let p = |s: &str| parse_poly(&ring, s).unwrap();
        let o = GroebnerOptions::default();
        assert_eq!(
            gcd(&ring, &p("(x+y)^2*(x-1)"), &p("(x+y)*(x-1)^3"), &o).unwrap(),
            p("(x+y)*(x-1)")
        );
        assert_eq!(
            gcd(&ring, &p("x^2 - y^2"), &p("x^2 + 2*x*y + y^2"), &o).unwrap(),
            p("x + y")
        );
        assert_eq!(gcd(&ring, &p("x + 1"), &p("y + 1"), &o).unwrap(), p("1"));
        assert_eq!(gcd(&ring, &p("2*x*z - 2*y"), &p("0"), &o).unwrap(), p("x*z - y"));
        assert_eq!(
            squarefree(&ring, &p("(x^2 + y^2 - z)^3*(x - y)^2*(z + 2)"), &o).unwrap(),
            p("(x^2 + y^2 - z)*(x - y)*(z + 2)")
        );
        assert_eq!(squarefree(&ring, &p("x*y - z"), &o).unwrap(), p("x*y - z"));
        assert_eq!(exact_div(&ring, &p("x^2 - 1"), &p("x - 1")), Some(p("x + 1")));
        assert_eq!(exact_div(&ring, &p("x^2 + 1"), &p("x - 1")), None);
    }
}
