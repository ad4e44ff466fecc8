//! Shadow buffers (Williams 1978): the scene's depth seen from each light;
//! a point is lit when it is no farther from the light than the depth
//! stored where it projects, less a bias, with percentage-closer filtering
//! (Reeves et al. 1987) over the 3×3 texels around it.
//!
//! Point, sphere and rectangle lights get an omnidirectional buffer (six 90°
//! faces around the light's centre); directional lights get one narrow
//! perspective view from far away along the light's direction (nearly
//! orthographic), framing the bounded objects at twice their radius (so the
//! shadows they cast on a ground plane fit), or the whole scene when every
//! object is unbounded. Points outside a buffer are lit.
//!
//! Against shadow acne, the point is looked up 1.5 texels off its surface
//! along the normal (on the light's side), and compared with a bias that
//! grows with the texel's size at the point's depth and with the slope of
//! the surface seen from the light: `bias = texel · (0.75 + 1.5 · min(tan θ,
//! 8))`, θ the angle between the normal and the light direction.

use glam::DVec3;
use isoray_job::{CancelToken, Cancelled};
use isoray_scene::{Camera, LightKind, Projection, Scene};

use crate::draw::{gbuffer_with, project_with, Cull};
use crate::envmap::{face_of, CubeFaces};
use crate::pipeline::ViewTransform;
use crate::triangles::SceneTriangles;

/// The depth buffer of one light.
#[derive(Debug, Clone)]
pub struct ShadowBuffer {
    views: Vec<ViewTransform>,
    omni: bool,
    size: usize,
    tan_half: f64,
    depth: Vec<Vec<f32>>,
}

impl ShadowBuffer {
    fn render(
        tris: &SceneTriangles,
        views: Vec<ViewTransform>,
        omni: bool,
        size: usize,
        tan_half: f64,
        near: f64,
        cancel: Option<&CancelToken>,
    ) -> Result<Self, Cancelled> {
        let depth = views
            .iter()
            .map(|v| {
                let eye = DVec3::from(v.eye());
                let projected = project_with(tris, v, eye, near, |_| Cull::None, cancel)?;
                Ok(gbuffer_with(&projected, size, size, cancel)?
                    .into_iter()
                    .map(|p| p.depth as f32)
                    .collect())
            })
            .collect::<Result<_, Cancelled>>()?;
        Ok(ShadowBuffer {
            views,
            omni,
            size,
            tan_half,
            depth,
        })
    }

    /// The fraction (0–1) of the 3×3 percentage-closer filter that sees point
    /// `p` (unit normal `n`, unit direction `l` toward the light) lit.
    pub fn visibility(&self, p: DVec3, n: DVec3, l: DVec3) -> f32 {
        let eye = DVec3::from(self.views[0].eye());
        let f = if self.omni { face_of(p - eye) } else { 0 };
        let n_px = self.size as f64;
        // Normal offset: look the point up a texel and a half off its surface,
        // on the light's side, then compare with a slope-scaled bias.
        let Some([_, _, w0]) = self.views[f].to_screen(p.to_array()) else {
            return 1.0;
        };
        let texel0 = 2.0 * w0 * self.tan_half / n_px;
        let side = if n.dot(l) >= 0.0 { n } else { -n };
        let q = p + side * (1.5 * texel0);
        let f = if self.omni { face_of(q - eye) } else { f };
        let view = &self.views[f];
        let Some([sx, sy, w]) = view.to_screen(q.to_array()) else {
            return 1.0;
        };
        if !(-0.5..n_px - 0.5).contains(&sx) || !(-0.5..n_px - 0.5).contains(&sy) {
            return 1.0;
        }
        let texel = 2.0 * w * self.tan_half / n_px;
        let cos = n.dot(l).abs().clamp(1e-3, 1.0);
        let tan = ((1.0 - cos * cos).sqrt() / cos).min(8.0);
        let bias = texel * (0.75 + 1.5 * tan);
        let (cx, cy) = ((sx + 0.5).floor() as i64, (sy + 0.5).floor() as i64);
        let last = self.size as i64 - 1;
        let mut lit = 0;
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (x, y) = ((cx + dx).clamp(0, last) as usize, (cy + dy).clamp(0, last) as usize);
                if w - bias <= self.depth[f][y * self.size + x] as f64 {
                    lit += 1;
                }
            }
        }
        lit as f32 / 9.0
    }
}

/// One shadow buffer per light of a scene.
#[derive(Debug, Clone)]
pub struct ShadowBuffers {
    /// Per light, in `scene.lights` order.
    pub lights: Vec<ShadowBuffer>,
}

impl ShadowBuffers {
    /// Renders a `size`×`size` buffer (per face) for every light of `scene`.
    pub fn build(scene: &Scene, tris: &SceneTriangles, size: usize, near: f64) -> Self {
        match Self::build_with(scene, tris, size, near, None) {
            Ok(b) => b,
            Err(Cancelled) => unreachable!("no token, no cancellation"),
        }
    }

    /// [`ShadowBuffers::build`], stopping soon after `cancel` is cancelled
    /// (checked before each face and each triangle drawn).
    pub fn build_with(
        scene: &Scene,
        tris: &SceneTriangles,
        size: usize,
        near: f64,
        cancel: Option<&CancelToken>,
    ) -> Result<Self, Cancelled> {
        let size = size.max(1);
        // Directional buffers frame the bounded objects (twice their radius,
        // for the shadows they cast on unbounded ones such as a ground
        // plane), or everything when there are none.
        let [lo, hi] = tris.bounds;
        let [blo, bhi] = tris.bounded;
        let (centre, radius) = if blo.cmple(bhi).all() {
            let c = (blo + bhi) * 0.5;
            (c, ((bhi - blo).length()).max(1e-6))
        } else if tris.is_empty() {
            (DVec3::ZERO, 1.0)
        } else {
            let c = (lo + hi) * 0.5;
            (c, tris.radius_from(c).max(1e-6))
        };
        let lights = scene
            .lights
            .iter()
            .map(|light| match light.kind {
                LightKind::Point { position }
                | LightKind::Sphere { position, .. }
                | LightKind::Rect { position, .. } => {
                    let faces = CubeFaces::new(DVec3::from(position), size);
                    ShadowBuffer::render(tris, faces.views.to_vec(), true, size, 1.0, near, cancel)
                }
                LightKind::Directional { direction } => {
                    let l = DVec3::from(direction).normalize_or(DVec3::Y);
                    let dist = 100.0 * radius;
                    let half = (radius / (dist - radius)).atan();
                    let up = if l.y.abs() > 0.9 {
                        [1.0, 0.0, 0.0]
                    } else {
                        [0.0, 1.0, 0.0]
                    };
                    let cam = Camera {
                        position: (centre + l * dist).to_array(),
                        target: centre.to_array(),
                        up,
                        fov: (2.0 * half).to_degrees(),
                        projection: Projection::Perspective,
                    };
                    let view = ViewTransform::new(&cam, size as u32, size as u32);
                    ShadowBuffer::render(
                        tris,
                        vec![view],
                        false,
                        size,
                        half.tan(),
                        near.max(dist - 2.0 * radius),
                        cancel,
                    )
                }
            })
            .collect::<Result<_, Cancelled>>()?;
        Ok(ShadowBuffers { lights })
    }
}
