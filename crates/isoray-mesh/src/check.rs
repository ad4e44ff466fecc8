//! Self-intersection detection: pairs of triangles that cross each other.
//!
//! Triangles are binned on a uniform grid by their bounding boxes; each pair
//! that shares a bin is tested exactly once. Pairs with no common vertex
//! intersect when an edge of one passes through the other; pairs that share
//! one vertex intersect when the edge opposite the shared vertex of one
//! passes through the other (a fold). Pairs that share an edge are
//! neighbours and are not tested.

use crate::mesh::{cross, dot, sub, Mesh};
use rayon::prelude::*;
use std::collections::HashMap;

/// The pairs of triangles (by index, smaller first) that intersect, sorted.
pub fn self_intersections(mesh: &Mesh) -> Vec<(u32, u32)> {
    let positions: Vec<[f64; 3]> = mesh.positions.iter().map(|p| p.map(f64::from)).collect();
    crossing_pairs(&positions, &mesh.triangles)
}

/// The crossing pairs of triangles, each pair tested once, in the bin that
/// holds the low corner of the overlap of their boxes.
fn crossing_pairs(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<(u32, u32)> {
    let n = triangles.len();
    if n < 2 {
        return Vec::new();
    }
    let corners = |i: usize| triangles[i].map(|v| positions[v as usize]);
    let bbox = |i: usize| bounding_box(&corners(i));
    let extent = |i: usize| {
        let b = bbox(i);
        (0..3).map(|k| b[1][k] - b[0][k]).fold(0.0, f64::max)
    };
    // Bin size: twice the mean box extent, but no triangle in more than
    // about 17³ bins (a few huge triangles among small ones).
    let extents: Vec<f64> = (0..n).map(extent).collect();
    let mean = extents.iter().sum::<f64>() / n as f64;
    let largest = extents.iter().copied().fold(0.0, f64::max);
    let size = (2.0 * mean).max(largest / 16.0).max(1e-12);
    let bin = |p: [f64; 3]| p.map(|v| (v / size).floor() as i64);
    let mut bins: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for i in 0..n {
        let b = bbox(i);
        let (lo, hi) = (bin(b[0]), bin(b[1]));
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    bins.entry([x, y, z]).or_default().push(i as u32);
                }
            }
        }
    }
    let all: Vec<u32> = (0..n as u32).collect();
    let mut pairs: Vec<(u32, u32)> = all
        .par_chunks(4096)
        .flat_map_iter(|chunk| {
            let mut found = Vec::new();
            for &a in chunk {
                let ba = bbox(a as usize);
                let (lo, hi) = (bin(ba[0]), bin(ba[1]));
                for x in lo[0]..=hi[0] {
                    for y in lo[1]..=hi[1] {
                        for z in lo[2]..=hi[2] {
                            let cell = [x, y, z];
                            let Some(list) = bins.get(&cell) else { continue };
                            for &b in list {
                                // Each pair once: from its smaller index.
                                if b <= a {
                                    continue;
                                }
                                let bb = bbox(b as usize);
                                if (0..3).any(|k| ba[1][k] < bb[0][k] || bb[1][k] < ba[0][k]) {
                                    continue;
                                }
                                let low = [0, 1, 2].map(|k| ba[0][k].max(bb[0][k]));
                                if bin(low) != cell {
                                    continue;
                                }
                                let (ta, tb) = (corners(a as usize), corners(b as usize));
                                if triangles_intersect(triangles[a as usize], triangles[b as usize], &ta, &tb) {
                                    found.push((a.min(b), a.max(b)));
                                }
                            }
                        }
                    }
                }
            }
            found.into_iter()
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// Rings of triangles around a watched vertex that fold repair tests.
const RINGS: usize = 1;

/// Vertex → incident triangles, in compressed rows.
pub(crate) struct VertexTriangles {
    start: Vec<u32>,
    list: Vec<u32>,
}

impl VertexTriangles {
    /// The incidence of `triangles` over `vertices` vertices.
    pub(crate) fn new(vertices: usize, triangles: &[[u32; 3]]) -> Self {
        let mut start = vec![0u32; vertices + 1];
        for t in triangles {
            for &v in t {
                start[v as usize + 1] += 1;
            }
        }
        for i in 0..vertices {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut list = vec![0u32; start[vertices] as usize];
        for (i, t) in triangles.iter().enumerate() {
            for &v in t {
                list[fill[v as usize] as usize] = i as u32;
                fill[v as usize] += 1;
            }
        }
        VertexTriangles { start, list }
    }

    /// The triangles around vertex `v`.
    pub(crate) fn of(&self, v: u32) -> &[u32] {
        &self.list[self.start[v as usize] as usize..self.start[v as usize + 1] as usize]
    }
}

/// The crossing pairs in which one triangle touches a `watch`ed vertex and
/// the other lies within [`RINGS`] ring(s) of triangles around it: the local test
/// of fold repair (folds of dual contouring stay within a few cells).
pub(crate) fn crossing_pairs_near(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    around: &VertexTriangles,
    watch: &[u32],
) -> Vec<(u32, u32)> {
    let corners = |i: u32| triangles[i as usize].map(|v| positions[v as usize]);
    let bbox = bounding_box;
    let mut pairs: Vec<(u32, u32)> = watch
        .par_iter()
        .flat_map_iter(|&v| {
            let near: Vec<u32> = around.of(v).to_vec();
            // Two rings of triangles around v.
            let mut ring: Vec<u32> = Vec::new();
            let mut frontier = near.clone();
            for _ in 0..RINGS {
                let mut next = Vec::new();
                for &t in &frontier {
                    for &w in &triangles[t as usize] {
                        next.extend_from_slice(around.of(w));
                    }
                }
                next.sort_unstable();
                next.dedup();
                frontier = next.clone();
                ring.extend(next);
            }
            ring.sort_unstable();
            ring.dedup();
            let mut found = Vec::new();
            for &a in &near {
                let ta = corners(a);
                let ba = bbox(&ta);
                for &b in &ring {
                    if b == a {
                        continue;
                    }
                    let tb = corners(b);
                    let bb = bbox(&tb);
                    if (0..3).any(|k| ba[1][k] < bb[0][k] || bb[1][k] < ba[0][k]) {
                        continue;
                    }
                    if triangles_intersect(triangles[a as usize], triangles[b as usize], &ta, &tb) {
                        found.push((a.min(b), a.max(b)));
                    }
                }
            }
            found.into_iter()
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// A triangle's axis-aligned bounding box, [min, max].
fn bounding_box(t: &[[f64; 3]; 3]) -> [[f64; 3]; 2] {
    let mut b = [t[0], t[0]];
    for p in &t[1..] {
        for k in 0..3 {
            b[0][k] = b[0][k].min(p[k]);
            b[1][k] = b[1][k].max(p[k]);
        }
    }
    b
}

fn triangles_intersect(ta: [u32; 3], tb: [u32; 3], pa: &[[f64; 3]; 3], pb: &[[f64; 3]; 3]) -> bool {
    let shared: Vec<(usize, usize)> = (0..3)
        .flat_map(|i| (0..3).map(move |j| (i, j)))
        .filter(|&(i, j)| ta[i] == tb[j])
        .collect();
    match shared.len() {
        0 => {
            (0..3).any(|i| segment_hits(pa[i], pa[(i + 1) % 3], pb))
                || (0..3).any(|i| segment_hits(pb[i], pb[(i + 1) % 3], pa))
        }
        1 => {
            let (i, j) = shared[0];
            segment_hits(pa[(i + 1) % 3], pa[(i + 2) % 3], pb) || segment_hits(pb[(j + 1) % 3], pb[(j + 2) % 3], pa)
        }
        _ => false,
    }
}

/// True when the segment p–q passes through the interior of triangle t
/// (touching at the segment's ends or the triangle's border does not count).
fn segment_hits(p: [f64; 3], q: [f64; 3], t: &[[f64; 3]; 3]) -> bool {
    const EPS: f64 = 1e-9;
    let d = sub(q, p);
    let (e1, e2) = (sub(t[1], t[0]), sub(t[2], t[0]));
    let h = cross(d, e2);
    let det = dot(e1, h);
    let scale = dot(e1, e1).max(dot(e2, e2)) * dot(d, d).sqrt();
    if det.abs() <= 1e-12 * scale {
        return false; // parallel (coplanar overlaps are not reported)
    }
    let inv = 1.0 / det;
    let s = sub(p, t[0]);
    let u = dot(s, h) * inv;
    if u <= EPS || u >= 1.0 - EPS {
        return false;
    }
    let qv = cross(s, e1);
    let v = dot(d, qv) * inv;
    if v <= EPS || u + v >= 1.0 - EPS {
        return false;
    }
    let tt = dot(e2, qv) * inv;
    tt > EPS && tt < 1.0 - EPS
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh(tris: &[[[f32; 3]; 3]]) -> Mesh {
        let mut m = Mesh::default();
        for t in tris {
            let base = m.positions.len() as u32;
            m.positions.extend_from_slice(t);
            m.triangles.push([base, base + 1, base + 2]);
        }
        m
    }

    #[test]
    fn crossing_triangles_are_found_and_separate_ones_are_not() {
        let a = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let crossing = [[0.2, 0.2, -0.5], [0.3, 0.2, 0.5], [0.2, 0.3, 0.5]];
        let apart = [[0.2, 0.2, 0.1], [0.3, 0.2, 0.5], [0.2, 0.3, 0.5]];
        assert_eq!(self_intersections(&mesh(&[a, crossing])), vec![(0, 1)]);
        assert!(self_intersections(&mesh(&[a, apart])).is_empty());
    }

    #[test]
    fn a_fold_through_a_shared_vertex_is_found() {
        // Two triangles sharing vertex 0; the second folds through the first.
        let mut m = Mesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [0.0, 2.0, 0.0],
                [1.0, 1.0, -0.5],
                [0.5, 0.1, 0.5],
            ],
            ..Default::default()
        };
        m.triangles = vec![[0, 1, 2], [0, 3, 4]];
        assert_eq!(self_intersections(&m), vec![(0, 1)]);
        // Lifted clear of the first triangle: no intersection.
        m.positions[3] = [1.0, 1.0, 0.2];
        assert!(self_intersections(&m).is_empty());
    }
}
