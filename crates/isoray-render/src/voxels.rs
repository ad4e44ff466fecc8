//! Depth and normals by voxel rasterization with interval pruning: the
//! image fidget's `render3d` and MPR produce, on the same work.
//!
//! The view is orthographic: the image is `width × height` pixels, each a
//! column of `depth` voxels going into the screen, and a voxel (x, y, z) has
//! the *world* coordinates of fidget's convention — the image spans
//! [−1, 1] along its shorter side, y up, z towards the viewer (a larger
//! voxel index z is nearer) — mapped into the model by an affine
//! `world_to_model` transform ([`VoxelView::from_view`] builds fidget's
//! `--scale --pitch --yaw --roll` views). A pixel's depth is one more than
//! the index of the nearest voxel whose center is inside the shape (value
//! < 0), or 0 when the column is empty; its normal is the gradient there,
//! in world axes.
//!
//! Columns are not scanned voxel by voxel. The image is cut into 64 × 64
//! pixel tiles, rendered in parallel; in each, cubes of 64 voxels are
//! visited from the nearest down and bounded by interval arithmetic
//! ([`isoray_shape::interval`]) over the model-space box they map to: a cube
//! whose interval is positive is empty and skipped, a negative one is solid
//! and fills the pixels it covers at once, and an ambiguous one is split
//! into eight, down to cubes of 4³ voxels whose 64 centers are evaluated in
//! one batch. A cube behind pixels already filled nearer is skipped too.
//! Each ambiguous cube simplifies the tape it was bounded with
//! ([`isoray_shape::simplify`]): the min/max branches that cannot win in it
//! are dropped for everything evaluated inside; the leaves run their short
//! tapes in the tile's one evaluator (a simplified tape keeps its tape's
//! slots), in f32 as fidget does, and compute their normals with them too,
//! by dual numbers in f64, all the leaf's filled columns in one batch.
//!
//! ```
//! use isoray_render::voxels::{depth_normals, VoxelView};
//! use isoray_shape::ir::Builder;
//!
//! // A sphere of radius 0.5 at the origin, seen along −z.
//! let mut b = Builder::new();
//! let (x, y, z) = (b.x(), b.y(), b.z());
//! let (x2, y2, z2) = (b.mul(x, x), b.mul(y, y), b.mul(z, z));
//! let s = b.add(x2, y2);
//! let s = b.add(s, z2);
//! let r = b.sqrt(s);
//! let half = b.constant(0.5);
//! let f = b.sub(r, half);
//! let tape = b.tape(f);
//! let img = depth_normals(&tape, &[], &VoxelView::from_view(64, 64, 64, 1.0, 0.0, 0.0, 0.0));
//! // The pixel at the center sees the sphere's front, z = 0.5 (voxel 48 of 64).
//! assert_eq!(img.depth_at(32, 31), 48);
//! assert_eq!(img.depth_at(0, 0), 0);
//! ```

use isoray_shape::eval::{BatchEvaluator, DualBatch, LANES};
use isoray_shape::interval::{Choice, Interval, IntervalEvaluator};
use isoray_shape::ir::Tape;
use isoray_shape::simplify::Simplifier;
use rayon::prelude::*;

/// The image side of a tile rendered by one task.
const TILE: u32 = 64;
/// The side of the smallest cube bounded by intervals (its 4³ = 64 voxel
/// centers are one batch of the evaluator).
const LEAF: u32 = 4;

/// An orthographic voxel view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxelView {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Voxels per pixel column.
    pub depth: u32,
    /// Model coordinates of world point w: `m · (w, 1)`, rows x, y, z.
    pub world_to_model: [[f64; 4]; 3],
}

impl VoxelView {
    /// fidget's `render3d` view (isometric): model = Ry(yaw) · Rz(roll) ·
    /// Rx(pitch) · world / scale, each rotation counter-clockwise by its
    /// angle in degrees seen from the positive axis — the transform
    /// fidget's command line applies for `--scale --pitch --yaw --roll`
    /// with `--isometric`, so both render exactly the same voxels.
    pub fn from_view(width: u32, height: u32, depth: u32, scale: f64, pitch: f64, yaw: f64, roll: f64) -> VoxelView {
        let (sp, cp) = pitch.to_radians().sin_cos();
        let (sy, cy) = yaw.to_radians().sin_cos();
        let (sr, cr) = roll.to_radians().sin_cos();
        let rx = [[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]];
        let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
        let rz = [[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]];
        let r = mul3(&ry, &mul3(&rz, &rx));
        let mut m = [[0.0; 4]; 3];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().take(3).enumerate() {
                *v = r[i][j] / scale;
            }
        }
        VoxelView {
            width,
            height,
            depth,
            world_to_model: m,
        }
    }

    /// The world point of voxel coordinates (x, y, z) (continuous: voxel k
    /// spans [k, k + 1)), in fidget's convention.
    pub fn screen_to_world(&self, s: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|axis| self.screen_to_world_axis(axis, s[axis]))
    }

    /// One world coordinate (`axis` 0, 1, 2: x, y, z) of a voxel coordinate
    /// along it ([`Self::screen_to_world`] axis by axis).
    pub fn screen_to_world_axis(&self, axis: usize, s: f64) -> f64 {
        let min = self.width.min(self.height).min(self.depth) as f64;
        let k = 2.0 / min;
        match axis {
            0 => (s - self.width as f64 / 2.0) * k,
            1 => -(s - (self.height as f64 / 2.0 - 1.0)) * k,
            _ => (s - self.depth as f64 / 2.0) * k,
        }
    }

    /// The model point of voxel coordinates (x, y, z).
    pub fn screen_to_model(&self, s: [f64; 3]) -> [f64; 3] {
        self.world_to_model_point(self.screen_to_world(s))
    }

    /// The model point of world point `w`.
    pub fn world_to_model_point(&self, w: [f64; 3]) -> [f64; 3] {
        let m = &self.world_to_model;
        std::array::from_fn(|i| m[i][0] * w[0] + m[i][1] * w[1] + m[i][2] * w[2] + m[i][3])
    }

    /// The model-space bounds of the voxel box [s0, s1] (per axis).
    fn model_box(&self, s0: [f64; 3], s1: [f64; 3]) -> [Interval; 3] {
        let (w0, w1) = (self.screen_to_world(s0), self.screen_to_world(s1));
        let m = &self.world_to_model;
        std::array::from_fn(|i| {
            let mut lo = m[i][3];
            let mut hi = m[i][3];
            for j in 0..3 {
                let (a, b) = (m[i][j] * w0[j], m[i][j] * w1[j]);
                lo += a.min(b);
                hi += a.max(b);
            }
            // Widened for rounding: the box must contain every voxel center.
            let pad = 1e-9 * (1.0 + lo.abs().max(hi.abs()));
            Interval::new(lo - pad, hi + pad)
        })
    }
}

fn mul3(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// A depth and normal image.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthNormals {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Voxels per column.
    pub depth: u32,
    /// Per pixel (row-major, top row first): one more than the nearest
    /// filled voxel's index, 0 for none.
    pub depths: Vec<u32>,
    /// Per pixel: the unit gradient in world axes at that voxel's center
    /// (zero where the depth is 0 or the gradient vanishes).
    pub normals: Vec<[f32; 3]>,
}

impl DepthNormals {
    /// The depth of pixel (x, y).
    pub fn depth_at(&self, x: u32, y: u32) -> u32 {
        self.depths[(y * self.width + x) as usize]
    }

    /// The depth as 8-bit gray (nearer is brighter; empty is black).
    pub fn depth_image(&self) -> Vec<u8> {
        self.depths
            .iter()
            .map(|&d| (d as u64 * 255 / self.depth.max(1) as u64) as u8)
            .collect()
    }

    /// The normals as 8-bit RGB (each component mapped from [−1, 1] to
    /// [0, 255]; empty pixels black).
    pub fn normal_image(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.normals.len() * 3);
        for (n, &d) in self.normals.iter().zip(&self.depths) {
            for c in n {
                out.push(if d == 0 {
                    0
                } else {
                    ((c + 1.0) * 127.5).round().clamp(0.0, 255.0) as u8
                });
            }
        }
        out
    }
}

/// Renders depth and normals of `tape` (with the inputs `vars`) in `view`,
/// on rayon's threads.
pub fn depth_normals(tape: &Tape, vars: &[f64], view: &VoxelView) -> DepthNormals {
    let (w, h) = (view.width, view.height);
    let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    let rendered: Vec<TileOutput> = tiles
        .par_iter()
        .map(|&(x0, y0)| {
            let mut t = TileRender::new(tape, vars, view, x0, y0);
            t.render();
            let normals = t.normals();
            (x0, y0, t.depths, normals)
        })
        .collect();
    let mut depths = vec![0u32; (w * h) as usize];
    let mut normals = vec![[0.0f32; 3]; (w * h) as usize];
    for (x0, y0, d, n) in rendered {
        for j in 0..TILE.min(h - y0) {
            for i in 0..TILE.min(w - x0) {
                let k = ((y0 + j) * w + x0 + i) as usize;
                let t = (j * TILE + i) as usize;
                depths[k] = d[t];
                normals[k] = n[t];
            }
        }
    }
    DepthNormals {
        width: w,
        height: h,
        depth: view.depth,
        depths,
        normals,
    }
}

/// A rendered tile: its corner pixel, depths and normals (TILE × TILE).
type TileOutput = (u32, u32, Vec<u32>, Vec<[f32; 3]>);

/// One tile's rendering state.
struct TileRender<'a> {
    tape: &'a Tape,
    vars: &'a [f64],
    view: &'a VoxelView,
    x0: u32,
    y0: u32,
    /// The tile's pixels that lie in the image.
    w: u32,
    h: u32,
    /// TILE × TILE depths.
    depths: Vec<u32>,
    /// Runs the leaves' simplified tapes (`eval_variant`), in f32.
    eval: BatchEvaluator<'a, f32>,
    /// TILE × TILE normals, and whether each was computed (in a leaf, with
    /// its short tape).
    normals: Vec<[f32; 3]>,
    has_normal: Vec<bool>,
    /// Bounds the cubes (the full tape or a simplified one).
    intervals: IntervalEvaluator<'a>,
    /// Normals by dual numbers (the leaves' short tapes, or the full tape).
    dual: DualBatch<'a>,
    /// Simplifies the tape per ambiguous cube (its buffers reused).
    simplifier: Simplifier,
    /// Scratch: the min/max choices of the last interval evaluation.
    choices: Vec<Choice>,
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    /// The leaf's points in f32 (evaluated in f32, as fidget does) and
    /// their values.
    xf: Vec<f32>,
    yf: Vec<f32>,
    zf: Vec<f32>,
    out: Vec<f32>,
}

impl<'a> TileRender<'a> {
    fn new(tape: &'a Tape, vars: &'a [f64], view: &'a VoxelView, x0: u32, y0: u32) -> Self {
        TileRender {
            tape,
            vars,
            view,
            x0,
            y0,
            w: TILE.min(view.width - x0),
            h: TILE.min(view.height - y0),
            depths: vec![0; (TILE * TILE) as usize],
            eval: BatchEvaluator::new(tape),
            normals: vec![[0.0; 3]; (TILE * TILE) as usize],
            has_normal: vec![false; (TILE * TILE) as usize],
            intervals: IntervalEvaluator::new(tape, vars),
            dual: DualBatch::new(tape),
            simplifier: Simplifier::default(),
            choices: Vec::new(),
            xs: vec![0.0; LANES],
            ys: vec![0.0; LANES],
            zs: vec![0.0; LANES],
            xf: vec![0.0; LANES],
            yf: vec![0.0; LANES],
            zf: vec![0.0; LANES],
            out: vec![0.0; LANES],
        }
    }

    fn render(&mut self) {
        // Cubes of TILE voxels along the column, nearest first.
        let mut z = self.view.depth;
        while z > 0 {
            let size = TILE.min(z);
            // The lowest cube of a column whose depth is not a multiple of
            // TILE starts at 0 and reaches above the one before it: its
            // voxels above the view are skipped (see `ambiguous`, `leaf`).
            let tape = self.tape;
            self.cube(tape, 0, 0, z - size, TILE);
            z -= size;
        }
    }

    /// Cube of side `size` at tile-relative pixel (i, j) and voxel layer z,
    /// `tape` the shape's tape simplified for a box around it.
    fn cube(&mut self, tape: &Tape, i: u32, j: u32, z: u32, size: u32) {
        if !self.ambiguous(tape, i, j, z, size) {
            return;
        }
        // The branches that cannot win in this cube are dropped for all
        // that is evaluated inside it.
        let simplified = self.simplifier.simplify(tape, &self.choices);
        let tape = simplified.as_ref().unwrap_or(tape);
        let s = size / 2;
        let children = [s, 0].into_iter().flat_map(|dz| {
            [0, s]
                .into_iter()
                .flat_map(move |dj| [0, s].into_iter().map(move |di| (di, dj, dz)))
        });
        if s > LEAF {
            for (di, dj, dz) in children {
                self.cube(tape, i + di, j + dj, z + dz, s);
            }
            return;
        }
        for (di, dj, dz) in children {
            if self.ambiguous(tape, i + di, j + dj, z + dz, s) {
                self.leaf(tape, i + di, j + dj, z + dz, s);
            }
        }
    }

    /// Whether the cube needs a closer look: false when it is outside the
    /// image, hidden behind pixels filled nearer, empty, or solid (then its
    /// pixels are filled here). Records the min/max choices of `tape` over it.
    fn ambiguous(&mut self, tape: &Tape, i: u32, j: u32, z: u32, size: u32) -> bool {
        // Voxels above the view (in the lowest cube of a column whose depth
        // is not a multiple of TILE) are not part of it.
        let top = (z + size).min(self.view.depth); // depth value a filled top voxel gives
        if i >= self.w || j >= self.h || z >= top {
            return false;
        }
        let (iw, jh) = (size.min(self.w - i), size.min(self.h - j));
        if (j..j + jh).all(|jj| (i..i + iw).all(|ii| self.depths[(jj * TILE + ii) as usize] >= top)) {
            return false;
        }
        let (sx, sy) = ((self.x0 + i) as f64, (self.y0 + j) as f64);
        // The voxel centers of the cube span [k + 0.5, k + size − 0.5] (up to top − 0.5).
        let b = self.view.model_box(
            [sx + 0.5, sy + 0.5, z as f64 + 0.5],
            [sx + size as f64 - 0.5, sy + size as f64 - 0.5, (top - 1) as f64 + 0.5],
        );
        let v = self.intervals.eval(tape, b, Some(&mut self.choices));
        if v.lo > 0.0 {
            return false;
        }
        if v.hi < 0.0 {
            for jj in j..j + jh {
                for ii in i..i + iw {
                    let d = &mut self.depths[(jj * TILE + ii) as usize];
                    *d = (*d).max(top);
                }
            }
            return false;
        }
        true
    }

    /// Evaluates the voxel centers of a leaf cube in one batch and sets the
    /// depth of each column from its nearest filled voxel.
    fn leaf(&mut self, tape: &Tape, i: u32, j: u32, z: u32, size: u32) {
        let n = (size * size * size) as usize;
        debug_assert!(n <= LANES && size <= LEAF);
        // The voxel centers in model space: m·w + t summed as
        // `world_to_model_point` sums it, ((m₀·w₀ + m₁·w₁) + m₂·w₂) + t, from
        // the products of each axis's four world coordinates (the same
        // numbers, without a product per voxel).
        let base = [self.x0 + i, self.y0 + j, z];
        let m = &self.view.world_to_model;
        let term: [[[f64; 3]; LEAF as usize]; 3] = std::array::from_fn(|a| {
            std::array::from_fn(|d| {
                let w = self.view.screen_to_world_axis(a, (base[a] + d as u32) as f64 + 0.5);
                std::array::from_fn(|r| m[r][a] * w)
            })
        });
        let mut k = 0;
        for tz in &term[2][..size as usize] {
            for ty in &term[1][..size as usize] {
                for tx in &term[0][..size as usize] {
                    let p: [f64; 3] = std::array::from_fn(|r| ((tx[r] + ty[r]) + tz[r]) + m[r][3]);
                    self.xs[k] = p[0];
                    self.ys[k] = p[1];
                    self.zs[k] = p[2];
                    (self.xf[k], self.yf[k], self.zf[k]) = (p[0] as f32, p[1] as f32, p[2] as f32);
                    k += 1;
                }
            }
        }
        // The short tape runs in the tile's evaluator (it keeps the slots).
        self.eval.eval_variant(
            tape,
            self.vars,
            &self.xf[..n],
            &self.yf[..n],
            &self.zf[..n],
            &mut self.out[..n],
        );
        // Columns whose depth this leaf sets, and their voxels (the batch index).
        let mut set: Vec<(usize, usize)> = Vec::new();
        for dj in 0..size {
            for di in 0..size {
                if i + di >= self.w || j + dj >= self.h {
                    continue;
                }
                let k = ((j + dj) * TILE + i + di) as usize;
                for dz in (0..size).rev().filter(|dz| z + dz < self.view.depth) {
                    if z + dz < self.depths[k] {
                        break;
                    }
                    let b = ((dz * size + dj) * size + di) as usize;
                    if self.out[b] < 0.0 {
                        self.depths[k] = z + dz + 1;
                        set.push((k, b));
                        break;
                    }
                }
            }
        }
        // Their normals, with this leaf's short tape (a depth found
        // front to back is final).
        if set.is_empty() {
            return;
        }
        let n = set.len();
        let (mut px, mut py, mut pz) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for (c, &(_, b)) in set.iter().enumerate() {
            (px[c], py[c], pz[c]) = (self.xs[b], self.ys[b], self.zs[b]);
        }
        let mut g = vec![[0.0; 3]; n];
        self.dual.gradients(tape, self.vars, &px, &py, &pz, &mut g);
        for (c, &(k, _)) in set.iter().enumerate() {
            self.normals[k] = world_normal(&self.view.world_to_model, g[c]);
            self.has_normal[k] = true;
        }
    }

    /// The unit gradients in world axes at the filled voxels: those the
    /// leaves did not compute (pixels filled by a solid cube) with the full
    /// tape.
    fn normals(&mut self) -> Vec<[f32; 3]> {
        let mut out = std::mem::take(&mut self.normals);
        let filled: Vec<usize> = (0..out.len())
            .filter(|&k| self.depths[k] > 0 && !self.has_normal[k])
            .collect();
        for chunk in filled.chunks(LANES) {
            for (c, &k) in chunk.iter().enumerate() {
                let (i, j) = (k as u32 % TILE, k as u32 / TILE);
                let p = self.view.screen_to_model([
                    (self.x0 + i) as f64 + 0.5,
                    (self.y0 + j) as f64 + 0.5,
                    (self.depths[k] - 1) as f64 + 0.5,
                ]);
                self.xs[c] = p[0];
                self.ys[c] = p[1];
                self.zs[c] = p[2];
            }
            let n = chunk.len();
            let mut g = vec![[0.0; 3]; n];
            let tape = self.tape;
            self.dual
                .gradients(tape, self.vars, &self.xs[..n], &self.ys[..n], &self.zs[..n], &mut g);
            for (c, &k) in chunk.iter().enumerate() {
                out[k] = world_normal(&self.view.world_to_model, g[c]);
            }
        }
        out
    }
}

/// The unit normal in world axes of model gradient g: ∇_world f = Mᵀ ∇_model f
/// (M the linear part of world → model); zero where it vanishes.
fn world_normal(m: &[[f64; 4]; 3], g: [f64; 3]) -> [f32; 3] {
    let wv: [f64; 3] = std::array::from_fn(|a| (0..3).map(|r| m[r][a] * g[r]).sum());
    let len = (wv[0] * wv[0] + wv[1] * wv[1] + wv[2] * wv[2]).sqrt();
    if len > 0.0 && len.is_finite() {
        [(wv[0] / len) as f32, (wv[1] / len) as f32, (wv[2] / len) as f32]
    } else {
        [0.0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use isoray_shape::ir::Builder;

    fn sphere(r: f64) -> Tape {
        let mut b = Builder::new();
        let (x, y, z) = (b.x(), b.y(), b.z());
        let (x2, y2, z2) = (b.mul(x, x), b.mul(y, y), b.mul(z, z));
        let s = b.add(x2, y2);
        let s = b.add(s, z2);
        let l = b.sqrt(s);
        let c = b.constant(r);
        let f = b.sub(l, c);
        b.tape(f)
    }

    /// The depth of every pixel equals a voxel-by-voxel scan of its column.
    #[test]
    fn pruning_gives_the_brute_force_depths() {
        let tape = sphere(0.6);
        for view in [
            VoxelView::from_view(70, 50, 40, 1.0, 0.0, 0.0, 0.0),
            VoxelView::from_view(33, 65, 90, 1.3, 20.0, -30.0, 45.0),
        ] {
            let img = depth_normals(&tape, &[], &view);
            let mut e = isoray_shape::PointEvaluator::<f32>::new(&tape);
            for y in 0..view.height {
                for x in 0..view.width {
                    let want = (0..view.depth)
                        .rev()
                        .find(|&z| {
                            let p = view.screen_to_model([x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5]);
                            e.eval(&[], p[0] as f32, p[1] as f32, p[2] as f32) < 0.0
                        })
                        .map_or(0, |z| z + 1);
                    assert_eq!(img.depth_at(x, y), want, "pixel ({x}, {y}) of {view:?}");
                }
            }
        }
    }

    /// A shape that fills the whole view gives every column the view's
    /// depth, also when the depth is not a multiple of the cube size.
    #[test]
    fn depths_stay_within_the_view() {
        let mut b = Builder::new();
        let one = b.constant(-1.0);
        let tape = b.tape(one);
        let img = depth_normals(&tape, &[], &VoxelView::from_view(20, 20, 40, 1.0, 0.0, 0.0, 0.0));
        assert!(img.depths.iter().all(|&d| d == 40), "{:?}", &img.depths[..5]);
    }

    /// A sphere's normals point away from its center, towards the viewer.
    #[test]
    fn sphere_normals_are_radial() {
        let view = VoxelView::from_view(64, 64, 64, 1.0, 0.0, 0.0, 0.0);
        let img = depth_normals(&sphere(0.5), &[], &view);
        let n = img.normals[(31 * 64 + 32) as usize];
        assert!(n[2] > 0.99, "{n:?}");
        for (k, &d) in img.depths.iter().enumerate() {
            if d == 0 {
                continue;
            }
            let (x, y) = ((k % 64) as f64 + 0.5, (k / 64) as f64 + 0.5);
            let w = view.screen_to_world([x, y, d as f64 - 0.5]);
            let len = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            let n = img.normals[k];
            let dot = (n[0] as f64 * w[0] + n[1] as f64 * w[1] + n[2] as f64 * w[2]) / len;
            assert!(dot > 0.999, "pixel {k}: normal {n:?} at {w:?}");
        }
    }
}
