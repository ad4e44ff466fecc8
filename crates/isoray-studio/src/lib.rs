//! isoray studio: a live editor of isoray scenes.
//!
//! The window ([`app::Studio`]) edits a [`Document`] (the scene file's
//! text, with undo and redo, saved atomically) and shows it through the
//! [`preview::Preview`] worker, on the GPU renderer or the CPU renderer's
//! progressive passes. Run it with
//! `cargo run --release -p isoray-studio -- [SCENE]`.

// The scene loader's error carries its located diagnostics by value, as
// isoray-scene's own functions return it.
#![allow(clippy::result_large_err)]

pub mod app;
pub mod curves;
pub mod document;
pub mod export;
pub mod graph;
pub mod midi;
pub mod orbit;
pub mod preview;
pub mod surfaces;

pub use app::{Studio, StudioOptions};
pub use document::Document;

/// Writes a screenshot of the window as a PNG, atomically.
pub fn write_screenshot(path: &std::path::Path, image: &eframe::egui::ColorImage) -> std::io::Result<()> {
    let [w, h] = image.size;
    let mut bytes = Vec::with_capacity(w * h * 4);
    for c in &image.pixels {
        bytes.extend_from_slice(&c.to_array());
    }
    let img = image::RgbaImage::from_raw(w as u32, h as u32, bytes)
        .ok_or_else(|| std::io::Error::other("the screenshot's size does not match its pixels"))?;
    isoray_scene::replace_atomically(path, |tmp| {
        img.save_with_format(tmp, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
}
