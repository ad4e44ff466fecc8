//! Kernel benchmarks: batch and point evaluation of the showcase's distance
//! function, and sphere tracing one tile of primary rays.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use isoray_render::{render, RenderOptions};
use isoray_shape::{BatchEvaluator, PointEvaluator};

fn showcase() -> isoray_scene::Scene {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/showcase.toml");
    isoray_scene::load(
        std::path::Path::new(path),
        &[
            "render.width=64".into(),
            "render.height=64".into(),
            "render.aa=1".into(),
        ],
    )
    .expect("showcase loads")
}

fn points(n: usize) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let mut s = 12345u32;
    let mut r = || {
        s = s.wrapping_mul(1664525).wrapping_add(1013904223);
        (s >> 8) as f32 / (1 << 24) as f32 * 6.0 - 3.0
    };
    let mut xs = Vec::with_capacity(n);
    let mut ys = Vec::with_capacity(n);
    let mut zs = Vec::with_capacity(n);
    for _ in 0..n {
        xs.push(r());
        ys.push(r());
        zs.push(r());
    }
    (xs, ys, zs)
}

fn bench(c: &mut Criterion) {
    let scene = showcase();
    let tape = scene.shape.tape();
    let n = 1 << 14;
    let (xs, ys, zs) = points(n);
    let mut out = vec![0.0f32; n];
    let mut g = c.benchmark_group("eval");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("batch_f32", |b| {
        let mut e = BatchEvaluator::<f32>::new(tape);
        b.iter(|| e.eval(&scene.inputs, &xs, &ys, &zs, &mut out))
    });
    g.bench_function("point_f64", |b| {
        let mut e = PointEvaluator::<f64>::new(tape);
        b.iter(|| {
            let mut acc = 0.0;
            for i in 0..n {
                acc += e.eval(&scene.inputs, xs[i] as f64, ys[i] as f64, zs[i] as f64);
            }
            acc
        })
    });
    g.finish();
    let mut g = c.benchmark_group("render");
    g.sample_size(10);
    g.bench_function("showcase_64x64", |b| {
        b.iter(|| render(&scene, &RenderOptions::default()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
