//! The object and material at each hit, evaluating only the objects that
//! can decide them.
//!
//! The material at a point folds every object in file order (see
//! [`Objects::fold`]): the nearest object wins, or with a smooth union of
//! width k > 0 materials mix by the union's blend weight. Done literally,
//! that is every object's distance at every hit: 1,000 evaluations per
//! pixel in a scene of 1,000 objects. Instead the hits are grouped into
//! boxes and each object's distance is bounded over a box by interval
//! arithmetic on its tape (a bounding volume computed from the IR); the
//! fold is then run on the bounds, which shows, for every point of the
//! box at once,
//!
//! - the objects that cannot change the fold there: an object at least k
//!   further than everything folded before it leaves the running distance
//!   and material exactly as they were (the blend weight is 0 and the
//!   smooth minimum is the plain minimum), and
//! - the objects that restart it: an object at least k nearer than
//!   everything before it replaces the running state exactly (weight 1),
//!   so nothing before it matters.
//!
//! The rest, usually a handful, are evaluated at the box's points; a box
//! whose list is still long is split in two and each half bounded again
//! from its parent's list. The result is the literal fold's, bit for bit:
//! the bounds are conservative (with a margin for the f32 evaluation's
//! rounding) and the two shortcuts are exact in floating point.

use isoray_shade::material::{blend_weight, smooth_min};
use isoray_shade::MaterialSample;
use isoray_shape::interval::{Interval, IntervalEvaluator};
use isoray_shape::ir::UnOp;
use isoray_shape::Tape;

use crate::trace::Field;

/// How the fold combines objects.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Fold {
    /// The smooth union's width (0: the nearest object wins outright).
    pub k: f32,
    /// The width over which materials mix (≤ k; used when k > 0).
    pub km: f32,
    /// Compare |d| instead of d (hits of rays inside objects); unblended.
    pub unsigned: bool,
}

/// A box whose bounds leave more objects than this is split (when it has
/// more than [`LEAF_POINTS`] points).
const LEAF_OBJECTS: usize = 4;

/// Boxes of at most this many points are not split.
const LEAF_POINTS: usize = 8;

/// Splits of a packet's box, at most.
const MAX_SPLITS: u32 = 12;

/// Every object of a scene as a field, with an interval evaluator of its
/// tape for the bounds (one per worker thread).
#[derive(Debug)]
pub(crate) struct Objects<'s> {
    tapes: Vec<&'s Tape>,
    fields: Vec<Field<'s>>,
    bounds: Vec<IntervalEvaluator<'s>>,
    /// Per object, the sphere its distance is, when it is (bounded in
    /// closed form; may be empty: none).
    spheres: Vec<Option<([f64; 3], f64)>>,
    /// Scratch: a box's points and the fold's state at them.
    gx: Vec<f32>,
    gy: Vec<f32>,
    gz: Vec<f32>,
    d: Vec<f32>,
    acc: Vec<f32>,
    best: Vec<f32>,
    obj: Vec<u32>,
    mat: Vec<MaterialSample>,
}

impl<'s> Objects<'s> {
    /// The objects of the given tapes, with the inputs `vars` (and
    /// `spheres`, per object the sphere its distance is when it is, or
    /// nothing).
    pub(crate) fn new(tapes: Vec<&'s Tape>, vars: &'s [f64], spheres: &[Option<([f64; 3], f64)>]) -> Self {
        Objects {
            spheres: spheres.to_vec(),
            fields: tapes.iter().map(|t| Field::new(t, vars)).collect(),
            bounds: tapes.iter().map(|t| IntervalEvaluator::new(t, vars)).collect(),
            tapes,
            gx: Vec::new(),
            gy: Vec::new(),
            gz: Vec::new(),
            d: Vec::new(),
            acc: Vec::new(),
            best: Vec::new(),
            obj: Vec::new(),
            mat: Vec::new(),
        }
    }

    /// Number of objects.
    pub(crate) fn len(&self) -> usize {
        self.fields.len()
    }

    /// Object `j`'s field.
    pub(crate) fn field(&mut self, j: usize) -> &mut Field<'s> {
        &mut self.fields[j]
    }

    /// The fold at the points (px, py, pz): per point, the object whose
    /// distance (|distance| when unsigned) is smallest, the first on a tie,
    /// into `obj`, and the material into `out`: with k > 0 the running
    /// material mixed, object by object, towards each object's surface (of
    /// `surfaces`) by [`blend_weight`] of the running smooth union
    /// ([`smooth_min`]) and the object's distance; otherwise the winning
    /// object's surface. Returns the object evaluations made.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn fold(
        &mut self,
        surfaces: &[MaterialSample],
        fold: Fold,
        px: &[f32],
        py: &[f32],
        pz: &[f32],
        out: &mut [MaterialSample],
        obj: &mut [usize],
    ) -> u64 {
        let m = px.len().min(py.len()).min(pz.len()).min(out.len()).min(obj.len());
        if m == 0 || self.fields.is_empty() {
            return 0;
        }
        let mut points: Vec<u32> = (0..m as u32).collect();
        let all: Vec<u32> = (0..self.fields.len() as u32).collect();
        let pts = [&px[..m], &py[..m], &pz[..m]];
        self.fold_box(surfaces, fold, pts, &mut points, &all, 0, out, obj)
    }

    /// [`Self::fold`] at the points `points` (indices into `pts`), of the
    /// objects `candidates` (a list that gives the whole fold's result at
    /// these points, its first object starting the fold).
    #[allow(clippy::too_many_arguments)]
    fn fold_box(
        &mut self,
        surfaces: &[MaterialSample],
        fold: Fold,
        pts: [&[f32]; 3],
        points: &mut [u32],
        candidates: &[u32],
        splits: u32,
        out: &mut [MaterialSample],
        obj: &mut [usize],
    ) -> u64 {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &i in points.iter() {
            for k in 0..3 {
                let v = pts[k][i as usize] as f64;
                lo[k] = lo[k].min(v);
                hi[k] = hi[k].max(v);
            }
        }
        let kept = if candidates.len() > 1 {
            self.cull(fold, lo, hi, candidates)
        } else {
            candidates.to_vec()
        };
        if kept.len() > LEAF_OBJECTS && points.len() > LEAF_POINTS && splits < MAX_SPLITS {
            // Halve along the longest side.
            let axis = (0..3)
                .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
                .unwrap_or(0);
            let half = points.len() / 2;
            let c = pts[axis];
            points.select_nth_unstable_by(half, |&a, &b| c[a as usize].total_cmp(&c[b as usize]));
            let (a, b) = points.split_at_mut(half);
            return self.fold_box(surfaces, fold, pts, a, &kept, splits + 1, out, obj)
                + self.fold_box(surfaces, fold, pts, b, &kept, splits + 1, out, obj);
        }
        self.fold_points(surfaces, fold, pts, points, &kept, out, obj)
    }

    /// The objects of `candidates` that can change the fold somewhere in
    /// the box [lo, hi], from the last one that restarts it there.
    fn cull(&mut self, fold: Fold, lo: [f64; 3], hi: [f64; 3], candidates: &[u32]) -> Vec<u32> {
        let bx: [Interval; 3] = std::array::from_fn(|k| Interval::new(lo[k], hi[k]));
        let scale = (0..3).fold(0.0f64, |s, k| s.max(lo[k].abs()).max(hi[k].abs()));
        let k = if fold.unsigned { 0.0 } else { fold.k.max(0.0) as f64 };
        let (spheres, bounds, tapes) = (&self.spheres, &mut self.bounds, &self.tapes);
        isoray_shape::fold::cull(candidates, k, k.max(fold.km as f64), scale, |j| {
            let iv = match spheres.get(j as usize).copied().flatten() {
                Some((c, r)) => isoray_shape::fold::sphere_bound(c, r, bx),
                None => bounds[j as usize].eval(tapes[j as usize], bx, None),
            };
            if fold.unsigned {
                Interval::unary(UnOp::Abs, iv)
            } else {
                iv
            }
        })
        .0
    }

    /// The fold of the objects `kept` (the first starting it) at the points.
    #[allow(clippy::too_many_arguments)]
    fn fold_points(
        &mut self,
        surfaces: &[MaterialSample],
        fold: Fold,
        pts: [&[f32]; 3],
        points: &[u32],
        kept: &[u32],
        out: &mut [MaterialSample],
        obj: &mut [usize],
    ) -> u64 {
        let n = points.len();
        for (dst, src) in [(&mut self.gx, pts[0]), (&mut self.gy, pts[1]), (&mut self.gz, pts[2])] {
            dst.clear();
            dst.extend(points.iter().map(|&i| src[i as usize]));
        }
        let k = if fold.unsigned { 0.0 } else { fold.k };
        let key = |d: f32| if fold.unsigned { d.abs() } else { d };
        for v in [&mut self.d, &mut self.acc, &mut self.best] {
            v.resize(n, 0.0);
        }
        let first = kept[0];
        self.fields[first as usize].eval(&self.gx, &self.gy, &self.gz, &mut self.acc);
        for q in 0..n {
            self.best[q] = key(self.acc[q]);
        }
        self.obj.clear();
        self.obj.resize(n, first);
        self.mat.clear();
        self.mat.resize(n, surfaces[first as usize]);
        for &j in &kept[1..] {
            self.fields[j as usize].eval(&self.gx, &self.gy, &self.gz, &mut self.d);
            let s = &surfaces[j as usize];
            for q in 0..n {
                let (a, b) = (self.acc[q], self.d[q]);
                if key(b) < self.best[q] {
                    self.best[q] = key(b);
                    self.obj[q] = j;
                }
                if k > 0.0 {
                    self.mat[q] = self.mat[q].mix(s, blend_weight(a, b, fold.km));
                    self.acc[q] = smooth_min(a, b, k);
                } else if self.obj[q] == j {
                    self.mat[q] = *s;
                }
            }
        }
        for (q, &i) in points.iter().enumerate() {
            out[i as usize] = self.mat[q];
            obj[i as usize] = self.obj[q] as usize;
        }
        (n * kept.len()) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use isoray_shade::material::{blend_weight, smooth_min};

    /// The fold over every object, literally (what [`Objects::fold`]
    /// must equal).
    fn literal(
        tapes: &[&Tape],
        surfaces: &[MaterialSample],
        fold: Fold,
        p: [&[f32]; 3],
    ) -> (Vec<MaterialSample>, Vec<usize>) {
        let m = p[0].len();
        let k = if fold.unsigned { 0.0 } else { fold.k };
        let key = |d: f32| if fold.unsigned { d.abs() } else { d };
        let (mut acc, mut best, mut obj) = (vec![0.0f32; m], vec![0.0f32; m], vec![0usize; m]);
        let mut out = vec![surfaces[0]; m];
        let mut d = vec![0.0f32; m];
        for (j, t) in tapes.iter().enumerate() {
            let mut f = Field::new(t, &[]);
            f.eval(p[0], p[1], p[2], if j == 0 { &mut acc } else { &mut d });
            for q in 0..m {
                if j == 0 {
                    best[q] = key(acc[q]);
                    continue;
                }
                let (a, b) = (acc[q], d[q]);
                if key(b) < best[q] {
                    best[q] = key(b);
                    obj[q] = j;
                }
                if k > 0.0 {
                    out[q] = out[q].mix(&surfaces[j], blend_weight(a, b, fold.km));
                    acc[q] = smooth_min(a, b, k);
                } else if obj[q] == j {
                    out[q] = surfaces[j];
                }
            }
        }
        (out, obj)
    }

    /// With bounds culling the objects, the fold is the literal one bit for
    /// bit, blended, plain and unsigned, at points near surfaces (where
    /// blends mix) and far from them, with the spheres bounded by their
    /// tapes or in closed form; and it evaluates far fewer objects.
    #[test]
    fn culled_fold_equals_the_literal_one() {
        let lib = isoray_shape::Library::new();
        let mut seed = 11u64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f32 / (1u64 << 53) as f32
        };
        let shapes: Vec<_> = (0..200)
            .map(|i| {
                let c = [rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0];
                let src = if i % 3 == 0 {
                    format!("box(p - vec3({}, {}, {}), vec3(0.3, 0.2, 0.25))", c[0], c[1], c[2])
                } else {
                    format!("sphere(p - vec3({}, {}, {}), 0.3)", c[0], c[1], c[2])
                };
                isoray_shape::compile(&lib, &src).unwrap()
            })
            .collect();
        let tapes: Vec<&Tape> = shapes.iter().map(|s| s.tape()).collect();
        let surfaces: Vec<MaterialSample> = (0..tapes.len())
            .map(|j| {
                let mut s = MaterialSample::from(&isoray_scene::Material::default());
                s.diffuse = glam::Vec3::new(j as f32 / 200.0, 1.0 - j as f32 / 200.0, 0.5);
                s.shininess = 1.0 + j as f32;
                s
            })
            .collect();
        // The spheres bounded in closed form (the renderer's way when it
        // recognises them), the boxes by their tapes.
        let spheres: Vec<Option<([f64; 3], f64)>> = shapes
            .iter()
            .map(|s| match isoray_scene::analytic::Analytic::recognise(s, &[]) {
                Some(isoray_scene::analytic::Analytic::Sphere { c, r }) => Some((c, r)),
                _ => None,
            })
            .collect();
        assert_eq!(spheres.iter().flatten().count(), 133);
        for closed in [false, true] {
            let mut objects = Objects::new(tapes.clone(), &[], if closed { &spheres } else { &[] });
            let folds = [
                Fold {
                    k: 0.5,
                    km: 0.15,
                    unsigned: false,
                },
                Fold {
                    k: 0.0,
                    km: 0.0,
                    unsigned: false,
                },
                Fold {
                    k: 0.0,
                    km: 0.0,
                    unsigned: true,
                },
            ];
            let mut evaluated = 0;
            let mut points = 0;
            for fold in folds {
                for round in 0..8 {
                    // A packet's hits: clustered, or spread over the scene.
                    let (c, r) = if round % 2 == 0 {
                        ([rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0], 0.6)
                    } else {
                        ([0.0; 3], 5.0)
                    };
                    let n = 256;
                    let p: [Vec<f32>; 3] =
                        std::array::from_fn(|k| (0..n).map(|_| c[k] + (rnd() * 2.0 - 1.0) * r).collect());
                    let (want, want_obj) = literal(&tapes, &surfaces, fold, [&p[0], &p[1], &p[2]]);
                    let mut got = vec![surfaces[0]; n];
                    let mut got_obj = vec![0; n];
                    evaluated += objects.fold(&surfaces, fold, &p[0], &p[1], &p[2], &mut got, &mut got_obj);
                    points += n;
                    assert_eq!(got_obj, want_obj);
                    for q in 0..n {
                        assert_eq!(
                            format!("{:?}", got[q]),
                            format!("{:?}", want[q]),
                            "point {q} of {fold:?}"
                        );
                    }
                }
            }
            let literal = (points * tapes.len()) as u64;
            assert!(
                evaluated * 3 < literal,
                "{evaluated} object evaluations, {literal} literally"
            );
        }
    }
}
