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
    let inside = |c: usize| v[c] < 0.0;
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
            let crossed: Vec<usize> = (0..4).filter(|&i| inside(c[i]) != inside(c[(i + 1) % 4])).collect();
            match crossed.len() {
                2 => link(e[crossed[0]], e[crossed[1]]),
                4 => {
                    // Corners 0 and 2 share a sign. The bilinear saddle value
                    // decides whether they connect through the face.
                    let (f0, f1, f2, f3) = (v[c[0]], v[c[1]], v[c[2]], v[c[3]]);
                    let saddle = (f0 * f2 - f1 * f3) / (f0 + f2 - f1 - f3);
                    let connected_02 = (saddle < 0.0) == inside(c[0]);
                    if connected_02 {
                        // Cut off corners 1 and 3.
                        link(e[0], e[1]);
                        link(e[2], e[3]);
                    } else {
                        // Cut off corners 0 and 2.
                        link(e[3], e[0]);
                        link(e[1], e[2]);
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
}

/// Sorted lattice keys with values.
struct Samples {
    keys: Vec<u64>,
    values: Vec<f64>,
}

impl Samples {
    fn get(&self, k: u64) -> f64 {
        match self.keys.binary_search(&k) {
            Ok(i) => self.values[i],
            Err(_) => f64::INFINITY,
        }
    }
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
    let mut samples = Samples {
        keys: Vec::new(),
        values: Vec::new(),
    };
    let mut missed_cells = 0;
    let mut cell_values: Vec<[f64; 8]>;
    // Corners and crossed edges; repeated when a crossed edge's neighbour
    // cells were not all active (the distance bound overestimated).
    let edges = loop {
        ctl.check()?;
        ctl.progress(Stage::Corners, 0.0);
        let mut corners: Vec<u64> = cells
            .par_iter()
            .flat_map_iter(|&k| {
                let c = unkey(k);
                CORNER.iter().map(move |o| key([c[0] + o[0], c[1] + o[1], c[2] + o[2]]))
            })
            .collect();
        corners.par_sort_unstable();
        corners.dedup();
        let new: Vec<u64> = corners
            .iter()
            .copied()
            .filter(|k| samples.keys.binary_search(k).is_err())
            .collect();
        let pts: Vec<[f64; 3]> = new.iter().map(|&k| grid.point(unkey(k))).collect();
        let mut vals = field.values(&pts);
        for (v, &k) in vals.iter_mut().zip(&new) {
            if grid.on_boundary(unkey(k)) {
                *v = v.max(0.0);
            }
        }
        let mut merged: Vec<(u64, f64)> = samples
            .keys
            .iter()
            .copied()
            .zip(samples.values.iter().copied())
            .collect();
        merged.extend(new.into_iter().zip(vals));
        merged.par_sort_unstable_by_key(|p| p.0);
        samples = Samples {
            keys: merged.iter().map(|p| p.0).collect(),
            values: merged.iter().map(|p| p.1).collect(),
        };
        ctl.check()?;
        ctl.progress(Stage::Edges, 0.0);
        cell_values = cells
            .par_iter()
            .map(|&k| {
                let c = unkey(k);
                CORNER.map(|o| samples.get(key([c[0] + o[0], c[1] + o[1], c[2] + o[2]])))
            })
            .collect();
        let mut edges: Vec<u64> = cells
            .par_iter()
            .zip(&cell_values)
            .flat_map_iter(|(&k, &v)| {
                let c = unkey(k);
                (0..12).filter_map(move |e| {
                    let (c0, c1) = edge_corners(e);
                    ((v[c0] < 0.0) != (v[c1] < 0.0)).then(|| {
                        let o = CORNER[c0];
                        edge_key([c[0] + o[0], c[1] + o[1], c[2] + o[2]], e / 4)
                    })
                })
            })
            .collect();
        edges.par_sort_unstable();
        edges.dedup();
        let mut missing: Vec<u64> = edges
            .par_iter()
            .flat_map_iter(|&ek| edge_cells(ek).into_iter().flatten())
            .filter(|k| cells.binary_search(k).is_err())
            .collect();
        missing.sort_unstable();
        missing.dedup();
        if missing.is_empty() {
            break edges;
        }
        missed_cells += missing.len();
        cells.extend(missing);
        cells.sort_unstable();
    };

    // Crossings: point and normal on every crossed edge.
    ctl.check()?;
    ctl.progress(Stage::Edges, 0.5);
    let crossings: Vec<([f64; 3], [f64; 3])> = edges
        .par_chunks(CHUNK)
        .map_init(
            || BatchEvaluator::<f64>::new(field.tape()),
            |batch, chunk| {
                if ctl.cancelled() {
                    return Vec::new();
                }
                let ends: Vec<([f64; 3], f64, [f64; 3], f64)> = chunk
                    .iter()
                    .map(|&ek| {
                        let (c, a) = edge_unkey(ek);
                        let mut c1 = c;
                        c1[a] += 1;
                        (grid.point(c), samples.get(key(c)), grid.point(c1), samples.get(key(c1)))
                    })
                    .collect();
                let points = crossings(field, batch, &ends);
                let mut grads = Vec::new();
                field.gradients_with(batch, &points, GRADIENT_STEP * grid.h, &mut grads);
                points
                    .into_iter()
                    .zip(grads)
                    .map(|(p, (_, g))| (p, normalize(g)))
                    .collect::<Vec<_>>()
            },
        )
        .flatten()
        .collect();
    ctl.check()?;

    // One vertex per patch of each cell with a crossed edge.
    ctl.progress(Stage::Vertices, 0.0);
    let cos_feature = feature_angle_deg.to_radians().cos();
    struct CellOut {
        key: u64,
        patch: [u8; 12],
        vertices: Vec<[f64; 3]>,
        features: usize,
    }
    let cell_out: Vec<CellOut> = cells
        .par_chunks(CHUNK)
        .zip(cell_values.par_chunks(CHUNK))
        .map_init(
            || BatchEvaluator::<f64>::new(field.tape()),
            |batch, (chunk, values)| {
                let mut out = Vec::new();
                if ctl.cancelled() {
                    return out;
                }
                // Start points (QEF fit or mass point) and their cells.
                let mut starts: Vec<[f64; 3]> = Vec::new();
                let mut lows: Vec<[f64; 3]> = Vec::new();
                for (&k, v) in chunk.iter().zip(values) {
                    let c = unkey(k);
                    let (patch, n) = cell_patches(v);
                    if n == 0 {
                        continue;
                    }
                    let lo = grid.point(c);
                    let mut features = 0;
                    for p in 0..n {
                        let mut q = Qef::default();
                        let mut normals: Vec<[f64; 3]> = Vec::with_capacity(6);
                        for e in 0..12 {
                            if patch[e] != p {
                                continue;
                            }
                            let a = e / 4;
                            let o = CORNER[edge_corners(e).0];
                            let ek = edge_key([c[0] + o[0], c[1] + o[1], c[2] + o[2]], a);
                            let Ok(i) = edges.binary_search(&ek) else {
                                continue;
                            };
                            let (pt, nm) = crossings[i];
                            if nm == [0.0; 3] {
                                q.add_point(pt);
                                continue;
                            }
                            q.add(pt, nm);
                            normals.push(nm);
                        }
                        let sharp = normals
                            .iter()
                            .enumerate()
                            .any(|(i, a)| normals[i + 1..].iter().any(|b| dot(*a, *b) < cos_feature));
                        // A sharp patch's vertex fits the tangent planes; on a
                        // curved feature that point is off the surface by
                        // O(h²κ), so it is projected too (a true edge or
                        // corner is on the surface already and stays).
                        let x = if sharp {
                            features += 1;
                            q.solve(QEF_TRUNCATION)
                        } else {
                            q.mass_point()
                        };
                        starts.push(x);
                        lows.push(lo);
                    }
                    out.push(CellOut {
                        key: k,
                        patch,
                        vertices: Vec::new(),
                        features,
                    });
                }
                let mut placed = project(field, batch, &starts, &lows, grid.h).into_iter();
                for c in &mut out {
                    let n = c
                        .patch
                        .iter()
                        .filter(|&&p| p != 255)
                        .max()
                        .map_or(0, |&p| p as usize + 1);
                    c.vertices.extend(placed.by_ref().take(n));
                }
                out
            },
        )
        .flatten()
        .collect();
    ctl.check()?;
    let mut first = Vec::with_capacity(cell_out.len());
    let mut positions = Vec::new();
    let mut feature_vertices = 0;
    for c in &cell_out {
        first.push(positions.len() as u32);
        positions.extend_from_slice(&c.vertices);
        feature_vertices += c.features;
    }
    let cell_keys: Vec<u64> = cell_out.iter().map(|c| c.key).collect();
    let vertex_of = |cell: [u32; 3], e: usize| -> Option<u32> {
        let i = cell_keys.binary_search(&key(cell)).ok()?;
        let p = cell_out[i].patch[e];
        (p != 255).then(|| first[i] + p as u32)
    };

    // One quad per crossed edge.
    ctl.progress(Stage::Faces, 0.0);
    let triangles: Vec<[u32; 3]> = edges
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut out = Vec::with_capacity(chunk.len() * 2);
            for &ek in chunk {
                let (c, a) = edge_unkey(ek);
                let Some(cells4) = edge_cells(ek) else { continue };
                let quad: Option<Vec<u32>> = cells4
                    .iter()
                    .map(|&ck| {
                        let cc = unkey(ck);
                        let mut o = [0u32; 3];
                        for k in 0..3 {
                            o[k] = c[k] - cc[k];
                        }
                        vertex_of(cc, edge_index(a, o))
                    })
                    .collect();
                let Some(mut q) = quad else { continue };
                let inside_start = samples.get(key(c)) < 0.0;
                if !inside_start {
                    q.reverse();
                }
                let q = [q[0], q[1], q[2], q[3]];
                let axis = {
                    let mut d = [0.0; 3];
                    d[a] = if inside_start { 1.0 } else { -1.0 };
                    d
                };
                out.extend(split_quad(&positions, q, axis));
            }
            out
        })
        .flatten()
        .collect();
    ctl.progress(Stage::Faces, 1.0);
    Ok(Contour {
        positions,
        triangles,
        missed_cells,
        active_cells,
        feature_vertices,
    })
}

/// Packs an edge: its lower corner and its axis.
fn edge_key(c: [u32; 3], a: usize) -> u64 {
    key(c) << 2 | a as u64
}

fn edge_unkey(k: u64) -> ([u32; 3], usize) {
    (unkey(k >> 2), (k & 3) as usize)
}

/// The four cells around an edge, in counter-clockwise order seen from the
/// edge's positive end (None at the lattice's low sides).
fn edge_cells(ek: u64) -> Option<[u64; 4]> {
    let (c, a) = edge_unkey(ek);
    let (b, d) = ((a + 1) % 3, (a + 2) % 3);
    if c[b] == 0 || c[d] == 0 {
        return None;
    }
    let at = |db: u32, dd: u32| {
        let mut o = c;
        o[b] -= db;
        o[d] -= dd;
        key(o)
    };
    Some([at(1, 1), at(0, 1), at(0, 0), at(1, 0)])
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
