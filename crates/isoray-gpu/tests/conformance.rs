//! The evaluator conformance suite on the GPU: every unary and binary
//! operation of the IR, written as WGSL by `isoray_shape::wgsl`, evaluated
//! in a compute pass on the suite's awkward arguments and compared with the
//! reference semantics, within the tolerances `isoray_gpu::accuracy`
//! documents. Runs on whatever Vulkan adapter there is (lavapipe in CI,
//! which `.ci/run` installs).

use isoray_gpu::{accuracy, Gpu};
use isoray_shape::conformance::{self, Containment};
use isoray_shape::ir::{BinOp, Builder, UnOp};
use isoray_shape::wgsl::emit_tape;
use isoray_shape::wgsl::interval::{emit_tape_interval, f32_box};

fn gpu() -> Gpu {
    Gpu::new().unwrap_or_else(|e| panic!("{e}"))
}

fn run(g: &Gpu, build: impl Fn(&mut Builder) -> isoray_shape::ir::Node, pts: &[[f32; 3]]) -> Vec<f64> {
    let mut b = Builder::new();
    let n = build(&mut b);
    let f = emit_tape(&b.tape(n), "f", "iso_in", 0);
    let shader = g.point_shader(&f, "f").unwrap_or_else(|e| panic!("{e}"));
    g.eval_points(&shader, &[], pts)
        .unwrap_or_else(|e| panic!("{e}"))
        .into_iter()
        .map(f64::from)
        .collect()
}

/// Fails with the first mismatches of the results, if any (`what` says what they are).
fn assert_none_fail(results: [Result<(), Vec<conformance::Mismatch>>; 2], what: &str) {
    let failures: Vec<String> = results
        .into_iter()
        .filter_map(Result::err)
        .flatten()
        .map(|m| m.to_string())
        .collect();
    assert!(
        failures.is_empty(),
        "{} {what}:\n{}",
        failures.len(),
        failures.iter().take(40).cloned().collect::<Vec<_>>().join("\n")
    );
}

#[test]
fn every_operation_follows_the_reference_on_the_gpu() {
    let g = gpu();
    eprintln!("adapter: {}", g.adapter_name());
    let mut checked = 0usize;
    let mut unary = |op: UnOp, args: &[f64]| -> Vec<f64> {
        checked += args.len();
        let pts: Vec<[f32; 3]> = args.iter().map(|&a| [a as f32, 0.0, 0.0]).collect();
        run(
            &g,
            |b: &mut Builder| {
                let x = b.x();
                b.unary(op, x)
            },
            &pts,
        )
    };
    let unary_result = conformance::check_unary_each(
        "gpu",
        &conformance::unary_args(),
        &mut unary,
        &|op| accuracy::unary(op).tolerance,
        &|op, x| accuracy::unary(op).holds_at(&[x]),
    );
    let mut binary = |op: BinOp, args: &[[f64; 2]]| -> Vec<f64> {
        checked += args.len();
        let pts: Vec<[f32; 3]> = args.iter().map(|&[a, c]| [a as f32, c as f32, 0.0]).collect();
        run(
            &g,
            |b: &mut Builder| {
                let (x, y) = (b.x(), b.y());
                b.binary(op, x, y)
            },
            &pts,
        )
    };
    let binary_result = conformance::check_binary_each(
        "gpu",
        &conformance::binary_args(),
        &mut binary,
        &|op| accuracy::binary(op).tolerance,
        &|op, p| accuracy::binary(op).holds_at(&p),
    );
    assert!(checked > 1000, "{checked} values checked");
    assert_none_fail([unary_result, binary_result], "values disagree");
}

/// The operations held bit for bit by the CPU's f32 evaluator are held to
/// it on the GPU too: the basic IEEE operations and the ones the prelude
/// writes out exactly.
#[test]
fn the_exact_operations_are_exact() {
    for op in [UnOp::Neg, UnOp::Abs, UnOp::Square, UnOp::Floor, UnOp::Round, UnOp::Sign] {
        assert_eq!(accuracy::unary(op).tolerance.rel, 0.0, "{op:?}");
    }
    for op in [BinOp::Add, BinOp::Sub, BinOp::Mul, BinOp::Min, BinOp::Max] {
        assert_eq!(accuracy::binary(op).tolerance.rel, 0.0, "{op:?}");
    }
}

/// The interval extension of `build`'s tape on the GPU over `boxes` (f64
/// boxes of x, y, z), each handed to the GPU as the f32 box around it.
fn run_intervals(
    g: &Gpu,
    build: impl Fn(&mut Builder) -> isoray_shape::ir::Node,
    inputs: &[f64],
    boxes: &[[(f64, f64); 3]],
) -> Vec<(f64, f64)> {
    let mut b = Builder::new();
    let n = build(&mut b);
    let tape = b.tape(n);
    let f = emit_tape_interval(&tape, "bounds", "iso_in", 0);
    let shader = g.interval_shader(&f, "bounds").unwrap_or_else(|e| panic!("{e}"));
    let gpu_boxes: Vec<[[f32; 3]; 2]> = boxes.iter().map(f32_box).collect();
    g.eval_boxes(&shader, &f.fill(&tape, inputs), &gpu_boxes)
        .unwrap_or_else(|e| panic!("{e}"))
        .into_iter()
        .map(|[lo, hi]| (f64::from(lo), f64::from(hi)))
        .collect()
}

/// The interval emitter on the GPU contains the reference value of every
/// operation at every sample point of every box of the suite (as the CPU's
/// interval arithmetic does, `eval_interval` in isoray-shape's suite).
#[test]
fn interval_arithmetic_contains_every_value_on_the_gpu() {
    let g = gpu();
    let zero = (0.0, 0.0);
    let mut boxes_checked = 0usize;
    let unary_result = conformance::check_unary_intervals(
        "gpu intervals",
        &mut |op, boxes| {
            boxes_checked += boxes.len();
            let boxes: Vec<_> = boxes.iter().map(|&b| [b, zero, zero]).collect();
            run_intervals(
                &g,
                |b: &mut Builder| {
                    let x = b.x();
                    b.unary(op, x)
                },
                &[],
                &boxes,
            )
        },
        Containment::RIGOROUS,
    );
    let binary_result = conformance::check_binary_intervals(
        "gpu intervals",
        &mut |op, pairs| {
            boxes_checked += pairs.len();
            let boxes: Vec<_> = pairs.iter().map(|&[a, b]| [a, b, zero]).collect();
            run_intervals(
                &g,
                |b: &mut Builder| {
                    let (x, y) = (b.x(), b.y());
                    b.binary(op, x, y)
                },
                &[],
                &boxes,
            )
        },
        Containment::RIGOROUS,
    );
    assert!(boxes_checked > 10_000, "{boxes_checked} boxes checked");
    assert_none_fail([unary_result, binary_result], "values escape");
}
