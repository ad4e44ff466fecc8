//! What a live edit costs: changing a parameter of the showcase and
//! rendering one 64×64 tile, against a cold load and compile.
//!
//! * `cold load and compile`: text → checked, compiled scene (parse, lower,
//!   extract every tape, recognise closed forms).
//! * `set parameter`: `Scene::set_param` — all that runs before tracing
//!   starts when a slider moves (no re-parse, re-lower or re-extract).
//! * `set parameter + render set-up`: the same and the render's shared
//!   context, with no tile (per-thread evaluators are made with the first tile).
//! * `set parameter + set-up + 1 pixel`: an upper bound on everything
//!   before tracing (the render's context and per-thread evaluators, and
//!   one pixel's rays).
//! * `set parameter + 64×64 tile`: the same, then the final pass of one
//!   64×64 region (setting up the workers included).
//!
//! * `edit one object: reload without a cache` / `… with the object cache`:
//!   a structural edit (the text of one of the six objects changes, a new
//!   value each time), loaded again from the text cold, and with the
//!   object cache of the earlier loads (only the edited object compiles).
//!
//! `cargo bench -p isoray-render --bench live`

use criterion::{criterion_group, criterion_main, Criterion};
use isoray_render::{render_region, NoSink, Pass, Region, RenderOptions};
use isoray_shape::Value;

const OVERRIDES: [&str; 3] = [
    "params.r=0.7",
    "object.4.shape=sphere(p - vec3(1.35, 0.7, 0.55), r)",
    "render.aa=1",
];

fn text() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/showcase.toml")).expect("showcase")
}

fn bench(c: &mut Criterion) {
    let text = text();
    let overrides: Vec<String> = OVERRIDES.map(String::from).to_vec();
    let mut g = c.benchmark_group("live");
    g.bench_function("cold load and compile", |b| {
        b.iter(|| isoray_scene::load_str(&text, "showcase.toml", &overrides).expect("loads"))
    });
    let mut scene = isoray_scene::load_str(&text, "showcase.toml", &overrides).expect("loads");
    let mut k = 0u32;
    let mut next = move || {
        k = k.wrapping_add(1);
        Value::Float(0.6 + 0.01 * (k % 20) as f64)
    };
    g.bench_function("set parameter", |b| {
        b.iter(|| scene.set_param("r", next()).expect("in range"))
    });
    let tile = Region {
        x0: 448,
        y0: 224,
        width: 64,
        height: 64,
    };
    let opts = RenderOptions::default();
    // An upper bound on everything before tracing: the parameter, the
    // render set-up (context, workers, evaluators) and one pixel's ray.
    let pixel = Region {
        width: 1,
        height: 1,
        ..tile
    };
    let nothing = Region {
        width: 0,
        height: 0,
        ..tile
    };
    g.bench_function("set parameter + render set-up", |b| {
        b.iter(|| {
            scene.set_param("r", next()).expect("in range");
            render_region(&scene, nothing, Pass::Final, &opts, &NoSink).expect("not cancelled")
        })
    });
    g.bench_function("set parameter + set-up + 1 pixel", |b| {
        b.iter(|| {
            scene.set_param("r", next()).expect("in range");
            render_region(&scene, pixel, Pass::Final, &opts, &NoSink).expect("not cancelled")
        })
    });
    g.bench_function("set parameter + 64x64 tile", |b| {
        b.iter(|| {
            scene.set_param("r", next()).expect("in range");
            render_region(&scene, tile, Pass::Final, &opts, &NoSink).expect("not cancelled")
        })
    });
    // A structural edit: object 2 (the prism) gets a new size each time.
    let mut n = 0u32;
    let mut edited = move || {
        n = n.wrapping_add(1);
        let mut o = vec![format!(
            "object.2.shape=tri_prism(p - vec3(-0.9, 0.45, 0.7), 0.45, {:?})",
            0.9 + 1e-6 * n as f64
        )];
        o.extend(OVERRIDES.map(String::from));
        o
    };
    g.bench_function("edit one object: reload without a cache", |b| {
        b.iter(|| isoray_scene::load_str(&text, "showcase.toml", &edited()).expect("loads"))
    });
    let cache = isoray_scene::ObjectCache::new();
    let opts = isoray_scene::LoadOptions {
        objects: Some(cache.clone()),
        ..Default::default()
    };
    g.bench_function("edit one object: reload with the object cache", |b| {
        b.iter(|| isoray_scene::load_str_with(&text, "showcase.toml", &edited(), &opts).expect("loads"))
    });
    let stats = cache.stats();
    assert!(stats.reused >= 5 * stats.compiled.saturating_sub(6), "{stats:?}");
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
