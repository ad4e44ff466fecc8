//! # isoray-render
//!
//! The CPU sphere tracer of isoray. Rays are traced in tiles of
//! [`TILE`]×[`TILE`] pixels, each tile as a wavefront: every sphere-tracing
//! step evaluates all active rays of the tile with one batch call of the
//! shape tape. Shading is `isoray-shade`'s Phong/Blinn-Phong model, with
//! hard, soft or improved soft shadows and ambient occlusion, and its optics
//! for reflected and refracted rays; antialiasing is aa×aa supersampling.
//! Colours are linear inside; sRGB happens once, when a PNG is written.
//!
//! Tiles run in parallel with rayon, and every pixel is computed the same way
//! whatever the thread count, so images are byte-identical across thread counts.
//!
//! ```
//! let scene = isoray_scene::load_str(r#"
//! [camera]
//! position = [0.0, 0.0, 4.0]
//! [render]
//! width = 32
//! height = 24
//! [[light]]
//! [[object]]
//! shape = "sphere(p, 1.0)"
//! "#, "doc.toml", &[]).unwrap();
//! let (image, stats) = isoray_render::render(&scene, &isoray_render::RenderOptions::default());
//! assert_eq!(image.color.len(), 32 * 24);
//! assert_eq!(stats.primary_rays, 32 * 24);
//! ```

pub mod bounds;
pub mod camera;
mod dents;
pub mod meshes;
mod objects;
pub mod output;
mod prune;
mod queue;
pub mod reach;
pub mod sequence;
pub mod tiles;
pub mod trace;
pub mod voxels;
mod whitted;

use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec3;
use isoray_job::{CancelToken, Cancelled, Progress};
use isoray_scene::{NormalMethod, Scene, ShadowMode, View};
use isoray_shade::material::checker;
use isoray_shade::{lights, phong, to_vec3, MaterialSample};
use isoray_shape::GradientMode;
use rayon::prelude::*;

use camera::RayCamera;
use trace::{shadow_march, sphere_trace_capped, Field, Hit, Rays, Scratch};

/// Tile edge in pixels.
pub const TILE: u32 = 16;

/// What to compute besides the colour, and the job's control.
#[derive(Default)]
pub struct RenderOptions {
    /// Compute the depth and normal AOVs (one ray through each pixel centre).
    pub aovs: bool,
    /// Told (tiles done, tiles in all) after each tile.
    pub progress: Option<std::sync::Arc<dyn Progress + Send>>,
    /// Stops the render at the next tile; the render then returns [`Cancelled`].
    pub cancel: Option<CancelToken>,
}

impl std::fmt::Debug for RenderOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RenderOptions")
            .field("aovs", &self.aovs)
            .field("progress", &self.progress.is_some())
            .field("cancel", &self.cancel)
            .finish()
    }
}

/// A rectangle of the image, in pixels (x to the right, y down).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
}

impl Region {
    /// The whole image of the scene.
    pub fn full(scene: &Scene) -> Region {
        Region {
            x0: 0,
            y0: 0,
            width: scene.render.width,
            height: scene.render.height,
        }
    }

    /// The region clipped to a `w`×`h` image.
    fn clip(self, w: u32, h: u32) -> Region {
        let x0 = self.x0.min(w);
        let y0 = self.y0.min(h);
        Region {
            x0,
            y0,
            width: self.width.min(w - x0),
            height: self.height.min(h - y0),
        }
    }
}

/// One pass of a progressive render.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// One sample at the centre of each n×n block of pixels (aligned to
    /// multiples of n), filling the block: a coarse preview.
    Blocks(u32),
    /// One sample at each pixel centre (the final image when aa = 1).
    Pixels,
    /// aa×aa samples per pixel: the final image, byte for byte what
    /// [`render`] computes.
    Final,
}

/// The progressive passes in order: 8×8, 4×4 and 2×2 blocks, every pixel,
/// then the antialiasing samples (left out when aa = 1, where the pixel
/// pass is already the final image).
pub fn passes(scene: &Scene) -> Vec<Pass> {
    let mut v = vec![Pass::Blocks(8), Pass::Blocks(4), Pass::Blocks(2)];
    if scene.render.aa > 1 {
        v.push(Pass::Pixels);
    }
    v.push(Pass::Final);
    v
}

/// A finished tile of a pass, handed to a [`TileSink`].
#[derive(Debug, Clone, Copy)]
pub struct TileImage<'a> {
    /// The pass it belongs to.
    pub pass: Pass,
    /// Where it goes in the image.
    pub region: Region,
    /// Linear RGB, row-major, `region.width × region.height`.
    pub color: &'a [[f32; 3]],
}

/// Receives tiles as they finish (from worker threads, in any order).
pub trait TileSink: Sync {
    /// A tile is done.
    fn tile(&self, tile: &TileImage);
}

/// A sink that ignores tiles.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoSink;

impl TileSink for NoSink {
    fn tile(&self, _tile: &TileImage) {}
}

impl<F: Fn(&TileImage) + Sync> TileSink for F {
    fn tile(&self, tile: &TileImage) {
        self(tile)
    }
}

/// A rendered image and its AOVs, row-major from the top-left pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB.
    pub color: Vec<[f32; 3]>,
    /// Distance t along the primary ray through the pixel centre; +inf on a miss.
    pub depth: Option<Vec<f32>>,
    /// World-space unit shading normal at the pixel-centre hit (normal
    /// mapped on dented objects); 0 on a miss.
    pub normals: Option<Vec<[f32; 3]>>,
    /// The diffuse colour of the material at the pixel-centre hit; 0 on a miss.
    pub albedo: Option<Vec<[f32; 3]>>,
}

/// Work counters.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Stats {
    /// Primary rays (pixels × aa²).
    pub primary_rays: u64,
    /// Distance-function evaluations of all kinds.
    pub evaluations: u64,
    /// Primary-ray steps that went from outside to clearly inside a surface:
    /// the field is not a distance bound there (see [`Stats::overshoot_factor`]).
    pub overshoots: u64,
    /// The largest factor a step was too long by; a `lipschitz_factor` at
    /// least this large on the responsible surface removes the overshoots.
    pub overshoot_factor: f32,
    /// Rays traced, by kind.
    pub rays: RayCounts,
}

/// Rays traced, by kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Camera rays (pixels × aa²).
    pub primary: u64,
    /// Mirror-reflected rays.
    pub reflected: u64,
    /// Refracted rays.
    pub refracted: u64,
    /// Shadow rays (one per light sample and shaded hit facing the light).
    pub shadow: u64,
}

impl std::ops::AddAssign for RayCounts {
    fn add_assign(&mut self, o: RayCounts) {
        self.primary += o.primary;
        self.reflected += o.reflected;
        self.refracted += o.refracted;
        self.shadow += o.shadow;
    }
}

/// Number of tiles an image of the scene's size is split into.
pub fn tile_count(scene: &Scene) -> usize {
    let (w, h) = (scene.render.width, scene.render.height);
    (w.div_ceil(TILE) * h.div_ceil(TILE)) as usize
}

impl TileOut {
    /// The part of the tile inside `region`, with its colours.
    fn clip(&self, region: Region) -> (Region, Vec<[f32; 3]>) {
        let x0 = self.x0.max(region.x0);
        let y0 = self.y0.max(region.y0);
        let x1 = (self.x0 + self.w).min(region.x0 + region.width);
        let y1 = (self.y0 + self.h).min(region.y0 + region.height);
        let mut color = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
        for y in y0..y1 {
            for x in x0..x1 {
                color.push(self.color[((y - self.y0) * self.w + (x - self.x0)) as usize]);
            }
        }
        (
            Region {
                x0,
                y0,
                width: x1 - x0,
                height: y1 - y0,
            },
            color,
        )
    }
}

struct TileOut {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    color: Vec<[f32; 3]>,
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    albedo: Vec<[f32; 3]>,
    evals: u64,
    overshoots: u64,
    worst_overshoot: f32,
    counts: RayCounts,
}

/// Renders the scene (the whole image, final pass). Without a cancel token
/// in `opts` it cannot fail; see [`render_with`].
pub fn render(scene: &Scene, opts: &RenderOptions) -> (RenderedImage, Stats) {
    match render_with(scene, opts) {
        Ok(r) => r,
        // Only a token can cancel; a render without one always finishes.
        Err(Cancelled) => (empty_image(scene, opts.aovs), Stats::default()),
    }
}

fn empty_image(scene: &Scene, aovs: bool) -> RenderedImage {
    let (w, h) = (scene.render.width, scene.render.height);
    let n = (w * h) as usize;
    RenderedImage {
        width: w,
        height: h,
        color: vec![[0.0; 3]; n],
        depth: aovs.then(|| vec![f32::INFINITY; n]),
        normals: aovs.then(|| vec![[0.0; 3]; n]),
        albedo: aovs.then(|| vec![[0.0; 3]; n]),
    }
}

/// Renders the whole image, stopping with [`Cancelled`] when `opts.cancel` is
/// cancelled (checked before every tile).
pub fn render_with(scene: &Scene, opts: &RenderOptions) -> Result<(RenderedImage, Stats), Cancelled> {
    render_region_image(scene, Region::full(scene), opts)
}

/// Renders `region` in one final pass into an image of the whole size
/// (black outside the region). The region's pixels are byte for byte those
/// of a whole render, so bands rendered apart (`isoray render --tile`)
/// assemble into the same image.
pub fn render_region_image(
    scene: &Scene,
    region: Region,
    opts: &RenderOptions,
) -> Result<(RenderedImage, Stats), Cancelled> {
    let mut img = empty_image(scene, opts.aovs);
    let stats = render_into(scene, region, Pass::Final, opts, &NoSink, Some(&mut img))?;
    Ok((img, stats))
}

/// Renders `region` of the image in one pass, handing each finished tile
/// to `sink`. Tiles follow the image's [`TILE`] grid, so the final pass of
/// a region is byte for byte the same pixels as a whole render.
pub fn render_region(
    scene: &Scene,
    region: Region,
    pass: Pass,
    opts: &RenderOptions,
    sink: &dyn TileSink,
) -> Result<Stats, Cancelled> {
    render_into(scene, region, pass, opts, sink, None)
}

/// Renders `region` progressively: every pass of [`passes`] in turn, each
/// tile handed to `sink` as it finishes, so a preview shows a coarse image
/// at once and refines it. Returns the final image (pixels outside
/// `region` are black) and the stats of the final pass.
pub fn render_progressive(
    scene: &Scene,
    region: Region,
    opts: &RenderOptions,
    sink: &dyn TileSink,
) -> Result<(RenderedImage, Stats), Cancelled> {
    let mut img = empty_image(scene, opts.aovs);
    let mut stats = Stats::default();
    for pass in passes(scene) {
        let pass_opts = RenderOptions {
            aovs: opts.aovs && pass == Pass::Final,
            progress: opts.progress.clone(),
            cancel: opts.cancel.clone(),
        };
        stats = render_into(scene, region, pass, &pass_opts, sink, Some(&mut img))?;
    }
    Ok((img, stats))
}

/// The tiles of the image grid that meet `region`.
fn grid_tiles(w: u32, h: u32, region: Region) -> Vec<(u32, u32)> {
    if region.width == 0 || region.height == 0 {
        return Vec::new();
    }
    let (tx0, ty0) = (region.x0 / TILE, region.y0 / TILE);
    let (tx1, ty1) = (
        (region.x0 + region.width).div_ceil(TILE).min(w.div_ceil(TILE)),
        (region.y0 + region.height).div_ceil(TILE).min(h.div_ceil(TILE)),
    );
    (ty0..ty1)
        .flat_map(|ty| (tx0..tx1).map(move |tx| (tx * TILE, ty * TILE)))
        .collect()
}

fn render_into(
    scene: &Scene,
    region: Region,
    pass: Pass,
    opts: &RenderOptions,
    sink: &dyn TileSink,
    mut img: Option<&mut RenderedImage>,
) -> Result<Stats, Cancelled> {
    let (w, h) = (scene.render.width, scene.render.height);
    let region = region.clip(w, h);
    let cam = RayCamera::new(&scene.camera, w, h);
    let tiles = grid_tiles(w, h, region);
    // The surface's reach pays for itself on the passes that trace every
    // pixel, not on a preview's coarse blocks (which it would delay).
    let rays = match pass {
        Pass::Blocks(_) => None,
        Pass::Pixels => Some(region.width as u64 * region.height as u64),
        Pass::Final => Some(region.width as u64 * region.height as u64 * (scene.render.aa as u64).pow(2)),
    };
    let ctx = Ctx::new(scene, cam, rays);
    let done = AtomicU64::new(0);
    let total = tiles.len() as u64;
    // One worker per thread, taking its band of tiles and then helping the
    // others (`queue`): a worker's pruned fields (their octrees of
    // simplified tapes) serve every tile its thread renders.
    let slots: Vec<std::sync::Mutex<Option<TileOut>>> = tiles.iter().map(|_| std::sync::Mutex::new(None)).collect();
    let threads = rayon::current_num_threads().min(tiles.len()).max(1);
    let queue = queue::TileQueue::new(tiles.len(), threads);
    (0..threads).into_par_iter().for_each(|worker| {
        let mut wk = Worker::new(&ctx);
        while let Some(k) = queue.take(worker) {
            let (x0, y0) = tiles[k];
            if opts.cancel.as_ref().is_some_and(|c| c.is_cancelled()) {
                break;
            }
            let (tw, th) = (TILE.min(w - x0), TILE.min(h - y0));
            let out = wk.tile(&ctx, x0, y0, tw, th, opts.aovs, pass);
            let clip = out.clip(region);
            sink.tile(&TileImage {
                pass,
                region: clip.0,
                color: &clip.1,
            });
            if let Some(p) = &opts.progress {
                p.update(done.fetch_add(1, Ordering::Relaxed) + 1, total);
            }
            *slots[k].lock().unwrap_or_else(|e| e.into_inner()) = Some(out);
        }
    });
    let outs: Vec<Option<TileOut>> = slots
        .into_iter()
        .map(|m| m.into_inner().unwrap_or_else(|e| e.into_inner()))
        .collect();
    if opts.cancel.as_ref().is_some_and(|c| c.is_cancelled()) || outs.iter().any(Option::is_none) {
        return Err(Cancelled);
    }
    let mut evals = 0;
    let (mut overshoots, mut worst) = (0, 0.0f32);
    let mut counts = RayCounts::default();
    for t in outs.into_iter().flatten() {
        evals += t.evals;
        counts += t.counts;
        overshoots += t.overshoots;
        worst = worst.max(t.worst_overshoot);
        let Some(img) = img.as_deref_mut() else { continue };
        for j in 0..t.h {
            for i in 0..t.w {
                let (x, y) = (t.x0 + i, t.y0 + j);
                if x < region.x0 || y < region.y0 || x >= region.x0 + region.width || y >= region.y0 + region.height {
                    continue;
                }
                let src = (j * t.w + i) as usize;
                let dst = (y * w + x) as usize;
                img.color[dst] = t.color[src];
                if let (Some(d), false) = (&mut img.depth, t.depth.is_empty()) {
                    d[dst] = t.depth[src];
                }
                if let (Some(nm), false) = (&mut img.normals, t.normals.is_empty()) {
                    nm[dst] = t.normals[src];
                }
                if let (Some(al), false) = (&mut img.albedo, t.albedo.is_empty()) {
                    al[dst] = t.albedo[src];
                }
            }
        }
    }
    let spp = match pass {
        Pass::Final => (scene.render.aa * scene.render.aa) as u64,
        _ => 1,
    };
    let pixels = region.width as u64 * region.height as u64;
    Ok(Stats {
        primary_rays: pixels * spp,
        evaluations: evals,
        overshoots,
        overshoot_factor: worst,
        rays: RayCounts {
            primary: pixels * spp,
            ..counts
        },
    })
}

/// The top-left corners of the n×n blocks (aligned to multiples of n)
/// whose centre lies in the tile at (x0, y0) of size tw×th.
fn block_grid(x0: u32, y0: u32, tw: u32, th: u32, n: u32) -> Vec<(u32, u32)> {
    let centre_in = |b: u32, lo: u32, len: u32| {
        let c2 = 2 * b + n; // twice the centre
        c2 >= 2 * lo && c2 < 2 * (lo + len)
    };
    let first = |lo: u32| (lo / n).saturating_sub(1) * n;
    let mut out = Vec::new();
    let mut by = first(y0);
    while by < y0 + th {
        if centre_in(by, y0, th) {
            let mut bx = first(x0);
            while bx < x0 + tw {
                if centre_in(bx, x0, tw) {
                    out.push((bx, by));
                }
                bx += n;
            }
        }
        by += n;
    }
    out
}

/// Whether the closed-form surface `a` blocks the shadow ray o + t·d
/// marched from t = `start` to `tmax` with the occluder threshold `eps`: as
/// a march would, when the ray starts within `eps` of it (or inside) or
/// meets it before `tmax`.
fn blocks(a: &isoray_scene::analytic::Analytic, o: [f32; 3], d: [f32; 3], start: f32, tmax: f32, eps: f32) -> bool {
    let p: [f64; 3] = std::array::from_fn(|k| (o[k] + d[k] * start) as f64);
    if a.distance(p) < eps as f64 {
        return true;
    }
    a.intersect(o, d).iter().any(|&t| t >= start && t < tmax)
}

/// The distance to the occluders beyond which no shadow ray marched
/// without closed forms can be darkened, whatever its light: a hard shadow
/// ray meets an occluder only nearer than the shadow epsilon, and the soft
/// and improved estimates take the least d / (size · t) over the march,
/// capped at 1, which d ≥ size · `shadow_max_distance` ≥ size · t never
/// lowers. None without shadows, or with Aaltonen's estimate (which a
/// large d does not bound).
fn penumbra(scene: &Scene) -> Option<f64> {
    let s = &scene.render;
    let mut d: Option<f64> = None;
    for light in &scene.lights {
        let area = lights::sample_count(light) > 1 || lights::is_area(light);
        let reach = match (s.shadows, area) {
            (ShadowMode::None, _) => continue,
            (_, true) | (ShadowMode::Hard, false) => trace::shadow_epsilon(s) as f64,
            (ShadowMode::Soft | ShadowMode::Improved, false) => light.size * s.shadow_max_distance,
            (ShadowMode::Aaltonen, false) => return None,
        };
        d = Some(d.map_or(reach, |d: f64| d.max(reach)));
    }
    d
}

/// Where the fields the CPU tracer marches can have surface, for a pass
/// tracing `rays` primary rays from a camera at `origin` (None: a coarse
/// pass, without the surfaces' reach): see [`reach`]. The GPU renderer
/// stops its rays where this one does.
#[derive(Debug, Clone)]
pub struct Reaches {
    /// The cube every traced point lies in (the camera's reach, then
    /// shadow rays' and ambient-occlusion samples'): the domain of the
    /// pruned fields; None with `render.prune` off.
    pub domain: Option<([f64; 3], f64)>,
    /// Per object, the sphere its distance is, when it is (with
    /// `render.prune` on and several objects; empty otherwise).
    pub object_spheres: Vec<Option<([f64; 3], f64)>>,
    /// The scene's field (rays outside objects without closed forms).
    pub scene: Option<reach::Reach>,
    /// The objects marched beside closed-form ones.
    pub rest: Option<reach::Reach>,
    /// What hard shadow rays march beside closed forms.
    pub shadow: Option<reach::Reach>,
    /// The transparent objects shadow rays pass through.
    pub clear: Option<reach::Reach>,
    /// Where the field shadow rays march without closed forms is below
    /// the penumbra's distance.
    pub penumbra: Option<reach::Reach>,
}

/// The fields' reaches (see [`Reaches`]).
pub fn reaches(scene: &Scene, origin: [f64; 3], rays: Option<u64>) -> Reaches {
    let r = &scene.render;
    let reach = r.max_distance + r.shadow_max_distance + r.ao_step * r.ao_samples as f64 + 1.0;
    let domain = r.prune.then_some((origin, reach));
    // A hit is a distance below hit_epsilon (times t, at most max_distance).
    let above = r.hit_epsilon
        * if r.relative_epsilon {
            r.max_distance.max(1.0)
        } else {
            1.0
        };
    // The objects that are spheres. When all are, the scene's reach
    // (and the penumbra's, of the same field) is a union of balls' boxes.
    let object_spheres: Vec<Option<([f64; 3], f64)>> = if domain.is_some() && scene.objects.len() > 1 {
        scene
            .objects
            .par_iter()
            .map(|o| match o.closed_form(&scene.inputs) {
                Some(isoray_scene::analytic::Analytic::Sphere { c, r }) => Some((c, r)),
                _ => None,
            })
            .collect()
    } else {
        Vec::new()
    };
    let spheres: Option<Vec<([f64; 3], f64)>> = object_spheres
        .iter()
        .copied()
        .collect::<Option<Vec<_>>>()
        .filter(|s| !s.is_empty());
    // Not in the steps view, which shows the march as it is without
    // them (as it does without closed forms).
    let reach_above = |tape: &isoray_shape::Tape, above: f64| {
        let rays = rays.filter(|_| r.view != View::Steps)?;
        let (c, h) = domain?;
        let closed = spheres
            .as_ref()
            .filter(|_| std::ptr::eq(tape, scene.shape.tape()))
            .and_then(|s| reach::Reach::of_spheres(s, r.blend, c, h, above));
        Some(closed.unwrap_or_else(|| reach::Reach::new(tape, &scene.inputs, c, h, above, rays)))
    };
    // The fields' reaches, computed side by side (each is a search of
    // its own over interval bounds, done before any tile starts).
    let shadow = scene.derived().shadow.as_ref();
    // The penumbra's box is the surface's when it bounds the same field
    // at a distance no greater.
    let penumbra_d = penumbra(scene);
    let penumbra_is_surface = shadow.is_none() && penumbra_d.is_some_and(|d| d <= above);
    let wanted: [Option<(&isoray_shape::Tape, f64)>; 5] = [
        Some((scene.shape.tape(), above)),
        scene.derived().rest.as_ref().map(|r| (r.tape(), above)),
        shadow.and_then(|sh| sh.opaque_rest.as_ref()).map(|r| (r.tape(), above)),
        shadow
            .filter(|_| scene.render.shadows != ShadowMode::None)
            .map(|sh| (sh.transparent.tape(), above)),
        penumbra_d
            .filter(|_| !penumbra_is_surface)
            .map(|d| (shadow.map_or(scene.shape.tape(), |sh| sh.opaque.tape()), d)),
    ];
    let reaches: Vec<Option<reach::Reach>> = wanted
        .par_iter()
        .map(|w| w.and_then(|(tape, above)| reach_above(tape, above)))
        .collect();
    let [scene_reach, rest_reach, opaque_rest_reach, clear_reach, penumbra_reach] = std::array::from_fn(|k| reaches[k]);
    let penumbra_reach = if penumbra_is_surface {
        scene_reach
    } else {
        penumbra_reach
    };
    let shadow_reach = if shadow.is_some() {
        opaque_rest_reach
    } else {
        rest_reach
    };
    Reaches {
        domain,
        object_spheres,
        scene: scene_reach,
        rest: rest_reach,
        shadow: shadow_reach,
        clear: clear_reach,
        penumbra: penumbra_reach,
    }
}

/// Read-only render context shared by all workers.
struct Ctx<'s> {
    scene: &'s Scene,
    cam: RayCamera,
    /// The surface of each object, then of each mesh (object index
    /// `objects.len() + m` is mesh m).
    surfaces: Vec<MaterialSample>,
    /// The material index of each object, then of each mesh.
    material_of: Vec<usize>,
    /// Every material as a surface, by material index (for checkers).
    material_surfaces: Vec<MaterialSample>,
    gradient: GradientMode,
    /// The cube every traced point lies in (the camera's reach, then
    /// shadow rays' and ambient-occlusion samples'): the domain of the
    /// pruned fields; None with `render.prune` off.
    domain: Option<([f64; 3], f64)>,
    /// Where the scene's surface and that of the objects marched beside
    /// closed-form ones can be (with `render.prune` on): rays stop
    /// marching once they leave it.
    scene_reach: Option<reach::Reach>,
    rest_reach: Option<reach::Reach>,
    /// The same for what hard shadow rays march beside closed forms.
    shadow_reach: Option<reach::Reach>,
    /// The same for the transparent objects shadow rays pass through.
    clear_reach: Option<reach::Reach>,
    /// Where the field shadow rays march without closed forms is below
    /// [`penumbra`]: past it they stop (nothing there changes their
    /// visibility).
    penumbra_reach: Option<reach::Reach>,
    /// When every transparent object is a plane or a sphere in closed
    /// form: those objects (index and form), which shadow rays then
    /// intersect instead of marching.
    clear_closed: Option<Vec<(usize, isoray_scene::analytic::Analytic)>>,
    /// Per object, the sphere its distance is, when it is (with
    /// `render.prune` on and several objects; empty otherwise): bounded in
    /// closed form by the scene field's object-level cells.
    object_spheres: Vec<Option<([f64; 3], f64)>>,
    /// The planes and spheres in closed form that block hard shadow rays:
    /// the opaque ones when shadow rays trace transparent objects apart,
    /// else all.
    opaque_closed: Vec<isoray_scene::analytic::Analytic>,
}

impl<'s> Ctx<'s> {
    /// The context of a pass tracing `rays` primary rays (None: a coarse
    /// pass, without the surfaces' reach).
    fn new(scene: &'s Scene, cam: RayCamera, rays: Option<u64>) -> Self {
        let h = scene.render.normal_epsilon;
        let gradient = match scene.render.normals {
            NormalMethod::Central => GradientMode::Central(h),
            NormalMethod::Forward => GradientMode::Forward(h),
            NormalMethod::Tetrahedron => GradientMode::Tetrahedron(h),
            NormalMethod::Analytic => GradientMode::Dual,
        };
        let material_of: Vec<usize> = scene
            .objects
            .iter()
            .map(|o| o.material)
            .chain(scene.meshes.iter().map(|m| m.material))
            .collect();
        let surfaces: Vec<MaterialSample> = material_of
            .iter()
            .map(|&m| MaterialSample::from(&scene.materials[m]))
            .collect();
        let material_surfaces = scene.materials.iter().map(MaterialSample::from).collect();
        let Reaches {
            domain,
            object_spheres,
            scene: scene_reach,
            rest: rest_reach,
            shadow: shadow_reach,
            clear: clear_reach,
            penumbra: penumbra_reach,
        } = reaches(scene, cam.origin().to_array(), rays);
        let shadow = scene.derived().shadow.as_ref();
        let opaque_closed = (scene.derived().analytic.iter())
            .zip(&surfaces)
            .filter(|(_, sf)| shadow.is_none() || sf.transparency <= 0.0)
            .filter_map(|(a, _)| *a)
            .collect();
        let clear_closed = shadow.and_then(|_| {
            let analytic = &scene.derived().analytic;
            let forms: Option<Vec<_>> = (0..scene.objects.len())
                .filter(|&k| surfaces[k].transparency > 0.0)
                .map(|k| analytic.get(k).copied().flatten().map(|a| (k, a)))
                .collect();
            forms.filter(|f| !f.is_empty())
        });
        Ctx {
            scene,
            cam,
            domain,
            scene_reach,
            rest_reach,
            shadow_reach,
            clear_reach,
            penumbra_reach,
            clear_closed,
            opaque_closed,
            object_spheres,
            surfaces,
            material_of,
            material_surfaces,
            gradient,
        }
    }
}

/// Per-thread state: evaluators and scratch buffers.
struct Worker<'s> {
    scene_eval: Field<'s>,
    /// The unsigned distance to the nearest surface, for rays inside objects.
    surf_eval: Field<'s>,
    /// What shadow rays trace when some object is transparent.
    shadow_evals: Option<whitted::ShadowEvals<'s>>,
    /// The union of the objects that are not planes or spheres (those are
    /// intersected in closed form), when some are.
    rest_eval: Option<Field<'s>>,
    caps: Vec<f32>,
    /// Rays traced, by kind (summed over tiles).
    counts: RayCounts,
    /// The current tile's top-left pixel (seeds the light samples).
    tile_origin: (u32, u32),
    /// Every object's field, when there are several (materials, nearest
    /// objects).
    objects: Option<objects::Objects<'s>>,
    scratch: Scratch,
    rays: Rays,
    hits: Vec<Hit>,
}

/// Geometry of the hit samples of a packet.
#[derive(Default)]
struct HitSet {
    /// Sample index of each hit.
    idx: Vec<usize>,
    px: Vec<f32>,
    py: Vec<f32>,
    pz: Vec<f32>,
    nx: Vec<f32>,
    ny: Vec<f32>,
    nz: Vec<f32>,
    /// The gradient's norm before normalising (the gradient view).
    gnorm: Vec<f32>,
    /// Per hit, the mesh it is on (None: an object of the field).
    mesh: Vec<Option<u32>>,
}

impl<'s> Worker<'s> {
    fn new(ctx: &Ctx<'s>) -> Self {
        let vars: &'s [f64] = &ctx.scene.inputs;
        let objects = (ctx.scene.objects.len() > 1).then(|| {
            let tapes = ctx.scene.objects.iter().map(|o| o.shape.tape()).collect();
            objects::Objects::new(tapes, vars, &ctx.object_spheres)
        });
        let field = |tape: &'s isoray_shape::Tape| match ctx.domain {
            Some((center, half)) => Field::pruned(tape, vars, center, half),
            None => Field::new(tape, vars),
        };
        Worker {
            scene_eval: match ctx.domain.filter(|_| ctx.scene.objects.len() > 1) {
                // The scene's distance is the fold of its objects'.
                Some((center, half)) => {
                    let tapes: Vec<&'s isoray_shape::Tape> = ctx.scene.objects.iter().map(|o| o.shape.tape()).collect();
                    let probe = match ctx.scene_reach.and_then(|r| r.surface()) {
                        Some(b) => (
                            std::array::from_fn(|k| 0.5 * (b.lo[k] + b.hi[k])),
                            (0..3).map(|k| 0.5 * (b.hi[k] - b.lo[k])).fold(1e-3, f64::max),
                        ),
                        None => (center, half),
                    };
                    let k = ctx.scene.render.blend;
                    let spheres = &ctx.object_spheres;
                    Field::pruned_fold(ctx.scene.shape.tape(), &tapes, spheres, k, vars, center, half, probe)
                }
                None => field(ctx.scene.shape.tape()),
            },
            surf_eval: field(ctx.scene.derived().surfaces.tape()),
            counts: RayCounts::default(),
            rest_eval: ctx.scene.derived().rest.as_ref().map(|r| field(r.tape())),
            caps: Vec::new(),
            tile_origin: (0, 0),
            shadow_evals: ctx.scene.derived().shadow.as_ref().map(|sh| whitted::ShadowEvals {
                opaque: field(sh.opaque.tape()),
                clear: field(sh.transparent.tape()),
                clear_surfaces: field(sh.transparent_surfaces.tape()),
                opaque_rest: sh.opaque_rest.as_ref().map(|r| field(r.tape())),
            }),
            objects,
            scratch: Scratch::default(),
            rays: Rays::default(),
            hits: Vec::new(),
        }
    }

    /// Traces `self.rays` and computes hit positions and normals. Rays
    /// `inside` objects trace the unsigned distance to the nearest surface.
    fn trace_and_normals(&mut self, ctx: &Ctx, inside: bool) -> (HitSet, u64) {
        let s = &ctx.scene.render;
        // Meshes first: the nearest triangle of each ray caps its march.
        let mesh_hits = meshes::closest_hits(&ctx.scene.meshes, &self.rays);
        let rest = !inside && self.rest_eval.is_some();
        let capped = rest || !ctx.scene.meshes.is_empty();
        self.caps.clear();
        if capped {
            // Planes and spheres in closed form, and meshes; the other
            // objects marched up to the nearest of them.
            for i in 0..self.rays.len() {
                let (o, d) = (self.rays.origin(i), self.rays.direction(i));
                let analytic = if rest {
                    ctx.scene
                        .derived()
                        .analytic
                        .iter()
                        .flatten()
                        .map(|a| a.intersect(o, d)[0])
                        .fold(f32::INFINITY, f32::min)
                } else {
                    f32::INFINITY
                };
                let mesh = mesh_hits.get(i).and_then(|h| h.map(|h| h.t)).unwrap_or(f32::INFINITY);
                self.caps.push(analytic.min(mesh));
            }
        }
        // Where the marched field's surface ends along each ray.
        let reach = match (inside, rest) {
            (true, _) => None,
            (false, true) => ctx.rest_reach.as_ref(),
            (false, false) => ctx.scene_reach.as_ref(),
        };
        let tmax = s.max_distance as f32;
        let far: Option<Vec<f32>> = reach.map(|r| {
            (0..self.rays.len())
                .map(|i| r.far(self.rays.origin(i), self.rays.direction(i), tmax))
                .collect()
        });
        let ev = match (inside, self.rest_eval.as_mut()) {
            (true, _) => &mut self.surf_eval,
            (false, Some(rest)) => rest,
            (false, None) => &mut self.scene_eval,
        };
        let caps = capped.then_some(&self.caps[..]);
        let mut evals = sphere_trace_capped(
            ev,
            &self.rays,
            s,
            &mut self.scratch,
            &mut self.hits,
            caps,
            far.as_deref(),
        );
        // A march that stopped at a mesh's triangle is a hit on the mesh,
        // exactly where the triangle is.
        let eps = s.hit_epsilon as f32;
        let mut on_mesh: Vec<Option<meshes::MeshHit>> = vec![None; self.rays.len()];
        for (i, h) in self.hits.iter_mut().enumerate() {
            if let Some(Some(mh)) = mesh_hits.get(i) {
                if h.t.is_finite() && h.t >= mh.t - eps && mh.t <= self.caps[i] {
                    h.t = mh.t;
                    on_mesh[i] = Some(*mh);
                }
            }
        }
        let mut hs = HitSet::default();
        for (i, h) in self.hits.iter().enumerate() {
            if h.t.is_finite() {
                hs.idx.push(i);
                hs.px.push(self.rays.ox[i] + self.rays.dx[i] * h.t);
                hs.py.push(self.rays.oy[i] + self.rays.dy[i] * h.t);
                hs.pz.push(self.rays.oz[i] + self.rays.dz[i] * h.t);
                hs.mesh.push(on_mesh[i].map(|m| m.mesh));
            }
        }
        let m = hs.idx.len();
        hs.nx.resize(m, 0.0);
        hs.ny.resize(m, 0.0);
        hs.nz.resize(m, 0.0);
        // Inside, the field is unsigned (|d|): finite differences across the
        // surface cancel, so normals there come from dual numbers, exact at
        // any distance from the surface.
        let (ev, mode) = if inside {
            (&mut self.surf_eval, GradientMode::Dual)
        } else {
            (&mut self.scene_eval, ctx.gradient)
        };
        ev.gradients(&hs.px, &hs.py, &hs.pz, mode, &mut hs.nx, &mut hs.ny, &mut hs.nz);
        evals += m as u64 * gradient_cost(mode);
        hs.gnorm.clear();
        for k in 0..m {
            if let Some(mh) = on_mesh[hs.idx[k]] {
                let n = meshes::normal(&ctx.scene.meshes, &mh);
                (hs.nx[k], hs.ny[k], hs.nz[k]) = (n[0], n[1], n[2]);
            }
            let g = Vec3::new(hs.nx[k], hs.ny[k], hs.nz[k]);
            hs.gnorm.push(g.length());
            let n = g.normalize_or_zero();
            let i = hs.idx[k];
            let dir = Vec3::new(self.rays.dx[i], self.rays.dy[i], self.rays.dz[i]);
            // Degenerate gradient: face the viewer. A normal facing away from
            // the ray (a hit just past the zero set of an unsigned field such
            // as abs(f), or an open sheet seen from behind) is turned to face
            // it: surfaces are shaded on the side the ray sees.
            let n = if n == Vec3::ZERO {
                -dir
            } else if n.dot(dir) > 0.0 {
                -n
            } else {
                n
            };
            hs.nx[k] = n.x;
            hs.ny[k] = n.y;
            hs.nz[k] = n.z;
        }
        (hs, evals)
    }

    #[allow(clippy::too_many_arguments)]
    fn tile(&mut self, ctx: &Ctx, x0: u32, y0: u32, tw: u32, th: u32, aovs: bool, pass: Pass) -> TileOut {
        let s = &ctx.scene.render;
        let (aa, block) = match pass {
            Pass::Final => (s.aa, 1),
            Pass::Pixels => (1, 1),
            // Blocks must not straddle tiles: n is a power of two up to TILE.
            Pass::Blocks(n) => (1, n.clamp(1, TILE).next_power_of_two().min(TILE)),
        };
        self.tile_origin = (x0, y0);
        let origin = ctx.cam.origin().as_vec3().to_array();
        self.rays.clear();
        if block > 1 {
            // One ray at the centre of each block (blocks aligned to the image).
            let blocks = block_grid(x0, y0, tw, th, block);
            for &(bx, by) in &blocks {
                let c = block as f64 * 0.5;
                let d = ctx.cam.direction(bx as f64 + c, by as f64 + c);
                self.rays.push(origin, d.as_vec3().to_array());
            }
            let (hs, mut evals) = self.trace_and_normals(ctx, false);
            let samples = self.shade_samples(ctx, hs, &mut evals);
            let mut color = vec![[0.0f32; 3]; (tw * th) as usize];
            for (&(bx, by), c) in blocks.iter().zip(&samples) {
                for y in by.max(y0)..(by + block).min(y0 + th) {
                    for x in bx.max(x0)..(bx + block).min(x0 + tw) {
                        color[((y - y0) * tw + (x - x0)) as usize] = c.to_array();
                    }
                }
            }
            return TileOut {
                x0,
                y0,
                w: tw,
                h: th,
                color,
                depth: Vec::new(),
                normals: Vec::new(),
                albedo: Vec::new(),
                evals,
                overshoots: std::mem::take(&mut self.scratch.overshoots),
                worst_overshoot: std::mem::take(&mut self.scratch.worst_overshoot),
                counts: std::mem::take(&mut self.counts),
            };
        }
        // Primary rays: aa×aa per pixel at the centres of a uniform sub-grid.
        for j in 0..th {
            for i in 0..tw {
                for sy in 0..aa {
                    for sx in 0..aa {
                        let (ox, oy) = sample_offset(s.aa_pattern, aa, sx, sy, x0 + i, y0 + j);
                        let x = (x0 + i) as f64 + ox;
                        let y = (y0 + j) as f64 + oy;
                        self.rays.push(origin, ctx.cam.direction(x, y).as_vec3().to_array());
                    }
                }
            }
        }
        let (hs, mut evals) = self.trace_and_normals(ctx, false);
        let samples = self.shade_samples(ctx, hs, &mut evals);
        let spp = (aa * aa) as usize;
        let inv = 1.0 / spp as f32;
        let color: Vec<[f32; 3]> = samples
            .chunks(spp)
            .map(|c| (c.iter().copied().sum::<Vec3>() * inv).to_array())
            .collect();

        let (mut depth, mut normals, mut albedo) = (Vec::new(), Vec::new(), Vec::new());
        if aovs {
            self.rays.clear();
            for j in 0..th {
                for i in 0..tw {
                    let d = ctx.cam.direction((x0 + i) as f64 + 0.5, (y0 + j) as f64 + 0.5);
                    self.rays.push(origin, d.as_vec3().to_array());
                }
            }
            let (mut hs, e) = self.trace_and_normals(ctx, false);
            evals += e;
            depth = self.hits.iter().map(|h| h.t).collect();
            let (surfaces, objects) = self.materials(ctx, &hs, &mut evals, false);
            // The shading normal: dented objects' tilted by their normal maps.
            crate::dents::perturb(ctx.scene, &mut hs, &objects, &self.rays);
            normals = vec![[0.0; 3]; self.rays.len()];
            for (k, &i) in hs.idx.iter().enumerate() {
                normals[i] = [hs.nx[k], hs.ny[k], hs.nz[k]];
            }
            albedo = vec![[0.0; 3]; self.rays.len()];
            for (k, &i) in hs.idx.iter().enumerate() {
                albedo[i] = surfaces[k].diffuse.to_array();
            }
        }
        TileOut {
            x0,
            y0,
            w: tw,
            h: th,
            color,
            depth,
            normals,
            albedo,
            evals,
            overshoots: std::mem::take(&mut self.scratch.overshoots),
            worst_overshoot: std::mem::take(&mut self.scratch.worst_overshoot),
            counts: std::mem::take(&mut self.counts),
        }
    }

    /// The colour of each primary ray of `self.rays` (traced into `hs`), as
    /// the scene's view asks: shaded, the step count or the normal.
    fn shade_samples(&mut self, ctx: &Ctx, hs: HitSet, evals: &mut u64) -> Vec<Vec3> {
        let s = &ctx.scene.render;
        let mut samples = vec![to_vec3(s.background); self.rays.len()];
        match s.view {
            View::Steps => {
                for (i, h) in self.hits.iter().enumerate() {
                    samples[i] = heat(h.steps as f32 / s.max_steps as f32);
                }
            }
            View::Normals => {
                for (k, &i) in hs.idx.iter().enumerate() {
                    samples[i] = Vec3::new(hs.nx[k], hs.ny[k], hs.nz[k]) * 0.5 + 0.5;
                }
            }
            View::Mask => {
                samples.iter_mut().for_each(|c| *c = Vec3::ZERO);
                for &i in &hs.idx {
                    samples[i] = Vec3::ONE;
                }
            }
            View::Gradient => {
                for (k, &i) in hs.idx.iter().enumerate() {
                    samples[i] = heat(0.5 * hs.gnorm[k]);
                }
            }
            View::Uv => {
                let cam = &ctx.scene.camera;
                let basis = cam.basis().map(|v| Vec3::from_array(v.map(|x| x as f32)));
                let tan = cam.tan_half_fov() as f32;
                let aspect = (s.width as f64 / s.height as f64) as f32;
                // In 4·uv, pixel centres lie 8/h apart at quarter multiples of
                // 4/h from the lines: a width of 2.9/h is never a tie.
                let lines = 2.9 / s.height as f32;
                for (i, c) in samples.iter_mut().enumerate() {
                    let d = Vec3::new(self.rays.dx[i], self.rays.dy[i], self.rays.dz[i]);
                    *c = uv_colour(d, basis, tan, aspect, lines);
                }
            }
            View::Shaded => *evals += self.trace_paths(ctx, hs, &mut samples),
        }
        samples
    }

    /// Local shading of the hits of `self.rays`: emission, ambient (with
    /// occlusion) and direct light, the ambient and diffuse parts weighted by
    /// `local` (what the Fresnel split leaves to local shading). Adds the
    /// evaluations spent to `evals`.
    /// `media` holds, per hit, the objects the arriving ray is inside, and
    /// `seeds` a per-sample seed for area-light sampling.
    #[allow(clippy::too_many_arguments)]
    fn shade(
        &mut self,
        ctx: &Ctx,
        hs: &HitSet,
        surfaces: &[MaterialSample],
        local: &[Vec3],
        media: &[whitted::Media],
        seeds: &[u32],
        evals: &mut u64,
    ) -> Vec<Vec3> {
        let scene = ctx.scene;
        let s = &scene.render;
        let m = hs.idx.len();
        if m == 0 {
            return Vec::new();
        }
        let mut ao = self.ambient_occlusion(s, hs, evals);
        // Inside a transparent object the occlusion estimate sees its walls: none there.
        for (a, md) in ao.iter_mut().zip(media) {
            if md.is_inside() {
                *a = 1.0;
            }
        }
        let pos = |k: usize| Vec3::new(hs.px[k], hs.py[k], hs.pz[k]);
        let nrm = |k: usize| Vec3::new(hs.nx[k], hs.ny[k], hs.nz[k]);
        // The Unity thesis's conventions: AO and shadows may darken the
        // whole colour (`factor`) instead of the ambient and direct terms.
        let ao_all = s.ao_applies_to == isoray_scene::AoTarget::All;
        let shadow_all = s.shadow_applies_to == isoray_scene::ShadowTarget::All && s.shadows != ShadowMode::None;
        let ambient_light = Vec3::from_array(s.ambient.map(|x| x as f32));
        let mut factor = vec![1.0f32; m];
        let mut color: Vec<Vec3> = (0..m)
            .map(|k| {
                let a = if ao_all { 1.0 } else { ao[k] };
                phong::emitted_and_ambient(&surfaces[k], local[k], a)
                    + local[k] * ambient_light * surfaces[k].diffuse * a
            })
            .collect();
        let floor = s.shadow_floor as f32;
        // With `shadow_applies_to = "all"`: each light's mean factor over its samples.
        let mut light_factor = vec![0.0f32; m];
        let mut lit = Vec::new();

        let mut shadow_rays = Rays::default();
        let mut tmax = Vec::new();
        let mut which = Vec::new();
        let mut vis = Vec::new();
        let mut origins = Vec::new();
        let mut ldirs = Vec::new();
        let mut start = Vec::new();
        // Area lights are sampled at `samples` points each (a hard shadow ray
        // per point); point and directional lights once, with the penumbra estimate.
        let passes: Vec<(usize, u32, u32)> = scene
            .lights
            .iter()
            .enumerate()
            .flat_map(|(li, light)| {
                let n = lights::sample_count(light);
                (0..n).map(move |j| (li, j, n))
            })
            .collect();
        for (li, j, n) in passes {
            let light = &scene.lights[li];
            let area = n > 1 || lights::is_area(light);
            let mode = if area && s.shadows != ShadowMode::None {
                ShadowMode::Hard
            } else {
                s.shadows
            };
            let radiance = lights::radiance(light, n);
            shadow_rays.clear();
            tmax.clear();
            which.clear();
            origins.clear();
            ldirs.clear();
            start.clear();
            let mut dirs = Vec::with_capacity(m);
            let mut atten = Vec::with_capacity(m);
            for (k, &md) in media.iter().enumerate().take(m) {
                let p = pos(k);
                let lights::Incident {
                    dir: l,
                    dist,
                    attenuation,
                } = lights::sample(
                    light,
                    p,
                    j,
                    n,
                    seeds[k].wrapping_add((li as u32).wrapping_mul(0x9E37_79B9)),
                );
                dirs.push(l);
                atten.push(attenuation);
                if nrm(k).dot(l) > 0.0 {
                    which.push(k);
                    let o = p + nrm(k) * (2.0 * s.hit_epsilon as f32);
                    shadow_rays.push(o.to_array(), l.to_array());
                    tmax.push(dist.min(s.shadow_max_distance as f32));
                    origins.push(o);
                    ldirs.push(l);
                    start.push(md);
                }
            }
            // Hard shadows: planes and spheres in closed form block the rays
            // that meet them, and the other objects are marched, no further
            // than the box their surface lies in.
            let closed = mode == ShadowMode::Hard
                && match &self.shadow_evals {
                    Some(se) => se.opaque_rest.is_some(),
                    None => self.rest_eval.is_some(),
                };
            let mut blocked = Vec::new();
            // How far each ray marches (meshes and transparent objects
            // beyond that still count, below).
            let mut reach_t = tmax.clone();
            if closed {
                let eps = trace::shadow_epsilon(s);
                for r in 0..shadow_rays.len() {
                    let (o, d) = (shadow_rays.origin(r), shadow_rays.direction(r));
                    let hit = (ctx.opaque_closed.iter()).any(|a| blocks(a, o, d, s.shadow_start as f32, tmax[r], eps));
                    blocked.push(hit);
                    if hit {
                        reach_t[r] = -1.0; // not marched
                    } else if let Some(reach) = &ctx.shadow_reach {
                        reach_t[r] = tmax[r].min(reach.far(o, d, tmax[r]));
                    }
                }
            } else if let Some(reach) = &ctx.penumbra_reach {
                // Past the box where occluders are nearer than the
                // penumbra distance, nothing changes the ray's visibility.
                for (r, t) in reach_t.iter_mut().enumerate() {
                    *t = t.min(reach.far(shadow_rays.origin(r), shadow_rays.direction(r), *t));
                }
            }
            // With transparent objects, opaque ones occlude (with the penumbra
            // estimate) and transparent ones transmit, traced separately.
            let occluders = match (&mut self.shadow_evals, self.rest_eval.as_mut()) {
                (Some(se), _) => match (&mut se.opaque_rest, closed) {
                    (Some(rest), true) => rest,
                    _ => &mut se.opaque,
                },
                (None, Some(rest)) if closed => rest,
                (None, _) => &mut self.scene_eval,
            };
            *evals += shadow_march(
                occluders,
                &shadow_rays,
                &reach_t,
                mode,
                light.size as f32,
                s,
                &mut self.scratch,
                &mut vis,
            );
            for (v, &b) in vis.iter_mut().zip(&blocked) {
                if b {
                    *v = 0.0;
                }
            }
            // Meshes block what reaches them (hard shadows).
            if mode != ShadowMode::None {
                meshes::occlude(&scene.meshes, &shadow_rays, &tmax, &mut vis);
            }
            // Transparent objects transmit along the rays the opaque ones let through.
            let transmitted = if self.shadow_evals.is_some() && s.shadows != ShadowMode::None {
                let open: Vec<usize> = (0..vis.len()).filter(|&r| vis[r] > 0.0).collect();
                let pick = |v: &[Vec3]| open.iter().map(|&r| v[r]).collect::<Vec<Vec3>>();
                let tm: Vec<f32> = open.iter().map(|&r| tmax[r]).collect();
                let st: Vec<whitted::Media> = open.iter().map(|&r| start[r]).collect();
                let (t, e) = self.transmission(ctx, &pick(&origins), &pick(&ldirs), &tm, &st);
                *evals += e;
                let mut all = vec![Vec3::ZERO; vis.len()];
                for (&r, v) in open.iter().zip(t) {
                    all[r] = v;
                }
                Some(all)
            } else {
                None
            };
            if mode != ShadowMode::None {
                self.counts.shadow += shadow_rays.len() as u64;
            }
            lit.clear();
            lit.resize(if shadow_all { m } else { 0 }, floor);
            for (r, &k) in which.iter().enumerate() {
                let i = hs.idx[k];
                let v = -Vec3::new(self.rays.dx[i], self.rays.dy[i], self.rays.dz[i]);
                let mut sh = vis[r];
                if mode != ShadowMode::None {
                    if s.shadow_exponent != 1.0 {
                        sh = sh.powf(s.shadow_exponent as f32);
                    }
                    sh = floor + (1.0 - floor) * sh;
                }
                if shadow_all {
                    lit[k] = sh;
                    sh = 1.0;
                }
                let through = transmitted.as_ref().map_or(Vec3::ONE, |t| t[r]);
                let arriving = radiance * atten[k] * sh * through;
                color[k] += phong::direct_light(&surfaces[k], nrm(k), v, dirs[k], local[k], arriving);
            }
            if shadow_all {
                for k in 0..m {
                    light_factor[k] += lit[k] / n as f32;
                    if j + 1 == n {
                        factor[k] *= light_factor[k];
                        light_factor[k] = 0.0;
                    }
                }
            }
        }
        for k in 0..m {
            let a = if ao_all { ao[k] } else { 1.0 };
            color[k] *= factor[k] * a;
        }
        color
    }

    /// The material at each hit and the object it belongs to: the closest
    /// object's, or with `blend` > 0 a mix following the smooth union's blend
    /// factor (the object is then the closest one). For hits of rays inside
    /// objects (`unsigned`), the object whose surface is nearest, unblended.
    fn materials(
        &mut self,
        ctx: &Ctx,
        hs: &HitSet,
        evals: &mut u64,
        unsigned: bool,
    ) -> (Vec<MaterialSample>, Vec<usize>) {
        let m = hs.idx.len();
        if m == 0 {
            return (Vec::new(), Vec::new());
        }
        let mut obj = vec![0; m];
        let mut out = vec![ctx.surfaces[0]; m];
        if let Some(objects) = &mut self.objects {
            let r = &ctx.scene.render;
            let k = if unsigned { 0.0 } else { r.blend as f32 };
            let fold = objects::Fold {
                k,
                km: k * r.material_blend as f32,
                unsigned,
            };
            *evals += objects.fold(&ctx.surfaces, fold, &hs.px, &hs.py, &hs.pz, &mut out, &mut obj);
        }
        Self::mesh_materials(ctx, hs, &mut obj, &mut out);
        self.apply_checkers(ctx, hs, &obj, &mut out);
        (out, obj)
    }

    /// Hits on meshes take the mesh's material (and its object index,
    /// after the objects').
    fn mesh_materials(ctx: &Ctx, hs: &HitSet, obj: &mut [usize], out: &mut [MaterialSample]) {
        for (q, mesh) in hs.mesh.iter().enumerate() {
            if let Some(k) = mesh {
                obj[q] = ctx.scene.objects.len() + *k as usize;
                out[q] = ctx.surfaces[obj[q]];
            }
        }
    }

    /// Objects whose material is a checker take the other material in odd cells.
    fn apply_checkers(&self, ctx: &Ctx, hs: &HitSet, obj: &[usize], out: &mut [MaterialSample]) {
        let scene = ctx.scene;
        for (q, &o) in obj.iter().enumerate() {
            let material = &scene.materials[ctx.material_of[o]];
            if let Some(other) = checker(material, Vec3::new(hs.px[q], hs.py[q], hs.pz[q])) {
                out[q] = ctx.material_surfaces[other];
            }
        }
    }

    /// Ambient occlusion by sampling the distance along the normal:
    /// ao = clamp(1 − intensity · Σᵢ wᵢ (iδ − d(p + iδn)) / (iδ), 0, 1),
    /// with weights wᵢ ∝ 2⁻ⁱ normalised to sum to 1.
    fn ambient_occlusion(&mut self, s: &isoray_scene::RenderSettings, hs: &HitSet, evals: &mut u64) -> Vec<f32> {
        let m = hs.idx.len();
        if !s.ao || s.ao_intensity == 0.0 {
            return vec![1.0; m];
        }
        let n = s.ao_samples as usize;
        let step = s.ao_step as f32;
        let (mut xs, mut ys, mut zs) = (
            Vec::with_capacity(m * n),
            Vec::with_capacity(m * n),
            Vec::with_capacity(m * n),
        );
        for i in 1..=n {
            let h = step * i as f32;
            for k in 0..m {
                xs.push(hs.px[k] + hs.nx[k] * h);
                ys.push(hs.py[k] + hs.ny[k] * h);
                zs.push(hs.pz[k] + hs.nz[k] * h);
            }
        }
        let mut ds = vec![0.0f32; m * n];
        self.scene_eval.eval(&xs, &ys, &zs, &mut ds);
        *evals += (m * n) as u64;
        let uniform = s.ao_weights == isoray_scene::AoWeights::Uniform;
        let wsum: f32 = (1..=n).map(|i| 0.5f32.powi(i as i32)).sum();
        let mut occ = vec![0.0f32; m];
        for i in 1..=n {
            let h = step * i as f32;
            let w = if uniform { 1.0 } else { 0.5f32.powi(i as i32) / wsum };
            for k in 0..m {
                occ[k] += w * (h - ds[(i - 1) * m + k]) / h;
            }
        }
        occ.iter()
            .map(|o| (1.0 - s.ao_intensity as f32 * o).clamp(0.0, 1.0))
            .collect()
    }
}

fn gradient_cost(g: GradientMode) -> u64 {
    match g {
        GradientMode::Central(_) => 6,
        GradientMode::Forward(_) | GradientMode::Tetrahedron(_) => 4,
        GradientMode::Dual => 1,
    }
}

/// Where sample (sx, sy) of the aa × aa samples of pixel (px, py) lies in
/// the pixel, in [0, 1)² (the GPU's `sample_offset` is its twin).
pub fn sample_offset(pattern: isoray_scene::AaPattern, aa: u32, sx: u32, sy: u32, px: u32, py: u32) -> (f64, f64) {
    use isoray_scene::AaPattern;
    let n = aa as f64;
    match pattern {
        AaPattern::Grid => ((sx as f64 + 0.5) / n, (sy as f64 + 0.5) / n),
        AaPattern::Rotated => (
            ((sx * aa + sy) as f64 + 0.5) / (n * n),
            ((sy * aa + aa - 1 - sx) as f64 + 0.5) / (n * n),
        ),
        AaPattern::Jittered => {
            use isoray_shade::lights::hash;
            let h1 = hash(hash(hash(px) ^ py) ^ (sy * aa + sx));
            let h2 = hash(h1);
            let unit = |h: u32| (h >> 8) as f64 / (1u32 << 24) as f64;
            ((sx as f64 + unit(h1)) / n, (sy as f64 + unit(h2)) / n)
        }
    }
}

/// The uv view's colour of a camera ray `d`: uv = (d·right, d·up) /
/// (d·fwd · tan(fov/2)) (the image plane: −1 … 1 vertically, ±aspect
/// across) as red (u/aspect) and green (v), blue 0.25, darkened on a grid
/// every 0.25 in uv, at the pixels whose centre is within `lines` of a line.
pub fn uv_colour(d: Vec3, basis: [Vec3; 3], tan: f32, aspect: f32, lines: f32) -> Vec3 {
    let [fwd, right, up] = basis;
    let z = d.dot(fwd) * tan;
    let (u, v) = (d.dot(right) / z, d.dot(up) / z);
    let c = Vec3::new(
        (0.5 + 0.5 * u / aspect).clamp(0.0, 1.0),
        (0.5 + 0.5 * v).clamp(0.0, 1.0),
        0.25,
    );
    let off = |x: f32| (4.0 * x - (4.0 * x).round()).abs();
    if off(u) < lines || off(v) < lines {
        c * 0.25
    } else {
        c
    }
}

/// A heat map from blue (0) through green and yellow to red (1).
pub fn heat(x: f32) -> Vec3 {
    let stops = [
        Vec3::new(0.0, 0.0, 0.5),
        Vec3::new(0.0, 0.3, 1.0),
        Vec3::new(0.0, 0.8, 0.2),
        Vec3::new(1.0, 0.9, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
    ];
    let x = x.clamp(0.0, 1.0) * (stops.len() - 1) as f32;
    let i = (x.floor() as usize).min(stops.len() - 2);
    stops[i].lerp(stops[i + 1], x - i as f32)
}
