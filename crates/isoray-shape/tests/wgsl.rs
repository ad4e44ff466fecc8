//! The WGSL the emitter writes is valid (parsed and validated by naga, the
//! shader compiler of wgpu) for every operation of the IR, for the
//! constants evaluators find awkward, for lazy regions and for real shapes.
//! (Its values are held to the conformance suite on a GPU by isoray-gpu.)

use isoray_shape::conformance::{BINARY, UNARY};
use isoray_shape::ir::{Builder, Instr, Tape};
use isoray_shape::wgsl::{self, emit_tape, literal, PRELUDE};
use isoray_shape::Library;

/// A compute shader around the functions: reads points, writes values.
fn module(functions: &[(String, String)], inputs: usize) -> String {
    let mut m = String::from(PRELUDE);
    m.push_str(&format!(
        "@group(0) @binding(0) var<storage, read> iso_in: array<f32, {}>;\n\
         @group(0) @binding(1) var<storage, read_write> out: array<f32>;\n",
        inputs.max(1)
    ));
    let mut body = String::new();
    for (k, (name, code)) in functions.iter().enumerate() {
        m.push_str(code);
        body.push_str(&format!("    out[{k}u + i * {}u] = {name}(p);\n", functions.len()));
    }
    m.push_str(&format!(
        "@compute @workgroup_size(64)\nfn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n    let i = id.x;\n    let p = vec3<f32>(f32(i), 0.5, -0.25);\n{body}}}\n"
    ));
    m
}

fn validate(source: &str) {
    let parsed =
        naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{}\n{source}", e.emit_to_string(source)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&parsed)
        .unwrap_or_else(|e| panic!("{e:?}\n{source}"));
}

#[test]
fn every_operation_has_valid_wgsl() {
    let mut fns = Vec::new();
    for (k, &op) in UNARY.iter().enumerate() {
        let mut b = Builder::new();
        let x = b.x();
        let n = b.unary(op, x);
        fns.push((
            format!("u{k}"),
            emit_tape(&b.tape(n), &format!("u{k}"), "iso_in", 0).code,
        ));
    }
    for (k, &op) in BINARY.iter().enumerate() {
        let mut b = Builder::new();
        let (x, y) = (b.x(), b.y());
        let n = b.binary(op, x, y);
        fns.push((
            format!("b{k}"),
            emit_tape(&b.tape(n), &format!("b{k}"), "iso_in", 0).code,
        ));
        // And on an input (a prologue value read from the buffer).
        let mut b = Builder::new();
        let (x, r) = (b.x(), b.input(1));
        let n = b.binary(op, x, r);
        let f = emit_tape(&b.tape(n), &format!("bi{k}"), "iso_in", 0);
        assert_eq!(f.uniform_slots.len(), 1);
        fns.push((format!("bi{k}"), f.code));
    }
    assert_eq!(fns.len(), UNARY.len() + 2 * BINARY.len());
    validate(&module(&fns, 1));
    // The code of each operation names its operands.
    for &op in UNARY {
        assert!(wgsl::unary(op, "A").contains('A'));
    }
    for &op in BINARY {
        let c = wgsl::binary(op, "A", "B");
        assert!(c.contains('A') && c.contains('B'));
    }
}

#[test]
fn literals_read_back_as_the_f32_the_evaluator_uses() {
    for v in [0.1, 1.0 / 3.0, -2.5, 1e-30, 3.4e38, 1e-45, 123456789.0, -0.0, 0.0] {
        let text = literal(v);
        let digits = text.trim_start_matches('(').trim_end_matches(')').trim_end_matches('f');
        let back: f32 = digits.parse().unwrap_or_else(|_| panic!("{text}"));
        let want = v as f32;
        assert_eq!(back.to_bits(), want.to_bits(), "{v}: {text}");
    }
    assert_eq!(literal(f64::NAN), "iso_nan()");
    assert_eq!(literal(f64::INFINITY), "iso_inf()");
    assert_eq!(literal(-1e300), "(-iso_inf())");
    // Every literal is valid WGSL.
    let mut b = Builder::new();
    let x = b.x();
    let mut acc = x;
    for v in [
        0.1,
        -2.5,
        1e-30,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        -0.0,
        1e-45,
    ] {
        let c = b.constant(v);
        acc = b.binary(isoray_shape::ir::BinOp::Max, acc, c);
    }
    validate(&module(
        &[("f".into(), emit_tape(&b.tape(acc), "f", "iso_in", 0).code)],
        0,
    ));
}

#[test]
fn lazy_regions_become_branches() {
    let mut b = Builder::new();
    let (x, y, z) = (b.x(), b.y(), b.z());
    let x2 = b.square(x);
    let y2 = b.square(y);
    let z2 = b.square(z);
    let r2 = b.add(x2, y2);
    let r2 = b.add(r2, z2);
    let r = b.sqrt(r2);
    let far = b.add_c(r, -2.0);
    let cheap = b.add_c(r, -1.0);
    let s = b.unary(isoray_shape::ir::UnOp::Sin, x);
    let e = b.add(cheap, s);
    let out = b.lazy_select(far, cheap, e);
    let tape = b.tape(out);
    assert!(tape.instrs().iter().any(|i| matches!(i, Instr::Skip { .. })));
    let f = emit_tape(&tape, "f", "iso_in", 0);
    assert!(f.code.contains("if (!("), "{}", f.code);
    validate(&module(&[("f".into(), f.code)], 0));
}

/// Shapes written in the shape language: primitives, operators, smooth
/// unions, repetition, parameters and time.
#[test]
fn real_shapes_have_valid_wgsl_and_their_inputs_in_the_buffer() {
    let mut lib = Library::new();
    lib.set_param("k", isoray_shape::Value::Float(0.25));
    lib.set_param("c", isoray_shape::Value::Vec3([1.0, 0.5, 0.0]));
    let texts = [
        "smooth_union(sphere(p - c, 1.0), box(rotate_y(p, t), vec3(0.5)), k)",
        "torus(repeat(p, vec3(3.0, 3.0, 3.0 + k)), 1.0, 0.25)",
        "max(-sphere(p, 0.8 + 0.1 * sin(t)), box(p, 0.6))",
        "cylinder(twist_y(p, k), 1.0, 0.5) * 0.5 + smin_exp(ellipsoid(p, vec3(1.0, 0.5, 0.5)), hex_prism(p, 0.5, 0.3), 8.0)",
    ];
    let mut fns = Vec::new();
    let mut base = 0u32;
    let vars = [0.5, 0.25, 1.0, 0.5, 0.0];
    for (k, text) in texts.iter().enumerate() {
        let mut b = Builder::new();
        let node = lib
            .compile(&mut b, text, 0)
            .unwrap_or_else(|d| panic!("{text}: {}", d.message));
        let tape: Tape = b.tape(node);
        let f = emit_tape(&tape, &format!("f{k}"), "iso_in", base);
        // The buffer holds what the f32 evaluator puts in those slots.
        let values = f.fill(&tape, &vars);
        assert_eq!(values.len(), f.uniform_slots.len());
        assert!(values.iter().all(|v| v.is_finite()), "{text}: {values:?}");
        base += values.len() as u32;
        fns.push((format!("f{k}"), f.code));
    }
    assert!(base > 0, "the shapes read parameters and the time");
    validate(&module(&fns, base as usize));
    // The same functions reading a uniform array of vec4s: element k at
    // [k / 4][k % 4], the same slots.
    let mut m = String::from(PRELUDE);
    m.push_str(&format!(
        "@group(0) @binding(0) var<uniform> iso_in: array<vec4<f32>, {}>;\n\
         @group(0) @binding(1) var<storage, read_write> out: array<f32>;\n",
        (base as usize).div_ceil(4)
    ));
    let mut body = String::new();
    let mut base = 0u32;
    for (k, text) in texts.iter().enumerate() {
        let mut b = Builder::new();
        let node = lib.compile(&mut b, text, 0).unwrap();
        let tape: Tape = b.tape(node);
        let plain = emit_tape(&tape, &format!("f{k}"), "iso_in", base);
        let f = emit_tape(&tape, &format!("f{k}"), wgsl::InputBuffer::Vec4s("iso_in"), base);
        assert_eq!(f.uniform_slots, plain.uniform_slots);
        let last = base + f.uniform_slots.len() as u32 - 1;
        assert!(
            f.code.contains(&format!("iso_in[{}u][{}u]", last / 4, last % 4)),
            "{}",
            f.code
        );
        base += f.uniform_slots.len() as u32;
        m.push_str(&f.code);
        body.push_str(&format!("    out[{k}u] = f{k}(p);\n"));
    }
    m.push_str(&format!(
        "@compute @workgroup_size(1)\nfn main() {{\n    let p = vec3<f32>(0.5, 0.25, -0.25);\n{body}}}\n"
    ));
    validate(&m);
}

/// A tape of each unary operation of x, of each binary operation of x and
/// an input, and of a lazy region.
fn op_tapes() -> Vec<Tape> {
    let mut tapes = Vec::new();
    for &op in UNARY {
        let mut b = Builder::new();
        let x = b.x();
        let n = b.unary(op, x);
        tapes.push(b.tape(n));
    }
    for &op in BINARY {
        let mut b = Builder::new();
        let (x, r) = (b.x(), b.input(1));
        let n = b.binary(op, x, r);
        tapes.push(b.tape(n));
    }
    let mut b = Builder::new();
    let (x, y) = (b.x(), b.y());
    let far = b.add_c(x, -2.0);
    let e = b.mul(x, y);
    let out = b.lazy_select(far, x, e);
    tapes.push(b.tape(out));
    tapes
}

/// The dual (gradient) form of every operation, of lazy regions and of a
/// real shape is valid WGSL, and reads the buffer as the value form does.
#[test]
fn every_operation_has_a_valid_gradient() {
    let mut fns = Vec::new();
    let mut tapes = op_tapes();
    let lib = Library::new();
    let mut b = Builder::new();
    let node = lib
        .compile(
            &mut b,
            "smooth_union(sphere(p, 1.0), box(rotate_y(p, 0.3), vec3(0.5)), 0.2)",
            0,
        )
        .unwrap();
    tapes.push(b.tape(node));
    for (k, tape) in tapes.iter().enumerate() {
        let v = emit_tape(tape, &format!("v{k}"), "iso_in", 0);
        let g = wgsl::emit_tape_dual(tape, &format!("g{k}"), "iso_in", 0);
        assert_eq!(v.uniform_slots, g.uniform_slots);
        fns.push((format!("g{k}"), g.code.clone()));
    }
    let mut m = String::from(PRELUDE);
    m.push_str(
        "@group(0) @binding(0) var<storage, read> iso_in: array<f32, 1>;\n\
         @group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;\n",
    );
    let mut body = String::new();
    for (k, (name, code)) in fns.iter().enumerate() {
        m.push_str(code);
        body.push_str(&format!("    out[{k}u] = {name}(p);\n"));
    }
    m.push_str(&format!(
        "@compute @workgroup_size(1)\nfn main() {{\n    let p = vec3<f32>(0.5, 0.25, -0.25);\n{body}}}\n"
    ));
    validate(&m);
}

/// The interval form of every operation, of lazy regions and of real
/// shapes is valid WGSL (after both preludes), and reads the buffer as the
/// value form does.
#[test]
fn every_operation_has_a_valid_interval_extension() {
    let mut tapes = op_tapes();
    let mut lib = Library::new();
    lib.set_param("k", isoray_shape::Value::Float(0.25));
    for text in [
        "smooth_union(sphere(p, 1.0), box(rotate_y(p, 0.3), vec3(0.5)), k)",
        "torus(repeat(p, vec3(3.0, 3.0, 3.0 + k)), 1.0, 0.25)",
        "cylinder(twist_y(p, k), 1.0, 0.5) * 0.5 + smin_exp(ellipsoid(p, vec3(1.0, 0.5, 0.5)), hex_prism(p, 0.5, 0.3), 8.0)",
    ] {
        let mut b = Builder::new();
        let node = lib.compile(&mut b, text, 0).unwrap_or_else(|d| panic!("{text}: {}", d.message));
        tapes.push(b.tape(node));
    }
    let mut m = format!("{PRELUDE}{}", wgsl::interval::INTERVAL_PRELUDE);
    m.push_str(
        "@group(0) @binding(0) var<storage, read> iso_in: array<f32, 4>;\n\
         @group(0) @binding(1) var<storage, read_write> out: array<vec2<f32>>;\n",
    );
    let mut body = String::new();
    for (k, tape) in tapes.iter().enumerate() {
        let v = emit_tape(tape, &format!("v{k}"), "iso_in", 0);
        let i = wgsl::interval::emit_tape_interval(tape, &format!("i{k}"), "iso_in", 0);
        assert_eq!(v.uniform_slots, i.uniform_slots);
        m.push_str(&i.code);
        body.push_str(&format!("    out[{k}u] = i{k}(lo, hi);\n"));
    }
    m.push_str(&format!(
        "@compute @workgroup_size(1)\nfn main() {{\n    let lo = vec3<f32>(0.5, 0.25, -0.25);\n    let hi = lo + 0.5;\n{body}}}\n"
    ));
    validate(&m);
}
