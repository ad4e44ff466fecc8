//! `isoray raster`: a scene rendered by the classic polygon pipeline
//! (issue 7). Shadows, reflections and the comparison with the ray tracer
//! are accepted on the command line but not implemented yet.

use std::path::Path;
use std::time::Instant;

use clap::ValueEnum;
use isoray_raster::render::{raster, HiddenSurface, RasterOptions};
use isoray_raster::shading::Shading;
use isoray_render::output;
use isoray_scene::load;

use crate::{io_failure, usage, Failure};

/// `--hidden`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum Hidden {
    /// Z-buffer: one sample per pixel.
    Zbuffer,
    /// A-buffer: 32 subsamples per pixel (antialiased).
    Abuffer,
}

/// `--shading`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum ShadingArg {
    /// One colour per triangle.
    Flat,
    /// Vertex colours interpolated.
    Gouraud,
    /// Normals interpolated, lit per pixel.
    Phong,
}

/// `--shadows`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum Shadows {
    /// No shadows.
    None,
    /// Shadow buffers (not implemented yet).
    Buffer,
    /// Shadows from environment maps (not implemented yet).
    Envmap,
}

/// `--reflections`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum Reflections {
    /// No reflections.
    None,
    /// Blinn–Newell environment mapping (not implemented yet).
    BlinnNewell,
    /// Cube maps rendered with the Z-buffer (not implemented yet).
    ZbufferMap,
    /// Cube maps rendered with the A-buffer (not implemented yet).
    AbufferMap,
}

/// What `isoray raster` was asked to do.
pub(crate) struct RasterArgs<'a> {
    pub scene: &'a Path,
    pub output: &'a Path,
    pub hidden: Hidden,
    pub shading: ShadingArg,
    pub shadows: Shadows,
    pub reflections: Reflections,
    pub map_size: Option<u32>,
    pub error_vs_raytrace: Option<&'a Path>,
    pub resolution: Option<u32>,
    pub overrides: &'a [String],
    pub threads: Option<usize>,
    pub quiet: bool,
}

fn not_yet(what: String) -> Failure {
    usage(format!("{what} is not implemented yet in `isoray raster` (issue 7)"))
}

pub(crate) fn cmd_raster(a: &RasterArgs) -> Result<(), Failure> {
    let ext = a.output.extension().map(|e| e.to_string_lossy().to_lowercase());
    if ext.as_deref() != Some("png") {
        return Err(usage(format!("output `{}` must end in .png", a.output.display())));
    }
    if a.shadows != Shadows::None {
        let v = a
            .shadows
            .to_possible_value()
            .map(|v| v.get_name().to_owned())
            .unwrap_or_default();
        return Err(not_yet(format!("--shadows {v}")));
    }
    if a.reflections != Reflections::None {
        let v = a
            .reflections
            .to_possible_value()
            .map(|v| v.get_name().to_owned())
            .unwrap_or_default();
        return Err(not_yet(format!("--reflections {v}")));
    }
    if a.error_vs_raytrace.is_some() {
        return Err(not_yet("--error-vs-raytrace".into()));
    }
    if a.map_size == Some(0) {
        return Err(usage("--map-size must be at least 1".into()));
    }
    if a.threads == Some(0) {
        return Err(usage("--threads must be at least 1".into()));
    }
    if let Some(r) = a.resolution {
        if r < 2 {
            return Err(usage(format!("--resolution must be at least 2, found {r}")));
        }
    }
    let scene = load(a.scene, a.overrides)?;
    let opts = RasterOptions {
        hidden: match a.hidden {
            Hidden::Zbuffer => HiddenSurface::ZBuffer,
            Hidden::Abuffer => HiddenSurface::ABuffer,
        },
        shading: match a.shading {
            ShadingArg::Flat => Shading::Flat,
            ShadingArg::Gouraud => Shading::Gouraud,
            ShadingArg::Phong => Shading::Phong,
        },
        resolution: a.resolution.unwrap_or(RasterOptions::default().resolution),
        ..RasterOptions::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .map_err(|e| io_failure(format!("cannot start worker threads: {e}")))?;
    let start = Instant::now();
    let image = pool.install(|| raster(&scene, &opts)).map_err(|e| match e {
        isoray_raster::render::RasterError::Mesh(_) => io_failure(e.to_string()),
        _ => usage(e.to_string()),
    })?;
    for w in &image.warnings {
        eprintln!("warning: {w}");
    }
    output::write_png(a.output, image.width, image.height, &image.color).map_err(|e| io_failure(e.to_string()))?;
    if !a.quiet {
        println!(
            "rasterised {} triangles into {}×{} in {:.2}s → {}",
            image.triangles,
            image.width,
            image.height,
            start.elapsed().as_secs_f64(),
            a.output.display()
        );
    }
    Ok(())
}
