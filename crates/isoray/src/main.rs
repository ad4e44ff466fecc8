//! The `isoray` command line.

mod algebra_cmd;
mod compare;
mod dent_cmd;
mod depth_cmd;
mod frames_cmd;
#[cfg(feature = "gpu")]
mod gpu_cmd;
#[cfg(feature = "physics")]
mod simulate_cmd;
#[cfg(feature = "gpu")]
use gpu_cmd::render_gpu;
mod jobs;
mod mesh_cmd;
mod raster_cmd;

use std::io::{BufRead, BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use isoray_job::Counter;
use isoray_render::{output, tile_count, RenderOptions};
use isoray_scene::{load_with, LoadOptions, Scene, SceneError};

/// mimalloc instead of the system allocator: the tracers allocate small
/// buffers per packet of rays, which glibc's malloc made about an eighth
/// of a render's time (the optics scene of `bench/optics.sh`).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Model implicit surfaces and render them with rays.
#[derive(Parser)]
#[command(name = "isoray", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Which renderer `isoray render` uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Backend {
    /// The CPU sphere tracer (isoray-render).
    Cpu,
    /// The GPU sphere tracer (isoray-gpu, through wgpu and Vulkan).
    Gpu,
}

/// How the GPU backend evaluates the objects' distances.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum GpuKernel {
    /// The renderer's choice (today the compiled kernel: see docs/BENCHMARKS.md).
    Auto,
    /// Each object's tape compiled into the shader: the fastest frames.
    Compiled,
    /// One fixed shader interpreting the tapes: no shader compile per edit.
    Interpreted,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to a PNG (and optional EXR depth and normal AOVs).
    Render {
        #[command(flatten)]
        input: SceneArgs,
        /// Output PNG.
        #[arg(short, long, value_name = "OUT.png")]
        output: PathBuf,
        /// Image width (overrides render.width).
        #[arg(long, value_name = "W")]
        width: Option<u32>,
        /// Image height (overrides render.height).
        #[arg(long, value_name = "H")]
        height: Option<u32>,
        /// Supersampling factor: N×N samples per pixel (overrides render.aa).
        #[arg(long, value_name = "N")]
        aa: Option<u32>,
        /// Write the depth AOV (channel Z, t along the centre ray, +inf on misses).
        #[arg(long, value_name = "F.exr")]
        depth: Option<PathBuf>,
        /// Write the normal AOV (channels R, G, B: world-space unit normal, 0 on misses).
        #[arg(long, value_name = "F.exr")]
        normals: Option<PathBuf>,
        /// Write the albedo AOV (channels R, G, B: diffuse colour at the first hit, 0 on misses).
        #[arg(long, value_name = "F.exr")]
        albedo: Option<PathBuf>,
        /// Worker threads (default: all cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// No progress bar and no summary.
        #[arg(short, long)]
        quiet: bool,
        /// The renderer: the CPU sphere tracer, or the same on the GPU
        /// (a build with `--features gpu` and a Vulkan driver).
        #[arg(long, value_enum, default_value = "cpu")]
        backend: Backend,
        /// With `--backend gpu`: print the GPU time of each pass
        /// (timestamp queries) and the pipeline build time.
        #[arg(long)]
        timing: bool,
        /// With `--backend gpu`: how the GPU evaluates distances.
        #[arg(long, value_enum, default_value = "auto", value_name = "KERNEL")]
        gpu_kernel: GpuKernel,
        /// Render the frames A to B of the scene's [animation] (both
        /// included; `A..` runs to the end of its duration), frame n at
        /// t = n / fps. OUT is then a numbered pattern (frame_%04d.png), a
        /// .gif, an .apng, or an .mp4 (with ffmpeg on the PATH).
        #[arg(long, value_name = "A..B", value_parser = frames_cmd::parse_frames)]
        frames: Option<frames_cmd::FrameRange>,
        /// With --frames: render only part I (from 0) of N contiguous parts
        /// of the range, for batch arrays (Slurm, Kubernetes Indexed Jobs).
        #[arg(long, value_name = "I/N", value_parser = frames_cmd::parse_part, requires = "frames")]
        shard: Option<frames_cmd::Part>,
        /// Render only band I (from 0) of N horizontal bands of rows of the
        /// still, to a PNG that `isoray merge` assembles into the whole image.
        #[arg(long, value_name = "I/N", value_parser = frames_cmd::parse_part, conflicts_with = "frames")]
        tile: Option<frames_cmd::Part>,
    },
    /// Assemble the bands of `isoray render --tile I/N` into the whole image,
    /// byte for byte the PNG one `isoray render` would have written.
    Merge {
        /// The band PNGs, in any order.
        #[arg(required = true, value_name = "BAND.png")]
        bands: Vec<PathBuf>,
        /// The whole image (PNG).
        #[arg(short, long, value_name = "OUT.png")]
        output: PathBuf,
        /// No summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Convert a height (bump) map into a normal map as the dents thesis
    /// does (G3D's Sobel converter, byte-compatible): an 8-bit grey PNG in,
    /// an 8-bit RGBA PNG out (RGB the normal, +y towards the top row; A the
    /// height).
    Normalmap {
        /// The height map (8-bit grey; 16-bit grey, or RGB whose red is the height, also read).
        #[arg(value_name = "HEIGHT.png")]
        input: PathBuf,
        /// The normal map.
        #[arg(short, long, value_name = "NORMAL.png")]
        output: PathBuf,
        /// Texels of a full-scale (0 to 255) height step: 8 in the thesis.
        #[arg(long, default_value_t = 8.0)]
        white_height: f32,
        /// Borders: wrap around (the thesis's) or clamp to the edge.
        #[arg(long, default_value = "repeat", value_name = "repeat|clamp")]
        wrap: String,
        /// Alpha holds the 3×3 mean height.
        #[arg(long)]
        low_pass: bool,
        /// Alpha's height is multiplied by the normal's z.
        #[arg(long)]
        scale_height_by_nz: bool,
        /// Convert only this rectangle (texels, X1 and Y1 excluded) into a
        /// fragment of that size, its lookups over the whole map.
        #[arg(long, value_name = "X0,Y0,X1,Y1")]
        rect: Option<String>,
        /// No summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Run the scene's rigid bodies (rapier; a build with `--features
    /// physics`): impacts dent what they strike (docs/DENTS.md), frames are
    /// rendered at --fps (OUT as for `render --frames`: a %04d pattern,
    /// .gif, .apng or .mp4), the final maps written to --maps DIR, the run
    /// recorded to --record and replayed, without physics, by --replay.
    Simulate {
        #[command(flatten)]
        input: SceneArgs,
        /// The frames: frame_%04d.png, .gif, .apng or .mp4.
        #[arg(short, long, value_name = "FRAMES")]
        output: PathBuf,
        /// Seconds simulated (default: [physics] duration).
        #[arg(long)]
        duration: Option<f64>,
        /// Frames per second (default: [animation] fps, else 30).
        #[arg(long)]
        fps: Option<f64>,
        /// The renderer of the frames.
        #[arg(long, default_value = "trace", value_name = "trace|raster|gpu")]
        renderer: String,
        /// Overrides every dentable object's `dents`.
        #[arg(long, value_name = "none|bump|sdf|auto")]
        dents: Option<String>,
        /// How dents are measured: texel (along the surface normal), ortho
        /// (the thesis's) or ortho-projected.
        #[arg(long, default_value = "texel", value_name = "texel|ortho|ortho-projected")]
        imprint: String,
        /// Write the run's record (every impact, every frame's placements) as JSON.
        #[arg(long, value_name = "impacts.json")]
        record: Option<PathBuf>,
        /// Replay a record instead of simulating: the same dents and frames.
        #[arg(long, value_name = "impacts.json")]
        replay: Option<PathBuf>,
        /// Write the scene with the dents cut into geometry (`--dents sdf`
        /// or `auto`) as [[object.sdf_dent]] tables: load it to render,
        /// mesh or simulate on from the dented objects.
        #[arg(long, value_name = "SCENE.toml")]
        save_scene: Option<PathBuf>,
        /// Worker threads of the CPU renderer (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// No progress bar and no summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Strike a dentable object once and write its dent maps: the impactor
    /// (a ball of --radius touching at --at, or --impactor OBJECT as placed
    /// in the scene) pushed --depth along −--normal, or as deep as an
    /// --impulse makes it with the object's material (docs/DENTS.md). The
    /// maps are read from and written back to --maps DIR as
    /// NAME-height.png (16-bit) and NAME-normal.png (RGBA).
    Dent {
        #[command(flatten)]
        input: SceneArgs,
        /// The struck object's name.
        object: String,
        /// The contact point, world coordinates.
        #[arg(
            long,
            value_delimiter = ',',
            allow_hyphen_values = true,
            value_name = "X,Y,Z",
            required = true
        )]
        at: Vec<f64>,
        /// The contact normal, from the object towards the impactor.
        #[arg(
            long,
            value_delimiter = ',',
            allow_hyphen_values = true,
            value_name = "X,Y,Z",
            required = true
        )]
        normal: Vec<f64>,
        /// The dent's depth, scene units.
        #[arg(long)]
        depth: Option<f64>,
        /// The impact's elastic impulse, N·s: the depth is then
        /// thickness · dent_compliance · max(0, J − ε/(1 − ε)).
        #[arg(long)]
        impulse: Option<f64>,
        /// The object that strikes, as placed in the scene (touching the
        /// struck object at --at); default a ball of --radius.
        #[arg(long, value_name = "OBJECT")]
        impactor: Option<String>,
        /// The default impactor ball's radius, scene units.
        #[arg(long, default_value_t = 0.25)]
        radius: f64,
        /// How the dent is measured: texel (along the surface normal), ortho
        /// (the thesis's depth passes along the impact) or ortho-projected
        /// (those scaled by N·N_C).
        #[arg(long, default_value = "texel", value_name = "texel|ortho|ortho-projected")]
        imprint: String,
        /// No summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Read points `x y z` from stdin and print the scene's signed distance at each.
    Eval {
        #[command(flatten)]
        input: SceneArgs,
    },
    /// Compute a reduced Gröbner basis; prints one polynomial per line.
    Groebner(algebra_cmd::GroebnerArgs),
    /// Find the implicit equation of a rational parametrization.
    Implicitize {
        /// x(s, t)
        #[arg(long, allow_hyphen_values = true)]
        x: String,
        /// y(s, t)
        #[arg(long, allow_hyphen_values = true)]
        y: String,
        /// z(s, t); leave out for a plane curve (x(t), y(t)).
        #[arg(long, allow_hyphen_values = true)]
        z: Option<String>,
        /// Parameters (default s,t for surfaces, t for curves).
        #[arg(long, value_delimiter = ',')]
        params: Option<Vec<String>>,
        /// auto (measures the implicit degree modulo a prime and runs the method
        /// with the cheapest cost estimate, the next one if it fails or overruns;
        /// --stats says which and why), groebner, interpolation or resultant
        /// (the Dixon resultant; stops at base points it cannot handle).
        #[arg(long, default_value = "auto")]
        method: String,
        /// Print statistics to stderr.
        #[arg(long)]
        stats: bool,
        /// Stop with an error after this many seconds.
        #[arg(long, value_name = "SECONDS")]
        timeout: Option<f64>,
    },
    /// Print what isoray derives for a surface: its implicit equation,
    /// degree, the distance bound it traces, and timings.
    Surface {
        #[command(flatten)]
        input: SceneArgs,
        /// The surface's name (`[surface.NAME]`).
        name: String,
    },
    /// Render a scene with the classic polygon pipeline: objects meshed,
    /// scan-converted behind a Z-buffer or an A-buffer and shaded, with
    /// shadow buffers and environment-mapped reflections and refractions.
    Raster {
        #[command(flatten)]
        input: SceneArgs,
        /// Output PNG.
        #[arg(short, long, value_name = "OUT.png")]
        output: PathBuf,
        /// Hidden-surface removal.
        #[arg(long, value_enum, default_value_t = raster_cmd::Hidden::Zbuffer)]
        hidden: raster_cmd::Hidden,
        /// Polygon shading.
        #[arg(long, value_enum, default_value_t = raster_cmd::ShadingArg::Phong)]
        shading: raster_cmd::ShadingArg,
        /// Shadows.
        #[arg(long, value_enum, default_value_t = raster_cmd::Shadows::None)]
        shadows: raster_cmd::Shadows,
        /// Reflections and refractions.
        #[arg(long, value_enum, default_value_t = raster_cmd::Reflections::None)]
        reflections: raster_cmd::Reflections,
        /// Texels along a side of each shadow-buffer and environment-map face (default 512).
        #[arg(long, value_name = "N")]
        map_size: Option<u32>,
        /// Compare with the ray tracer: write a JSON report (angular error of
        /// reflections, wrong reflective pixels, PSNR) and the ray-traced
        /// image beside it (REPORT.raytrace.png).
        #[arg(long, value_name = "REPORT.json")]
        error_vs_raytrace: Option<PathBuf>,
        /// Mesh resolution: cells along each object's longest side (default 96).
        #[arg(long, value_name = "N")]
        resolution: Option<u32>,
        /// Also draw a mesh file (.stl, .obj, .ply or .glb, world coordinates),
        /// with a scene material (default: the scene's first material).
        #[arg(long = "add-mesh", value_name = "FILE[@MATERIAL]")]
        add_mesh: Vec<String>,
        /// Also draw a parametric surface of the scene (`[surface.NAME]`),
        /// tessellated over its (s, t) domain, with a scene material.
        #[arg(long = "add-surface", value_name = "NAME[@MATERIAL]")]
        add_surface: Vec<String>,
        /// Image width (overrides render.width).
        #[arg(long, value_name = "W")]
        width: Option<u32>,
        /// Image height (overrides render.height).
        #[arg(long, value_name = "H")]
        height: Option<u32>,
        /// Worker threads (default: all cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// No summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Depth and normal images by voxel rasterization with interval pruning,
    /// as fidget's render3d makes them: an orthographic view whose image spans
    /// [-1, 1] world units, each pixel a column of --depth voxels; the depth is
    /// that of the nearest voxel whose center is inside the scene's shape.
    Depth {
        #[command(flatten)]
        input: SceneArgs,
        /// Output depth image (PNG, gray: nearer is brighter, empty is black).
        #[arg(short, long, value_name = "OUT.png")]
        output: PathBuf,
        /// Also write the normals (PNG, RGB from the unit normal's x, y, z in [-1, 1]).
        #[arg(long, value_name = "NORMALS.png")]
        normals: Option<PathBuf>,
        /// Image width and height in pixels.
        #[arg(long, default_value_t = 512, value_name = "N")]
        size: u32,
        /// Voxels per pixel column (default: --size).
        #[arg(long, value_name = "D")]
        depth: Option<u32>,
        /// The view as fidget's render3d --isometric takes it: model =
        /// Ry(yaw)·Rz(roll)·Rx(pitch)·world/scale.
        #[arg(long, default_value_t = 1.0, value_name = "S")]
        scale: f64,
        /// Turn about x, degrees.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_name = "DEG")]
        pitch: f64,
        /// Turn about y, degrees.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_name = "DEG")]
        yaw: f64,
        /// Turn about z, degrees.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_name = "DEG")]
        roll: f64,
        /// Worker threads (default: one per core).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// No summary line.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Mesh a scene's objects, one object, or one surface into a triangle mesh
    /// file (.stl, .obj, .ply or .glb by the output's extension). Shapes are
    /// meshed by sparse-octree dual contouring (closed, manifold, sharp
    /// edges kept); a parametric surface is tessellated over its (s, t) domain.
    Mesh {
        #[command(flatten)]
        input: SceneArgs,
        /// An object's name (`[[object]] name`) or a surface's (`[surface.NAME]`);
        /// leave out to mesh every object (unbounded ones, such as planes, are skipped).
        name: Option<String>,
        /// Output mesh: .stl (binary), .obj, .ply (binary) or .glb.
        #[arg(short, long, value_name = "OUT")]
        output: PathBuf,
        /// Cells along the longest side of the bounds (default 128); for a
        /// parametric surface, the base grid's cells along s and t (default 16).
        #[arg(long, value_name = "N")]
        resolution: Option<u32>,
        /// The box to mesh: xmin,ymin,zmin,xmax,ymax,zmax (default: found from
        /// the distance bound). Where it cuts a shape, the mesh is closed by its faces.
        #[arg(
            long,
            value_delimiter = ',',
            allow_hyphen_values = true,
            value_name = "X0,Y0,Z0,X1,Y1,Z1"
        )]
        bounds: Option<Vec<f64>>,
        /// Normals that differ by more than this many degrees within a cell
        /// make a sharp feature (edge or corner) that is kept sharp.
        #[arg(long, default_value_t = 30.0, value_name = "DEGREES")]
        feature_angle: f64,
        /// How much the distance may overestimate (default 1 / render.step_scale):
        /// empty space is skipped only beyond this factor.
        #[arg(long, value_name = "L")]
        lipschitz: Option<f64>,
        /// Mesh the level f = D instead of f = 0: D > 0 grows solids by D, and
        /// turns an unsigned field (a sheet such as abs(f)) into a closed
        /// shell 2D thick.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_name = "D")]
        offset: f64,
        /// Chord tolerance of a parametric tessellation, in world units
        /// (default 1/1000 of the surface's size).
        #[arg(long, value_name = "T")]
        tolerance: Option<f64>,
        /// Also look for self-intersecting triangles (slower).
        #[arg(long)]
        check_intersections: bool,
        /// Worker threads (default: all cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// No progress bar.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Parse and type-check a scene; print `ok` or the errors. Objects that
    /// call implicit or parametric surfaces are also checked on sampled camera
    /// rays for distance estimates that overstep the surface.
    Check {
        #[command(flatten)]
        input: SceneArgs,
    },
    /// Set scene keys and write the scene back with its comments, key order
    /// and formatting kept: the same KEY=VALUE syntax as --set, checked like
    /// a load, written atomically (in place unless -o is given).
    Set {
        /// The scene file (TOML).
        scene: PathBuf,
        /// KEY=VALUE edits, e.g. render.width=1280 'object.0.shape=sphere(p, 2.0)' params.k=0.5.
        #[arg(required = true, value_name = "KEY=VALUE")]
        edits: Vec<String>,
        /// Write the edited scene here instead of over SCENE.
        #[arg(short, long, value_name = "OUT.toml")]
        output: Option<PathBuf>,
    },
}

/// The scene a command reads, its overrides and the time.
#[derive(clap::Args, Clone, Debug)]
pub(crate) struct SceneArgs {
    /// The scene file (TOML).
    scene: PathBuf,
    /// Override any scene key, e.g. render.shadows=hard, light.0.intensity=2
    /// or params.k=0.5 (a parameter outside its declared range is an error).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// The time t in seconds, which shape text and tracks read (default 0);
    /// a fraction N/D is N / D, so `--time 7/24` is frame 7 at 24 fps.
    #[arg(long, allow_hyphen_values = true, value_name = "T", value_parser = frames_cmd::parse_time)]
    pub(crate) time: Option<f64>,
    /// A MIDI file whose control changes and notes drive the scene's
    /// [[midi]] mappings: at each time, the last value each controller sent
    /// at or before it (the scene's own value before the first).
    #[arg(long, value_name = "TAKE.mid")]
    midi: Option<PathBuf>,
    /// A folder of dent maps (`isoray dent`, `isoray simulate`): each named
    /// dentable object whose NAME-height.png is there is drawn with its dents.
    #[arg(long, value_name = "DIR")]
    maps: Option<PathBuf>,
}

impl SceneArgs {
    /// Loads the scene with these overrides followed by `extra`.
    pub(crate) fn load(&self, extra: &[String]) -> Result<Scene, Failure> {
        let mut overrides = self.set.clone();
        overrides.extend_from_slice(extra);
        // Long surface analyses (implicitization) show a bar on a terminal.
        let bar = jobs::JobBar::for_terminal();
        let opts = LoadOptions {
            time: self.time.unwrap_or(0.0),
            cancel: Some(jobs::cancel_token()),
            progress: jobs::reporter(&bar),
            ..LoadOptions::default()
        };
        let scene = load_with(&self.scene, &overrides, &opts);
        if let Some(b) = &bar {
            b.finish();
        }
        let mut scene = scene?;
        if let Some(path) = &self.midi {
            if scene.midi.is_empty() {
                return Err(usage(format!(
                    "`{}` has no [[midi]] mappings, so --midi {} would drive nothing",
                    self.scene.display(),
                    path.display()
                )));
            }
            let events = isoray_scene::midi::read_midi_file(path).map_err(|e| {
                let io = !path.exists();
                Failure {
                    code: if io { 1 } else { 2 },
                    message: e,
                }
            })?;
            scene.play_midi(&events)?;
        }
        if let Some(dir) = &self.maps {
            let io = !dir.is_dir();
            scene.attach_dent_maps(dir).map_err(|message| Failure {
                code: if io { 1 } else { 2 },
                message,
            })?;
        }
        Ok(scene)
    }

    /// The scene file.
    pub(crate) fn path(&self) -> &Path {
        &self.scene
    }

    /// The folder of dent maps (`--maps`).
    pub(crate) fn maps(&self) -> Option<&Path> {
        self.maps.as_deref()
    }
}

/// A failure with its exit code: 1 for rendering/IO, 2 for bad input.
pub(crate) struct Failure {
    code: u8,
    message: String,
}

impl From<SceneError> for Failure {
    fn from(e: SceneError) -> Self {
        if e.cancelled {
            return jobs::cancelled();
        }
        Failure {
            code: if e.io { 1 } else { 2 },
            message: e.rendered,
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if !matches!(cli.command, Command::Eval { .. }) {
        jobs::watch_ctrl_c();
    }
    let result = match cli.command {
        Command::Render {
            input,
            output,
            width,
            height,
            aa,
            depth,
            normals,
            albedo,
            threads,
            quiet,
            backend,
            timing,
            gpu_kernel,
            frames,
            shard,
            tile,
        } => {
            let mut overrides = Vec::new();
            overrides.extend(width.map(|w| format!("render.width={w}")));
            overrides.extend(height.map(|h| format!("render.height={h}")));
            overrides.extend(aa.map(|a| format!("render.aa={a}")));
            let outputs = Outputs {
                png: &output,
                depth: depth.as_deref(),
                normals: normals.as_deref(),
                albedo: albedo.as_deref(),
            };
            let how = HowToRender {
                threads,
                quiet,
                backend,
                timing,
                gpu_kernel,
            };
            match (frames, tile) {
                (Some(range), _) => frames_cmd::render_frames(&input, &overrides, &outputs, &how, range, shard),
                (None, Some(part)) => frames_cmd::render_tile(&input, &overrides, &outputs, &how, part),
                (None, None) => cmd_render(&input, &overrides, &outputs, &how),
            }
        }
        Command::Merge { bands, output, quiet } => frames_cmd::cmd_merge(&bands, &output, quiet),
        Command::Normalmap {
            input,
            output,
            white_height,
            wrap,
            low_pass,
            scale_height_by_nz,
            rect,
            quiet,
        } => dent_cmd::cmd_normalmap(&dent_cmd::NormalmapArgs {
            input: &input,
            output: &output,
            white_height,
            wrap: &wrap,
            low_pass,
            scale_height_by_nz,
            rect: rect.as_deref(),
            quiet,
        }),
        #[cfg(feature = "physics")]
        Command::Simulate {
            input,
            output,
            duration,
            fps,
            renderer,
            dents,
            imprint,
            record,
            replay,
            save_scene,
            threads,
            quiet,
        } => simulate_cmd::cmd_simulate(&simulate_cmd::SimulateArgs {
            input: &input,
            output: &output,
            duration,
            fps,
            renderer: &renderer,
            dents: dents.as_deref(),
            imprint: &imprint,
            record: record.as_deref(),
            replay: replay.as_deref(),
            save_scene: save_scene.as_deref(),
            threads,
            quiet,
        }),
        #[cfg(not(feature = "physics"))]
        Command::Simulate { .. } => Err(io_failure(
            "this isoray was built without rigid bodies; build it with `cargo build --release -p isoray --features physics`".into(),
        )),
        Command::Dent {
            input,
            object,
            at,
            normal,
            depth,
            impulse,
            impactor,
            radius,
            imprint,
            quiet,
        } => dent_cmd::cmd_dent(&dent_cmd::DentArgs {
            scene: &input,
            object: &object,
            at: &at,
            normal: &normal,
            depth,
            impulse,
            impactor: impactor.as_deref(),
            radius,
            imprint: &imprint,
            quiet,
        }),
        Command::Eval { input } => cmd_eval(&input),
        Command::Groebner(args) => algebra_cmd::cmd_groebner(&args),
        Command::Implicitize {
            x,
            y,
            z,
            params,
            method,
            stats,
            timeout,
        } => algebra_cmd::cmd_implicitize(&x, &y, z.as_deref(), params.as_deref(), &method, stats, timeout),
        Command::Check { input } => cmd_check(&input),
        Command::Raster {
            input,
            output,
            hidden,
            shading,
            shadows,
            reflections,
            map_size,
            error_vs_raytrace,
            resolution,
            add_mesh,
            add_surface,
            width,
            height,
            threads,
            quiet,
        } => {
            let mut overrides = Vec::new();
            overrides.extend(width.map(|w| format!("render.width={w}")));
            overrides.extend(height.map(|h| format!("render.height={h}")));
            raster_cmd::cmd_raster(&raster_cmd::RasterArgs {
                input: &input,
                output: &output,
                hidden,
                shading,
                shadows,
                reflections,
                map_size,
                error_vs_raytrace: error_vs_raytrace.as_deref(),
                resolution,
                add_mesh: &add_mesh,
                add_surface: &add_surface,
                overrides: &overrides,
                threads,
                quiet,
            })
        }
        Command::Mesh {
            input,
            name,
            output,
            resolution,
            bounds,
            feature_angle,
            lipschitz,
            offset,
            tolerance,
            check_intersections,
            threads,
            quiet,
        } => mesh_cmd::cmd_mesh(&mesh_cmd::MeshArgs {
            input: &input,
            name: name.as_deref(),
            output: &output,
            resolution,
            bounds: bounds.as_deref(),
            feature_angle,
            lipschitz,
            offset,
            tolerance,
            threads,
            check_intersections,
            quiet,
        }),
        Command::Depth {
            input,
            output,
            normals,
            size,
            depth,
            scale,
            pitch,
            yaw,
            roll,
            threads,
            quiet,
        } => depth_cmd::cmd_depth(&depth_cmd::DepthArgs {
            input: &input,
            output: &output,
            normals: normals.as_deref(),
            size,
            depth,
            view: [scale, pitch, yaw, roll],
            threads,
            quiet,
        }),
        Command::Surface { input, name } => cmd_surface(&input, &name),
        Command::Set { scene, edits, output } => cmd_set(&scene, &edits, output.as_deref()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            let msg = f.message.trim_end();
            if msg.starts_with("error:") {
                eprintln!("{msg}");
            } else {
                eprintln!("error: {msg}");
            }
            ExitCode::from(f.code)
        }
    }
}

fn cmd_set(scene: &Path, edits: &[String], output: Option<&Path>) -> Result<(), Failure> {
    let report = isoray_scene::set_file(scene, edits, output)?;
    println!(
        "wrote {} ({} edit{})",
        report.written.display(),
        report.edits,
        if report.edits == 1 { "" } else { "s" }
    );
    Ok(())
}

fn cmd_check(input: &SceneArgs) -> Result<(), Failure> {
    let scene = input.load(&[])?;
    println!("ok");
    for c in isoray_render::bounds::check_scene(&scene) {
        let what = object_label(&scene, c.object);
        if c.violated() {
            eprintln!("{}", violation_warning(&what, &c));
        } else if c.crossings == 0 {
            println!(
                "bound: {what}: not checked: none of {} sampled rays crosses its surface (out of view, or an unsigned field such as image_only)",
                c.rays
            );
        } else {
            println!(
                "bound: {what}: holds on {} of {} sampled rays that reach the surface (largest field/distance ratio {:.3})",
                c.crossings, c.rays, c.worst_ratio
            );
        }
    }
    Ok(())
}

fn object_label(scene: &Scene, i: usize) -> String {
    match &scene.objects[i].name {
        Some(n) => format!("object {i} (`{n}`)"),
        None => format!("object {i}"),
    }
}

fn violation_warning(what: &str, c: &isoray_render::bounds::BoundCheck) -> String {
    let surfaces: Vec<String> = c.surfaces.iter().map(|s| format!("[surface.{s}]")).collect();
    format!(
        "warning: {what}: the distance estimate oversteps the surface by up to {:.2}x (at ({:.4}, {:.4}, {:.4})), so rays can step through it\n  = help: set lipschitz_factor = {:.1} in {}",
        c.worst_ratio,
        c.at[0],
        c.at[1],
        c.at[2],
        c.suggested_factor(),
        surfaces.join(", ")
    )
}

fn cmd_surface(input: &SceneArgs, name: &str) -> Result<(), Failure> {
    let scene_path = input.path();
    let scene = input.load(&[])?;
    let lib = &scene.library;
    let Some(s) = lib.surface(name) else {
        let names = lib.surface_names();
        let mut msg = format!("the scene `{}` has no surface named `{name}`", scene_path.display());
        if let Some(sg) = isoray_shape::diag::suggest(name, names.iter().map(|s| s.as_str())) {
            msg.push_str(&format!("\n  = help: did you mean `{sg}`?"));
        }
        if names.is_empty() {
            msg.push_str("\n  = note: it defines no [surface.NAME] tables");
        } else {
            msg.push_str(&format!("\n  = note: its surfaces: {}", names.join(", ")));
        }
        return Err(usage(msg));
    };
    if s.mode == isoray_shape::SurfaceMode::Sdf {
        println!("surface:   {name} (sdf)");
        println!("bound:     the signed distance as written");
        return Ok(());
    }
    let analysis = lib
        .default_analysis(name)
        .expect("the surface exists")
        .map_err(|d| usage(d.message.clone()))?;
    print!("{}", isoray_shape::surface::describe(name, s, &analysis));
    Ok(())
}

pub(crate) fn usage(message: String) -> Failure {
    Failure { code: 2, message }
}

pub(crate) fn io_failure(message: String) -> Failure {
    Failure { code: 1, message }
}

/// The files `isoray render` writes.
pub(crate) struct Outputs<'a> {
    pub(crate) png: &'a Path,
    pub(crate) depth: Option<&'a Path>,
    pub(crate) normals: Option<&'a Path>,
    pub(crate) albedo: Option<&'a Path>,
}

/// How `isoray render` runs: threads, output on the terminal, backend.
pub(crate) struct HowToRender {
    pub(crate) threads: Option<usize>,
    pub(crate) quiet: bool,
    pub(crate) backend: Backend,
    pub(crate) timing: bool,
    pub(crate) gpu_kernel: GpuKernel,
}

/// A finished render and what the summary line says of it.
pub(crate) struct Rendered {
    pub(crate) image: isoray_render::RenderedImage,
    pub(crate) stats: isoray_render::Stats,
    pub(crate) elapsed: f64,
    /// `cpu (2 threads)` or `gpu llvmpipe (…)`.
    pub(crate) backend: String,
}

/// Renders on the CPU with a progress bar.
pub(crate) fn render_cpu(scene: &Scene, aovs: bool, threads: Option<usize>, quiet: bool) -> Result<Rendered, Failure> {
    render_region_cpu_with(scene, isoray_render::Region::full(scene), aovs, threads, quiet)
}

/// Renders the rows of `region` on the CPU (a whole-size image, black
/// outside), with a progress bar.
pub(crate) fn render_region_cpu(
    scene: &Scene,
    region: isoray_render::Region,
    threads: Option<usize>,
    quiet: bool,
) -> Result<Rendered, Failure> {
    render_region_cpu_with(scene, region, false, threads, quiet)
}

fn render_region_cpu_with(
    scene: &Scene,
    region: isoray_render::Region,
    aovs: bool,
    threads: Option<usize>,
    quiet: bool,
) -> Result<Rendered, Failure> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| io_failure(format!("cannot start worker threads: {e}")))?;
    let progress = Arc::new(Counter::default());
    let opts = RenderOptions {
        aovs,
        progress: Some(progress.clone()),
        cancel: Some(jobs::cancel_token()),
    };
    let start = Instant::now();
    let result = with_progress(
        quiet,
        &progress,
        || tile_count(scene),
        start,
        || pool.install(|| isoray_render::render_region_image(scene, region, &opts)),
    )
    .map_err(|_| io_failure("the renderer failed unexpectedly".into()))?;
    let Ok((image, stats)) = result else {
        return Err(jobs::cancelled());
    };
    let n = pool.current_num_threads();
    Ok(Rendered {
        image,
        stats,
        elapsed: start.elapsed().as_secs_f64(),
        backend: format!("cpu ({n} thread{})", if n == 1 { "" } else { "s" }),
    })
}

#[cfg(not(feature = "gpu"))]
fn render_gpu(_scene: &Scene, _aovs: bool, _how: &HowToRender) -> Result<Rendered, Failure> {
    Err(no_gpu())
}

/// The error of `--backend gpu` in a build without the GPU backend.
#[cfg(not(feature = "gpu"))]
pub(crate) fn no_gpu() -> Failure {
    io_failure(
        "this isoray was built without the GPU backend; build it with `cargo build --release -p isoray --features gpu`"
            .into(),
    )
}

fn cmd_render(input: &SceneArgs, overrides: &[String], outputs: &Outputs, how: &HowToRender) -> Result<(), Failure> {
    let &HowToRender {
        threads,
        quiet,
        backend,
        timing,
        gpu_kernel,
    } = how;
    let Outputs {
        png: out,
        depth,
        normals,
        albedo,
    } = *outputs;
    for (p, what) in [(Some(out), "png"), (depth, "exr"), (normals, "exr"), (albedo, "exr")] {
        if let Some(p) = p {
            let ext = p.extension().map(|e| e.to_string_lossy().to_lowercase());
            if ext.as_deref() != Some(what) {
                return Err(usage(format!("output `{}` must end in .{what}", p.display())));
            }
        }
    }
    if threads == Some(0) {
        return Err(usage("--threads must be at least 1".into()));
    }
    if timing && backend != Backend::Gpu {
        return Err(usage("--timing needs --backend gpu".into()));
    }
    if gpu_kernel != GpuKernel::Auto && backend != Backend::Gpu {
        return Err(usage("--gpu-kernel needs --backend gpu".into()));
    }
    let scene = input.load(overrides)?;
    let aovs = depth.is_some() || normals.is_some() || albedo.is_some();
    let Rendered {
        image,
        stats,
        elapsed,
        backend,
    } = match backend {
        Backend::Cpu => render_cpu(&scene, aovs, threads, quiet)?,
        Backend::Gpu => render_gpu(&scene, aovs, how)?,
    };
    let w = |r: Result<(), output::OutputError>| r.map_err(|e| io_failure(e.to_string()));
    w(output::write_png(out, image.width, image.height, &image.color))?;
    if let (Some(p), Some(d)) = (depth, &image.depth) {
        w(output::write_exr_channel(p, image.width, image.height, "Z", d))?;
    }
    if let (Some(p), Some(n)) = (normals, &image.normals) {
        w(output::write_exr_rgb(p, image.width, image.height, n))?;
    }
    if let (Some(p), Some(a)) = (albedo, &image.albedo) {
        w(output::write_exr_rgb(p, image.width, image.height, a))?;
    }
    if !quiet {
        summary(&scene, &stats, elapsed, &backend, out);
    }
    if stats.overshoots > 0 {
        let names: Vec<String> = (0..scene.objects.len())
            .flat_map(|i| scene.equation_surfaces(i))
            .map(|s| format!("[surface.{s}]"))
            .collect();
        let fix = if names.is_empty() {
            "check the shapes' distance functions".to_string()
        } else {
            format!(
                "set lipschitz_factor = {:.1} in {} (`isoray check` finds the object)",
                (stats.overshoot_factor * 1.1 * 10.0).ceil() / 10.0,
                names.join(", ")
            )
        };
        eprintln!(
            "warning: {} ray steps went through a surface (a step was up to {:.2}x too long): the distance estimate is not a bound there\n  = help: {fix}",
            stats.overshoots, stats.overshoot_factor
        );
    }
    Ok(())
}

/// Runs `work` on a thread of its own while this one shows a progress bar
/// of `done` out of `total()` (unless `quiet`), and returns as soon as the
/// work ends: the work tells this thread when it finishes, so a short job
/// is not held up by the bar's polling interval (it was, by up to 50 ms).
pub(crate) fn with_progress<T: Send>(
    quiet: bool,
    done: &Counter,
    total: impl FnOnce() -> usize,
    start: Instant,
    work: impl FnOnce() -> T + Send,
) -> std::thread::Result<T> {
    let (finished, ended) = std::sync::mpsc::channel::<()>();
    std::thread::scope(|sc| {
        let handle = sc.spawn(move || {
            let result = work();
            // Nothing waits on it when the run is quiet.
            let _ = finished.send(());
            result
        });
        if !quiet {
            show_progress(&ended, done, total(), start);
        }
        handle.join()
    })
}

/// Shows a progress bar (after the first second, on a terminal) until the
/// work sends on `ended` or drops its sender (it panicked).
fn show_progress(ended: &std::sync::mpsc::Receiver<()>, done: &Counter, total: usize, start: Instant) {
    let mut bar: Option<indicatif::ProgressBar> = None;
    while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) = ended.recv_timeout(Duration::from_millis(50)) {
        if bar.is_none() && start.elapsed() > Duration::from_secs(1) && std::io::stderr().is_terminal() {
            let b = indicatif::ProgressBar::new(total as u64);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} rendering [{bar:40}] {percent}% tiles {pos}/{len}, eta {eta}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            bar = Some(b);
        }
        if let Some(b) = &bar {
            b.set_position(done.done());
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
}

fn summary(scene: &Scene, stats: &isoray_render::Stats, secs: f64, backend: &str, out: &Path) {
    let r = &scene.render;
    let secs = secs.max(1e-9);
    eprintln!(
        "rendered {}x{} (aa {}, {} primary rays) on {backend} in {:.2} s: {:.2} M primary rays/s, {:.1} M distance evaluations/s -> {}",
        r.width,
        r.height,
        r.aa,
        stats.primary_rays,
        secs,
        stats.primary_rays as f64 / secs / 1e6,
        stats.evaluations as f64 / secs / 1e6,
        out.display()
    );
    let k = &stats.rays;
    if k.reflected + k.refracted + k.shadow > 0 {
        let rate = |n: u64| n as f64 / secs / 1e6;
        eprintln!(
            "rays: {} primary ({:.2} M/s), {} reflected ({:.2} M/s), {} refracted ({:.2} M/s), {} shadow ({:.2} M/s)",
            k.primary,
            rate(k.primary),
            k.reflected,
            rate(k.reflected),
            k.refracted,
            rate(k.refracted),
            k.shadow,
            rate(k.shadow)
        );
    }
}

fn cmd_eval(input: &SceneArgs) -> Result<(), Failure> {
    let scene = input.load(&[])?;
    let mut eval = isoray_shape::PointEvaluator::<f64>::new(scene.shape.tape());
    let stdin = std::io::stdin();
    let stdout = std::io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    for (n, line) in stdin.lock().lines().enumerate() {
        let line = line.map_err(|e| io_failure(format!("cannot read stdin: {e}")))?;
        let text = line.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let nums: Vec<&str> = text
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .collect();
        let parsed: Option<Vec<f64>> = nums.iter().map(|s| s.parse::<f64>().ok()).collect();
        let p = match parsed {
            Some(v) if v.len() == 3 => v,
            _ => {
                return Err(usage(format!(
                    "stdin:{}: expected three numbers `x y z`, found `{text}`",
                    n + 1
                )))
            }
        };
        let d = eval.eval(&scene.inputs, p[0], p[1], p[2]);
        writeln!(out, "{d}").map_err(|e| io_failure(format!("cannot write stdout: {e}")))?;
    }
    out.flush()
        .map_err(|e| io_failure(format!("cannot write stdout: {e}")))?;
    Ok(())
}
