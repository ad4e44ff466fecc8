//! # isoray-raster
//!
//! The classic polygon pipeline, in software: object → world → camera →
//! screen transforms with the ray tracer's conventions, back-face culling,
//! near-plane clipping, scan conversion with a consistent fill rule and
//! perspective-correct interpolation, and hidden-surface removal by a
//! Z-buffer or an A-buffer with 4×8 subpixel coverage masks.
//!
//! Work in progress (issue 7): shading, shadow buffers, environment-mapped
//! reflections and `isoray raster` come next.

pub mod abuffer;
pub mod pipeline;
