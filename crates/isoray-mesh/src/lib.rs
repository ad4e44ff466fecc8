//! # isoray-mesh
//!
//! Triangle meshes for isoray: watertight, manifold meshes extracted from any
//! shape by sparse-octree dual contouring, tessellations of parametric
//! surfaces, and mesh files (STL, OBJ, PLY, glTF binary).

pub mod io;
pub mod mesh;
pub mod parametric;

pub use mesh::{Mesh, MeshMaterial, Topology};
