//! `isoray raster`'s renderer: the scene's objects meshed, transformed,
//! clipped, scan-converted in parallel bands and shaded, behind a Z-buffer or
//! an A-buffer, with shadows from shadow buffers or from the A-buffered
//! environment map, and reflections and refractions from environment maps.
//!
//! **Z-buffer.** Deferred: the nearest triangle and its perspective-correct
//! barycentric coordinates are kept per pixel centre, then every visible
//! pixel is shaded once.
//!
//! **A-buffer.** A fragment per pixel a triangle touches: the coverage mask
//! is [`crate::abuffer::Mask::coverage`] of the screen triangle; the colour
//! is shaded at the pixel centre (barycentric coordinates clamped to the
//! triangle, so attributes are never extrapolated); the depth range is the
//! triangle's depth at the pixel's four corners (clamped to its vertex
//! depths); opacity is 1 − the material's transparency when refraction is
//! not mapped (1 when it is: the refracted colour then comes from the map);
//! the object id is the object's index in the scene.
//!
//! **Culling.** Opaque objects are back-face culled (against the face normal
//! oriented by the vertex normals, so winding does not matter); transparent
//! ones are not.
//!
//! **Shading** is the ray tracer's model (`isoray_shade`): at a reflective or
//! transparent surface the light splits by the Fresnel equations into a
//! reflected part, a transmitted part and the local (ambient and diffuse)
//! part; local shading has emission, ambient and, per light, diffuse and
//! specular terms times the light's visibility. Surfaces found in an
//! environment map are shaded locally, as seen from the point that looked
//! them up (one bounce, as the ray tracer with `render.max_depth = 1`, except
//! that a refracted ray is followed through the object it enters to the
//! first surface beyond it with the A-buffered map).

use std::collections::HashMap;
use std::time::Instant;

use glam::{DVec3, Vec3};
use isoray_scene::{Projection, Scene};
use isoray_shade::optics::{beer_lambert, interface, reflect, Split};
use isoray_shade::{to_vec3, MaterialSample};
use rayon::prelude::*;

use crate::abuffer::{Fragment as AFragment, FragmentList};
use crate::draw::{coverage_fragments, for_each_band, gbuffer_with, is_cancelled, project_with, Cull, GPixel};
use crate::envmap::{CubeMap, MapKind, SearchTolerance};
use crate::pipeline::ViewTransform;
use crate::scene::{mesh_scene_with, MeshedScene, SceneMeshError};
use crate::shading::{Lighting, Shading};
use crate::shadow::ShadowBuffers;
use crate::triangles::SceneTriangles;

/// How hidden surfaces are removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HiddenSurface {
    /// One sample per pixel centre, nearest wins.
    #[default]
    ZBuffer,
    /// 32-subsample coverage masks per fragment, resolved front to back (antialiased, transparency).
    ABuffer,
}

/// Where shadows come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ShadowMethod {
    /// No shadows.
    #[default]
    None,
    /// A shadow buffer per light, with bias and percentage-closer filtering.
    Buffer,
    /// A walk through the camera-centred A-buffered cube map, from the light toward the point.
    EnvMap,
}

/// Where reflections and refractions come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ReflectionMethod {
    /// None: reflective surfaces show their local shading only (transparency
    /// is A-buffer blending).
    #[default]
    None,
    /// One cube map per reflective object (centred on it, without it), looked up by direction.
    BlinnNewell,
    /// One camera-centred Z-buffered cube map, searched along the ray.
    ZBufferMap,
    /// One camera-centred A-buffered cube map with back faces kept, searched along the ray through every layer.
    ABufferMap,
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
    /// Shadows.
    pub shadows: ShadowMethod,
    /// Reflections and refractions.
    pub reflections: ReflectionMethod,
    /// Texels along a side of each environment-map face and shadow-buffer face.
    pub map_size: usize,
    /// The environment-map search's angle threshold.
    pub tolerance: SearchTolerance,
    /// Record, per reflective pixel centre, what the reflection lookup found ([`RasterImage::probes`]).
    pub probes: bool,
    /// Stops the render soon after it is cancelled: it is checked per object
    /// meshed, per face and per triangle drawn into each shadow buffer and
    /// environment map, per triangle drawn into the image and per pixel
    /// shaded, so the render returns [`RasterError::Cancelled`] within a few
    /// milliseconds.
    pub cancel: Option<isoray_job::CancelToken>,
}

impl Default for RasterOptions {
    fn default() -> Self {
        RasterOptions {
            hidden: HiddenSurface::ZBuffer,
            shading: Shading::Phong,
            resolution: 96,
            near: 1e-3,
            shadows: ShadowMethod::None,
            reflections: ReflectionMethod::None,
            map_size: 512,
            cancel: None,
            tolerance: SearchTolerance::default(),
            probes: false,
        }
    }
}

/// What the reflection lookup of one reflective pixel centre found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReflectionProbe {
    /// Pixel index (row-major).
    pub pixel: u32,
    /// The surface point (on the mesh).
    pub origin: DVec3,
    /// Its unit normal, facing the camera.
    pub normal: DVec3,
    /// The exact reflected direction.
    pub direction: DVec3,
    /// Mean edge length of the triangle at the pixel (the mesh's local scale).
    pub footprint: f64,
    /// The object found and the point the map stored, or `None` (background).
    pub found: Option<(u32, DVec3)>,
}

impl ReflectionProbe {
    /// Angle (radians) between the reflected direction and the direction
    /// from the surface point to the point found (0 for the background,
    /// which is looked up along the reflected direction itself).
    pub fn angular_error(&self) -> f64 {
        match self.found {
            None => 0.0,
            Some((_, p)) => {
                let d = (p - self.origin).normalize_or_zero();
                d.dot(self.direction).clamp(-1.0, 1.0).acos()
            }
        }
    }
}

/// Seconds spent in each stage.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Timings {
    /// Meshing the objects.
    pub mesh: f64,
    /// Rendering shadow buffers and environment maps.
    pub maps: f64,
    /// Drawing and shading the image.
    pub draw: f64,
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
    /// Time per stage.
    pub timings: Timings,
    /// Fragments stored in the environment maps.
    pub map_fragments: usize,
    /// With [`RasterOptions::probes`]: the reflective pixel centres' lookups.
    pub probes: Vec<ReflectionProbe>,
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
    /// [`RasterOptions::cancel`] was cancelled.
    #[error("cancelled")]
    Cancelled,
}

impl From<isoray_job::Cancelled> for RasterError {
    fn from(_: isoray_job::Cancelled) -> Self {
        RasterError::Cancelled
    }
}

/// `Err(Cancelled)` once the options' token is cancelled.
fn stop(opts: &RasterOptions) -> Result<(), RasterError> {
    match &opts.cancel {
        Some(c) if c.is_cancelled() => Err(RasterError::Cancelled),
        _ => Ok(()),
    }
}

/// Meshes and renders `scene`.
pub fn raster(scene: &Scene, opts: &RasterOptions) -> Result<RasterImage, RasterError> {
    check(scene, opts)?;
    let start = Instant::now();
    let meshed = match mesh_scene_with(scene, opts.resolution, opts.cancel.as_ref()) {
        Err(e) if e.source == isoray_mesh::MeshError::Cancelled => return Err(RasterError::Cancelled),
        r => r?,
    };
    let mesh = start.elapsed().as_secs_f64();
    let mut image = raster_meshes(scene, &meshed, opts)?;
    image.timings.mesh = mesh;
    Ok(image)
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
    if !(1..=8192).contains(&opts.map_size) {
        return Err(RasterError::Options(format!(
            "the map size must be between 1 and 8192 texels, found {}",
            opts.map_size
        )));
    }
    if !(opts.tolerance.texels.is_finite() && opts.tolerance.texels >= 0.0 && opts.tolerance.min_angle >= 0.0) {
        return Err(RasterError::Options(
            "the search tolerance must be non-negative".to_string(),
        ));
    }
    Ok(())
}

/// Everything shading needs, prepared once per image.
struct Ctx<'a> {
    scene: &'a Scene,
    tris: &'a SceneTriangles,
    lighting: Lighting<'a>,
    opts: &'a RasterOptions,
    shadow_buffers: Option<ShadowBuffers>,
    /// The camera-centred A-buffered map (reflections, refractions or shadows).
    amap: Option<CubeMap>,
    /// The camera-centred Z-buffered map.
    zmap: Option<CubeMap>,
    /// Blinn–Newell maps per reflective or transparent object.
    object_maps: HashMap<u32, CubeMap>,
    background: Vec3,
    /// How far outside a surface its material is looked up (checkers).
    lookup_offset: f64,
}

fn v3(p: DVec3) -> Vec3 {
    p.as_vec3()
}

impl Ctx<'_> {
    /// The shading normal of triangle `t` at barycentric `b` (point `p`,
    /// seen from `viewer`): the vertex normals interpolated, tilted by the
    /// object's dent maps, and kept on the side of the surface the
    /// interpolated normal is (a steep dent wall tilted past the line of
    /// sight would otherwise read as the surface's inside).
    fn normal_at(&self, t: usize, b: [f64; 3], p: DVec3, viewer: DVec3) -> DVec3 {
        let n = self.tris.normal(t, b).as_dvec3();
        let d = (p - viewer).normalize_or_zero();
        let Some(w) = self.scene.dent_normal(
            self.tris.object[t] as usize,
            p.to_array(),
            n.to_array(),
            (-d).to_array(),
        ) else {
            return n;
        };
        let w = DVec3::from_array(w);
        let side = n.dot(d);
        if w.dot(d) * side > 0.0 {
            return w;
        }
        (w - d * w.dot(d) + d * (1e-3 * side.signum())).normalize_or_zero()
    }

    /// The render's cancel token, which map searches check.
    fn cancel(&self) -> Option<&isoray_job::CancelToken> {
        self.opts.cancel.as_ref()
    }

    /// The material of triangle `t` at `p`, looked up a hair outside the
    /// surface: a face lying on a checker boundary (a floor at y = 0) would
    /// otherwise flip between the two materials with rounding.
    fn surface_at(&self, t: usize, p: DVec3) -> MaterialSample {
        let q = p + self.tris.face[t] * self.lookup_offset;
        *self.lighting.surface(self.tris.material[t] as usize, v3(q))
    }

    /// The light arriving from direction `d` when nothing is hit.
    fn sky(&self, d: DVec3) -> Vec3 {
        match &self.scene.environment {
            Some(env) => Vec3::from(env.radiance(v3(d).to_array())),
            None => self.background,
        }
    }

    /// Visibility of light `i` from `p` (normal `n`), direction `l`, distance `dist`.
    fn visibility(&self, i: usize, p: DVec3, n: DVec3, l: Vec3, dist: f32) -> f32 {
        let l = l.as_dvec3();
        match self.opts.shadows {
            ShadowMethod::None => 1.0,
            ShadowMethod::Buffer => match &self.shadow_buffers {
                Some(sb) => sb.lights[i].visibility(p, n, l),
                None => 1.0,
            },
            ShadowMethod::EnvMap => {
                let Some(map) = &self.amap else { return 1.0 };
                // Walk from the light toward the point; the first occluder
                // before the point's own surface shadows it.
                let texel = map.faces.texel_size((p - map.faces.centre).length());
                let cos = n.dot(l).abs().max(0.05);
                let guard = 3.0 * texel / cos;
                let (origin, to_p, total) = if dist.is_finite() {
                    let light = p + l * dist as f64;
                    (light, -l, dist as f64)
                } else {
                    let far = 2.0 * map.radius + (p - map.faces.centre).length() + 1.0;
                    (p + l * far, -l, far)
                };
                let tol = &self.opts.tolerance;
                let hit = map.search_with(origin, to_p, 0.0, total - guard, tol, |_| true, self.cancel());
                if hit.is_some() {
                    0.0
                } else {
                    1.0
                }
            }
        }
    }

    /// Local shading of surface `s` at `p` (normal `n` facing `viewer`), with shadows.
    fn local(&self, s: &MaterialSample, p: DVec3, n: DVec3, viewer: DVec3, weight: Vec3) -> Vec3 {
        let v = (viewer - p).normalize_or_zero();
        self.lighting
            .shade_lit(s, v3(p), v3(n), v3(v), weight, |i, l, d| self.visibility(i, p, n, l, d))
    }

    /// The Fresnel split at surface `s` for a ray arriving along `d` at unit
    /// normal `n` (facing the ray), entering (`inside` false) or leaving the object.
    fn split_at(&self, s: &MaterialSample, d: DVec3, n: DVec3, inside: bool) -> (Split, Option<DVec3>) {
        let (n1, n2) = if inside { (s.ior, 1.0) } else { (1.0, s.ior) };
        let at = interface(s, v3(d), v3(n), (-n.dot(d)) as f32, n1, n2);
        (at.split, at.refracted.map(|t| t.as_dvec3()))
    }

    /// The colour of the surface found by a map lookup: triangle `tri` at
    /// `p`, seen from `viewer` (local shading with the Fresnel split's local weight).
    fn secondary(&self, tri: u32, p: DVec3, viewer: DVec3) -> Vec3 {
        let t = tri as usize;
        let b = self.tris.barycentric(t, p);
        let mut n = self.normal_at(t, b, p, viewer);
        let d = (p - viewer).normalize_or_zero();
        if n.dot(d) > 0.0 {
            n = -n;
        }
        let s = self.surface_at(t, p);
        let weight = if s.is_optical() {
            self.split_at(&s, d, n, false).0.local
        } else {
            Vec3::ONE
        };
        self.local(&s, p, n, viewer, weight)
    }

    /// Minimum ray parameter for a map search leaving `p`: a few texels of the map at `p`.
    fn guard(map: &CubeMap, p: DVec3, d: DVec3, n: DVec3) -> f64 {
        let texel = map.faces.texel_size((p - map.faces.centre).length());
        2.0 * texel / d.dot(n).abs().max(0.1)
    }

    /// What the reflected ray from `p` (object `obj`, normal `n`) along `r` finds.
    fn reflection_hit(&self, obj: u32, p: DVec3, n: DVec3, r: DVec3) -> Option<(u32, DVec3)> {
        match self.opts.reflections {
            ReflectionMethod::None => None,
            ReflectionMethod::BlinnNewell => self.object_maps.get(&obj)?.lookup(r),
            ReflectionMethod::ZBufferMap | ReflectionMethod::ABufferMap => {
                let map = if self.opts.reflections == ReflectionMethod::ZBufferMap {
                    self.zmap.as_ref()?
                } else {
                    self.amap.as_ref()?
                };
                let tris = self.tris;
                let front = |t: u32| tris.face[t as usize].dot(r) < 0.0;
                map.search_with(
                    p,
                    r,
                    Self::guard(map, p, r, n),
                    f64::INFINITY,
                    &self.opts.tolerance,
                    front,
                    self.cancel(),
                )
                .map(|h| (h.tri, h.point))
            }
        }
    }

    /// The light arriving at `p` along the refracted direction `t` into object `obj` (material `s`).
    fn refraction(&self, obj: u32, s: &MaterialSample, p: DVec3, n: DVec3, t: DVec3) -> Vec3 {
        let tris = self.tris;
        match self.opts.reflections {
            ReflectionMethod::None => Vec3::ZERO,
            ReflectionMethod::BlinnNewell => match self.object_maps.get(&obj).and_then(|m| m.lookup(t)) {
                Some((tri, q)) => self.secondary(tri, q, p),
                None => self.sky(t),
            },
            ReflectionMethod::ZBufferMap => {
                let Some(map) = &self.zmap else { return self.sky(t) };
                let other = |k: u32| tris.object[k as usize] != obj && tris.face[k as usize].dot(t) < 0.0;
                match map.search_with(
                    p,
                    t,
                    Self::guard(map, p, t, n),
                    f64::INFINITY,
                    &self.opts.tolerance,
                    other,
                    self.cancel(),
                ) {
                    Some(h) => self.secondary(h.tri, h.point, p),
                    None => self.sky(t),
                }
            }
            ReflectionMethod::ABufferMap => {
                let Some(map) = &self.amap else { return self.sky(t) };
                // Through the object: find its back face, refract out (or
                // reflect internally), then the first surface beyond.
                let (mut o, mut d, mut nn) = (p, t, -n);
                let mut weight = Vec3::ONE;
                for _ in 0..4 {
                    let exit = |k: u32| tris.object[k as usize] == obj && tris.face[k as usize].dot(d) > 0.0;
                    let Some(h) = map.search_with(
                        o,
                        d,
                        Self::guard(map, o, d, nn),
                        f64::INFINITY,
                        &self.opts.tolerance,
                        exit,
                        self.cancel(),
                    ) else {
                        return weight * self.sky(d);
                    };
                    weight *= beer_lambert(s.absorption, (h.point - o).length() as f32);
                    let k = h.tri as usize;
                    let out_n = self.tris.normal(k, self.tris.barycentric(k, h.point)).as_dvec3();
                    let inward = -out_n;
                    let (sp, t2) = self.split_at(s, d, inward, true);
                    o = h.point;
                    match t2 {
                        Some(t2) => {
                            weight *= sp.transmit;
                            let outside = |k: u32| tris.face[k as usize].dot(t2) < 0.0;
                            return match map.search_with(
                                o,
                                t2,
                                Self::guard(map, o, t2, out_n),
                                f64::INFINITY,
                                &self.opts.tolerance,
                                outside,
                                self.cancel(),
                            ) {
                                Some(h2) => weight * self.secondary(h2.tri, h2.point, o),
                                None => weight * self.sky(t2),
                            };
                        }
                        None => {
                            weight *= sp.reflect;
                            d = reflect(v3(d), v3(inward)).as_dvec3();
                            nn = inward;
                        }
                    }
                }
                Vec3::ZERO
            }
        }
    }

    /// The full colour of scene triangle `tri` at barycentric `b`, seen from `viewer`.
    fn surface_color(&self, tri: u32, b: [f64; 3], viewer: DVec3) -> Vec3 {
        let t = tri as usize;
        let p = self.tris.point(t, b);
        let mut n = self.normal_at(t, b, p, viewer);
        self.color_at(tri, p, &mut n, viewer)
    }

    fn color_at(&self, tri: u32, p: DVec3, n: &mut DVec3, viewer: DVec3) -> Vec3 {
        let t = tri as usize;
        let d = (p - viewer).normalize_or_zero();
        let inside = n.dot(d) > 0.0;
        if inside {
            *n = -*n;
        }
        let n = *n;
        let s = self.surface_at(t, p);
        if self.opts.reflections == ReflectionMethod::None || !s.is_optical() {
            return self.local(&s, p, n, viewer, Vec3::ONE);
        }
        let (sp, refracted) = self.split_at(&s, d, n, inside);
        let mut c = self.local(&s, p, n, viewer, sp.local);
        let obj = self.tris.object[t];
        if sp.reflect.max_element() > 0.0 {
            let r = reflect(v3(d), v3(n)).as_dvec3();
            c += sp.reflect
                * match self.reflection_hit(obj, p, n, r) {
                    Some((k, q)) => self.secondary(k, q, p),
                    None => self.sky(r),
                };
        }
        if let Some(tr) = refracted {
            if sp.transmit.max_element() > 0.0 {
                c += sp.transmit * self.refraction(obj, &s, p, n, tr);
            }
        }
        c
    }
}

/// Renders already meshed objects of `scene`.
pub fn raster_meshes(scene: &Scene, meshed: &MeshedScene, opts: &RasterOptions) -> Result<RasterImage, RasterError> {
    check(scene, opts)?;
    let tris = SceneTriangles::new(meshed);
    let (w, h) = (scene.render.width as usize, scene.render.height as usize);
    let view = ViewTransform::new(&scene.camera, w as u32, h as u32);
    let eye = DVec3::from(scene.camera.position);
    let lighting = Lighting::new(scene);

    // Shadow buffers and environment maps.
    let t0 = Instant::now();
    let size = opts.map_size;
    let cancel = opts.cancel.as_ref();
    stop(opts)?;
    let shadow_buffers = (opts.shadows == ShadowMethod::Buffer)
        .then(|| ShadowBuffers::build_with(scene, &tris, size, opts.near, cancel))
        .transpose()?;
    let need_amap = opts.shadows == ShadowMethod::EnvMap || opts.reflections == ReflectionMethod::ABufferMap;
    let amap = need_amap
        .then(|| CubeMap::build_with(&tris, eye, size, MapKind::ABuffer, None, opts.near, cancel))
        .transpose()?;
    let zmap = (opts.reflections == ReflectionMethod::ZBufferMap)
        .then(|| CubeMap::build_with(&tris, eye, size, MapKind::ZBuffer, None, opts.near, cancel))
        .transpose()?;
    let mut object_maps = HashMap::new();
    if opts.reflections == ReflectionMethod::BlinnNewell {
        for om in &meshed.objects {
            if !scene.materials[om.material].is_optical() {
                continue;
            }
            let Some([lo, hi]) = om.mesh.bounds() else { continue };
            let centre = (DVec3::from(lo) + DVec3::from(hi)) * 0.5;
            let exclude = Some(om.object as u32);
            let map = CubeMap::build_with(&tris, centre, size, MapKind::ZBuffer, exclude, opts.near, cancel)?;
            object_maps.insert(om.object as u32, map);
        }
    }
    let map_fragments = amap.as_ref().map_or(0, CubeMap::sample_count)
        + zmap.as_ref().map_or(0, CubeMap::sample_count)
        + object_maps.values().map(CubeMap::sample_count).sum::<usize>();
    let maps = t0.elapsed().as_secs_f64();
    stop(opts)?;

    let ctx = Ctx {
        scene,
        tris: &tris,
        lighting,
        opts,
        shadow_buffers,
        amap,
        zmap,
        object_maps,
        background: to_vec3(scene.render.background),
        lookup_offset: 1e-5 * tris.radius_from((tris.bounds[0] + tris.bounds[1]) * 0.5) + 1e-9,
    };

    let t1 = Instant::now();
    let mapped_refraction = opts.reflections != ReflectionMethod::None;
    let opacity = |t: usize| {
        if mapped_refraction {
            1.0
        } else {
            ctx.lighting.opacity(tris.material[t] as usize)
        }
    };
    let cull = |t| {
        if opacity(t) >= 1.0 {
            Cull::Back
        } else {
            Cull::None
        }
    };
    let projected = project_with(&tris, &view, eye, opts.near, cull, cancel)?;
    let triangles = projected.len();

    // Per-vertex (Gouraud) or per-face (flat) colours of the triangles drawn.
    let vertex_colors: HashMap<u32, [Vec3; 3]> = match opts.shading {
        Shading::Phong => HashMap::new(),
        _ => {
            let mut ids: Vec<u32> = projected.iter().map(|p| p.tri).collect();
            ids.sort_unstable();
            ids.dedup();
            ids.par_iter()
                .map(|&t| {
                    if is_cancelled(cancel) {
                        return Err(RasterError::Cancelled);
                    }
                    let k = t as usize;
                    let c = if opts.shading == Shading::Flat {
                        let corners = tris.corners[k];
                        let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
                        let mut n = tris.face[k];
                        let c = ctx.color_at(t, centroid, &mut n, eye);
                        [c; 3]
                    } else {
                        let bary = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
                        bary.map(|b| ctx.surface_color(t, b, eye))
                    };
                    Ok((t, c))
                })
                .collect::<Result<_, _>>()?
        }
    };
    let shade = |tri: u32, b: [f64; 3]| -> Vec3 {
        match vertex_colors.get(&tri) {
            Some(c) => c[0] * b[0] as f32 + c[1] * b[1] as f32 + c[2] * b[2] as f32,
            None => ctx.surface_color(tri, b, eye),
        }
    };
    let miss = |i: usize| -> Vec3 {
        if scene.environment.is_none() {
            return ctx.background;
        }
        let q = view.screen_to_world((i % w) as f64, (i / w) as f64, 1.0);
        ctx.sky((DVec3::from(q) - eye).normalize_or_zero())
    };

    let mut g: Option<Vec<GPixel>> = None;
    let color: Vec<[f32; 3]> = match opts.hidden {
        HiddenSurface::ZBuffer => {
            let gb = gbuffer_with(&projected, w, h, cancel)?;
            // Once cancelled, the remaining pixels are left black (and the image dropped).
            let c = gb
                .par_iter()
                .enumerate()
                .map(|(i, px)| {
                    if is_cancelled(cancel) {
                        [0.0; 3]
                    } else if px.is_hit() {
                        shade(px.tri, px.bary).to_array()
                    } else {
                        miss(i).to_array()
                    }
                })
                .collect();
            g = Some(gb);
            c
        }
        HiddenSurface::ABuffer => {
            let mut lists = vec![FragmentList::new(); w * h];
            for_each_band(&projected, &mut lists, w, |rows, chunk, it| {
                let y0 = rows.start;
                for p in it {
                    if is_cancelled(cancel) {
                        return;
                    }
                    let t = p.tri as usize;
                    let alpha = opacity(t);
                    coverage_fragments(&p.v, w, rows.clone(), |cv| {
                        // A large triangle is shaded pixel by pixel: stop within it too.
                        if is_cancelled(cancel) {
                            return;
                        }
                        chunk[(cv.y - y0) * w + cv.x].insert(AFragment {
                            mask: cv.mask,
                            zmin: cv.zmin as f32,
                            zmax: cv.zmax as f32,
                            color: shade(p.tri, cv.attributes).to_array(),
                            opacity: alpha,
                            object: tris.object[t],
                        });
                    });
                }
            });
            stop(opts)?;
            // `ABuffer::resolve_image` with the background of each pixel (the
            // environment's, if any), checking the token per pixel.
            lists
                .par_iter()
                .enumerate()
                .map(|(i, l)| {
                    if is_cancelled(cancel) {
                        [0.0; 3]
                    } else {
                        l.resolve(miss(i).to_array())
                    }
                })
                .collect()
        }
    };
    stop(opts)?;
    let draw = t1.elapsed().as_secs_f64();

    let probes = if opts.probes && opts.reflections != ReflectionMethod::None {
        let gb = match g {
            Some(gb) => gb,
            None => gbuffer_with(&projected, w, h, cancel)?,
        };
        let p = probes(&ctx, &gb, eye, cancel);
        stop(opts)?;
        p
    } else {
        Vec::new()
    };

    Ok(RasterImage {
        width: w as u32,
        height: h as u32,
        color,
        triangles,
        warnings: meshed.warnings.clone(),
        timings: Timings { mesh: 0.0, maps, draw },
        map_fragments,
        probes,
    })
}

/// The reflection lookups of the reflective pixel centres of a G-buffer
/// (incomplete once `cancel` is cancelled).
fn probes(ctx: &Ctx, g: &[GPixel], eye: DVec3, cancel: Option<&isoray_job::CancelToken>) -> Vec<ReflectionProbe> {
    g.par_iter()
        .enumerate()
        .filter_map(|(i, px)| {
            if !px.is_hit() || is_cancelled(cancel) {
                return None;
            }
            let t = px.tri as usize;
            let p = ctx.tris.point(t, px.bary);
            let mut n = ctx.normal_at(t, px.bary, p, eye);
            let d = (p - eye).normalize_or_zero();
            let inside = n.dot(d) > 0.0;
            if inside {
                n = -n;
            }
            let s = &ctx.surface_at(t, p);
            if !s.is_optical() {
                return None;
            }
            let (sp, _) = ctx.split_at(s, d, n, inside);
            if sp.reflect.max_element() < 0.01 {
                return None;
            }
            let r = reflect(v3(d), v3(n)).as_dvec3().normalize_or_zero();
            let [a, b, c] = ctx.tris.corners[t];
            Some(ReflectionProbe {
                pixel: i as u32,
                origin: p,
                normal: n,
                direction: r,
                footprint: ((b - a).length() + (c - b).length() + (a - c).length()) / 3.0,
                found: ctx
                    .reflection_hit(ctx.tris.object[t], p, n, r)
                    .map(|(k, q)| (ctx.tris.object[k as usize], q)),
            })
        })
        .collect()
}
