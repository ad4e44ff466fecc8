//! # isoray-algebra
//!
//! Computer algebra for isoray, usable on its own: sparse multivariate
//! polynomials over Q and GF(p), monomial orders chosen at run time,
//! multivariate division, Gröbner bases (Buchberger with the sugar strategy
//! and the Gebauer–Möller criteria, fraction-free over Q), elimination and
//! implicitization of rational parametrizations.
//!
//! ```
//! use isoray_algebra::{groebner, parse_poly, GroebnerOptions, MonomialOrder, Ring};
//!
//! let ring = Ring::new(&["x", "y"], MonomialOrder::Lex);
//! let f = parse_poly(&ring, "x^2 + y^2 - 1").unwrap();
//! let g = parse_poly(&ring, "x - y").unwrap();
//! let basis = groebner(&ring, &[f, g], &GroebnerOptions::default()).unwrap().basis;
//! let text: Vec<String> = basis.iter().map(|p| p.display(&ring)).collect();
//! assert_eq!(text, ["y^2 - 1/2", "x - y"]);
//! ```

pub mod auto;
pub mod coeff;
pub mod f4;
pub mod fglm;
pub mod gcd;
pub mod groebner;
pub mod ideal;
pub mod implicit;
pub mod interp;
pub mod modular;
pub mod modular_f4;
pub mod monomial;
pub mod parse;
pub mod poly;
pub mod resultant;
pub mod surface_resultant;
pub mod systems;

#[cfg(test)]
pub(crate) mod testing;

pub use coeff::{Coeff, Domain, Field, Fp, Int, Rat};
pub use groebner::{
    groebner, Algorithm, Budget, Criteria, GroebnerError, GroebnerOptions, GroebnerResult, Method, Stats, Strategy,
};
pub use implicit::{implicitize_groebner, Implicit, ImplicitError};
pub use modular_f4::Verify;
pub use monomial::{Monomial, MonomialOrder};
pub use parse::{parse_poly, parse_rational, ParseError, RatFunc};
pub use poly::{divide, Poly, Ring};
