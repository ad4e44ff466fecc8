//! Meshing a shape: settings, statistics and the pipeline that ties the
//! octree, dual contouring and the final normals and error measurement together.

use crate::contour::{contour, normalize, GRADIENT_STEP};
use crate::field::Field;
use crate::octree::{active_cells, find_bounds, Grid};
use crate::{Control, Mesh, MeshError, Stage};
use isoray_shape::{BatchEvaluator, Tape};
use rayon::prelude::*;
use std::time::Instant;

/// How to mesh a shape.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSettings {
    /// Cells along the longest side of the bounds (default 128). The octree
    /// covers the next power of two; cells stay cubic.
    pub resolution: u32,
    /// The box to mesh, [min, max]; None finds the shape's bounds from its
    /// distance bound and pads them by two cells. Where the box cuts the
    /// shape, the mesh is closed by the box's faces.
    pub bounds: Option<[[f64; 3]; 2]>,
    /// Patches whose normals differ by more than this many degrees are
    /// sharp features, placed by the quadratic error fit (default 30).
    pub feature_angle_deg: f64,
    /// The level meshed: the surface f = offset (default 0). A positive
    /// offset grows a solid by that distance; around an unsigned field (a
    /// sheet such as |f|) it gives a closed shell of thickness 2 × offset.
    pub offset: f64,
    /// How much the field may overestimate the distance (≥ 1, default 1):
    /// empty space is skipped only where |f| > lipschitz × the cell's half-diagonal.
    pub lipschitz: f64,
}

impl Default for MeshSettings {
    fn default() -> Self {
        MeshSettings {
            resolution: 128,
            bounds: None,
            feature_angle_deg: 30.0,
            offset: 0.0,
            lipschitz: 1.0,
        }
    }
}

/// What meshing measured.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshStats {
    /// The box that was meshed (given, or found and padded).
    pub bounds: [[f64; 3]; 2],
    /// Cell side.
    pub cell_size: f64,
    /// Cells per axis.
    pub cells: [u32; 3],
    /// Finest cells the octree kept.
    pub active_cells: usize,
    /// Cells the distance bound skipped although the surface crosses them
    /// (added back; non-zero means the field overestimates the distance).
    pub missed_cells: usize,
    /// Vertices placed at sharp features.
    pub feature_vertices: usize,
    /// Vertices moved back to their patch's mass point because triangles
    /// around them crossed others (a fold at a vertex held at its cell's side).
    pub unfolded_vertices: usize,
    /// Pairs of crossing triangles around such vertices that remain.
    pub folds_left: usize,
    /// The largest distance from a vertex to the surface, estimated as
    /// |f| / |∇f| at the vertex (exact for a true distance field).
    pub max_error: f64,
    /// The root mean square of the same.
    pub rms_error: f64,
    /// Wall time of each stage, in seconds.
    pub timings: Vec<(Stage, f64)>,
    /// Total wall time in seconds.
    pub seconds: f64,
}

/// The mesher evaluates a shape at one moment: its inputs must be fixed.
fn require_bound(tape: &Tape) -> Result<(), MeshError> {
    if tape.vars().is_empty() {
        Ok(())
    } else {
        Err(MeshError::Settings(
            "the shape reads runtime inputs (the time or parameters): fix them first with Tape::bind".into(),
        ))
    }
}

/// The box that [`mesh_shape`] finds for the surface f = `offset` of
/// `tape` before padding it (see [`MeshSettings::lipschitz`]).
pub fn shape_bounds(tape: &Tape, offset: f64, lipschitz: f64) -> Result<[[f64; 3]; 2], MeshError> {
    require_bound(tape)?;
    find_bounds(tape, offset, lipschitz.max(1.0), &Control::none())
}

/// Meshes the surface of the shape `tape` (a signed distance, or a bound on
/// one) with default progress handling (none) and no cancellation.
pub fn mesh_shape(tape: &Tape, settings: &MeshSettings) -> Result<(Mesh, MeshStats), MeshError> {
    mesh_shape_with(tape, settings, &Control::none())
}

/// Meshes the surface of `tape`, reporting progress and honouring
/// cancellation through `ctl`.
///
/// The mesh is closed and manifold; its triangles wind counter-clockwise
/// seen from outside (where the field is positive); its normals are the
/// field's normalised gradient at each vertex.
pub fn mesh_shape_with(tape: &Tape, settings: &MeshSettings, ctl: &Control) -> Result<(Mesh, MeshStats), MeshError> {
    let start = Instant::now();
    let mut timings = Vec::new();
    let mut lap = Instant::now();
    let mut mark = |stage: Stage, lap: &mut Instant| {
        timings.push((stage, lap.elapsed().as_secs_f64()));
        *lap = Instant::now();
    };
    require_bound(tape)?;
    if !(settings.lipschitz >= 1.0 && settings.lipschitz.is_finite()) {
        return Err(MeshError::Settings(format!(
            "lipschitz must be a number ≥ 1, found {}",
            settings.lipschitz
        )));
    }
    if !(settings.feature_angle_deg >= 0.0 && settings.feature_angle_deg <= 180.0) {
        return Err(MeshError::Settings(format!(
            "the feature angle must be between 0 and 180 degrees, found {}",
            settings.feature_angle_deg
        )));
    }
    if !settings.offset.is_finite() {
        return Err(MeshError::Settings(format!(
            "the offset must be a finite number, found {}",
            settings.offset
        )));
    }
    let resolution = settings.resolution;
    let bounds = match settings.bounds {
        Some(b) => b,
        None => {
            ctl.progress(Stage::Bounds, 0.0);
            let b = find_bounds(tape, settings.offset, settings.lipschitz, ctl)?;
            mark(Stage::Bounds, &mut lap);
            // Pad by two cells of the final grid (after padding).
            let longest = (0..3).map(|k| b[1][k] - b[0][k]).fold(0.0, f64::max);
            let pad = 2.0 * longest / (resolution.max(8) as f64 - 4.0);
            [b[0].map(|v| v - pad), b[1].map(|v| v + pad)]
        }
    };
    let grid = Grid::new(bounds, resolution)?;
    // The field is clipped to the box asked for (the lattice may reach a
    // little beyond it, to whole cells).
    let field = Field::new(tape, bounds, settings.offset);
    let cells = active_cells(&field, &grid, settings.lipschitz, ctl)?;
    mark(Stage::Octree, &mut lap);
    let c = contour(&field, &grid, cells, settings.feature_angle_deg, ctl)?;
    if c.triangles.is_empty() {
        return Err(if c.active_cells > 0 {
            MeshError::NoSignChange
        } else {
            MeshError::NoSurface
        });
    }
    mark(Stage::Faces, &mut lap);

    // Normals from the gradient; the distance error at each vertex.
    ctl.progress(Stage::Finish, 0.0);
    let finish: Vec<([f64; 3], f64)> = c
        .positions
        .par_chunks(1024)
        .map_init(
            || BatchEvaluator::<f64>::new(tape),
            |ev, chunk| {
                let mut grads = Vec::new();
                field.gradients_with(ev, chunk, GRADIENT_STEP * grid.h, &mut grads);
                grads
                    .into_iter()
                    .map(|(f, g)| {
                        let gn = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                        // Where differences see no slope (the tip of a
                        // corner), |f| itself: a distance's error.
                        let err = if gn > 1e-3 { f.abs() / gn } else { f.abs() };
                        (normalize(g), err)
                    })
                    .collect::<Vec<_>>()
            },
        )
        .flatten()
        .collect();
    ctl.check()?;
    mark(Stage::Finish, &mut lap);
    let n = finish.len().max(1) as f64;
    let max_error = finish.iter().fold(0.0f64, |m, x| m.max(x.1));
    let rms_error = (finish.iter().map(|x| x.1 * x.1).sum::<f64>() / n).sqrt();
    // Where the gradient vanishes (a cone's apex, the middle of a symmetric
    // kink), the normal is the area-weighted mean of the triangles' normals.
    let mut normals: Vec<[f64; 3]> = finish.iter().map(|x| x.0).collect();
    if normals.contains(&[0.0; 3]) {
        let missing: Vec<bool> = normals.iter().map(|n| *n == [0.0; 3]).collect();
        for t in &c.triangles {
            if !t.iter().any(|&v| missing[v as usize]) {
                continue;
            }
            let [a, b, d] = t.map(|v| c.positions[v as usize]);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
            let n = [
                u[1] * w[2] - u[2] * w[1],
                u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0],
            ];
            for &v in t {
                if missing[v as usize] {
                    let m = &mut normals[v as usize];
                    *m = [m[0] + n[0], m[1] + n[1], m[2] + n[2]];
                }
            }
        }
        for (n, &m) in normals.iter_mut().zip(&missing) {
            if m {
                *n = normalize(*n);
            }
        }
    }
    let mesh = Mesh {
        positions: c.positions.iter().map(|p| p.map(|v| v as f32)).collect(),
        normals: normals.iter().map(|n| n.map(|v| v as f32)).collect(),
        uvs: Vec::new(),
        triangles: c.triangles,
        materials: Vec::new(),
        triangle_materials: Vec::new(),
    };
    let stats = MeshStats {
        bounds,
        cell_size: grid.h,
        cells: grid.cells,
        active_cells: c.active_cells,
        missed_cells: c.missed_cells,
        feature_vertices: c.feature_vertices,
        unfolded_vertices: c.unfolded,
        folds_left: c.folds_left,
        max_error,
        rms_error,
        timings,
        seconds: start.elapsed().as_secs_f64(),
    };
    ctl.progress(Stage::Finish, 1.0);
    Ok((mesh, stats))
}
