//! The sparse octree: the meshing grid, the descent that keeps only the
//! cells the surface may cross (empty space is skipped with the distance
//! bound: a cell whose centre is farther from the surface than its
//! half-diagonal cannot contain any of it), and the search for a shape's
//! bounds by the same test.

use crate::field::Field;
use crate::{Control, MeshError, Stage};
use isoray_shape::Tape;

/// Bits per coordinate in a packed cell, corner or edge key.
pub(crate) const KEY_BITS: u32 = 20;
/// The deepest octree (finest cells per side: 2^MAX_DEPTH).
pub(crate) const MAX_DEPTH: u32 = KEY_BITS - 1;
const KEY_MASK: u64 = (1 << KEY_BITS) - 1;

/// Packs integer lattice coordinates into a key that sorts by z, then y, then x.
#[inline]
pub(crate) fn key(c: [u32; 3]) -> u64 {
    c[0] as u64 | (c[1] as u64) << KEY_BITS | (c[2] as u64) << (2 * KEY_BITS)
}

/// The coordinates of a key.
#[inline]
pub(crate) fn unkey(k: u64) -> [u32; 3] {
    [
        (k & KEY_MASK) as u32,
        ((k >> KEY_BITS) & KEY_MASK) as u32,
        ((k >> (2 * KEY_BITS)) & KEY_MASK) as u32,
    ]
}

/// The finest level of the octree: cubic cells of side `h` from `origin`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Grid {
    /// The lattice point (0, 0, 0).
    pub(crate) origin: [f64; 3],
    /// Cell side.
    pub(crate) h: f64,
    /// Octree depth: the root covers 2^depth cells per side.
    pub(crate) depth: u32,
    /// Cells per axis that lie in the meshing box.
    pub(crate) cells: [u32; 3],
}

impl Grid {
    /// A grid over `bounds` with `resolution` cells along the longest side.
    pub(crate) fn new(bounds: [[f64; 3]; 2], resolution: u32) -> Result<Grid, MeshError> {
        let ext = [0, 1, 2].map(|k| bounds[1][k] - bounds[0][k]);
        let longest = ext[0].max(ext[1]).max(ext[2]);
        if !longest.is_finite() || ext.iter().any(|e| e.is_nan() || *e <= 0.0) {
            return Err(MeshError::Settings(format!(
                "the bounds {:?} .. {:?} are empty or not finite",
                bounds[0], bounds[1]
            )));
        }
        let max = 1u32 << MAX_DEPTH;
        if resolution < 2 || resolution > max {
            return Err(MeshError::Settings(format!(
                "resolution {resolution} is out of range: expected 2 to {max}"
            )));
        }
        let h = longest / resolution as f64;
        let cells = ext.map(|e| ((e / h - 1e-9).ceil() as u32).clamp(1, resolution));
        let depth = 32 - (resolution - 1).leading_zeros();
        Ok(Grid {
            origin: bounds[0],
            h,
            depth,
            cells,
        })
    }

    /// The position of a lattice point.
    #[inline]
    pub(crate) fn point(&self, c: [u32; 3]) -> [f64; 3] {
        [0, 1, 2].map(|k| self.origin[k] + c[k] as f64 * self.h)
    }

    /// True when a lattice point lies on or beyond the box's boundary.
    #[inline]
    pub(crate) fn on_boundary(&self, c: [u32; 3]) -> bool {
        (0..3).any(|k| c[k] == 0 || c[k] >= self.cells[k])
    }
}

/// The most cells one octree level may keep: about 150 bytes of work space
/// per kept finest cell, so about 2.5 GiB at the limit.
pub(crate) const MAX_CELLS: usize = 16 << 20;

/// The finest cells (as sorted keys of their lowest corner) that the
/// surface of `field` may cross, by breadth-first descent from the root.
///
/// `lipschitz` (≥ 1) is how much the field may overestimate the distance.
pub(crate) fn active_cells(field: &Field, grid: &Grid, lipschitz: f64, ctl: &Control) -> Result<Vec<u64>, MeshError> {
    // Start a few levels down so that the first batch is large enough to share.
    let start = grid.depth.min(3);
    let mut size = 1u32 << (grid.depth - start);
    let per_side = 1u32 << start;
    let mut level: Vec<[u32; 3]> = Vec::new();
    for z in 0..per_side {
        for y in 0..per_side {
            for x in 0..per_side {
                let c = [x * size, y * size, z * size];
                if (0..3).all(|k| c[k] < grid.cells[k]) {
                    level.push(c);
                }
            }
        }
    }
    let levels = grid.depth - start + 1;
    for l in 0..levels {
        ctl.check()?;
        ctl.progress(Stage::Octree, l as f64 / levels as f64);
        let half = 0.5 * size as f64 * grid.h;
        let radius = half * 3f64.sqrt() * lipschitz * (1.0 + 1e-9) + 1e-12 * grid.h;
        let centres: Vec<[f64; 3]> = level
            .iter()
            .map(|c| {
                let p = grid.point(*c);
                [p[0] + half, p[1] + half, p[2] + half]
            })
            .collect();
        let values = field.values(&centres);
        if !values.is_empty() && values.iter().all(|v| v.is_nan()) {
            return Err(MeshError::NotANumber {
                count: values.len(),
                at: centres[0],
            });
        }
        let kept = level
            .iter()
            .zip(&values)
            // NaN cannot rule a cell out (it is reported once the corners are sampled).
            .filter(|(_, v)| v.is_nan() || v.abs() <= radius)
            .map(|(c, _)| *c);
        if size == 1 {
            let mut keys: Vec<u64> = kept.map(key).collect();
            keys.sort_unstable();
            return Ok(keys);
        }
        let child = size / 2;
        let mut next = Vec::new();
        for c in kept {
            for o in 0..8u32 {
                let d = [o & 1, (o >> 1) & 1, (o >> 2) & 1];
                let cc = [c[0] + d[0] * child, c[1] + d[1] * child, c[2] + d[2] * child];
                if (0..3).all(|k| cc[k] < grid.cells[k]) {
                    next.push(cc);
                }
            }
        }
        if next.len() > MAX_CELLS {
            return Err(MeshError::Settings(format!(
                "the surface crosses more than {MAX_CELLS} cells at this resolution (cell size {:.3e}); lower the resolution or mesh a smaller box",
                grid.h
            )));
        }
        level = next;
        size = child;
    }
    Ok(Vec::new())
}

/// Half the side of the cube searched for a shape's surface.
pub const SEARCH_RADIUS: f64 = 1.0e4;

/// Finds an axis-aligned box that contains the surface of `tape`, by
/// repeated octree descents that shrink a search cube (±[`SEARCH_RADIUS`])
/// onto the cells the surface may cross. Errors when there is no surface or
/// it reaches the search cube's sides (an unbounded shape such as a plane).
pub(crate) fn find_bounds(tape: &Tape, iso: f64, lipschitz: f64, ctl: &Control) -> Result<[[f64; 3]; 2], MeshError> {
    const DEPTH: u32 = 6;
    let mut cube = [[-SEARCH_RADIUS; 3], [SEARCH_RADIUS; 3]];
    let mut found: Option<[[f64; 3]; 2]> = None;
    for pass in 0..8 {
        ctl.check()?;
        let side = (0..3).map(|k| cube[1][k] - cube[0][k]).fold(0.0, f64::max);
        let grid = Grid {
            origin: cube[0],
            h: side / (1u32 << DEPTH) as f64,
            depth: DEPTH,
            cells: [1 << DEPTH; 3],
        };
        // The search field is not clipped: a box far larger than the cube.
        let far = [[-1e300; 3], [1e300; 3]];
        let field = Field::new(tape, far, iso);
        let cells = active_cells(&field, &grid, lipschitz, &Control::silent(ctl))?;
        if cells.is_empty() {
            return Err(MeshError::NoSurface);
        }
        let mut lo = [u32::MAX; 3];
        let mut hi = [0u32; 3];
        for &k in &cells {
            let c = unkey(k);
            for a in 0..3 {
                lo[a] = lo[a].min(c[a]);
                hi[a] = hi[a].max(c[a] + 1);
            }
        }
        if pass == 0 && (0..3).any(|a| lo[a] == 0 || hi[a] == 1 << DEPTH) {
            return Err(MeshError::Unbounded);
        }
        let b = [grid.point(lo), grid.point(hi)];
        let shrink = (0..3).map(|a| (b[1][a] - b[0][a]) / side).fold(0.0, f64::max);
        found = Some(b);
        // Stop when a pass no longer shrinks the box much.
        if shrink > 0.7 {
            break;
        }
        // A cube around the box, slightly larger so no cell is cut.
        let c = [0, 1, 2].map(|a| 0.5 * (b[0][a] + b[1][a]));
        let half = 0.5 * (0..3).map(|a| b[1][a] - b[0][a]).fold(0.0, f64::max) * 1.05;
        cube = [c.map(|v| v - half), c.map(|v| v + half)];
    }
    found.ok_or(MeshError::NoSurface)
}
