//! The interval emitter on real shapes: the GPU's bounds of a library
//! shape over boxes of three sizes contain the shape's f64 value at every
//! sampled point of each box, and are about as tight as the CPU's interval
//! arithmetic (`isoray_shape::interval::eval_interval`) on the same box.

use isoray_gpu::Gpu;
use isoray_shape::eval::PointEvaluator;
use isoray_shape::interval::{eval_interval, Interval};
use isoray_shape::ir::Builder;
use isoray_shape::wgsl::interval::{emit_tape_interval, f32_box};
use isoray_shape::{Library, Value};

/// A deterministic stream of numbers in [0, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn bounds_of_real_shapes_contain_their_values() {
    let g = Gpu::new().unwrap_or_else(|e| panic!("{e}"));
    let mut lib = Library::new();
    lib.set_param("r", Value::Float(0.8));
    lib.set_param("c", Value::Vec3([0.5, 0.25, 0.0]));
    let shapes = [
        // (text, whether the CPU's bounds may be much tighter: smooth minimums)
        ("sphere(p - c, r)", false),
        ("box(rotate_y(p, 0.7), vec3(0.5, r, 0.25))", false),
        ("torus(p - c, 1.0, 0.25)", false),
        ("max(-sphere(p, r), box(p, vec3(0.6)))", false),
        (
            "sin(p.x * 3.0) * cos(p.y * 3.0) + sin(p.y * 3.0) * cos(p.z * 3.0) + sin(p.z * 3.0) * cos(p.x * 3.0)",
            false,
        ),
        ("length(p) - r + 0.1 * sin(10.0 * p.x) * exp(-abs(p.y))", false),
        ("smooth_union(sphere(p - c, r), box(p + c, vec3(0.4)), 0.3)", true),
    ];
    let vars = lib.input_values();
    let mut rng = Lcg(7);
    let mut checked = 0usize;
    for (text, blended) in shapes {
        let mut b = Builder::new();
        let node = lib
            .compile(&mut b, text, 0)
            .unwrap_or_else(|d| panic!("{text}: {}", d.message));
        let tape = b.tape(node);
        let f = emit_tape_interval(&tape, "bounds", "iso_in", 0);
        let shader = g.interval_shader(&f, "bounds").unwrap_or_else(|e| panic!("{e}"));
        let mut boxes = Vec::new();
        for size in [0.01, 0.2, 1.5] {
            for _ in 0..200 {
                let c: [f64; 3] = std::array::from_fn(|_| rng.next() * 4.0 - 2.0);
                boxes.push(c.map(|v| (v - size / 2.0, v + size / 2.0)));
            }
        }
        let gpu_boxes: Vec<[[f32; 3]; 2]> = boxes.iter().map(f32_box).collect();
        let got = g.eval_boxes(&shader, &f.fill(&tape, &vars), &gpu_boxes).unwrap();
        let mut eval = PointEvaluator::<f64>::new(&tape);
        let mut wider = 0usize;
        for (bx, &[lo, hi]) in boxes.iter().zip(&got) {
            let (lo, hi) = (f64::from(lo), f64::from(hi));
            assert!(lo <= hi, "{text}: [{lo}, {hi}]");
            // Corners, centre and random points of the box.
            let mut pts: Vec<[f64; 3]> = (0..8)
                .map(|k| std::array::from_fn(|a| if k >> a & 1 == 1 { bx[a].1 } else { bx[a].0 }))
                .collect();
            pts.push(bx.map(|(l, h)| (l + h) / 2.0));
            for _ in 0..16 {
                pts.push(bx.map(|(l, h)| l + (h - l) * rng.next()));
            }
            for p in pts {
                let v = eval.eval(&vars, p[0], p[1], p[2]);
                assert!(
                    lo <= v && v <= hi,
                    "{text}: {v} at {p:?} escapes [{lo}, {hi}] over {bx:?}"
                );
                checked += 1;
            }
            let cpu = eval_interval(
                &tape,
                &vars,
                Interval::new(bx[0].0, bx[0].1),
                Interval::new(bx[1].0, bx[1].1),
                Interval::new(bx[2].0, bx[2].1),
            );
            if hi - lo > 1.01 * cpu.width() + 1e-5 {
                wider += 1;
            }
        }
        // As tight as the CPU's (its f64 rounding and the GPU's margins
        // aside), but where the CPU tightens smooth minimums.
        if !blended {
            assert_eq!(
                wider,
                0,
                "{text}: {wider} of {} boxes wider than the CPU's",
                boxes.len()
            );
        }
    }
    assert!(checked > 50_000, "{checked}");
}
