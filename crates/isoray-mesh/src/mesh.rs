//! The indexed triangle mesh every part of isoray-mesh produces and reads,
//! and the measurements made on it: topology (watertight, manifold,
//! consistently wound), area and enclosed volume.

use rayon::prelude::*;

/// A material carried by a mesh: what glTF and the raster pipeline need.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshMaterial {
    /// The material's name in the scene (or in the file it was read from).
    pub name: String,
    /// Linear RGBA base colour.
    pub base_color: [f32; 4],
}

/// An indexed triangle mesh.
///
/// Triangles wind counter-clockwise seen from outside (their normal, by the
/// right-hand rule, points out of the solid). `normals` and `uvs` are either
/// empty or hold one entry per position. `triangle_materials` is either empty
/// (every triangle uses material 0, if there is one) or holds one index into
/// `materials` per triangle.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals (empty when unknown).
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates (empty when none); parametric tessellations carry (s, t).
    pub uvs: Vec<[f32; 2]>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[u32; 3]>,
    /// Materials (may be empty).
    pub materials: Vec<MeshMaterial>,
    /// Per-triangle material index (empty: all 0).
    pub triangle_materials: Vec<u32>,
}

/// What [`Mesh::topology`] finds.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Topology {
    /// Distinct undirected edges.
    pub edges: usize,
    /// Edges used by exactly one triangle (holes).
    pub boundary_edges: usize,
    /// Edges used by three or more triangles.
    pub nonmanifold_edges: usize,
    /// Edges shared by two triangles that traverse it in the same direction
    /// (inconsistent winding).
    pub misoriented_edges: usize,
    /// Vertices whose triangles do not form a single fan (a disk or, on a
    /// boundary, a half-disk): two cones touching at a point.
    pub nonmanifold_vertices: usize,
    /// Triangles with a repeated vertex index or (near) zero area.
    pub degenerate_triangles: usize,
    /// Connected components (through shared edges).
    pub components: usize,
}

impl Topology {
    /// Closed: every edge has exactly two triangles, wound consistently.
    pub fn is_watertight(&self) -> bool {
        self.boundary_edges == 0 && self.nonmanifold_edges == 0 && self.misoriented_edges == 0
    }

    /// Watertight, with manifold vertices and no degenerate triangles.
    pub fn is_closed_manifold(&self) -> bool {
        self.is_watertight() && self.nonmanifold_vertices == 0 && self.degenerate_triangles == 0
    }
}

impl MeshMaterial {
    /// A material of a diffuse colour, opaque but for `transparency`
    /// (alpha = 1 − transparency).
    pub fn from_diffuse(name: &str, diffuse: [f64; 3], transparency: f64) -> MeshMaterial {
        MeshMaterial {
            name: name.to_string(),
            base_color: [
                diffuse[0] as f32,
                diffuse[1] as f32,
                diffuse[2] as f32,
                (1.0 - transparency).clamp(0.0, 1.0) as f32,
            ],
        }
    }
}

impl Mesh {
    /// A UV sphere of radius `r` about the origin: `rings` bands from pole
    /// to pole (y up), `segments` around, wound outwards, with the exact
    /// unit normals at the vertices. For tests and examples.
    ///
    /// ```
    /// let m = isoray_mesh::Mesh::uv_sphere(1.0, 32, 64);
    /// assert!(m.topology().is_closed_manifold());
    /// assert!((m.volume() - 4.0 / 3.0 * std::f64::consts::PI).abs() < 0.03);
    /// ```
    pub fn uv_sphere(r: f32, rings: u32, segments: u32) -> Mesh {
        let mut m = Mesh::default();
        m.positions.push([0.0, r, 0.0]);
        m.normals.push([0.0, 1.0, 0.0]);
        for i in 1..rings {
            let th = std::f64::consts::PI * i as f64 / rings as f64;
            for j in 0..segments {
                let ph = std::f64::consts::TAU * j as f64 / segments as f64;
                let n = [th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin()].map(|x| x as f32);
                m.positions.push(n.map(|x| r * x));
                m.normals.push(n);
            }
        }
        m.positions.push([0.0, -r, 0.0]);
        m.normals.push([0.0, -1.0, 0.0]);
        let south = m.positions.len() as u32 - 1;
        let at = |i: u32, j: u32| 1 + (i - 1) * segments + j % segments;
        for j in 0..segments {
            m.triangles.push([0, at(1, j), at(1, j + 1)]);
            m.triangles.push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
        }
        for i in 1..rings - 1 {
            for j in 0..segments {
                let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
                m.triangles.push([a, c, b]);
                m.triangles.push([b, c, d]);
            }
        }
        m
    }

    /// Appends `part`'s vertices and triangles, with `material` for its
    /// triangles (materials equal to one already listed are shared).
    pub fn append(&mut self, part: Mesh, material: Option<MeshMaterial>) {
        let base = self.positions.len() as u32;
        let mat = material.map(|m| match self.materials.iter().position(|x| *x == m) {
            Some(i) => i as u32,
            None => {
                self.materials.push(m);
                (self.materials.len() - 1) as u32
            }
        });
        self.positions.extend(part.positions);
        self.normals.extend(part.normals);
        self.triangles
            .extend(part.triangles.iter().map(|t| t.map(|v| v + base)));
        if let Some(m) = mat {
            self.triangle_materials.resize(self.triangles.len(), m);
        }
    }

    /// The number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The three corners of triangle `i` in f64.
    pub fn corners(&self, i: usize) -> [[f64; 3]; 3] {
        let t = self.triangles[i];
        t.map(|v| self.positions[v as usize].map(f64::from))
    }

    /// The axis-aligned bounds of the positions (None for an empty mesh).
    pub fn bounds(&self) -> Option<[[f64; 3]; 2]> {
        let mut it = self.positions.iter();
        let first = it.next()?.map(f64::from);
        let mut b = [first, first];
        for p in it {
            for k in 0..3 {
                b[0][k] = b[0][k].min(p[k] as f64);
                b[1][k] = b[1][k].max(p[k] as f64);
            }
        }
        Some(b)
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len())
            .map(|i| {
                let [a, b, c] = self.corners(i);
                0.5 * norm(cross(sub(b, a), sub(c, a)))
            })
            .sum()
    }

    /// The enclosed volume by the divergence theorem, Σ a·(b×c)/6: exact for
    /// a closed, outward-wound mesh, and negative when it is wound inwards.
    pub fn volume(&self) -> f64 {
        // Centre the sum on the bounds' middle to keep the terms small.
        let o = self
            .bounds()
            .map(|b| {
                [
                    0.5 * (b[0][0] + b[1][0]),
                    0.5 * (b[0][1] + b[1][1]),
                    0.5 * (b[0][2] + b[1][2]),
                ]
            })
            .unwrap_or([0.0; 3]);
        (0..self.triangles.len())
            .map(|i| {
                let [a, b, c] = self.corners(i).map(|p| sub(p, o));
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    /// Checks the mesh's topology: edges, winding, vertex fans, degenerate triangles.
    ///
    /// A triangle counts as degenerate when two of its indices are equal or
    /// its area is below `1e-12` times the square of its longest edge.
    pub fn topology(&self) -> Topology {
        let mut topo = Topology::default();
        // Undirected edges as (smaller << 32 | larger), with the direction
        // in which each triangle runs along it; sorted, equal keys are one edge.
        let mut edges: Vec<(u64, bool)> = Vec::with_capacity(self.triangles.len() * 3);
        for (i, t) in self.triangles.iter().enumerate() {
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                topo.degenerate_triangles += 1;
                continue;
            }
            let [a, b, c] = self.corners(i);
            let area = 0.5 * norm(cross(sub(b, a), sub(c, a)));
            let longest2 = dot(sub(b, a), sub(b, a))
                .max(dot(sub(c, b), sub(c, b)))
                .max(dot(sub(a, c), sub(a, c)));
            if area <= 1e-12 * longest2 {
                topo.degenerate_triangles += 1;
            }
            for k in 0..3 {
                let (u, v) = (t[k], t[(k + 1) % 3]);
                edges.push(((u.min(v) as u64) << 32 | u.max(v) as u64, u < v));
            }
        }
        edges.par_sort_unstable();
        let mut i = 0;
        while i < edges.len() {
            let mut j = i;
            let mut forward = 0;
            while j < edges.len() && edges[j].0 == edges[i].0 {
                forward += edges[j].1 as usize;
                j += 1;
            }
            topo.edges += 1;
            match j - i {
                1 => topo.boundary_edges += 1,
                2 if forward != 1 => topo.misoriented_edges += 1,
                2 => {}
                _ => topo.nonmanifold_edges += 1,
            }
            i = j;
        }
        topo.nonmanifold_vertices = self.nonmanifold_vertices();
        topo.components = self.components();
        topo
    }

    /// Vertices whose incident triangles split into two or more fans
    /// (connected through edges around the vertex).
    fn nonmanifold_vertices(&self) -> usize {
        let n = self.positions.len();
        // For each vertex, the triangle-local "opposite edges" (b, c).
        let mut start = vec![0usize; n + 1];
        for t in &self.triangles {
            for &v in t {
                if (v as usize) < n {
                    start[v as usize + 1] += 1;
                }
            }
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut opp = vec![(0u32, 0u32); start[n]];
        for t in &self.triangles {
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || t.iter().any(|&v| v as usize >= n) {
                continue;
            }
            for k in 0..3 {
                let v = t[k] as usize;
                opp[fill[v]] = (t[(k + 1) % 3], t[(k + 2) % 3]);
                fill[v] += 1;
            }
        }
        (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .filter(|&v| {
                let fan = &opp[start[v]..fill[v]];
                if fan.len() < 2 {
                    return false;
                }
                // Grow one fan from the first triangle through shared neighbours.
                let mut reached = vec![false; fan.len()];
                reached[0] = true;
                let mut stack = vec![0usize];
                while let Some(i) = stack.pop() {
                    let (b, c) = fan[i];
                    for (j, &(d, e)) in fan.iter().enumerate() {
                        if !reached[j] && (d == b || d == c || e == b || e == c) {
                            reached[j] = true;
                            stack.push(j);
                        }
                    }
                }
                reached.iter().any(|r| !r)
            })
            .count()
    }

    /// Connected components through shared vertices.
    fn components(&self) -> usize {
        let n = self.positions.len();
        let mut parent: Vec<usize> = (0..n).collect();
        let mut used = vec![false; n];
        for t in &self.triangles {
            if t.iter().any(|&v| v as usize >= n) {
                continue;
            }
            for k in 0..3 {
                used[t[k] as usize] = true;
                union(&mut parent, t[k] as usize, t[(k + 1) % 3] as usize);
            }
        }
        (0..n).filter(|&v| used[v] && find(&mut parent, v) == v).count()
    }
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb)] = ra.min(rb);
    }
}

/// a − b.
pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// a · b.
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// a × b.
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// |a|.
pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit cube [0,1]³ as 12 outward-wound triangles.
    pub(crate) fn cube() -> Mesh {
        let positions: Vec<[f32; 3]> = (0..8)
            .map(|i| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32])
            .collect();
        // Faces as quads (counter-clockwise from outside).
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let triangles = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        Mesh {
            positions,
            triangles,
            ..Default::default()
        }
    }

    #[test]
    fn cube_is_closed_with_unit_volume_and_area_six() {
        let m = cube();
        let t = m.topology();
        assert!(t.is_closed_manifold(), "{t:?}");
        assert_eq!(t.edges, 18);
        assert_eq!(t.components, 1);
        assert!((m.volume() - 1.0).abs() < 1e-12);
        assert!((m.area() - 6.0).abs() < 1e-12);
    }

    #[test]
    fn holes_flips_and_fins_are_found() {
        let mut m = cube();
        m.triangles.pop();
        let t = m.topology();
        assert_eq!(t.boundary_edges, 3);
        assert!(!t.is_watertight());

        let mut m = cube();
        m.triangles[0].swap(1, 2);
        assert_eq!(m.topology().misoriented_edges, 3);

        let mut m = cube();
        let fin = m.triangles[0];
        m.triangles.push(fin);
        assert!(m.topology().nonmanifold_edges >= 3);
        // Inward winding gives a negative volume.
        let mut m = cube();
        for t in &mut m.triangles {
            t.swap(1, 2);
        }
        assert!((m.volume() + 1.0).abs() < 1e-12);
    }

    #[test]
    fn two_cubes_sharing_a_corner_vertex_are_not_manifold() {
        let a = cube();
        let mut m = a.clone();
        let off = m.positions.len() as u32 - 1; // share vertex 7 of a as vertex 0 of b
        for p in &a.positions[1..] {
            m.positions.push([p[0] + 1.0, p[1] + 1.0, p[2] + 1.0]);
        }
        for t in &a.triangles {
            m.triangles.push(t.map(|v| if v == 0 { 7 } else { v + off }));
        }
        let t = m.topology();
        assert!(t.is_watertight(), "{t:?}");
        assert_eq!(t.nonmanifold_vertices, 1);
        assert_eq!(t.components, 1);
        assert!((m.volume() - 2.0).abs() < 1e-12);
    }
}
