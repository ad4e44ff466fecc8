//! Cube environment maps: six 90° views from one centre, rendered with the
//! polygon pipeline, holding per texel either the nearest surface (a
//! Z-buffered map) or every surface, front and back faces, as a
//! depth-sorted fragment list with coverage masks (an A-buffered map).
//!
//! Texels store no colour: each sample keeps its triangle and its depth, so
//! a lookup knows the *point* the texel saw ([`CubeMap::stored_point`]) and
//! shades it as seen from wherever the lookup comes from (deferred shading).
//!
//! Two lookups:
//!
//! * [`CubeMap::lookup`] — by direction only (Blinn–Newell): the surface the
//!   map's centre sees in that direction, as if it were infinitely far away.
//! * [`CubeMap::search`] — along a ray. The ray's points project onto the
//!   map along the arc where the plane through the centre and the ray cuts
//!   the cube, from the projection of the ray's origin toward its direction.
//!   The walk follows that arc texel by texel; in each texel it takes the
//!   samples whose depth range the ray passes through (and, in an A-buffered
//!   map, whose coverage mask the ray crosses), and accepts the first one
//!   whose stored point lies within an angle threshold of the ray (a few
//!   texels seen from the ray's origin). A ray that passes behind a
//!   silhouette fails the threshold and the walk goes on; a walk that leaves
//!   the scene finds nothing (the caller's background).

use glam::DVec3;
use isoray_job::{CancelToken, Cancelled};
use rayon::prelude::*;

use crate::abuffer::Mask;
use crate::draw::{check, coverage_fragments, for_each_band, gbuffer_with, is_cancelled, project_with, Cull};
use crate::pipeline::ViewTransform;
use crate::triangles::SceneTriangles;
use isoray_scene::{Camera, Projection};

/// The unit axis of cube face `f`: +X, −X, +Y, −Y, +Z, −Z.
pub fn face_axis(f: usize) -> DVec3 {
    let s = if f % 2 == 0 { 1.0 } else { -1.0 };
    match f / 2 {
        0 => DVec3::new(s, 0.0, 0.0),
        1 => DVec3::new(0.0, s, 0.0),
        _ => DVec3::new(0.0, 0.0, s),
    }
}

/// The face a direction falls on: the axis of its largest component, by sign.
pub fn face_of(u: DVec3) -> usize {
    let a = u.abs();
    if a.x >= a.y && a.x >= a.z {
        usize::from(u.x < 0.0)
    } else if a.y >= a.z {
        2 + usize::from(u.y < 0.0)
    } else {
        4 + usize::from(u.z < 0.0)
    }
}

/// One texel of a cube map, and where in it (which subsample) a direction falls.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Texel {
    /// Face, 0–5 ([`face_axis`]).
    pub face: usize,
    /// Column.
    pub x: usize,
    /// Row.
    pub y: usize,
    /// Subsample column (0–7) of the direction within the texel.
    pub c: u32,
    /// Subsample row (0–3) of the direction within the texel.
    pub r: u32,
}

impl Texel {
    fn same_texel(&self, o: &Texel) -> bool {
        (self.face, self.x, self.y) == (o.face, o.x, o.y)
    }
}

/// The six views of a cube map: 90° square perspective views from `centre`.
#[derive(Debug, Clone)]
pub struct CubeFaces {
    /// The centre of projection.
    pub centre: DVec3,
    /// Texels along each face's side.
    pub size: usize,
    /// The views, in [`face_axis`] order.
    pub views: [ViewTransform; 6],
}

impl CubeFaces {
    /// Faces of `size`×`size` texels around `centre`.
    pub fn new(centre: DVec3, size: usize) -> Self {
        let views = std::array::from_fn(|f| {
            let axis = face_axis(f);
            let up = if f / 2 == 1 { [0.0, 0.0, 1.0] } else { [0.0, 1.0, 0.0] };
            let cam = Camera {
                position: centre.to_array(),
                target: (centre + axis).to_array(),
                up,
                fov: 90.0,
                projection: Projection::Perspective,
            };
            ViewTransform::new(&cam, size as u32, size as u32)
        });
        CubeFaces { centre, size, views }
    }

    /// The texel (and subsample) direction `u` (need not be unit) falls in.
    pub fn texel(&self, u: DVec3) -> Texel {
        let face = face_of(u);
        let axis = face_axis(face);
        let un = u / u.dot(axis);
        let s = self.views[face]
            .to_screen((self.centre + un).to_array())
            .unwrap_or([0.0; 3]);
        let n = self.size as f64;
        let fx = (s[0] + 0.5).clamp(0.0, n - 1e-9);
        let fy = (s[1] + 0.5).clamp(0.0, n - 1e-9);
        let (x, y) = (fx.floor(), fy.floor());
        Texel {
            face,
            x: x as usize,
            y: y as usize,
            c: (((fx - x) * Mask::COLUMNS as f64) as u32).min(Mask::COLUMNS - 1),
            r: (((fy - y) * Mask::ROWS as f64) as u32).min(Mask::ROWS - 1),
        }
    }

    /// The world point seen at the centre of texel (`x`, `y`) of face `f` at depth `z` along the face's axis.
    pub fn stored_point(&self, f: usize, x: usize, y: usize, z: f64) -> DVec3 {
        DVec3::from(self.views[f].screen_to_world(x as f64, y as f64, z))
    }

    /// The world-space size of a texel at depth `z` (its side, at the face's centre).
    pub fn texel_size(&self, z: f64) -> f64 {
        2.0 * z / self.size as f64
    }
}

/// How a cube map resolves hidden surfaces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapKind {
    /// The nearest front-facing surface per texel, point-sampled at the texel centre.
    ZBuffer,
    /// Every surface per texel (back faces kept), with 4×8 coverage masks, depth-sorted.
    ABuffer,
}

/// One surface seen in a texel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSample {
    /// Scene triangle.
    pub tri: u32,
    /// Depth along the face's axis at the texel centre.
    pub z: f32,
    /// Nearest depth of the surface over the texel.
    pub zmin: f32,
    /// Farthest depth of the surface over the texel.
    pub zmax: f32,
    /// Covered subsamples (all of them in a Z-buffered map).
    pub mask: Mask,
    /// Whether the triangle faces the map's centre.
    pub front: bool,
}

/// What [`CubeMap::search`] found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapHit {
    /// The sample's triangle.
    pub tri: u32,
    /// The point stored in the texel (on the triangle, at the texel centre).
    pub point: DVec3,
    /// Ray parameter of the stored point's projection onto the ray.
    pub t: f64,
    /// Angle (radians) between the ray and the direction from its origin to the stored point.
    pub angle: f64,
}

/// How far from the ray a stored point may be and still count as its hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchTolerance {
    /// The angle threshold in texels, seen from the ray's origin.
    pub texels: f64,
    /// A floor for the threshold, in radians.
    pub min_angle: f64,
}

impl Default for SearchTolerance {
    fn default() -> Self {
        SearchTolerance {
            texels: 1.5,
            min_angle: 0.0,
        }
    }
}

/// A cube environment map (see the module documentation).
#[derive(Debug, Clone)]
pub struct CubeMap {
    /// The six views.
    pub faces: CubeFaces,
    /// Z-buffered or A-buffered.
    pub kind: MapKind,
    /// Radius (from the centre) of a ball holding every triangle.
    pub radius: f64,
    offsets: Vec<u32>,
    samples: Vec<MapSample>,
    /// Depth bounds of blocks of texels, coarse to fine (empty-space skipping).
    levels: Vec<BlockLevel>,
}

/// Texels along a side of the blocks of the search's empty-space skipping, coarse to fine.
const BLOCKS: [usize; 2] = [16, 4];

/// Per face and block of `size`×`size` texels: the depth range (min `zmin`,
/// max `zmax`) of every sample in the block; empty blocks hold `[∞, −∞]`.
#[derive(Debug, Clone)]
struct BlockLevel {
    size: usize,
    per_side: usize,
    bounds: Vec<[f32; 2]>,
}

impl BlockLevel {
    fn new(
        size: usize,
        n: usize,
        offsets: &[u32],
        samples: &[MapSample],
        cancel: Option<&CancelToken>,
    ) -> Result<Self, Cancelled> {
        let nb = n.div_ceil(size);
        let mut bounds = vec![[f32::INFINITY, f32::NEG_INFINITY]; 6 * nb * nb];
        for f in 0..6 {
            for y in 0..n {
                check(cancel)?;
                for x in 0..n {
                    let i = (f * n + y) * n + x;
                    let b = &mut bounds[(f * nb + y / size) * nb + x / size];
                    for s in &samples[offsets[i] as usize..offsets[i + 1] as usize] {
                        b[0] = b[0].min(s.zmin);
                        b[1] = b[1].max(s.zmax);
                    }
                }
            }
        }
        Ok(BlockLevel {
            size,
            per_side: nb,
            bounds,
        })
    }

    /// The union of the bounds of the blocks at the four corners of the box
    /// spanned by texels `a` and `b` of one face.
    fn around(&self, a: &Texel, b: &Texel) -> [f32; 2] {
        let (nb, s) = (self.per_side, self.size);
        let mut out = [f32::INFINITY, f32::NEG_INFINITY];
        for (x, y) in [(a.x, a.y), (b.x, b.y), (a.x, b.y), (b.x, a.y)] {
            let k = self.bounds[(a.face * nb + y / s) * nb + x / s];
            out = [out[0].min(k[0]), out[1].max(k[1])];
        }
        out
    }
}

/// Depth range (along `axis`, from `c`) of triangle `t`'s plane over the texel
/// whose corner rays are `corners` (each with unit component along the axis),
/// clamped to the triangle's corner depths.
fn plane_depth_range(tris: &SceneTriangles, t: usize, c: DVec3, axis: DVec3, corners: &[DVec3; 4]) -> (f64, f64) {
    let [a, b, d] = tris.corners[t];
    let n = tris.face[t];
    let h = (a - c).dot(n);
    let dz = [a, b, d].map(|p| (p - c).dot(axis));
    let (lo, hi) = (dz[0].min(dz[1]).min(dz[2]), dz[0].max(dz[1]).max(dz[2]));
    let (mut zmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for dir in corners {
        let den = dir.dot(n);
        let z = if den.abs() > 1e-300 {
            (h / den).clamp(lo, hi)
        } else {
            hi
        };
        let z = if z.is_finite() && z > 0.0 { z } else { hi };
        zmin = zmin.min(z);
        zmax = zmax.max(z);
    }
    (zmin, zmax)
}

impl CubeMap {
    /// Renders the map of `kind` with `size`×`size` faces around `centre`,
    /// leaving out the triangles of object `exclude` (Blinn–Newell maps leave
    /// out the reflecting object). Faces are drawn in parallel bands.
    pub fn build(
        tris: &SceneTriangles,
        centre: DVec3,
        size: usize,
        kind: MapKind,
        exclude: Option<u32>,
        near: f64,
    ) -> Self {
        match Self::build_with(tris, centre, size, kind, exclude, near, None) {
            Ok(map) => map,
            Err(Cancelled) => unreachable!("no token, no cancellation"),
        }
    }

    /// [`CubeMap::build`], stopping soon after `cancel` is cancelled: it is
    /// checked per triangle projected and drawn, per texel and per row of
    /// texels.
    pub fn build_with(
        tris: &SceneTriangles,
        centre: DVec3,
        size: usize,
        kind: MapKind,
        exclude: Option<u32>,
        near: f64,
        cancel: Option<&CancelToken>,
    ) -> Result<Self, Cancelled> {
        let faces = CubeFaces::new(centre, size.max(1));
        let n = faces.size;
        let cull = |t: usize| {
            if Some(tris.object[t]) == exclude {
                Cull::All
            } else if kind == MapKind::ZBuffer {
                Cull::Back
            } else {
                Cull::None
            }
        };
        // Per face: the number of samples of each texel (row-major) and the
        // samples, texel after texel (a few large vectors rather than one
        // per texel: quick to build, and to drop when cancelled).
        let mut per_face: Vec<(Vec<u32>, Vec<MapSample>)> = Vec::with_capacity(6);
        for f in 0..6 {
            let view = &faces.views[f];
            let projected = project_with(tris, view, centre, near, cull, cancel)?;
            let axis = face_axis(f);
            let corner_dirs = |x: usize, y: usize| -> [DVec3; 4] {
                [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)]
                    .map(|(dx, dy)| DVec3::from(view.screen_to_world(x as f64 + dx, y as f64 + dy, 1.0)) - centre)
            };
            let face = match kind {
                MapKind::ZBuffer => {
                    let g = gbuffer_with(&projected, n, n, cancel)?;
                    let texels: Vec<Option<MapSample>> = g
                        .par_iter()
                        .enumerate()
                        .map(|(i, px)| {
                            if !px.is_hit() || is_cancelled(cancel) {
                                return None;
                            }
                            let (x, y) = (i % n, i / n);
                            let t = px.tri as usize;
                            let (zmin, zmax) = plane_depth_range(tris, t, centre, axis, &corner_dirs(x, y));
                            Some(MapSample {
                                tri: px.tri,
                                z: px.depth as f32,
                                zmin: zmin.min(px.depth) as f32,
                                zmax: zmax.max(px.depth) as f32,
                                mask: Mask::FULL,
                                front: true,
                            })
                        })
                        .collect();
                    let counts = texels.iter().map(|t| u32::from(t.is_some())).collect();
                    (counts, texels.into_iter().flatten().collect())
                }
                MapKind::ABuffer => {
                    let mut rows: Vec<Vec<(u32, MapSample)>> = vec![Vec::new(); n];
                    for_each_band(&projected, &mut rows, 1, |band, chunk, tris_in| {
                        let y0 = band.start;
                        for p in tris_in {
                            if is_cancelled(cancel) {
                                return;
                            }
                            let t = p.tri as usize;
                            let cen = (tris.corners[t][0] + tris.corners[t][1] + tris.corners[t][2]) / 3.0;
                            let front = tris.face[t].dot(cen - centre) < 0.0;
                            coverage_fragments(&p.v, n, band.clone(), |cv| {
                                chunk[cv.y - y0].push((
                                    cv.x as u32,
                                    MapSample {
                                        tri: p.tri,
                                        z: cv.z as f32,
                                        zmin: cv.zmin as f32,
                                        zmax: cv.zmax as f32,
                                        mask: cv.mask,
                                        front,
                                    },
                                ));
                            });
                        }
                    });
                    check(cancel)?;
                    // Per row: each texel's fragments merged into its depth-sorted list.
                    let rows: Vec<(Vec<u32>, Vec<MapSample>)> = rows
                        .into_par_iter()
                        .map(|mut row| {
                            let mut counts = vec![0u32; n];
                            let mut flat = Vec::new();
                            if is_cancelled(cancel) {
                                // Left empty: the map is dropped below.
                                return (counts, flat);
                            }
                            row.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.z.total_cmp(&b.1.z)));
                            let mut texel: Vec<MapSample> = Vec::new();
                            for run in row.chunk_by(|a, b| a.0 == b.0) {
                                texel.clear();
                                for &(_, s) in run {
                                    merge_into(&mut texel, s, tris);
                                }
                                counts[run[0].0 as usize] = texel.len() as u32;
                                flat.extend_from_slice(&texel);
                            }
                            (counts, flat)
                        })
                        .collect();
                    let mut counts = Vec::with_capacity(n * n);
                    let mut flat = Vec::with_capacity(rows.iter().map(|r| r.1.len()).sum());
                    for (c, s) in rows {
                        counts.extend(c);
                        flat.extend(s);
                    }
                    (counts, flat)
                }
            };
            check(cancel)?;
            per_face.push(face);
        }
        let mut offsets = Vec::with_capacity(6 * n * n + 1);
        let mut samples = Vec::with_capacity(per_face.iter().map(|f| f.1.len()).sum());
        offsets.push(0u32);
        for (counts, face_samples) in per_face {
            check(cancel)?;
            samples.extend(face_samples);
            for c in counts {
                let last = *offsets.last().expect("starts with 0");
                offsets.push(last + c);
            }
        }
        let levels = BLOCKS
            .iter()
            .map(|&b| BlockLevel::new(b, n, &offsets, &samples, cancel))
            .collect::<Result<_, _>>()?;
        Ok(CubeMap {
            radius: tris.radius_from(centre),
            faces,
            kind,
            offsets,
            samples,
            levels,
        })
    }

    /// The samples of texel (`x`, `y`) of face `f`, nearest first.
    pub fn samples_at(&self, f: usize, x: usize, y: usize) -> &[MapSample] {
        let n = self.faces.size;
        let i = (f * n + y) * n + x;
        &self.samples[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Total number of samples (fragments) in the map.
    pub fn sample_count(&self) -> usize {
        self.samples.len()
    }

    /// The point stored by sample `s` of texel (`f`, `x`, `y`).
    pub fn stored_point(&self, f: usize, x: usize, y: usize, s: &MapSample) -> DVec3 {
        self.faces.stored_point(f, x, y, s.z as f64)
    }

    /// Blinn–Newell lookup: the nearest surface the centre sees in direction `dir`.
    pub fn lookup(&self, dir: DVec3) -> Option<(u32, DVec3)> {
        let tx = self.faces.texel(dir);
        let s = self.samples_at(tx.face, tx.x, tx.y).first()?;
        Some((s.tri, self.stored_point(tx.face, tx.x, tx.y, s)))
    }

    /// Searches the map along the ray `origin + t·dir` (unit `dir`), t in
    /// (`t_min`, `t_max`), for the first stored surface on the ray (see the
    /// module docs); `accept` filters samples by triangle.
    pub fn search(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
        tol: &SearchTolerance,
        accept: impl Fn(u32) -> bool,
    ) -> Option<MapHit> {
        self.search_with(origin, dir, t_min, t_max, tol, accept, None)
    }

    /// [`CubeMap::search`] that gives up (finding nothing) soon after
    /// `cancel` is cancelled: a walk across a whole face can take
    /// milliseconds, so work that searches many rays stops within one.
    #[allow(clippy::too_many_arguments)]
    pub fn search_with(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
        tol: &SearchTolerance,
        accept: impl Fn(u32) -> bool,
        cancel: Option<&CancelToken>,
    ) -> Option<MapHit> {
        let c = self.faces.centre;
        let a = origin - c;
        // Clip the ray to the ball holding the scene.
        let r = self.radius * 1.001 + 1e-9;
        let b = a.dot(dir);
        let disc = b * b - (a.length_squared() - r * r);
        if disc < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        let t_lo = t_min.max(-b - sq);
        let t_hi = t_max.min(-b + sq);
        if t_hi <= t_lo || t_hi.is_nan() || t_lo.is_nan() {
            return None;
        }
        let start = a + dir * t_lo;
        let ra = start.length();
        let n = self.faces.size as f64;
        let check = |tx: &Texel, w_lo: f64, w_hi: f64, ray_mask: &dyn Fn(&Texel) -> Mask| -> Option<MapHit> {
            let samples = self.samples_at(tx.face, tx.x, tx.y);
            if samples.is_empty() {
                return None;
            }
            let mut mask: Option<Mask> = None;
            for s in samples {
                let slack = 1e-6 * (s.zmax as f64).abs();
                if (s.zmax as f64) < w_lo - slack || (s.zmin as f64) > w_hi + slack {
                    continue;
                }
                if !accept(s.tri) {
                    continue;
                }
                if self.kind == MapKind::ABuffer {
                    let m = *mask.get_or_insert_with(|| ray_mask(tx));
                    if (m & s.mask).is_empty() {
                        continue;
                    }
                }
                let p = self.stored_point(tx.face, tx.x, tx.y, s);
                let d = p - origin;
                let t = d.dot(dir);
                if t <= t_min || t >= t_max {
                    continue;
                }
                let dist = d.length();
                let angle = (t / dist).clamp(-1.0, 1.0).acos();
                let threshold = tol.min_angle + tol.texels * 1.5 * self.faces.texel_size(s.z as f64) / dist;
                if angle <= threshold {
                    return Some(MapHit {
                        tri: s.tri,
                        point: p,
                        t,
                        angle,
                    });
                }
            }
            None
        };
        // The ray seen from the centre: it starts at `start` (direction e1)
        // and turns in the plane (e1, e2) toward `dir`.
        let e1 = start / ra.max(1e-300);
        let dx = dir.dot(e1);
        let perp = dir - e1 * dx;
        let dy = perp.length();
        if ra < 1e-12 * (1.0 + r) || dy < 1e-9 {
            // Radial ray: every point projects into one texel (or two, through the centre).
            let u = if ra < 1e-12 * (1.0 + r) || dx > 0.0 { dir } else { e1 };
            let tx = self.faces.texel(u);
            let axis = face_axis(tx.face);
            let (w0, w1) = ((a + dir * t_lo).dot(axis), (a + dir * t_hi).dot(axis));
            let full = |_: &Texel| Mask::FULL;
            return check(&tx, w0.min(w1), w0.max(w1), &full);
        }
        let e2 = perp / dy;
        let ray_t = |phi: f64| {
            let (s, co) = phi.sin_cos();
            let den = dy * co - dx * s;
            if den <= 0.0 {
                f64::INFINITY
            } else {
                ra * s / den
            }
        };
        let phi_end = (dy * (t_hi - t_lo)).atan2(ra + dx * (t_hi - t_lo));
        let point = |phi: f64| -> DVec3 {
            let t = ray_t(phi).min(t_hi - t_lo);
            start + dir * t
        };
        let dir_at = |phi: f64| -> DVec3 {
            let (s, co) = phi.sin_cos();
            e1 * co + e2 * s
        };
        // The subsamples the arc crosses in texel `tx` (dilated by one subsample).
        let arc_mask = |tx: &Texel, from: f64, to: f64| -> Mask {
            let mut bits = 0u32;
            let k = 16;
            for i in 0..=k {
                let phi = from + (to - from) * i as f64 / k as f64;
                let t2 = self.faces.texel(dir_at(phi));
                if t2.same_texel(tx) {
                    for dr in -1i32..=1 {
                        for dc in -1i32..=1 {
                            let (cc, rr) = (t2.c as i32 + dc, t2.r as i32 + dr);
                            if (0..Mask::COLUMNS as i32).contains(&cc) && (0..Mask::ROWS as i32).contains(&rr) {
                                bits |= 1 << Mask::bit_index(cc as u32, rr as u32);
                            }
                        }
                    }
                }
            }
            Mask(bits)
        };
        let step = |u: DVec3| {
            let cos = u.abs().max_element() / u.length();
            0.5 * (2.0 / n) * cos * cos
        };
        let mut phi = 0.0;
        let mut cur = self.faces.texel(e1);
        let mut cur_from = 0.0f64;
        let mut prev_point = start;
        let axis0 = face_axis(cur.face);
        let mut w_lo = start.dot(axis0);
        let mut w_hi = w_lo;
        let mut steps = 0u32;
        loop {
            steps = steps.wrapping_add(1);
            if steps % 16 == 0 && is_cancelled(cancel) {
                return None;
            }
            let last = phi >= phi_end;
            let phi_now = phi.min(phi_end);
            let x = point(phi_now);
            let u = dir_at(phi_now);
            let tx = self.faces.texel(u);
            let axis = face_axis(cur.face);
            let w = x.dot(axis);
            w_lo = w_lo.min(w);
            w_hi = w_hi.max(w);
            if !tx.same_texel(&cur) || last {
                let from = cur_from;
                let to = phi_now;
                let mask_fn = |t: &Texel| arc_mask(t, (from - step(u)).max(0.0), (to + step(u)).min(phi_end));
                if let Some(hit) = check(&cur, w_lo, w_hi, &mask_fn) {
                    return Some(hit);
                }
                if last {
                    return None;
                }
                // Start the new texel from the previous point (the ray entered it in between).
                let axis_new = face_axis(tx.face);
                let wp = prev_point.dot(axis_new);
                let wn = x.dot(axis_new);
                w_lo = wp.min(wn);
                w_hi = wp.max(wn);
                cur = tx;
                cur_from = (phi_now - step(u)).max(0.0);
            }
            // Empty-space skipping: jump a block's width along the arc when
            // the ray's depth over that stretch misses every sample it passes
            // (coarse blocks first). An arc shorter than a block spans at most
            // the blocks at the four corners of its start and end texels.
            let mut jumped = false;
            for level in &self.levels {
                let phi2 = (phi_now + 0.9 * 2.0 * level.size as f64 * step(u)).min(phi_end);
                let u2 = dir_at(phi2);
                let t2 = self.faces.texel(u2);
                if phi2 <= phi_now || t2.face != cur.face {
                    continue;
                }
                let bounds = level.around(&cur, &t2);
                let axis = face_axis(cur.face);
                let x2 = point(phi2);
                let (wa, wb) = (x.dot(axis), x2.dot(axis));
                let empty = bounds[0] > bounds[1];
                let slack = if empty { 0.0 } else { 1e-6 * (bounds[1].abs() as f64) };
                if !(empty || wa.max(wb) < bounds[0] as f64 - slack || wa.min(wb) > bounds[1] as f64 + slack) {
                    continue;
                }
                let from = cur_from;
                let mask_fn = |t: &Texel| arc_mask(t, (from - step(u)).max(0.0), (phi_now + step(u)).min(phi_end));
                if let Some(hit) = check(&cur, w_lo, w_hi, &mask_fn) {
                    return Some(hit);
                }
                cur = t2;
                let w2 = x2.dot(face_axis(cur.face));
                w_lo = w2;
                w_hi = w2;
                cur_from = phi2;
                prev_point = x2;
                phi = phi2;
                if phi2 >= phi_end {
                    return check(&cur, w_lo, w_hi, &|t: &Texel| arc_mask(t, phi2 - step(u2), phi2));
                }
                jumped = true;
                break;
            }
            if jumped {
                continue;
            }
            prev_point = x;
            phi += step(u);
        }
    }
}

/// Inserts `s` into a texel's depth-sorted list, merging it into a sample of
/// the same object and facing whose depth range it overlaps (masks OR-ed, the
/// larger coverage's triangle kept).
fn merge_into(list: &mut Vec<MapSample>, s: MapSample, tris: &SceneTriangles) {
    let obj = tris.object[s.tri as usize];
    for o in list.iter_mut() {
        if tris.object[o.tri as usize] == obj && o.front == s.front && o.zmin <= s.zmax && s.zmin <= o.zmax {
            if s.mask.count() > o.mask.count() {
                o.tri = s.tri;
                o.z = s.z;
            }
            o.mask = o.mask | s.mask;
            o.zmin = o.zmin.min(s.zmin);
            o.zmax = o.zmax.max(s.zmax);
            return;
        }
    }
    let at = list.partition_point(|o| o.z <= s.z);
    list.insert(at, s);
}
