//! Dual contouring on the sparse octree's finest cells, with one vertex per
//! surface *patch* of a cell rather than one per cell (the dual of marching
//! cubes, as in Nielson's dual marching cubes and manifold dual contouring).
//!
//! 1. The field is sampled at the corners of the active cells.
//! 2. Every lattice edge whose ends differ in sign is crossed once; the
//!    crossing is found by bracketed root finding, and its normal is the
//!    field's exact gradient there.
//! 3. In each cell the crossed edges are joined into closed loops through the
//!    cell's faces: a face with two crossed edges joins them, a face with
//!    four (an ambiguous face) is resolved by the asymptotic decider on the
//!    face's own four values, so both cells that share it agree. Each loop is
//!    one patch and gets one vertex.
//! 4. A patch whose normals spread wider than the feature angle is a sharp
//!    feature: its vertex minimises the quadratic error to the tangent
//!    planes (edges and corners come out sharp). Other patches put the vertex
//!    at the mass point, projected onto the surface along the gradient.
//!    Vertices are kept inside their cell.
//! 5. Every crossed edge becomes a quad between the patches of its four
//!    cells, wound so its normal points from negative to positive.
//!
//! Because the loops are the marching-cubes surface (closed, and consistent
//! across faces), the quads form its dual: a closed surface in which every
//! edge joins two faces.

use crate::field::Field;
use crate::octree::{key, unkey, Grid};
use crate::qef::Qef;
use crate::{Control, MeshError, Stage};
use isoray_shape::BatchEvaluator;
use rayon::prelude::*;

/// Items per parallel work unit.
const CHUNK: usize = 512;
/// Iterations of bracketed root finding on a crossed edge.
const ROOT_ITERATIONS: usize = 10;
/// Eigenvalues of the QEF below this fraction of the largest are dropped.
const QEF_TRUNCATION: f64 = 0.02;
/// Finite-difference step of gradients, as a fraction of the cell: small
/// enough that only crossings within it of a crease see a blended normal.
pub(crate) const GRADIENT_STEP: f64 = 1e-6;
/// Secant steps along a smooth patch's normal onto the surface.
const LINE_STEPS: usize = 4;
/// Newton steps that move a vertex onto the surface.
const PROJECTION_STEPS: usize = 4;
/// Vertices stay this fraction of a cell inside their cell, so that vertices
/// of neighbouring cells never coincide.
const CELL_MARGIN: f64 = 1e-3;

/// The corners of a cell: bit 0 is +x, bit 1 is +y, bit 2 is +z.
const CORNER: [[u32; 3]; 8] = [
    [0, 0, 0],
    [1, 0, 0],
    [0, 1, 0],
    [1, 1, 0],
    [0, 0, 1],
    [1, 0, 1],
    [0, 1, 1],
    [1, 1, 1],
];

/// Edge `a·4 + u + 2v` runs along axis a, at offset u along axis (a+1)%3
/// and v along axis (a+2)%3. Its two corners.
fn edge_corners(e: usize) -> (usize, usize) {
    let a = e / 4;
    let (u, v) = ((e & 1) as u32, ((e >> 1) & 1) as u32);
    let mut o = [0u32; 3];
    o[(a + 1) % 3] = u;
    o[(a + 2) % 3] = v;
    let c0 = (o[0] | o[1] << 1 | o[2] << 2) as usize;
    (c0, c0 | 1 << a)
}

/// The edge along axis `a` whose lower corner has the offsets `o`.
fn edge_index(a: usize, o: [u32; 3]) -> usize {
    a * 4 + (o[(a + 1) % 3] + 2 * o[(a + 2) % 3]) as usize
}

fn corner_index(o: [u32; 3]) -> usize {
    (o[0] | o[1] << 1 | o[2] << 2) as usize
}

/// Face (axis a, side s): its corners in cyclic order, and the edges between
/// consecutive corners (edge i joins corner i and corner i+1).
fn face(a: usize, s: u32) -> ([usize; 4], [usize; 4]) {
    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
    let at = |ub: u32, uc: u32| {
        let mut o = [0u32; 3];
        o[a] = s;
        o[b] = ub;
        o[c] = uc;
        o
    };
    let corners = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)];
    let edges = [
        edge_index(b, at(0, 0)),
        edge_index(c, at(1, 0)),
        edge_index(b, at(0, 1)),
        edge_index(c, at(0, 0)),
    ];
    (corners.map(corner_index), edges)
}

/// Splits a cell's crossed edges into patches (closed loops through its
/// faces). Returns, per edge, its patch (255 when not crossed), and the
/// number of patches.
pub(crate) fn cell_patches(v: &[f64; 8]) -> ([u8; 12], u8) {
    cell_patches_with(v, 0)
}

/// The two segments (as pairs of positions 0..4 in the face's cyclic edge
/// order) of face (a, s) when it is ambiguous (four crossed edges), with
/// the asymptotic decider's choice, inverted when `flipped`.
fn face_segments(v: &[f64; 8], a: usize, s: u32, flipped: bool) -> Option<[(usize, usize); 2]> {
    let (c, _) = face(a, s);
    let inside = |k: usize| v[c[k]] < 0.0;
    if (0..4).any(|i| inside(i) == inside((i + 1) % 4)) {
        return None;
    }
    // Corners 0 and 2 share a sign. The bilinear saddle value decides
    // whether they connect through the face.
    let (f0, f1, f2, f3) = (v[c[0]], v[c[1]], v[c[2]], v[c[3]]);
    let saddle = (f0 * f2 - f1 * f3) / (f0 + f2 - f1 - f3);
    let connected_02 = ((saddle < 0.0) == inside(0)) != flipped;
    Some(if connected_02 {
        // Cut off corners 1 and 3.
        [(0, 1), (2, 3)]
    } else {
        // Cut off corners 0 and 2.
        [(3, 0), (1, 2)]
    })
}

/// [`cell_patches`] with the ambiguous faces whose bit (a·2 + s) is set in
/// `flip` resolved the other way.
fn cell_patches_with(v: &[f64; 8], flip: u8) -> ([u8; 12], u8) {
    let inside = |c: usize| v[c] < 0.0;
    if v.iter().all(|&x| x < 0.0) || v.iter().all(|&x| x >= 0.0) {
        return ([255; 12], 0);
    }
    let mut links = [[255u8; 2]; 12];
    let mut link = |e0: usize, e1: usize| {
        for (e, o) in [(e0, e1), (e1, e0)] {
            let slot = if links[e][0] == 255 { 0 } else { 1 };
            links[e][slot] = o as u8;
        }
    };
    for a in 0..3 {
        for s in 0..2 {
            let (c, e) = face(a, s);
            let mut crossed = [0usize; 4];
            let mut count = 0;
            for i in 0..4 {
                if inside(c[i]) != inside(c[(i + 1) % 4]) {
                    crossed[count] = i;
                    count += 1;
                }
            }
            match count {
                2 => link(e[crossed[0]], e[crossed[1]]),
                4 => {
                    if let Some(segs) = face_segments(v, a, s, flip >> (a * 2 + s as usize) & 1 == 1) {
                        for (i, j) in segs {
                            link(e[i], e[j]);
                        }
                    }
                }
                _ => {}
            }
        }
    }
    let mut patch = [255u8; 12];
    let mut n = 0u8;
    for start in 0..12 {
        let (c0, c1) = edge_corners(start);
        if inside(c0) == inside(c1) || patch[start] != 255 {
            continue;
        }
        let mut e = start;
        while patch[e] == 255 {
            patch[e] = n;
            let [l0, l1] = links[e];
            e = if l0 != 255 && patch[l0 as usize] == 255 {
                l0 as usize
            } else if l1 != 255 {
                l1 as usize
            } else {
                break;
            };
        }
        n += 1;
    }
    (patch, n)
}

/// The mesher's intermediate results on a grid.
pub(crate) struct Contour {
    /// Vertex positions.
    pub(crate) positions: Vec<[f64; 3]>,
    /// Triangles, wound with outward normals.
    pub(crate) triangles: Vec<[u32; 3]>,
    /// Cells added because the distance bound had skipped them.
    pub(crate) missed_cells: usize,
    /// Active cells after the descent.
    pub(crate) active_cells: usize,
    /// Patches placed at a sharp feature.
    pub(crate) feature_vertices: usize,
    /// Vertices moved back to their mass point to undo a fold.
    pub(crate) unfolded: usize,
    /// Pairs of crossing triangles that remained after that.
    pub(crate) folds_left: usize,
}

/// No match in [`lookup`].
const NONE: u32 = u32::MAX;

/// The position in `sorted` of each of `queries` (which must be sorted too),
/// or [`NONE`]: a merge walk per parallel chunk, O(n + m) in all, in place
/// of one binary search per query.
fn lookup(sorted: &[u64], queries: &[u64]) -> Vec<u32> {
    let mut out = vec![NONE; queries.len()];
    out.par_chunks_mut(4096)
        .zip(queries.par_chunks(4096))
        .for_each(|(o, q)| {
            let Some(&first) = q.first() else { return };
            let mut j = sorted.partition_point(|&k| k < first);
            for (oi, &qk) in o.iter_mut().zip(q) {
                while j < sorted.len() && sorted[j] < qk {
                    j += 1;
                }
                if j < sorted.len() && sorted[j] == qk {
                    *oi = j as u32;
                }
            }
        });
    out
}

/// The key offsets of a cell's corners (adding them to a cell's key never
/// carries, since coordinates stay below 2^KEY_BITS).
fn corner_keys() -> [u64; 8] {
    CORNER.map(key)
}

/// The union of sorted lists, sorted and without repeats (pairwise merges:
/// each list is sorted already, so nothing is sorted again).
fn merge_sorted(mut lists: Vec<Vec<u64>>) -> Vec<u64> {
    fn merge(a: &[u64], b: &[u64]) -> Vec<u64> {
        let mut out = Vec::with_capacity(a.len() + b.len());
        let (mut i, mut j) = (0, 0);
        while i < a.len() && j < b.len() {
            let v = a[i].min(b[j]);
            if out.last() != Some(&v) {
                out.push(v);
            }
            i += (a[i] == v) as usize;
            j += (b[j] == v) as usize;
        }
        for &v in a[i..].iter().chain(&b[j..]) {
            if out.last() != Some(&v) {
                out.push(v);
            }
        }
        out
    }
    while lists.len() > 1 {
        lists = lists
            .par_chunks(2)
            .map(|p| {
                if p.len() == 2 {
                    merge(&p[0], &p[1])
                } else {
                    merge(&p[0], &[])
                }
            })
            .collect();
    }
    lists.pop().unwrap_or_default()
}

/// Per-cell work, gathered in parallel chunks and concatenated in order.
fn par_gather<T: Sync, U: Send>(items: &[T], f: impl Fn(&[T], &mut Vec<U>) + Sync) -> Vec<U> {
    let parts: Vec<Vec<U>> = items
        .par_chunks(4096)
        .map(|chunk| {
            let mut v = Vec::new();
            f(chunk, &mut v);
            v
        })
        .collect();
    parts.into_iter().flatten().collect()
}

/// Rounds of ambiguous-face flipping.
const FACE_ROUNDS: usize = 4;

/// Each cell's patches, with ambiguous faces re-resolved where two
/// face-adjacent cells would otherwise join the same two patches by both
/// segments of their shared face: that pair of vertices would be an edge of
/// four quads (a non-manifold edge, where a sheet thinner than a cell
/// passes between them). Flipping the face's choice in both cells splits
/// the link; it is repeated around the cells that changed.
fn resolve_faces(cells: &[u64], values: &[[f64; 8]]) -> Vec<([u8; 12], u8)> {
    let n = cells.len();
    let mut patches: Vec<([u8; 12], u8)> = values.par_iter().map(cell_patches).collect();
    let mut flip = vec![0u8; n];
    // Upper neighbour of each cell along each axis.
    let upper: Vec<Vec<u32>> = (0..3)
        .map(|a| {
            let unit = key(std::array::from_fn(|k| (k == a) as u32));
            let q: Vec<u64> = cells.iter().map(|&k| k + unit).collect();
            lookup(cells, &q)
        })
        .collect();
    let conflict = |patches: &[([u8; 12], u8)], flip: &[u8], lo: usize, hi: usize, a: usize| -> bool {
        let Some(segs) = face_segments(&values[lo], a, 1, flip[lo] >> (a * 2 + 1) & 1 == 1) else {
            return false;
        };
        let (_, el) = face(a, 1);
        let (_, eh) = face(a, 0);
        let (pl, ph) = (&patches[lo].0, &patches[hi].0);
        pl[el[segs[0].0]] == pl[el[segs[1].0]] && ph[eh[segs[0].0]] == ph[eh[segs[1].0]]
    };
    let mut todo: Vec<usize> = (0..n).filter(|&i| patches[i].1 > 0).collect();
    for _ in 0..FACE_ROUNDS {
        let found: Vec<(usize, usize, usize)> = todo
            .par_iter()
            .flat_map_iter(|&lo| {
                let mut out = Vec::new();
                for (a, up) in upper.iter().enumerate() {
                    let hi = up[lo];
                    if hi != NONE && conflict(&patches, &flip, lo, hi as usize, a) {
                        out.push((lo, hi as usize, a));
                    }
                }
                out.into_iter()
            })
            .collect();
        if found.is_empty() {
            break;
        }
        let mut changed = Vec::new();
        for &(lo, hi, a) in &found {
            flip[lo] ^= 1 << (a * 2 + 1);
            flip[hi] ^= 1 << (a * 2);
            changed.extend([lo, hi]);
        }
        changed.sort_unstable();
        changed.dedup();
        for &c in &changed {
            patches[c] = cell_patches_with(&values[c], flip[c]);
        }
        // Check again the faces of the changed cells: their upper faces,
        // and their lower ones from the cell below.
        let mut next = changed.clone();
        for up in &upper {
            for (lo, &hi) in up.iter().enumerate() {
                if hi != NONE && changed.binary_search(&(hi as usize)).is_ok() {
                    next.push(lo);
                }
            }
        }
        next.sort_unstable();
        next.dedup();
        todo = next;
    }
    patches
}

/// Runs dual contouring over the `cells` (sorted keys) of `grid`.
pub(crate) fn contour(
    field: &Field,
    grid: &Grid,
    mut cells: Vec<u64>,
    feature_angle_deg: f64,
    ctl: &Control,
) -> Result<Contour, MeshError> {
    let active_cells = cells.len();
    let ck = corner_keys();
    let mut keys: Vec<u64> = Vec::new();
    let mut values: Vec<f64> = Vec::new();
    let mut missed_cells = 0;
    let mut cell_values: Vec<[f64; 8]>;
    // Corners and crossed edges; repeated when a crossed edge's neighbour
    // cells were not all active (the distance bound overestimated).
    let edges = loop {
        ctl.check()?;
        ctl.progress(Stage::Corners, 0.0);
        let corners = merge_sorted(ck.iter().map(|&off| cells.iter().map(|&k| k + off).collect()).collect());
        let new: Vec<u64> = if keys.is_empty() {
            corners
        } else {
            let found = lookup(&keys, &corners);
            corners
                .iter()
                .zip(found)
                .filter(|(_, i)| *i == NONE)
                .map(|(k, _)| *k)
                .collect()
        };
        let pts: Vec<[f64; 3]> = new.iter().map(|&k| grid.point(unkey(k))).collect();
        let mut vals = field.values(&pts);
        if let Some(i) = vals.iter().position(|v| v.is_nan()) {
            let n = vals.iter().filter(|v| v.is_nan()).count();
            return Err(MeshError::NotANumber { count: n, at: pts[i] });
        }
        for (v, &k) in vals.iter_mut().zip(&new) {
            if grid.on_boundary(unkey(k)) {
                *v = v.max(0.0);
            }
        }
        if keys.is_empty() {
            keys = new;
            values = vals;
        } else {
            let mut merged: Vec<(u64, f64)> = keys.iter().copied().zip(values.iter().copied()).collect();
            merged.extend(new.into_iter().zip(vals));
            merged.par_sort_unstable_by_key(|p| p.0);
            keys = merged.iter().map(|p| p.0).collect();
            values = merged.iter().map(|p| p.1).collect();
        }
        ctl.check()?;
        ctl.progress(Stage::Edges, 0.0);
        cell_values = vec![[f64::INFINITY; 8]; cells.len()];
        for (o, &off) in ck.iter().enumerate() {
            let q: Vec<u64> = cells.iter().map(|&k| k + off).collect();
            for (cv, i) in cell_values.iter_mut().zip(lookup(&keys, &q)) {
                if i != NONE {
                    cv[o] = values[i as usize];
                }
            }
        }
        // Per local edge, the crossed ones in cell order: sorted lists.
        let edges = merge_sorted(
            (0..12)
                .into_par_iter()
                .map(|e| {
                    let (c0, c1) = edge_corners(e);
                    cells
                        .iter()
                        .zip(&cell_values)
                        .filter(|(_, v)| (v[c0] < 0.0) != (v[c1] < 0.0))
                        .map(|(&k, _)| (k + ck[c0]) << 2 | (e / 4) as u64)
                        .collect()
                })
                .collect(),
        );
        // The cells around each crossed edge.
        let around = merge_sorted(edge_sides(&edges).into_iter().map(|s| s.cells).collect());
        let missing: Vec<u64> = around
            .iter()
            .zip(lookup(&cells, &around))
            .filter(|(_, i)| *i == NONE)
            .map(|(k, _)| *k)
            .collect();
        if missing.is_empty() {
            break edges;
        }
        missed_cells += missing.len();
        cells.extend(missing);
        cells.sort_unstable();
    };
    let value_at = |q: &[u64]| -> Vec<f64> {
        lookup(&keys, q)
            .into_iter()
            .map(|i| if i == NONE { f64::INFINITY } else { values[i as usize] })
            .collect()
    };

    // Crossings: point and normal on every crossed edge. The values at the
    // edges' ends: lower ends in edge order; upper ends per axis, in order.
    ctl.check()?;
    ctl.progress(Stage::Edges, 0.5);
    let lower: Vec<u64> = edges.iter().map(|&ek| ek >> 2).collect();
    let f_lower = value_at(&lower);
    let mut f_upper = vec![f64::INFINITY; edges.len()];
    for a in 0..3 {
        let unit = key(std::array::from_fn(|k| (k == a) as u32));
        let idx: Vec<usize> = (0..edges.len()).filter(|&i| (edges[i] & 3) as usize == a).collect();
        let q: Vec<u64> = idx.iter().map(|&i| lower[i] + unit).collect();
        for (&i, f) in idx.iter().zip(value_at(&q)) {
            f_upper[i] = f;
        }
    }
    let order: Vec<usize> = (0..edges.len()).collect();
    let crossings: Vec<([f64; 3], [f64; 3], f64)> = order
        .par_chunks(CHUNK)
        .map_init(
            || BatchEvaluator::<f64>::new(field.tape()),
            |batch, chunk| {
                if ctl.cancelled() {
                    return Vec::new();
                }
                let ends: Vec<([f64; 3], f64, [f64; 3], f64)> = chunk
                    .iter()
                    .map(|&i| {
                        let (c, a) = edge_unkey(edges[i]);
                        let mut c1 = c;
                        c1[a] += 1;
                        (grid.point(c), f_lower[i], grid.point(c1), f_upper[i])
                    })
                    .collect();
                let ends = &ends[..];
                let points = crossings(field, batch, ends);
                let mut grads = Vec::new();
                field.gradients_with(batch, &points, GRADIENT_STEP * grid.h, &mut grads);
                points
                    .into_iter()
                    .zip(grads)
                    .map(|(p, (_, g))| (p, normalize(g), norm(g)))
                    .collect::<Vec<_>>()
            },
        )
        .flatten()
        .collect();
    ctl.check()?;

    // One vertex per patch of each cell with a crossed edge. First, each
    // cell's edges' places in `edges`.
    ctl.progress(Stage::Vertices, 0.0);
    let mut cell_edges = vec![[NONE; 12]; cells.len()];
    for e in 0..12 {
        let off = ck[edge_corners(e).0];
        let q: Vec<u64> = cells.iter().map(|&k| (k + off) << 2 | (e / 4) as u64).collect();
        for (ce, i) in cell_edges.iter_mut().zip(lookup(&edges, &q)) {
            ce[e] = i;
        }
    }
    let patches = resolve_faces(&cells, &cell_values);
    let cos_feature = feature_angle_deg.to_radians().cos();
    struct CellOut {
        key: u64,
        patch: [u8; 12],
        count: u8,
        features: usize,
    }
    let indexed: Vec<usize> = (0..cells.len()).collect();
    // Per chunk: its cells, and per vertex its position, mass point and risk.
    type Placed = (Vec<CellOut>, Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<bool>);
    let placed: Vec<Placed> = indexed
        .par_chunks(CHUNK)
        .map_init(
            || BatchEvaluator::<f64>::new(field.tape()),
            |batch, chunk| {
                let mut out = Vec::new();
                if ctl.cancelled() {
                    return (out, Vec::new(), Vec::new(), Vec::new());
                }
                // Start points (QEF fit or mass point), their cells and directions.
                let mut starts: Vec<[f64; 3]> = Vec::new();
                let mut lows: Vec<[f64; 3]> = Vec::new();
                let mut dirs: Vec<Option<([f64; 3], f64)>> = Vec::new();
                let mut masses: Vec<[f64; 3]> = Vec::new();
                for &ci in chunk {
                    let (patch, n) = patches[ci];
                    if n == 0 {
                        continue;
                    }
                    let lo = grid.point(unkey(cells[ci]));
                    let mut features = 0;
                    for p in 0..n {
                        let mut q = Qef::default();
                        let mut normals = [[0.0; 3]; 12];
                        let mut nn = 0;
                        let mut slope = 0.0;
                        for e in 0..12 {
                            let i = cell_edges[ci][e];
                            if patch[e] != p || i == NONE {
                                continue;
                            }
                            let (pt, nm, gm) = crossings[i as usize];
                            if nm == [0.0; 3] {
                                q.add_point(pt);
                                continue;
                            }
                            q.add(pt, nm);
                            normals[nn] = nm;
                            slope += gm;
                            nn += 1;
                        }
                        let normals = &normals[..nn];
                        let sharp = normals
                            .iter()
                            .enumerate()
                            .any(|(i, a)| normals[i + 1..].iter().any(|b| dot(*a, *b) < cos_feature));
                        // A sharp patch's vertex fits the tangent planes; on a
                        // curved feature that point is off the surface by
                        // O(h²κ), so it is projected too (a true edge or
                        // corner is on the surface already and stays).
                        let (x, dir) = if sharp {
                            features += 1;
                            (q.solve(QEF_TRUNCATION), None)
                        } else {
                            let mut m = [0.0; 3];
                            for v in normals {
                                m = [m[0] + v[0], m[1] + v[1], m[2] + v[2]];
                            }
                            let m = normalize(m);
                            // The field's mean slope across the patch seeds the search.
                            (q.mass_point(), (m != [0.0; 3]).then_some((m, slope / nn.max(1) as f64)))
                        };
                        starts.push(x);
                        lows.push(lo);
                        dirs.push(dir);
                        masses.push(q.mass_point());
                    }
                    out.push(CellOut {
                        key: cells[ci],
                        patch,
                        count: n,
                        features,
                    });
                }
                let placed = place(field, batch, &starts, &dirs, &lows, grid.h);
                // Vertices held at their cell's side (their fit or projection
                // wanted to leave the cell) are where folds happen; they keep
                // their mass point as a fallback.
                let risky: Vec<bool> = placed
                    .iter()
                    .zip(&lows)
                    .map(|(p, lo)| {
                        (0..3).any(|k| (p[k] - lo[k]).min(lo[k] + grid.h - p[k]) <= 2.0 * CELL_MARGIN * grid.h)
                    })
                    .collect();
                (out, placed, masses, risky)
            },
        )
        .collect();
    ctl.check()?;
    let mut first = Vec::new();
    let mut positions = Vec::new();
    let mut feature_vertices = 0;
    let mut cell_out = Vec::new();
    let mut masses = Vec::new();
    let mut risky = Vec::new();
    for (cs, ps, ms, rs) in placed {
        masses.extend(ms);
        risky.extend(rs);
        let mut k = positions.len() as u32;
        for c in &cs {
            first.push(k);
            k += c.count as u32;
            feature_vertices += c.features;
        }
        positions.extend(ps);
        cell_out.extend(cs);
    }
    // What the faces do not need any more.
    drop((cell_values, cell_edges, crossings, keys, values, cells));
    let cell_keys: Vec<u64> = cell_out.iter().map(|c| c.key).collect();

    // One quad per crossed edge: its four cells' patches, found per axis and
    // corner of the quad (each a sorted query).
    ctl.progress(Stage::Faces, 0.0);
    let mut quads = vec![[NONE; 4]; edges.len()];
    for side in edge_sides(&edges) {
        for (&i, ci) in side.edges.iter().zip(lookup(&cell_keys, &side.cells)) {
            if ci == NONE {
                continue;
            }
            let p = cell_out[ci as usize].patch[side.local];
            if p != 255 {
                quads[i][side.corner] = first[ci as usize] + p as u32;
            }
        }
    }
    let triangles: Vec<[u32; 3]> = par_gather(&order, |chunk, out| {
        for &i in chunk {
            let mut q = quads[i];
            if q.contains(&NONE) {
                continue;
            }
            let a = (edges[i] & 3) as usize;
            let inside_start = f_lower[i] < 0.0;
            if !inside_start {
                q.reverse();
            }
            let mut axis = [0.0; 3];
            axis[a] = if inside_start { 1.0 } else { -1.0 };
            out.extend(split_quad(&positions, q, axis));
        }
    });
    ctl.progress(Stage::Faces, 1.0);
    let (unfolded, folds_left) = unfold(&mut positions, &triangles, &masses, &mut risky);
    Ok(Contour {
        positions,
        triangles,
        unfolded,
        folds_left,
        missed_cells,
        active_cells,
        feature_vertices,
    })
}

/// Rounds of fold repair.
const UNFOLD_ROUNDS: usize = 4;

/// Undoes folds: where triangles around risky vertices (held at their
/// cell's side) cross other triangles, those vertices go back to their
/// patch's mass point, which lies inside the cell on the marching-cubes
/// polygon; repeated (checking again around every vertex involved) a few
/// rounds. Returns the vertices moved and the crossing pairs left.
fn unfold(
    positions: &mut [[f64; 3]],
    triangles: &[[u32; 3]],
    masses: &[[f64; 3]],
    risky: &mut [bool],
) -> (usize, usize) {
    let around = crate::check::VertexTriangles::new(positions.len(), triangles);
    let mut watch: Vec<u32> = (0..risky.len() as u32).filter(|&v| risky[v as usize]).collect();
    let mut moved = 0;
    let mut left = 0;
    for round in 0..=UNFOLD_ROUNDS {
        if watch.is_empty() {
            left = 0;
            break;
        }
        let pairs = crate::check::crossing_pairs_near(positions, triangles, &around, &watch);
        left = pairs.len();
        if pairs.is_empty() || round == UNFOLD_ROUNDS {
            break;
        }
        let mut next = Vec::new();
        let mut any = false;
        for (a, b) in pairs {
            for t in [a, b] {
                for &v in &triangles[t as usize] {
                    next.push(v);
                    let v = v as usize;
                    if risky[v] {
                        positions[v] = masses[v];
                        risky[v] = false;
                        moved += 1;
                        any = true;
                    }
                }
            }
        }
        if !any {
            break;
        }
        next.sort_unstable();
        next.dedup();
        watch = next;
    }
    (moved, left)
}

/// An edge key (lower corner << 2 | axis) as corner and axis.
fn edge_unkey(k: u64) -> ([u32; 3], usize) {
    (unkey(k >> 2), (k & 3) as usize)
}

/// One of the four cells around the crossed edges along one axis.
struct EdgeSide {
    /// Which corner of the edges' quads (0..4, counter-clockwise seen from
    /// the edges' positive ends).
    corner: usize,
    /// The edges' index in the edge list, in order.
    edges: Vec<usize>,
    /// The cell on this side of each of those edges (sorted keys).
    cells: Vec<u64>,
    /// The edges' local index in those cells.
    local: usize,
}

/// The cells around the crossed edges (sorted keys), per axis and quad
/// corner; edges on the lattice's low sides have no cells there.
fn edge_sides(edges: &[u64]) -> Vec<EdgeSide> {
    let mut sides = Vec::with_capacity(12);
    for a in 0..3 {
        let (b, d) = ((a + 1) % 3, (a + 2) % 3);
        let along: Vec<usize> = (0..edges.len()).filter(|&i| (edges[i] & 3) as usize == a).collect();
        for (corner, (db, dd)) in [(1u32, 1u32), (0, 1), (0, 0), (1, 0)].into_iter().enumerate() {
            let mut off = [0u32; 3];
            off[b] = db;
            off[d] = dd;
            let off_key = key(off);
            let kept: Vec<usize> = along
                .iter()
                .copied()
                .filter(|&i| {
                    let c = unkey(edges[i] >> 2);
                    c[b] >= db && c[d] >= dd
                })
                .collect();
            let cells = kept.iter().map(|&i| (edges[i] >> 2) - off_key).collect();
            sides.push(EdgeSide {
                corner,
                edges: kept,
                cells,
                local: edge_index(a, off),
            });
        }
    }
    sides
}

/// Where the field crosses zero on each segment p0–p1 whose end values f0,
/// f1 have opposite signs: the Illinois variant of regula falsi (it keeps
/// the bracket and converges superlinearly), run over all segments at once
/// with the batch evaluator.
fn crossings<'t>(
    field: &Field<'t>,
    ev: &mut BatchEvaluator<'t, f64>,
    ends: &[([f64; 3], f64, [f64; 3], f64)],
) -> Vec<[f64; 3]> {
    struct Bracket {
        a: f64,
        fa: f64,
        b: f64,
        fb: f64,
        side: i8,
        t: f64,
    }
    let mut br: Vec<Bracket> = ends
        .iter()
        .map(|&(_, f0, _, f1)| Bracket {
            a: 0.0,
            fa: f0,
            b: 1.0,
            fb: f1,
            side: 0,
            t: 0.5,
        })
        .collect();
    let at = |e: &([f64; 3], f64, [f64; 3], f64), t: f64| [0, 1, 2].map(|k| e.0[k] + t * (e.2[k] - e.0[k]));
    let mut pts = Vec::with_capacity(ends.len());
    let mut vals = Vec::new();
    // Converged when |f| is this small (a ten-millionth of the edge for a
    // distance field) or the bracket this narrow.
    let tiny = ends.first().map_or(0.0, |e| {
        let d = [0, 1, 2].map(|k| e.2[k] - e.0[k]);
        1e-7 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
    });
    let mut open: Vec<usize> = (0..br.len()).collect();
    for _ in 0..ROOT_ITERATIONS {
        pts.clear();
        for &i in &open {
            let b = &mut br[i];
            let t = if (b.fa - b.fb).abs() > 0.0 && b.fa.is_finite() && b.fb.is_finite() {
                (b.a * b.fb - b.b * b.fa) / (b.fb - b.fa)
            } else {
                0.5 * (b.a + b.b)
            };
            b.t = if t > b.a && t < b.b { t } else { 0.5 * (b.a + b.b) };
            pts.push(at(&ends[i], b.t));
        }
        field.values_with(ev, &pts, &mut vals);
        let mut still = Vec::with_capacity(open.len());
        for (&i, &ft) in open.iter().zip(&vals) {
            let b = &mut br[i];
            if ft.abs() <= tiny || !ft.is_finite() {
                continue;
            }
            if (ft < 0.0) == (b.fa < 0.0) {
                b.a = b.t;
                b.fa = ft;
                if b.side == -1 {
                    b.fb *= 0.5;
                }
                b.side = -1;
            } else {
                b.b = b.t;
                b.fb = ft;
                if b.side == 1 {
                    b.fa *= 0.5;
                }
                b.side = 1;
            }
            if b.b - b.a >= 1e-9 {
                still.push(i);
            }
        }
        open = still;
        if open.is_empty() {
            break;
        }
    }
    br.iter().zip(ends).map(|(b, e)| at(e, b.t)).collect()
}

/// Moves start points onto the surface, inside their cells: along the
/// patch's mean normal by a secant search where one is given (smooth
/// patches: one value per step), else by Newton steps along the gradient
/// (sharp patches).
fn place<'t>(
    field: &Field<'t>,
    ev: &mut BatchEvaluator<'t, f64>,
    starts: &[[f64; 3]],
    dirs: &[Option<([f64; 3], f64)>],
    lows: &[[f64; 3]],
    h: f64,
) -> Vec<[f64; 3]> {
    let mut out: Vec<[f64; 3]> = starts
        .iter()
        .zip(lows)
        .map(|(&x, &lo)| clamp_to_cell(x, lo, h))
        .collect();
    // Line searches: x(s) = start + s·n, secant on f(x(s)).
    struct Line {
        i: usize,
        n: [f64; 3],
        s: f64,
        slope: f64,
        prev: Option<(f64, f64)>,
    }
    let mut lines: Vec<Line> = Vec::new();
    let mut newton: Vec<usize> = Vec::new();
    for (i, d) in dirs.iter().enumerate() {
        match d {
            Some((n, slope)) => lines.push(Line {
                i,
                n: *n,
                s: 0.0,
                slope: if *slope > 1e-9 { *slope } else { 1.0 },
                prev: None,
            }),
            None => newton.push(i),
        }
    }
    let tiny = 1e-7 * h;
    let mut pts = Vec::new();
    let mut vals = Vec::new();
    for _ in 0..LINE_STEPS {
        if lines.is_empty() {
            break;
        }
        pts.clear();
        pts.extend(lines.iter().map(|l| out[l.i]));
        field.values_with(ev, &pts, &mut vals);
        let mut still = Vec::with_capacity(lines.len());
        for (mut l, &f) in lines.into_iter().zip(&vals) {
            if !f.is_finite() || f.abs() <= tiny {
                continue;
            }
            // Secant on the previous sample, or the slope seen at the crossings.
            let slope = match l.prev {
                Some((s0, f0)) if (f - f0).abs() > 0.0 && l.s != s0 => (f - f0) / (l.s - s0),
                _ => l.slope,
            };
            if slope.abs() <= 1e-6 || slope.is_nan() {
                continue;
            }
            let s_next = l.s - f / slope;
            if (s_next - l.s).abs() > 2.0 * h {
                continue;
            }
            l.prev = Some((l.s, f));
            l.s = s_next;
            let st = starts[l.i];
            let next = clamp_to_cell(
                [st[0] + l.s * l.n[0], st[1] + l.s * l.n[1], st[2] + l.s * l.n[2]],
                lows[l.i],
                h,
            );
            let moved = dot(sub(next, out[l.i]), sub(next, out[l.i]));
            out[l.i] = next;
            // Where the cell held the point, the search goes on from where it is.
            l.s = dot(sub(next, st), l.n);
            if moved > 1e-20 * h * h {
                still.push(l);
            }
        }
        lines = still;
    }
    if !newton.is_empty() {
        let s: Vec<[f64; 3]> = newton.iter().map(|&i| out[i]).collect();
        let l: Vec<[f64; 3]> = newton.iter().map(|&i| lows[i]).collect();
        for (&i, p) in newton.iter().zip(project(field, ev, &s, &l, h)) {
            out[i] = p;
        }
    }
    out
}

/// Newton steps along the gradient towards the surface, for many points
/// at once, each kept inside the cell whose lowest corner is in `lows`: the
/// point of the cell nearest the surface along the gradient flow.
fn project<'t>(
    field: &Field<'t>,
    ev: &mut BatchEvaluator<'t, f64>,
    starts: &[[f64; 3]],
    lows: &[[f64; 3]],
    h: f64,
) -> Vec<[f64; 3]> {
    let mut p: Vec<[f64; 3]> = starts
        .iter()
        .zip(lows)
        .map(|(&x, &lo)| clamp_to_cell(x, lo, h))
        .collect();
    // Per point: where it was and |f| there, to undo a step that made it worse.
    let mut last: Vec<([f64; 3], f64)> = p.iter().map(|&x| (x, f64::INFINITY)).collect();
    let mut open: Vec<usize> = (0..p.len()).collect();
    let mut pts = Vec::new();
    let mut grads = Vec::new();
    let eps = GRADIENT_STEP * h;
    for _ in 0..=PROJECTION_STEPS {
        if open.is_empty() {
            break;
        }
        pts.clear();
        pts.extend(open.iter().map(|&i| p[i]));
        field.gradients_with(ev, &pts, eps, &mut grads);
        let mut still = Vec::with_capacity(open.len());
        for (&i, &(f, g)) in open.iter().zip(&grads) {
            if f.abs() >= last[i].1 || f.is_nan() {
                // Worse than before the step (a kink): keep the earlier point.
                p[i] = last[i].0;
                continue;
            }
            let g2 = dot(g, g);
            // Below a few stencil steps the differences cannot resolve |f|.
            if g2 <= 1e-18 || g2.is_nan() || !f.is_finite() || f.abs() <= 4.0 * eps {
                continue;
            }
            last[i] = (p[i], f.abs());
            let s = f / g2;
            let next = clamp_to_cell([p[i][0] - g[0] * s, p[i][1] - g[1] * s, p[i][2] - g[2] * s], lows[i], h);
            let moved = dot(sub(next, p[i]), sub(next, p[i]));
            p[i] = next;
            if moved > 1e-20 * h * h {
                still.push(i);
            }
        }
        open = still;
    }
    p
}

fn clamp_to_cell(x: [f64; 3], lo: [f64; 3], h: f64) -> [f64; 3] {
    let m = CELL_MARGIN * h;
    [0, 1, 2].map(|k| {
        let v = if x[k].is_finite() { x[k] } else { lo[k] + 0.5 * h };
        v.clamp(lo[k] + m, lo[k] + h - m)
    })
}

/// Splits a quad into two triangles along the diagonal that gives the
/// better pair: neither folded against the quad's direction, least sliver-like.
fn split_quad(pos: &[[f64; 3]], q: [u32; 4], axis: [f64; 3]) -> [[u32; 3]; 2] {
    let quality = |t: [u32; 3]| {
        let [a, b, c] = t.map(|i| pos[i as usize]);
        let n = cross(sub(b, a), sub(c, a));
        let perim2 = dot(sub(b, a), sub(b, a)) + dot(sub(c, b), sub(c, b)) + dot(sub(a, c), sub(a, c));
        // Signed: negative when the triangle faces against the edge direction.
        dot(n, axis).signum() * norm(n) / perim2.max(1e-300)
    };
    let s1 = [[q[0], q[1], q[2]], [q[0], q[2], q[3]]];
    let s2 = [[q[0], q[1], q[3]], [q[1], q[2], q[3]]];
    let m1 = quality(s1[0]).min(quality(s1[1]));
    let m2 = quality(s2[0]).min(quality(s2[1]));
    if m2 > m1 {
        s2
    } else {
        s1
    }
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

pub(crate) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = norm(a);
    if n > 0.0 && n.is_finite() {
        a.map(|v| v / n)
    } else {
        [0.0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_crossed_edge_has_two_face_links_and_loops_close() {
        // All 256 sign configurations, with ambiguous faces resolved both ways.
        for mask in 0u32..256 {
            for bias in [-0.3, 0.3] {
                let v: [f64; 8] = std::array::from_fn(|c| {
                    if mask >> c & 1 == 1 {
                        -1.0 + bias * (c as f64 / 8.0)
                    } else {
                        1.0
                    }
                });
                let (patch, n) = cell_patches(&v);
                let crossed = (0..12)
                    .filter(|&e| {
                        let (a, b) = edge_corners(e);
                        (v[a] < 0.0) != (v[b] < 0.0)
                    })
                    .count();
                assert_eq!(patch.iter().filter(|&&p| p != 255).count(), crossed, "mask {mask:08b}");
                // Every patch has at least three edges (a closed polygon).
                for p in 0..n {
                    assert!(patch.iter().filter(|&&x| x == p).count() >= 3, "mask {mask:08b}");
                }
                if mask == 0 || mask == 255 {
                    assert_eq!(n, 0);
                }
            }
        }
    }

    #[test]
    fn known_configurations_have_the_textbook_patch_counts() {
        let cell = |inside: &[usize]| {
            let v: [f64; 8] = std::array::from_fn(|c| if inside.contains(&c) { -1.0 } else { 1.0 });
            cell_patches(&v).1
        };
        assert_eq!(cell(&[0]), 1); // one corner: a triangle
        assert_eq!(cell(&[0, 1]), 1); // one edge: a quad
        assert_eq!(cell(&[0, 7]), 2); // opposite corners: two triangles
        assert_eq!(cell(&[0, 1, 2, 3]), 1); // a face: a plane
    }

    #[test]
    fn edge_tables_agree() {
        for e in 0..12 {
            let (c0, c1) = edge_corners(e);
            let a = e / 4;
            assert_eq!(edge_index(a, CORNER[c0]), e);
            assert_eq!(c1, c0 | 1 << a);
        }
        for a in 0..3 {
            for s in 0..2 {
                let (c, e) = face(a, s);
                for i in 0..4 {
                    let (x, y) = edge_corners(e[i]);
                    let ends = [c[i], c[(i + 1) % 4]];
                    assert!(ends.contains(&x) && ends.contains(&y));
                }
            }
        }
    }
}
