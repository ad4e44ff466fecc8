//! # isoray-dent
//!
//! Dents from collisions, after the 2009 UCI thesis (a re-implementation
//! of Wrotek, Rice and McGuire's real-time collision deformations; see
//! `shared/reference/dents.md`):
//!
//! - [`impulse`]: the impact model: the elastic impulse of an impact, the
//!   yield impulse of a restitution, and the permanent dent depth;
//! - [`heightmap`]: a height (bump) map per dentable object, lowered by
//!   impacts (the deepest dent wins on a texel), with the rectangle it
//!   changed;
//! - [`normalmap`]: the thesis's (G3D's) Sobel normal map of a height map,
//!   byte for byte, recomputed on a changed rectangle grown by one texel
//!   so that a partial update equals a full recompute;
//! - [`uv`]: how a body's surface lays out on its map (planar and
//!   spherical mappings, one-to-one where they say), and the tangent frame;
//! - [`field`]: bodies as signed distances, and the marches the imprints use;
//! - [`imprint`]: where an impactor presses a body, the dent in its map:
//!   isoray's texel method along the true normal, and the thesis's
//!   orthographic depth passes for comparison;
//! - [`maps`]: a dentable object's maps together, kept consistent;
//! - [`bump`]: Blinn's perturbed normal, the thesis's derivation of bump
//!   mapping.
//!
//! ```
//! use isoray_dent::impulse::{dent_depth, elastic_impulse, yield_impulse};
//! // A 1 kg ball falling at 2 m/s on a fixed plane (normal from the plane to the ball).
//! let j = elastic_impulse([0.0, 1.0, 0.0], [0.0; 3], [0.0, -2.0, 0.0], 0.0, 1.0);
//! assert_eq!(j, [0.0, 4.0, 0.0]);
//! assert_eq!(yield_impulse(0.5), 1.0);
//! // thickness 0.1, compliance 0.01: 0.1 · 0.01 · (4 − 1).
//! assert!((dent_depth(0.1, 0.01, 4.0, 0.5) - 0.003).abs() < 1e-12);
//! ```

#![warn(missing_docs)]

pub mod bump;
pub mod field;
pub mod heightmap;
pub mod imprint;
pub mod impulse;
pub mod maps;
pub mod normalmap;
pub mod param;
pub mod uv;
mod vec;

pub use heightmap::{HeightMap, Rect};
pub use maps::DentMaps;
pub use normalmap::{NormalMap, NormalMapOptions, Wrap};
