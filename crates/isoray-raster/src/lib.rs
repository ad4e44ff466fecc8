//! # isoray-raster
//!
//! The classic polygon pipeline, in software: object → world → camera →
//! screen transforms with the ray tracer's conventions, back-face culling,
//! near-plane clipping, scan conversion with a consistent fill rule and
//! perspective-correct interpolation, and hidden-surface removal by a
//! Z-buffer or an A-buffer with 4×8 subpixel coverage masks.
//!
//! [`render::raster`] meshes a scene ([`scene`]) and renders it with flat,
//! Gouraud or Phong shading ([`shading`]) behind either buffer; it backs
//! `isoray raster`. Work in progress (issue 7): shadow buffers and
//! environment-mapped reflections come next.

pub mod abuffer;
pub mod compare;
pub mod draw;
pub mod envmap;
pub mod pipeline;
pub mod render;
pub mod scene;
pub mod shading;
pub mod shadow;
pub mod triangles;
