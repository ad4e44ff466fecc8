//! The evaluator conformance suite on the GPU: every unary and binary
//! operation of the IR, written as WGSL by `isoray_shape::wgsl`, evaluated
//! in a compute pass on the suite's awkward arguments and compared with the
//! reference semantics, within the tolerances `isoray_gpu::accuracy`
//! documents. Runs on whatever Vulkan adapter there is (lavapipe in CI,
//! which `.ci/run` installs).

use isoray_gpu::{accuracy, Gpu};
use isoray_shape::conformance::{self, BINARY, UNARY};
use isoray_shape::ir::{BinOp, Builder, UnOp};
use isoray_shape::wgsl::emit_tape;

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

#[test]
fn every_operation_follows_the_reference_on_the_gpu() {
    let g = gpu();
    eprintln!("adapter: {}", g.adapter_name());
    let mut failures: Vec<String> = Vec::new();
    let mut checked = 0usize;
    for &op in UNARY {
        let info = conformance::unary_info(op);
        let acc = accuracy::unary(op);
        let args: Vec<f64> = conformance::unary_args()
            .into_iter()
            .map(|x| acc.tolerance.arg(x))
            .filter(|&x| acc.holds_at(&[x]))
            .collect();
        let pts: Vec<[f32; 3]> = args.iter().map(|&a| [a as f32, 0.0, 0.0]).collect();
        let got = run(
            &g,
            |b: &mut Builder| {
                let x = b.x();
                b.unary(op, x)
            },
            &pts,
        );
        for (&x, &v) in args.iter().zip(&got) {
            let want = conformance::reference_unary(op, x, acc.tolerance);
            checked += 1;
            if !acc.tolerance.agrees(want, v, info.zero_sign) {
                failures.push(format!("{}({x:e}) = {v:e}, want {want:e}", info.name));
            }
        }
    }
    for &op in BINARY {
        let info = conformance::binary_info(op);
        let acc = accuracy::binary(op);
        let args: Vec<[f64; 2]> = conformance::binary_args()
            .into_iter()
            .map(|[a, b]| [acc.tolerance.arg(a), acc.tolerance.arg(b)])
            .filter(|p| acc.holds_at(p))
            .collect();
        let pts: Vec<[f32; 3]> = args.iter().map(|&[a, c]| [a as f32, c as f32, 0.0]).collect();
        let got = run(
            &g,
            |b: &mut Builder| {
                let (x, y) = (b.x(), b.y());
                b.binary(op, x, y)
            },
            &pts,
        );
        for (&[a, c], &v) in args.iter().zip(&got) {
            let want = conformance::reference_binary(op, a, c, acc.tolerance);
            checked += 1;
            if !acc.tolerance.agrees(want, v, info.zero_sign) {
                failures.push(format!("{}({a:e}, {c:e}) = {v:e}, want {want:e}", info.name));
            }
        }
    }
    assert!(checked > 1000, "{checked} values checked");
    assert!(
        failures.is_empty(),
        "{} of {checked} values disagree:\n{}",
        failures.len(),
        failures.iter().take(40).cloned().collect::<Vec<_>>().join("\n")
    );
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
