//! Reduced Gröbner bases of katsura-n and cyclic-n over Q in grevlex, and the
//! implicit equations, against reference outputs computed with Singular by
//! `bench/singular/reference.sh` (stored in tests/data, so no Singular is needed here).

use isoray_algebra::implicit::implicitize_groebner;
use isoray_algebra::parse::to_primitive_integer;
use isoray_algebra::{groebner, parse_poly, systems, GroebnerOptions, MonomialOrder, Poly, Rat, Ring};

fn data(name: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// (ring, input, basis) from a reference file.
fn reference(name: &str) -> (Ring, Vec<Poly<Rat>>, Vec<Poly<Rat>>) {
    let text = data(name);
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let vars = header.trim_start_matches("# vars: ").split(" order:").next().unwrap();
    let vars: Vec<&str> = vars.split(',').collect();
    assert!(header.ends_with("order: grevlex"), "{header}");
    let ring = Ring::new(&vars, MonomialOrder::DegRevLex);
    let (mut input, mut basis, mut in_basis) = (Vec::new(), Vec::new(), false);
    for l in lines {
        if l.starts_with("# basis:") {
            in_basis = true;
        } else if let Some(p) = l.strip_prefix("#   ") {
            input.push(parse_poly(&ring, p).unwrap());
        } else if in_basis && !l.trim().is_empty() {
            basis.push(parse_poly(&ring, l).unwrap());
        }
    }
    (ring, input, basis)
}

fn check(name: &str) {
    let (ring, input, want) = reference(name);
    let got = groebner(&ring, &input, &GroebnerOptions::default()).unwrap().basis;
    assert_eq!(got.len(), want.len(), "{name}: basis size");
    assert_eq!(got, want, "{name}");
}

#[test]
fn katsura_matches_singular() {
    for n in 2..=6 {
        check(&format!("katsura-{n}.txt"));
    }
}

#[test]
fn cyclic_matches_singular() {
    for n in 3..=6 {
        check(&format!("cyclic-{n}.txt"));
    }
}

#[test]
fn generated_systems_match_the_reference_inputs() {
    for (name, (ring, polys)) in [
        ("katsura-4.txt", systems::katsura(4)),
        ("cyclic-5.txt", systems::cyclic(5)),
    ] {
        let (r2, input, _) = reference(name);
        assert_eq!(ring, r2);
        let mut a: Vec<String> = polys.iter().map(|p| p.display(&ring)).collect();
        let mut b: Vec<String> = input.iter().map(|p| p.display(&ring)).collect();
        a.sort();
        b.sort();
        assert_eq!(a, b, "{name}");
    }
}

#[test]
fn implicit_equations_match_singular_eliminate() {
    let ring = Ring::new(&["x", "y", "z"], MonomialOrder::DegRevLex);
    let text = data("implicit.txt");
    let mut n = 0;
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let (lhs, want) = line.split_once(" => ").unwrap();
        let parts: Vec<&str> = lhs.split("; ").map(|p| p.split_once('=').unwrap().1).collect();
        let got = implicitize_groebner(&parts, &["s", "t"], &GroebnerOptions::default()).unwrap();
        let want = to_primitive_integer(&ring, &parse_poly(&ring, want).unwrap());
        assert_eq!(got.poly, want, "{line}");
        n += 1;
    }
    assert_eq!(n, 9);
}
