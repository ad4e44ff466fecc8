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
    let t = std::time::Instant::now();
    let r = groebner(&ring, &polys, &GroebnerOptions::default()).expect("no budget");
    println!(
        "{kind}-{n}: {} elements in {:.3} s\n{}",
        r.basis.len(),
        t.elapsed().as_secs_f64(),
        r.stats
    );
}
