//! Measuring the polygon pipeline (`isoray-raster`) against the ray tracer
//! (`isoray-render`) on the same scene (`isoray raster --error-vs-raytrace`).
//! It needs both renderers, so it lives in the command line and neither
//! renderer depends on the other.
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

use isoray_raster::render::{HiddenSurface, RasterImage, RasterOptions, ReflectionProbe, ShadowMethod};
use isoray_render::{render, RenderOptions};
use isoray_scene::{Scene, ShadowMode};
use isoray_shade::srgb::to_srgb8;

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

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use isoray_raster::render::{raster, ReflectionMethod};

    use super::*;

    const MIRROR: &str = r#"
[camera]
position = [0.0, 1.5, 4.0]
target = [0.0, 0.3, 0.0]

[render]
width = 48
height = 32
aa = 2

[[light]]
kind = "point"
position = [2.0, 4.0, 3.0]

[material.mirror]
reflectivity = 0.8

[[object]]
shape = "sphere(p - vec3(0.0, 0.5, 0.0), 0.5)"

[[object]]
material = "mirror"
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"
"#;

    fn scene() -> Scene {
        isoray_scene::load_str(MIRROR, "mirror.toml", &[]).expect("scene loads")
    }

    #[test]
    fn angle_statistics() {
        assert_eq!(AngleStats::of(&[]), AngleStats::default());
        let s = AngleStats::of(&[3.0, 1.0, 2.0, 4.0]);
        assert_eq!(s.mean, 2.5);
        assert_eq!(s.rms, (30.0f64 / 4.0).sqrt());
        assert_eq!((s.p95, s.max), (4.0, 4.0));
        // The 95th percentile of 1..=100 is 95.
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(AngleStats::of(&v).p95, 95.0);
    }

    #[test]
    fn psnr_on_srgb_bytes() {
        let a = [[0.5f32, 0.5, 0.5]; 4];
        assert_eq!(psnr(&a, &a), f64::INFINITY);
        // Black against white: every byte differs by 255, MSE = 255², 0 dB.
        assert_eq!(psnr(&[[0.0; 3]], &[[1.0; 3]]), 0.0);
        // One byte in three off by one: MSE = 1/3, 10 log10(3 · 255²).
        let b = [[0.0f32, 0.0, 0.0]];
        let c = [[0.000_304f32, 0.0, 0.0]]; // sRGB code 1
        let expected = 10.0 * (3.0 * 255.0f64 * 255.0).log10();
        assert!((psnr(&b, &c) - expected).abs() < 1e-9);
    }

    #[test]
    fn the_reference_matches_what_the_pipeline_draws() {
        let s = scene();
        let z = reference_scene(&s, &RasterOptions::default());
        assert!(!z.render.ao);
        assert_eq!(z.render.shadows, ShadowMode::None);
        assert_eq!(z.render.aa, 1);
        let a = reference_scene(
            &s,
            &RasterOptions {
                hidden: HiddenSurface::ABuffer,
                shadows: ShadowMethod::Buffer,
                ..RasterOptions::default()
            },
        );
        assert_eq!(a.render.shadows, ShadowMode::Hard);
        assert_eq!(a.render.aa, 2);
    }

    #[test]
    fn exact_reflections_find_the_sphere_or_escape() {
        let s = scene();
        // From the floor below the sphere, straight up: the sphere (object 0).
        let up = ReflectionProbe {
            pixel: 0,
            origin: DVec3::new(0.0, 0.0, 0.0),
            normal: DVec3::Y,
            direction: DVec3::Y,
            footprint: 0.01,
            found: None,
        };
        assert_eq!(true_reflection(&s, &up), Some(0));
        // Far from it, towards the sky: nothing.
        let away = ReflectionProbe {
            origin: DVec3::new(3.0, 0.0, 0.0),
            direction: DVec3::new(1.0, 1.0, 0.0).normalize(),
            ..up
        };
        assert_eq!(true_reflection(&s, &away), None);
        assert_eq!(away.angular_error(), 0.0);
    }

    #[test]
    fn the_report_measures_a_mirrored_sphere() {
        let s = scene();
        let opts = RasterOptions {
            resolution: 24,
            map_size: 64,
            reflections: ReflectionMethod::ABufferMap,
            probes: true,
            ..RasterOptions::default()
        };
        let image = raster(&s, &opts).unwrap();
        let (report, traced) = error_vs_raytrace(&s, &image, &opts);
        assert_eq!((report.width, report.height), (48, 32));
        assert_eq!(traced.len(), 48 * 32);
        assert!(report.reflective_pixels > 100, "{report:?}");
        assert!(report.wrong_fraction < 0.5, "{report:?}");
        assert!(report.angular_error_deg.mean < 10.0, "{report:?}");
        assert!(report.psnr_db.is_finite() && report.psnr_db > 15.0, "{report:?}");
    }
}
