//! Bump dents against SDF dents (docs/BENCHMARKS.md, "Dents"): a unit
//! sphere (marched, not intersected in closed form, in every render)
//! struck by a ball of radius 0.3, once at its silhouette and once
//! facing the camera, at depths 0.02, 0.05 and 0.1. The same dent is
//! written into the sphere's height map (shaded by normal mapping) and cut
//! into its geometry (`[[object.sdf_dent]]`); the SDF render is the
//! reference. Prints, per case, the pixels whose coverage differs (the
//! silhouette) and the mean and 95th-percentile angle between the normals
//! over the dent's pixels (where the SDF normal differs from the undented
//! sphere's), for the bump render and, as a baseline, for no dent at all.
//!
//! cargo run --release -p isoray-render --example bump_vs_sdf [-- PICTURE.png]
//!
//! With a path, also writes the deepest facing dent drawn both ways, bump
//! on the left and SDF on the right.

use std::sync::Arc;

use isoray_dent::field::March;
use isoray_dent::imprint::{imprint_texel, Sphere};
use isoray_render::{render, RenderOptions};
use isoray_scene::{Placement, SdfDent};

const R: f64 = 0.3;
const SIZE: u32 = 320;

fn scene() -> isoray_scene::Scene {
    let text = format!(
        "[camera]\nposition = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 35.0\n\
         [render]\nwidth = {SIZE}\nheight = {SIZE}\nshadows = \"none\"\nao = false\nanalytic = false\n\
         [[light]]\nkind = \"directional\"\ndirection = [-0.5, 0.6, 0.6]\n\
         [[object]]\nname = \"sphere\"\nshape = \"length(p) - 1.0\"\n\
         dents = \"bump\"\ndent_map = {{ size = 2048, range = 0.4, uv = \"spherical\", extent = 1.0 }}\n"
    );
    isoray_scene::load_str(&text, "bump_vs_sdf.toml", &[]).unwrap_or_else(|e| panic!("{e}"))
}

struct Aovs {
    hit: Vec<bool>,
    normals: Vec<[f32; 3]>,
    color: Vec<[f32; 3]>,
}

fn aovs(s: &isoray_scene::Scene) -> Aovs {
    let opts = RenderOptions {
        aovs: true,
        ..Default::default()
    };
    let img = render(s, &opts).0;
    let depth = img.depth.expect("depth");
    Aovs {
        hit: depth.iter().map(|d| d.is_finite()).collect(),
        normals: img.normals.expect("normals"),
        color: img.color,
    }
}

fn angle(a: [f32; 3], b: [f32; 3]) -> f64 {
    let d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) as f64;
    d.clamp(-1.0, 1.0).acos().to_degrees()
}

/// (differing coverage pixels, mean and 95th-percentile normal angle over `dent` pixels).
fn compare(a: &Aovs, reference: &Aovs, dent: &[bool]) -> (usize, f64, f64) {
    let coverage = a.hit.iter().zip(&reference.hit).filter(|(x, y)| x != y).count();
    let mut angles: Vec<f64> = (0..a.hit.len())
        .filter(|&i| dent[i] && a.hit[i] && reference.hit[i])
        .map(|i| angle(a.normals[i], reference.normals[i]))
        .collect();
    angles.sort_by(f64::total_cmp);
    let mean = angles.iter().fold(0.0, |a, b| a + b) / angles.len().max(1) as f64;
    let p95 = angles.get(angles.len() * 95 / 100).copied().unwrap_or(0.0);
    (coverage, mean, p95)
}

fn main() {
    let picture = std::env::args().nth(1);
    println!(
        "| dent | depth | silhouette pixels: bump / none | normal error, mean (p95) °: bump | none | dent pixels |"
    );
    println!("|---|---|---|---|---|---|");
    // Where the dent is: on the silhouette (where rays from the camera at
    // distance 4 graze the sphere: cos φ = 1/4 from the view axis) and
    // facing the camera half way (between +x and +z).
    let graze = (1.0f64 - 1.0 / 16.0).sqrt();
    let sites = [("silhouette", [graze, 0.0, 0.25]), ("facing", [0.6, 0.0, 0.8f64])];
    let plain = aovs(&scene());
    for (name, n) in sites {
        for depth in [0.02, 0.05, 0.1] {
            // The ball's centre: at R − depth outside the sphere along n.
            let centre = n.map(|c| c * (1.0 + R - depth));
            // Bump: the texel imprint of the ball into the height map.
            let mut bump = scene();
            let mut maps = bump.objects[0].physics.dent_map.blank().unwrap();
            let sphere = |p: [f64; 3]| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0;
            let ball = |p: [f64; 3]| {
                ((p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2) + (p[2] - centre[2]).powi(2)).sqrt() - R
            };
            let reach = Sphere { centre, radius: R };
            let mapping = maps.mapping.clone();
            imprint_texel(&mut maps.height, &mapping, &sphere, &ball, reach, March::default());
            maps.update_normals();
            bump.objects[0].physics.maps = Some(Arc::new(maps));
            // SDF: the ball cut out of the geometry.
            let mut sdf = scene();
            let rho = (2.0 * R * depth - depth * depth).sqrt();
            let mid = n.map(|c| c * (1.0 - 0.5 * depth));
            sdf.add_sdf_dents(
                0,
                &[SdfDent {
                    shape: format!("length(p) - {R:?}"),
                    placement: Placement {
                        position: centre,
                        ..Default::default()
                    },
                    rim: 0.0,
                    bound: [mid[0], mid[1], mid[2], 1.5 * (rho + depth)],
                }],
            )
            .unwrap();
            let (b, r) = (aovs(&bump), aovs(&sdf));
            // The dent's pixels: where the reference differs from the plain sphere.
            let dent: Vec<bool> = (0..r.hit.len())
                .map(|i| r.hit[i] != plain.hit[i] || (r.hit[i] && angle(r.normals[i], plain.normals[i]) > 0.5))
                .collect();
            let (bc, bm, bp) = compare(&b, &r, &dent);
            let (nc, nm, np) = compare(&plain, &r, &dent);
            println!(
                "| {name} | {depth} | {bc} / {nc} | {bm:.1} ({bp:.1}) | {nm:.1} ({np:.1}) | {} |",
                dent.iter().filter(|&&d| d).count()
            );
            if let (Some(path), "facing", 0.1) = (&picture, name, depth) {
                // Bump | SDF, side by side.
                let w = SIZE as usize;
                let mut both = Vec::with_capacity(2 * w * w);
                for y in 0..w {
                    both.extend_from_slice(&b.color[y * w..y * w + w]);
                    both.extend_from_slice(&r.color[y * w..y * w + w]);
                }
                isoray_render::output::write_png(std::path::Path::new(path), 2 * SIZE, SIZE, &both).unwrap();
            }
        }
    }
}
