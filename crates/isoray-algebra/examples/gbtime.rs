//! Times reduced Gröbner bases of katsura-n and cyclic-n over Q:
//! `cargo run --release -p isoray-algebra --example gbtime -- katsura 6`.
use isoray_algebra::{groebner, systems, GroebnerOptions};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (kind, n) = (
        args.get(1).map(String::as_str).unwrap_or("katsura"),
        args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5),
    );
    let (ring, polys) = if kind == "cyclic" {
        systems::cyclic(n)
    } else {
        systems::katsura(n)
    };
    if let Some(p) = args.get(3).and_then(|s| s.parse::<u64>().ok()) {
        let mods: Vec<_> = polys
            .iter()
            .map(|f| f.map_coeffs(&ring, |c| isoray_algebra::Fp::from_rat(c, p).unwrap()))
            .collect();
        let t = std::time::Instant::now();
        let (b, st) = isoray_algebra::groebner::groebner_in(&ring, &mods, &GroebnerOptions::default()).unwrap();
        println!(
            "{kind}-{n} mod {p}: {} elements in {:.3} s\n{st}",
            b.len(),
            t.elapsed().as_secs_f64()
        );
        return;
    }
    if args.get(3).map(String::as_str) == Some("modular") {
        let t = std::time::Instant::now();
        let (b, st) = isoray_algebra::modular::groebner_modular(&ring, &polys, &GroebnerOptions::default()).unwrap();
        println!(
            "{kind}-{n} modular: {} elements in {:.3} s\n{st}",
            b.len(),
            t.elapsed().as_secs_f64()
        );
        return;
    }
    let method = match args.get(3).map(String::as_str) {
        Some("ff") => isoray_algebra::Method::FractionFree,
        _ => isoray_algebra::Method::Auto,
    };
    let t = std::time::Instant::now();
    let r = groebner(
        &ring,
        &polys,
        &GroebnerOptions {
            method,
            ..Default::default()
        },
    )
    .expect("no budget");
    println!(
        "{kind}-{n}: {} elements in {:.3} s\n{}",
        r.basis.len(),
        t.elapsed().as_secs_f64(),
        r.stats
    );
}
