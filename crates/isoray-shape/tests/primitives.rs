//! Every primitive and operator against an independent implementation of its
//! formula, at many points inside and outside, plus analytic values.

use isoray_shape::{compile, GradientMode, Library};

type V = [f64; 3];

fn len(v: V) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}
fn len2(x: f64, y: f64) -> f64 {
    (x * x + y * y).sqrt()
}
fn clamp(x: f64, lo: f64, hi: f64) -> f64 {
    x.max(lo).min(hi)
}

fn ref_box(p: V, b: V) -> f64 {
    let q = [p[0].abs() - b[0], p[1].abs() - b[1], p[2].abs() - b[2]];
    len([q[0].max(0.0), q[1].max(0.0), q[2].max(0.0)]) + q[0].max(q[1]).max(q[2]).min(0.0)
}

fn ref_cone(p: V, angle: f64, h: f64) -> f64 {
    let (qx, qy) = (h * angle.tan(), -h);
    let (wx, wy) = (len2(p[0], p[2]), p[1]);
    let t = clamp((wx * qx + wy * qy) / (qx * qx + qy * qy), 0.0, 1.0);
    let (ax, ay) = (wx - qx * t, wy - qy * t);
    let u = clamp(wx / qx, 0.0, 1.0);
    let (bx, by) = (wx - qx * u, wy - qy);
    let k = qy.signum();
    let d = (ax * ax + ay * ay).min(bx * bx + by * by);
    let s = (k * (wx * qy - wy * qx)).max(k * (wy - qy));
    d.sqrt() * s.signum()
}

fn ref_hex(p: V, h: f64, w: f64) -> f64 {
    let k = [-0.8660254037844386, 0.5, 0.5773502691896258];
    let (mut x, mut y, z) = (p[0].abs(), p[1].abs(), p[2].abs());
    let t = 2.0 * (k[0] * x + k[1] * y).min(0.0);
    x -= t * k[0];
    y -= t * k[1];
    let dx = len2(x - clamp(x, -k[2] * w, k[2] * w), y - w) * (y - w).signum();
    let dy = z - h;
    dx.max(dy).min(0.0) + len2(dx.max(0.0), dy.max(0.0))
}

fn ref_octa(p: V, s: f64) -> f64 {
    let p = [p[0].abs(), p[1].abs(), p[2].abs()];
    let m = p[0] + p[1] + p[2] - s;
    let q = if 3.0 * p[0] < m {
        p
    } else if 3.0 * p[1] < m {
        [p[1], p[2], p[0]]
    } else if 3.0 * p[2] < m {
        [p[2], p[0], p[1]]
    } else {
        return m / 3f64.sqrt();
    };
    let k = clamp(0.5 * (q[2] - q[1] + s), 0.0, s);
    len([q[0], q[1] - s + k, q[2] - k])
}

/// Deterministic pseudo-random points in [-2.5, 2.5]^3.
fn points(n: usize) -> Vec<V> {
    let mut s: u64 = 0x9E3779B97F4A7C15;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 5.0 - 2.5
    };
    (0..n).map(|_| [next(), next(), next()]).collect()
}

fn check(src: &str, reference: impl Fn(V) -> f64) {
    let shape = compile(&Library::new(), src).unwrap_or_else(|e| panic!("{src}: {e}"));
    let mut inside = 0;
    for p in points(2000) {
        let (got, want) = (shape.eval(p), reference(p));
        inside += usize::from(want < 0.0);
        assert!(
            (got - want).abs() <= 1e-9 * (1.0 + want.abs()),
            "{src} at {p:?}: got {got}, want {want}"
        );
    }
    assert!(
        inside > 0,
        "{src}: no sample point fell inside; the test would not cover the interior"
    );
}

#[test]
fn sphere() {
    check("sphere(p, 1.3)", |p| len(p) - 1.3);
}

#[test]
fn boxes() {
    check("box(p, vec3(1.0, 0.5, 1.5))", |p| ref_box(p, [1.0, 0.5, 1.5]));
    check("box(p, 1.0)", |p| ref_box(p, [1.0; 3]));
    check("round_box(p, vec3(1.0, 0.8, 1.2), 0.3)", |p| {
        ref_box(p, [0.7, 0.5, 0.9]) - 0.3
    });
    let b = compile(&Library::new(), "box(p, vec3(1.0))").unwrap();
    assert_eq!(b.eval([2.0, 0.0, 0.0]), 1.0);
    assert!((b.eval([2.0, 2.0, 2.0]) - 3f64.sqrt()).abs() < 1e-12);
    assert_eq!(b.eval([0.5, 0.0, 0.0]), -0.5);
}

#[test]
fn plane_and_ellipsoid() {
    check("plane(p, vec3(0.0, 1.0, 0.0), 0.5)", |p| p[1] + 0.5);
    check("ellipsoid(p, vec3(1.0, 0.5, 1.5))", |p| {
        let r = [1.0, 0.5, 1.5];
        let k0 = len([p[0] / r[0], p[1] / r[1], p[2] / r[2]]);
        let k1 = len([p[0] / (r[0] * r[0]), p[1] / (r[1] * r[1]), p[2] / (r[2] * r[2])]);
        k0 * (k0 - 1.0) / k1
    });
    let e = compile(&Library::new(), "ellipsoid(p, vec3(1.0, 0.5, 1.5))").unwrap();
    assert!(e.eval([0.0, 0.0, 0.0]).is_finite());
    assert!(e.eval([1.0, 0.0, 0.0]).abs() < 1e-12);
    assert!(e.eval([0.0, 0.0, 1.5]).abs() < 1e-12);
}

#[test]
fn cylinder_capsule_torus() {
    check("cylinder(p, 0.8, 0.6)", |p| {
        let dx = len2(p[0], p[2]) - 0.6;
        let dy = p[1].abs() - 0.8;
        dx.max(dy).min(0.0) + len2(dx.max(0.0), dy.max(0.0))
    });
    check("capsule(p, 1.2, 0.4)", |p| {
        len([p[0], p[1] - clamp(p[1], -0.6, 0.6), p[2]]) - 0.4
    });
    check("torus(p, 1.0, 0.3)", |p| len2(len2(p[0], p[2]) - 1.0, p[1]) - 0.3);
    let lib = Library::new();
    let c = compile(&lib, "cylinder(p, 1.0, 0.5)").unwrap();
    assert!((c.eval([0.0, 2.0, 0.0]) - 1.0).abs() < 1e-12);
    assert!((c.eval([1.5, 0.0, 0.0]) - 1.0).abs() < 1e-12);
    assert!((c.eval([1.5, 2.0, 0.0]) - 2f64.sqrt()).abs() < 1e-12);
    let cap = compile(&lib, "capsule(p, 2.0, 0.5)").unwrap();
    assert!((cap.eval([0.0, 2.5, 0.0]) - 1.0).abs() < 1e-12);
    let t = compile(&lib, "torus(p, 2.0, 0.5)").unwrap();
    assert!((t.eval([3.5, 0.0, 0.0]) - 1.0).abs() < 1e-12);
    assert!((t.eval([0.0, 0.0, 2.0]) - -0.5).abs() < 1e-12);
}

#[test]
fn cone_prisms_octahedron() {
    check("cone(p, 0.5, 1.5)", |p| ref_cone(p, 0.5, 1.5));
    check("tri_prism(p, 0.8, 1.2)", |p| {
        let q = [p[0].abs(), p[1].abs(), p[2].abs()];
        (q[2] - 0.8).max((q[0] * 0.8660254037844386 + p[1] * 0.5).max(-p[1]) - 0.6)
    });
    check("hex_prism(p, 0.9, 0.7)", |p| ref_hex(p, 0.9, 0.7));
    check("octahedron(p, 1.4)", |p| ref_octa(p, 1.4));
    let lib = Library::new();
    // Cone: the apex is on the surface, a point straight above it is at distance y.
    let c = compile(&lib, "cone(p, 0.5, 1.0)").unwrap();
    assert!(c.eval([0.0, 0.0, 0.0]).abs() < 1e-12);
    assert!((c.eval([0.0, 0.7, 0.0]) - 0.7).abs() < 1e-12);
    // Below the base centre: distance to the base disk.
    assert!((c.eval([0.0, -1.5, 0.0]) - 0.5).abs() < 1e-12);
    let o = compile(&lib, "octahedron(p, 1.0)").unwrap();
    assert!((o.eval([0.0, 0.0, 0.0]) + 1.0 / 3f64.sqrt()).abs() < 1e-7);
    assert!(o.eval([1.0, 0.0, 0.0]).abs() < 1e-12);
    assert!((o.eval([2.0, 0.0, 0.0]) - 1.0).abs() < 1e-12);
}

#[test]
fn hard_operators() {
    let (a, b) = ("sphere(p, 1.0)", "box(p - vec3(0.8, 0.0, 0.0), vec3(0.5))");
    let fa = |p: V| len(p) - 1.0;
    let fb = |p: V| ref_box([p[0] - 0.8, p[1], p[2]], [0.5; 3]);
    check(&format!("union({a}, {b})"), |p| fa(p).min(fb(p)));
    check(&format!("intersection({a}, {b})"), |p| fa(p).max(fb(p)));
    check(&format!("difference({a}, {b})"), |p| fa(p).max(-fb(p)));
    check(&format!("union({a}, {b}, sphere(p, 0.2))"), |p| {
        fa(p).min(fb(p)).min(len(p) - 0.2)
    });
    check(&format!("round({b}, 0.1)"), |p| fb(p) - 0.1);
    check(&format!("onion({a}, 0.1)"), |p| fa(p).abs() - 0.1);
}

#[test]
fn smooth_operators_match_their_formulas() {
    let fa = |p: V| len(p) - 1.0;
    let fb = |p: V| ref_box([p[0] - 0.8, p[1], p[2]], [0.5; 3]);
    let (a, b) = ("sphere(p, 1.0)", "box(p - vec3(0.8, 0.0, 0.0), vec3(0.5))");
    let corr = |x: f64, y: f64, k: f64, n: f64| (k - (x - y).abs()).max(0.0).powf(n) / (2.0 * n * k.powf(n - 1.0));
    for (k, n) in [(0.3, 2.0), (0.5, 3.0), (0.2, 1.5)] {
        check(&format!("smooth_union({a}, {b}, {k}, {n})"), |p| {
            fa(p).min(fb(p)) - corr(fa(p), fb(p), k, n)
        });
        check(&format!("smooth_intersection({a}, {b}, {k}, {n})"), |p| {
            fa(p).max(fb(p)) + corr(fa(p), fb(p), k, n)
        });
        check(&format!("smooth_difference({a}, {b}, {k}, {n})"), |p| {
            fa(p).max(-fb(p)) + corr(fa(p), -fb(p), k, n)
        });
    }
    check(&format!("smin_cubic({a}, {b}, 0.4)"), |p| {
        let h = (0.4 - (fa(p) - fb(p)).abs()).max(0.0) / 0.4;
        fa(p).min(fb(p)) - h * h * h * 0.4 / 6.0
    });
    check(&format!("smin_exp({a}, {b}, 0.1)"), |p| {
        -0.1 * ((-fa(p) / 0.1).exp() + (-fb(p) / 0.1).exp()).ln()
    });
    // The n-ary smooth union: -k ln Σ e^(-dᵢ/k), the same in any order, and
    // smin_exp for two distances.
    let c = "box(p - vec3(0.0, 0.5, 0.0), vec3(0.3))";
    let fc = |p: V| {
        let q = [p[0].abs() - 0.3, (p[1] - 0.5).abs() - 0.3, p[2].abs() - 0.3];
        let out = (q[0].max(0.0).powi(2) + q[1].max(0.0).powi(2) + q[2].max(0.0).powi(2)).sqrt();
        out + q[0].max(q[1]).max(q[2]).min(0.0)
    };
    let n_ary = |p: V| -0.2 * ((-fa(p) / 0.2).exp() + (-fb(p) / 0.2).exp() + (-fc(p) / 0.2).exp()).ln();
    check(&format!("smooth_union_n(0.2, {a}, {b}, {c})"), n_ary);
    check(&format!("smooth_union_n(0.2, {c}, {a}, {b})"), n_ary);
    check(&format!("smooth_union_n(0.1, {a}, {b})"), |p| {
        -0.1 * ((-fa(p) / 0.1).exp() + (-fb(p) / 0.1).exp()).ln()
    });
    check(&format!("smin_root({a}, {b}, 0.3)"), |p| {
        0.5 * (fa(p) + fb(p) - ((fa(p) - fb(p)).powi(2) + 0.09).sqrt())
    });
    // smin_pow stays finite in f32 far from the shapes (no overflow of a^k b^k).
    let far = compile(
        &Library::new(),
        "smin_pow(sphere(p, 1.0), sphere(p - vec3(2.0, 0.0, 0.0), 1.0), 16.0)",
    )
    .unwrap();
    let mut e = isoray_shape::PointEvaluator::<f32>::new(far.tape());
    let v = e.eval(&[], 0.0, 0.0, 30.0);
    let (da, db) = (29.0f64, (904.0f64).sqrt() - 1.0);
    let want = ((da.powi(16) * db.powi(16)) / (da.powi(16) + db.powi(16))).powf(1.0 / 16.0);
    assert!(v.is_finite() && (v as f64 - want).abs() < 1e-3, "{v} vs {want}");
    check(&format!("smin_pow({a}, {b}, 8.0)"), |p| {
        let (x, y) = (fa(p), fb(p));
        if x.min(y) <= 0.0 {
            x.min(y)
        } else {
            ((x.powf(8.0) * y.powf(8.0)) / (x.powf(8.0) + y.powf(8.0))).powf(1.0 / 8.0)
        }
    });
}

#[test]
fn smooth_identities() {
    let lib = Library::new();
    for p in points(200) {
        for (k, n) in [(0.3, 2.0), (0.5, 3.0), (0.8, 4.0)] {
            // smooth_union(a, a, k) = a - k/(2n) for the polynomial family.
            let s = compile(&lib, &format!("smooth_union(sphere(p, 1.0), sphere(p, 1.0), {k}, {n})")).unwrap();
            let a = len(p) - 1.0;
            assert!((s.eval(p) - (a - k / (2.0 * n))).abs() < 1e-12);
        }
        // k = 0 gives the hard operators.
        for (soft, hard) in [
            ("smooth_union", "union"),
            ("smooth_intersection", "intersection"),
            ("smooth_difference", "difference"),
        ] {
            let args = "sphere(p, 1.0), box(p - vec3(0.5), vec3(0.6)), 0.0";
            let s = compile(&lib, &format!("{soft}({args})")).unwrap();
            let h = compile(&lib, &format!("{hard}(sphere(p, 1.0), box(p - vec3(0.5), vec3(0.6)))")).unwrap();
            assert_eq!(s.eval(p), h.eval(p));
        }
        // A non-constant k that evaluates to 0 also gives the hard operator, without NaN.
        let s = compile(&lib, "smooth_union(sphere(p, 1.0), box(p, vec3(0.5)), p.x * 0.0)").unwrap();
        let h = compile(&lib, "union(sphere(p, 1.0), box(p, vec3(0.5)))").unwrap();
        assert_eq!(s.eval(p), h.eval(p));
    }
}

#[test]
fn domain_operators() {
    let s = |src: &str| compile(&Library::new(), src).unwrap();
    // Rotating a box by 90 degrees about y swaps its x and z extents.
    let r = s("box(rotate_y(p, PI / 2.0), vec3(1.0, 0.5, 0.25))");
    assert!((r.eval([0.25 + 1.0, 0.0, 0.0]) - 1.0).abs() < 1e-12);
    assert!((r.eval([0.0, 0.0, 2.0]) - 1.0).abs() < 1e-12);
    // rotate(p, axis, angle) agrees with rotate_x/y/z.
    for p in points(100) {
        for (ax, f) in [
            ("vec3(1.0, 0.0, 0.0)", "rotate_x"),
            ("vec3(0.0, 2.0, 0.0)", "rotate_y"),
            ("vec3(0.0, 0.0, 1.0)", "rotate_z"),
        ] {
            let a = s(&format!("box(rotate(p, {ax}, 0.7), vec3(1.0, 0.5, 0.25))"));
            let b = s(&format!("box({f}(p, 0.7), vec3(1.0, 0.5, 0.25))"));
            assert!((a.eval(p) - b.eval(p)).abs() < 1e-12);
        }
    }
    // Right-handed: rotating by +90° about z takes the +x axis to +y.
    let bar = s("box(rotate_z(p, PI / 2.0), vec3(1.0, 0.1, 0.1))");
    assert!(bar.eval([0.0, 0.95, 0.0]) < 0.0);
    assert!(bar.eval([0.95, 0.0, 0.0]) > 0.0);
    // Repetition.
    let rep = s("sphere(repeat(p, 2.0), 0.5)");
    assert!((rep.eval([4.0, -2.0, 6.0]) + 0.5).abs() < 1e-12);
    let lim = s("sphere(repeat_limited(p, 2.0, 1.0), 0.5)");
    assert!((lim.eval([2.0, 0.0, 0.0]) + 0.5).abs() < 1e-12);
    assert!((lim.eval([6.0, 0.0, 0.0]) - 3.5).abs() < 1e-12);
    // Elongation keeps the distance exact outside the stretched region.
    let el = s("sphere(elongate(p, vec3(1.0, 0.0, 0.0)), 0.5)");
    assert!((el.eval([0.7, 1.0, 0.0]) - 0.5).abs() < 1e-12);
    assert!((el.eval([3.0, 0.0, 0.0]) - 1.5).abs() < 1e-12);
    // Mirrors.
    let m = s("sphere(mirror_x(p) - vec3(1.0, 0.0, 0.0), 0.3)");
    assert_eq!(m.eval([-1.0, 0.0, 0.0]), -0.3);
    // Twist at height 0 is the identity; at height y it turns the plane by k*y.
    let tw = s("box(twist_y(p, 1.0), vec3(1.0, 2.0, 0.1))");
    assert!(tw.eval([0.9, 0.0, 0.0]) < 0.0);
    let (c, sn) = ((1.0f64).cos(), (1.0f64).sin());
    assert!(tw.eval([0.9 * c, 1.0, -0.9 * sn]) < 0.0, "the bar turns with height");
    // Bend is the identity at x = 0.
    let bd = s("box(bend(p, 0.5), vec3(1.0, 0.2, 0.2))");
    assert!((bd.eval([0.0, 0.5, 0.0]) - 0.3).abs() < 1e-12);
    // Displacement is a distance term.
    let d = s("sphere(p, 1.0) + displace(p, 0.1, 5.0)");
    let p = [0.3, 0.4, 0.5];
    assert!((d.eval(p) - (len(p) - 1.0 + 0.1 * (1.5f64).sin() * (2.0f64).sin() * (2.5f64).sin())).abs() < 1e-12);
    // Uniform scale: sphere(p / s, r) * s is a sphere of radius r*s.
    let sc = s("sphere(p / 2.0, 1.0) * 2.0");
    assert!((sc.eval([3.0, 0.0, 0.0]) - 1.0).abs() < 1e-12);
}

#[test]
fn gradients_of_a_sphere_are_radial() {
    let sh = compile(&Library::new(), "sphere(p - vec3(0.1, 0.2, 0.3), 1.0)").unwrap();
    let p = [1.0, 0.5, -0.2];
    let d = [0.9, 0.3, -0.5];
    let l = len(d);
    for mode in [
        GradientMode::Dual,
        GradientMode::Central(1e-4),
        GradientMode::Forward(1e-6),
        GradientMode::Tetrahedron(1e-5),
    ] {
        let g = sh.gradient(p, mode);
        for i in 0..3 {
            assert!((g[i] - d[i] / l).abs() < 1e-5, "{mode:?}: {g:?}");
        }
    }
}

#[test]
fn power_operator() {
    let lib = Library::new();
    check("p.x^2 + p.y^2 + p.z^2 - 1.0", |p| {
        p[0] * p[0] + p[1] * p[1] + p[2] * p[2] - 1.0
    });
    // Tangle cube: x^4 - 5x^2 + y^4 - 5y^2 + z^4 - 5z^2 + 10 (negative inside its blobs).
    check(
        "p.x^4 - 5.0*p.x^2 + p.y^4 - 5.0*p.y^2 + p.z^4 - 5.0*p.z^2 + 10.0",
        |p| p.iter().map(|v| v.powi(4) - 5.0 * v * v).sum::<f64>() + 10.0,
    );
    let e = |s: &str| compile(&lib, s).unwrap().eval([-2.0, 3.0, 0.5]);
    assert_eq!(e("p.x^3"), -8.0);
    assert_eq!(e("-p.y^2"), -9.0);
    assert_eq!(e("2.0^3.0^2.0"), 512.0);
    assert_eq!(e("length(p^2)"), (16.0f64 + 81.0 + 0.0625).sqrt());
    assert!(compile(&lib, "p.x^").is_err());
}
