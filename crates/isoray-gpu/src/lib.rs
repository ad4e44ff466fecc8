//! # isoray-gpu
//!
//! isoray's GPU backend, through wgpu: headless, on a software Vulkan
//! driver (Mesa's lavapipe) in tests and on a real GPU where one exists.
//! Shapes reach the GPU as WGSL written by [`isoray_shape::wgsl`] from the
//! same tapes the CPU evaluates; the values a tape computes from the inputs
//! (parameters, time, placements) live in a storage buffer, so changing
//! them never rebuilds a pipeline.
//!
//! The device ([`Gpu`]); a compute evaluator of tapes over points
//! ([`Gpu::eval_points`]), which the evaluator conformance suite holds to
//! the reference semantics (`tests/conformance.rs`); and the renderer
//! ([`GpuRenderer`]): the tracer in `src/kernel/*.wgsl`, reading the
//! buffer structures of [`layout`] and the scene's fold cells.

#![warn(missing_docs)]

pub mod accuracy;
mod cells;
mod device;
#[cfg(test)]
mod kernel_parity;
pub mod layout;
mod pack;
mod points;
mod raster;
mod render;

pub use cells::CellStats;
pub use device::{Gpu, GpuError};
pub use pack::{Features, Kernel, SceneCode};
pub use points::PointShader;
pub use render::{band_count, FoldCells, GpuRenderOptions, GpuRenderer, GpuTiming};
