//! Animation on the GPU: a scene moved from frame to frame by its tracks
//! (a parameter, an object's placement, a light) and a MIDI take renders
//! each frame exactly as a scene loaded at that time does, on one pipeline
//! built once: tracks are runtime inputs, not new shaders.

use isoray_gpu::{GpuRenderOptions, GpuRenderer};
use isoray_scene::{load_str, load_str_with, LoadOptions};
use isoray_shade::srgb::to_srgb8;

/// examples/tracks.toml at 40×28.
fn scene_text() -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/tracks.toml");
    let text = std::fs::read_to_string(path).unwrap();
    text.replace("width = 640", "width = 40")
        .replace("height = 360", "height = 28")
}

#[test]
fn each_frame_on_one_pipeline_is_the_scene_loaded_at_its_time() {
    std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    let mut gpu = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    let opts = GpuRenderOptions::default();
    let text = scene_text();
    let mut moving = load_str(&text, "anim.toml", &[]).unwrap();
    let anim = moving.animation.unwrap();
    let mut frames = Vec::new();
    for n in 0..anim.frame_count() {
        let t = anim.time_of(n);
        moving.set_time(t).unwrap();
        let (img, _, timing) = gpu.render(&moving, &opts).unwrap();
        if n > 0 {
            assert!(timing.pipeline_build.is_none(), "frame {n} built a pipeline");
        }
        frames.push(to_srgb8(&img.color));
    }
    assert_eq!(
        frames.iter().collect::<std::collections::HashSet<_>>().len(),
        frames.len(),
        "every frame moves"
    );
    // Each frame equals a scene loaded at its time, rendered on its own.
    for (n, frame) in frames.iter().enumerate() {
        let opts_t = LoadOptions {
            time: anim.time_of(n as u64),
            ..LoadOptions::default()
        };
        let loaded = load_str_with(&text, "anim.toml", &[], &opts_t).unwrap();
        let mut fresh = GpuRenderer::new().unwrap();
        let (img, _, _) = fresh.render(&loaded, &opts).unwrap();
        assert!(to_srgb8(&img.color) == *frame, "frame {n}");
    }
}
