//! Renders an animation in one process: the scene is loaded and compiled
//! once, then only the time changes from frame to frame (nothing is
//! recompiled). The counterpart of running `isoray render --time T` once per
//! frame; `bench/live/frames.sh` compares the two.
//!
//! ```text
//! cargo run --release -p isoray-render --example frames -- SCENE FRAMES FPS OUTDIR [--set KEY=VALUE]...
//! ```

use std::path::PathBuf;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 4 {
        eprintln!("usage: frames SCENE FRAMES FPS OUTDIR [--set KEY=VALUE]...");
        std::process::exit(2);
    }
    let (scene, frames, fps, out) = (&args[0], &args[1], &args[2], PathBuf::from(&args[3]));
    let frames: u32 = frames.parse().expect("FRAMES is a number");
    let fps: f64 = fps.parse().expect("FPS is a number");
    let overrides: Vec<String> = args[4..]
        .chunks(2)
        .filter(|c| c[0] == "--set" && c.len() == 2)
        .map(|c| c[1].clone())
        .collect();
    let start = Instant::now();
    let mut scene = isoray_scene::load(std::path::Path::new(scene), &overrides).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2)
    });
    let load = start.elapsed().as_secs_f64();
    std::fs::create_dir_all(&out).expect("the output folder can be made");
    let opts = isoray_render::RenderOptions::default();
    for n in 0..frames {
        scene
            .set_time(n as f64 / fps)
            .expect("the scene is valid at every frame");
        let (img, _) = isoray_render::render(&scene, &opts);
        let path = out.join(format!("frame{n:04}.png"));
        isoray_render::output::write_png(&path, img.width, img.height, &img.color).expect("the frame is written");
    }
    let total = start.elapsed().as_secs_f64();
    println!("{frames} frames in {total:.2} s (load and compile once: {load:.3} s)");
}
