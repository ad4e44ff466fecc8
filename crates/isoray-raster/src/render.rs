//! `isoray raster`'s renderer: the scene's objects meshed, transformed,
//! clipped, scan-converted and shaded, with a Z-buffer or an A-buffer.
//!
//! A-buffer fragments: the coverage mask is [`Mask::coverage`] of the screen
//! triangle over the pixel; the colour is shaded at the pixel centre (its
//! barycentric coordinates clamped to the triangle, so attributes are never
//! extrapolated); the depth range is the triangle's depth at the pixel's four
//! corners (perspective-correct, extended across the pixel's plane), clamped
//! to the triangle's vertex depths; opacity is 1 − the material's
//! transparency; the object id is the object's index in the scene.
//!
//! Opaque objects are back-face culled (against the face normal oriented by
//! the vertex normals, so winding does not matter); transparent ones are not.

use glam::Vec3;
use isoray_scene::{Projection, Scene};

use crate::abuffer::{ABuffer, Fragment as AFragment, Mask};
use crate::pipeline::{clip_near, signed_area, ScreenVertex, Vertex, ViewTransform, ZBuffer};
use crate::scene::{cross, mesh_scene, sub, MeshedScene, SceneMeshError};
use crate::shading::{Lighting, Shading};

/// How hidden surfaces are removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HiddenSurface {
    /// One sample per pixel centre, nearest wins.
    #[default]
    ZBuffer,
    /// 32-subsample coverage masks per fragment, resolved front to back (antialiased, transparency).
    ABuffer,
}

/// What [`raster`] does.
#[derive(Debug, Clone, PartialEq)]
pub struct RasterOptions {
    /// Hidden-surface removal.
    pub hidden: HiddenSurface,
    /// Shading of polygons.
    pub shading: Shading,
    /// Mesh resolution: cells along each object's longest side.
    pub resolution: u32,
    /// Distance of the near clipping plane from the camera.
    pub near: f64,
}

impl Default for RasterOptions {
    fn default() -> Self {
        RasterOptions {
            hidden: HiddenSurface::ZBuffer,
            shading: Shading::Phong,
            resolution: 96,
            near: 1e-3,
        }
    }
}

/// A rendered image, linear RGB, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct RasterImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB per pixel.
    pub color: Vec<[f32; 3]>,
    /// Triangles sent down the pipeline.
    pub triangles: usize,
    /// Objects skipped and similar notes.
    pub warnings: Vec<String>,
}

/// Why [`raster`] failed.
#[derive(Debug, thiserror::Error)]
pub enum RasterError {
    /// An object could not be meshed.
    #[error(transparent)]
    Mesh(#[from] SceneMeshError),
    /// The camera is not a perspective one.
    #[error("the polygon pipeline renders perspective cameras only (camera.projection = equirect is not supported)")]
    Projection,
    /// The options are out of range.
    #[error("{0}")]
    Options(String),
}

/// Attribute count per vertex: world position, then a normal (Phong) or a colour (flat, Gouraud).
const N: usize = 6;

/// Meshes and renders `scene`.
pub fn raster(scene: &Scene, opts: &RasterOptions) -> Result<RasterImage, RasterError> {
    check(scene, opts)?;
    let meshed = mesh_scene(scene, opts.resolution)?;
    raster_meshes(scene, &meshed, opts)
}

fn check(scene: &Scene, opts: &RasterOptions) -> Result<(), RasterError> {
    if scene.camera.projection != Projection::Perspective {
        return Err(RasterError::Projection);
    }
    if opts.resolution < 2 {
        return Err(RasterError::Options(format!(
            "the mesh resolution must be at least 2, found {}",
            opts.resolution
        )));
    }
    if !(opts.near.is_finite() && opts.near > 0.0) {
        return Err(RasterError::Options(format!(
            "the near plane must be a positive distance, found {}",
            opts.near
        )));
    }
    Ok(())
}

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    if l > 0.0 {
        [a[0] / l, a[1] / l, a[2] / l]
    } else {
        a
    }
}

/// Renders already meshed objects of `scene`.
pub fn raster_meshes(scene: &Scene, meshed: &MeshedScene, opts: &RasterOptions) -> Result<RasterImage, RasterError> {
    check(scene, opts)?;
    let (w, h) = (scene.render.width, scene.render.height);
    let view = ViewTransform::new(&scene.camera, w, h);
    let lighting = Lighting::new(scene);
    let bg = scene.render.background.map(|c| c as f32);
    let eye = scene.camera.position;
    let (wu, hu) = (w as usize, h as usize);
    let mut zbuf = (opts.hidden == HiddenSurface::ZBuffer).then(|| ZBuffer::new(wu, hu, bg));
    let mut abuf = (opts.hidden == HiddenSurface::ABuffer).then(|| ABuffer::new(wu, hu));
    let mut triangles = 0;
    for om in &meshed.objects {
        let m = om.material;
        let opacity = lighting.opacity(m);
        let mesh = &om.mesh;
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let corners = mesh.corners(t);
            let normals = tri.map(|v| mesh.normals[v as usize].map(f64::from));
            let [a, b, c] = corners;
            let mut face = normalize(cross(sub(b, a), sub(c, a)));
            let nsum: [f64; 3] = std::array::from_fn(|k| normals[0][k] + normals[1][k] + normals[2][k]);
            if face[0] * nsum[0] + face[1] * nsum[1] + face[2] * nsum[2] < 0.0 {
                face = face.map(|x| -x);
            }
            let centroid: [f64; 3] = std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0);
            let to_c = sub(centroid, eye);
            if opacity >= 1.0 && face[0] * to_c[0] + face[1] * to_c[1] + face[2] * to_c[2] > 0.0 {
                continue;
            }
            let flat = (opts.shading == Shading::Flat).then(|| lighting.shade(m, v3(centroid), v3(face)));
            let verts: [Vertex<N>; 3] = std::array::from_fn(|i| {
                let p = corners[i];
                let x: [f64; 3] = match opts.shading {
                    Shading::Phong => normals[i],
                    Shading::Gouraud => lighting.shade(m, v3(p), v3(normals[i])).to_array().map(f64::from),
                    Shading::Flat => flat.unwrap_or_default().to_array().map(f64::from),
                };
                Vertex::new(view.world_to_camera(p), [p[0], p[1], p[2], x[0], x[1], x[2]])
            });
            triangles += 1;
            let shade = |attr: &[f64; N]| -> [f32; 3] {
                match opts.shading {
                    Shading::Phong => {
                        let n = Vec3::new(attr[3] as f32, attr[4] as f32, attr[5] as f32).normalize_or_zero();
                        let p = Vec3::new(attr[0] as f32, attr[1] as f32, attr[2] as f32);
                        lighting.shade(m, p, n).to_array()
                    }
                    _ => [attr[3] as f32, attr[4] as f32, attr[5] as f32],
                }
            };
            for piece in clip_near(verts, opts.near) {
                let s = piece.map(|v| ScreenVertex::from_camera(&view, &v));
                let [Some(sa), Some(sb), Some(sc)] = s else { continue };
                let st = [sa, sb, sc];
                if let Some(zb) = &mut zbuf {
                    zb.draw_triangle(&st, |f| shade(&f.attributes));
                }
                if let Some(ab) = &mut abuf {
                    a_buffer_triangle(ab, &st, om.object as u32, opacity, &shade);
                }
            }
        }
    }
    let color = match (zbuf, abuf) {
        (Some(zb), _) => zb.color,
        (_, Some(ab)) => ab.resolve_image(bg),
        _ => unreachable!("one hidden-surface method is chosen"),
    };
    Ok(RasterImage {
        width: w,
        height: h,
        color,
        triangles,
        warnings: meshed.warnings.clone(),
    })
}

/// Perspective-correct barycentric weights (normalised) and 1/w of screen point `q`.
fn weights(tri: &[ScreenVertex<N>; 3], area2: f64, q: [f64; 2], clamp: bool) -> ([f64; 3], f64) {
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

/// Adds the fragments of one screen triangle to the A-buffer.
fn a_buffer_triangle(
    ab: &mut ABuffer,
    tri: &[ScreenVertex<N>; 3],
    object: u32,
    opacity: f32,
    shade: &impl Fn(&[f64; N]) -> [f32; 3],
) {
    let p = [tri[0].xy(), tri[1].xy(), tri[2].xy()];
    let area2 = 2.0 * signed_area(p[0], p[1], p[2]);
    if area2 == 0.0 || !area2.is_finite() {
        return;
    }
    let min = |k: usize| p.iter().map(|v| v[k]).fold(f64::INFINITY, f64::min);
    let max = |k: usize| p.iter().map(|v| v[k]).fold(f64::NEG_INFINITY, f64::max);
    let x0 = ((min(0) - 0.5).floor() as i64).max(0);
    let x1 = ((max(0) + 0.5).ceil() as i64).min(ab.width as i64 - 1);
    let y0 = ((min(1) - 0.5).floor() as i64).max(0);
    let y1 = ((max(1) + 0.5).ceil() as i64).min(ab.height as i64 - 1);
    let depths = tri.map(|v| 1.0 / v.inv_w);
    let (dmin, dmax) = (
        depths.iter().copied().fold(f64::INFINITY, f64::min),
        depths.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    for y in y0..=y1 {
        for x in x0..=x1 {
            let mask = Mask::coverage(&p, x as i32, y as i32);
            if mask.is_empty() {
                continue;
            }
            let (wt, _) = weights(tri, area2, [x as f64, y as f64], true);
            let attr: [f64; N] = std::array::from_fn(|k| {
                wt[0] * tri[0].attributes[k] + wt[1] * tri[1].attributes[k] + wt[2] * tri[2].attributes[k]
            });
            let (mut zmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
            for (dx, dy) in [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)] {
                let (_, inv_w) = weights(tri, area2, [x as f64 + dx, y as f64 + dy], false);
                let d = if inv_w > 0.0 {
                    (1.0 / inv_w).clamp(dmin, dmax)
                } else {
                    dmax
                };
                zmin = zmin.min(d);
                zmax = zmax.max(d);
            }
            ab.add(
                x as usize,
                y as usize,
                AFragment {
                    mask,
                    zmin: zmin as f32,
                    zmax: zmax as f32,
                    color: shade(&attr),
                    opacity,
                    object,
                },
            );
        }
    }
}
