//! Drawing many triangles into one view, in parallel: every scene triangle
//! is transformed, culled, clipped and projected once ([`project`]), binned
//! into horizontal bands of rows, and each band is scan-converted by one
//! thread ([`gbuffer`], [`for_each_band`]). Triangles carry their
//! barycentric coordinates as attributes, so any per-vertex quantity can be
//! interpolated afterwards (deferred shading).
//!
//! [`coverage_fragments`] is the A-buffer's scan conversion: every pixel a
//! triangle touches, with its 4×8 coverage mask and the triangle's depth range
//! over the pixel.

use glam::DVec3;
use isoray_job::{CancelToken, Cancelled};
use rayon::prelude::*;

use crate::abuffer::Mask;
use crate::pipeline::{clip_near, rasterize_rows, signed_area, ScreenVertex, Vertex, ViewTransform};
use crate::triangles::SceneTriangles;

/// A scene triangle projected into a view (a clipped piece of it).
#[derive(Debug, Clone, Copy)]
pub struct Projected {
    /// Index of the scene triangle.
    pub tri: u32,
    /// Screen vertices; attributes are barycentric coordinates of the scene triangle.
    pub v: [ScreenVertex<3>; 3],
    /// First pixel row it may touch.
    pub row0: u32,
    /// One past the last pixel row it may touch.
    pub row1: u32,
}

/// Which faces [`project`] drops.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cull {
    /// Keep every triangle.
    None,
    /// Drop triangles whose outward face normal points away from the eye
    /// (except those of two-sided objects).
    Back,
    /// Drop the triangle whatever its facing.
    All,
}

/// Transforms, culls, clips (near plane at `near`) and projects the
/// triangles `keep` accepts into `view` (eye at `eye`), in parallel.
/// Triangles outside the image rows `0..height` are dropped.
pub fn project(
    tris: &SceneTriangles,
    view: &ViewTransform,
    eye: DVec3,
    near: f64,
    cull: impl Fn(usize) -> Cull + Sync,
) -> Vec<Projected> {
    match project_with(tris, view, eye, near, cull, None) {
        Ok(p) => p,
        Err(Cancelled) => unreachable!("no token, no cancellation"),
    }
}

/// [`project`], stopping soon after `cancel` is cancelled (checked per triangle).
pub fn project_with(
    tris: &SceneTriangles,
    view: &ViewTransform,
    eye: DVec3,
    near: f64,
    cull: impl Fn(usize) -> Cull + Sync,
    cancel: Option<&CancelToken>,
) -> Result<Vec<Projected>, Cancelled> {
    let (w, h) = (view.width(), view.height());
    let projected = (0..tris.len())
        .into_par_iter()
        .flat_map_iter(|t| {
            let corners = tris.corners[t];
            let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
            let keep = !is_cancelled(cancel)
                && match cull(t) {
                    Cull::None => true,
                    Cull::Back => tris.two_sided[t] || tris.face[t].dot(centroid - eye) <= 0.0,
                    Cull::All => false,
                };
            let pieces = if keep {
                let bary = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
                let cam: [Vertex<3>; 3] =
                    std::array::from_fn(|i| Vertex::new(view.world_to_camera(corners[i].to_array()), bary[i]));
                clip_near(cam, near)
            } else {
                Vec::new()
            };
            pieces.into_iter().filter_map(move |piece| {
                let s = piece.map(|v| ScreenVertex::from_camera(view, &v));
                let [Some(a), Some(b), Some(c)] = s else { return None };
                let v = [a, b, c];
                let ys = v.map(|p| p.y);
                let xs = v.map(|p| p.x);
                let (y_lo, y_hi) = (ys[0].min(ys[1]).min(ys[2]), ys[0].max(ys[1]).max(ys[2]));
                let (x_lo, x_hi) = (xs[0].min(xs[1]).min(xs[2]), xs[0].max(xs[1]).max(xs[2]));
                // One pixel of margin: A-buffer coverage reaches half a pixel beyond centres.
                if !(y_hi >= -1.0 && y_lo <= h && x_hi >= -1.0 && x_lo <= w) {
                    return None;
                }
                let row0 = (y_lo - 1.0).floor().max(0.0) as u32;
                let row1 = ((y_hi + 2.0).ceil().min(h)).max(0.0) as u32;
                Some(Projected {
                    tri: t as u32,
                    v,
                    row0,
                    row1,
                })
            })
        })
        .collect();
    check(cancel)?;
    Ok(projected)
}

/// Splits `height` rows into bands for `threads`-way parallel drawing.
pub fn bands(height: usize) -> Vec<std::ops::Range<usize>> {
    let threads = rayon::current_num_threads().max(1);
    let n = (threads * 8).clamp(1, height.max(1));
    let size = height.div_ceil(n).max(1);
    (0..height).step_by(size).map(|y| y..(y + size).min(height)).collect()
}

/// Calls `draw(band rows, band's buffer slice, triangles touching the band)`
/// for every band of `rows_per_band`-row bands of a buffer of `width`-wide
/// rows, in parallel. `buffer` is row-major with `width` entries per row.
pub fn for_each_band<T: Send>(
    projected: &[Projected],
    buffer: &mut [T],
    width: usize,
    draw: impl Fn(std::ops::Range<usize>, &mut [T], &mut dyn Iterator<Item = &Projected>) + Sync,
) {
    let height = buffer.len().checked_div(width).unwrap_or(0);
    let bs = bands(height);
    let size = bs.first().map_or(1, |b| b.len()).max(1);
    // Bin triangles by band.
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); bs.len()];
    for (i, p) in projected.iter().enumerate() {
        let b0 = p.row0 as usize / size;
        let b1 = (p.row1 as usize).div_ceil(size).min(bs.len());
        for bin in bins.iter_mut().take(b1).skip(b0) {
            bin.push(i as u32);
        }
    }
    buffer
        .par_chunks_mut(size * width.max(1))
        .zip(bs.into_par_iter())
        .zip(bins.par_iter())
        .for_each(|((chunk, rows), bin)| {
            let mut it = bin.iter().map(|&i| &projected[i as usize]);
            draw(rows, chunk, &mut it);
        });
}

/// One pixel of a G-buffer: the nearest triangle's depth, index and
/// perspective-correct barycentric coordinates at the pixel centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GPixel {
    /// Depth `w` (camera-space distance along the view axis); infinite when empty.
    pub depth: f64,
    /// Scene triangle index (`u32::MAX` when empty).
    pub tri: u32,
    /// Barycentric coordinates of the scene triangle.
    pub bary: [f64; 3],
}

impl GPixel {
    /// Nothing drawn.
    pub const EMPTY: GPixel = GPixel {
        depth: f64::INFINITY,
        tri: u32::MAX,
        bary: [0.0; 3],
    };

    /// Whether a triangle covers the pixel.
    pub fn is_hit(&self) -> bool {
        self.tri != u32::MAX
    }
}

/// True once `cancel` (if any) is cancelled: the check long loops make per
/// triangle, pixel or texel.
pub(crate) fn is_cancelled(cancel: Option<&CancelToken>) -> bool {
    cancel.is_some_and(CancelToken::is_cancelled)
}

/// `Err(Cancelled)` once `cancel` (if any) is cancelled.
pub(crate) fn check(cancel: Option<&CancelToken>) -> Result<(), Cancelled> {
    if is_cancelled(cancel) {
        Err(Cancelled)
    } else {
        Ok(())
    }
}

/// A Z-buffer of `width`×`height` pixel centres (row-major) keeping the
/// nearest triangle per pixel, drawn in parallel bands.
pub fn gbuffer(projected: &[Projected], width: usize, height: usize) -> Vec<GPixel> {
    match gbuffer_with(projected, width, height, None) {
        Ok(buf) => buf,
        Err(Cancelled) => unreachable!("no token, no cancellation"),
    }
}

/// [`gbuffer`], stopping soon after `cancel` is cancelled: every band checks
/// the token before each triangle it scan-converts.
pub fn gbuffer_with(
    projected: &[Projected],
    width: usize,
    height: usize,
    cancel: Option<&CancelToken>,
) -> Result<Vec<GPixel>, Cancelled> {
    let mut buf = vec![GPixel::EMPTY; width * height];
    for_each_band(projected, &mut buf, width, |rows, chunk, tris| {
        let y0 = rows.start;
        for p in tris {
            if is_cancelled(cancel) {
                return;
            }
            rasterize_rows(&p.v, width, rows.clone(), |f| {
                let px = &mut chunk[(f.y as usize - y0) * width + f.x as usize];
                if f.depth < px.depth {
                    *px = GPixel {
                        depth: f.depth,
                        tri: p.tri,
                        bary: f.attributes,
                    };
                }
            });
        }
    });
    check(cancel)?;
    Ok(buf)
}

/// Perspective-correct barycentric weights of the screen triangle at screen
/// point `q` (normalised to sum 1) and 1/w there; with `clamp`, the screen
/// weights are clamped to the triangle first.
pub fn weights<const N: usize>(tri: &[ScreenVertex<N>; 3], area2: f64, q: [f64; 2], clamp: bool) -> ([f64; 3], f64) {
    let p = [tri[0].xy(), tri[1].xy(), tri[2].xy()];
    let mut l = [
        2.0 * signed_area(p[1], p[2], q) / area2,
        2.0 * signed_area(p[2], p[0], q) / area2,
        0.0,
    ];
    l[2] = 1.0 - l[0] - l[1];
    if clamp {
        l = l.map(|x| x.max(0.0));
        let s = l[0] + l[1] + l[2];
        l = l.map(|x| x / s);
    }
    let lw = [l[0] * tri[0].inv_w, l[1] * tri[1].inv_w, l[2] * tri[2].inv_w];
    let inv_w = lw[0] + lw[1] + lw[2];
    (lw.map(|x| x / inv_w), inv_w)
}

/// One A-buffer fragment of a triangle: a pixel it touches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coverage<const N: usize> {
    /// Pixel column.
    pub x: usize,
    /// Pixel row.
    pub y: usize,
    /// Covered subsamples.
    pub mask: Mask,
    /// Nearest depth of the triangle over the pixel.
    pub zmin: f64,
    /// Farthest depth of the triangle over the pixel.
    pub zmax: f64,
    /// Depth at the pixel centre (on the triangle's plane, clamped to its depth range).
    pub z: f64,
    /// Attributes at the pixel centre, clamped to the triangle (never extrapolated).
    pub attributes: [f64; N],
}

/// Every pixel in rows `rows` (of a `width`-wide image) that the screen
/// triangle covers at one of its 32 subsamples, with the coverage mask
/// ([`Mask::coverage`]), the depth range of the triangle across the pixel's
/// four corners (perspective-correct, clamped to the vertex depths) and the
/// attributes at the pixel centre.
pub fn coverage_fragments<const N: usize>(
    tri: &[ScreenVertex<N>; 3],
    width: usize,
    rows: std::ops::Range<usize>,
    mut emit: impl FnMut(&Coverage<N>),
) {
    let p = [tri[0].xy(), tri[1].xy(), tri[2].xy()];
    let area2 = 2.0 * signed_area(p[0], p[1], p[2]);
    if area2 == 0.0 || !area2.is_finite() || width == 0 {
        return;
    }
    let min = |k: usize| p.iter().map(|v| v[k]).fold(f64::INFINITY, f64::min);
    let max = |k: usize| p.iter().map(|v| v[k]).fold(f64::NEG_INFINITY, f64::max);
    let x0 = ((min(0) - 0.5).floor() as i64).max(0);
    let x1 = ((max(0) + 0.5).ceil() as i64).min(width as i64 - 1);
    let y0 = ((min(1) - 0.5).floor() as i64).max(rows.start as i64);
    let y1 = ((max(1) + 0.5).ceil() as i64).min(rows.end as i64 - 1);
    let depths = tri.map(|v| 1.0 / v.inv_w);
    let dmin = depths.iter().copied().fold(f64::INFINITY, f64::min);
    let dmax = depths.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let depth_at = |q: [f64; 2]| {
        let (_, inv_w) = weights(tri, area2, q, false);
        if inv_w > 0.0 {
            (1.0 / inv_w).clamp(dmin, dmax)
        } else {
            dmax
        }
    };
    for y in y0..=y1 {
        for x in x0..=x1 {
            let mask = Mask::coverage(&p, x as i32, y as i32);
            if mask.is_empty() {
                continue;
            }
            let (xf, yf) = (x as f64, y as f64);
            let (wt, _) = weights(tri, area2, [xf, yf], true);
            let attributes: [f64; N] = std::array::from_fn(|k| {
                wt[0] * tri[0].attributes[k] + wt[1] * tri[1].attributes[k] + wt[2] * tri[2].attributes[k]
            });
            let (mut zmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
            for (dx, dy) in [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)] {
                let d = depth_at([xf + dx, yf + dy]);
                zmin = zmin.min(d);
                zmax = zmax.max(d);
            }
            let z = depth_at([xf, yf]);
            emit(&Coverage {
                x: x as usize,
                y: y as usize,
                mask,
                zmin,
                zmax,
                z,
                attributes,
            });
        }
    }
}
