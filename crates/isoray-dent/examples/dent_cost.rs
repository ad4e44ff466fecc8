//! The cost of one impact against a full recompute of the maps
//! (`bench/dents/maps.sh`, docs/BENCHMARKS.md): a ball pressed into a
//! plane mapped onto an N × N height map so that its dent spans D texels;
//! the imprint (isoray's texel method), the height update and the normal
//! map's update of the changed rectangle grown by one texel, against the
//! normal map of the whole height map.
//!
//! ```text
//! cargo run --release -p isoray-dent --example dent_cost [REPEATS]
//! ```
//!
//! Prints one markdown row per (map size, dent size): the median times of
//! the impact's stages and of the full recompute, in milliseconds, and
//! their ratio; and checks that the partial update equals the full one.

use std::time::Instant;

use isoray_dent::field::March;
use isoray_dent::imprint::{imprint_texel, Sphere};
use isoray_dent::normalmap::{NormalMap, NormalMapOptions, Wrap};
use isoray_dent::uv::UvMapping;
use isoray_dent::HeightMap;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let repeats: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(7);
    println!("| map | dent (texels across) | texels lowered | imprint ms | normal update ms | impact ms | full normal map ms | full / impact |");
    println!("|---|---|---|---|---|---|---|---|");
    for n in [1024u32, 2048, 4096] {
        let opts = NormalMapOptions {
            wrap: Wrap::Clamp,
            // One scene unit across the map; a height range of 0.05.
            white_height: 0.05 * n as f32,
            ..Default::default()
        };
        let mapping = UvMapping::named("planar-xz", [-0.5, -1.0, -0.5], [0.5, 0.0, 0.5]).unwrap();
        let plane = |p: [f64; 3]| p[1];
        let base = HeightMap::new(n, n, 0.05);
        let base_normals = NormalMap::of(base.texels(), n, n, &opts);
        let mut full_ms = Vec::new();
        for _ in 0..repeats.min(3) {
            let t = Instant::now();
            let full = NormalMap::of(base.texels(), n, n, &opts);
            full_ms.push(t.elapsed().as_secs_f64() * 1e3);
            std::hint::black_box(full);
        }
        let full = median(full_ms);
        for across in [16u32, 64, 256] {
            // A ball of radius r pressed to depth d leaves a dent of radius
            // sqrt(2rd − d²): r = 4 × the dent's radius, d to match.
            let a = across as f64 / n as f64 / 2.0;
            let r = 4.0 * a;
            let d = r - (r * r - a * a).sqrt();
            let ball = move |p: [f64; 3]| (p[0] * p[0] + (p[1] - (r - d)).powi(2) + p[2] * p[2]).sqrt() - r;
            let reach = Sphere {
                centre: [0.0, r - d, 0.0],
                radius: r,
            };
            let (mut imp, mut nor, mut lowered) = (Vec::new(), Vec::new(), 0);
            let mut last = None;
            for _ in 0..repeats {
                let mut map = base.clone();
                let mut normals = base_normals.clone();
                let t = Instant::now();
                let out = imprint_texel(&mut map, &mapping, &plane, &ball, reach, March::default());
                let t1 = t.elapsed().as_secs_f64() * 1e3;
                let rect = map.take_dirty().expect("a dent");
                let t = Instant::now();
                normals.update(map.texels(), &opts, rect);
                let t2 = t.elapsed().as_secs_f64() * 1e3;
                imp.push(t1);
                nor.push(t2);
                lowered = out.lowered;
                last = Some((map, normals));
            }
            let (map, normals) = last.expect("ran");
            assert!(
                normals == NormalMap::of(map.texels(), n, n, &opts),
                "the partial update equals the full recompute"
            );
            let (i, u) = (median(imp), median(nor));
            println!(
                "| {n}² | {across} | {lowered} | {i:.3} | {u:.3} | {:.3} | {full:.1} | {:.0}× |",
                i + u,
                full / (i + u)
            );
        }
    }
}
