//! # isoray-shape
//!
//! The shape language of isoray: a GLSL-like expression language for signed
//! distance functions, its typed lowering into one shared scalar DAG (the
//! shape IR), and the evaluators that run it.
//!
//! ```
//! use isoray_shape::{Library, compile};
//!
//! let lib = Library::new();
//! let shape = compile(&lib, "smooth_union(sphere(p, 1.0), box(p - vec3(1.0, 0.0, 0.0), vec3(0.5)), 0.25)").unwrap();
//! // Inside the sphere, away from the blend: the exact sphere distance.
//! assert!((shape.eval([-0.5, 0.0, 0.0]) - -0.5).abs() < 1e-12);
//! ```
//!
//! Conventions: right-handed coordinates, y up. Rotations turn the shape
//! counter-clockwise when looking down the axis towards the origin.

pub mod algebraic;
pub mod conformance;
pub mod diag;
pub mod eval;
pub mod fold;
pub mod interval;
pub mod ir;
pub mod library;
pub mod lipschitz;
mod lower;
mod program;
pub mod simplify;
pub mod surface;
pub mod syntax;
pub mod types;
pub mod vm;
pub mod wgsl;

pub use diag::{Diagnostic, SourceId, Span};
pub use eval::{gradient, BatchEvaluator, Dual, DualBatch, GradientMode, PointEvaluator, LANES};
pub use ir::{Builder, Node, Tape, TIME};
pub use lower::{Analyses, Compiled, Library, Surface, SurfaceMode, GRADIENT_GUARD};
pub use program::sphere_form;
pub use types::{Type, Value};

/// A compiled shape: the tape of one signed distance function.
#[derive(Debug, Clone)]
pub struct Shape {
    tape: Tape,
}

impl Shape {
    /// Wraps a tape.
    pub fn from_tape(tape: Tape) -> Self {
        Shape { tape }
    }
    /// The tape.
    pub fn tape(&self) -> &Tape {
        &self.tape
    }
    /// The signed distance at one point, in f64, for a shape that reads no
    /// input (an input it does read is NaN: use [`Shape::eval_with`]).
    pub fn eval(&self, p: [f64; 3]) -> f64 {
        self.eval_with(&[], p)
    }
    /// The signed distance at one point with the inputs `vars` (the time,
    /// then the parameters: see [`Library::input_values`]).
    pub fn eval_with(&self, vars: &[f64], p: [f64; 3]) -> f64 {
        PointEvaluator::<f64>::new(&self.tape).eval(vars, p[0], p[1], p[2])
    }
    /// The gradient at one point, for a shape that reads no input.
    pub fn gradient(&self, p: [f64; 3], mode: GradientMode) -> [f64; 3] {
        gradient(&self.tape, &[], p, mode)
    }
    /// The gradient at one point with the inputs `vars`.
    pub fn gradient_with(&self, vars: &[f64], p: [f64; 3], mode: GradientMode) -> [f64; 3] {
        gradient(&self.tape, vars, p, mode)
    }
    /// True when the shape reads the time or a parameter.
    pub fn reads_inputs(&self) -> bool {
        !self.tape.vars().is_empty()
    }
}

/// Compiles one snippet of shape text against a library (source id 0).
pub fn compile(lib: &Library, text: &str) -> Result<Shape, Diagnostic> {
    let mut b = Builder::new();
    let n = lib.compile(&mut b, text, 0)?;
    Ok(Shape { tape: b.tape(n) })
}
