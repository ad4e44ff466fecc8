//! `isoray depth`: depth and normal images by voxel rasterization with
//! interval pruning (`isoray_render::voxels`), fidget's `render3d` work.

use std::path::Path;
use std::time::Instant;

use isoray_render::output::write_png_srgb8;
use isoray_render::voxels::{depth_normals, VoxelView};

use crate::{io_failure, usage, Failure, SceneArgs};

/// The arguments of `isoray depth`.
pub(crate) struct DepthArgs<'a> {
    pub input: &'a SceneArgs,
    pub output: &'a Path,
    pub normals: Option<&'a Path>,
    pub size: u32,
    pub depth: Option<u32>,
    /// scale, pitch, yaw, roll.
    pub view: [f64; 4],
    pub threads: Option<usize>,
    pub quiet: bool,
}

pub(crate) fn cmd_depth(a: &DepthArgs) -> Result<(), Failure> {
    let depth = a.depth.unwrap_or(a.size);
    for (flag, v) in [("--size", a.size), ("--depth", depth)] {
        if !(1..=16384).contains(&v) {
            return Err(usage(format!("{flag} must be between 1 and 16384, found {v}")));
        }
    }
    let [scale, pitch, yaw, roll] = a.view;
    if !(scale.is_finite() && scale > 0.0) {
        return Err(usage(format!("--scale must be a positive number, found {scale}")));
    }
    if ![pitch, yaw, roll].iter().all(|v| v.is_finite()) {
        return Err(usage(
            "--pitch, --yaw and --roll must be finite numbers of degrees".into(),
        ));
    }
    if a.threads == Some(0) {
        return Err(usage("--threads must be at least 1".into()));
    }
    let scene = a.input.load(&[])?;
    let shape = scene.frozen(&scene.shape);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .map_err(|e| io_failure(format!("cannot start worker threads: {e}")))?;
    let view = VoxelView::from_view(a.size, a.size, depth, scale, pitch, yaw, roll);
    let start = Instant::now();
    let img = pool.install(|| depth_normals(shape.tape(), &[], &view));
    let took = start.elapsed();
    let gray: Vec<u8> = img.depth_image().iter().flat_map(|&g| [g, g, g]).collect();
    write_png_srgb8(a.output, a.size, a.size, &gray)
        .map_err(|e| io_failure(format!("cannot write {}: {e}", a.output.display())))?;
    if let Some(n) = a.normals {
        write_png_srgb8(n, a.size, a.size, &img.normal_image())
            .map_err(|e| io_failure(format!("cannot write {}: {e}", n.display())))?;
    }
    if !a.quiet {
        let filled = img.depths.iter().filter(|&&d| d > 0).count();
        eprintln!(
            "depth {}x{}x{} on {} threads in {:.3} s: {filled} pixels filled -> {}",
            a.size,
            a.size,
            depth,
            pool.current_num_threads(),
            took.as_secs_f64(),
            a.output.display()
        );
    }
    Ok(())
}
