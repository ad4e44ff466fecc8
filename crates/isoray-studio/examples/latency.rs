//! The studio's latencies, measured in the studio itself: a headless
//! window (egui_kittest) of the given size on a scene, driven by pointer
//! events as a user's hand would, with the preview on the renderer the
//! studio picks by default (the GPU renderer on a hardware adapter, the CPU
//! renderer otherwise) or, with `--gpu` or `--cpu`, on that one.
//!
//! ```text
//! cargo run --release -p isoray-studio --example latency -- \
//!     [--size 1280x800] [--cpu | --gpu] [--moves 12] SCENE [OPEN_ONLY_SCENE…]
//! ```
//!
//! On the first scene: the time to open it (until the first final frame at
//! full size), the frame time while orbiting (pointer moved, then the frame
//! that answers it on screen), slider-to-frame (a light's intensity slider
//! dragged), node-drag-to-frame (a number in the graph dragged),
//! release-to-full-frame, and structural-edit-to-frame (Add object, then
//! undo). On the other scenes: the time to open them. Medians, in ms, as a
//! Markdown table; `bash bench/studio/latency.sh` runs it as
//! docs/BENCHMARKS.md records.

use std::time::{Duration, Instant};

use egui_kittest::kittest::Queryable;
use egui_kittest::Harness;
use isoray_studio::graph::GraphNode;
use isoray_studio::{Studio, StudioOptions};

/// How long any one wait may take before the run gives up.
const PATIENCE: Duration = Duration::from_secs(300);

struct Args {
    size: egui::Vec2,
    renderer: isoray_studio::preview::PreviewChoice,
    moves: usize,
    scenes: Vec<std::path::PathBuf>,
}

fn args() -> Result<Args, String> {
    let mut a = Args {
        size: egui::vec2(1280.0, 800.0),
        renderer: Default::default(),
        moves: 12,
        scenes: vec![],
    };
    let mut it = std::env::args().skip(1);
    while let Some(s) = it.next() {
        match s.as_str() {
            "--cpu" => a.renderer = isoray_studio::preview::PreviewChoice::Cpu,
            "--gpu" => a.renderer = isoray_studio::preview::PreviewChoice::Gpu,
            "--size" => {
                let v = it.next().ok_or("--size needs WxH")?;
                let (w, h) = v.split_once('x').ok_or(format!("--size: expected WxH, found `{v}`"))?;
                let (w, h) = (w.parse::<f32>(), h.parse::<f32>());
                a.size = match (w, h) {
                    (Ok(w), Ok(h)) if w >= 64.0 && h >= 64.0 => egui::vec2(w, h),
                    _ => return Err(format!("--size: expected WxH of at least 64x64, found `{v}`")),
                };
            }
            "--moves" => {
                let v = it.next().ok_or("--moves needs a count")?;
                a.moves = v
                    .parse()
                    .ok()
                    .filter(|n| *n > 0)
                    .ok_or(format!("--moves: expected a count, found `{v}`"))?;
            }
            s if s.starts_with('-') => return Err(format!("unknown option `{s}`")),
            s => a.scenes.push(s.into()),
        }
    }
    if a.scenes.is_empty() {
        return Err("usage: latency [--size WxH] [--cpu | --gpu] [--moves N] SCENE [OPEN_ONLY_SCENE…]".into());
    }
    Ok(a)
}

fn open(path: &std::path::Path, a: &Args) -> Harness<'static, Studio> {
    let options = StudioOptions {
        scene: Some(path.to_path_buf()),
        renderer: a.renderer,
        screenshot: None,
    };
    Harness::builder()
        .with_size(a.size)
        .build_eframe(move |cc| Studio::new(&cc.egui_ctx, options))
}

/// Steps the UI until `done` holds; the time it took.
fn until(h: &mut Harness<'_, Studio>, what: &str, done: impl Fn(&Studio) -> bool) -> Duration {
    let t = Instant::now();
    loop {
        h.run_steps(1);
        if done(h.state()) {
            return t.elapsed();
        }
        if t.elapsed() > PATIENCE {
            eprintln!("error: gave up waiting for {what} after {PATIENCE:?}");
            std::process::exit(1);
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// The preview shows the latest request's final frame (on the CPU, the
/// last of its progressive passes).
fn converged(s: &Studio) -> bool {
    s.wanted() > 0 && s.shown().is_some_and(|f| f.id == s.wanted() && f.done)
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Drags from `from` in `moves` steps of `step`; for each step, the time
/// from the pointer's move to the frame that answers it on screen. Then
/// releases and returns (move-to-frame times, release-to-full-frame time,
/// the size of the frames shown while dragging).
fn drag(h: &mut Harness<'_, Studio>, from: egui::Pos2, step: egui::Vec2, moves: usize) -> (Vec<f64>, f64, (u32, u32)) {
    h.hover_at(from);
    h.run_steps(1);
    h.drag_at(from);
    h.run_steps(1);
    let mut times = vec![];
    let mut size = (0, 0);
    let mut at = from;
    for _ in 0..moves {
        at += step;
        let before = h.state().wanted();
        let t = Instant::now();
        h.hover_at(at);
        until(h, "the drag to ask for a frame", |s| s.wanted() != before);
        until(h, "a frame while dragging", converged);
        times.push(ms(t.elapsed()));
        if let Some(f) = h.state().shown() {
            size = (f.width, f.height);
        }
    }
    let t = Instant::now();
    h.drop_at(at);
    until(h, "the full frame after the release", |s| {
        converged(s) && s.shown().is_some_and(|f| f.width >= size.0)
    });
    (times, ms(t.elapsed()), size)
}

fn main() {
    let a = match args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let first = &a.scenes[0];
    let t = Instant::now();
    let mut h = open(first, &a);
    until(&mut h, "the first full frame", converged);
    let open_ms = ms(t.elapsed());
    let full = h.state().shown().expect("a frame");
    println!(
        "studio {}×{} on {} ({}), preview {}×{} px, full frame {:.0} ms\n",
        a.size.x,
        a.size.y,
        first.display(),
        h.state().backend().map_or("no renderer yet".into(), |b| b.describe()),
        full.width,
        full.height,
        full.ms
    );
    println!("| measure | median | runs | frames while dragging |");
    println!("|---|---|---|---|");
    let row = |what: &str, v: f64, n: usize, size: Option<(u32, u32)>| {
        let size = size.map_or(String::new(), |(w, h)| format!("{w}×{h}"));
        println!("| {what} | {v:.0} ms | {n} | {size} |");
    };
    row(&format!("open {}", first.display()), open_ms, 1, None);

    // Orbit: drag across the preview's middle.
    let c = h.state().preview_rect().center();
    let (orbit, release, size) = drag(&mut h, c - egui::vec2(60.0, 0.0), egui::vec2(8.0, 2.0), a.moves);
    row("orbit: pointer move to frame", median(orbit), a.moves, Some(size));
    row("orbit: release to full frame", release, 1, None);

    // A slider: the first light's intensity, dragged to the right.
    let slider = h.get_by_label("light.0.intensity").rect();
    let from = slider.left_center() + egui::vec2(slider.width() * 0.1, 0.0);
    let (slide, release, size) = drag(&mut h, from, egui::vec2(3.0, 0.0), a.moves);
    row("slider to frame", median(slide), a.moves, Some(size));
    row("slider: release to full frame", release, 1, None);

    // A number in the graph: the first sphere's radius.
    let sphere = h
        .state()
        .graph()
        .snarl
        .node_ids()
        .find(|(_, n)| n.title() == "sphere" && !matches!(n, GraphNode::Object { .. }))
        .map(|(id, _)| id.0);
    match sphere {
        Some(id) => {
            let to_screen = h
                .ctx
                .memory(|m| m.to_global.values().next().copied())
                .unwrap_or_default();
            let r = to_screen * h.get_by_label(&format!("sphere #{id} r")).rect().center();
            let (nodes, release, size) = drag(&mut h, r, egui::vec2(3.0, 0.0), a.moves);
            row("node value drag to frame", median(nodes), a.moves, Some(size));
            row("node value: release to full frame", release, 1, None);
        }
        None => eprintln!("note: no sphere node in {}; node drag not measured", first.display()),
    }

    // Structural edits: a new object, then undo, three times (the first
    // builds new pipelines; later ones may find them in the drivers' caches).
    let mut add = vec![];
    let mut undo = vec![];
    for _ in 0..3 {
        let before = h.state().wanted();
        let t = Instant::now();
        h.get_by_label("Add object").click();
        until(&mut h, "the new object's frame", |s| {
            s.wanted() != before && converged(s)
        });
        add.push(ms(t.elapsed()));
        let before = h.state().wanted();
        let t = Instant::now();
        h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
        until(&mut h, "the undone frame", |s| s.wanted() != before && converged(s));
        undo.push(ms(t.elapsed()));
    }
    row(
        &format!("structural edit (Add object) to full frame, first {:.0} ms", add[0]),
        median(add),
        3,
        None,
    );
    row(
        &format!("undo of it to full frame, first {:.0} ms", undo[0]),
        median(undo),
        3,
        None,
    );
    drop(h);

    for path in &a.scenes[1..] {
        let t = Instant::now();
        let mut h = open(path, &a);
        until(&mut h, "the first full frame", converged);
        row(&format!("open {}", path.display()), ms(t.elapsed()), 1, None);
    }
}
