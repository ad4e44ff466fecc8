//! The field the mesher samples: a shape's distance (less the level meshed)
//! clipped to the meshing box, max(f − iso, box), so that the mesh is closed even where the box cuts the
//! shape, evaluated in parallel batches.

use isoray_shape::{BatchEvaluator, Tape};
use rayon::prelude::*;

/// Points per parallel work item.
const CHUNK: usize = 1024;

/// A shape's distance intersected with an axis-aligned box.
pub(crate) struct Field<'t> {
    tape: &'t Tape,
    centre: [f64; 3],
    half: [f64; 3],
    /// The level meshed: the surface f = iso.
    iso: f64,
}

impl<'t> Field<'t> {
    /// The field f − iso of `tape` inside `bounds` ([min, max]).
    pub(crate) fn new(tape: &'t Tape, bounds: [[f64; 3]; 2], iso: f64) -> Self {
        let centre = [0, 1, 2].map(|k| 0.5 * (bounds[0][k] + bounds[1][k]));
        let half = [0, 1, 2].map(|k| 0.5 * (bounds[1][k] - bounds[0][k]));
        Field {
            tape,
            centre,
            half,
            iso,
        }
    }

    /// The shape's tape.
    pub(crate) fn tape(&self) -> &'t Tape {
        self.tape
    }

    /// The exact distance to the box, with its gradient.
    fn box_distance(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let mut q = [0.0; 3];
        let mut sgn = [0.0; 3];
        for k in 0..3 {
            let d = p[k] - self.centre[k];
            sgn[k] = if d < 0.0 { -1.0 } else { 1.0 };
            q[k] = d.abs() - self.half[k];
        }
        let outside = [q[0].max(0.0), q[1].max(0.0), q[2].max(0.0)];
        let len = (outside[0] * outside[0] + outside[1] * outside[1] + outside[2] * outside[2]).sqrt();
        if len > 0.0 {
            return (len, [0, 1, 2].map(|k| sgn[k] * outside[k] / len));
        }
        let k = if q[0] >= q[1] && q[0] >= q[2] {
            0
        } else if q[1] >= q[2] {
            1
        } else {
            2
        };
        let mut g = [0.0; 3];
        g[k] = sgn[k];
        (q[k], g)
    }

    /// Values at many points, in parallel; the same values whatever the thread count.
    pub(crate) fn values(&self, points: &[[f64; 3]]) -> Vec<f64> {
        let mut out = vec![0.0; points.len()];
        out.par_chunks_mut(CHUNK).zip(points.par_chunks(CHUNK)).for_each_init(
            || (BatchEvaluator::<f64>::new(self.tape), Vec::new()),
            |(ev, vals), (o, pts)| {
                self.values_with(ev, pts, vals);
                o.copy_from_slice(vals);
            },
        );
        out
    }

    /// Values at `points` into `out` (resized), on this thread.
    pub(crate) fn values_with(&self, ev: &mut BatchEvaluator<'t, f64>, points: &[[f64; 3]], out: &mut Vec<f64>) {
        let n = points.len();
        out.resize(n, 0.0);
        let mut xyz = [Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n)];
        for (k, v) in xyz.iter_mut().enumerate() {
            v.extend(points.iter().map(|p| p[k]));
        }
        ev.eval(&[], &xyz[0], &xyz[1], &xyz[2], out);
        for (v, p) in out.iter_mut().zip(points) {
            // NaN stays NaN (f64::max would drop it) so that it is reported.
            if !v.is_nan() {
                *v = (*v - self.iso).max(self.box_distance(*p).0);
            }
        }
    }

    /// Values and gradients at `points` into `out` (resized), on this
    /// thread: central differences with step `eps` on a tetrahedral stencil
    /// (four evaluations per point, in batches); the value is the stencil's
    /// mean, exact to O(eps²).
    pub(crate) fn gradients_with(
        &self,
        ev: &mut BatchEvaluator<'t, f64>,
        points: &[[f64; 3]],
        eps: f64,
        out: &mut Vec<(f64, [f64; 3])>,
    ) {
        const K: [[f64; 3]; 4] = [[1.0, -1.0, -1.0], [-1.0, -1.0, 1.0], [-1.0, 1.0, -1.0], [1.0, 1.0, 1.0]];
        let mut pts = Vec::with_capacity(points.len() * 4);
        for p in points {
            for k in &K {
                pts.push([p[0] + eps * k[0], p[1] + eps * k[1], p[2] + eps * k[2]]);
            }
        }
        let mut vals = Vec::new();
        self.values_with(ev, &pts, &mut vals);
        out.clear();
        out.extend(vals.chunks_exact(4).map(|v| {
            let mut g = [0.0; 3];
            for (k, &f) in K.iter().zip(v) {
                for a in 0..3 {
                    g[a] += k[a] * f;
                }
            }
            (0.25 * (v[0] + v[1] + v[2] + v[3]), g.map(|x| x / (4.0 * eps)))
        }));
    }
}
