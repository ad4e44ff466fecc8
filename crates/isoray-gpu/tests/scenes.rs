//! The example scenes' distance fields on the GPU: the scene's tape and
//! every object's tape, written as WGSL, with their input-derived values
//! (parameters, time, placements) in the input buffer, agree with the CPU's
//! f32 evaluator at points all over each scene; and changing an input
//! changes only the buffer.

use isoray_gpu::Gpu;
use isoray_shape::eval::PointEvaluator;
use isoray_shape::wgsl::emit_tape;
use isoray_shape::Shape;

fn examples() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// Points over the box [-6, 6]³ on a jittered lattice.
fn points() -> Vec<[f32; 3]> {
    let mut out = Vec::new();
    let n = 14;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let h = ((i * 73 + j * 37 + k * 11) % 17) as f32 / 17.0;
                let c = |m: usize| -6.0 + 12.0 * (m as f32 + 0.5 * h) / n as f32;
                out.push([c(i), c(j), c(k)]);
            }
        }
    }
    out
}

/// The largest |gpu − cpu| / (1 + |cpu|) over the points, or the first
/// disagreement in kind (finite against not).
fn compare(g: &Gpu, shape: &Shape, vars: &[f64], pts: &[[f32; 3]], what: &str) -> f64 {
    let tape = shape.tape();
    let f = emit_tape(tape, "f", "iso_in", 0);
    let t0 = std::time::Instant::now();
    let shader = g.point_shader(&f, "f").unwrap_or_else(|e| panic!("{what}: {e}"));
    if !what.contains("object") {
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        eprintln!(
            "{what}: {} instructions, shader and pipeline built in {ms:.1} ms",
            tape.len()
        );
    }
    let gpu = g
        .eval_points(&shader, &f.fill(tape, vars), pts)
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    worst_difference(tape, vars, pts, &gpu, what)
}

/// The largest |gpu − cpu| / (1 + |cpu|) of the GPU's values `gpu` at the
/// points against the CPU's f32 evaluator; a disagreement in kind (finite
/// against not) fails.
fn worst_difference(tape: &isoray_shape::Tape, vars: &[f64], pts: &[[f32; 3]], gpu: &[f32], what: &str) -> f64 {
    let mut cpu = PointEvaluator::<f32>::new(tape);
    let mut worst = 0.0f64;
    for (p, &v) in pts.iter().zip(gpu) {
        let want = cpu.eval(vars, p[0], p[1], p[2]);
        assert_eq!(want.is_finite(), v.is_finite(), "{what} at {p:?}: gpu {v}, cpu {want}");
        if want.is_finite() {
            worst = worst.max((v as f64 - want as f64).abs() / (1.0 + (want as f64).abs()));
        }
    }
    worst
}

/// The example scene files, sorted.
fn example_files() -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(examples())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_example_scene_agrees_with_the_cpu() {
    let g = Gpu::new().unwrap_or_else(|e| panic!("{e}"));
    let pts = points();
    let mut report = Vec::new();
    let files = example_files();
    assert!(files.len() >= 8);
    for path in files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let scene = isoray_scene::load(&path, &[]).unwrap_or_else(|e| panic!("{}", e.rendered));
        let mut worst = compare(&g, &scene.shape, &scene.inputs, &pts, &name);
        for (i, o) in scene.objects.iter().enumerate() {
            worst = worst.max(compare(
                &g,
                &o.shape,
                &scene.inputs,
                &pts,
                &format!("{name} object {i}"),
            ));
        }
        report.push(format!("{name}: {worst:.2e}"));
        // Measured on lavapipe: 0 (bit for bit) to 2.6e-7, from the GPU's
        // sin/cos in rotations and its exp/ln in smooth minima.
        assert!(worst < 1e-5, "{name}: relative difference {worst:e}");
    }
    eprintln!("{}", report.join("\n"));
}

#[test]
fn a_new_parameter_value_is_a_new_buffer_not_a_new_shader() {
    let g = Gpu::new().unwrap_or_else(|e| panic!("{e}"));
    let text = "[params]\nr = 1.0\n[[object]]\nshape = \"sphere(p - vec3(sin(t), 0.0, 0.0), r)\"\n";
    let mut scene = isoray_scene::load_str(text, "t.toml", &[]).unwrap();
    let tape = scene.shape.tape().clone();
    let f = emit_tape(&tape, "f", "iso_in", 0);
    let shader = g.point_shader(&f, "f").unwrap();
    let pts = [[3.0f32, 0.0, 0.0], [0.0, 2.0, 0.0]];
    let at = |scene: &isoray_scene::Scene| g.eval_points(&shader, &f.fill(&tape, &scene.inputs), &pts).unwrap();
    assert_eq!(at(&scene), vec![2.0, 1.0]);
    scene.set_param("r", isoray_shape::Value::Float(1.5)).unwrap();
    assert_eq!(scene.shape.tape(), &tape, "the same tape");
    assert_eq!(at(&scene), vec![1.5, 0.5]);
    scene.set_time(std::f64::consts::FRAC_PI_2).unwrap();
    let v = at(&scene);
    assert!((v[0] - 0.5).abs() < 1e-6, "{v:?}");
}

/// The interpreting kernel's programs give what the CPU gives, every
/// example object run by one interpreter pipeline.
#[test]
fn the_interpreter_agrees_with_the_cpu_on_every_example_object() {
    use isoray_shape::wgsl::encode_tape;
    let g = Gpu::new().unwrap_or_else(|e| panic!("{e}"));
    let shader = g.program_shader().unwrap_or_else(|e| panic!("{e}"));
    let pts = points();
    for path in example_files() {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let scene = isoray_scene::load(&path, &[]).unwrap_or_else(|e| panic!("{}", e.rendered));
        for (i, o) in scene.objects.iter().enumerate() {
            let tape = o.shape.tape();
            let prog = encode_tape(tape, 0).unwrap();
            let gpu = g
                .eval_program(&shader, &prog, &prog.fill(tape, &scene.inputs), &pts)
                .unwrap();
            let worst = worst_difference(tape, &scene.inputs, &pts, &gpu, &format!("{name} object {i}"));
            assert!(worst < 1e-5, "{name} object {i}: {worst:e}");
        }
    }
}
