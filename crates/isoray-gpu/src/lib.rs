//! # isoray-gpu
//!
//! isoray's GPU backend, through wgpu: headless, on a software Vulkan
//! driver (Mesa's lavapipe) in tests and on a real GPU where one exists.
//! Shapes reach the GPU as WGSL written by [`isoray_shape::wgsl`] from the
//! same tapes the CPU evaluates; the values a tape computes from the inputs
//! (parameters, time, placements) live in a storage buffer, so changing
//! them never rebuilds a pipeline.
//!
//! So far: the device ([`Gpu`]) and a compute evaluator of tapes over
//! points ([`Gpu::eval_points`]), which the evaluator conformance suite
//! holds to the reference semantics (`tests/conformance.rs`).

#![warn(missing_docs)]

pub mod accuracy;
mod device;
mod pack;
mod points;
mod raster;
mod render;

pub use device::{Gpu, GpuError};
pub use pack::{Kernel, SceneCode};
pub use points::PointShader;
pub use render::{band_count, GpuRenderOptions, GpuRenderer, GpuTiming};
