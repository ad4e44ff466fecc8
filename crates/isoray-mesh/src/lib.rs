//! # isoray-mesh
//!
//! Triangle meshes for isoray: watertight, manifold meshes extracted from any
//! shape by sparse-octree dual contouring ([`mesh_shape`]), tessellations of
//! parametric surfaces ([`parametric`]), and mesh files ([`io`]: STL, OBJ,
//! PLY, glTF binary).
//!
//! ```
//! use isoray_mesh::{mesh_shape, MeshSettings};
//! use isoray_shape::{compile, Library};
//!
//! let shape = compile(&Library::new(), "box(p, vec3(1.0))").unwrap();
//! let settings = MeshSettings { resolution: 16, ..MeshSettings::default() };
//! let (mesh, stats) = mesh_shape(shape.tape(), &settings).unwrap();
//! let topology = mesh.topology();
//! assert!(topology.is_closed_manifold());
//! // The cube's volume is 8, and its sharp corners are kept.
//! assert!((mesh.volume() - 8.0).abs() < 1e-3);
//! assert!(stats.max_error < 1e-3);
//! ```

pub mod bvh;
pub mod check;
mod contour;
mod extract;
mod field;
pub mod io;
pub mod mesh;
mod octree;
pub mod parametric;
mod qef;

pub use check::self_intersections;
pub use extract::{mesh_shape, mesh_shape_with, shape_bounds, MeshSettings, MeshStats};
pub use mesh::{Mesh, MeshMaterial, Topology};
pub use octree::SEARCH_RADIUS;

use std::sync::atomic::{AtomicBool, Ordering};

/// Why meshing failed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    /// A setting is out of range.
    #[error("{0}")]
    Settings(String),
    /// The shape has no surface within the search cube (or the given box).
    #[error("the shape has no surface in the box (or, without one, within ±{SEARCH_RADIUS} of the origin), or its field overestimates the distance")]
    NoSurface,
    /// The surface reaches the search cube: give bounds.
    #[error("the shape is unbounded (its surface reaches ±{SEARCH_RADIUS}): give bounds to mesh a part of it")]
    Unbounded,
    /// The field comes near zero but never turns negative at the lattice
    /// points: a shape thinner than a cell, or an unsigned field (a sheet
    /// such as |f|), which encloses no solid.
    #[error("the field comes close to zero but is never negative at the lattice points: the shape is thinner than a cell (raise the resolution), or the field is unsigned (a sheet such as abs(f) encloses no solid: mesh a thin shell around it with an offset)")]
    NoSignChange,
    /// The field is not a number at some lattice points.
    #[error("the field is not a number (NaN) at {count} sample points, e.g. at ({:.4}, {:.4}, {:.4}): check for sqrt or log of negative numbers and 0/0", at[0], at[1], at[2])]
    NotANumber {
        /// How many samples were NaN.
        count: usize,
        /// One of them.
        at: [f64; 3],
    },
    /// Cancelled through [`Control`]'s flag.
    #[error("cancelled")]
    Cancelled,
}

/// The stages of meshing, reported to a progress callback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Finding the bounds.
    Bounds,
    /// Descending the octree.
    Octree,
    /// Sampling cell corners.
    Corners,
    /// Crossing edges.
    Edges,
    /// Placing vertices.
    Vertices,
    /// Making faces.
    Faces,
    /// Normals and distance errors.
    Finish,
}

impl Stage {
    /// A short name for progress displays.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Bounds => "bounds",
            Stage::Octree => "octree",
            Stage::Corners => "corners",
            Stage::Edges => "edges",
            Stage::Vertices => "vertices",
            Stage::Faces => "faces",
            Stage::Finish => "normals",
        }
    }
}

/// Progress reporting and cancellation for long meshing runs.
pub struct Control<'a> {
    progress: Option<&'a (dyn Fn(Stage, f64) + Sync)>,
    job: Option<&'a dyn isoray_job::Progress>,
    cancel: Option<&'a AtomicBool>,
}

impl<'a> Control<'a> {
    /// No progress, no cancellation.
    pub fn none() -> Control<'static> {
        Control {
            progress: None,
            job: None,
            cancel: None,
        }
    }

    /// Reports to an [`isoray_job::Progress`] (each stage by its name, then
    /// per-mille updates) and stops soon after `cancel` is cancelled: the
    /// job control every long isoray operation takes.
    pub fn job(progress: &'a dyn isoray_job::Progress, cancel: &'a isoray_job::CancelToken) -> Self {
        Control {
            progress: None,
            job: Some(progress),
            cancel: Some(cancel.flag()),
        }
    }

    /// Reports `(stage, fraction done)` to `progress` and stops with
    /// [`MeshError::Cancelled`] soon after `cancel` becomes true.
    pub fn new(progress: Option<&'a (dyn Fn(Stage, f64) + Sync)>, cancel: Option<&'a AtomicBool>) -> Self {
        Control {
            progress,
            job: None,
            cancel,
        }
    }

    /// The same cancellation without progress reports.
    pub(crate) fn silent(other: &Control<'a>) -> Control<'a> {
        Control {
            progress: None,
            job: None,
            cancel: other.cancel,
        }
    }

    pub(crate) fn progress(&self, stage: Stage, fraction: f64) {
        if let Some(p) = self.progress {
            p(stage, fraction);
        }
        if let Some(j) = self.job {
            if fraction <= 0.0 {
                j.stage(stage.name());
            }
            j.update((fraction.clamp(0.0, 1.0) * 1000.0) as u64, 1000);
        }
    }

    pub(crate) fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }

    pub(crate) fn check(&self) -> Result<(), MeshError> {
        if self.cancelled() {
            Err(MeshError::Cancelled)
        } else {
            Ok(())
        }
    }
}
