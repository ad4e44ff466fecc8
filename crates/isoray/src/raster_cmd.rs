//! `isoray raster`: a scene rendered by the classic polygon pipeline, with
//! shadow buffers or environment-map shadows, environment-mapped
//! reflections and refractions, and a measured comparison with the ray
//! tracer (`--error-vs-raytrace`).

use std::path::Path;
use std::time::Instant;

use clap::ValueEnum;
use isoray_mesh::parametric::{tessellate, TessellationSettings};
use isoray_raster::render::{raster_meshes, HiddenSurface, RasterOptions, ReflectionMethod, ShadowMethod};
use isoray_raster::scene::{mesh_scene_with, MeshedScene};
use isoray_raster::shading::Shading;
use isoray_render::output;
use isoray_scene::Scene;

use crate::compare::{error_vs_raytrace, ErrorReport};
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
    /// A shadow buffer per light, with bias and percentage-closer filtering.
    Buffer,
    /// A walk from the light through the camera-centred A-buffered cube map.
    Envmap,
}

/// `--reflections`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum Reflections {
    /// No reflections.
    None,
    /// Blinn–Newell: a cube map per reflective object, looked up by direction.
    BlinnNewell,
    /// A camera-centred Z-buffered cube map, searched along the reflected ray.
    ZbufferMap,
    /// A camera-centred A-buffered cube map (back faces kept), searched through every layer.
    AbufferMap,
}

/// What `isoray raster` was asked to do.
pub(crate) struct RasterArgs<'a> {
    pub input: &'a crate::SceneArgs,
    pub output: &'a Path,
    pub hidden: Hidden,
    pub shading: ShadingArg,
    pub shadows: Shadows,
    pub reflections: Reflections,
    pub map_size: Option<u32>,
    pub error_vs_raytrace: Option<&'a Path>,
    pub resolution: Option<u32>,
    pub add_mesh: &'a [String],
    pub add_surface: &'a [String],
    pub overrides: &'a [String],
    pub threads: Option<usize>,
    pub quiet: bool,
}

pub(crate) fn cmd_raster(a: &RasterArgs) -> Result<(), Failure> {
    let ext = a.output.extension().map(|e| e.to_string_lossy().to_lowercase());
    if ext.as_deref() != Some("png") {
        return Err(usage(format!("output `{}` must end in .png", a.output.display())));
    }
    if let Some(r) = a.error_vs_raytrace {
        let ext = r.extension().map(|e| e.to_string_lossy().to_lowercase());
        if ext.as_deref() != Some("json") {
            return Err(usage(format!(
                "--error-vs-raytrace `{}` must end in .json",
                r.display()
            )));
        }
    }
    if let Some(m) = a.map_size {
        if !(1..=8192).contains(&m) {
            return Err(usage(format!("--map-size must be between 1 and 8192, found {m}")));
        }
    }
    if a.threads == Some(0) {
        return Err(usage("--threads must be at least 1".into()));
    }
    if let Some(r) = a.resolution {
        if r < 2 {
            return Err(usage(format!("--resolution must be at least 2, found {r}")));
        }
    }
    let scene = a.input.load(a.overrides)?;
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
        shadows: match a.shadows {
            Shadows::None => ShadowMethod::None,
            Shadows::Buffer => ShadowMethod::Buffer,
            Shadows::Envmap => ShadowMethod::EnvMap,
        },
        reflections: match a.reflections {
            Reflections::None => ReflectionMethod::None,
            Reflections::BlinnNewell => ReflectionMethod::BlinnNewell,
            Reflections::ZbufferMap => ReflectionMethod::ZBufferMap,
            Reflections::AbufferMap => ReflectionMethod::ABufferMap,
        },
        map_size: a.map_size.map_or(RasterOptions::default().map_size, |m| m as usize),
        probes: a.error_vs_raytrace.is_some(),
        cancel: Some(crate::jobs::cancel_token()),
        ..RasterOptions::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .map_err(|e| io_failure(format!("cannot start worker threads: {e}")))?;
    let start = Instant::now();
    let image = pool.install(|| -> Result<_, Failure> {
        let t0 = Instant::now();
        let cancel = crate::jobs::cancel_token();
        let mut meshed = mesh_scene_with(&scene, opts.resolution, Some(&cancel)).map_err(|e| {
            if e.source == isoray_mesh::MeshError::Cancelled {
                crate::jobs::cancelled()
            } else {
                io_failure(e.to_string())
            }
        })?;
        add_extras(a, &scene, &mut meshed)?;
        let mesh_secs = t0.elapsed().as_secs_f64();
        let mut image = raster_meshes(&scene, &meshed, &opts).map_err(|e| match e {
            isoray_raster::render::RasterError::Cancelled => crate::jobs::cancelled(),
            isoray_raster::render::RasterError::Mesh(_) => io_failure(e.to_string()),
            _ => usage(e.to_string()),
        })?;
        image.timings.mesh = mesh_secs;
        Ok(image)
    })?;
    for w in &image.warnings {
        eprintln!("warning: {w}");
    }
    output::write_png(a.output, image.width, image.height, &image.color).map_err(|e| io_failure(e.to_string()))?;
    if !a.quiet {
        let t = image.timings;
        println!(
            "rasterised {} triangles into {}×{} in {:.2}s (meshing {:.2}s, maps {:.2}s, drawing {:.2}s) → {}",
            image.triangles,
            image.width,
            image.height,
            start.elapsed().as_secs_f64(),
            t.mesh,
            t.maps,
            t.draw,
            a.output.display()
        );
    }
    if let Some(report_path) = a.error_vs_raytrace {
        if !a.quiet {
            eprintln!("ray tracing the reference image…");
        }
        let (report, reference) = pool.install(|| error_vs_raytrace(&scene, &image, &opts));
        let reference_png = report_path.with_extension("raytrace.png");
        output::write_png(&reference_png, image.width, image.height, &reference)
            .map_err(|e| io_failure(e.to_string()))?;
        let json = report_json(a, &report, &image, &reference_png);
        output::write_text(report_path, &json).map_err(|e| io_failure(e.to_string()))?;
        if !a.quiet {
            println!(
                "vs the ray tracer: PSNR {:.2} dB; {} reflective pixels, {:.2}% wrong, angular error mean {:.3}° max {:.3}° → {}",
                report.psnr_db,
                report.reflective_pixels,
                100.0 * report.wrong_fraction,
                report.angular_error_deg.mean,
                report.angular_error_deg.max,
                report_path.display()
            );
        }
    }
    Ok(())
}

/// `SPEC` = `NAME[@MATERIAL]`: the name and the material's index (default: the scene's first material).
fn name_and_material<'s>(flag: &str, spec: &'s str, scene: &Scene) -> Result<(&'s str, usize), Failure> {
    let (name, material) = match spec.rsplit_once('@') {
        Some((n, m)) => (n, Some(m)),
        None => (spec, None),
    };
    if name.is_empty() {
        return Err(usage(format!("{flag} `{spec}`: expected NAME[@MATERIAL]")));
    }
    let index = match material {
        None => 0,
        Some(m) => scene.materials.iter().position(|x| x.name == m).ok_or_else(|| {
            let names: Vec<&str> = scene.materials.iter().map(|x| x.name.as_str()).collect();
            usage(format!(
                "{flag} `{spec}`: the scene has no material `{m}` (it has: {})",
                names.join(", ")
            ))
        })?,
    };
    Ok((name, index))
}

/// Adds the `--add-mesh` files and `--add-surface` tessellations to the meshed scene.
fn add_extras(a: &RasterArgs, scene: &Scene, meshed: &mut MeshedScene) -> Result<(), Failure> {
    let first = scene.objects.len();
    for spec in a.add_mesh {
        let (path, m) = name_and_material("--add-mesh", spec, scene)?;
        let mesh = isoray_mesh::io::read(Path::new(path)).map_err(|e| usage(e.to_string()))?;
        if mesh.triangles.is_empty() {
            return Err(usage(format!("--add-mesh `{path}`: the file has no triangles")));
        }
        meshed.add(first, m, mesh);
    }
    for spec in a.add_surface {
        let (name, m) = name_and_material("--add-surface", spec, scene)?;
        let coords = scene
            .library
            .parametric_coords(name, None)
            .map_err(|d| usage(format!("--add-surface `{name}`: {}", d.message)))?;
        let (mesh, _) = tessellate(&coords, &TessellationSettings::default())
            .map_err(|e| usage(format!("--add-surface `{name}`: {e}")))?;
        meshed.add(first, m, mesh);
    }
    Ok(())
}

fn value_name<T: ValueEnum>(v: &T) -> String {
    v.to_possible_value()
        .map(|p| p.get_name().to_owned())
        .unwrap_or_default()
}

fn json_number(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        "null".into()
    }
}

fn json_string(s: &str) -> String {
    let mut out = String::from("\"");
    for ch in s.chars() {
        match ch {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The `--error-vs-raytrace` report as JSON.
fn report_json(
    a: &RasterArgs,
    r: &ErrorReport,
    image: &isoray_raster::render::RasterImage,
    reference: &Path,
) -> String {
    let s = &r.angular_error_deg;
    let t = image.timings;
    format!(
        "{{\n  \"scene\": {},\n  \"hidden\": {},\n  \"shading\": {},\n  \"shadows\": {},\n  \"reflections\": {},\n  \"map_size\": {},\n  \"width\": {},\n  \"height\": {},\n  \"triangles\": {},\n  \"reflective_pixels\": {},\n  \"angular_error_deg\": {{ \"mean\": {}, \"rms\": {}, \"p95\": {}, \"max\": {} }},\n  \"wrong_pixels\": {},\n  \"wrong_fraction\": {},\n  \"psnr_db\": {},\n  \"seconds\": {{ \"mesh\": {}, \"maps\": {}, \"draw\": {}, \"raytrace\": {} }},\n  \"map_fragments\": {},\n  \"raytrace_image\": {}\n}}\n",
        json_string(&a.input.path().display().to_string()),
        json_string(&value_name(&a.hidden)),
        json_string(&value_name(&a.shading)),
        json_string(&value_name(&a.shadows)),
        json_string(&value_name(&a.reflections)),
        a.map_size.unwrap_or(RasterOptions::default().map_size as u32),
        r.width,
        r.height,
        image.triangles,
        r.reflective_pixels,
        json_number(s.mean),
        json_number(s.rms),
        json_number(s.p95),
        json_number(s.max),
        r.wrong_pixels,
        json_number(r.wrong_fraction),
        json_number(r.psnr_db),
        json_number(t.mesh),
        json_number(t.maps),
        json_number(t.draw),
        json_number(r.raytrace_seconds),
        image.map_fragments,
        json_string(&reference.display().to_string()),
    )
}
