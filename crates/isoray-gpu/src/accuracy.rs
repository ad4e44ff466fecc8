//! How closely the GPU follows the reference semantics of each operation,
//! as measured on lavapipe (Mesa 22.3, LLVM 15) by `tests/conformance.rs`.
//!
//! WGSL leaves the accuracy of transcendental functions to the
//! implementation (sin and cos: absolute error 2⁻¹¹ on [−π, π] only; exp
//! and log: 3 + 2·|x| ulps), GPUs flush subnormal numbers to zero, and
//! their argument reduction for sin, cos and tan is only good for moderate
//! arguments. So:
//!
//! | operations | held to |
//! |---|---|
//! | `-x`, `abs`, `x²`, `floor`, `round`, `sign`, `+`, `−`, `×`, `min`, `max` | exactly (f32), every argument |
//! | `sqrt`, `/` | 1 f32 ulp |
//! | `exp` | 2·10⁻⁵ relative (WGSL allows 3 + 2·\|x\| ulps: 180 ulps near the top of the f32 range) |
//! | `ln` | 4 ulps relative, not at subnormal arguments (flushed to zero) |
//! | `atan`, `asin`, `acos`, `atan2` | 3·10⁻⁵ relative (lavapipe's `atan` is an approximation); IEEE values at zeros, infinities and NaN; `atan2` not at subnormal arguments |
//! | `sin`, `cos`, `tan` | 10⁻⁶ absolute (`tan`: relative) for \|x\| ≤ 2¹⁶; larger arguments are not held |
//! | `pow` | 10⁻⁵ relative (it is exp2(b·log2 a)), results below the smallest normal f32 may be 0; IEEE values at zeros, infinities, negative bases; not at subnormal arguments |
//!
//! A renderer on the GPU therefore agrees with the CPU's image to within
//! what these tolerances allow (the parity tests of the renderer measure
//! it); the exact operations, which make up most distance fields, agree
//! bit for bit.

use isoray_shape::conformance::Tolerance;
use isoray_shape::ir::{BinOp, UnOp};

/// What one operation is held to on the GPU.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Accuracy {
    /// The tolerance (always in f32).
    pub tolerance: Tolerance,
    /// Arguments beyond this magnitude are not held (∞: all are).
    pub max_arg: f64,
    /// Subnormal arguments are not held (flushed to zero).
    pub normal_args_only: bool,
}

impl Accuracy {
    /// True when the operation is held to its tolerance at these arguments.
    pub fn holds_at(&self, args: &[f64]) -> bool {
        args.iter().all(|&x| {
            let sub = x != 0.0 && x.abs() < f32::MIN_POSITIVE as f64;
            let too_large = x.is_finite() && x.abs() > self.max_arg;
            let flushed = self.normal_args_only && sub;
            !(too_large || flushed)
        })
    }
}

const fn held(rel: f64, abs: f64) -> Accuracy {
    Accuracy {
        tolerance: Tolerance { rel, abs, f32: true },
        max_arg: f64::INFINITY,
        normal_args_only: false,
    }
}

const ULP: f64 = f32::EPSILON as f64;
/// The smallest f32 subnormal: results below it are zero.
const TINY: f64 = 1.401298464324817e-45;

/// The accuracy of a unary operation on the GPU.
pub fn unary(op: UnOp) -> Accuracy {
    match op {
        UnOp::Neg | UnOp::Abs | UnOp::Square | UnOp::Floor | UnOp::Round | UnOp::Sign => held(0.0, 0.0),
        UnOp::Sqrt => held(ULP, TINY),
        UnOp::Exp => held(2e-5, TINY),
        UnOp::Ln => Accuracy {
            normal_args_only: true,
            ..held(4.0 * ULP, TINY)
        },
        UnOp::Atan | UnOp::Asin | UnOp::Acos => held(3e-5, TINY),
        UnOp::Sin | UnOp::Cos => Accuracy {
            max_arg: 65536.0,
            ..held(0.0, 1e-6)
        },
        UnOp::Tan => Accuracy {
            max_arg: 65536.0,
            ..held(1e-5, 1e-6)
        },
    }
}

/// The accuracy of a binary operation on the GPU.
pub fn binary(op: BinOp) -> Accuracy {
    match op {
        BinOp::Add | BinOp::Sub | BinOp::Mul | BinOp::Min | BinOp::Max => held(0.0, 0.0),
        BinOp::Div => held(ULP, TINY),
        BinOp::Atan2 => Accuracy {
            normal_args_only: true,
            ..held(3e-5, TINY)
        },
        BinOp::Pow => Accuracy {
            normal_args_only: true,
            ..held(1e-5, f32::MIN_POSITIVE as f64)
        },
    }
}
