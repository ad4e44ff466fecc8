//! The known implicitization answers, and the errors.

use isoray_algebra::implicit::implicitize_groebner;
use isoray_algebra::parse::to_primitive_integer;
use isoray_algebra::{parse_poly, GroebnerOptions, ImplicitError, MonomialOrder, Ring};

const CASES: &[(&str, &str, &str, &str)] = &[
    ("s+t", "s", "t", "x - y - z"),
    ("t^2+s^2", "t", "s", "x - y^2 - z^2"),
    ("t", "s", "t^2-s^2", "x^2 - y^2 - z"),
    (
        "2s/(s^2+t^2+1)",
        "2t/(s^2+t^2+1)",
        "(s^2+t^2-1)/(s^2+t^2+1)",
        "x^2 + y^2 + z^2 - 1",
    ),
    ("s", "t", "s^2+t^2", "x^2 + y^2 - z"),
    ("(t-s)/t", "s/t", "(s^3+t^2)/t^2", "x + y - 1"),
    ("s/t", "s/t^2", "(s+t)/s", "xz - x - 1"),
    ("s/(st)", "(t^2-s)/t^2", "t/s", "x + yz - z"),
    ("(t-s^2)/(st)", "s^2/3", "s", "3y - z^2"),
];

#[test]
fn known_implicit_equations() {
    let ring = Ring::new(&["x", "y", "z"], MonomialOrder::DegRevLex);
    for (x, y, z, want) in CASES {
        let got = implicitize_groebner(&[x, y, z], &["s", "t"], &GroebnerOptions::default())
            .unwrap_or_else(|e| panic!("{x}, {y}, {z}: {e}"));
        let want = to_primitive_integer(&ring, &parse_poly(&ring, want).unwrap());
        assert_eq!(got.poly, want, "x={x}, y={y}, z={z}: got {}", got.display());
    }
}

#[test]
fn plane_curves() {
    // The unit circle, rationally parametrized.
    let got = implicitize_groebner(&["(1-t^2)/(1+t^2)", "2t/(1+t^2)"], &["t"], &GroebnerOptions::default()).unwrap();
    assert_eq!(got.display(), "x^2 + y^2 - 1");
    // The cuspidal cubic.
    let got = implicitize_groebner(&["t^2", "t^3"], &["t"], &GroebnerOptions::default()).unwrap();
    assert_eq!(got.display(), "x^3 - y^2");
}

#[test]
fn errors() {
    let o = GroebnerOptions::default();
    let e = implicitize_groebner(&["s/(t-t)", "s", "t"], &["s", "t"], &o).unwrap_err();
    assert!(
        matches!(&e, ImplicitError::Parse { error, .. } if error.message.contains("division by zero")),
        "{e}"
    );
    let e = implicitize_groebner(&["s + x", "s", "t"], &["s", "t"], &o).unwrap_err();
    assert!(
        matches!(&e, ImplicitError::UsesCoordinate { var, .. } if var == "x"),
        "{e}"
    );
    let e = implicitize_groebner(&["s", "s^2", "s^3"], &["s"], &o).unwrap_err();
    assert!(
        matches!(e, ImplicitError::WrongParameterCount { want: 2, found: 1, .. }),
        "{e}"
    );
    // A surface parametrization whose image is a curve: the elimination ideal is not principal.
    let e = implicitize_groebner(&["s+t", "(s+t)^2", "(s+t)^3"], &["s", "t"], &o).unwrap_err();
    match &e {
        ImplicitError::NotPrincipal { found } => assert!(
            found.contains("x^2 - y") || found.contains("y - x^2") || found.contains(','),
            "{found}"
        ),
        other => panic!("{other}"),
    }
    let e = implicitize_groebner(&["s + q", "s", "t"], &["s", "t"], &o).unwrap_err();
    assert!(
        matches!(&e, ImplicitError::Parse { error, .. } if error.column == 5),
        "{e}"
    );
}

#[test]
fn resultant_cross_checks_groebner_for_plane_curves() {
    use isoray_algebra::resultant::implicitize_curve_resultant;
    let ring = Ring::new(&["x", "y"], MonomialOrder::DegRevLex);
    for (x, y) in [
        ("(1-t^2)/(1+t^2)", "2t/(1+t^2)"),
        ("t^2", "t^3"),
        ("t^2 - 1", "t^3 - t"),
        ("t/(1+t^3)", "t^2/(1+t^3)"),
    ] {
        let g = implicitize_groebner(&[x, y], &["t"], &GroebnerOptions::default()).unwrap();
        let r = implicitize_curve_resultant(x, y, "t").unwrap();
        // Up to sign, the square-free resultant is the implicit equation.
        let neg = isoray_algebra::Poly::from_sorted(r.terms().iter().map(|(m, c)| (m.clone(), -c)).collect());
        assert!(
            r == g.poly || neg == g.poly,
            "x={x}, y={y}: resultant {} vs Gröbner {}",
            r.display(&ring),
            g.display()
        );
    }
}

/// The coordinates of the generic bicubic patch of `bench/bicubic.txt`.
fn bicubic() -> [String; 3] {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench/bicubic.txt")).unwrap();
    ["x=", "y=", "z="].map(|c| {
        text.lines()
            .find_map(|l| l.strip_prefix(c))
            .unwrap_or_else(|| panic!("bench/bicubic.txt has no line {c}"))
            .to_string()
    })
}

/// F4 elimination keeps to its time budget on a case of minutes (a generic
/// bicubic patch, `bench/bicubic.txt`, implicit degree 18: symbolic
/// preprocessing of large matrices is checked too), and stops with the
/// budget error.
#[test]
fn f4_elimination_keeps_its_time_budget() {
    let opts = GroebnerOptions {
        budget: isoray_algebra::Budget {
            time: Some(std::time::Duration::from_millis(300)),
            ..Default::default()
        },
        ..Default::default()
    };
    let [x, y, z] = bicubic();
    let start = std::time::Instant::now();
    let r = implicitize_groebner(&[&x, &y, &z], &["s", "t"], &opts);
    let took = start.elapsed();
    assert!(matches!(r, Err(ImplicitError::Groebner(_))), "{r:?}");
    assert!(took.as_secs_f64() < 2.0, "stopped after {took:?}");
}

/// `--method auto` measures the implicit degree, chooses by its cost
/// estimate and gives elimination's answer: interpolation at low degree
/// (random-9 of the implicitization bench: degree 8 although the Bézout
/// bound is 25), resultants at high degree (the bicubic patch, degree 18),
/// never the resultant with affine base points.
#[test]
fn auto_chooses_by_the_estimate_and_agrees_with_elimination() {
    use isoray_algebra::auto::{implicitize_auto, AutoOptions, Method};
    let cases: [([&str; 3], Method, u32); 3] = [
        (
            [
                "(-2*s^2*t-2)/(-1*s-3)",
                "(-2*s^3-1*s^2*t)/(-2*s+1)",
                "(-1*s^3+1*s*t^2)/(2*t+2)",
            ],
            Method::Interpolation,
            8,
        ),
        (
            ["(s+t^2)/(t+1)", "(s^2-t)/(s+2)", "(s*t)/(s-t+1)"],
            Method::Interpolation,
            6,
        ),
        (
            ["s/(s^2+t^2)", "t/(s^2+t^2)", "s*t/(s^2+t^2)"],
            Method::Interpolation,
            3,
        ),
    ];
    for (coords, method, degree) in cases {
        let a = implicitize_auto(&coords, &["s", "t"], &AutoOptions::default()).unwrap();
        let g = implicitize_groebner(&coords, &["s", "t"], &GroebnerOptions::default()).unwrap();
        assert_eq!(a.implicit.display(), g.display(), "{coords:?}");
        assert_eq!(
            (a.method, a.estimate.degree),
            (method, Some(degree)),
            "{coords:?}: {}",
            a.estimate
        );
        assert_eq!(a.implicit.poly.degree(), i64::from(degree));
    }
    let [x, y, z] = bicubic();
    let a = implicitize_auto(&[&x, &y, &z], &["s", "t"], &AutoOptions::default()).unwrap();
    assert_eq!(
        (a.method, a.estimate.degree),
        (Method::Resultant, Some(18)),
        "{}",
        a.estimate
    );
    assert_eq!(a.implicit.poly.degree(), 18);
    assert!(!a.estimate.base_points);
}
