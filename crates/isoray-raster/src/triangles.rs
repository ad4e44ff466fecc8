//! The meshed scene as one flat list of world-space triangles with what
//! every renderer pass needs per triangle: corners, vertex normals, an
//! outward face normal, the material and the object.

use glam::{DVec3, Vec3};

use crate::scene::MeshedScene;

/// Every triangle of a meshed scene, in world space (structure of arrays).
#[derive(Debug, Clone, Default)]
pub struct SceneTriangles {
    /// Corner positions.
    pub corners: Vec<[DVec3; 3]>,
    /// Unit vertex normals (outward).
    pub normals: Vec<[Vec3; 3]>,
    /// Unit face normal, oriented to agree with the vertex normals (outward),
    /// so culling does not depend on the winding.
    pub face: Vec<DVec3>,
    /// Material index (into `scene.materials`).
    pub material: Vec<u32>,
    /// Object index (into `scene.objects`; added meshes come after them).
    pub object: Vec<u32>,
    /// Whether the triangle's object is drawn from both sides (never culled).
    pub two_sided: Vec<bool>,
    /// Axis-aligned bounds of all corners (`[min, max]`); empty scenes have
    /// `min > max`.
    pub bounds: [DVec3; 2],
    /// Axis-aligned bounds of the triangles of bounded objects (empty, with
    /// `min > max`, when every object is unbounded).
    pub bounded: [DVec3; 2],
}

impl SceneTriangles {
    /// Flattens the meshes of a scene (normals must be filled, as
    /// [`crate::scene::mesh_scene`] does).
    pub fn new(meshed: &MeshedScene) -> Self {
        let mut out = SceneTriangles {
            bounds: [DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)],
            bounded: [DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)],
            ..SceneTriangles::default()
        };
        let n: usize = meshed.objects.iter().map(|om| om.mesh.triangles.len()).sum();
        out.corners.reserve_exact(n);
        out.normals.reserve_exact(n);
        out.face.reserve_exact(n);
        out.material.reserve_exact(n);
        out.object.reserve_exact(n);
        out.two_sided.reserve_exact(n);
        for om in &meshed.objects {
            let mesh = &om.mesh;
            for (t, tri) in mesh.triangles.iter().enumerate() {
                let corners = mesh.corners(t).map(DVec3::from);
                let normals = tri.map(|v| Vec3::from(mesh.normals[v as usize]));
                let [a, b, c] = corners;
                let mut face = (b - a).cross(c - a).normalize_or_zero();
                let nsum = (normals[0] + normals[1] + normals[2]).as_dvec3();
                if face.dot(nsum) < 0.0 {
                    face = -face;
                }
                for p in corners {
                    out.bounds[0] = out.bounds[0].min(p);
                    out.bounds[1] = out.bounds[1].max(p);
                    if !om.unbounded {
                        out.bounded[0] = out.bounded[0].min(p);
                        out.bounded[1] = out.bounded[1].max(p);
                    }
                }
                out.corners.push(corners);
                out.normals.push(normals);
                out.face.push(face);
                out.material.push(om.material as u32);
                out.object.push(om.object as u32);
                out.two_sided.push(om.two_sided);
            }
        }
        out
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.corners.len()
    }

    /// Whether there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    /// The point with barycentric coordinates `b` on triangle `t`.
    pub fn point(&self, t: usize, b: [f64; 3]) -> DVec3 {
        let [p0, p1, p2] = self.corners[t];
        p0 * b[0] + p1 * b[1] + p2 * b[2]
    }

    /// The unit shading normal (interpolated vertex normals) at barycentric `b` of triangle `t`.
    pub fn normal(&self, t: usize, b: [f64; 3]) -> Vec3 {
        let [n0, n1, n2] = self.normals[t];
        let n = n0 * b[0] as f32 + n1 * b[1] as f32 + n2 * b[2] as f32;
        let n = n.normalize_or_zero();
        if n == Vec3::ZERO {
            self.face[t].as_vec3()
        } else {
            n
        }
    }

    /// Barycentric coordinates of the projection of `p` onto the plane of
    /// triangle `t`, clamped to the triangle (never extrapolated).
    pub fn barycentric(&self, t: usize, p: DVec3) -> [f64; 3] {
        let [a, b, c] = self.corners[t];
        let (e0, e1, d) = (b - a, c - a, p - a);
        let (d00, d01, d11) = (e0.dot(e0), e0.dot(e1), e1.dot(e1));
        let (d20, d21) = (d.dot(e0), d.dot(e1));
        let den = d00 * d11 - d01 * d01;
        if den.abs() < 1e-300 {
            return [1.0 / 3.0; 3];
        }
        let v = (d11 * d20 - d01 * d21) / den;
        let w = (d00 * d21 - d01 * d20) / den;
        let l = [1.0 - v - w, v, w].map(|x| x.max(0.0));
        let s = l[0] + l[1] + l[2];
        l.map(|x| x / s)
    }

    /// The radius of the smallest ball around `centre` that holds every triangle.
    pub fn radius_from(&self, centre: DVec3) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let [lo, hi] = self.bounds;
        let far = (centre - lo).abs().max((hi - centre).abs());
        far.length()
    }
}
