//! Frame times of the GPU renderer (and the CPU renderer beside it), for
//! `bench/gpu/lavapipe.sh` and `bench/gpu/device.sh`.
//!
//! ```text
//! gpu_frames SCENE [--size WxH] [--frames N] [--warmup K] [--cpu N] [--latency]
//!        [--label TEXT] [--kernel compiled|interpreted] [--walk-meshes] [--set KEY=VALUE]...
//! ```
//!
//! Prints one tab-separated line: label, size, the median GPU time of the
//! frames' passes (timestamp queries; `-` without them), the median frame
//! wall time on the host, and with `--cpu N` the median of N CPU renders
//! in the same process. With `--latency` it also prints the time from a
//! parameter change (the first `[params]` entry, else the time) to the
//! next finished frame, and from a structural edit (a new object) to the
//! next finished frame, pipeline build included. A scene with an
//! `[animation]` is played: each frame moves it to the next frame's time
//! (tracks, bones, MIDI mappings) before it is drawn, and the wall time
//! includes that move and the upload of the new inputs. `--walk-meshes`
//! walks the meshes' trees for the primary rays instead of reading the
//! raster prepass.

use std::time::{Duration, Instant};

use isoray_gpu::{GpuRenderOptions, GpuRenderer, Kernel};
use isoray_scene::Scene;
use isoray_shape::Value;

struct Args {
    scene: String,
    size: Option<(u32, u32)>,
    frames: usize,
    warmup: usize,
    cpu: usize,
    latency: bool,
    label: String,
    kernel: Option<Kernel>,
    walk_meshes: bool,
    sets: Vec<String>,
}

fn parse() -> Result<Args, String> {
    let mut it = std::env::args().skip(1);
    let mut a = Args {
        scene: String::new(),
        size: None,
        frames: 100,
        warmup: 10,
        cpu: 0,
        latency: false,
        label: String::new(),
        kernel: None,
        walk_meshes: false,
        sets: Vec::new(),
    };
    let num = |v: Option<String>, what: &str| -> Result<usize, String> {
        v.ok_or(format!("{what} needs a value"))?
            .parse()
            .map_err(|e| format!("{what}: {e}"))
    };
    while let Some(x) = it.next() {
        match x.as_str() {
            "--size" => {
                let v = it.next().ok_or("--size needs WxH")?;
                let (w, h) = v.split_once('x').ok_or("--size is WxH")?;
                a.size = Some((
                    w.parse().map_err(|_| "bad width")?,
                    h.parse().map_err(|_| "bad height")?,
                ));
            }
            "--frames" => a.frames = num(it.next(), "--frames")?.max(1),
            "--warmup" => a.warmup = num(it.next(), "--warmup")?,
            "--cpu" => a.cpu = num(it.next(), "--cpu")?,
            "--latency" => a.latency = true,
            "--label" => a.label = it.next().ok_or("--label needs text")?,
            "--kernel" => {
                let name = it.next().unwrap_or_default();
                a.kernel = Some(Kernel::from_name(&name).ok_or("--kernel is compiled or interpreted")?);
            }
            "--walk-meshes" => a.walk_meshes = true,
            "--set" => a.sets.push(it.next().ok_or("--set needs KEY=VALUE")?),
            s if a.scene.is_empty() && !s.starts_with('-') => a.scene = s.to_string(),
            s => return Err(format!("unexpected argument `{s}`")),
        }
    }
    if a.scene.is_empty() {
        return Err("usage: gpu_frames SCENE [--size WxH] [--frames N] [--warmup K] [--cpu N] [--latency] [--label TEXT] [--kernel compiled|interpreted] [--walk-meshes] [--set KEY=VALUE]...".into());
    }
    Ok(a)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let a = parse()?;
    let mut sets = a.sets.clone();
    if let Some((w, h)) = a.size {
        sets.push(format!("render.width={w}"));
        sets.push(format!("render.height={h}"));
    }
    let mut scene = isoray_scene::load(std::path::Path::new(&a.scene), &sets).map_err(|e| e.rendered)?;
    let mut gpu = GpuRenderer::new().map_err(|e| e.to_string())?;
    let opts = GpuRenderOptions {
        timing: true,
        kernel: a.kernel,
        no_mesh_raster: a.walk_meshes,
        ..Default::default()
    };
    let frame = |gpu: &mut GpuRenderer, scene: &Scene| gpu.render(scene, &opts).map_err(|e| e.to_string());
    let anim = scene.animation;
    let mut tick = 0u64;
    // The next frame's time, for an animated scene.
    let mut advance = |scene: &mut Scene| -> Result<Duration, String> {
        let Some(a) = anim else { return Ok(Duration::ZERO) };
        let start = Instant::now();
        tick += 1;
        scene
            .set_time(a.time_of(tick % a.frame_count()))
            .map_err(|e| e.rendered)?;
        Ok(start.elapsed())
    };
    let (_, _, first) = frame(&mut gpu, &scene)?;
    let build = first.pipeline_build.map_or(0.0, ms);
    for _ in 0..a.warmup {
        advance(&mut scene)?;
        frame(&mut gpu, &scene)?;
    }
    let mut gpu_ms = Vec::new();
    let mut wall_ms = Vec::new();
    let mut rebuilt = 0;
    for _ in 0..a.frames {
        let moved = advance(&mut scene)?;
        let (_, _, t) = frame(&mut gpu, &scene)?;
        if let Some(g) = t.gpu_ms() {
            gpu_ms.push(g);
        }
        rebuilt += usize::from(t.pipeline_build.is_some());
        wall_ms.push(ms(t.wall + moved));
    }
    let cpu = (a.cpu > 0).then(|| {
        let times: Vec<f64> = (0..a.cpu)
            .map(|_| {
                let start = Instant::now();
                let _ = isoray_render::render(&scene, &Default::default());
                ms(start.elapsed())
            })
            .collect();
        median(times)
    });
    let r = &scene.render;
    let fmt = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.3}"));
    println!(
        "{}\t{}x{}\tkernel={}\tgpu_ms={}\twall_ms={:.3}\tcpu_ms={}\tbuild_ms={build:.0}\tanimated={}\trebuilt={rebuilt}\tadapter={}",
        if a.label.is_empty() { &a.scene } else { &a.label },
        r.width,
        r.height,
        first.kernel.map_or("-", |k| k.name()),
        fmt((!gpu_ms.is_empty()).then(|| median(gpu_ms.clone()))),
        median(wall_ms),
        fmt(cpu),
        if anim.is_some() { "yes" } else { "no" },
        gpu.gpu().adapter_name()
    );
    if a.latency {
        // A parameter change: new buffers, the same pipeline.
        let param = scene.library.params().iter().find_map(|(n, v)| match v {
            Value::Float(x) => Some((n.clone(), *x)),
            _ => None,
        });
        let start = Instant::now();
        match &param {
            Some((name, v)) => scene
                .set_param(name, Value::Float(v * 1.01 + 0.01))
                .map_err(|e| e.rendered)?,
            None => scene.set_time(0.25).map_err(|e| e.rendered)?,
        }
        let (_, _, t) = frame(&mut gpu, &scene)?;
        let what = param.map_or("time".to_string(), |(n, _)| format!("params.{n}"));
        println!(
            "latency\tparameter change ({what}) to finished frame: {:.1} ms (pipeline {})",
            ms(start.elapsed()),
            if t.pipeline_build.is_some() {
                "rebuilt"
            } else {
                "reused"
            }
        );
        // A structural edit: one more object (a new shape text), so a new pipeline.
        let path = std::path::Path::new(&a.scene);
        let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
        let edited = format!("{text}\n[[object]]\nshape = \"sphere(p - vec3(0.0, 4.0, -3.0), 0.5)\"\n");
        let start = Instant::now();
        let scene2 = isoray_scene::load_str(&edited, &a.scene, &sets).map_err(|e| e.rendered)?;
        let (_, _, t) = frame(&mut gpu, &scene2)?;
        println!(
            "latency\tstructural edit (a new object) to finished frame: {:.1} ms (pipeline build {:.1} ms)",
            ms(start.elapsed()),
            t.pipeline_build.map_or(0.0, ms)
        );
    }
    Ok(())
}
