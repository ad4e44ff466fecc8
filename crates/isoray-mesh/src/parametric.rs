//! Tessellation of parametric surfaces over their (s, t) domain.
//!
//! [`tessellate`] turns the coordinate functions of a parametric surface
//! ([`ParametricCoords`], from [`Library::parametric_coords`]) into a grid
//! mesh whose texture coordinates are the parameters (s, t):
//!
//! 1. The domain is cut into a base grid of [`TessellationSettings::initial`]
//!    cells. A cell is split into four (a quadtree) while the surface leaves
//!    its piecewise-linear approximation by more than the tolerance — the
//!    chord error, measured at the midpoints of the cell's edges (against the
//!    average of the edge's two corners) and at its centre (against the
//!    average of the four corners, and against the midpoint of the diagonal
//!    the cell would be cut along) — or while the normals at its corners
//!    differ by more than [`TessellationSettings::max_angle_deg`], or while
//!    a side of the cell is longer in space than
//!    [`TessellationSettings::max_edge`], up to
//!    [`TessellationSettings::max_depth`] levels. A cell where the surface is
//!    finite at some but not all of those nine points is split too, so that
//!    the hole left where it is not finite hugs that region.
//! 2. The quadtree is balanced: neighbouring leaves (across an edge) differ
//!    by at most one level.
//! 3. Each leaf becomes two triangles cut along its shorter diagonal (in
//!    space) or, when a finer neighbour puts a vertex in the middle of one of
//!    its edges (a hanging vertex), a fan of triangles from its centre
//!    through every such vertex. Every shared edge is thus split the same way
//!    on both sides and the mesh has no cracks. Vertices are keyed by their
//!    integer (s, t) lattice coordinates at the finest level, so cells that
//!    share a vertex share its index.
//!
//! Vertices carry uv = (s, t) and the unit normal (∂P/∂s × ∂P/∂t)/|…|,
//! computed exactly with dual numbers; triangles wind counter-clockwise in
//! (s, t), so their normals agree with the vertex normals wherever the mesh
//! resolves the surface (a parametrization with ∂s × ∂t pointing inwards
//! gives an inward-wound mesh). Where the cross
//! product vanishes (a pole, where a whole edge of the domain maps to one
//! point), the normal is the exact one at a point nudged slightly into the
//! domain (towards its centre), which gives the limit normal at poles; where
//! that also vanishes, the area-weighted average of the normals of the
//! vertex's triangles, and `[0, 0, 0]` for a vertex without triangles.
//!
//! Triangles of (near) zero area, such as those with two corners at a pole,
//! are dropped, but the vertices keep their own (s, t): a seam or a pole is
//! not welded. Triangles with a corner where the coordinates are not finite
//! are skipped and counted in [`TessellationStats::skipped_triangles`].
//!
//! Samples are evaluated in parallel, and the result does not depend on the
//! number of threads: the same input gives the same mesh, bit for bit.
//!
//! ```
//! use std::f64::consts::{FRAC_PI_2, PI};
//! use isoray_mesh::parametric::{tessellate, TessellationSettings};
//! use isoray_shape::surface::SurfaceOptions;
//! use isoray_shape::Library;
//!
//! let mut lib = Library::new();
//! lib.add_parametric_surface(
//!     "globe",
//!     vec![],
//!     [("cos(t) * cos(s)", 0), ("cos(t) * sin(s)", 1), ("sin(t)", 2)],
//!     [[0.0, 2.0 * PI], [-FRAC_PI_2, FRAC_PI_2]],
//!     SurfaceOptions::default(),
//! )
//! .unwrap();
//! let coords = lib.parametric_coords("globe", None).unwrap();
//! let (mesh, stats) = tessellate(&coords, &TessellationSettings::default()).unwrap();
//! assert_eq!(mesh.triangle_count(), stats.triangles);
//! assert!((mesh.area() - 4.0 * PI).abs() < 0.01 * 4.0 * PI);
//! // uv = (s, t): the vertex at s = 0, t = 0 is the point (1, 0, 0), with the outward normal.
//! let i = mesh.uvs.iter().position(|uv| *uv == [0.0, 0.0]).unwrap();
//! assert_eq!(mesh.positions[i], [1.0, 0.0, 0.0]);
//! assert!((mesh.normals[i][0] - 1.0).abs() < 1e-6);
//! ```
//!
//! [`Library::parametric_coords`]: isoray_shape::Library::parametric_coords

use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

use isoray_shape::surface::ParametricCoords;
use isoray_shape::{Dual, PointEvaluator};
use rayon::prelude::*;

use crate::mesh::{cross, dot, norm, sub, Mesh};

/// How finely [`tessellate`] cuts a parametric surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TessellationSettings {
    /// Cells of the base grid along s and t (each at least 1).
    pub initial: [u32; 2],
    /// The most times a base cell is split in four (0: the base grid only).
    pub max_depth: u32,
    /// The largest chord error allowed, in world units: the distance between
    /// the surface and its piecewise-linear approximation at the midpoints of
    /// a cell's edges and at its centre. `None`: 10⁻³ times the diagonal of
    /// the bounding box of the base grid's samples.
    pub tolerance: Option<f64>,
    /// The largest angle, in degrees, between the normals at a cell's
    /// corners (180 or more turns the test off).
    pub max_angle_deg: f64,
    /// The longest a cell's side may be in space, in world units, where the
    /// parametrization stretches the domain. `None`: 1/20 of the diagonal of
    /// the bounding box of the base grid's samples.
    pub max_edge: Option<f64>,
}

impl Default for TessellationSettings {
    /// A 16 × 16 base grid, up to 6 levels of refinement, the tolerance
    /// derived from the surface's size, and 15° between normals.
    fn default() -> Self {
        TessellationSettings {
            initial: [16, 16],
            max_depth: 6,
            tolerance: None,
            max_angle_deg: 15.0,
            max_edge: None,
        }
    }
}

/// What [`tessellate`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TessellationStats {
    /// Triangles in the mesh.
    pub triangles: usize,
    /// Vertices in the mesh.
    pub vertices: usize,
    /// Leaf cells of the quadtree.
    pub leaves: usize,
    /// Leaf cells at each depth (index 0: base cells never split).
    pub leaves_per_depth: Vec<usize>,
    /// The deepest leaf's depth.
    pub max_depth_reached: u32,
    /// The chord tolerance used, in world units (given or derived).
    pub tolerance: f64,
    /// Points of the domain where the surface was evaluated.
    pub samples: usize,
    /// Triangles left out because a corner is not finite.
    pub skipped_triangles: usize,
    /// Triangles dropped because their area is (nearly) zero, e.g. at a pole.
    pub degenerate_triangles: usize,
    /// Vertices whose normal came from a nudged point or from their
    /// triangles because ∂P/∂s × ∂P/∂t vanishes there.
    pub fallback_normals: usize,
    /// Vertices left with the normal `[0, 0, 0]` (no fallback worked).
    pub missing_normals: usize,
}

/// Why a parametric surface could not be tessellated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TessellateError {
    /// The domain has no interior or a bound is not finite.
    #[error("the parameter domain of surface `{name}` is empty or not finite: s in [{}, {}], t in [{}, {}]", .domain[0][0], .domain[0][1], .domain[1][0], .domain[1][1])]
    EmptyDomain {
        /// The surface.
        name: String,
        /// Its domain.
        domain: [[f64; 2]; 2],
    },
    /// The coordinates are not finite at any point of the base grid.
    #[error("surface `{name}` is not finite at any sampled point of its domain")]
    NotFinite {
        /// The surface.
        name: String,
    },
    /// A setting is out of range.
    #[error("invalid tessellation settings: {0}")]
    InvalidSettings(String),
}

/// The finest lattice may have at most this many points along an axis.
const MAX_LATTICE: u64 = 1 << 31;

/// Chord tolerance relative to the bounding-box diagonal when none is given.
const DEFAULT_RELATIVE_TOLERANCE: f64 = 1e-3;
/// Longest cell side relative to the bounding-box diagonal when none is given.
const DEFAULT_RELATIVE_EDGE: f64 = 0.05;

/// ∂P/∂s × ∂P/∂t counts as zero below this times |∂P/∂s|² + |∂P/∂t|².
const DEGENERATE_JACOBIAN: f64 = 1e-12;

/// The nudge of the normal fallback, as a fraction of the finest lattice step.
const NUDGE: f64 = 1e-3;

/// A triangle is dropped when its area is below this times its longest edge squared.
const DEGENERATE_AREA: f64 = 1e-10;

/// A fast hasher for lattice keys and cells (the maps are only looked up,
/// never iterated in an order that matters, so the output stays deterministic).
#[derive(Debug, Clone, Copy, Default)]
struct MixHasher(u64);

impl Hasher for MixHasher {
    fn finish(&self) -> u64 {
        // The splitmix64 finalizer.
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_u32(&mut self, v: u32) {
        self.write_u64(v as u64);
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0 ^ v).wrapping_mul(0x9e37_79b9_7f4a_7c15).rotate_left(29);
    }
}

type FastMap<K, V> = HashMap<K, V, BuildHasherDefault<MixHasher>>;
type FastSet<K> = HashSet<K, BuildHasherDefault<MixHasher>>;

/// A quadtree cell: (depth, index along s, index along t) at that depth.
type Cell = (u32, u32, u32);

/// A lattice point packed as (j << 32) | i: sorting orders by t, then s.
type Key = u64;

fn key(i: u32, j: u32) -> Key {
    ((j as u64) << 32) | i as u64
}

fn unkey(k: Key) -> (u32, u32) {
    (k as u32, (k >> 32) as u32)
}

/// The surface at one lattice point.
#[derive(Debug, Clone, Copy)]
struct Sample {
    p: [f64; 3],
    /// The unit normal (None where it vanishes or the point is not finite).
    n: Option<[f64; 3]>,
    /// The normal comes from a nudged point.
    nudged: bool,
}

impl Sample {
    fn finite(&self) -> bool {
        self.p.iter().all(|v| v.is_finite())
    }
}

/// The finest lattice over the domain.
struct Grid {
    domain: [[f64; 2]; 2],
    /// Lattice intervals along s and t.
    n: [u64; 2],
    /// The deepest level.
    depth: u32,
    /// Base cells along s and t.
    base: [u32; 2],
}

impl Grid {
    /// The parameter value of lattice coordinate `i` along `axis`.
    fn param(&self, i: u32, axis: usize) -> f64 {
        let [lo, hi] = self.domain[axis];
        let n = self.n[axis];
        if i == 0 {
            lo
        } else if i as u64 == n {
            hi
        } else {
            lo + (hi - lo) * (i as f64 / n as f64)
        }
    }

    /// The lattice corner (i0, j0) and lattice size of a cell.
    fn cell(&self, c: Cell) -> (u32, u32, u32) {
        let h = 1u32 << (self.depth - c.0);
        (c.1 * h, c.2 * h, h)
    }

    /// Cells along s and t at a level.
    fn cells_at(&self, level: u32) -> (u32, u32) {
        (self.base[0] << level, self.base[1] << level)
    }

    /// The 3 × 3 lattice points of a cell (corners, edge midpoints, centre),
    /// row by row from (s_min, t_min). Needs the cell's level below the depth.
    fn nine(&self, c: Cell) -> [Key; 9] {
        let (i0, j0, h) = self.cell(c);
        let h2 = h / 2;
        std::array::from_fn(|k| key(i0 + (k % 3) as u32 * h2, j0 + (k / 3) as u32 * h2))
    }
}

/// Three dual-number evaluators, one per coordinate.
struct Evaluator<'a> {
    e: [PointEvaluator<'a, Dual>; 3],
}

impl<'a> Evaluator<'a> {
    fn new(coords: &'a ParametricCoords) -> Self {
        Evaluator {
            e: coords.coords.each_ref().map(PointEvaluator::new),
        }
    }

    /// The point and its exact derivatives along s and t.
    fn at(&mut self, s: f64, t: f64) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let (mut p, mut ds, mut dt) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        for (k, e) in self.e.iter_mut().enumerate() {
            let v = e.eval(
                &[],
                Dual {
                    v: s,
                    d: [1.0, 0.0, 0.0],
                },
                Dual {
                    v: t,
                    d: [0.0, 1.0, 0.0],
                },
                Dual { v: 0.0, d: [0.0; 3] },
            );
            p[k] = v.v;
            ds[k] = v.d[0];
            dt[k] = v.d[1];
        }
        (p, ds, dt)
    }
}

/// The unit normal ∂s × ∂t, or None where it vanishes or is not finite.
fn unit_normal(ds: [f64; 3], dt: [f64; 3]) -> Option<[f64; 3]> {
    let c = cross(ds, dt);
    let l = norm(c);
    let scale = dot(ds, ds) + dot(dt, dt);
    (l.is_finite() && scale.is_finite() && l > 0.0 && l > DEGENERATE_JACOBIAN * scale).then(|| c.map(|v| v / l))
}

fn sample(ev: &mut Evaluator, grid: &Grid, k: Key) -> Sample {
    let (i, j) = unkey(k);
    let (s, t) = (grid.param(i, 0), grid.param(j, 1));
    let (p, ds, dt) = ev.at(s, t);
    let mut out = Sample {
        p,
        n: None,
        nudged: false,
    };
    if !out.finite() {
        return out;
    }
    out.n = unit_normal(ds, dt);
    if out.n.is_none() {
        // Step a little into the domain, towards its centre.
        let toward = |x: f64, axis: usize| {
            let [lo, hi] = grid.domain[axis];
            let step = NUDGE * (hi - lo) / grid.n[axis] as f64;
            if x <= 0.5 * (lo + hi) {
                x + step
            } else {
                x - step
            }
        };
        let (q, ds, dt) = ev.at(toward(s, 0), toward(t, 1));
        if q.iter().all(|v| v.is_finite()) {
            out.n = unit_normal(ds, dt);
            out.nudged = out.n.is_some();
        }
    }
    out
}

/// The samples evaluated so far, by lattice point.
struct Samples<'a> {
    coords: &'a ParametricCoords,
    map: FastMap<Key, Sample>,
}

impl Samples<'_> {
    /// Evaluates the points of `keys` not yet known (in parallel).
    fn ensure(&mut self, grid: &Grid, mut keys: Vec<Key>) {
        keys.sort_unstable();
        keys.dedup();
        keys.retain(|k| !self.map.contains_key(k));
        let coords = self.coords;
        let values: Vec<Vec<Sample>> = keys
            .par_chunks(256)
            .map(|chunk| {
                let mut ev = Evaluator::new(coords);
                chunk.iter().map(|&k| sample(&mut ev, grid, k)).collect()
            })
            .collect();
        self.map.reserve(keys.len());
        for (k, v) in keys.into_iter().zip(values.into_iter().flatten()) {
            self.map.insert(k, v);
        }
    }

    fn get(&self, k: Key) -> &Sample {
        &self.map[&k]
    }
}

fn mid(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])]
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(sub(a, b))
}

/// True when the diagonal from corner (0, 0) to (1, 1) is not longer than
/// the other one (the one a two-triangle cell is cut along).
fn first_diagonal(c00: [f64; 3], c10: [f64; 3], c11: [f64; 3], c01: [f64; 3]) -> bool {
    let a = dist(c00, c11);
    let b = dist(c10, c01);
    // A diagonal with a non-finite end loses; ties take the first.
    !(b < a || a.is_nan())
}

/// Whether a cell's chord error or normal spread calls for a split.
fn needs_split(samples: &Samples, grid: &Grid, c: Cell, tol: f64, cos_max: f64, max_edge: f64) -> bool {
    let s = grid.nine(c).map(|k| *samples.get(k));
    let finite = s.iter().filter(|x| x.finite()).count();
    if finite == 0 {
        return false;
    }
    if finite < 9 {
        return true;
    }
    let p = s.map(|x| x.p);
    let (c00, c10, c01, c11) = (p[0], p[2], p[6], p[8]);
    let diag = if first_diagonal(c00, c10, c11, c01) {
        mid(c00, c11)
    } else {
        mid(c10, c01)
    };
    let bilinear = mid(mid(c00, c11), mid(c10, c01));
    let err = [
        dist(p[1], mid(c00, c10)),
        dist(p[5], mid(c10, c11)),
        dist(p[7], mid(c01, c11)),
        dist(p[3], mid(c00, c01)),
        dist(p[4], bilinear),
        dist(p[4], diag),
    ];
    if err.iter().any(|&e| e > tol) {
        return true;
    }
    // Samples too far apart in space.
    if [(c00, c10), (c10, c11), (c11, c01), (c01, c00)]
        .iter()
        .any(|&(a, b)| dist(a, b) > max_edge)
    {
        return true;
    }
    let normals: Vec<[f64; 3]> = [s[0], s[2], s[8], s[6]].iter().filter_map(|x| x.n).collect();
    for a in 0..normals.len() {
        for b in a + 1..normals.len() {
            if dot(normals[a], normals[b]) < cos_max {
                return true;
            }
        }
    }
    false
}

/// Splits `c` (and, first, any of its ancestors that is not split yet),
/// queueing each newly split cell.
fn force_split(c: Cell, split: &mut FastSet<Cell>, work: &mut Vec<Cell>) {
    if split.contains(&c) {
        return;
    }
    if c.0 > 0 {
        force_split((c.0 - 1, c.1 / 2, c.2 / 2), split, work);
    }
    split.insert(c);
    work.push(c);
}

/// The same-level neighbours of a cell across its edges, inside the domain:
/// below (t−), right (s+), above (t+), left (s−).
fn neighbours(grid: &Grid, c: Cell) -> [Option<Cell>; 4] {
    let (ns, nt) = grid.cells_at(c.0);
    let (l, i, j) = c;
    [
        (j > 0).then(|| (l, i, j - 1)),
        (i + 1 < ns).then_some((l, i + 1, j)),
        (j + 1 < nt).then_some((l, i, j + 1)),
        (i > 0).then(|| (l, i - 1, j)),
    ]
}

/// Balances the quadtree: after this, leaves that share an edge differ by at
/// most one level. A split cell at level L ≥ 1 needs its same-level
/// neighbours to exist, i.e. their parents to be split.
fn balance(grid: &Grid, split: &mut FastSet<Cell>) {
    let mut work: Vec<Cell> = split.iter().copied().collect();
    work.sort_unstable();
    while let Some(x) = work.pop() {
        if x.0 == 0 {
            continue;
        }
        for n in neighbours(grid, x).into_iter().flatten() {
            force_split((n.0 - 1, n.1 / 2, n.2 / 2), split, &mut work);
        }
    }
}

fn children(c: Cell) -> [Cell; 4] {
    let (l, i, j) = c;
    [
        (l + 1, 2 * i, 2 * j),
        (l + 1, 2 * i + 1, 2 * j),
        (l + 1, 2 * i, 2 * j + 1),
        (l + 1, 2 * i + 1, 2 * j + 1),
    ]
}

/// The leaves, depth first from the base cells in (t, s) order.
fn leaves(grid: &Grid, split: &FastSet<Cell>) -> Vec<Cell> {
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for j in 0..grid.base[1] {
        for i in 0..grid.base[0] {
            stack.push((0, i, j));
            while let Some(c) = stack.pop() {
                if split.contains(&c) {
                    stack.extend(children(c).into_iter().rev());
                } else {
                    out.push(c);
                }
            }
        }
    }
    out
}

/// A cell's corners, counter-clockwise in (s, t) from (s_min, t_min).
fn corner_keys(i0: u32, j0: u32, h: u32) -> [Key; 4] {
    [key(i0, j0), key(i0 + h, j0), key(i0 + h, j0 + h), key(i0, j0 + h)]
}

/// The midpoints of a cell's edges, in the order of [`neighbours`].
fn mid_keys(i0: u32, j0: u32, h: u32) -> [Key; 4] {
    let h2 = h / 2;
    [
        key(i0 + h2, j0),
        key(i0 + h, j0 + h2),
        key(i0 + h2, j0 + h),
        key(i0, j0 + h2),
    ]
}

/// Which edges of a leaf carry a hanging vertex: those whose same-level
/// neighbour is split (and then, the tree being balanced, has leaves one
/// level finer along the edge).
fn hanging_edges(grid: &Grid, split: &FastSet<Cell>, c: Cell) -> [bool; 4] {
    neighbours(grid, c).map(|n| n.is_some_and(|n| split.contains(&n)))
}

/// Appends the triangles of a leaf as lattice keys, counter-clockwise in (s, t).
fn triangulate(grid: &Grid, split: &FastSet<Cell>, samples: &Samples, c: Cell, out: &mut Vec<[Key; 3]>) {
    let (i0, j0, h) = grid.cell(c);
    let corners = corner_keys(i0, j0, h);
    let [c00, c10, c11, c01] = corners;
    let hanging = hanging_edges(grid, split, c);
    if !hanging.iter().any(|&x| x) {
        let p = |k| samples.get(k).p;
        if first_diagonal(p(c00), p(c10), p(c11), p(c01)) {
            out.push([c00, c10, c11]);
            out.push([c00, c11, c01]);
        } else {
            out.push([c00, c10, c01]);
            out.push([c10, c11, c01]);
        }
        return;
    }
    // A fan from the centre through the corners and the hanging vertices.
    let mids = mid_keys(i0, j0, h);
    let mut ring = Vec::with_capacity(8);
    for e in 0..4 {
        ring.push(corners[e]);
        if hanging[e] {
            ring.push(mids[e]);
        }
    }
    let centre = key(i0 + h / 2, j0 + h / 2);
    for k in 0..ring.len() {
        out.push([centre, ring[k], ring[(k + 1) % ring.len()]]);
    }
}

/// Appends the keys a leaf's triangulation uses: its corners and, when a
/// neighbour is finer, its centre and the hanging vertices.
fn leaf_keys(grid: &Grid, split: &FastSet<Cell>, c: Cell, out: &mut Vec<Key>) {
    let (i0, j0, h) = grid.cell(c);
    out.extend(corner_keys(i0, j0, h));
    let hanging = hanging_edges(grid, split, c);
    if hanging.iter().any(|&x| x) {
        out.push(key(i0 + h / 2, j0 + h / 2));
        let mids = mid_keys(i0, j0, h);
        out.extend((0..4).filter(|&e| hanging[e]).map(|e| mids[e]));
    }
}

fn check_settings(coords: &ParametricCoords, settings: &TessellationSettings) -> Result<(), TessellateError> {
    let d = coords.domain;
    if !d.iter().flatten().all(|v| v.is_finite()) || d[0][0] >= d[0][1] || d[1][0] >= d[1][1] {
        return Err(TessellateError::EmptyDomain {
            name: coords.name.clone(),
            domain: d,
        });
    }
    let [ns, nt] = settings.initial;
    if ns == 0 || nt == 0 {
        return Err(TessellateError::InvalidSettings(format!(
            "the base grid must have at least one cell along s and t, found {ns} × {nt}"
        )));
    }
    if settings.max_depth > 31 || (ns.max(nt) as u64) << settings.max_depth > MAX_LATTICE {
        return Err(TessellateError::InvalidSettings(format!(
            "a base grid of {ns} × {nt} cells refined {} times exceeds {MAX_LATTICE} lattice steps along an axis",
            settings.max_depth
        )));
    }
    if let Some(tol) = settings.tolerance {
        if tol.is_nan() || tol < 0.0 || tol.is_infinite() {
            return Err(TessellateError::InvalidSettings(format!(
                "the tolerance must be a finite number ≥ 0, found {tol}"
            )));
        }
    }
    if let Some(e) = settings.max_edge {
        if !(e.is_finite() && e > 0.0) {
            return Err(TessellateError::InvalidSettings(format!(
                "the longest edge must be a finite number > 0, found {e}"
            )));
        }
    }
    if settings.max_angle_deg.is_nan() || settings.max_angle_deg <= 0.0 {
        return Err(TessellateError::InvalidSettings(format!(
            "the largest angle between normals must be above 0°, found {}°",
            settings.max_angle_deg
        )));
    }
    Ok(())
}

/// Tessellates a parametric surface over its domain into a crack-free grid
/// mesh with uv = (s, t), refined adaptively (see the module documentation).
///
/// Returns the mesh (positions, unit normals, uvs and triangles; no
/// materials) and what was done. Errors when the domain is empty or not
/// finite, when a setting is out of range, or when the surface is not finite
/// anywhere on the first grid of samples.
pub fn tessellate(
    coords: &ParametricCoords,
    settings: &TessellationSettings,
) -> Result<(Mesh, TessellationStats), TessellateError> {
    check_settings(coords, settings)?;
    let depth = settings.max_depth;
    let base = settings.initial;
    let grid = Grid {
        domain: coords.domain,
        n: [(base[0] as u64) << depth, (base[1] as u64) << depth],
        depth,
        base,
    };
    let mut samples = Samples {
        coords,
        map: FastMap::default(),
    };
    let base_cells: Vec<Cell> = (0..base[1])
        .flat_map(|j| (0..base[0]).map(move |i| (0, i, j)))
        .collect();

    // The first samples: the base grid, with midpoints when it will be refined.
    let mut keys = Vec::new();
    for &c in &base_cells {
        if depth > 0 {
            keys.extend(grid.nine(c));
        } else {
            leaf_keys(&grid, &FastSet::default(), c, &mut keys);
        }
    }
    samples.ensure(&grid, keys);
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for s in samples.map.values().filter(|s| s.finite()) {
        for k in 0..3 {
            lo[k] = lo[k].min(s.p[k]);
            hi[k] = hi[k].max(s.p[k]);
        }
    }
    if lo[0] > hi[0] {
        return Err(TessellateError::NotFinite {
            name: coords.name.clone(),
        });
    }
    let tol = settings
        .tolerance
        .unwrap_or_else(|| DEFAULT_RELATIVE_TOLERANCE * dist(hi, lo));
    let max_edge = settings
        .max_edge
        .unwrap_or_else(|| DEFAULT_RELATIVE_EDGE * dist(hi, lo));
    let cos_max = if settings.max_angle_deg >= 180.0 {
        -2.0
    } else {
        settings.max_angle_deg.to_radians().cos()
    };

    // Refinement, level by level.
    let mut split: FastSet<Cell> = FastSet::default();
    let mut frontier = base_cells;
    for _ in 0..depth {
        if frontier.is_empty() {
            break;
        }
        samples.ensure(&grid, frontier.iter().flat_map(|&c| grid.nine(c)).collect());
        let decisions: Vec<bool> = frontier
            .par_iter()
            .map(|&c| needs_split(&samples, &grid, c, tol, cos_max, max_edge))
            .collect();
        let mut next = Vec::new();
        for (&c, d) in frontier.iter().zip(decisions) {
            if d {
                split.insert(c);
                next.extend(children(c));
            }
        }
        frontier = next;
    }
    balance(&grid, &mut split);
    let leaves = leaves(&grid, &split);

    // Triangulation.
    let mut keys = Vec::new();
    for &c in &leaves {
        leaf_keys(&grid, &split, c, &mut keys);
    }
    samples.ensure(&grid, keys);
    let mut tris = Vec::with_capacity(leaves.len() * 2);
    for &c in &leaves {
        triangulate(&grid, &split, &samples, c, &mut tris);
    }

    let mut stats = TessellationStats {
        leaves: leaves.len(),
        tolerance: tol,
        samples: samples.map.len(),
        ..Default::default()
    };
    stats.max_depth_reached = leaves.iter().map(|c| c.0).max().unwrap_or(0);
    stats.leaves_per_depth = vec![0; stats.max_depth_reached as usize + 1];
    for c in &leaves {
        stats.leaves_per_depth[c.0 as usize] += 1;
    }

    // Vertices: every finite lattice point the triangulation uses, in (t, s) order.
    let mut verts: Vec<Key> = tris.iter().flatten().copied().collect();
    verts.sort_unstable();
    verts.dedup();
    verts.retain(|&k| samples.get(k).finite());
    let index = |k: Key| verts.binary_search(&k).ok().map(|i| i as u32);
    let positions: Vec<[f32; 3]> = verts.iter().map(|&k| samples.get(k).p.map(|v| v as f32)).collect();
    let uvs: Vec<[f32; 2]> = verts
        .iter()
        .map(|&k| {
            let (i, j) = unkey(k);
            [grid.param(i, 0) as f32, grid.param(j, 1) as f32]
        })
        .collect();

    let mut triangles = Vec::with_capacity(tris.len());
    for t in &tris {
        let (Some(a), Some(b), Some(c)) = (index(t[0]), index(t[1]), index(t[2])) else {
            stats.skipped_triangles += 1;
            continue;
        };
        let [pa, pb, pc] = [a, b, c].map(|v| positions[v as usize].map(f64::from));
        let area2 = norm(cross(sub(pb, pa), sub(pc, pa)));
        let longest = dot(sub(pb, pa), sub(pb, pa))
            .max(dot(sub(pc, pb), sub(pc, pb)))
            .max(dot(sub(pa, pc), sub(pa, pc)));
        if area2.is_nan() || area2 <= 0.0 || 0.5 * area2 <= DEGENERATE_AREA * longest {
            stats.degenerate_triangles += 1;
            continue;
        }
        triangles.push([a, b, c]);
    }

    // Normals: exact, nudged, or from the triangles around.
    let mut normals: Vec<[f64; 3]> = Vec::with_capacity(verts.len());
    let mut missing = Vec::new();
    for (v, &k) in verts.iter().enumerate() {
        let s = samples.get(k);
        if s.nudged {
            stats.fallback_normals += 1;
        }
        match s.n {
            Some(n) => normals.push(n),
            None => {
                normals.push([0.0; 3]);
                missing.push(v);
            }
        }
    }
    if !missing.is_empty() {
        let mut acc = vec![[0.0f64; 3]; verts.len()];
        for t in &triangles {
            let [pa, pb, pc] = t.map(|v| samples.get(verts[v as usize]).p);
            let n = cross(sub(pb, pa), sub(pc, pa));
            for &v in t {
                for k in 0..3 {
                    acc[v as usize][k] += n[k];
                }
            }
        }
        for v in missing {
            let l = norm(acc[v]);
            if l > 0.0 && l.is_finite() {
                normals[v] = acc[v].map(|x| x / l);
                stats.fallback_normals += 1;
            } else {
                stats.missing_normals += 1;
            }
        }
    }

    stats.triangles = triangles.len();
    stats.vertices = verts.len();
    let mesh = Mesh {
        positions,
        normals: normals.into_iter().map(|n| n.map(|v| v as f32)).collect(),
        uvs,
        triangles,
        materials: Vec::new(),
        triangle_materials: Vec::new(),
    };
    Ok((mesh, stats))
}
