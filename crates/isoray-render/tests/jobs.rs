//! Regions, progressive passes, tile sinks, progress and cancellation.

use std::sync::{Arc, Mutex};

use isoray_job::{CancelToken, Cancelled, Counter};
use isoray_render::{
    passes, render, render_progressive, render_region, render_with, Pass, Region, RenderOptions, TileImage,
};

/// A scene with an area light (its samples are seeded per tile), AA and a mirror.
const SCENE: &str = r#"
[camera]
position = [0.0, 1.5, 5.0]
target = [0.0, 0.5, 0.0]
[render]
width = 70
height = 45
aa = 2
[[light]]
kind = "rect"
position = [0.0, 4.0, 1.0]
u = [1.0, 0.0, 0.0]
v = [0.0, 0.0, 1.0]
samples = 4
[material.mirror]
reflectivity = 0.6
[[object]]
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"
[[object]]
material = "mirror"
shape = "sphere(p - vec3(0.0, 0.8, 0.0), 0.8)"
[[object]]
shape = "box(p - vec3(1.5, 0.4, 0.5), vec3(0.4))"
"#;

fn scene() -> isoray_scene::Scene {
    isoray_scene::load_str(SCENE, "jobs.toml", &[]).unwrap()
}

fn bits(c: &[[f32; 3]]) -> Vec<u32> {
    c.iter().flat_map(|p| p.map(f32::to_bits)).collect()
}

#[test]
fn a_region_is_the_same_pixels_as_the_whole_image() {
    let s = scene();
    let (full, _) = render(&s, &RenderOptions::default());
    // Not aligned to tiles, and running past the image's right edge.
    let region = Region {
        x0: 21,
        y0: 9,
        width: 60,
        height: 23,
    };
    let got: Mutex<Vec<(Region, Vec<[f32; 3]>)>> = Mutex::new(Vec::new());
    let sink = |t: &TileImage| got.lock().unwrap().push((t.region, t.color.to_vec()));
    let stats = render_region(&s, region, Pass::Final, &RenderOptions::default(), &sink).unwrap();
    assert_eq!(stats.primary_rays, (70 - 21) * 23 * 4);
    let tiles = got.into_inner().unwrap();
    let mut covered = 0;
    for (r, c) in &tiles {
        assert!(
            r.x0 >= 21 && r.y0 >= 9 && r.x0 + r.width <= 70 && r.y0 + r.height <= 32,
            "{r:?}"
        );
        for j in 0..r.height {
            for i in 0..r.width {
                let want = full.color[((r.y0 + j) * 70 + r.x0 + i) as usize];
                let have = c[(j * r.width + i) as usize];
                assert_eq!(bits(&[have]), bits(&[want]), "pixel ({}, {})", r.x0 + i, r.y0 + j);
                covered += 1;
            }
        }
    }
    assert_eq!(covered, 49 * 23, "every pixel of the region once");
}

#[test]
fn progressive_passes_refine_to_the_plain_render() {
    let s = scene();
    assert_eq!(
        passes(&s),
        [
            Pass::Blocks(8),
            Pass::Blocks(4),
            Pass::Blocks(2),
            Pass::Pixels,
            Pass::Final
        ]
    );
    let order: Mutex<Vec<Pass>> = Mutex::new(Vec::new());
    let blocks8: Mutex<Vec<(Region, Vec<[f32; 3]>)>> = Mutex::new(Vec::new());
    let sink = |t: &TileImage| {
        order.lock().unwrap().push(t.pass);
        if t.pass == Pass::Blocks(8) {
            blocks8.lock().unwrap().push((t.region, t.color.to_vec()));
        }
    };
    let (img, _) = render_progressive(&s, Region::full(&s), &RenderOptions::default(), &sink).unwrap();
    let (plain, _) = render(&s, &RenderOptions::default());
    assert_eq!(
        bits(&img.color),
        bits(&plain.color),
        "the final pass is the plain render"
    );
    // Passes arrive in order, each with every tile (5 × 3 tiles of 16 pixels).
    let order = order.into_inner().unwrap();
    assert_eq!(order.len(), 5 * 15);
    for (k, p) in passes(&s).iter().enumerate() {
        assert!(order[k * 15..(k + 1) * 15].iter().all(|q| q == p));
    }
    // The coarse pass fills each 8×8 block with one colour.
    for (r, c) in blocks8.into_inner().unwrap() {
        for j in 0..r.height {
            for i in 0..r.width {
                let (x, y) = (r.x0 + i, r.y0 + j);
                let corner = ((y / 8 * 8 - r.y0) * r.width + (x / 8 * 8 - r.x0)) as usize;
                assert_eq!(c[(j * r.width + i) as usize], c[corner]);
            }
        }
    }
}

#[test]
fn progress_counts_tiles_and_cancellation_stops_the_render() {
    let s = scene();
    let counter = Arc::new(Counter::default());
    let opts = RenderOptions {
        progress: Some(counter.clone()),
        ..RenderOptions::default()
    };
    render_with(&s, &opts).unwrap();
    assert_eq!((counter.done(), counter.total()), (15, 15));
    // Cancelled before it starts.
    let token = CancelToken::new();
    token.cancel();
    let opts = RenderOptions {
        cancel: Some(token),
        ..RenderOptions::default()
    };
    assert_eq!(render_with(&s, &opts).unwrap_err(), Cancelled);
    // Cancelled by the first finished tile: the others are skipped.
    let token = CancelToken::new();
    let seen = Mutex::new(0);
    let sink = |_: &TileImage| {
        *seen.lock().unwrap() += 1;
        token.cancel();
    };
    let opts = RenderOptions {
        cancel: Some(token.clone()),
        ..RenderOptions::default()
    };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let r = pool.install(|| render_region(&s, Region::full(&s), Pass::Final, &opts, &sink));
    assert_eq!(r.unwrap_err(), Cancelled);
    assert_eq!(*seen.lock().unwrap(), 1, "one tile, then it stopped");
}
