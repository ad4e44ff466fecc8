//! Developer tool: how long the driver takes to compile a tracer module.
//!
//! `shader_cost dump SCENE OUT.wgsl [compiled|interpreted]` writes a scene's module;
//! `shader_cost time FILE.wgsl` builds it and runs one empty dispatch (lavapipe
//! compiles at the first dispatch), printing both times. Set
//! `MESA_SHADER_CACHE_DISABLE=true` to measure cold compiles.

use isoray_gpu::{GpuRenderer, Kernel, SceneCode};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    match (args.get(1).map(String::as_str), args.get(2)) {
        (Some("dump"), Some(scene)) if args.len() > 3 => {
            let scene = isoray_scene::load(std::path::Path::new(scene), &[]).unwrap_or_else(|e| exit(&e.rendered));
            let kernel = match args.get(4).map(String::as_str) {
                Some("interpreted") => Kernel::Interpreted,
                _ => Kernel::Compiled,
            };
            let code = SceneCode::new(&scene, kernel).unwrap_or_else(|e| exit(&e));
            std::fs::write(&args[3], code.source).unwrap_or_else(|e| exit(&e.to_string()));
        }
        (Some("time"), Some(file)) => {
            let source = std::fs::read_to_string(file).unwrap_or_else(|e| exit(&e.to_string()));
            let renderer = GpuRenderer::new().unwrap_or_else(|e| exit(&e.to_string()));
            let (created, compiled) = renderer.time_module(&source).unwrap_or_else(|e| exit(&e.to_string()));
            println!(
                "pipeline {:.2} s, first dispatch done at {:.2} s",
                created.as_secs_f64(),
                compiled.as_secs_f64()
            );
        }
        _ => exit("usage: shader_cost dump SCENE OUT.wgsl [compiled|interpreted] | time FILE.wgsl"),
    }
}

fn exit(message: &str) -> ! {
    eprintln!("error: {message}");
    std::process::exit(1)
}
