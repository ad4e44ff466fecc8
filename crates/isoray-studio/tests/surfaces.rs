//! The surfaces table and dialog: rows read from the file, the dialog's
//! fields written back, and the scene loader's errors placed at the field
//! they are about.

use isoray_studio::surfaces::{
    calls_of, candidate, rename_calls, rows, Check, Field, Mode, Outcome, ParamRow, SurfaceForm, PREVIEW,
};

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
    form.params[0].default = "0.8".into();
    form.params[1].default = "0.25".into();
    let text = candidate(SCENE, &form).unwrap();
    assert!(text.starts_with("# surfaces\n"));
    assert!(text.contains("material = \"gold\""), "{text}");
    let check = Check::start(text, "scene.toml".into(), "ring".into(), None, || {});
    assert!(matches!(check.wait(), Outcome::Valid(_)));
}

#[test]
fn errors_are_shown_at_their_field() {
    // A body that does not parse: at the body.
    let mut form = rows(SCENE)[1].form.clone();
    form.body = "x^2 + y^2 +".into();
    let text = candidate(SCENE, &form).unwrap();
    match Check::start(text, "scene.toml".into(), "sphere_eq".into(), None, || {}).wait() {
        Outcome::Invalid(e) => assert_eq!(e.field, Field::Body, "{}", e.message),
        o => panic!("{o:?}"),
    }
    // An unused parameter: the loader says so; the error is not lost.
    let mut form = rows(SCENE)[1].form.clone();
    form.params.push(ParamRow {
        name: "k".into(),
        default: "2.0".into(),
        ..ParamRow::default()
    });
    let text = candidate(SCENE, &form).unwrap();
    match Check::start(text, "scene.toml".into(), "sphere_eq".into(), None, || {}).wait() {
        Outcome::Invalid(e) => assert!(e.message.contains('k'), "{}", e.message),
        o => panic!("{o:?}"),
    }
    // Parameters that are not a table, a bad name, a taken name: before loading.
    let mut form = rows(SCENE)[1].form.clone();
    form.params[0].default = "r = 1".into();
    assert_eq!(candidate(SCENE, &form).unwrap_err().field, Field::Param(0));
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
    match Check::start(text, "scene.toml".into(), "sphere_rational".into(), None, || {}).wait() {
        Outcome::Invalid(e) => assert_eq!(e.field, Field::Coord(1), "{}", e.message),
        o => panic!("{o:?}"),
    }
}

#[test]
fn a_parametric_surface_reports_its_implicit_equation() {
    let form = rows(SCENE)[2].form.clone();
    let text = candidate(SCENE, &form).unwrap();
    match Check::start(text, "scene.toml".into(), "sphere_rational".into(), None, || {}).wait() {
        Outcome::Valid(d) => {
            // The unit sphere: x^2 + y^2 + z^2 - 1 = 0, degree 2.
            assert!(d.contains("degree") && d.contains('2'), "{d}");
        }
        o => panic!("{o:?}"),
    }
}

/// A scene with a multi-line body, ranges, comments and a call from
/// another surface: what the dialog must leave as it found it.
const RICH: &str = r#"# rich surfaces
[surface.ring]                    # a torus-like ring
params = { R = { default = 0.7, range = [0.2, 1.5] }, r = 0.2 }
sdf = '''
// distance to the ring's core circle
length(vec2(length(p.xz) - R, p.y)) - r
'''

[surface.two_rings]
sdf = "min(ring(p), ring(p - vec3(0.0, 0.5, 0.0), 0.5)) /* ring( */"

[surface.patch]
parametric = { x = "s", y = "t", z = "s*t" }
domain = { s = [-0.5, 0.5], t = [-1.0, 1.0] }
image_only = true
lipschitz_factor = 2.0

[[object]]
shape = "ring(p)" # the main one

[[object]]
shape = "two_rings(p)"
"#;

#[test]
fn an_unchanged_form_writes_the_file_back_byte_for_byte() {
    for r in rows(RICH) {
        assert_eq!(candidate(RICH, &r.form).unwrap(), RICH, "{}", r.name);
    }
    for r in rows(SCENE) {
        assert_eq!(candidate(SCENE, &r.form).unwrap(), SCENE, "{}", r.name);
    }
}

#[test]
fn the_parameters_grid_reads_and_writes_defaults_and_ranges_in_call_order() {
    let r = rows(RICH);
    let p = &r[0].form.params;
    let row = |name: &str, default: &str, min: &str, max: &str| ParamRow {
        name: name.into(),
        default: default.into(),
        min: min.into(),
        max: max.into(),
    };
    assert_eq!(p, &[row("R", "0.7", "0.2", "1.5"), row("r", "0.2", "", "")]);
    let patch = &r[2].form;
    assert_eq!(
        patch.domain,
        [
            ["-0.5".to_string(), "0.5".to_string()],
            ["-1.0".to_string(), "1.0".to_string()]
        ]
    );
    assert!(patch.image_only);
    assert_eq!(patch.lipschitz_factor, "2.0");

    // Swap the two parameters, give r a range and add a vector one.
    let mut form = r[0].form.clone();
    form.params.swap(0, 1);
    form.params[0].min = "0.05".into();
    form.params[0].max = "0.5".into();
    form.params.push(row("c", "0, 1, 0", "", ""));
    form.body = "length(vec2(length(p.xz - c.xz) - R, p.y)) - r".into();
    let text = candidate(RICH, &form).unwrap();
    let back = rows(&text);
    assert_eq!(
        back[0].form.params,
        [
            row("r", "0.2", "0.05", "0.5"),
            row("R", "0.7", "0.2", "1.5"),
            row("c", "[0, 1, 0]", "", "")
        ]
    );
    // The comment on the table's header stays, and the scene loads with
    // the new order (r first in a call).
    assert!(
        text.contains("[surface.ring]                    # a torus-like ring"),
        "{text}"
    );
    let scene = isoray_scene::load_str(&text, "rich.toml", &[]).unwrap();
    let ring = scene.library.surface("ring").unwrap();
    let names: Vec<&str> = ring.params.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["r", "R", "c"]);
}

#[test]
fn a_parameter_error_is_shown_at_its_row() {
    let base = rows(RICH)[0].form.clone();
    let at = |form: &SurfaceForm| -> (Field, String) {
        match candidate(RICH, form) {
            Err(e) => (e.field, e.message),
            Ok(text) => match Check::start(text, "rich.toml".into(), form.name.clone(), None, || {}).wait() {
                Outcome::Invalid(e) => (e.field, e.message),
                o => panic!("{o:?}"),
            },
        }
    };
    let mut f = base.clone();
    f.params[1].name = "1r".into();
    assert_eq!(at(&f).0, Field::Param(1));
    let mut f = base.clone();
    f.params[1].name = "R".into();
    assert_eq!(at(&f).0, Field::Param(1));
    let mut f = base.clone();
    f.params[0].default = "big".into();
    assert_eq!(at(&f).0, Field::Param(0));
    let mut f = base.clone();
    f.params[1].min = "0.1".into();
    let (field, message) = at(&f);
    assert_eq!(field, Field::Param(1));
    assert!(message.contains("both ends"), "{message}");
    // From the loader: a default outside its range, a range on a vector.
    let mut f = base.clone();
    f.params[0].default = "3.0".into();
    let (field, message) = at(&f);
    assert_eq!(field, Field::Param(0), "{message}");
    assert!(message.contains("outside"), "{message}");
    let mut f = base.clone();
    f.params[1].default = "0.1, 0.2".into();
    f.params[1].min = "0.0".into();
    f.params[1].max = "1.0".into();
    assert_eq!(at(&f).0, Field::Param(1));
    // A parameter the body never uses, and the domain and factor fields.
    let mut f = rows(SCENE)[1].form.clone();
    f.params.push(ParamRow {
        name: "k".into(),
        default: "2.0".into(),
        ..ParamRow::default()
    });
    let text = candidate(SCENE, &f).unwrap();
    match Check::start(text, "scene.toml".into(), "sphere_eq".into(), None, || {}).wait() {
        Outcome::Invalid(e) => assert_eq!(e.field, Field::Param(1), "{}", e.message),
        o => panic!("{o:?}"),
    }
    let mut f = rows(RICH)[2].form.clone();
    f.domain[1][0] = "zero".into();
    assert_eq!(at(&f).0, Field::Domain(1));
    let mut f = rows(RICH)[2].form.clone();
    f.lipschitz_factor = "0.5".into();
    assert_eq!(at(&f).0, Field::LipschitzFactor);
}

#[test]
fn renaming_a_surface_renames_its_calls_and_nothing_else() {
    let mut form = rows(RICH)[0].form.clone();
    form.name = "hoop".into();
    assert_eq!(calls_of(RICH, "ring"), 3);
    let text = candidate(RICH, &form).unwrap();
    assert!(
        text.contains("[surface.hoop]                    # a torus-like ring"),
        "{text}"
    );
    assert!(text.contains("shape = \"hoop(p)\" # the main one"), "{text}");
    assert!(
        text.contains("sdf = \"min(hoop(p), hoop(p - vec3(0.0, 0.5, 0.0), 0.5)) /* ring( */\""),
        "{text}"
    );
    assert!(!text.contains("[surface.ring]"));
    let scene = isoray_scene::load_str(&text, "rich.toml", &[]).unwrap();
    assert!(scene.library.surface("hoop").is_some());
    // The body's own comment mentions no call and stays.
    assert!(text.contains("// distance to the ring's core circle"));
    // A name the loader refuses is shown at the name.
    form.name = "torus".into();
    let text = candidate(RICH, &form).unwrap();
    match Check::start(text, "rich.toml".into(), "torus".into(), None, || {}).wait() {
        Outcome::Invalid(e) => assert_eq!(e.field, Field::Name, "{}", e.message),
        o => panic!("{o:?}"),
    }
    assert_eq!(
        rename_calls("ring (p) + ringo(p) + ring", "ring", "r2").0,
        "r2 (p) + ringo(p) + ring"
    );
}

/// Pixels of two RGBA previews that differ by more than a little.
fn differing(a: &[u8], b: &[u8]) -> usize {
    a.chunks(4)
        .zip(b.chunks(4))
        .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > 24))
        .count()
}

#[test]
fn the_preview_shows_the_surface_alone() {
    // The rational sphere and the exact unit sphere look the same; the
    // ring, which the scene's only object shows, does not appear.
    let pixels = (PREVIEW[0] * PREVIEW[1]) as usize;
    let preview = |form: &SurfaceForm| {
        let text = candidate(SCENE, form).unwrap();
        let check = Check::start(text, "scene.toml".into(), form.name.clone(), None, || {});
        let p = check.wait_preview().expect("a preview");
        assert_eq!(p.len(), pixels * 4);
        p
    };
    let rational = preview(&rows(SCENE)[2].form);
    let mut unit = SurfaceForm::new(&rows(SCENE));
    unit.body = "length(p) - 1.0".into();
    unit.params.clear();
    let exact = preview(&unit);
    let empty = {
        let mut f = unit.clone();
        f.body = "length(p - vec3(100.0, 0.0, 0.0)) - 1.0".into();
        preview(&f)
    };
    let sphere = differing(&exact, &empty);
    assert!(sphere > pixels / 20, "the sphere covers {sphere} of {pixels} pixels");
    let diff = differing(&rational, &exact);
    assert!(diff < pixels / 100, "{diff} pixels differ");
    // A surface that does not load has no preview.
    let mut bad = unit.clone();
    bad.body = "length(p) -".into();
    let text = candidate(SCENE, &bad).unwrap();
    let check = Check::start(text, "scene.toml".into(), bad.name.clone(), None, || {});
    assert!(check.wait_preview().is_none());
}

#[test]
fn a_slow_implicitization_can_be_cancelled() {
    // A generic polynomial patch of bidegree (4, 4): implicit degree 32,
    // beyond interpolation's degrees; the resultant takes minutes.
    let coord = |seed: u64| {
        let mut r = seed;
        let mut terms = Vec::new();
        for i in 0..5 {
            for j in 0..5 {
                r ^= r << 13;
                r ^= r >> 7;
                r ^= r << 17;
                terms.push(format!("{}*s^{i}*t^{j}", [-2, -1, 1, 2][(r % 4) as usize]));
            }
        }
        terms.join(" + ")
    };
    let slow = format!(
        r#"[surface.slow]
parametric = {{ x = "{}", y = "{}", z = "{}" }}
domain = {{ s = [-0.5, 0.5], t = [-0.5, 0.5] }}

[[object]]
shape = "slow(p)"
"#,
        coord(1),
        coord(2),
        coord(3)
    );
    let check = Check::start(slow, "scene.toml".into(), "slow".into(), None, || {});
    std::thread::sleep(std::time::Duration::from_millis(300));
    assert!(check.status().outcome.is_none(), "still running after 0.3 s");
    let asked = std::time::Instant::now();
    check.cancel();
    assert!(matches!(check.wait(), Outcome::Cancelled));
    let took = asked.elapsed();
    assert!(took.as_secs_f64() < 2.0, "cancelled in {took:?}");
}
