//! Parameters and the time as runtime inputs; exact algebra binds them.

use isoray_scene::{load_str, load_str_with, LoadOptions, Scene};
use isoray_shape::Value;

fn scene(text: &str) -> Scene {
    load_str(text, "test.toml", &[]).unwrap_or_else(|e| panic!("{}", e.rendered))
}

#[test]
fn sdf_parameters_and_time_stay_live() {
    let mut s = scene(
        "[params]\nr = 1.0\n[surface.ball]\nsdf = \"length(p) - k\"\nparams = { k = 1.0 }\n[[object]]\nshape = \"ball(p - vec3(t, 0.0, 0.0), r)\"\n",
    );
    assert!(s.objects[0].bound_inputs.is_empty());
    assert_eq!(s.input_names, ["t", "r"]);
    let tape = s.objects[0].shape.tape().clone();
    assert_eq!(tape.vars(), &[0, 1]);
    s.set_param("r", Value::Float(2.0)).unwrap();
    s.set_time(0.5).unwrap();
    assert_eq!(s.objects[0].shape.tape(), &tape, "nothing recompiled");
    assert_eq!(s.distance([0.5, 0.0, 0.0]), -2.0);
    assert_eq!(s.distance([4.5, 0.0, 0.0]), 2.0);
    // The same values through a load give the same distances.
    let opts = LoadOptions {
        time: 0.5,
        ..LoadOptions::default()
    };
    let text = "[params]\nr = 2.0\n[[object]]\nshape = \"sphere(p - vec3(t, 0.0, 0.0), r)\"\n";
    let loaded = load_str_with(text, "t.toml", &[], &opts).unwrap();
    assert_eq!(loaded.distance([4.5, 0.0, 0.0]), 2.0);
}

#[test]
fn implicit_surfaces_bind_the_parameters_they_take() {
    let text = "[params]\nR = 1.0\n[surface.sph]\nimplicit = \"x*x + y*y + z*z - r*r\"\nparams = { r = 1.0 }\n[[object]]\nshape = \"sph(p, R)\"\n";
    let mut s = scene(text);
    assert_eq!(s.objects[0].bound_inputs, vec![1], "R is bound");
    let cached = s.library.analyses().len();
    assert_eq!(cached, 1);
    let inside = |s: &Scene, x: f64| s.distance([x, 0.0, 0.0]) < 0.0;
    assert!(inside(&s, 0.9) && !inside(&s, 1.1));
    s.set_param("R", Value::Float(2.0)).unwrap();
    assert!(inside(&s, 1.9) && !inside(&s, 2.1), "re-derived for R = 2");
    assert_eq!(s.library.analyses().len(), 2);
    s.set_param("R", Value::Float(1.0)).unwrap();
    assert!(inside(&s, 0.9) && !inside(&s, 1.1));
    assert_eq!(s.library.analyses().len(), 2, "R = 1 again comes from the cache");
    // A body that reads a scene parameter directly binds it too.
    let s = scene(
        "[params]\nR = 1.5\n[surface.sph]\nimplicit = \"x*x + y*y + z*z - R*R\"\n[[object]]\nshape = \"sph(p)\"\n",
    );
    assert_eq!(s.objects[0].bound_inputs, vec![1]);
    assert!(s.distance([1.4, 0.0, 0.0]) < 0.0 && s.distance([1.6, 0.0, 0.0]) > 0.0);
}

#[test]
fn a_redefined_surface_is_never_served_stale() {
    let a = scene("[surface.s]\nimplicit = \"x*x + y*y + z*z - 1.0\"\n[[object]]\nshape = \"s(p)\"\n");
    let cache = a.library.analyses().clone();
    let opts = LoadOptions {
        analyses: Some(cache.clone()),
        ..LoadOptions::default()
    };
    // Same name, other content, same cache.
    let b = load_str_with(
        "[surface.s]\nimplicit = \"x*x + y*y + z*z - 4.0\"\n[[object]]\nshape = \"s(p)\"\n",
        "b.toml",
        &[],
        &opts,
    )
    .unwrap();
    assert!(b.distance([1.9, 0.0, 0.0]) < 0.0 && b.distance([2.1, 0.0, 0.0]) > 0.0);
    assert_eq!(cache.len(), 2);
}

#[test]
fn setting_a_parameter_checks_name_type_and_range() {
    let mut s = scene("[params]\nk = { default = 1.0, range = [0.5, 2.0] }\nc = [0.0, 0.0, 0.0]\n[[object]]\nshape = \"sphere(p - c, k)\"\n");
    let e = s.set_param("k", Value::Float(3.0)).unwrap_err();
    assert!(e.message.contains("outside its range [0.5, 2]"), "{}", e.message);
    let e = s.set_param("kk", Value::Float(1.0)).unwrap_err();
    assert!(e.message.contains("did you mean `k`"), "{}", e.message);
    let e = s.set_param("c", Value::Float(1.0)).unwrap_err();
    assert!(e.message.contains("is a `vec3`"), "{}", e.message);
    s.set_param("c", Value::Vec3([1.0, 0.0, 0.0])).unwrap();
    assert_eq!(s.distance([1.0, 0.0, 0.0]), -1.0);
}

#[test]
fn camera_light_and_material_values_may_be_expressions_of_time() {
    let text = r#"
[params]
glow = 0.5
[camera]
position = ["4.0 * sin(t)", 1.0, "4.0 * cos(t)"]
fov = "40.0 + 10.0 * t"
[[light]]
kind = "point"
position = "vec3(0.0, 3.0 + t, 0.0)"
intensity = "1.0 + 0.5 * sin(t)"
color = [1.0, "glow", 0.25]
[material.warm]
diffuse = "vec3(0.8, 0.4 * glow, 0.1)"
shininess = "16.0 * (1.0 + t)"
[[object]]
material = "warm"
shape = "sphere(p, 1.0)"
"#;
    let mut s = scene(text);
    let keys: Vec<&str> = s.driven.iter().map(|d| d.key.as_str()).collect();
    assert_eq!(
        keys,
        [
            "camera.position",
            "camera.fov",
            "light.0.position",
            "light.0.intensity",
            "light.0.color",
            "material.warm.diffuse",
            "material.warm.shininess"
        ]
    );
    assert_eq!(s.camera.position, [0.0, 1.0, 4.0]);
    assert_eq!(s.lights[0].intensity, 1.0);
    assert_eq!(s.lights[0].color, [1.0, 0.5, 0.25]);
    s.set_time(1.0).unwrap();
    assert!((s.camera.position[0] - 4.0 * 1f64.sin()).abs() < 1e-12);
    assert_eq!(s.camera.fov, 50.0);
    assert_eq!(
        s.lights[0].kind,
        isoray_scene::LightKind::Point {
            position: [0.0, 4.0, 0.0]
        }
    );
    assert!((s.lights[0].intensity - (1.0 + 0.5 * 1f64.sin())).abs() < 1e-12);
    assert_eq!(s.materials[1].shininess, 32.0);
    s.set_param("glow", Value::Float(1.0)).unwrap();
    assert_eq!(s.lights[0].color, [1.0, 1.0, 0.25]);
    assert_eq!(s.materials[1].diffuse, [0.8, 0.4, 0.1]);
    // A value that leaves its range at some time is an error there, and changes nothing.
    let e = s.set_time(14.0).unwrap_err();
    assert!(
        e.message.contains("camera.fov") && e.message.contains("at t = 14"),
        "{}",
        e.message
    );
    assert_eq!(s.camera.fov, 50.0);
    // Setting a value directly is checked the same way.
    s.set_value("light.0.intensity", &[2.0]).unwrap();
    assert_eq!(s.lights[0].intensity, 2.0);
    assert!(s.set_value("light.0.intensity", &[-1.0]).is_err());
    assert!(
        s.set_value("light.0.direction", &[0.0, 1.0, 0.0]).is_err(),
        "a point light has no direction"
    );
    assert!(s.set_value("material.warm.reflectivity", &[1.5]).is_err());
}

#[test]
fn expression_errors_point_into_the_value() {
    let e = load_str(
        "[[light]]\nintensity = \"1.0 + sin(q)\"\n[[object]]\nshape = \"sphere(p, 1.0)\"\n",
        "bad.toml",
        &[],
    )
    .unwrap_err();
    assert!(e.message.contains("unknown name `q`"), "{}", e.rendered);
    assert_eq!((e.line, e.column), (Some(2), Some(24)));
    let e = load_str(
        "[[light]]\nintensity = \"-1.0 + 0.5 * t\"\n[[object]]\nshape = \"sphere(p, 1.0)\"\n",
        "bad.toml",
        &[],
    )
    .unwrap_err();
    assert!(
        e.message.contains("`light.0.intensity`: expected a number ≥ 0"),
        "{}",
        e.rendered
    );
    assert_eq!(e.line, Some(2));
}

#[test]
fn closed_forms_follow_parameters() {
    let mut s = scene("[params]\nr = 0.7\n[[object]]\nshape = \"sphere(p - vec3(1.0, 0.0, 0.0), r)\"\n");
    let radius = |s: &Scene| match s.derived().analytic[0] {
        Some(isoray_scene::analytic::Analytic::Sphere { r, .. }) => r,
        other => panic!("{other:?}"),
    };
    assert!((radius(&s) - 0.7).abs() < 1e-9);
    s.set_param("r", Value::Float(0.9)).unwrap();
    assert!((radius(&s) - 0.9).abs() < 1e-9);
}

/// Every numeric key of the camera, light and material descriptions can be
/// driven by an expression and set live, and is checked by its description.
#[test]
fn every_numeric_key_is_driven_and_settable() {
    let text = r#"
[camera]
position = [0.0, 0.0, 5.0]
up = ["sin(t)", 1.0, 0.0]
[[light]]
kind = "rect"
position = [0.0, 3.0, 0.0]
u = [1.0, 0.0, 0.0]
v = [0.0, 0.0, 1.0]
[material.m]
checker = "default"
checker_size = "0.5 + t"
[[object]]
material = "m"
shape = "sphere(p, 1.0)"
"#;
    let mut s = isoray_scene::load_str(text, "t.toml", &[]).unwrap();
    assert_eq!(s.camera.up, [0.0, 1.0, 0.0]);
    assert_eq!(s.materials[1].checker.map(|c| c.1), Some(0.5));
    s.set_time(0.25).unwrap();
    assert_eq!(s.camera.up[0], 0.25f64.sin());
    assert_eq!(s.materials[1].checker.map(|c| c.1), Some(0.75));
    let numeric: Vec<&str> = isoray_scene::camera_keys()
        .iter()
        .filter(|k| k.is_numeric())
        .map(|k| k.name)
        .collect();
    assert_eq!(numeric, ["position", "target", "up", "fov"]);
    s.set_value("camera.position", &[0.0, 1.0, 6.0]).unwrap();
    s.set_value("camera.target", &[0.0, 0.5, 0.0]).unwrap();
    s.set_value("camera.up", &[0.1, 1.0, 0.0]).unwrap();
    s.set_value("camera.fov", &[30.0]).unwrap();
    assert_eq!(s.camera.fov, 30.0);
    // The target may not meet the position, nor `up` lie along the view.
    assert!(s.set_value("camera.target", &[0.0, 1.0, 6.0]).is_err());
    assert!(s.set_value("camera.up", &[0.0, 0.5, 6.0]).is_err());
    assert_eq!(s.camera.target, [0.0, 0.5, 0.0]);
    // A value outside its description's range is an error naming what was expected.
    let e = s.set_value("camera.fov", &[200.0]).unwrap_err();
    assert!(e.message.contains("between 0 and 180"), "{}", e.message);
    let e = s.set_value("light.0.intensity", &[-1.0]).unwrap_err();
    assert!(e.message.contains("≥ 0"), "{}", e.message);
    // Rect edges must stay across each other.
    assert!(s.set_value("light.0.v", &[2.0, 0.0, 0.0]).is_err());
    s.set_value("light.0.v", &[0.0, 1.0, 0.0]).unwrap();
    // Integers, booleans and choices are not set from numbers.
    assert!(s.set_value("light.0.samples", &[4.0]).is_err());
    assert!(s.set_value("material.m.model", &[1.0]).is_err());
    s.set_value("material.m.checker_size", &[2.0]).unwrap();
    assert_eq!(s.materials[1].checker.map(|c| c.1), Some(2.0));
    // Every value key reads back as the file would write it.
    s.set_value("material.m.diffuse", &[0.25, 0.5, 1.0]).unwrap();
    let m = &s.materials[1];
    assert_eq!(m.value_text("diffuse").as_deref(), Some("[0.25, 0.5, 1.0]"));
    assert_eq!(m.value_text("shininess").as_deref(), Some("32.0"));
    assert_eq!(m.value_text("model").as_deref(), Some("\"blinn-phong\""));
    assert_eq!(m.value_text("specular_fresnel").as_deref(), Some("false"));
    assert_eq!(m.value_text("checker"), None, "not a value key");
    for k in isoray_scene::material_value_keys() {
        assert!(m.value_text(k.name).is_some(), "{}", k.name);
    }
    assert_eq!(s.lights[0].value_text("samples").as_deref(), Some("16"));
}

/// A period of `repeat` that reads a parameter or the time must stay
/// positive when they change, as it must at load: an error, not NaN.
#[test]
fn live_periods_stay_positive() {
    let mut s =
        scene("[params]\ns = 2.0\n[[object]]\nshape = \"sphere(repeat(p, vec3(s, 1.0 + 0.5 * sin(t), 3.0)), 0.25)\"\n");
    let before = s.distance([0.3, 0.2, 0.1]);
    let e = s.set_param("s", Value::Float(0.0)).unwrap_err();
    assert!(
        e.message.contains("the period of `repeat` must be positive, found 0"),
        "{}",
        e.message
    );
    assert_eq!(e.key.as_deref(), Some("object.0.shape"));
    assert_eq!(s.distance([0.3, 0.2, 0.1]), before, "an error changes nothing");
    s.set_param("s", Value::Float(1.0)).unwrap();
    assert!(s.set_time(-std::f64::consts::FRAC_PI_2).is_ok(), "1 − 0.5 > 0");
    assert!(s.distance([0.3, 0.2, 0.1]).is_finite());
    // Bad at load: a load error.
    let e = isoray_scene::load_str(
        "[params]\ns = -1.0\n[[object]]\nshape = \"sphere(repeat(p, vec3(s)), 0.25)\"\n",
        "t.toml",
        &[],
    )
    .unwrap_err();
    assert!(e.message.contains("must be positive"), "{}", e.message);
}
