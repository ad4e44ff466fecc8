//! Implicit and parametric surfaces reached through scene files: the
//! equations isoray derives, the distance bounds it traces, and the errors.

use isoray_algebra::{parse_poly, MonomialOrder, Ring};
use isoray_scene::{load_str, Scene};
use isoray_shape::surface::Analysis;

fn scene(text: &str) -> Scene {
    load_str(text, "s.toml", &[]).unwrap_or_else(|e| panic!("{}", e.rendered))
}

fn err(text: &str) -> isoray_scene::SceneError {
    load_str(text, "bad.toml", &[]).expect_err("should fail")
}

fn analysis(s: &Scene, name: &str) -> std::sync::Arc<Analysis> {
    s.library.default_analysis(name).expect("a surface").unwrap()
}

/// The implicitization reference set of the algebra tests (Singular's
/// answers), each reached through a `[surface.NAME] parametric` table.
#[test]
fn parametrizations_through_scenes_match_the_reference() {
    let data = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../isoray-algebra/tests/data/implicit.txt"
    ))
    .unwrap();
    let ring = Ring::new(&["x", "y", "z"], MonomialOrder::DegRevLex);
    let mut n = 0;
    for line in data.lines().filter(|l| !l.trim().is_empty()) {
        let (lhs, want) = line.split_once(" => ").unwrap();
        let parts: Vec<&str> = lhs.split("; ").map(|p| p.split_once('=').unwrap().1).collect();
        let text = format!(
            "[surface.f]\nparametric = {{ x = \"{}\", y = \"{}\", z = \"{}\" }}\ndomain = {{ s = [0.5, 2.0], t = [0.5, 2.0] }}\n[[object]]\nshape = \"f(p)\"\n",
            parts[0], parts[1], parts[2]
        );
        let s = scene(&text);
        let a = analysis(&s, "f");
        let eq = a.equation.as_ref().unwrap_or_else(|e| panic!("{line}: {e}"));
        let want = parse_poly(&ring, want).unwrap().monic();
        assert_eq!(eq.poly, want, "{line}");
        let check = a.implicitization.as_ref().unwrap();
        assert!(
            check.checked_points > 100 && check.max_residual < 1e-9,
            "{line}: {check:?}"
        );
        n += 1;
    }
    assert_eq!(n, 9);
}

fn norm(p: [f64; 3]) -> f64 {
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

/// Points on rays from the origin at many radii (inside and outside).
fn samples() -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for i in 0..40 {
        let a = i as f64 * 0.61;
        let dir = [a.cos() * (1.3 * a).sin(), (0.7 * a).cos(), a.sin() * (1.3 * a).sin()];
        let n = norm(dir);
        for k in 1..60 {
            let r = 0.05 * k as f64;
            out.push([dir[0] / n * r, dir[1] / n * r, dir[2] / n * r]);
        }
    }
    out
}

#[test]
fn sphere_bounds_against_the_true_distance() {
    let base = "[surface.ball]\nimplicit = \"x^2 + y^2 + z^2 - 1\"\n";
    let taylor = scene(&format!("{base}[[object]]\nshape = \"ball(p)\"\n"));
    let first = scene(&format!(
        "{base}bound = \"first-order\"\n[[object]]\nshape = \"ball(p)\"\n"
    ));
    let lipschitz = scene(&format!(
        "{base}bound = \"lipschitz\"\n[[object]]\nshape = \"ball(p)\"\n"
    ));
    let exact = scene("[surface.ball]\nimplicit = \"sqrt(x^2 + y^2 + z^2) - 1\"\nbound = \"first-order\"\n[[object]]\nshape = \"ball(p)\"\n");
    for p in samples() {
        let r = norm(p);
        let d = r - 1.0;
        // f = |p| − 1 has |∇f| = 1: f/|∇f| is the distance itself.
        assert!((exact.distance(p) - d).abs() < 1e-12, "{p:?}");
        // f = |p|² − 1: f/|∇f| = (r² − 1)/(2r), below the distance outside, above it inside.
        assert!((first.distance(p) - (r * r - 1.0) / (2.0 * r)).abs() < 1e-12, "{p:?}");
        // The guaranteed bounds never exceed the distance, and are useful.
        for (what, s) in [("taylor", &taylor), ("lipschitz", &lipschitz)] {
            let v = s.distance(p);
            assert!(
                v.abs() <= d.abs() * (1.0 + 1e-12) + 1e-15,
                "{what} at r = {r}: {v} > {d}"
            );
            if d.abs() > 1e-12 {
                assert_eq!(v.signum(), d.signum(), "{what} at r = {r}");
            }
            if (r - 1.0).abs() < 0.5 {
                assert!(v.abs() >= 0.3 * d.abs(), "{what} at r = {r}: {v} ≪ {d}");
            }
        }
    }
}

#[test]
fn torus_quartic_bound_never_exceeds_the_distance() {
    // (|p|² + R² − r²)² − 4R²(x² + z²): the torus around the y axis.
    let s = scene(
        "[surface.torus4]\nparams = { R = 1.0, r = 0.25 }\nimplicit = \"(x^2 + y^2 + z^2 + R^2 - r^2)^2 - 4*R^2*(x^2 + z^2)\"\n[[object]]\nshape = \"torus4(p)\"\n",
    );
    let a = analysis(&s, "torus4");
    assert_eq!(a.equation.as_ref().unwrap().poly.degree(), 4);
    let mut near = 0;
    for p in samples().into_iter().map(|p| [p[0] * 0.8, p[1] * 0.5, p[2] * 0.8]) {
        let q = ((p[0] * p[0] + p[2] * p[2]).sqrt() - 1.0).hypot(p[1]);
        let d = q - 0.25;
        let v = s.distance(p);
        assert!(
            v.abs() <= d.abs() * (1.0 + 1e-9) + 1e-12,
            "at {p:?}: bound {v}, distance {d}"
        );
        if d.abs() > 1e-9 {
            assert_eq!(v.signum(), d.signum(), "at {p:?}");
        }
        if d.abs() < 0.05 {
            near += 1;
            assert!(v.abs() >= 0.5 * d.abs(), "at {p:?}: bound {v} ≪ distance {d}");
        }
    }
    assert!(near > 10);
    // f/|∇f| is the distance to first order: near the surface the ratio tends to 1.
    let fo = scene(
        "[surface.torus4]\nparams = { R = 1.0, r = 0.25 }\nimplicit = \"(x^2 + y^2 + z^2 + R^2 - r^2)^2 - 4*R^2*(x^2 + z^2)\"\nbound = \"first-order\"\n[[object]]\nshape = \"torus4(p)\"\n",
    );
    let mut checked = 0;
    for p in samples().into_iter().map(|p| [p[0] * 0.8, p[1] * 0.5, p[2] * 0.8]) {
        let q = ((p[0] * p[0] + p[2] * p[2]).sqrt() - 1.0).hypot(p[1]);
        let d = q - 0.25;
        if d.abs() < 0.02 && d.abs() > 1e-6 {
            checked += 1;
            let v = fo.distance(p);
            assert!((v / d - 1.0).abs() < 0.1, "at {p:?}: f/|grad f| = {v}, distance {d}");
        }
    }
    assert!(checked > 5, "{checked}");
}

#[test]
fn square_free_part_is_traced() {
    // (x² + y² + z² − 1)³: f/|∇f| would be a third of the distance; the
    // square-free part gives the same bound as the sphere itself.
    let cubed = scene("[surface.c]\nimplicit = \"(x^2 + y^2 + z^2 - 1)^3\"\n[[object]]\nshape = \"c(p)\"\n");
    let plain = scene("[surface.c]\nimplicit = \"x^2 + y^2 + z^2 - 1\"\n[[object]]\nshape = \"c(p)\"\n");
    let eq = analysis(&cubed, "c").equation.clone().unwrap();
    assert!(eq.reduced && eq.original_degree == 6 && eq.poly.degree() == 2);
    for p in samples() {
        assert!((cubed.distance(p) - plain.distance(p)).abs() < 1e-9, "{p:?}");
    }
}

#[test]
fn image_only_keeps_points_with_a_real_preimage() {
    // (s², st, t²) covers only the nappe x, z ≥ 0 of the cone y² = xz.
    let text = |image: bool| {
        format!(
            "[surface.k]\nparametric = {{ x = \"s^2\", y = \"s*t\", z = \"t^2\" }}\ndomain = {{ s = [-1.0, 1.0], t = [-1.0, 1.0] }}\nimage_only = {image}\n[[object]]\nshape = \"k(p)\"\n"
        )
    };
    let closure = scene(&text(false));
    let image = scene(&text(true));
    let on_image = [0.25, 0.25, 0.25]; // s = t = 0.5
    let off_image = [-0.25, 0.25, -0.25]; // y² = xz with x, z < 0
    assert!(closure.distance(on_image).abs() < 1e-9);
    assert!(closure.distance(off_image).abs() < 1e-9);
    assert!(image.distance(on_image).abs() < 1e-3);
    assert!(image.distance(off_image) > 0.1, "{}", image.distance(off_image));
}

#[test]
fn surfaces_of_every_mode_are_called_like_primitives() {
    let s = scene(
        "[material.gold]\ndiffuse = [1.0, 0.8, 0.3]\n\
         [surface.a]\nparams = { r = 1.0 }\nimplicit = \"x^2 + y^2 + z^2 - r\"\n\
         [surface.b]\nparametric = { x = \"2*s/(s^2+t^2+1)\", y = \"2*t/(s^2+t^2+1)\", z = \"(s^2+t^2-1)/(s^2+t^2+1)\" }\nmaterial = \"gold\"\n\
         [surface.c]\nparams = { R = 1.0, r = 0.25 }\nsdf = \"length(vec2(length(p.xz) - R, p.y)) - r\"\n\
         [[object]]\nshape = \"smooth_union(a(p - vec3(3.0, 0.0, 0.0), 4.0), c(p, 1.5, 0.5), 0.2)\"\n\
         [[object]]\nshape = \"b(translate(p, vec3(0.0, 0.0, 3.0)))\"\n",
    );
    // The sphere of radius 2 around (3, 0, 0) meets the x axis at 5.
    assert!(s.distance([5.0, 0.0, 0.0]).abs() < 1e-9);
    // The rational (unit) sphere, moved to z = 3.
    assert!(s.objects[1].shape.eval([0.0, 0.0, 2.0]).abs() < 1e-9);
    assert!(s.objects[1].shape.eval([0.0, 1.0, 3.0]).abs() < 1e-9);
    assert!(s.objects[1].shape.eval([0.0, 0.0, 3.0]) < 0.0);
    // The object without a material takes its surface's default.
    assert_eq!(s.materials[s.objects[1].material].name, "gold");
    assert_eq!(s.objects[0].material, 0);
}

#[test]
fn surface_errors_name_the_place() {
    let e =
        err("[surface.w]\nparametric = { x = \"cos(s)\", y = \"sin(s)\", z = \"t\" }\n[[object]]\nshape = \"w(p)\"\n");
    assert!(
        e.message.contains("cannot be sphere-traced") && e.message.contains("not rational"),
        "{e}"
    );
    assert!(e.message.contains("cos"), "{e}");
    assert_eq!(e.line, Some(4));
    // A non-rational surface that is defined but not used loads.
    assert!(load_str("[surface.w]\nparametric = { x = \"cos(s)\", y = \"sin(s)\", z = \"t\" }\n[[object]]\nshape = \"sphere(p, 1.0)\"\n", "ok.toml", &[]).is_ok());
    let e = err("[surface.w]\nparametric = { x = \"s\", y = \"t\" }\n[[object]]\nshape = \"w(p)\"\n");
    assert!(e.message.contains("needs `z`"), "{e}");
    let e = err("[surface.w]\nparametric = { x = \"s\", y = \"t\", z = \"u\" }\n[[object]]\nshape = \"w(p)\"\n");
    assert!(e.message.contains("unknown name `u`"), "{e}");
    assert_eq!((e.line, e.column), (Some(2), Some(39)), "{e}");
    let e = err("[surface.w]\nparametric = { x = \"s\", y = \"s\", z = \"s\" }\n[[object]]\nshape = \"w(p)\"\n");
    assert!(
        e.message.contains("could not be implicitized") || e.message.contains("principal"),
        "{e}"
    );
    let e = err("[surface.w]\nimplicit = \"x - 1.0\"\nimage_only = true\n[[object]]\nshape = \"w(p)\"\n");
    assert!(e.message.contains("only to parametric"), "{e}");
    let e = err("[surface.w]\nparametric = { x = \"s\", y = \"t\", z = \"s*t\" }\ndomain = { s = [1.0, -1.0] }\n[[object]]\nshape = \"w(p)\"\n");
    assert!(e.message.contains("min < max"), "{e}");
    let e = err("[surface.w]\nimplicit = \"sin(x) + y\"\nbound = \"taylor\"\n[[object]]\nshape = \"w(p)\"\n");
    assert!(e.message.contains("not a polynomial"), "{e}");
    let e = err("[surface.w]\nimplicit = \"x - 1.0\"\nbound = \"exact\"\n[[object]]\nshape = \"w(p)\"\n");
    assert!(e.message.contains("\"lipschitz\""), "{e}");
    let e = err("[surface.w]\nimplicit = \"x - 1.0\"\nlipschitz_factor = 0.5\n[[object]]\nshape = \"w(p)\"\n");
    assert!(e.message.contains("≥ 1"), "{e}");
    let e = err("[surface.w]\nparams = { a = 1.0 }\nparametric = { x = \"s\", y = \"t\", z = \"a*s*t\" }\n[[object]]\nshape = \"w(p, p.x)\"\n");
    assert!(e.message.contains("must be constants"), "{e}");
    let e = err("[surface.w]\nimplicit = \"x - 1.0\"\nmaterial = \"nope\"\n[[object]]\nshape = \"w(p)\"\n");
    assert!(e.message.contains("no material named \"nope\""), "{e}");
}

#[test]
fn parameters_may_declare_ranges() {
    let s = scene(
        "[params]\nk = { default = 0.5, range = [0.0, 1.0] }\n\
         [surface.sphere_eq]\nparams = { r = { default = 1.0, range = [0.25, 3.0] }, c = [0.0, 0.0, 0.0] }\nimplicit = \"(x - c.x)^2 + y^2 + z^2 - r^2\"\n\
         [[object]]\nshape = \"sphere_eq(p) + k * 0.0\"\n",
    );
    let keys: Vec<(&str, [f64; 2])> = s.param_ranges.iter().map(|r| (r.key.as_str(), r.range)).collect();
    assert_eq!(
        keys,
        [("params.k", [0.0, 1.0]), ("surface.sphere_eq.params.r", [0.25, 3.0])]
    );
    assert!(s.distance([1.0, 0.0, 0.0]).abs() < 1e-12);
    let e = err("[surface.s]\nparams = { r = { default = 5.0, range = [0.0, 1.0] } }\nimplicit = \"x - r\"\n[[object]]\nshape = \"s(p)\"\n");
    assert!(e.message.contains("outside its range"), "{e}");
    assert_eq!(e.line, Some(2));
    let e = err(
        "[surface.s]\nparams = { r = { range = [0.0, 1.0] } }\nimplicit = \"x - r\"\n[[object]]\nshape = \"s(p)\"\n",
    );
    assert!(e.message.contains("needs a `default`"), "{e}");
    let e = err("[surface.s]\nparams = { r = { default = [1.0, 2.0], range = [0.0, 1.0] } }\nsdf = \"length(p) - r.x\"\n[[object]]\nshape = \"s(p)\"\n");
    assert!(e.message.contains("number parameters only"), "{e}");
    let e = err("[surface.s]\nparams = { r = { default = 1.0, range = [2.0, 1.0] } }\nsdf = \"length(p) - r\"\n[[object]]\nshape = \"s(p)\"\n");
    assert!(e.message.contains("min < max"), "{e}");
}

#[test]
fn each_surface_is_implicitized_once() {
    let s = scene(
        "[surface.b]\nparametric = { x = \"2*s/(s^2+t^2+1)\", y = \"2*t/(s^2+t^2+1)\", z = \"(s^2+t^2-1)/(s^2+t^2+1)\" }\n\
         [[object]]\nshape = \"b(p)\"\n[[object]]\nshape = \"b(p - vec3(3.0, 0.0, 0.0))\"\n",
    );
    // The analysis made at load time is the one every later request gets.
    let first = analysis(&s, "b");
    let again = analysis(&s, "b");
    assert!(std::sync::Arc::ptr_eq(&first, &again));
    // The cost estimate picks interpolation for this degree-2 surface.
    assert_eq!(first.implicitization.as_ref().unwrap().method, "interpolation");
}

#[test]
fn huge_equations_do_not_hang() {
    let start = std::time::Instant::now();
    for eq in [
        "((x + y + z)^64)^64 - 1",
        "(x + y + z + 1)^40 - 2",
        "(x^2 + y^2 + z^2)^30 - 1",
    ] {
        let s = scene(&format!(
            "[surface.h]\nimplicit = \"{eq}\"\n[[object]]\nshape = \"h(p)\"\n"
        ));
        let a = analysis(&s, "h");
        assert!(a.equation.is_err(), "{eq}: expected no Taylor bound");
        // The Lipschitz bound is traced instead (f overflows f64 far from the
        // planes of the first one; its value there is meaningless but finite).
        assert!(s.distance([0.0, 0.0, 0.0]).is_finite(), "{eq}");
        if !eq.starts_with("((") {
            let d = s.distance([0.0, 0.0, 0.0]);
            // Distances from the origin: 0.0175/√3 to the plane x + y + z = 2^(1/40) − 1,
            // and 1 to the unit sphere.
            let exact = if eq.starts_with("(x + y") {
                (2f64.powf(1.0 / 40.0) - 1.0) / 3f64.sqrt()
            } else {
                1.0
            };
            assert!(d <= 0.0 && -d <= exact, "{eq}: {d} vs {exact}");
            if exact < 1.0 {
                assert!(-d > 0.2 * exact, "{eq}: {d} vs {exact}");
            }
        }
    }
    // A high power of a small equation is made square-free first, and traced
    // through the Taylor-root bound of the sphere.
    let s = scene("[surface.h]\nimplicit = \"(x^2 + y^2 + z^2 - 1)^10\"\n[[object]]\nshape = \"h(p)\"\n");
    let eq = analysis(&s, "h").equation.clone().unwrap();
    assert_eq!((eq.original_degree, eq.poly.degree()), (20, 2));
    assert!(eq.taylor_terms.is_ok());
    // A large dense polynomial keeps its equation but uses the Lipschitz bound.
    let s = scene("[surface.h]\nimplicit = \"(x + y + z + 1)^16 - 2\"\n[[object]]\nshape = \"h(p)\"\n");
    let eq = analysis(&s, "h").equation.clone().unwrap();
    assert!(eq.taylor_terms.is_err());
    assert!(s.distance([0.0, 0.0, 0.0]) < 0.0);
    assert!(start.elapsed().as_secs() < 20, "{:?}", start.elapsed());
}

/// The algebraic gallery clips each surface by a ball (`max(f, sphere(q,
/// r))`): far from it that is the ball's distance, so sampling far away
/// alone took the torus, the Kummer quartic and the Barth sextic for balls
/// in closed form, and the tracer drew balls. Nothing there is a plane or
/// a sphere.
#[test]
fn clipped_surfaces_are_not_taken_for_their_balls() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/algebraic.toml");
    let s = isoray_scene::load(std::path::Path::new(path), &[]).unwrap_or_else(|e| panic!("{}", e.rendered));
    assert_eq!(s.objects.len(), 8);
    for (k, a) in s.derived().analytic.iter().enumerate() {
        assert!(a.is_none(), "object {k} taken for {a:?}");
    }
}
