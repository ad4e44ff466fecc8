//! The GPU renderer: `isoray render --backend gpu`.
//!
//! One compute pipeline per scene structure: the objects' generated WGSL
//! and the tracer (`kernel/*.wgsl`). Everything else (parameters, time,
//! placements, lights, materials, settings, camera, environment) goes in
//! buffers written for each frame, so only a structural edit (a changed
//! shape text) builds a new pipeline; [`GpuRenderer::prepare`] says when
//! it did and how long it took.
//!
//! The image is drawn in bands of rows, one dispatch each, so that a render
//! can be cancelled between bands and reports progress per band.

use std::time::{Duration, Instant};

use isoray_job::{CancelToken, Progress};
use isoray_render::{RayCounts, RenderedImage, Stats};
use isoray_scene::Scene;
use wgpu::util::DeviceExt;

use crate::pack::{self, Band, Kernel, SceneCode, Scratch, Words};
use crate::raster::{self, MeshRaster};
use crate::{cells, layout};
use crate::{Gpu, GpuError};

/// The tracer's bindings.
const BINDINGS: usize = 14;

/// Lanes (samples) per dispatch at most (bands of whole rows).
const BAND_LANES: u64 = 1 << 18;

/// Bytes of lane scratch (ray stacks, interpreter registers) per dispatch
/// at most: a scene with deep reflections or large interpreted tapes draws
/// narrower bands.
const SCRATCH_BYTES: u64 = 64 << 20;

/// The rows of one band of a `width`-pixel-wide image whose pixels each
/// need `scratch`.
fn band_rows(width: u32, height: u32, scratch: Scratch) -> u32 {
    let by_scratch = SCRATCH_BYTES / scratch.bytes_per_pixel().max(1);
    let pixels = (BAND_LANES / scratch.lanes.max(1) as u64).min(by_scratch) as u32;
    (pixels / width.max(1)).clamp(1, height.max(1))
}

/// How many bands (dispatches, progress steps) the scene's image takes
/// with `kernel` (None: the renderer's choice), with or without the AOVs.
pub fn band_count(scene: &Scene, kernel: Option<Kernel>, aovs: bool) -> usize {
    let (w, h) = (scene.render.width, scene.render.height);
    let kernel = kernel.unwrap_or_else(|| Kernel::choose(scene));
    h.div_ceil(band_rows(w, h, Scratch::of(scene, kernel, aovs))) as usize
}

/// What to compute besides the colour, and the job's control.
#[derive(Default)]
pub struct GpuRenderOptions {
    /// Compute the depth, normal and albedo AOVs.
    pub aovs: bool,
    /// Told (bands done, bands in all) after each band.
    pub progress: Option<std::sync::Arc<dyn Progress + Send>>,
    /// Stops the render at the next band ([`GpuError::Cancelled`]).
    pub cancel: Option<CancelToken>,
    /// Measure each band's GPU time with timestamp queries (where the
    /// adapter has them).
    pub timing: bool,
    /// The kernel; None chooses ([`Kernel::choose`]).
    pub kernel: Option<Kernel>,
    /// Walk the meshes' trees for the primary rays too, instead of
    /// reading the raster prepass (for comparisons).
    pub no_mesh_raster: bool,
}

/// Whether the tracer evaluates each field's objects from fold cells
/// ([`crate::cells`]) or folds every object at every point.
///
/// Chosen by measurement: on a software adapter (lavapipe) a branch that
/// some lanes of a subgroup take runs for all of them, and a `switch` on
/// an object index that differs between lanes runs every case, so lists
/// that differ from lane to lane save nothing there and cost their
/// look-up (showcase at 640×360: 2.5 s with cells, 2.3 s without); a real
/// GPU skips what no lane of a warp takes. [`FoldCells::Auto`] uses cells
/// on hardware adapters only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FoldCells {
    /// Cells on hardware adapters, none on software ones.
    #[default]
    Auto,
    /// Always.
    On,
    /// Never.
    Off,
}

impl FoldCells {
    /// Whether the tracer reads cells on `gpu`.
    fn on(self, gpu: &Gpu) -> bool {
        match self {
            FoldCells::Auto => !gpu.is_software(),
            FoldCells::On => true,
            FoldCells::Off => false,
        }
    }
}

/// Which of the tracer's bindings a module declares as uniform buffers.
fn uniform_bindings(source: &str) -> [bool; BINDINGS] {
    std::array::from_fn(|b| source.contains(&format!("@binding({b}) var<uniform>")))
}

/// What a frame cost.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GpuTiming {
    /// Time to build the pipeline before this frame (a structural change),
    /// or None when the cached one was used.
    pub pipeline_build: Option<Duration>,
    /// The GPU time of each band's pass (timestamp queries), in
    /// milliseconds; empty when not asked for or not available.
    pub passes_ms: Vec<f64>,
    /// Wall time of the frame on the host: upload, dispatches, read-back.
    pub wall: Duration,
    /// The kernel that drew it.
    pub kernel: Option<Kernel>,
    /// Whether the primary rays read the meshes' raster prepass (the
    /// scene has meshes and its primary rays lie on the grid it samples).
    pub mesh_raster: bool,
    /// The fold cells the frame's fields were evaluated with.
    pub cells: cells::CellStats,
    /// Host time spent finding where the surfaces end (the reach).
    pub reach: Duration,
}

impl GpuTiming {
    /// The GPU time of the whole frame (sum of the passes), in milliseconds.
    pub fn gpu_ms(&self) -> Option<f64> {
        (!self.passes_ms.is_empty()).then(|| self.passes_ms.iter().sum())
    }
}

struct Program {
    code: SceneCode,
    /// The objects' tapes `code` was written from: a frame whose tapes are
    /// the same reuses everything without writing the module again.
    tapes: Vec<isoray_shape::Tape>,
    /// The tracer: one lane per sample.
    pipeline: wgpu::ComputePipeline,
    /// The samples' mean per pixel.
    resolve: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

fn tapes_of(scene: &Scene) -> Vec<isoray_shape::Tape> {
    scene.objects.iter().map(|o| o.shape.tape().clone()).collect()
}

/// Renders scenes on a [`Gpu`], keeping the pipeline of the last scene
/// structure it saw.
pub struct GpuRenderer {
    gpu: Gpu,
    program: Option<Program>,
    /// The meshes' raster prepass, built at the first scene that has one.
    raster: Option<MeshRaster>,
    /// The last frame's dent maps' texel normals.
    dent_cache: pack::DentCache,
    /// Whether the pipeline reads fold cells.
    cells: bool,
}

impl std::fmt::Debug for GpuRenderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuRenderer")
            .field("adapter", &self.gpu.adapter_name())
            .field("pipeline", &self.program.is_some())
            .finish()
    }
}

impl GpuRenderer {
    /// A renderer on the first adapter [`Gpu::new`] finds.
    pub fn new() -> Result<GpuRenderer, GpuError> {
        Ok(GpuRenderer::with_gpu(Gpu::new()?))
    }

    /// A renderer on `gpu`.
    pub fn with_gpu(gpu: Gpu) -> GpuRenderer {
        let cells = FoldCells::Auto.on(&gpu);
        GpuRenderer {
            gpu,
            program: None,
            raster: None,
            dent_cache: Default::default(),
            cells,
        }
    }

    /// Sets whether the tracer reads fold cells (the next frame builds a
    /// new pipeline when that changes it).
    pub fn set_fold_cells(&mut self, cells: FoldCells) {
        let on = cells.on(&self.gpu);
        if on != self.cells {
            self.cells = on;
            self.program = None;
        }
    }

    /// Whether the tracer reads fold cells.
    pub fn fold_cells(&self) -> bool {
        self.cells
    }

    /// The device.
    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// Makes the pipeline for the scene's structure ready: returns the time
    /// it took to build one, or None when the cached pipeline fits (the
    /// objects' shapes are the same; inputs and settings may differ).
    pub fn prepare(&mut self, scene: &Scene, kernel: Kernel) -> Result<Option<Duration>, GpuError> {
        let same_tapes = |p: &Program| {
            p.tapes.len() == scene.objects.len() && p.tapes.iter().zip(&scene.objects).all(|(t, o)| t == o.shape.tape())
        };
        if self
            .program
            .as_ref()
            .is_some_and(|p| p.code.kernel == kernel && p.code.features == pack::Features::of(scene) && same_tapes(p))
        {
            return Ok(None);
        }
        let code = SceneCode::new(scene, kernel).map_err(GpuError::Gpu)?;
        if let Some(p) = self.program.as_mut().filter(|p| p.code.source == code.source) {
            // The interpreted kernel: the same module, new programs.
            p.code = code;
            p.tapes = tapes_of(scene);
            return Ok(None);
        }
        let start = Instant::now();
        let mut program = self.build(code)?;
        self.warm_up(
            &[&program.pipeline, &program.resolve],
            &program.layout,
            &program.code.source,
        )?;
        program.tapes = tapes_of(scene);
        self.program = Some(program);
        Ok(Some(start.elapsed()))
    }

    fn build(&self, code: SceneCode) -> Result<Program, GpuError> {
        let ([pipeline, resolve], layout) = self.tracer_pipelines(&code.source)?;
        Ok(Program {
            code,
            tapes: Vec::new(),
            pipeline,
            resolve,
            layout,
        })
    }

    /// The compute pipelines of a tracer module (the tracer, the resolve
    /// pass), with the tracer's bindings.
    fn tracer_pipelines(&self, source: &str) -> Result<([wgpu::ComputePipeline; 2], wgpu::BindGroupLayout), GpuError> {
        let read = wgpu::BufferBindingType::Storage { read_only: true };
        let write = wgpu::BufferBindingType::Storage { read_only: false };
        let uniform = wgpu::BufferBindingType::Uniform;
        // iso_in, settings, lights, materials, objects, environment, out,
        // stats, programs, scratch, meshes, the meshes' raster ids, dent maps,
        // fold cells.
        let mut bindings = [
            read, uniform, read, read, read, read, write, write, read, write, read, read, read, read,
        ];
        debug_assert_eq!(bindings.len(), BINDINGS);
        // The inputs and the tables are uniform arrays where the module
        // declares them so (see pack::Features::tables).
        for (ty, is_uniform) in bindings.iter_mut().zip(uniform_bindings(source)) {
            if is_uniform {
                *ty = uniform;
            }
        }
        let source = format!("const USE_CELLS: bool = {};\n{source}", self.cells);
        let (pipelines, layout) = self
            .gpu
            .compute_pipelines(&source, "the scene", &bindings, &["main", "resolve"])?;
        let pipelines: [wgpu::ComputePipeline; 2] = pipelines.try_into().expect("two entry points");
        Ok((pipelines, layout))
    }

    /// What a tracer module (a [`SceneCode::source`], possibly edited by
    /// hand) costs the driver: the time to create its pipeline, and the
    /// time until its first (empty) dispatch has run, which includes the
    /// compile of drivers that compile then (lavapipe does).
    pub fn time_module(&self, source: &str) -> Result<(Duration, Duration), GpuError> {
        let start = Instant::now();
        let ([pipeline, resolve], layout) = self.tracer_pipelines(source)?;
        let created = start.elapsed();
        self.warm_up(&[&pipeline, &resolve], &layout, source)?;
        Ok((created, start.elapsed()))
    }

    /// Runs a new pipeline once on an empty region, so that a driver
    /// that compiles at the first dispatch (lavapipe does) compiles now and
    /// the build time reported is the whole cost of a structural edit.
    fn warm_up(
        &self,
        pipelines: &[&wgpu::ComputePipeline],
        layout: &wgpu::BindGroupLayout,
        source: &str,
    ) -> Result<(), GpuError> {
        let device = &self.gpu.device;
        let buffers: Vec<wgpu::Buffer> = uniform_bindings(source)
            .into_iter()
            .map(|is_uniform| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("warm-up"),
                    // All zero: an empty region, so no lane does anything.
                    // A uniform array's buffer holds at least its length.
                    size: if is_uniform { pack::UNIFORM_BYTES as u64 } else { 256 },
                    usage: if is_uniform {
                        wgpu::BufferUsages::UNIFORM
                    } else {
                        wgpu::BufferUsages::STORAGE
                    },
                    mapped_at_creation: false,
                })
            })
            .collect();
        let bind = self.bind_group(layout, &buffers.iter().collect::<Vec<_>>());
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &bind, &[]);
            for pipeline in pipelines {
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(1, 1, 1);
            }
        }
        let submission = self.gpu.queue.submit([enc.finish()]);
        self.gpu.wait(submission)
    }

    fn bind_group(&self, layout: &wgpu::BindGroupLayout, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tracer"),
            layout,
            entries: &entries,
        })
    }

    /// Renders the whole image of the scene (as [`isoray_render::render_with`]
    /// does on the CPU), building the pipeline first when the scene's
    /// structure changed.
    pub fn render(
        &mut self,
        scene: &Scene,
        opts: &GpuRenderOptions,
    ) -> Result<(RenderedImage, Stats, GpuTiming), GpuError> {
        let start = Instant::now();
        let kernel = opts.kernel.unwrap_or_else(|| Kernel::choose(scene));
        let pipeline_build = self.prepare(scene, kernel)?;
        let grid = raster::grid(scene).filter(|_| !opts.no_mesh_raster);
        if grid.is_some() && self.raster.is_none() {
            self.raster = Some(MeshRaster::new(&self.gpu)?);
        }
        let program = self.program.as_ref().expect("prepared");
        let gpu = &self.gpu;
        let device = &gpu.device;
        let (w, h) = (scene.render.width, scene.render.height);
        let storage = |label: &str, bytes: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        // Bindings 0 and 2 to 4: uniform arrays where the module declares them.
        let table =
            |binding: usize, label: &str, bytes: &[u8]| program.code.table_buffer(device, binding, label, bytes);
        let inputs = Words(program.code.inputs(scene).iter().map(|x| x.to_bits()).collect());
        let in_buf = table(0, "iso_in", &inputs.bytes());
        let lights = table(2, "lights", &layout::bytes_of_all(&pack::lights(scene)));
        let mats = table(3, "materials", &layout::bytes_of_all(&pack::materials(scene)));
        let (dent_words, dent_offsets) = pack::dents(scene, &mut self.dent_cache);
        let objs = table(
            4,
            "objects",
            &layout::bytes_of_all(&program.code.objects(scene, &dent_offsets)),
        );
        let dent_buf = storage("dents", &dent_words.bytes());
        let code_buf = storage("programs", &Words::bytes_of(&program.code.code));
        let env = storage("environment", &pack::environment(scene).bytes());
        let mesh_buf = storage("meshes", &pack::meshes(scene).bytes());
        // Where the surfaces end (the CPU's reach): rays past it stop
        // marching. Searched with the CPU renderer's budget for the frame.
        let reach_start = Instant::now();
        let origin = isoray_render::camera::RayCamera::new(&scene.camera, w, h)
            .origin()
            .to_array();
        let rays = w as u64 * h as u64 * (scene.render.aa as u64).pow(2);
        let reaches = isoray_render::reaches(scene, origin, Some(rays));
        let reach_time = reach_start.elapsed();
        let cells_start = Instant::now();
        let (cell_words, mut cell_stats) = if self.cells {
            cells::build(scene, reaches.domain)
        } else {
            cells::none()
        };
        cell_stats.build = cells_start.elapsed();
        let cell_buf = storage("cells", &cell_words.bytes());
        let timestamps = opts.timing && device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let mut passes_ms = Vec::new();
        // The meshes' raster prepass, ahead of the bands on the same queue.
        let mut ids = None;
        if let (Some(size), Some(prepass)) = (grid, &self.raster) {
            let query = timestamps.then(|| Queries::new(device));
            let mut enc = device.create_command_encoder(&Default::default());
            let writes = query.as_ref().map(|q| wgpu::RenderPassTimestampWrites {
                query_set: &q.set,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            ids = prepass.encode(gpu, &mut enc, scene, &mesh_buf, size, writes);
            if let Some(q) = &query {
                q.resolve(&mut enc);
            }
            let submission = gpu.queue.submit([enc.finish()]);
            if let Some(q) = &query {
                gpu.wait(submission)?;
                passes_ms.push(q.elapsed_ms(gpu)?);
            }
        }
        let ids_buf = match &ids {
            Some(r) => r.buffer.clone(),
            None => storage("no mesh ids", &Words::bytes_of(&[0])),
        };
        let stats_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("stats"),
            contents: &[0u8; 48],
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        });
        let scratch = Scratch::of(scene, kernel, opts.aovs);
        // A row's lanes are one dispatch dimension, 8 lanes per workgroup.
        let max_groups = device.limits().max_compute_workgroups_per_dimension as u64;
        if (w as u64 * scratch.lanes as u64).div_ceil(8) > max_groups {
            return Err(GpuError::Gpu(format!(
                "{w} pixels × {} samples per row is more than the GPU renderer draws in one row \
                 ({} lanes); lower render.aa or the width",
                scratch.lanes,
                8 * max_groups
            )));
        }
        let rows = band_rows(w, h, scratch);
        let scratch_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scratch"),
            size: (rows as u64 * w as u64 * scratch.bytes_per_pixel()).max(16),
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let bands: Vec<Band> = (0..h.div_ceil(rows))
            .map(|b| Band {
                x0: 0,
                y0: b * rows,
                width: w,
                height: rows.min(h - b * rows),
            })
            .collect();
        let record = if opts.aovs {
            pack::RECORD_AOVS
        } else {
            pack::RECORD_COLOUR
        } as usize;
        let n = (w * h) as usize;
        let mut image = RenderedImage {
            width: w,
            height: h,
            color: vec![[0.0; 3]; n],
            depth: opts.aovs.then(|| vec![f32::INFINITY; n]),
            normals: opts.aovs.then(|| vec![[0.0; 3]; n]),
            albedo: opts.aovs.then(|| vec![[0.0; 3]; n]),
        };
        for (bi, band) in bands.iter().enumerate() {
            if opts.cancel.as_ref().is_some_and(|c| c.is_cancelled()) {
                return Err(GpuError::Cancelled);
            }
            let cfg = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("settings"),
                contents: bytemuck::bytes_of(&pack::settings(
                    scene,
                    *band,
                    opts.aovs,
                    scratch,
                    ids.as_ref().map(|r| r.stride),
                    &reaches,
                )),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let size = (band.width as usize * band.height as usize * record * 4) as u64;
            let out_buf = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("out"),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let read_buf = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("read-back"),
                size,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            });
            let buffers = [
                &in_buf,
                &cfg,
                &lights,
                &mats,
                &objs,
                &env,
                &out_buf,
                &stats_buf,
                &code_buf,
                &scratch_buf,
                &mesh_buf,
                &ids_buf,
                &dent_buf,
                &cell_buf,
            ];
            let bind = self.bind_group(&program.layout, &buffers);
            let query = timestamps.then(|| Queries::new(device));
            let mut enc = device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("trace"),
                    timestamp_writes: query.as_ref().map(|q| wgpu::ComputePassTimestampWrites {
                        query_set: &q.set,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }),
                });
                pass.set_pipeline(&program.pipeline);
                pass.set_bind_group(0, &bind, &[]);
                pass.dispatch_workgroups((band.width * scratch.lanes).div_ceil(8), band.height.div_ceil(8), 1);
                // The samples' mean per pixel (the pass sees the trace's
                // writes: wgpu orders dispatches in a pass that share a buffer).
                pass.set_pipeline(&program.resolve);
                pass.dispatch_workgroups((band.width * band.height).div_ceil(64), 1, 1);
            }
            enc.copy_buffer_to_buffer(&out_buf, 0, &read_buf, 0, size);
            if let Some(q) = &query {
                q.resolve(&mut enc);
            }
            let submission = gpu.queue.submit([enc.finish()]);
            let words = gpu.read_back(&read_buf, submission)?;
            if let Some(q) = &query {
                passes_ms.push(q.elapsed_ms(gpu)?);
            }
            for (k, rec) in words.chunks_exact(record).enumerate() {
                let f = |i: usize| f32::from_bits(rec[i]);
                let idx = (band.y0 as usize + k / band.width as usize) * w as usize + k % band.width as usize;
                image.color[idx] = [f(0), f(1), f(2)];
                if opts.aovs {
                    image.depth.as_mut().expect("aovs")[idx] = f(3);
                    image.normals.as_mut().expect("aovs")[idx] = [f(4), f(5), f(6)];
                    image.albedo.as_mut().expect("aovs")[idx] = [f(7), f(8), f(9)];
                }
            }
            if let Some(p) = &opts.progress {
                p.update(bi as u64 + 1, bands.len() as u64);
            }
        }
        let stats = self.read_stats(scene, &stats_buf)?;
        let timing = GpuTiming {
            pipeline_build,
            passes_ms,
            wall: start.elapsed(),
            kernel: Some(kernel),
            mesh_raster: ids.is_some(),
            cells: cell_stats,
            reach: reach_time,
        };
        Ok((image, stats, timing))
    }

    fn read_stats(&self, scene: &Scene, stats_buf: &wgpu::Buffer) -> Result<Stats, GpuError> {
        let gpu = &self.gpu;
        let read = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stats read-back"),
            size: 48,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(stats_buf, 0, &read, 0, 48);
        let submission = gpu.queue.submit([enc.finish()]);
        let s = gpu.read_back(&read, submission)?;
        let sum = |k: usize| s[2 * k] as u64 | (s[2 * k + 1] as u64) << 32;
        let r = &scene.render;
        let primary = r.width as u64 * r.height as u64 * (r.aa * r.aa) as u64;
        Ok(Stats {
            primary_rays: primary,
            evaluations: sum(0),
            overshoots: sum(4),
            overshoot_factor: f32::from_bits(s[10]),
            rays: RayCounts {
                primary,
                reflected: sum(1),
                refracted: sum(2),
                shadow: sum(3),
            },
        })
    }
}

/// Two timestamps around one pass, resolved into a buffer.
struct Queries {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
}

impl Queries {
    fn new(device: &wgpu::Device) -> Queries {
        Queries {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass time"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            read: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps read-back"),
                size: 16,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
        }
    }

    fn resolve(&self, enc: &mut wgpu::CommandEncoder) {
        enc.resolve_query_set(&self.set, 0..2, &self.resolve, 0);
        enc.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, 16);
    }

    /// The pass's duration (after its submission finished).
    fn elapsed_ms(&self, gpu: &Gpu) -> Result<f64, GpuError> {
        let slice = self.read.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        gpu.device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: None,
            })
            .map_err(|e| GpuError::Gpu(format!("reading timestamps: {e}")))?;
        let view = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Gpu(format!("reading timestamps: {e}")))?;
        let t = |i: usize| u64::from_le_bytes(view[8 * i..8 * i + 8].try_into().expect("8 bytes"));
        let ticks = t(1).saturating_sub(t(0));
        Ok(ticks as f64 * gpu.queue.get_timestamp_period() as f64 / 1e6)
    }
}
