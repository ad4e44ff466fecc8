//! # isoray-scene
//!
//! Scene documents for isoray: a TOML file with a camera, render settings,
//! lights, materials, named parameters, user surfaces and objects, loaded into
//! a checked [`Scene`] whose shapes are compiled once.
//!
//! ```
//! let scene = isoray_scene::load_str(r#"
//! [camera]
//! position = [0.0, 0.0, 4.0]
//! [[object]]
//! shape = "sphere(p, 1.0)"
//! "#, "inline.toml", &["render.width=64".to_string()]).unwrap();
//! assert_eq!(scene.render.width, 64);
//! assert!((scene.distance([2.0, 0.0, 0.0]) - 1.0).abs() < 1e-12);
//! ```
//!
//! Errors name the file, line and column (or the `--set` override) and say
//! what was expected; see [`SceneError`].

// A SceneError carries its rendered report and its structure (key, span,
// label, notes) for editors; loads are not a hot path, so its size is fine.
#![allow(clippy::result_large_err)]

pub mod analytic;
mod animation;
mod compile;
mod derive;
pub mod doc;
pub mod env;
mod error;
mod load;
pub mod meshes;
pub mod midi;
mod model;
mod physics;
mod read;
mod reader;
mod save;
pub mod schema;
mod sdf_dents;
pub mod skeleton;

pub use animation::{animation_keys, track_keys, Animation, Interpolation, Track};
pub use compile::{CacheStats, ObjectCache};
pub use derive::{analytic_allowed, Derived};
pub use error::{SceneError, Sources};
pub use load::{load, load_str, load_str_with, load_with, LoadOptions};
pub use model::*;
pub use physics::{physics_keys, BodyKind, Collider, DentMapSettings, DentMode, ObjectPhysics, Physics, Placement};
pub use save::{edit_text, replace_atomically, set_file, write_atomic, SetReport};
pub use sdf_dents::{append_to_text as append_sdf_dents_to_text, sdf_dent_keys, SdfDent};
