//! A-buffer (Carpenter 1984): anti-aliased, area-averaged hidden-surface
//! removal with 4×8 subpixel coverage masks.
//!
//! Each pixel keeps a list of [`Fragment`]s sorted front to back by `zmin`.
//! A fragment carries a 32-bit coverage [`Mask`], a depth range, a colour, an
//! opacity and the id of the object it came from. Fragments of the same object
//! that overlap in depth are merged on insertion. [`resolve`] then "packs" the
//! list under a search mask, front to back: opaque fragments hide whatever is
//! behind them in the bits they cover, transparent ones let the colour behind
//! through in proportion to `1 − opacity`, and fragments that interpenetrate in
//! depth are blended by an estimate of the front one's visible fraction.
//!
//! Screen conventions: pixel `(i, j)` spans `[i − 0.5, i + 0.5] × [j − 0.5, j + 0.5]`
//! (pixel centres at integer coordinates), `x` grows to the right and `y`
//! grows downwards (row index), as in the rest of the raster pipeline.

use rayon::prelude::*;
use std::ops::{BitAnd, BitOr, Not};

/// A 32-subpixel coverage mask of one pixel, stored in a `u32`.
///
/// Layout: 8 columns × 4 rows; subsample `(c, r)` with column `c ∈ 0..8` and
/// row `r ∈ 0..4` is bit `r · 8 + c`. Its position within the pixel, relative
/// to the pixel's lower corner `(i − 0.5, j − 0.5)`, is
/// `((c + 0.5) / 8, (r + 0.5) / 4)`: columns go along `x`, rows along `y`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Mask(pub u32);

impl Mask {
    /// The mask with no subsample covered.
    pub const EMPTY: Mask = Mask(0);
    /// The mask with every subsample covered.
    pub const FULL: Mask = Mask(u32::MAX);
    /// Number of subsample columns (along `x`).
    pub const COLUMNS: u32 = 8;
    /// Number of subsample rows (along `y`).
    pub const ROWS: u32 = 4;

    /// The bit index of subsample column `c` (`0..8`) and row `r` (`0..4`): `r · 8 + c`.
    pub const fn bit_index(c: u32, r: u32) -> u32 {
        r * Self::COLUMNS + c
    }

    /// The offset of subsample `(c, r)` from the pixel centre: `((c + 0.5)/8 − 0.5, (r + 0.5)/4 − 0.5)`.
    pub fn sample_offset(c: u32, r: u32) -> [f64; 2] {
        [
            (c as f64 + 0.5) / Self::COLUMNS as f64 - 0.5,
            (r as f64 + 0.5) / Self::ROWS as f64 - 0.5,
        ]
    }

    /// Number of covered subsamples (0–32).
    pub fn count(self) -> u32 {
        self.0.count_ones()
    }

    /// Covered fraction of the pixel: `count / 32`, always a multiple of 1/32.
    pub fn area(self) -> f32 {
        self.count() as f32 / 32.0
    }

    /// Whether no subsample is covered.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Whether subsample column `c`, row `r` is covered.
    pub fn contains(self, c: u32, r: u32) -> bool {
        self.0 >> Self::bit_index(c, r) & 1 == 1
    }

    /// The coverage mask of a screen-space triangle over pixel `(x, y)`.
    ///
    /// A subsample is covered when it lies strictly inside the triangle, or
    /// exactly on an edge that is a *top* or *left* edge (top-left fill rule,
    /// with `y` growing downwards): an edge owns the samples on it when the
    /// triangle's interior lies to its right (inward normal with positive `x`),
    /// or, for a horizontal edge, below it. The winding order of the vertices
    /// does not matter. Edge functions are evaluated with the edge's endpoints
    /// in a canonical order, so two triangles sharing an edge compute exactly
    /// the same values on it: no subsample is covered by both or by neither.
    /// Degenerate (zero-area) triangles cover nothing.
    pub fn coverage(tri: &[[f64; 2]; 3], x: i32, y: i32) -> Mask {
        // Per edge: (origin, direction, sign making the interior positive, owns zero).
        let mut edges = [([0.0f64; 2], [0.0f64; 2], 0.0f64, false); 3];
        for (k, edge) in edges.iter_mut().enumerate() {
            let (p, q, opposite) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let (a, b) = if (p[0], p[1]) <= (q[0], q[1]) { (p, q) } else { (q, p) };
            let d = [b[0] - a[0], b[1] - a[1]];
            let side = edge_function(a, d, opposite);
            if side == 0.0 || side.is_nan() {
                return Mask::EMPTY;
            }
            let sign = side.signum();
            // Inward normal = sign · gradient of the edge function = sign · (−dy, dx).
            let (nx, ny) = (-d[1] * sign, d[0] * sign);
            let owns = nx > 0.0 || (nx == 0.0 && ny > 0.0);
            *edge = (a, d, sign, owns);
        }
        let mut bits = 0u32;
        for r in 0..Self::ROWS {
            for c in 0..Self::COLUMNS {
                let o = Self::sample_offset(c, r);
                let s = [x as f64 + o[0], y as f64 + o[1]];
                let inside = edges.iter().all(|&(a, d, sign, owns)| {
                    let e = edge_function(a, d, s) * sign;
                    e > 0.0 || (e == 0.0 && owns)
                });
                if inside {
                    bits |= 1 << Self::bit_index(c, r);
                }
            }
        }
        Mask(bits)
    }
}

/// The edge function of the line through `a` with direction `d`, at point `p`.
fn edge_function(a: [f64; 2], d: [f64; 2], p: [f64; 2]) -> f64 {
    d[0] * (p[1] - a[1]) - d[1] * (p[0] - a[0])
}

impl BitAnd for Mask {
    type Output = Mask;
    fn bitand(self, rhs: Mask) -> Mask {
        Mask(self.0 & rhs.0)
    }
}

impl BitOr for Mask {
    type Output = Mask;
    fn bitor(self, rhs: Mask) -> Mask {
        Mask(self.0 | rhs.0)
    }
}

impl Not for Mask {
    type Output = Mask;
    fn not(self) -> Mask {
        Mask(!self.0)
    }
}

/// One surface's contribution to a pixel: coverage, depth range and shading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fragment {
    /// Subsamples of the pixel the surface covers.
    pub mask: Mask,
    /// Nearest depth of the surface within the pixel (larger is farther).
    pub zmin: f32,
    /// Farthest depth of the surface within the pixel.
    pub zmax: f32,
    /// Linear RGB colour.
    pub color: [f32; 3],
    /// Opacity in `[0, 1]`; 1 is opaque.
    pub opacity: f32,
    /// Id of the object the fragment came from; same-object fragments that
    /// overlap in depth are merged.
    pub object: u32,
}

impl Fragment {
    /// Whether the depth ranges of `self` and `other` overlap (closed intervals).
    pub fn overlaps_in_depth(&self, other: &Fragment) -> bool {
        self.zmin <= other.zmax && other.zmin <= self.zmax
    }

    /// Merge `other` into `self`: OR the masks, widen the depth range, and
    /// blend colour and opacity weighted by each fragment's coverage.
    pub fn merge(&mut self, other: &Fragment) {
        let (wa, wb) = (self.mask.count() as f32, other.mask.count() as f32);
        let (wa, wb) = if wa + wb == 0.0 {
            (0.5, 0.5)
        } else {
            (wa / (wa + wb), wb / (wa + wb))
        };
        for k in 0..3 {
            self.color[k] = self.color[k] * wa + other.color[k] * wb;
        }
        self.opacity = self.opacity * wa + other.opacity * wb;
        self.mask = self.mask | other.mask;
        self.zmin = self.zmin.min(other.zmin);
        self.zmax = self.zmax.max(other.zmax);
    }
}

/// A pixel's fragments, kept sorted front to back by `zmin`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FragmentList {
    fragments: Vec<Fragment>,
}

impl FragmentList {
    /// An empty list (allocates nothing).
    pub const fn new() -> Self {
        FragmentList { fragments: Vec::new() }
    }

    /// Insert a fragment, keeping the list sorted by `zmin`. A fragment of the
    /// same object that overlaps it in depth is merged with it (repeatedly, as
    /// the widened range may reach further fragments of that object).
    /// Fragments with an empty mask are ignored.
    pub fn insert(&mut self, fragment: Fragment) {
        if fragment.mask.is_empty() {
            return;
        }
        let mut f = fragment;
        while let Some(i) = self
            .fragments
            .iter()
            .position(|g| g.object == f.object && g.overlaps_in_depth(&f))
        {
            let g = self.fragments.remove(i);
            f.merge(&g);
        }
        let at = self.fragments.partition_point(|g| g.zmin <= f.zmin);
        self.fragments.insert(at, f);
    }

    /// The fragments, front to back.
    pub fn fragments(&self) -> &[Fragment] {
        &self.fragments
    }

    /// Number of fragments.
    pub fn len(&self) -> usize {
        self.fragments.len()
    }

    /// Whether the list holds no fragment.
    pub fn is_empty(&self) -> bool {
        self.fragments.is_empty()
    }

    /// Remove every fragment (keeps the allocation).
    pub fn clear(&mut self) {
        self.fragments.clear();
    }

    /// Resolve this pixel's colour over `background`; see [`resolve`].
    pub fn resolve(&self, background: [f32; 3]) -> [f32; 3] {
        resolve(&self.fragments, background)
    }
}

/// Resolve a pixel's colour from its fragments, sorted front to back by
/// `zmin`, over an opaque `background`: Carpenter's "pack under mask".
///
/// Fragments are processed front to back with a search mask (initially all 32
/// bits). Bits of the search mask not covered by the current fragment are
/// searched further back. In the bits it covers, the fragment contributes
/// `opacity · color` and lets `(1 − opacity)` of the colour behind it (the
/// rest of the list packed under those bits) through; an opaque fragment
/// hides what is behind it. Where the next fragment interpenetrates the
/// current one in depth (`cur.zmax > next.zmin`) and they share bits, the
/// front fragment's visible fraction is estimated as
/// `(next.zmax − cur.zmin) / ((cur.zmax − cur.zmin) + (next.zmax − next.zmin))`,
/// clamped to `[0, 1]`, and over the shared bits the result is that fraction
/// of the front fragment (over what is behind it) plus the rest of what lies
/// behind. The result is the average over the pixel's 32 subsamples.
pub fn resolve(fragments: &[Fragment], background: [f32; 3]) -> [f32; 3] {
    pack(fragments, Mask::FULL, background)
}

/// Colour integrated over `search` (sum over its bits of colour / 32).
fn pack(mut fragments: &[Fragment], search: Mask, background: [f32; 3]) -> [f32; 3] {
    if search.is_empty() {
        return [0.0; 3];
    }
    // Skip fragments that cover none of the searched bits.
    let cur = loop {
        match fragments.split_first() {
            None => return scale(background, search.area()),
            Some((f, rest)) => {
                fragments = rest;
                if !(f.mask & search).is_empty() {
                    break *f;
                }
            }
        }
    };
    let rest = fragments;
    let inside = search & cur.mask;
    let mut result = pack(rest, search & !cur.mask, background);

    // Shared bits with an interpenetrating next fragment.
    let mut plain = inside;
    if let Some(next) = rest.first() {
        let shared = inside & next.mask;
        if cur.zmax > next.zmin && !shared.is_empty() {
            let thickness = (cur.zmax - cur.zmin) + (next.zmax - next.zmin);
            let visible = if thickness > 0.0 {
                ((next.zmax - cur.zmin) / thickness).clamp(0.0, 1.0)
            } else {
                0.5
            };
            let behind = pack(rest, shared, background);
            let front = over(&cur, shared, behind);
            result = add(result, add(scale(front, visible), scale(behind, 1.0 - visible)));
            plain = inside & !next.mask;
        }
    }
    if !plain.is_empty() {
        let behind = if cur.opacity >= 1.0 {
            [0.0; 3]
        } else {
            pack(rest, plain, background)
        };
        result = add(result, over(&cur, plain, behind));
    }
    result
}

/// `fragment` composited over `behind` (already integrated) within `mask`.
fn over(fragment: &Fragment, mask: Mask, behind: [f32; 3]) -> [f32; 3] {
    let a = fragment.opacity.clamp(0.0, 1.0);
    add(scale(fragment.color, a * mask.area()), scale(behind, 1.0 - a))
}

fn scale(c: [f32; 3], s: f32) -> [f32; 3] {
    [c[0] * s, c[1] * s, c[2] * s]
}

fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// A `width × height` A-buffer: one front-to-back [`FragmentList`] per pixel,
/// row-major (`lists[y · width + x]`). Empty lists allocate nothing.
#[derive(Clone, Debug, Default)]
pub struct ABuffer {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Per-pixel fragment lists, row-major.
    pub lists: Vec<FragmentList>,
}

impl ABuffer {
    /// An empty A-buffer.
    pub fn new(width: usize, height: usize) -> Self {
        ABuffer {
            width,
            height,
            lists: vec![FragmentList::new(); width * height],
        }
    }

    /// Add a fragment to pixel `(x, y)`; out-of-range pixels are ignored.
    pub fn add(&mut self, x: usize, y: usize, fragment: Fragment) {
        if x < self.width && y < self.height {
            self.lists[y * self.width + x].insert(fragment);
        }
    }

    /// The fragment list of pixel `(x, y)`.
    ///
    /// # Panics
    /// If `(x, y)` is outside the buffer.
    pub fn list(&self, x: usize, y: usize) -> &FragmentList {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the A-buffer"
        );
        &self.lists[y * self.width + x]
    }

    /// Remove every fragment.
    pub fn clear(&mut self) {
        self.lists.iter_mut().for_each(FragmentList::clear);
    }

    /// Resolve every pixel over `background` (in parallel), row-major.
    pub fn resolve_image(&self, background: [f32; 3]) -> Vec<[f32; 3]> {
        self.lists.par_iter().map(|l| l.resolve(background)).collect()
    }
}
