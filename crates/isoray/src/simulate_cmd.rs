//! `isoray simulate`: the scene's rigid bodies run by isoray-sim (rapier),
//! impacts denting what they strike, frames rendered at the frame rate
//! (the patterns of `render --frames`), the final dent maps written to
//! `--maps`, the run's record to `--record`; `--replay` reproduces a
//! recorded run without the physics.

use std::path::{Path, PathBuf};
use std::time::Instant;

use isoray_render::sequence::{SequenceKind, SequenceWriter};
use isoray_scene::{DentMode, Scene};
use isoray_sim::run::{frame_count, replay, run, Record, RunOptions};
use isoray_sim::{ImprintMethod, SimError};

use crate::frames_cmd::Engine;
use crate::{io_failure, usage, Backend, Failure, GpuKernel, HowToRender, SceneArgs};

impl From<SimError> for Failure {
    fn from(e: SimError) -> Failure {
        usage(e.to_string())
    }
}

/// The options of `isoray simulate`, as parsed.
pub(crate) struct SimulateArgs<'a> {
    pub input: &'a SceneArgs,
    pub output: &'a Path,
    pub duration: Option<f64>,
    pub fps: Option<f64>,
    pub renderer: &'a str,
    pub dents: Option<&'a str>,
    pub imprint: &'a str,
    pub record: Option<&'a Path>,
    pub replay: Option<&'a Path>,
    pub save_scene: Option<&'a Path>,
    pub threads: Option<usize>,
    pub quiet: bool,
}

enum Renderer {
    Trace(Engine),
    Raster,
}

/// Runs `isoray simulate`.
pub(crate) fn cmd_simulate(a: &SimulateArgs) -> Result<(), Failure> {
    let dents = match a.dents {
        None => None,
        Some("none") => Some(DentMode::None),
        Some("bump") => Some(DentMode::Bump),
        Some("auto") => Some(DentMode::Auto),
        Some("sdf") => Some(DentMode::Sdf),
        Some(other) => return Err(usage(format!("--dents {other}: expected none, bump, sdf or auto"))),
    };
    let Some(imprint) = ImprintMethod::from_name(a.imprint) else {
        return Err(usage(format!(
            "--imprint {}: expected {}",
            a.imprint,
            ImprintMethod::NAMES
        )));
    };
    let how = HowToRender {
        threads: a.threads,
        quiet: a.quiet,
        backend: if a.renderer == "gpu" {
            Backend::Gpu
        } else {
            Backend::Cpu
        },
        timing: false,
        gpu_kernel: GpuKernel::Auto,
    };
    let mut renderer = match a.renderer {
        "trace" | "gpu" => Renderer::Trace(Engine::new(&how)?),
        "raster" => Renderer::Raster,
        other => return Err(usage(format!("--renderer {other}: expected trace, raster or gpu"))),
    };
    SequenceKind::of(a.output).map_err(usage)?;
    // --maps: dents found there are the start; the final maps go there.
    if let Some(dir) = a.input.maps() {
        std::fs::create_dir_all(dir).map_err(|e| io_failure(format!("{}: {e}", dir.display())))?;
    }
    let mut scene = a.input.load(&[])?;
    let physics = scene.physics.unwrap_or_default();
    let duration = a.duration.unwrap_or(physics.duration);
    let fps = a.fps.or(scene.animation.map(|an| an.fps)).unwrap_or(30.0);
    if !(duration > 0.0 && duration.is_finite() && fps > 0.0 && fps.is_finite()) {
        return Err(usage(format!(
            "--duration {duration} and --fps {fps}: expected positive numbers"
        )));
    }
    if scene
        .objects
        .iter()
        .all(|o| o.physics.body == isoray_scene::BodyKind::None)
    {
        return Err(usage(format!(
            "`{}` has no rigid bodies: give objects body = \"fixed\", \"dynamic\" or \"kinematic\"",
            a.input.path().display()
        )));
    }
    let opts = RunOptions {
        duration,
        fps,
        dents,
        imprint,
    };
    let replayed = match a.replay {
        Some(path) => Some(Record::read(path).map_err(|e| if path.exists() { usage(e) } else { io_failure(e) })?),
        None => None,
    };
    let count = replayed
        .as_ref()
        .map_or(frame_count(duration, fps), |r| r.frames.len() as u64);
    let (w, h) = (scene.render.width, scene.render.height);
    let mut writer = SequenceWriter::create(a.output, w, h, fps, count).map_err(|e| io_failure(e.to_string()))?;
    let start = Instant::now();
    let mut render_secs = 0.0;
    let bar = crate::frames_cmd::frame_bar(count, a.quiet);
    let mut frame = |n: u64, scene: &Scene| -> Result<(), Failure> {
        let t = Instant::now();
        let color = match &mut renderer {
            Renderer::Trace(engine) => engine.render(scene, false, &how, true)?.image.color,
            Renderer::Raster => {
                let opts = isoray_raster::render::RasterOptions {
                    cancel: Some(crate::jobs::cancel_token()),
                    ..Default::default()
                };
                isoray_raster::render::raster(scene, &opts)
                    .map_err(|e| io_failure(e.to_string()))?
                    .color
            }
        };
        render_secs += t.elapsed().as_secs_f64();
        writer.push(n, &color).map_err(|e| io_failure(e.to_string()))?;
        if let Some(b) = &bar {
            b.inc(1);
        }
        Ok(())
    };
    let record = match &replayed {
        Some(r) => {
            replay(&mut scene, r, &opts, &mut frame)?;
            None
        }
        None => Some(run(&mut scene, &opts, &mut frame)?),
    };
    let (first, last) = (writer.path_of(0), writer.path_of(count - 1));
    writer.finish().map_err(|e| io_failure(e.to_string()))?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let mut written: Vec<PathBuf> = Vec::new();
    if let Some(dir) = a.input.maps() {
        std::fs::create_dir_all(dir).map_err(|e| io_failure(format!("{}: {e}", dir.display())))?;
        for o in &scene.objects {
            if let (Some(name), Some(maps)) = (&o.name, &o.physics.maps) {
                maps.write(dir, name).map_err(|e| io_failure(e.to_string()))?;
                let (hp, np) = isoray_dent::DentMaps::paths(dir, name);
                written.extend([hp, np]);
            }
        }
    }
    if let (Some(path), Some(r)) = (a.record, &record) {
        r.write(path).map_err(io_failure)?;
        written.push(path.to_path_buf());
    }
    if let Some(path) = a.save_scene {
        isoray_scene::write_atomic(path, scene.source_text().as_bytes())
            .map_err(|e| io_failure(format!("{}: {e}", path.display())))?;
        written.push(path.to_path_buf());
    }
    if !a.quiet {
        let secs = start.elapsed().as_secs_f64().max(1e-9);
        let impacts = replayed.as_ref().or(record.as_ref()).map_or(0, |r| r.impacts.len());
        let dented: usize = record.as_ref().map_or(0, |r| {
            r.impacts
                .iter()
                .flat_map(|i| &i.dents)
                .filter(|d| d.texels > 0 || d.geometry)
                .count()
        });
        eprintln!(
            "{} {count} frames ({duration} s at {fps} fps) in {secs:.2} s ({:.2} frames/s, {render_secs:.2} s rendering): {impacts} impacts{} -> {} … {}",
            if replayed.is_some() { "replayed" } else { "simulated" },
            count as f64 / secs,
            if record.is_some() { format!(", {dented} dents") } else { String::new() },
            first.display(),
            last.display()
        );
        for p in written {
            eprintln!("wrote {}", p.display());
        }
    }
    Ok(())
}
