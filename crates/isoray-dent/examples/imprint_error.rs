//! The dent-shape error of each imprint method against the analytic
//! spherical cap (`bench/dents/maps.sh`, docs/BENCHMARKS.md): a ball of
//! radius 0.5 pressed 0.05 into a plane (the dent's radius 0.218), the
//! impact direction tilted 0° to 60° from the plane's normal; a 256 × 256
//! map over 2 × 2 scene units (one texel 0.0078), range 0.2.
//!
//! ```text
//! cargo run --release -p isoray-dent --example imprint_error
//! ```

use isoray_dent::field::March;
use isoray_dent::imprint::{imprint_ortho, imprint_texel, OrthoOptions, Sphere};
use isoray_dent::uv::UvMapping;
use isoray_dent::HeightMap;

const R: f64 = 0.5;
const D: f64 = 0.05;
const N: u32 = 256;

fn exact(x: u32, y: u32) -> f64 {
    let s = 2.0 / N as f64;
    let (px, pz) = (-1.0 + (x as f64 + 0.5) * s, -1.0 + (y as f64 + 0.5) * s);
    let rho2 = px * px + pz * pz;
    if rho2 <= 2.0 * R * D - D * D {
        D - R + (R * R - rho2).sqrt()
    } else {
        0.0
    }
}

/// (max error, rms error over the dent's texels, centre depth), scene units.
fn errors(map: &HeightMap) -> (f64, f64, f64) {
    let (mut worst, mut sum, mut count) = (0.0f64, 0.0, 0);
    for y in 0..N {
        for x in 0..N {
            let (d, e) = (-map.displacement(x, y), exact(x, y));
            if d > 0.0 || e > 0.0 {
                worst = worst.max((d - e).abs());
                sum += (d - e) * (d - e);
                count += 1;
            }
        }
    }
    (
        worst,
        (sum / count.max(1) as f64).sqrt(),
        -map.displacement(N / 2, N / 2),
    )
}

fn main() {
    let mapping = UvMapping::named("planar-xz", [-1.0, -1.0, -1.0], [1.0, 0.0, 1.0]).unwrap();
    let plane = |p: [f64; 3]| p[1];
    let ball = |p: [f64; 3]| (p[0] * p[0] + (p[1] - (R - D)).powi(2) + p[2] * p[2]).sqrt() - R;
    let reach = Sphere {
        centre: [0.0, R - D, 0.0],
        radius: R,
    };
    let texel = 2.0 / N as f64;
    println!("| tilt | method | max error | max error / dent depth | rms error | centre depth (exact 0.05) |");
    println!("|---|---|---|---|---|---|");
    for tilt in [0.0f64, 15.0, 30.0, 45.0, 60.0] {
        let t = tilt.to_radians();
        let n_c = [t.sin(), t.cos(), 0.0];
        let mut rows = Vec::new();
        let mut map = HeightMap::new(N, N, 0.2);
        imprint_texel(&mut map, &mapping, &plane, &ball, reach, March::default());
        rows.push(("texel", errors(&map)));
        for (name, project) in [("ortho", false), ("ortho + N·N_C", true)] {
            let mut map = HeightMap::new(N, N, 0.2);
            imprint_ortho(
                &mut map,
                &mapping,
                &plane,
                &ball,
                [0.0; 3],
                n_c,
                reach,
                texel / 2.0,
                OrthoOptions {
                    project_on_normal: project,
                },
                March::default(),
            );
            rows.push((name, errors(&map)));
        }
        for (name, (worst, rms, centre)) in rows {
            println!(
                "| {tilt}° | {name} | {worst:.5} | {:.1} % | {rms:.5} | {centre:.5} |",
                100.0 * worst / D
            );
        }
    }
}
