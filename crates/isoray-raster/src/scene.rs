//! Scene objects → world-space triangle meshes with their materials.
//!
//! Each object is meshed by [`isoray_mesh::mesh_shape`] at a given
//! resolution. Unbounded objects (planes, half-spaces) are meshed within the
//! bounding box of what the camera sees ([`unbounded_box`]): the view
//! frustum out to `render.max_distance`, capped at [`UNBOUNDED_EXTENT`] ×
//! the distance from the camera to its target, so a ground plane reaches the
//! horizon in ordinary framings. Sheets (unsigned fields with no sign
//! change) and empty shapes are skipped with a warning.

use isoray_mesh::{mesh_shape_with, Control, Mesh, MeshError, MeshSettings};
use isoray_scene::Scene;

/// One object's mesh, with unit vertex normals (always filled).
#[derive(Debug, Clone)]
pub struct ObjectMesh {
    /// Index into `scene.objects`.
    pub object: usize,
    /// Index into `scene.materials`.
    pub material: usize,
    /// The triangles, in world space.
    pub mesh: Mesh,
    /// Whether the object is unbounded (meshed within [`unbounded_box`]).
    pub unbounded: bool,
    /// Whether both sides are drawn (open surfaces: never back-face culled).
    pub two_sided: bool,
}

/// The meshed scene and what could not be meshed.
#[derive(Debug, Clone, Default)]
pub struct MeshedScene {
    /// Meshes, in object order.
    pub objects: Vec<ObjectMesh>,
    /// Human-readable warnings (skipped objects).
    pub warnings: Vec<String>,
}

/// Why an object could not be meshed.
#[derive(Debug, thiserror::Error)]
#[error("object {label}: {source}")]
pub struct SceneMeshError {
    /// The object's name or index.
    pub label: String,
    /// The mesher's error.
    #[source]
    pub source: MeshError,
}

/// How far the box of unbounded objects reaches, in distances from the camera to its target.
pub const UNBOUNDED_EXTENT: f64 = 25.0;

/// The box unbounded objects are meshed in: the axis-aligned bounds of the
/// camera's view frustum (for a `render.width`×`render.height` image) from
/// the eye out to `min(render.max_distance, UNBOUNDED_EXTENT × distance
/// from the camera to its target)`.
pub fn unbounded_box(scene: &Scene) -> [[f64; 3]; 2] {
    let c = &scene.camera;
    let (p, t) = (c.position, c.target);
    let d = ((p[0] - t[0]).powi(2) + (p[1] - t[1]).powi(2) + (p[2] - t[2]).powi(2)).sqrt();
    let far = (UNBOUNDED_EXTENT * d).max(1e-3).min(scene.render.max_distance);
    let [forward, right, up] = c.basis();
    let th = c.tan_half_fov();
    let aspect = scene.render.width as f64 / scene.render.height.max(1) as f64;
    let mut lo = p;
    let mut hi = p;
    for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
        let dir: [f64; 3] = std::array::from_fn(|k| forward[k] + sx * th * aspect * right[k] + sy * th * up[k]);
        let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
        for k in 0..3 {
            let q = p[k] + dir[k] / len * far;
            lo[k] = lo[k].min(q);
            hi[k] = hi[k].max(q);
        }
    }
    [lo, hi]
}

/// Meshes every object of `scene` at `resolution` cells along the longest side.
pub fn mesh_scene(scene: &Scene, resolution: u32) -> Result<MeshedScene, SceneMeshError> {
    mesh_scene_with(scene, resolution, None)
}

/// [`mesh_scene`] that stops (with [`MeshError::Cancelled`]) when `cancel` is cancelled.
pub fn mesh_scene_with(
    scene: &Scene,
    resolution: u32,
    cancel: Option<&isoray_job::CancelToken>,
) -> Result<MeshedScene, SceneMeshError> {
    let ctl = Control::new(None, cancel.map(|c| c.flag()));
    let lipschitz = (1.0 / scene.render.step_scale.clamp(1e-6, 1.0)).max(1.0);
    let mut out = MeshedScene::default();
    for (i, obj) in scene.objects.iter().enumerate() {
        let label = obj.name.clone().unwrap_or_else(|| format!("#{i}"));
        let mut settings = MeshSettings {
            resolution,
            lipschitz,
            ..MeshSettings::default()
        };
        let shape = scene.frozen(&obj.shape);
        let mut result = mesh_shape_with(shape.tape(), &settings, &ctl);
        let unbounded = matches!(result, Err(MeshError::Unbounded));
        if unbounded {
            settings.bounds = Some(unbounded_box(scene));
            result = mesh_shape_with(shape.tape(), &settings, &ctl);
        }
        match result {
            Ok((mut mesh, _)) => {
                ensure_normals(&mut mesh);
                out.objects.push(ObjectMesh {
                    object: i,
                    material: obj.material,
                    mesh,
                    unbounded,
                    two_sided: false,
                });
            }
            Err(e @ (MeshError::NoSignChange | MeshError::Unbounded)) => {
                out.warnings.push(format!("object {label} skipped: {e}"));
            }
            Err(source) => return Err(SceneMeshError { label, source }),
        }
    }
    Ok(out)
}

impl MeshedScene {
    /// Adds a mesh that is not one of the scene's objects (a mesh file, a
    /// tessellated parametric surface) with material `material`: it gets the
    /// object index `scene.objects.len()` + its rank among the added meshes
    /// (`first_extra`), its normals are filled when missing, and it is drawn
    /// two-sided unless it is closed (every edge shared by two triangles).
    pub fn add(&mut self, first_extra: usize, material: usize, mut mesh: Mesh) {
        ensure_normals(&mut mesh);
        let closed = mesh.topology().is_watertight();
        let object = first_extra + self.objects.iter().filter(|o| o.object >= first_extra).count();
        self.objects.push(ObjectMesh {
            object,
            material,
            mesh,
            unbounded: false,
            two_sided: !closed,
        });
    }
}

/// Fills `mesh.normals` with area-weighted face normals when it has none.
pub fn ensure_normals(mesh: &mut Mesh) {
    if mesh.normals.len() == mesh.positions.len() {
        return;
    }
    let mut acc = vec![[0.0f64; 3]; mesh.positions.len()];
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.corners(t);
        let n = cross(sub(b, a), sub(c, a));
        for &v in &mesh.triangles[t] {
            for k in 0..3 {
                acc[v as usize][k] += n[k];
            }
        }
    }
    mesh.normals = acc
        .iter()
        .map(|n| {
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-300);
            [(n[0] / l) as f32, (n[1] / l) as f32, (n[2] / l) as f32]
        })
        .collect();
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
