//! # isoray-raster
//!
//! The classic polygon pipeline, in software: object → world → camera →
//! screen transforms with the ray tracer's conventions, back-face culling,
//! near-plane clipping, scan conversion with a consistent fill rule and
//! perspective-correct interpolation, and hidden-surface removal by a
//! Z-buffer or an A-buffer with 4×8 subpixel coverage masks.
//!
//! [`render::raster`] meshes a scene ([`scene`]), draws it in parallel
//! bands ([`draw`]) behind either buffer with flat, Gouraud or Phong shading
//! ([`shading`]), with shadows from shadow buffers ([`shadow`]) or from the
//! A-buffered environment map, and reflections and refractions from cube
//! environment maps ([`envmap`]: Blinn–Newell, Z-buffered, A-buffered).
//! Materials, lights, optics and their formulas are `isoray-shade`'s, the
//! ray tracer's shading model. It backs `isoray raster` (whose
//! `--error-vs-raytrace` report, needing both renderers, lives in the
//! command line).
//!
//! ```
//! use isoray_raster::render::{raster, RasterOptions, ReflectionMethod, ShadowMethod};
//!
//! let scene = isoray_scene::load_str(
//!     r#"
//!     [camera]
//!     position = [0.0, 1.5, 4.0]
//!     target = [0.0, 0.5, 0.0]
//!
//!     [render]
//!     width = 64
//!     height = 48
//!
//!     [[light]]
//!     kind = "point"
//!     position = [2.0, 4.0, 3.0]
//!
//!     [material.mirror]
//!     reflectivity = 0.8
//!
//!     [[object]]
//!     material = "mirror"
//!     shape = "sphere(p - vec3(0.0, 0.5, 0.0), 0.5)"
//!
//!     [[object]]
//!     shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"
//!     "#,
//!     "doc.toml",
//!     &[],
//! )?;
//! let opts = RasterOptions {
//!     resolution: 24,
//!     map_size: 64,
//!     shadows: ShadowMethod::Buffer,
//!     reflections: ReflectionMethod::ABufferMap,
//!     ..RasterOptions::default()
//! };
//! let image = raster(&scene, &opts)?;
//! assert_eq!(image.color.len(), 64 * 48);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod abuffer;
pub mod draw;
pub mod envmap;
pub mod pipeline;
pub mod render;
pub mod scene;
pub mod shading;
pub mod shadow;
pub mod triangles;
