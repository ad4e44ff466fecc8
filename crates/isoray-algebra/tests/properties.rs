//! Property tests of Gröbner bases: same ideal, reducedness, the S-pair
//! criterion, and independence from the input order.

use isoray_algebra::groebner::normal_form;
use isoray_algebra::{groebner, Budget, GroebnerOptions, Monomial, MonomialOrder, Poly, Rat, Ring};
use proptest::prelude::*;

fn ring(order: usize) -> Ring {
    let o = match order {
        0 => MonomialOrder::Lex,
        1 => MonomialOrder::DegLex,
        2 => MonomialOrder::DegRevLex,
        _ => MonomialOrder::Block(vec![1, 2]),
    };
    Ring::new(&["x", "y", "z"], o)
}

fn poly(r: &Ring, terms: &[(i64, [u16; 3])]) -> Poly<Rat> {
    Poly::from_terms(
        r,
        terms
            .iter()
            .map(|(c, e)| (Monomial::new(e), Rat::from_integer((*c).into())))
            .collect(),
    )
}

fn opts() -> GroebnerOptions {
    GroebnerOptions {
        budget: Budget {
            steps: Some(20_000),
            ..Default::default()
        },
        ..Default::default()
    }
}

fn term() -> impl Strategy<Value = (i64, [u16; 3])> {
    (-3i64..=3, 0u16..3, 0u16..3, 0u16..2).prop_map(|(c, a, b, d)| (c, [a, b, d]))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(150))]

    #[test]
    fn reduced_groebner_basis_properties(
        gens in proptest::collection::vec(proptest::collection::vec(term(), 1..4), 1..4),
        order in 0usize..4,
    ) {
        let r = ring(order);
        let input: Vec<Poly<Rat>> = gens.iter().map(|t| poly(&r, t)).filter(|p| !p.is_zero()).collect();
        prop_assume!(!input.is_empty());
        let Ok(res) = groebner(&r, &input, &opts()) else { return Ok(()) };
        let g = res.basis;
        // Every input reduces to zero modulo the basis.
        for f in &input {
            prop_assert!(normal_form(&r, f, &g).is_zero());
        }
        // Reduced: monic, and no term of an element is divisible by another's leading monomial.
        for (i, a) in g.iter().enumerate() {
            prop_assert!(a.lc().unwrap() == &Rat::from_integer(1.into()));
            for (j, b) in g.iter().enumerate() {
                if i != j {
                    let lb = b.lm().unwrap();
                    prop_assert!(a.terms().iter().all(|(m, _)| !lb.divides(m)));
                }
            }
        }
        // Buchberger's criterion: every S-polynomial reduces to zero.
        for i in 0..g.len() {
            for j in i + 1..g.len() {
                let (a, b) = (&g[i], &g[j]);
                let l = a.lm().unwrap().lcm(b.lm().unwrap());
                let one = Rat::from_integer(1.into());
                let s = a.mul_term(&a.lm().unwrap().quotient(&l).unwrap(), &one).sub(&r, &b.mul_term(&b.lm().unwrap().quotient(&l).unwrap(), &one));
                prop_assert!(normal_form(&r, &s, &g).is_zero());
            }
        }
        // The same ideal: adding the basis to the input changes nothing, and the basis is its own basis.
        let mut both = input.clone();
        both.extend(g.iter().cloned());
        prop_assert_eq!(&groebner(&r, &both, &opts()).unwrap().basis, &g);
        prop_assert_eq!(&groebner(&r, &g, &opts()).unwrap().basis, &g);
        // Independent of the input order.
        let mut rev = input.clone();
        rev.reverse();
        prop_assert_eq!(&groebner(&r, &rev, &opts()).unwrap().basis, &g);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// F4 and Buchberger agree term for term modulo 32003 and over Q
    /// (F4's multi-modular lift, either check), in every order.
    #[test]
    fn f4_agrees_with_buchberger(
        gens in proptest::collection::vec(proptest::collection::vec(term(), 1..5), 1..5),
        order in 0usize..4,
    ) {
        use isoray_algebra::{f4::f4_modp, groebner::groebner_in, Algorithm, Fp, Verify};
        let r = ring(order);
        let input: Vec<Poly<Rat>> = gens.iter().map(|t| poly(&r, t)).filter(|p| !p.is_zero()).collect();
        prop_assume!(!input.is_empty());
        let buchberger = GroebnerOptions { algorithm: Algorithm::Buchberger, ..opts() };
        let Ok(want) = groebner(&r, &input, &buchberger) else { return Ok(()) };
        for verify in [Verify::Probabilistic, Verify::Exact] {
            let f4 = GroebnerOptions { verify, ..GroebnerOptions::default() };
            prop_assert_eq!(&groebner(&r, &input, &f4).unwrap().basis, &want.basis);
        }
        let modp: Vec<Poly<Fp>> = input
            .iter()
            .map(|f| Poly::from_terms(&r, f.terms().iter().map(|(m, c)| (m.clone(), Fp::from_rat(c, 32003).unwrap())).filter(|(_, c)| c.value() != 0).collect()))
            .collect();
        let Ok((want_p, _)) = groebner_in(&r, &modp, &opts()) else { return Ok(()) };
        prop_assert_eq!(f4_modp(&r, &modp, &GroebnerOptions::default()).unwrap().0, want_p);
    }
}
