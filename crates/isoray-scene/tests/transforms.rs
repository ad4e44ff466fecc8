//! Object placements: `position`, `rotation` (degrees, about x, then y, then
//! z in world axes) and uniform `scale`, as runtime inputs.

use isoray_scene::analytic::Analytic;
use isoray_scene::{load_str, Scene};
use isoray_shape::Value;

fn scene(text: &str) -> Scene {
    load_str(text, "test.toml", &[]).unwrap_or_else(|e| panic!("{}", e.rendered))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

fn is_sphere(a: Option<Analytic>, centre: [f64; 3], radius: f64) -> bool {
    matches!(a, Some(Analytic::Sphere { c, r }) if (0..3).all(|k| close(c[k], centre[k])) && close(r, radius))
}

#[test]
fn a_placed_box_has_its_exact_distances() {
    // Half extents (1, 0.5, 0.25), turned 90° about z (long side along y),
    // doubled, centred at (1, 2, 3): half extents (1, 2, 0.5) there.
    let s = scene(
        "[[object]]\nshape = \"box(p, vec3(1.0, 0.5, 0.25))\"\nposition = [1.0, 2.0, 3.0]\nrotation = [0.0, 0.0, 90.0]\nscale = 2.0\n",
    );
    for (p, d) in [
        ([1.0, 2.0, 3.0], -0.5),
        ([1.0, 4.0, 3.0], 0.0),
        ([3.0, 2.0, 3.0], 1.0),
        ([1.0, 7.0, 3.0], 3.0),
        ([1.0, 2.0, 5.5], 2.0),
    ] {
        assert!(close(s.distance(p), d), "at {p:?}: {} ≠ {d}", s.distance(p));
    }
}

#[test]
fn rotations_apply_about_x_then_y_then_z() {
    // A small sphere at local (0, 1, 0): Rx(90°) takes it to (0, 0, 1), then
    // Ry(90°) to (1, 0, 0).
    let s = scene("[[object]]\nshape = \"sphere(p - vec3(0.0, 1.0, 0.0), 0.1)\"\nrotation = [90.0, 90.0, 0.0]\n");
    assert!(close(s.distance([1.0, 0.0, 0.0]), -0.1));
    // Rz(90°) alone takes local (1, 0, 0) to (0, 1, 0): counter-clockwise seen from +z.
    let s = scene("[[object]]\nshape = \"sphere(p - vec3(1.0, 0.0, 0.0), 0.1)\"\nrotation = [0.0, 0.0, 90.0]\n");
    assert!(close(s.distance([0.0, 1.0, 0.0]), -0.1));
    // Then y, then z: local (0, 0, 1) → Ry(90°) → (1, 0, 0) → Rz(90°) → (0, 1, 0).
    let s = scene("[[object]]\nshape = \"sphere(p - vec3(0.0, 0.0, 1.0), 0.1)\"\nrotation = [0.0, 90.0, 90.0]\n");
    assert!(close(s.distance([0.0, 1.0, 0.0]), -0.1));
}

#[test]
fn scale_keeps_distances_exact() {
    let s = scene("[[object]]\nshape = \"sphere(p, 1.0)\"\nscale = 3.0\n");
    for x in [0.0, 1.0, 3.0, 5.0, 40.0] {
        assert!(close(s.distance([x, 0.0, 0.0]), x - 3.0));
    }
}

#[test]
fn placements_follow_time_and_parameters_without_recompiling() {
    let mut s = scene(
        "[params]\nspeed = 2.0\n[[object]]\nshape = \"sphere(p, 1.0)\"\nposition = [\"speed * t\", 0.0, \"sin(t)\"]\nscale = \"1.0 + 0.5 * t\"\n",
    );
    let tape_before = s.objects[0].shape.tape().clone();
    assert!(
        is_sphere(s.derived().analytic[0], [0.0; 3], 1.0),
        "{:?}",
        s.derived().analytic[0]
    );
    s.set_time(2.0).unwrap();
    assert_eq!(s.objects[0].shape.tape(), &tape_before, "same tape");
    let Some(Analytic::Sphere { c, r }) = s.derived().analytic[0] else {
        panic!("{:?}", s.derived().analytic[0])
    };
    assert!(close(c[0], 4.0) && close(c[1], 0.0) && close(c[2], 2f64.sin()) && close(r, 2.0));
    assert!(close(s.distance([4.0, 0.0, 2f64.sin()]), -2.0));
    s.set_param("speed", Value::Float(-1.0)).unwrap();
    assert!(close(s.distance([-2.0, 0.0, 2f64.sin()]), -2.0));
    assert_eq!(
        s.input_names[s.objects[0].transform.as_ref().unwrap().inputs as usize],
        "object.0.position.x"
    );
    // A scale that is not positive is an error that changes nothing.
    let e = s.set_time(-3.0).unwrap_err();
    assert!(e.message.contains("object.0.scale"), "{}", e.message);
    assert_eq!(s.time(), 2.0);
    assert!(close(s.distance([-2.0, 0.0, 2f64.sin()]), -2.0));
}

#[test]
fn closed_forms_follow_the_placement() {
    let s = scene(
        "[[object]]\nshape = \"plane(p, vec3(0.0, 1.0, 0.0), 0.0)\"\nrotation = [0.0, 0.0, 90.0]\nposition = [2.0, 0.0, 0.0]\n[[object]]\nshape = \"sphere(p, 0.5)\"\nposition = [0.0, 3.0, 0.0]\nscale = 2.0\n",
    );
    // The floor's normal +y turned 90° about z points to −x; it passes through x = 2.
    let Some(Analytic::Plane { n, h }) = s.derived().analytic[0] else {
        panic!("{:?}", s.derived().analytic[0])
    };
    assert!(close(n[0], -1.0) && close(n[1], 0.0) && close(h, 2.0), "{n:?} {h}");
    assert!(
        is_sphere(s.derived().analytic[1], [0.0, 3.0, 0.0], 1.0),
        "{:?}",
        s.derived().analytic[1]
    );
}

#[test]
fn bad_placements_are_located_errors() {
    let err = |text: &str| load_str(text, "bad.toml", &[]).unwrap_err();
    let e = err("[[object]]\nshape = \"sphere(p, 1.0)\"\nscale = 0.0\n");
    assert!(
        e.message.contains("`object.0.scale` must be a positive number"),
        "{}",
        e.rendered
    );
    assert_eq!(e.line, Some(3));
    let e = err("[[object]]\nshape = \"sphere(p, 1.0)\"\nposition = \"1.0\"\n");
    assert!(e.message.contains("expected a `vec3`"), "{}", e.rendered);
    let e = err("[[object]]\nshape = \"sphere(p, 1.0)\"\nposition = [0.0, \"p.x\", 0.0]\n");
    assert!(e.message.contains("unknown name `p`"), "{}", e.rendered);
    assert_eq!((e.line, e.column), (Some(3), Some(19)));
    let e = err("[[object]]\nshape = \"sphere(p, 1.0)\"\nrotation = [0.0, 1.0]\n");
    assert!(
        e.message
            .contains("`object.0.rotation`: expected an array of 3 numbers"),
        "{}",
        e.rendered
    );
    let e = err("[[object]]\nshape = \"sphere(p, 1.0)\"\nscale = \"t - 1.0\"\n");
    assert!(e.message.contains("found -1"), "{}", e.rendered);
    let e = err("[[object]]\nshape = \"sphere(p, 1.0)\"\nscale = [1.0, 2.0, 3.0]\n");
    assert!(
        e.message.contains("`object.0.scale`: expected a number"),
        "{}",
        e.rendered
    );
}
