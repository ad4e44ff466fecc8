//! Malformed scenes give located errors, never panics; overrides work.

use isoray_scene::{load, load_str, ShadowMode};

fn err(text: &str) -> isoray_scene::SceneError {
    load_str(text, "bad.toml", &[]).expect_err("should fail")
}

const OK: &str = "[[object]]\nshape = \"sphere(p, 1.0)\"\n";

#[test]
fn toml_syntax_error_is_located() {
    let e = err("[render]\nwidth = = 3\n");
    assert_eq!(e.line, Some(2), "{e}");
    assert!(e.rendered.contains("bad.toml:2:"), "{e}");
}

#[test]
fn wrong_type_names_key_line_and_expectation() {
    let e = err(&format!("[render]\nwidth = \"wide\"\n{OK}"));
    assert_eq!((e.line, e.column), (Some(2), Some(9)), "{e}");
    assert!(
        e.message.contains("render.width") && e.message.contains("integer"),
        "{e}"
    );
    let e = err(&format!("[camera]\nposition = [1.0, 2.0]\n{OK}"));
    assert!(e.message.contains("array of 3 numbers"), "{e}");
    let e = err(&format!("[render]\nshadows = \"sofft\"\n{OK}"));
    assert!(e.rendered.contains("did you mean \"soft\"?"), "{e}");
}

#[test]
fn unknown_keys_are_rejected_with_suggestions() {
    let e = err(&format!("[render]\nwidht = 3\n{OK}"));
    assert_eq!(e.line, Some(2));
    assert!(e.rendered.contains("did you mean `width`?"), "{e}");
    let e = err(&format!("[rendr]\nwidth = 3\n{OK}"));
    assert!(e.rendered.contains("did you mean `render`?"), "{e}");
}

#[test]
fn shape_errors_point_into_the_toml_string() {
    let text = "[[object]]\nshape = \"sphere(p + vec2(1.0, 2.0), 1.0)\"\n";
    let e = err(text);
    assert_eq!(e.line, Some(2));
    // The caret starts at `p + vec2(...)`, column 17 of line 2.
    assert_eq!(e.column, Some(17), "{e}");
    assert!(e.message.contains("cannot add `vec3` and `vec2`"), "{e}");
    assert!(e.rendered.contains(&format!("{} vec3 + vec2", "^".repeat(18))), "{e}");

    let e = err("[[object]]\nshape = \"sphre(p, 1.0)\"\n");
    assert!(
        e.message.contains("unknown function `sphre`") && e.rendered.contains("did you mean `sphere`?"),
        "{e}"
    );
    let e = err("[[object]]\nshape = \"sphere(p, 1.0, 2.0)\"\n");
    assert!(e.message.contains("takes 2 argument(s), found 3"), "{e}");
    let e = err("[[object]]\nshape = '''\nlet r = 1.0;\nsphere(p, q)'''\n");
    assert_eq!((e.line, e.column), (Some(4), Some(11)), "{e}");
}

#[test]
fn surface_errors_and_user_primitives() {
    let text = "[surface.ring]\nparams = { R = 1.0, r = 0.25 }\nsdf = \"length(vec2(length(p.xz) - R, p.y)) - r\"\n[[object]]\nshape = \"ring(p, 2.0)\"\n";
    let s = load_str(text, "ok.toml", &[]).unwrap();
    // R = 2 given, r = 0.25 by default.
    assert!((s.distance([2.25, 0.0, 0.0])).abs() < 1e-12);
    let e = err("[surface.ring]\nsdf = \"length(p.xw)\"\n[[object]]\nshape = \"ring(p)\"\n");
    assert_eq!(e.line, Some(2));
    assert!(e.message.contains("`.w`") || e.message.contains("component"), "{e}");
    let e = err("[surface.a]\nsdf = \"b(p)\"\n[surface.b]\nsdf = \"a(p)\"\n[[object]]\nshape = \"a(p)\"\n");
    assert!(e.message.contains("calls itself"), "{e}");
}

#[test]
fn semantic_errors() {
    let e = err("[[object]]\nmaterial = \"gld\"\nshape = \"sphere(p, 1.0)\"\n[material.gold]\n");
    assert!(
        e.message.contains("no material named \"gld\"") && e.rendered.contains("did you mean \"gold\"?"),
        "{e}"
    );
    let e =
        err("[camera]\nposition = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n[[object]]\nshape = \"sphere(p, 1.0)\"\n");
    assert!(e.message.contains("no direction"), "{e}");
    // A scene without objects is empty space, not an error.
    let empty = isoray_scene::load_str("[render]\nwidth = 10\n", "empty.toml", &[]).unwrap();
    assert!(empty.objects.is_empty() && empty.distance([0.0; 3]) >= 1e9);
    // A period of repeat that is not positive is a load-time error at its text.
    let e = err("[[object]]\nshape = \"sphere(repeat(p, vec3(2.0, 0.0, 2.0)), 0.5)\"\n");
    assert!(
        e.message.contains("the period of `repeat` must be positive, found 0"),
        "{e}"
    );
    assert_eq!((e.line, e.column), (Some(2), Some(27)));
    let e = err("[params]\nk = -1.0\n[[object]]\nshape = \"sphere(repeat_limited(p, k, vec3(2.0)), 0.5)\"\n");
    assert!(e.message.contains("found -1 with the parameters as they are"), "{e}");
    let e = err("[[light]]\nkind = \"point\"\n[[object]]\nshape = \"sphere(p, 1.0)\"\n");
    assert!(e.message.contains("needs a `position`"), "{e}");
    let e = err("[[light]]\nkind = \"point\"\nposition = [0.0, 1.0, 0.0]\ndirection = [0.0, 1.0, 0.0]\n[[object]]\nshape = \"sphere(p, 1.0)\"\n");
    assert!(
        e.message.contains("`light.0.direction` does not apply here")
            && e.rendered.contains("point lights have a `position`"),
        "{e}"
    );
    assert_eq!(e.line, Some(4));
}

#[test]
fn overrides() {
    let text = "[render]\nshadows = \"soft\"\n[[light]]\nintensity = 1.0\n[[object]]\nshape = \"sphere(p, 1.0)\"\n";
    let s = load_str(
        text,
        "s.toml",
        &[
            "render.shadows=hard".into(),
            "light.0.intensity=2".into(),
            "render.aa=3".into(),
        ],
    )
    .unwrap();
    assert_eq!(s.render.shadows, ShadowMode::Hard);
    assert_eq!(s.lights[0].intensity, 2.0);
    assert_eq!(s.render.aa, 3);
    let s = load_str(
        text,
        "s.toml",
        &["object.0.shape=sphere(p, 2.0)".into(), "params.k=0.5".into()],
    )
    .unwrap();
    assert!((s.distance([3.0, 0.0, 0.0]) - 1.0).abs() < 1e-12);
    for (ov, want) in [
        ("light.5.intensity=2", "out of range"),
        ("material.0.diffuse=[1, 1, 1]", "no `material` array"),
        ("render.width=abc", "render.width"),
        ("render", "KEY=VALUE"),
        ("object.0.shape=sphere(p)", "takes 2 argument"),
    ] {
        let e = load_str(text, "s.toml", &[ov.into()]).expect_err(ov);
        assert!(e.message.contains(want), "{ov}: {e}");
        assert_eq!(e.file, "--set", "{ov}: {e}");
    }
}

#[test]
fn missing_file_is_an_io_error() {
    let e = load(std::path::Path::new("/nonexistent/scene.toml"), &[]).unwrap_err();
    assert!(e.io && e.message.contains("cannot read"), "{e}");
}

#[test]
fn examples_load() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut n = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            load(&path, &[]).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            n += 1;
        }
    }
    assert!(n >= 1);
}

#[test]
fn garbage_never_panics() {
    // (The empty scene is valid: empty space.)
    let samples = [
        "[",
        "]]",
        "a = ",
        "[[object]]",
        "[[object]]\nshape = 3",
        "[[object]]\nshape = \"\"",
        "[[object]]\nshape = \"((((\"",
        "[camera]\nfov = -1\n",
        "[render]\naa = 0\n",
        "[render]\nbackground = [1, -1, 0]\n",
        "[light]\nkind = 3\n",
        "object = 5",
        "[material]\nx = 1\n",
        "[params]\np = 1\n",
        "[surface.x]\nparams = 3\n",
        "[[object]]\nshape = \"sphere(p, 1.0)\"\n[params]\nk = [1]\n",
    ];
    for s in samples {
        assert!(load_str(s, "g.toml", &[]).is_err(), "{s:?} should be rejected");
    }
}

#[test]
fn implicit_surfaces() {
    let text = "[surface.sphere_eq]\nparams = { r = 1.0 }\nimplicit = \"x^2 + y^2 + z^2 - r\"\nbound = \"first-order\"\n[[object]]\nshape = \"sphere_eq(p - vec3(1.0, 0.0, 0.0), 4.0)\"\n";
    let s = load_str(text, "imp.toml", &[]).unwrap();
    // f / |grad f| for the sphere of radius 2 centred at (1, 0, 0): at distance 1 outside,
    // f = 9 - 4 = 5 and |grad f| = 6.
    assert!((s.distance([4.0, 0.0, 0.0]) - 5.0 / 6.0).abs() < 1e-12);
    assert!(s.distance([3.0, 0.0, 0.0]).abs() < 1e-12);
    assert!(s.distance([1.0, 0.0, 0.0]) < 0.0);
    // Near the surface the estimate is the distance to first order.
    assert!((s.distance([3.001, 0.0, 0.0]) - 0.001).abs() < 1e-6);
    // The centre, where the gradient vanishes, is guarded (no NaN).
    assert!(s.distance([1.0, 0.0, 0.0]).is_finite());
    // The default bound for a polynomial is the Taylor-root bound: at (4, 0, 0),
    // the smallest root of 6δ + √3·δ² = 5, below the true distance 1.
    let s = load_str(&text.replace("bound = \"first-order\"\n", ""), "imp.toml", &[]).unwrap();
    let want = (-6.0 + (36.0f64 + 20.0 * 3f64.sqrt()).sqrt()) / (2.0 * 3f64.sqrt());
    assert!(
        (s.distance([4.0, 0.0, 0.0]) - want).abs() < 1e-9,
        "{}",
        s.distance([4.0, 0.0, 0.0])
    );
    assert!((s.distance([3.001, 0.0, 0.0]) - 0.001).abs() < 1e-6);
    assert!(s.distance([1.0, 0.0, 0.0]) < 0.0 && s.distance([1.0, 0.0, 0.0]) >= -2.0);
    let e = err("[surface.flat]\nparams = { r = 1.0 }\nimplicit = \"r - 1.0\"\n[[object]]\nshape = \"flat(p)\"\n");
    assert!(
        e.message.contains("gradient") && e.message.contains("identically zero"),
        "{e}"
    );
    assert_eq!(e.line, Some(3));
    let e = err("[surface.s]\nsdf = \"length(p) - 1.0\"\nimplicit = \"x - 1.0\"\n[[object]]\nshape = \"s(p)\"\n");
    assert!(e.message.contains("exactly one mode"), "{e}");
    let e = err("[surface.s]\nparams = { r = 1.0, q = 2.0 }\nimplicit = \"x^2 + y^2 + z^2 - r\"\n[[object]]\nshape = \"s(p)\"\n");
    assert!(e.message.contains("parameter `q` of surface `s` is never used"), "{e}");
    assert_eq!((e.line, e.column), (Some(2), Some(21)), "{e}");
    let e = err("[surface.s]\nimplicit = \"x^2 + w^2 - 1.0\"\n[[object]]\nshape = \"s(p)\"\n");
    assert!(e.message.contains("unknown name `w`"), "{e}");
}

#[test]
fn cube_environment_maps_load_and_look_up_their_faces() {
    let dir = std::env::temp_dir().join(format!("isoray-cube-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let colours = [
        [255u8, 0, 0],
        [0, 255, 0],
        [0, 0, 255],
        [255, 255, 0],
        [0, 255, 255],
        [255, 0, 255],
    ];
    let names = ["px", "nx", "py", "ny", "pz", "nz"];
    for (name, c) in names.iter().zip(colours) {
        let img = image::RgbImage::from_pixel(4, 4, image::Rgb(c));
        img.save(dir.join(format!("{name}.png"))).unwrap();
    }
    image::RgbImage::from_pixel(4, 2, image::Rgb([0, 0, 0]))
        .save(dir.join("wide.png"))
        .unwrap();
    let faces: Vec<String> = names.iter().map(|n| format!("{n} = \"{n}.png\"")).collect();
    let text = format!(
        "[environment]\ncube = {{ {} }}\nintensity = 2.0\n[[object]]\nshape = \"sphere(p, 1.0)\"\n",
        faces.join(", ")
    );
    let path = dir.join("cube.toml");
    std::fs::write(&path, &text).unwrap();
    let s = isoray_scene::load(&path, &[]).unwrap();
    let env = s.environment.as_ref().unwrap();
    let dirs = [
        [1.0f32, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    for (d, c) in dirs.iter().zip(colours) {
        let want = c.map(|x| if x == 255 { 2.0f32 } else { 0.0 });
        assert_eq!(env.radiance(*d), want, "{d:?}");
    }
    // Faces must be square and of one size.
    std::fs::write(&path, text.replace("nz = \"nz.png\"", "nz = \"wide.png\"")).unwrap();
    let e = isoray_scene::load(&path, &[]).unwrap_err();
    assert!(
        e.message.contains("environment.cube.nz") && e.message.contains("square"),
        "{e}"
    );
    std::fs::write(&path, text.replace("py = \"py.png\", ", "")).unwrap();
    let e = isoray_scene::load(&path, &[]).unwrap_err();
    assert!(e.message.contains("needs `py`"), "{e}");
}

#[test]
fn errors_are_structured_for_editors() {
    let text = "[render]\naa = 0\n[[object]]\nshape = \"sphere(p, 1.0)\"\n";
    let e = load_str(text, "s.toml", &[]).unwrap_err();
    assert_eq!(e.key.as_deref(), Some("render.aa"));
    let span = e.span.expect("a span in the file");
    assert_eq!(&text[span.start..span.end], "0");
    assert_eq!(e.label.as_deref(), Some("expected an integer from 1 to 16"));
    let e = load_str("[render]\nwidht = 3\n", "s.toml", &[]).unwrap_err();
    assert_eq!(e.key.as_deref(), Some("render.widht"));
    assert!(e.notes.iter().any(|n| n == "did you mean `width`?"), "{:?}", e.notes);
    let e = load_str(
        "[[light]]\nkind = \"sun\"\n",
        "s.toml",
        &["light.0.kind=\"spot\"".into()],
    )
    .unwrap_err();
    assert_eq!(e.key.as_deref(), Some("light.0.kind"));
    assert_eq!(e.file, "--set");
}

#[test]
fn shape_text_errors_name_their_key() {
    let key = |text: &str, overrides: &[&str]| {
        let ov: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        load_str(text, "k.toml", &ov).unwrap_err().key
    };
    let two = "[[object]]\nshape = \"sphere(p, 1.0)\"\n[[object]]\nshape = \"sphere(p, q)\"\n";
    assert_eq!(key(two, &[]).as_deref(), Some("object.1.shape"));
    let placed = "[[object]]\nshape = \"sphere(p, 1.0)\"\nposition = [0.0, \"w\", 0.0]\n";
    assert_eq!(key(placed, &[]).as_deref(), Some("object.0.position.1"));
    let surf = "[surface.s]\nsdf = \"length(p) - r\"\n[[object]]\nshape = \"s(p)\"\n";
    assert_eq!(key(surf, &[]).as_deref(), Some("surface.s.sdf"));
    let ok = "[[object]]\nshape = \"sphere(p, 1.0)\"\n";
    assert_eq!(key(ok, &["object.0.shape=box(p)"]).as_deref(), Some("object.0.shape"));
}
