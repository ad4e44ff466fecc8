//! Triangle meshes inside SDF scenes (`[[mesh]]`): a mesh file (OBJ, STL,
//! PLY or glb) with a material and a placement, ray-cast through a
//! bounding volume hierarchy built once per file.
//!
//! Renderers intersect rays with meshes in the mesh's own coordinates:
//! [`MeshObject::to_local`] maps a world ray to them so that the distance
//! t along it is the same in both, and [`MeshObject::normal_to_world`]
//! maps a normal back.
//!
//! ```
//! # let dir = std::env::temp_dir().join(format!("isoray-mesh-doc-{}", std::process::id()));
//! # std::fs::create_dir_all(&dir).unwrap();
//! # std::fs::write(dir.join("tri.obj"), "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n").unwrap();
//! # let path = dir.join("scene.toml");
//! std::fs::write(&path, r#"
//! [[mesh]]
//! file = "tri.obj"
//! position = [0.0, 0.0, -2.0]
//! scale = 2.0
//! "#).unwrap();
//! let scene = isoray_scene::load(&path, &[]).unwrap();
//! let m = &scene.meshes[0];
//! // A ray down the z axis meets the triangle where it was placed, z = −2.
//! let (o, d) = m.to_local([0.0, 0.0, 5.0], [0.0, 0.0, -1.0]);
//! let hit = m.bvh().closest(o, d, 0.0, f32::INFINITY).unwrap();
//! assert!((hit.t - 7.0).abs() < 1e-5);
//! ```

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Quat, Vec3};
use isoray_mesh::bvh::Bvh;
use isoray_mesh::Mesh;

use crate::doc::Located;
use crate::error::{SceneError, Sources};
use crate::model::Material;
use crate::reader::Reader;
use crate::schema::{key, key_without_default, num, vector, KeySpec, Kind, Range};

type Result<T> = std::result::Result<T, SceneError>;

/// A mesh file read and its hierarchy (shared by the scenes that place it).
#[derive(Debug)]
pub struct LoadedMesh {
    /// The triangles as the file gives them.
    pub mesh: Mesh,
    /// Their hierarchy, in the file's coordinates.
    pub bvh: Bvh,
}

/// A `[[mesh]]` of a scene.
#[derive(Debug, Clone)]
pub struct MeshObject {
    /// Optional name.
    pub name: Option<String>,
    /// The file as written (relative to the scene file).
    pub file: String,
    /// Index into [`crate::Scene::materials`].
    pub material: usize,
    /// Where the mesh's origin is placed.
    pub position: [f64; 3],
    /// Degrees about x, then y, then z, in world axes (as objects turn).
    pub rotation: [f64; 3],
    /// Uniform scale.
    pub scale: f64,
    loaded: Arc<LoadedMesh>,
    /// World from local: rotation, translation (f32, as renderers use them).
    turn: Quat,
    shift: Vec3,
}

impl MeshObject {
    /// The triangles, in the mesh's own coordinates.
    pub fn mesh(&self) -> &Mesh {
        &self.loaded.mesh
    }

    /// The hierarchy over [`MeshObject::mesh`].
    pub fn bvh(&self) -> &Bvh {
        &self.loaded.bvh
    }

    /// The placement as a rotation quaternion [x, y, z, w], a translation
    /// and a scale: world = translation + scale · rotate(local).
    pub fn placement(&self) -> ([f32; 4], [f32; 3], f32) {
        (self.turn.to_array(), self.shift.to_array(), self.scale as f32)
    }

    /// The ray o + t·d in the mesh's coordinates, with the same t.
    pub fn to_local(&self, o: [f32; 3], d: [f32; 3]) -> ([f32; 3], [f32; 3]) {
        let inv = self.turn.conjugate();
        let s = 1.0 / self.scale as f32;
        (
            (inv * (Vec3::from(o) - self.shift) * s).to_array(),
            (inv * Vec3::from(d) * s).to_array(),
        )
    }

    /// A normal of the mesh's coordinates in world axes.
    pub fn normal_to_world(&self, n: [f32; 3]) -> [f32; 3] {
        (self.turn * Vec3::from(n)).to_array()
    }

    /// A point of the mesh's coordinates in the world.
    pub fn point_to_world(&self, p: [f32; 3]) -> [f32; 3] {
        (self.shift + self.turn * Vec3::from(p) * self.scale as f32).to_array()
    }
}

/// Every key of a `[[mesh]]` table.
pub fn mesh_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key_without_default(
                "file",
                Kind::Str,
                "required",
                "a mesh file, relative to the scene file: `.obj`, `.stl`, `.ply` or `.glb`",
            ),
            key(
                "material",
                Kind::Str,
                "\"default\"",
                "the name of a `[material.NAME]`; it must be opaque (`transparency = 0`)",
            ),
            key_without_default("name", Kind::Str, "none", "a label, for your own reference"),
            key(
                "position",
                vector(),
                "[0.0, 0.0, 0.0]",
                "where the mesh's origin is placed",
            ),
            key(
                "rotation",
                vector(),
                "[0.0, 0.0, 0.0]",
                "degrees: the mesh is turned about x, then y, then z, in world axes (as objects are)",
            ),
            key("scale", num(Range::POSITIVE), "1.0", "uniform scale"),
        ]
    });
    &KEYS
}

/// Reads the `[[mesh]]` tables; files are relative to `dir` and read
/// through `cache` (unchanged files are not read again).
pub(crate) fn read_meshes(
    src: &Sources,
    table: Option<&Located>,
    materials: &[Material],
    dir: &Path,
    cache: &crate::compile::ObjectCache,
) -> Result<Vec<MeshObject>> {
    let Some(v) = table else {
        return Ok(Vec::new());
    };
    let items = crate::read::array_of_tables(src, v, "mesh", false)?;
    let mut out = Vec::with_capacity(items.len());
    for (i, mv) in items.into_iter().enumerate() {
        let ctx = format!("mesh.{i}");
        let mut r = Reader::new(src, mv, &ctx)?;
        let name = r.string("name")?.map(|(s, _)| s.to_string());
        let Some((file, file_loc)) = r.string("file")? else {
            return Err(src
                .error(
                    mv.origin,
                    format!("`{ctx}` needs a `file`"),
                    Some("add file = \"model.obj\""),
                    &[],
                )
                .with_key(format!("{ctx}.file")));
        };
        let material = match r.string("material")? {
            None => materials.iter().position(|m| m.name == "default").unwrap_or(0),
            Some((m, loc)) => crate::read::material_index(src, materials, m, loc, &format!("{ctx}.material"))?,
        };
        if materials[material].transparency > 0.0 {
            let origin = r.get("material").map_or(mv.origin, |l| l.origin);
            return Err(src
                .error(
                    origin,
                    format!(
                        "`{ctx}.material`: \"{}\" is transparent; meshes are drawn opaque",
                        materials[material].name
                    ),
                    Some("expected an opaque material (transparency = 0)"),
                    &["refraction through meshes is not supported; use an SDF object for glass".into()],
                )
                .with_key(format!("{ctx}.material")));
        }
        let position = r.vec3("position", [0.0; 3])?;
        let rotation = r.vec3("rotation", [0.0; 3])?;
        let scale = r.num_in("scale", 1.0, |x| x > 0.0 && x.is_finite(), "a positive number")?;
        r.finish_keys(mesh_keys())?;
        let path: PathBuf = dir.join(file);
        let loaded = cache
            .mesh(&path, || {
                let mesh = isoray_mesh::io::read(&path).map_err(|e| e.to_string())?;
                if mesh.triangles.is_empty() {
                    return Err(format!("`{}` has no triangles", path.display()));
                }
                let bvh = Bvh::build(&mesh);
                Ok(LoadedMesh { mesh, bvh })
            })
            .map_err(|message| {
                let mut err = src
                    .error(
                        file_loc.origin,
                        format!("`{ctx}.file`: {message}"),
                        Some("this file"),
                        &[],
                    )
                    .with_key(format!("{ctx}.file"));
                err.io = true;
                err
            })?;
        let q = crate::skeleton::euler_to_quat(rotation);
        out.push(MeshObject {
            name,
            file: file.to_string(),
            material,
            position,
            rotation,
            scale,
            loaded,
            turn: Quat::from_xyzw(q.x as f32, q.y as f32, q.z as f32, q.w as f32).normalize(),
            shift: Vec3::new(position[0] as f32, position[1] as f32, position[2] as f32),
        });
    }
    Ok(out)
}
