//! The surfaces table and dialog: rows read from the file, the dialog's
//! fields written back, and the scene loader's errors placed at the field
//! they are about.

use isoray_studio::surfaces::{candidate, rows, Check, Field, Mode, Outcome, SurfaceForm};

const SCENE: &str = r#"# surfaces
[surface.ring]
params = { R = 0.7, r = 0.2 }
sdf = "length(vec2(length(p.xz) - R, p.y)) - r"
material = "gold"

[surface.sphere_eq]
params = { r = 1.0 }
implicit = "x^2 + y^2 + z^2 - r"

[surface.sphere_rational]
parametric = { x = "2*s/(s^2+t^2+1)", y = "2*t/(s^2+t^2+1)", z = "(s^2+t^2-1)/(s^2+t^2+1)" }

[material.gold]
diffuse = [0.9, 0.7, 0.3]

[[object]]
shape = "ring(p)"
"#;

#[test]
fn the_table_lists_every_surface_with_its_type_parameters_and_input() {
    let r = rows(SCENE);
    let names: Vec<&str> = r.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(names, ["ring", "sphere_eq", "sphere_rational"]);
    assert_eq!(r[0].mode, Mode::Sdf);
    assert_eq!(r[0].params, ["R", "r"]);
    assert_eq!(r[1].mode, Mode::Implicit);
    assert_eq!(r[1].input, "x^2 + y^2 + z^2 - r");
    assert_eq!(r[2].mode, Mode::Parametric);
    assert!(r[2].input.starts_with("(2*s/(s^2+t^2+1), "));
}

#[test]
fn a_valid_edit_loads_and_keeps_the_keys_the_dialog_does_not_show() {
    let mut form = rows(SCENE)[0].form.clone();
    form.params = "{ R = 0.8, r = 0.25 }".into();
    let text = candidate(SCENE, &form).unwrap();
    assert!(text.starts_with("# surfaces\n"));
    assert!(text.contains("material = \"gold\""), "{text}");
    let check = Check::start(text, "scene.toml".into(), "ring".into(), || {});
    assert!(matches!(check.wait(), Outcome::Valid(_)));
}

#[test]
fn errors_are_shown_at_their_field() {
    // A body that does not parse: at the body.
    let mut form = rows(SCENE)[1].form.clone();
    form.body = "x^2 + y^2 +".into();
    let text = candidate(SCENE, &form).unwrap();
    match Check::start(text, "scene.toml".into(), "sphere_eq".into(), || {}).wait() {
        Outcome::Invalid(e) => assert_eq!(e.field, Field::Body, "{}", e.message),
        o => panic!("{o:?}"),
    }
    // An unused parameter: the loader says so; the error is not lost.
    let mut form = rows(SCENE)[1].form.clone();
    form.params = "{ r = 1.0, k = 2.0 }".into();
    let text = candidate(SCENE, &form).unwrap();
    match Check::start(text, "scene.toml".into(), "sphere_eq".into(), || {}).wait() {
        Outcome::Invalid(e) => assert!(e.message.contains('k'), "{}", e.message),
        o => panic!("{o:?}"),
    }
    // Parameters that are not a table, a bad name, a taken name: before loading.
    let mut form = rows(SCENE)[1].form.clone();
    form.params = "r = 1".into();
    assert_eq!(candidate(SCENE, &form).unwrap_err().field, Field::Params);
    form = SurfaceForm::new(&rows(SCENE));
    form.name = "2fast".into();
    assert_eq!(candidate(SCENE, &form).unwrap_err().field, Field::Name);
    form.name = "ring".into();
    let e = candidate(SCENE, &form).unwrap_err();
    assert_eq!((e.field, e.message.contains("already")), (Field::Name, true));
    // A parametric coordinate that does not parse: at that coordinate.
    let mut form = rows(SCENE)[2].form.clone();
    form.coords[1] = "2*t/(".into();
    let text = candidate(SCENE, &form).unwrap();
    match Check::start(text, "scene.toml".into(), "sphere_rational".into(), || {}).wait() {
        Outcome::Invalid(e) => assert_eq!(e.field, Field::Coord(1), "{}", e.message),
        o => panic!("{o:?}"),
    }
}

#[test]
fn a_parametric_surface_reports_its_implicit_equation() {
    let form = rows(SCENE)[2].form.clone();
    let text = candidate(SCENE, &form).unwrap();
    match Check::start(text, "scene.toml".into(), "sphere_rational".into(), || {}).wait() {
        Outcome::Valid(d) => {
            // The unit sphere: x^2 + y^2 + z^2 - 1 = 0, degree 2.
            assert!(d.contains("degree") && d.contains('2'), "{d}");
        }
        o => panic!("{o:?}"),
    }
}
