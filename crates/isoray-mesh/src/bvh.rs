//! A bounding volume hierarchy over a mesh's triangles, for ray casting:
//! the nearest hit along a ray ([`Bvh::closest`], Möller–Trumbore
//! intersection) and whether anything lies on a segment ([`Bvh::any`],
//! for shadow rays).
//!
//! The tree is built top-down with the surface area heuristic over 12
//! bins of triangle centroids, and stored flat, depth-first: an interior
//! node's left child follows it and its right child is named, so the same
//! arrays serve the CPU tracer and a GPU shader.
//!
//! ```
//! use isoray_mesh::bvh::Bvh;
//! use isoray_mesh::Mesh;
//!
//! // A unit square in the z = 0 plane, as two triangles.
//! let mesh = Mesh {
//!     positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
//!     triangles: vec![[0, 1, 2], [0, 2, 3]],
//!     ..Mesh::default()
//! };
//! let bvh = Bvh::build(&mesh);
//! let hit = bvh.closest([0.25, 0.5, 2.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY).unwrap();
//! assert_eq!(hit.t, 2.0);
//! assert!(bvh.any([0.25, 0.5, 2.0], [0.0, 0.0, -1.0], 0.0, 3.0));
//! assert!(!bvh.any([0.25, 0.5, 2.0], [0.0, 0.0, -1.0], 0.0, 1.5));
//! ```

use glam::Vec3;

use crate::Mesh;

/// A node of the flattened tree (32 bytes, the layout a GPU buffer holds).
///
/// `count == 0`: an interior node; its left child is the next node and its
/// right child is node `index`. `count > 0`: a leaf of the `count`
/// triangles from `index` on in [`Bvh::triangles`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct BvhNode {
    /// The box's lower corner.
    pub min: [f32; 3],
    /// The right child (interior) or the first triangle (leaf).
    pub index: u32,
    /// The box's upper corner.
    pub max: [f32; 3],
    /// Triangles in the leaf; 0 for an interior node.
    pub count: u32,
}

/// Where a ray meets a triangle: p = o + t·d = (1 − u − v)·a + u·b + v·c
/// for the triangle's corners a, b, c as the mesh lists them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangleHit {
    /// Distance along the ray (in units of its direction's length).
    pub t: f32,
    /// Barycentric weight of the second corner.
    pub u: f32,
    /// Barycentric weight of the third corner.
    pub v: f32,
    /// The triangle's index in the mesh.
    pub triangle: u32,
}

/// The hierarchy over one mesh (see the module documentation).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    tris: Vec<[[f32; 3]; 3]>,
    order: Vec<u32>,
}

/// Bins of the surface area heuristic.
const BINS: usize = 12;
/// A leaf never holds more triangles than this, whatever the heuristic says.
const MAX_LEAF: usize = 8;
/// The depth of the traversal stack (the tree is at most this deep).
const STACK: usize = 64;

#[derive(Clone, Copy)]
struct Aabb {
    min: Vec3,
    max: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };
    fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    fn join(&mut self, b: &Aabb) {
        self.min = self.min.min(b.min);
        self.max = self.max.max(b.max);
    }
    fn area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

struct Prim {
    bounds: Aabb,
    centre: Vec3,
    index: u32,
}

impl Bvh {
    /// Builds the hierarchy over `mesh`'s triangles (in the mesh's own
    /// coordinates). Degenerate triangles are kept; rays never hit them.
    pub fn build(mesh: &Mesh) -> Bvh {
        let mut prims: Vec<Prim> = mesh
            .triangles
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let mut b = Aabb::EMPTY;
                for &k in t {
                    b.grow(Vec3::from(mesh.positions[k as usize]));
                }
                Prim {
                    bounds: b,
                    centre: 0.5 * (b.min + b.max),
                    index: i as u32,
                }
            })
            .collect();
        let mut bvh = Bvh::default();
        if prims.is_empty() {
            return bvh;
        }
        bvh.nodes.reserve(2 * prims.len());
        bvh.split(&mut prims, 0);
        bvh.order = prims.iter().map(|p| p.index).collect();
        bvh.tris = bvh
            .order
            .iter()
            .map(|&i| mesh.triangles[i as usize].map(|k| mesh.positions[k as usize]))
            .collect();
        bvh
    }

    /// Builds the subtree over `prims` (which start at `first` in leaf
    /// order) and returns its node index.
    fn split(&mut self, prims: &mut [Prim], first: usize) -> usize {
        let mut bounds = Aabb::EMPTY;
        let mut centres = Aabb::EMPTY;
        for p in prims.iter() {
            bounds.join(&p.bounds);
            centres.grow(p.centre);
        }
        let node = self.nodes.len();
        self.nodes.push(BvhNode {
            min: bounds.min.to_array(),
            index: first as u32,
            max: bounds.max.to_array(),
            count: prims.len() as u32,
        });
        let n = prims.len();
        if n <= 2 {
            return node;
        }
        let extent = centres.max - centres.min;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        // None: split at the median centroid along the axis.
        let mid = if extent[axis] <= 0.0 {
            // Every centroid at one place: no plane separates them.
            if n <= MAX_LEAF {
                return node;
            }
            None
        } else {
            let lo = centres.min[axis];
            let scale = BINS as f32 / extent[axis];
            let bin_of = |p: &Prim| (((p.centre[axis] - lo) * scale) as usize).min(BINS - 1);
            let mut bins = [(Aabb::EMPTY, 0usize); BINS];
            for p in prims.iter() {
                let b = &mut bins[bin_of(p)];
                b.0.join(&p.bounds);
                b.1 += 1;
            }
            // Cost of each split plane between bins: areas × counts of both sides.
            let mut left = [(0.0f32, 0usize); BINS - 1];
            let (mut acc, mut count) = (Aabb::EMPTY, 0);
            for i in 0..BINS - 1 {
                acc.join(&bins[i].0);
                count += bins[i].1;
                left[i] = (acc.area(), count);
            }
            let (mut acc, mut count) = (Aabb::EMPTY, 0);
            let mut best = (f32::INFINITY, 0usize);
            for i in (0..BINS - 1).rev() {
                acc.join(&bins[i + 1].0);
                count += bins[i + 1].1;
                let (la, lc) = left[i];
                if lc == 0 || count == 0 {
                    continue;
                }
                let cost = la * lc as f32 + acc.area() * count as f32;
                if cost < best.0 {
                    best = (cost, i);
                }
            }
            // A leaf costs its triangles; a split, one box test and its children.
            let split_cost = 0.5 + best.0 / bounds.area().max(f32::MIN_POSITIVE);
            if best.0.is_infinite() || (split_cost >= n as f32 && n <= MAX_LEAF) {
                if n <= MAX_LEAF {
                    return node;
                }
                None
            } else {
                let plane = best.1;
                let mut i = 0;
                for j in 0..n {
                    if bin_of(&prims[j]) <= plane {
                        prims.swap(i, j);
                        i += 1;
                    }
                }
                Some(i)
            }
        };
        let mid = mid.unwrap_or_else(|| {
            prims.select_nth_unstable_by(n / 2, |a, b| a.centre[axis].total_cmp(&b.centre[axis]));
            n / 2
        });
        let (l, r) = prims.split_at_mut(mid);
        self.split(l, first);
        let right = self.split(r, first + mid);
        self.nodes[node].index = right as u32;
        self.nodes[node].count = 0;
        node
    }

    /// The nodes, root first (empty for a mesh without triangles).
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// The triangles' corners in leaf order.
    pub fn triangles(&self) -> &[[[f32; 3]; 3]] {
        &self.tris
    }

    /// The mesh's index of each triangle of [`Bvh::triangles`].
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// The box around every triangle (None for a mesh without triangles).
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        self.nodes.first().map(|n| (n.min, n.max))
    }

    /// The nearest triangle the ray o + t·d meets with `tmin < t < tmax`.
    /// Triangles are two-sided.
    pub fn closest(&self, o: [f32; 3], d: [f32; 3], tmin: f32, tmax: f32) -> Option<TriangleHit> {
        let mut best: Option<TriangleHit> = None;
        let mut far = tmax;
        self.walk(o, d, tmin, &mut far, |k, hit| {
            best = Some(TriangleHit {
                triangle: self.order[k],
                ..hit
            });
            false
        });
        best
    }

    /// Whether the ray o + t·d meets any triangle with `tmin < t < tmax`.
    pub fn any(&self, o: [f32; 3], d: [f32; 3], tmin: f32, tmax: f32) -> bool {
        let mut far = tmax;
        let mut found = false;
        self.walk(o, d, tmin, &mut far, |_, _| {
            found = true;
            true
        });
        found
    }

    /// Visits the triangles hit in (tmin, far), nearer children first,
    /// shrinking `far` to each hit; `on_hit` returns true to stop.
    fn walk(
        &self,
        o: [f32; 3],
        d: [f32; 3],
        tmin: f32,
        far: &mut f32,
        mut on_hit: impl FnMut(usize, TriangleHit) -> bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let (o, d) = (Vec3::from(o), Vec3::from(d));
        let inv = d.recip();
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if slab(node, o, inv, tmin, *far).is_none() {
                continue;
            }
            if node.count > 0 {
                let first = node.index as usize;
                for k in first..first + node.count as usize {
                    if let Some(hit) = intersect(&self.tris[k], o, d, tmin, *far) {
                        *far = hit.t;
                        if on_hit(k, hit) {
                            return;
                        }
                    }
                }
                continue;
            }
            let (l, r) = (stack[top] + 1, node.index);
            let tl = slab(&self.nodes[l as usize], o, inv, tmin, *far);
            let tr = slab(&self.nodes[r as usize], o, inv, tmin, *far);
            // Push the farther child first, so the nearer is visited first.
            let order = match (tl, tr) {
                (Some(a), Some(b)) if b < a => [Some(l), Some(r)],
                (a, b) => [b.map(|_| r), a.map(|_| l)],
            };
            for c in order.into_iter().flatten() {
                if top < STACK {
                    stack[top] = c;
                    top += 1;
                }
            }
        }
    }
}

/// Where the ray enters the node's box, if it does within (tmin, tmax).
fn slab(node: &BvhNode, o: Vec3, inv: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
    let t0 = (Vec3::from(node.min) - o) * inv;
    let t1 = (Vec3::from(node.max) - o) * inv;
    // NaN (a zero direction component on the box's plane) never narrows.
    let near = t0.min(t1).max_element().max(tmin);
    let far = t0.max(t1).min_element().min(tmax);
    (near <= far).then_some(near)
}

/// Möller–Trumbore: the ray o + t·d against the triangle, two-sided.
fn intersect(tri: &[[f32; 3]; 3], o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<TriangleHit> {
    let a = Vec3::from(tri[0]);
    let e1 = Vec3::from(tri[1]) - a;
    let e2 = Vec3::from(tri[2]) - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > tmin && t < tmax).then_some(TriangleHit { t, u, v, triangle: 0 })
}

/// The shading normal at a hit, unit length, in the mesh's coordinates:
/// the vertex normals interpolated when the mesh has them, else the
/// triangle's own (by its winding). Zero for a degenerate triangle
/// without vertex normals.
pub fn hit_normal(mesh: &Mesh, hit: &TriangleHit) -> [f32; 3] {
    let t = mesh.triangles[hit.triangle as usize];
    let w = [1.0 - hit.u - hit.v, hit.u, hit.v];
    if !mesh.normals.is_empty() {
        let n: Vec3 = (0..3).map(|k| w[k] * Vec3::from(mesh.normals[t[k] as usize])).sum();
        let n = n.normalize_or_zero();
        if n != Vec3::ZERO {
            return n.to_array();
        }
    }
    let [a, b, c] = t.map(|k| Vec3::from(mesh.positions[k as usize]));
    (b - a).cross(c - a).normalize_or_zero().to_array()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle tested, no hierarchy: the reference.
    fn brute(mesh: &Mesh, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<TriangleHit> {
        let mut best: Option<TriangleHit> = None;
        for (i, t) in mesh.triangles.iter().enumerate() {
            let tri = t.map(|k| mesh.positions[k as usize]);
            if let Some(h) = intersect(&tri, o, d, tmin, best.map_or(tmax, |b| b.t)) {
                best = Some(TriangleHit {
                    triangle: i as u32,
                    ..h
                });
            }
        }
        best
    }

    #[test]
    fn closest_hits_equal_testing_every_triangle() {
        let mesh = Mesh::uv_sphere(1.0, 24, 48);
        let bvh = Bvh::build(&mesh);
        assert_eq!(bvh.triangles().len(), mesh.triangles.len());
        let mut sorted = bvh.order().to_vec();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(i, &k)| i as u32 == k));
        let mut seed = 7u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3::new(rnd(), rnd(), rnd()) * 3.0;
            let d = (Vec3::new(rnd(), rnd(), rnd()) * 0.5 - o * 0.3).normalize();
            let a = bvh.closest(o.to_array(), d.to_array(), 0.0, f32::INFINITY);
            let b = brute(&mesh, o, d, 0.0, f32::INFINITY);
            assert_eq!(a.map(|h| h.t), b.map(|h| h.t), "ray {o} {d}");
            assert_eq!(a.is_some(), bvh.any(o.to_array(), d.to_array(), 0.0, f32::INFINITY));
            hits += a.is_some() as u32;
        }
        assert!(hits > 200, "{hits}");
    }

    #[test]
    fn a_ray_through_the_centre_meets_the_sphere_at_its_radius() {
        let mesh = Mesh::uv_sphere(2.0, 32, 64);
        let bvh = Bvh::build(&mesh);
        // From outside: the tessellation lies inside the true sphere, within
        // r·(1 − cos(π/64)) of it.
        let hit = bvh
            .closest([0.3, 0.2, 10.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY)
            .unwrap();
        let p = Vec3::new(0.3, 0.2, 10.0 - hit.t);
        assert!((p.length() - 2.0).abs() < 2.0 * (1.0 - (std::f32::consts::PI / 32.0).cos()) + 1e-5);
        let n = Vec3::from(hit_normal(&mesh, &hit));
        assert!(n.dot(p.normalize()) > 0.999, "{n} vs {p}");
        // From inside, two-sided: the far wall.
        let hit = bvh
            .closest([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.0, f32::INFINITY)
            .unwrap();
        assert!((hit.t - 2.0).abs() < 0.01);
        // A segment that stops short finds nothing.
        assert!(!bvh.any([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.0, 1.9));
        assert!(bvh.any([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.0, 2.1));
    }

    #[test]
    fn degenerate_and_empty_meshes() {
        assert!(Bvh::build(&Mesh::default())
            .closest([0.0; 3], [0.0, 0.0, 1.0], 0.0, 1e9)
            .is_none());
        assert!(Bvh::build(&Mesh::default()).bounds().is_none());
        // Many triangles at one centroid still build, and a leaf stays small.
        let mut m = Mesh::default();
        for i in 0..100 {
            let s = 1.0 + i as f32;
            let k = m.positions.len() as u32;
            m.positions.extend([[-s, -s, 0.0], [s, -s, 0.0], [s, s, 0.0]]);
            m.triangles.push([k, k + 1, k + 2]);
        }
        let bvh = Bvh::build(&m);
        assert!(bvh.nodes().iter().all(|n| n.count as usize <= MAX_LEAF));
        let hit = bvh.closest([0.5, -0.5, -1.0], [0.0, 0.0, 1.0], 0.0, 1e9).unwrap();
        assert!((hit.t - 1.0).abs() < 1e-6);
    }
}
