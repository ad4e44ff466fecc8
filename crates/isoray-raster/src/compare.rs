//! Measuring the polygon pipeline against the ray tracer on the same scene
//! (`isoray raster --error-vs-raytrace`).
//!
//! * **Angular error** of the reflected direction, per reflective pixel
//!   centre: the angle between the exact mirror direction and the direction
//!   from the surface point to the point the environment map returned
//!   ([`ReflectionProbe::angular_error`]; 0 where the map returned the
//!   background, which is looked up along the exact direction).
//! * **Wrong pixels**: the fraction of reflective pixel centres whose
//!   reflection shows the wrong object — the object found differs from the
//!   one the exact reflected ray hits (or one of them is the background).
//!   The exact ray is sphere-traced through the scene's distance field from
//!   the surface point, and its hit is assigned to the object whose surface
//!   is nearest.
//! * **PSNR** of the whole image against the ray tracer's, on 8-bit sRGB
//!   values: `10 log10(255² / MSE)`.
//!
//! The reference is rendered by `isoray_render::render` with ambient
//! occlusion off (the pipeline has none), hard shadows when the pipeline
//! draws shadows and none otherwise, one sample per pixel for the Z-buffer
//! and the scene's `render.aa` for the A-buffer.

use isoray_render::output::to_srgb8;
use isoray_render::{render, RenderOptions};
use isoray_scene::{Scene, ShadowMode};

use crate::render::{HiddenSurface, RasterImage, RasterOptions, ReflectionProbe, ShadowMethod};

/// Summary statistics of a set of angles, in degrees.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AngleStats {
    /// Mean.
    pub mean: f64,
    /// Root mean square.
    pub rms: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest.
    pub max: f64,
}

impl AngleStats {
    /// Statistics of `degrees` (zeros when empty).
    pub fn of(degrees: &[f64]) -> Self {
        if degrees.is_empty() {
            return AngleStats::default();
        }
        let n = degrees.len() as f64;
        let mut sorted = degrees.to_vec();
        sorted.sort_by(f64::total_cmp);
        let k = ((0.95 * n).ceil() as usize).clamp(1, sorted.len()) - 1;
        AngleStats {
            mean: degrees.iter().sum::<f64>() / n,
            rms: (degrees.iter().map(|d| d * d).sum::<f64>() / n).sqrt(),
            p95: sorted[k],
            max: sorted[sorted.len() - 1],
        }
    }
}

/// The comparison of one raster image with the ray tracer's.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorReport {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Reflective pixel centres measured.
    pub reflective_pixels: usize,
    /// Angular error of the reflected direction, degrees.
    pub angular_error_deg: AngleStats,
    /// Reflective pixels showing the wrong object.
    pub wrong_pixels: usize,
    /// `wrong_pixels / reflective_pixels` (0 when there are none).
    pub wrong_fraction: f64,
    /// PSNR of the image against the ray tracer's, dB (infinite when identical).
    pub psnr_db: f64,
    /// Seconds the ray tracer took.
    pub raytrace_seconds: f64,
}

/// The scene the reference image is ray traced with (see the module docs).
pub fn reference_scene(scene: &Scene, opts: &RasterOptions) -> Scene {
    let mut s = scene.clone();
    s.render.ao = false;
    s.render.shadows = if opts.shadows == ShadowMethod::None {
        ShadowMode::None
    } else {
        ShadowMode::Hard
    };
    if opts.hidden == HiddenSurface::ZBuffer {
        s.render.aa = 1;
    }
    s
}

/// The object the exact reflected ray of `probe` hits, by sphere tracing the
/// scene's distance field (`None`: it escapes).
pub fn true_reflection(scene: &Scene, probe: &ReflectionProbe) -> Option<u32> {
    let r = &scene.render;
    let start = probe.origin + probe.normal * (0.25 * probe.footprint);
    let eps = r.hit_epsilon.max(1e-6);
    let step = r.step_scale.clamp(1e-3, 1.0);
    let mut t = 0.0;
    for _ in 0..(4 * r.max_steps.max(64)) {
        let x = start + probe.direction * t;
        let d = scene.distance(x.to_array());
        if !d.is_finite() {
            return None;
        }
        if d.abs() < eps {
            let mut best = (f64::INFINITY, None);
            for (i, o) in scene.objects.iter().enumerate() {
                let di = o.shape.eval_with(&scene.inputs, x.to_array()).abs();
                if di < best.0 {
                    best = (di, Some(i as u32));
                }
            }
            return best.1;
        }
        t += d.abs().max(eps * 0.5) * step;
        if t > r.max_distance {
            return None;
        }
    }
    None
}

/// PSNR (dB) between two linear RGB images on their 8-bit sRGB values.
pub fn psnr(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let (a8, b8) = (to_srgb8(a), to_srgb8(b));
    let n = a8.len().min(b8.len()).max(1);
    let mse = a8
        .iter()
        .zip(&b8)
        .map(|(&x, &y)| {
            let d = x as f64 - y as f64;
            d * d
        })
        .sum::<f64>()
        / n as f64;
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    }
}

/// Ray traces the reference of `image` (rendered from `scene` with `opts`,
/// with probes) and measures the errors. Returns the report and the
/// reference image (linear RGB).
pub fn error_vs_raytrace(scene: &Scene, image: &RasterImage, opts: &RasterOptions) -> (ErrorReport, Vec<[f32; 3]>) {
    let reference = reference_scene(scene, opts);
    let start = std::time::Instant::now();
    let (traced, _) = render(&reference, &RenderOptions::default());
    let raytrace_seconds = start.elapsed().as_secs_f64();
    let truth: Vec<Option<u32>> = {
        use rayon::prelude::*;
        image.probes.par_iter().map(|p| true_reflection(scene, p)).collect()
    };
    let angles: Vec<f64> = image.probes.iter().map(|p| p.angular_error().to_degrees()).collect();
    let wrong_pixels = image
        .probes
        .iter()
        .zip(&truth)
        .filter(|(p, t)| p.found.map(|f| f.0) != **t)
        .count();
    let n = image.probes.len();
    let report = ErrorReport {
        width: image.width,
        height: image.height,
        reflective_pixels: n,
        angular_error_deg: AngleStats::of(&angles),
        wrong_pixels,
        wrong_fraction: if n == 0 { 0.0 } else { wrong_pixels as f64 / n as f64 },
        psnr_db: psnr(&image.color, &traced.color),
        raytrace_seconds,
    };
    (report, traced.color)
}
