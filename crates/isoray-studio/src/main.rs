//! `isoray-studio [SCENE] [--screenshot OUT.png] [--size WxH] [--cpu]`

use std::path::PathBuf;

use isoray_studio::{Studio, StudioOptions};

const USAGE: &str = "usage: isoray-studio [SCENE.toml] [--screenshot OUT.png] [--size WxH] [--cpu | --gpu]

  SCENE.toml          the scene file to open (a new scene when absent)
  --screenshot OUT    wait until the preview has converged, write a PNG of the
                      whole window to OUT and exit
  --size WxH          the window's size in points (default 1280x800)
  --cpu               preview with the CPU renderer even when there is a GPU
  --gpu               preview with the GPU renderer even on a software adapter
                      (lavapipe, llvmpipe, SwiftShader, WARP), where the CPU
                      renderer is faster and is the default";

fn parse() -> Result<(StudioOptions, [f32; 2]), String> {
    let mut options = StudioOptions::default();
    let mut size = [1280.0, 800.0];
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "-h" | "--help" => {
                println!("{USAGE}");
                std::process::exit(0);
            }
            "--screenshot" => {
                options.screenshot = Some(PathBuf::from(args.next().ok_or("--screenshot needs a file name")?));
            }
            "--size" => {
                let v = args.next().ok_or("--size needs WxH, for example 1280x800")?;
                let parsed = v
                    .split_once('x')
                    .and_then(|(w, h)| Some([w.parse::<f32>().ok()?, h.parse::<f32>().ok()?]))
                    .filter(|[w, h]| *w >= 64.0 && *h >= 64.0 && *w <= 16384.0 && *h <= 16384.0);
                size = parsed.ok_or(format!("--size: expected WxH with each from 64 to 16384, found `{v}`"))?;
            }
            "--cpu" => options.renderer = isoray_studio::preview::PreviewChoice::Cpu,
            "--gpu" => options.renderer = isoray_studio::preview::PreviewChoice::Gpu,
            s if s.starts_with('-') => return Err(format!("unknown option `{s}`\n\n{USAGE}")),
            s => {
                if options.scene.is_some() {
                    return Err(format!("one scene at a time: `{s}` is a second one\n\n{USAGE}"));
                }
                options.scene = Some(PathBuf::from(s));
            }
        }
    }
    Ok((options, size))
}

fn main() {
    let (options, size) = match parse() {
        Ok(x) => x,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let native = eframe::NativeOptions {
        viewport: eframe::egui::ViewportBuilder::default()
            .with_inner_size(size)
            .with_title("isoray studio"),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    let result = eframe::run_native(
        "isoray studio",
        native,
        Box::new(move |cc| Ok(Box::new(Studio::new(&cc.egui_ctx, options)))),
    );
    if let Err(e) = result {
        eprintln!(
            "error: the studio's window could not open: {e}\n  = help: it needs a display (X11 or Wayland) and a Vulkan driver; \
             for a software one install Debian's `mesa-vulkan-drivers`, and under no display run it inside `xvfb-run`"
        );
        std::process::exit(1);
    }
}
