//! `isoray render --backend gpu`: the scene drawn by isoray-gpu.

use std::sync::Arc;
use std::time::{Duration, Instant};

use isoray_gpu::{GpuError, GpuRenderOptions, GpuRenderer, Kernel};
use isoray_job::Counter;
use isoray_scene::Scene;

use crate::{io_failure, jobs, Failure, GpuKernel, HowToRender, Rendered};

/// Renders on the GPU: the first Vulkan adapter (a real GPU before a
/// software one), with a progress bar over the bands and, with `timing`,
/// the pipeline build and each pass's GPU time on stderr.
pub(crate) fn render_gpu(scene: &Scene, aovs: bool, how: &HowToRender) -> Result<Rendered, Failure> {
    let start = Instant::now();
    let mut session = GpuSession::new()?;
    let mut r = session.render(scene, aovs, how)?;
    r.elapsed = start.elapsed().as_secs_f64();
    Ok(r)
}

/// A GPU renderer kept across frames, so its pipeline is built once.
pub(crate) struct GpuSession {
    renderer: GpuRenderer,
    adapter: String,
}

impl GpuSession {
    /// Opens the first Vulkan adapter.
    pub(crate) fn new() -> Result<GpuSession, Failure> {
        let renderer = GpuRenderer::new().map_err(gpu_failure)?;
        let adapter = renderer.gpu().adapter_name();
        Ok(GpuSession { renderer, adapter })
    }

    /// Renders one image of `scene`.
    pub(crate) fn render(&mut self, scene: &Scene, aovs: bool, how: &HowToRender) -> Result<Rendered, Failure> {
        let (renderer, adapter) = (&mut self.renderer, &self.adapter);
        let (timing, quiet) = (how.timing, how.quiet);
        let kernel = match how.gpu_kernel {
            GpuKernel::Auto => None,
            GpuKernel::Compiled => Some(Kernel::Compiled),
            GpuKernel::Interpreted => Some(Kernel::Interpreted),
        };
        let start = Instant::now();
        let progress = Arc::new(Counter::default());
        let opts = GpuRenderOptions {
            aovs,
            progress: Some(progress.clone()),
            cancel: Some(jobs::cancel_token()),
            timing,
            kernel,
            ..Default::default()
        };
        let total = || isoray_gpu::band_count(scene, kernel, aovs);
        let result = crate::with_progress(quiet, &progress, total, start, || renderer.render(scene, &opts))
            .map_err(|_| io_failure("the GPU renderer failed unexpectedly".into()))?;
        let (image, stats, t) = result.map_err(gpu_failure)?;
        if timing {
            let ms = |d: Duration| d.as_secs_f64() * 1e3;
            if let Some(k) = t.kernel {
                eprintln!("timing: {} kernel", k.name());
            }
            match t.pipeline_build {
                Some(d) => eprintln!("timing: pipeline built in {:.1} ms", ms(d)),
                None => eprintln!("timing: pipeline reused"),
            }
            eprintln!("timing: surfaces' reach found in {:.1} ms", ms(t.reach));
            let c = &t.cells;
            if c.cells > 0 {
                eprintln!(
                    "timing: fold cells made in {:.1} ms: {} cells, {} leaves, {} levels, longest list {}",
                    ms(c.build),
                    c.cells,
                    c.leaves,
                    c.depth,
                    c.longest
                );
            }
            if t.passes_ms.is_empty() {
                eprintln!(
                    "timing: the adapter has no timestamp queries; frame wall time {:.1} ms",
                    ms(t.wall)
                );
            } else {
                for (i, p) in t.passes_ms.iter().enumerate() {
                    eprintln!("timing: pass trace[{i}] {p:.3} ms (GPU)");
                }
                eprintln!(
                    "timing: GPU {:.3} ms in {} pass{}, frame wall time {:.1} ms",
                    t.gpu_ms().unwrap_or(0.0),
                    t.passes_ms.len(),
                    if t.passes_ms.len() == 1 { "" } else { "es" },
                    ms(t.wall)
                );
            }
        }
        Ok(Rendered {
            image,
            stats,
            elapsed: start.elapsed().as_secs_f64(),
            backend: format!("gpu {adapter}"),
        })
    }
}

fn gpu_failure(e: GpuError) -> Failure {
    match e {
        GpuError::Cancelled => jobs::cancelled(),
        other => io_failure(other.to_string()),
    }
}
