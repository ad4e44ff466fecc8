//! Mesh files: binary STL, OBJ, PLY and glTF binary (`.glb`).
//!
//! [`write`](fn@write) picks the format from the file's extension and replaces the file
//! atomically; [`read`] loads `.obj`, `.stl` (binary or ASCII), `.ply` (ASCII
//! or binary) and `.glb` files into a [`Mesh`]. [`write_to`] encodes into any
//! [`Write`] (an OBJ written this way has no material library).
//!
//! What each format keeps:
//!
//! | format | positions | normals | uvs | materials |
//! | --- | --- | --- | --- | --- |
//! | STL | per triangle (read back welded by exact position) | face normals only | no | no |
//! | OBJ | yes | `vn` | `vt` | `usemtl` names, colours in a `.mtl` written beside the file |
//! | PLY | yes | `nx ny nz` | `s t` | no |
//! | glb | yes | `NORMAL` | `TEXCOORD_0` (as stored, not flipped) | `baseColorFactor` |

mod glb;
mod obj;
mod ply;
mod stl;

use std::fmt;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::mesh::{Mesh, MeshMaterial};

/// The base colour given to materials whose file names no colour (an OBJ
/// group or `usemtl` without a `.mtl` colour), and to the material a glb
/// gets when the mesh has none: linear RGBA light grey.
pub const DEFAULT_BASE_COLOR: [f32; 4] = [0.8, 0.8, 0.8, 1.0];

/// A mesh file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// STL: written binary; read binary or ASCII.
    Stl,
    /// Wavefront OBJ (text), with an optional `.mtl` material library.
    Obj,
    /// PLY: written binary little-endian; read ASCII or binary.
    Ply,
    /// glTF 2.0 binary container (`.glb`).
    Glb,
}

impl Format {
    /// Every format, in the order the error messages list them.
    pub const ALL: [Format; 4] = [Format::Stl, Format::Obj, Format::Ply, Format::Glb];

    /// The format named by `path`'s extension (`.stl`, `.obj`, `.ply`,
    /// `.glb`; any case).
    ///
    /// # Errors
    /// [`MeshIoError::UnknownFormat`] for any other or no extension.
    pub fn from_path(path: &Path) -> Result<Format, MeshIoError> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        Format::ALL
            .into_iter()
            .find(|f| ext.eq_ignore_ascii_case(f.extension()))
            .ok_or_else(|| MeshIoError::UnknownFormat {
                path: path.to_path_buf(),
            })
    }

    /// The format's usual file extension, lower case and without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Stl => "stl",
            Format::Obj => "obj",
            Format::Ply => "ply",
            Format::Glb => "glb",
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::Stl => "STL",
            Format::Obj => "OBJ",
            Format::Ply => "PLY",
            Format::Glb => "glb",
        })
    }
}

/// Why reading or writing a mesh file failed. Every message starts with the
/// file's path (`<stl stream>` and the like for [`write_to`]).
#[derive(Debug, thiserror::Error)]
pub enum MeshIoError {
    /// The path's extension names no supported format.
    #[error("{}: unknown mesh file extension (supported: .stl, .obj, .ply, .glb)", path.display())]
    UnknownFormat {
        /// The path whose extension was not recognised.
        path: PathBuf,
    },
    /// The operating system refused to read, create, write or rename a file.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file being read or written.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: io::Error,
    },
    /// The file's contents are not a valid mesh in its format.
    #[error("{}: {message}", path.display())]
    Malformed {
        /// The file being read.
        path: PathBuf,
        /// What is wrong and where, e.g. "face 12 refers to vertex 900 but the file has 800 vertices".
        message: String,
    },
    /// The mesh is inconsistent (or too large for the format), so nothing was written.
    #[error("{}: cannot write the mesh: {message}", path.display())]
    InvalidMesh {
        /// The file that was to be written.
        path: PathBuf,
        /// What is wrong with the mesh.
        message: String,
    },
}

/// What went wrong inside a format module, before the path is known.
#[derive(Debug)]
enum Problem {
    /// An I/O failure.
    Io(io::Error),
    /// Malformed file contents.
    Bad(String),
    /// A mesh the format cannot hold.
    Mesh(String),
}

impl Problem {
    fn at(self, path: &Path) -> MeshIoError {
        let path = path.to_path_buf();
        match self {
            Problem::Io(source) => MeshIoError::Io { path, source },
            Problem::Bad(message) => MeshIoError::Malformed { path, message },
            Problem::Mesh(message) => MeshIoError::InvalidMesh { path, message },
        }
    }
}

impl From<io::Error> for Problem {
    fn from(e: io::Error) -> Self {
        Problem::Io(e)
    }
}

/// Shorthand for a malformed-file problem.
fn bad<T>(message: impl Into<String>) -> Result<T, Problem> {
    Err(Problem::Bad(message.into()))
}

/// Reads a mesh file, choosing the format by the path's extension.
///
/// STL triangles are welded by exact position (so the mesh is indexed and
/// carries no normals); OBJ and PLY keep their vertex numbering, with
/// polygons split into triangle fans. An OBJ position used with several
/// normals or texture coordinates is split, the copies appended after the
/// file's vertices. OBJ `usemtl` names (or, without any, group names) become
/// materials, coloured from the `.mtl` library's `Kd` and `d` when it can be
/// read and [`DEFAULT_BASE_COLOR`] otherwise. A glb's primitives are merged
/// into one mesh (node transforms are not supported).
///
/// # Errors
/// An unknown extension, an unreadable file, or contents that are malformed:
/// truncated data, indices out of range, non-finite numbers, and so on. Bad
/// input never panics.
pub fn read(path: &Path) -> Result<Mesh, MeshIoError> {
    let format = Format::from_path(path)?;
    let bytes = fs::read(path).map_err(|e| Problem::Io(e).at(path))?;
    let mesh = match format {
        Format::Stl => stl::read(&bytes),
        Format::Obj => obj::read(&bytes, path),
        Format::Ply => ply::read(&bytes),
        Format::Glb => glb::read(&bytes),
    }
    .map_err(|p| p.at(path))?;
    // Every reader checks its indices; this also rejects non-finite numbers.
    validate(&mesh).map_err(|m| Problem::Bad(m).at(path))?;
    Ok(mesh)
}

/// Writes `mesh` to `path` in the format its extension names, atomically:
/// the data goes to a temporary file in the same directory
/// (`.<name>.tmp-<pid>-<n>`, see [`isoray_job::file`]), which is flushed to disk and then renamed over
/// `path`. On any failure the temporary file is removed and an existing
/// `path` is left untouched.
///
/// An OBJ of a mesh with materials also gets a material library beside it
/// (`path` with the extension `.mtl`, replacing any such file), written the
/// same way just before the OBJ is renamed into place.
///
/// # Errors
/// An unknown extension; a mesh with out-of-range indices, non-finite
/// numbers, `normals`/`uvs` neither empty nor one per position, or
/// `triangle_materials` neither empty nor one valid index per triangle; a
/// mesh too large for the format; or an I/O failure.
pub fn write(path: &Path, mesh: &Mesh) -> Result<(), MeshIoError> {
    let format = Format::from_path(path)?;
    validate(mesh).map_err(|m| Problem::Mesh(m).at(path))?;
    if format == Format::Obj && !mesh.materials.is_empty() {
        let mtl_path = path.with_extension("mtl");
        let mtl_name = mtl_path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        // Both files are written before either is renamed into place.
        let obj_tmp = write_temp(path, |w| obj::write(w, mesh, Some(&mtl_name)))?;
        let mtl_tmp = write_temp(&mtl_path, |w| obj::write_mtl(w, mesh))?;
        commit(mtl_tmp, &mtl_path)?;
        commit(obj_tmp, path)
    } else {
        let tmp = write_temp(path, |w| encode(format, w, mesh))?;
        commit(tmp, path)
    }
}

/// Encodes `mesh` in `format` into `out` (buffered internally). An OBJ
/// written this way names its materials with `usemtl` but has no `mtllib`.
///
/// # Errors
/// As [`write`](fn@write), with the path given as `<stl stream>` (and so on).
pub fn write_to<W: Write>(format: Format, out: &mut W, mesh: &Mesh) -> Result<(), MeshIoError> {
    let name = PathBuf::from(format!("<{} stream>", format.extension()));
    validate(mesh).map_err(|m| Problem::Mesh(m).at(&name))?;
    let mut w = BufWriter::new(out);
    encode(format, &mut w, mesh).map_err(|p| p.at(&name))?;
    w.flush().map_err(|e| Problem::Io(e).at(&name))
}

fn encode(format: Format, w: &mut dyn Write, mesh: &Mesh) -> Result<(), Problem> {
    match format {
        Format::Stl => stl::write(w, mesh),
        Format::Obj => obj::write(w, mesh, None),
        Format::Ply => ply::write(w, mesh),
        Format::Glb => glb::write(w, mesh),
    }
}

/// Fills a temporary file beside `target` with `fill` (see
/// [`isoray_job::file::TempFile`]): removed on failure, or if dropped
/// before it is committed.
fn write_temp(
    target: &Path,
    fill: impl FnOnce(&mut dyn Write) -> Result<(), Problem>,
) -> Result<isoray_job::file::TempFile, MeshIoError> {
    let (tmp, file) = isoray_job::file::TempFile::beside(target).map_err(|e| Problem::Io(e).at(target))?;
    let mut w = BufWriter::new(file);
    fill(&mut w).map_err(|p| p.at(target))?;
    w.flush().map_err(|e| Problem::Io(e).at(target))?;
    Ok(tmp)
}

/// Renames `tmp` over `target` (flushed to disk first).
fn commit(tmp: isoray_job::file::TempFile, target: &Path) -> Result<(), MeshIoError> {
    tmp.commit().map_err(|e| Problem::Io(e).at(target))
}

/// Checks the mesh's invariants; the message says what is wrong.
fn validate(mesh: &Mesh) -> Result<(), String> {
    let n = mesh.positions.len();
    if let Some(i) = mesh.positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(format!("vertex {i} has a non-finite position {:?}", mesh.positions[i]));
    }
    if !mesh.normals.is_empty() && mesh.normals.len() != n {
        return Err(format!("the mesh has {n} positions but {} normals", mesh.normals.len()));
    }
    if let Some(i) = mesh.normals.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(format!("vertex {i} has a non-finite normal {:?}", mesh.normals[i]));
    }
    if !mesh.uvs.is_empty() && mesh.uvs.len() != n {
        return Err(format!(
            "the mesh has {n} positions but {} texture coordinates",
            mesh.uvs.len()
        ));
    }
    if let Some(i) = mesh.uvs.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(format!(
            "vertex {i} has non-finite texture coordinates {:?}",
            mesh.uvs[i]
        ));
    }
    for (i, t) in mesh.triangles.iter().enumerate() {
        if let Some(&v) = t.iter().find(|&&v| v as usize >= n) {
            return Err(format!(
                "triangle {i} refers to vertex {v} but the mesh has {n} vertices"
            ));
        }
    }
    if !mesh.triangle_materials.is_empty() && mesh.triangle_materials.len() != mesh.triangles.len() {
        return Err(format!(
            "the mesh has {} triangles but {} triangle materials",
            mesh.triangles.len(),
            mesh.triangle_materials.len()
        ));
    }
    let m = mesh.materials.len();
    if let Some(i) = mesh.triangle_materials.iter().position(|&k| k as usize >= m) {
        return Err(format!(
            "triangle {i} uses material {} but the mesh has {m} materials",
            mesh.triangle_materials[i]
        ));
    }
    if let Some(mat) = mesh
        .materials
        .iter()
        .find(|mat| !mat.base_color.iter().all(|c| c.is_finite()))
    {
        return Err(format!("material {:?} has a non-finite base colour", mat.name));
    }
    Ok(())
}

/// The material index of triangle `i` (0 when `triangle_materials` is empty).
fn material_of(mesh: &Mesh, i: usize) -> u32 {
    mesh.triangle_materials.get(i).copied().unwrap_or(0)
}

/// Per-triangle material indices, empty when every triangle uses material 0.
fn compact_materials(per_triangle: Vec<u32>) -> Vec<u32> {
    if per_triangle.iter().all(|&m| m == 0) {
        Vec::new()
    } else {
        per_triangle
    }
}

/// A material with the default colour.
fn default_material(name: &str) -> MeshMaterial {
    MeshMaterial {
        name: name.to_string(),
        base_color: DEFAULT_BASE_COLOR,
    }
}

/// The unit normal of a triangle (zero when it is degenerate).
fn face_normal(p: [[f32; 3]; 3]) -> [f32; 3] {
    let [a, b, c] = p.map(|v| v.map(f64::from));
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len > 0.0 && len.is_finite() {
        n.map(|c| (c / len) as f32)
    } else {
        [0.0; 3]
    }
}
