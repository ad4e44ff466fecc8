//! The real window: `isoray-studio EXAMPLE --screenshot` under Xvfb for
//! every example scene. Each run must exit cleanly with a 1280×800
//! screenshot whose preview area shows a picture (not one flat colour).
//! Set `ISORAY_SCREENSHOTS=DIR` to keep the screenshots (to look at them).
//!
//! Needs `xvfb-run` (Debian `xvfb`, installed by `.ci/run`).

use std::path::PathBuf;
use std::process::Command;

mod common;
use common::examples;

#[test]
fn the_window_opens_on_every_example_and_its_screenshot_shows_the_scene() {
    let has_xvfb = Command::new("xvfb-run").arg("--help").output().is_ok();
    assert!(
        has_xvfb,
        "this test opens the studio's window under Xvfb: install it with `apt-get install xvfb xauth` (.ci/run does)"
    );
    let keep = std::env::var_os("ISORAY_SCREENSHOTS").map(PathBuf::from);
    let dir = tempfile::tempdir().unwrap();
    let out_dir = keep.clone().unwrap_or_else(|| dir.path().to_path_buf());
    std::fs::create_dir_all(&out_dir).unwrap();
    let runtime = dir.path().join("xdg");
    std::fs::create_dir_all(&runtime).unwrap();
    for scene in examples() {
        let name = scene.file_stem().unwrap().to_string_lossy().to_string();
        let shot = out_dir.join(format!("studio-{name}.png"));
        let _ = std::fs::remove_file(&shot);
        let start = std::time::Instant::now();
        let out = Command::new("xvfb-run")
            .args(["-a", "-s", "-screen 0 1400x900x24"])
            .arg(env!("CARGO_BIN_EXE_isoray-studio"))
            .arg(&scene)
            .arg("--screenshot")
            .arg(&shot)
            .args(["--size", "1280x800", "--cpu"])
            .env("XDG_RUNTIME_DIR", &runtime)
            .output()
            .unwrap();
        let log = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "{name}: the studio failed ({}):\n{log}",
            out.status
        );
        let img = image::open(&shot)
            .unwrap_or_else(|e| panic!("{name}: no screenshot ({e}):\n{log}"))
            .to_rgb8();
        assert_eq!(img.dimensions(), (1280, 800), "{name}");
        // The preview is the middle of the window (graph left, controls
        // right): not one flat colour, at least a twentieth of it not the
        // background.
        let mut counts = std::collections::HashMap::new();
        let mut samples = 0;
        for y in (100..700).step_by(10) {
            for x in (600..950).step_by(10) {
                *counts.entry(img.get_pixel(x, y).0).or_insert(0usize) += 1;
                samples += 1;
            }
        }
        let commonest = counts.values().copied().max().unwrap_or(0);
        assert!(
            counts.len() >= 2 && (samples - commonest) * 20 >= samples,
            "{name}: the preview looks empty ({} colours, {commonest} of {samples} samples alike)",
            counts.len()
        );
        let colours = counts.len();
        eprintln!("{name}: {:.1} s, {colours} colours", start.elapsed().as_secs_f64());
    }
}
