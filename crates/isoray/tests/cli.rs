//! End-to-end tests of the `isoray` binary: outputs, exit codes, messages.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn isoray() -> Command {
    Command::new(env!("CARGO_BIN_EXE_isoray"))
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isoray-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn run(cmd: &mut Command) -> Output {
    cmd.output().expect("isoray runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn write_scene(name: &str, text: &str) -> PathBuf {
    let p = tmp(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs `isoray eval SCENE` with `input` on stdin.
fn eval_stdin(scene: &Path, input: &[u8]) -> Output {
    eval_with(scene, &[], input)
}

const SPHERE: &str = "[camera]\nposition = [0.0, 0.0, 4.0]\n[render]\nwidth = 40\nheight = 30\n[[light]]\n[[object]]\nshape = \"sphere(p, 1.0)\"\n";

#[test]
fn renders_every_example() {
    for entry in std::fs::read_dir(examples()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let out = tmp(&format!("{}.png", path.file_stem().unwrap().to_string_lossy()));
        let o = run(isoray()
            .arg("render")
            .arg(&path)
            .arg("-o")
            .arg(&out)
            .args(["--width", "64", "--height", "36", "--aa", "1"]));
        assert!(o.status.success(), "{}: {}", path.display(), stderr(&o));
        let img = image::open(&out).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (64, 36));
        // The summary line reports resolution and speed.
        let e = stderr(&o);
        assert!(e.contains("rendered 64x36") && e.contains("rays/s"), "{e}");
    }
}

#[test]
fn depth_and_normal_aovs_are_exr() {
    let scene = write_scene("aov.toml", SPHERE);
    let (png, depth, normals) = (tmp("aov.png"), tmp("aov-depth.exr"), tmp("aov-normals.exr"));
    let o = run(isoray()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&png)
        .arg("--depth")
        .arg(&depth)
        .arg("--normals")
        .arg(&normals)
        .arg("--quiet"));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stderr.is_empty(), "--quiet prints nothing: {}", stderr(&o));
    let read = |p: &Path| exr::prelude::read_all_flat_layers_from_file(p).unwrap();
    let d = read(&depth);
    let layer = &d.layer_data[0];
    let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    assert_eq!(names, vec!["Z"]);
    let z = |x: usize, y: usize| {
        layer.channel_data.list[0]
            .sample_data
            .value_by_flat_index(y * 40 + x)
            .to_f32()
    };
    // Pixels (19,14)..(20,15) surround the centre; the sphere front is at t ≈ 3.
    assert!((z(20, 15) - 3.0).abs() < 0.01, "{}", z(20, 15));
    assert_eq!(z(0, 0), f32::INFINITY);
    let n = read(&normals);
    let names: Vec<String> = n.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert_eq!(names, vec!["B", "G", "R"]);
    let b = n.layer_data[0].channel_data.list[0]
        .sample_data
        .value_by_flat_index(15 * 40 + 20)
        .to_f32();
    assert!(b > 0.99, "normal facing the camera has z ≈ 1, got {b}");
}

#[test]
fn eval_prints_distances() {
    let scene = write_scene("eval.toml", SPHERE);
    let o = eval_stdin(&scene, b"2 0 0\n0 0 0\n\n# comment\n0.6 0.0 0.8\n1e-3 0 0\n");
    assert!(o.status.success(), "{}", stderr(&o));
    let vals: Vec<f64> = String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .map(|l| l.parse().unwrap())
        .collect();
    assert_eq!(vals.len(), 4);
    assert_eq!(vals[0], 1.0);
    assert_eq!(vals[1], -1.0);
    assert!(vals[2].abs() < 1e-15);
    assert_eq!(vals[3], 1e-3 - 1.0, "full precision");

    let o = eval_stdin(&scene, b"1 2 3\n1 2\n");
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("stdin:2: expected three numbers"), "{}", stderr(&o));
}

#[test]
fn eval_uses_smooth_union_when_blending() {
    let text = "[render]\nblend = 0.5\n[[object]]\nshape = \"sphere(p, 1.0)\"\n[[object]]\nshape = \"sphere(p - vec3(1.5, 0.0, 0.0), 1.0)\"\n";
    let scene = write_scene("blend.toml", text);
    let o = eval_stdin(&scene, b"0.75 0 0\n");
    let v: f64 = String::from_utf8(o.stdout).unwrap().trim().parse().unwrap();
    // Both distances are -0.25: min - k/4 = -0.25 - 0.125.
    assert!((v - -0.375).abs() < 1e-12, "{v}");
}

#[test]
fn check_reports_ok_or_located_errors() {
    let good = write_scene("good.toml", SPHERE);
    let o = run(isoray().arg("check").arg(&good));
    assert!(o.status.success());
    assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), "ok");

    let bad = write_scene("bad.toml", "[[object]]\nshape = \"sphere(p, vec2(1.0, 2.0))\"\n");
    let o = run(isoray().arg("check").arg(&bad));
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.starts_with("error: argument `r` of `sphere` must be a `float`"),
        "{e}"
    );
    assert!(e.contains("bad.toml:2:20"), "{e}");
    assert!(e.contains("^^^^^^^^^^^^^^"), "{e}");
}

#[test]
fn exit_codes() {
    let good = write_scene("codes.toml", SPHERE);
    // Usage errors: 2.
    assert_eq!(run(isoray().arg("render")).status.code(), Some(2));
    assert_eq!(
        run(isoray().arg("render").arg(&good).args(["-o", "x.jpg"]))
            .status
            .code(),
        Some(2)
    );
    let o = run(isoray()
        .arg("render")
        .arg(&good)
        .arg("-o")
        .arg(tmp("c.png"))
        .args(["--set", "render.aa=0"]));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("render.aa"), "{}", stderr(&o));
    // I/O failures: 1.
    let o = run(isoray().arg("render").arg(&good).args(["-o", "/nonexistent-dir/x.png"]));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).starts_with("error: cannot write `/nonexistent-dir/x.png`"),
        "{}",
        stderr(&o)
    );
    let o = run(isoray().args(["check", "/nonexistent/scene.toml"]));
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("cannot read"));
}

#[test]
fn thread_count_does_not_change_the_png() {
    let scene = examples().join("showcase.toml");
    let render = |threads: &str, name: &str| {
        let out = tmp(name);
        let o = run(isoray().arg("render").arg(&scene).arg("-o").arg(&out).args([
            "--width",
            "80",
            "--height",
            "45",
            "--threads",
            threads,
            "--quiet",
        ]));
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(out).unwrap()
    };
    assert_eq!(render("1", "t1.png"), render("2", "t2.png"));
}

#[test]
fn groebner_command() {
    let o = run(isoray().args([
        "groebner",
        "--vars",
        "s,t,x,y,z",
        "--order",
        "lex",
        "x - s - t",
        "y - s",
        "z - t",
        "--stats",
    ]));
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(String::from_utf8_lossy(&o.stdout), "x - y - z\nt - z\ns - y\n");
    assert!(stderr(&o).contains("reductions to zero"), "{}", stderr(&o));
    // The thesis's Example 1.3 counts: six pairs reduced without the
    // criteria (five to zero), one with them; the same basis.
    for (flags, counts) in [
        (&["--no-criteria"][..], "pairs reduced: 6\nreductions to zero: 5\n"),
        (&[][..], "pairs reduced: 1\nreductions to zero: 0\n"),
    ] {
        let o = run(isoray()
            .args([
                "groebner",
                "--vars",
                "s,t,x,y,z",
                "--order",
                "lex",
                "--algorithm",
                "buchberger",
                "--stats",
            ])
            .args(flags)
            .args(["--", "x - s - t", "y - s", "z - t"]));
        assert_eq!(
            String::from_utf8_lossy(&o.stdout),
            "x - y - z\nt - z\ns - y\n",
            "{}",
            stderr(&o)
        );
        assert!(stderr(&o).contains(counts), "{flags:?}: {}", stderr(&o));
    }
    // GF(7): 1/2 = 4 mod 7.
    let o = run(isoray().args(["groebner", "--vars", "x,y", "--field", "7", "2*x - 1", "y^2 - x"]));
    assert_eq!(String::from_utf8_lossy(&o.stdout), "x + 3\ny^2 + 3\n", "{}", stderr(&o));
    // Input from a file with a located error.
    let f = write_scene("polys.txt", "x^2 - y\n# comment\nx*y - 1 +\n");
    let o = run(isoray().args(["groebner", "--vars", "x,y", "--input"]).arg(&f));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("polys.txt:3:"), "{}", stderr(&o));
    for bad in [
        &["--vars", "x,y", "--order", "nope", "x"][..],
        &["--vars", "x", "--field", "8", "x"],
        &["--vars", "x", "y"],
    ] {
        let o = run(isoray().arg("groebner").args(bad));
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {}", stderr(&o));
        assert!(stderr(&o).starts_with("error:"), "{}", stderr(&o));
    }
}

#[test]
fn implicitize_command() {
    let o = run(isoray().args(["implicitize", "--x", "(t-s^2)/(st)", "--y", "s^2/3", "--z", "s"]));
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), "z^2 - 3*y");
    let o = run(isoray().args(["implicitize", "--x", "t^2", "--y", "t^3"]));
    assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), "x^3 - y^2");
    let o = run(isoray().args(["implicitize", "--x", "s/(t-t)", "--y", "s", "--z", "t"]));
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--x:") && stderr(&o).contains("division by zero"),
        "{}",
        stderr(&o)
    );
    let o = run(isoray().args(["implicitize", "--x", "s+x", "--y", "s", "--z", "t"]));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("uses the variable `x`"), "{}", stderr(&o));
    // By resultant: the issue-18 surface (distinct denominators) equals
    // the elimination answer; base points are reported, exit 1.
    let args = ["--x", "(s+t^2)/(t+1)", "--y", "(s^2-t)/(s+2)", "--z", "(s*t)/(s-t+1)"];
    same_as_groebner(&args, "resultant");
    let o = run(isoray().args([
        "implicitize",
        "--method",
        "resultant",
        "--x",
        "s/(s^2+t^2)",
        "--y",
        "t/(s^2+t^2)",
        "--z",
        "s*t/(s^2+t^2)",
    ]));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("base points") && stderr(&o).contains("(0, 0)"),
        "{}",
        stderr(&o)
    );
}

/// `isoray implicitize ARGS --method METHOD` succeeds with the output of
/// `--method groebner`.
fn same_as_groebner(args: &[&str], method: &str) {
    let a = run(isoray().arg("implicitize").args(args).args(["--method", method]));
    let b = run(isoray().arg("implicitize").args(args).args(["--method", "groebner"]));
    assert!(
        a.status.success() && b.status.success(),
        "{} {}",
        stderr(&a),
        stderr(&b)
    );
    assert_eq!(a.stdout, b.stdout, "{method}");
}

#[test]
fn implicitize_by_interpolation_agrees_with_elimination() {
    let args = [
        "--x",
        "s^2*t + s - t",
        "--y",
        "s*t^2 - t + 1",
        "--z",
        "s^2*t^2 + s*t + s",
    ];
    same_as_groebner(&args, "interpolation");
    let o = run(isoray().args(["implicitize", "--method", "fourier", "--x", "s", "--y", "t", "--z", "s"]));
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn implicitize_auto_reports_its_choice() {
    // The issue-18 surface: degree 6 measured, the cheapest estimate wins.
    let args = ["--x", "(s+t^2)/(t+1)", "--y", "(s^2-t)/(s+2)", "--z", "(s*t)/(s-t+1)"];
    same_as_groebner(&args, "auto");
    let o = run(isoray().arg("implicitize").args(args).arg("--stats"));
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    let line = e
        .lines()
        .find(|l| l.starts_with("method: "))
        .unwrap_or_else(|| panic!("{e}"));
    assert!(line.contains("implicit degree 6"), "{line}");
    assert!(
        ["groebner", "interpolation", "resultant"]
            .iter()
            .all(|m| line.contains(&format!("{m} "))),
        "{line}"
    );
}

#[test]
fn surface_command_prints_the_derived_equation() {
    let scene = examples().join("surfaces.toml");
    let o = run(isoray().arg("surface").arg(&scene).arg("sphere_rational"));
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("equation:  x^2 + y^2 + z^2 - 1 = 0"), "{out}");
    assert!(out.contains("degree:    2"), "{out}");
    assert!(out.contains("Taylor-root bound"), "{out}");
    assert!(out.contains("satisfy the equation"), "{out}");
    assert!(out.contains("time:      implicitization:"), "{out}");
    let o = run(isoray().arg("surface").arg(&scene).arg("sphere_rationl"));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("did you mean `sphere_rational`?"), "{}", stderr(&o));
    let o = run(isoray().arg("surface").arg(&scene).arg("cube"));
    assert!(String::from_utf8_lossy(&o.stdout).contains("(sdf)"));
}

const WAVE: &str = "[camera]\nposition = [0.0, 3.0, 9.0]\n[render]\nwidth = 80\nheight = 45\n[[light]]\n\
    [surface.wave]\nimplicit = \"y - 0.5*sin(3*x)*sin(3*z) + 1.5\"\nbound = \"first-order\"\n\
    [[object]]\nname = \"wave\"\nshape = \"wave(p)\"\n";

#[test]
fn bound_violations_are_reported_with_a_factor() {
    // f/|grad f| of a steep wave oversteps: check and render both say so.
    let scene = write_scene("wave.toml", WAVE);
    let o = run(isoray().arg("check").arg(&scene));
    assert!(o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("warning: object 0 (`wave`): the distance estimate oversteps"),
        "{e}"
    );
    assert!(
        e.contains("set lipschitz_factor = ") && e.contains("[surface.wave]"),
        "{e}"
    );
    // The suggested factor removes the violation.
    let factor: f64 = e
        .split("lipschitz_factor = ")
        .nth(1)
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(factor > 1.0);
    let fixed = write_scene(
        "wave_fixed.toml",
        &WAVE.replace(
            "bound = \"first-order\"",
            &format!("bound = \"first-order\"\nlipschitz_factor = {factor}"),
        ),
    );
    let o = run(isoray().arg("check").arg(&fixed));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("bound: object 0 (`wave`): holds"));
    // The default (Lipschitz) bound holds without a factor.
    let guarded = write_scene("wave_lipschitz.toml", &WAVE.replace("bound = \"first-order\"\n", ""));
    let o = run(isoray().arg("check").arg(&guarded));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    // Rendering the overstepping field warns too.
    let o = run(isoray()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(tmp("wave.png"))
        .arg("-q"));
    assert!(o.status.success());
    assert!(
        stderr(&o).contains("ray steps went through a surface"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn albedo_aov_holds_the_first_hit_diffuse_colour() {
    let scene = write_scene(
        "albedo.toml",
        &SPHERE.replace(
            "[[object]]\nshape = \"sphere(p, 1.0)\"\n",
            "[material.red]\ndiffuse = [0.7, 0.2, 0.1]\n[[object]]\nmaterial = \"red\"\nshape = \"sphere(p, 1.0)\"\n",
        ),
    );
    let (png, albedo) = (tmp("albedo.png"), tmp("albedo.exr"));
    let o = run(isoray()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&png)
        .arg("--albedo")
        .arg(&albedo)
        .arg("-q"));
    assert!(o.status.success(), "{}", stderr(&o));
    let a = exr::prelude::read_all_flat_layers_from_file(&albedo).unwrap();
    let ch = |name: &str, i: usize| {
        let c = a.layer_data[0]
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap();
        c.sample_data.value_by_flat_index(i).to_f32()
    };
    let centre = 15 * 40 + 20;
    assert!(
        (ch("R", centre) - 0.7).abs() < 1e-6
            && (ch("G", centre) - 0.2).abs() < 1e-6
            && (ch("B", centre) - 0.1).abs() < 1e-6
    );
    assert_eq!((ch("R", 0), ch("G", 0), ch("B", 0)), (0.0, 0.0, 0.0));
    let o = run(isoray()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&png)
        .arg("--albedo")
        .arg(tmp("a.png")));
    assert_eq!(o.status.code(), Some(2));
}

/// Runs `isoray eval SCENE ARGS...` with `input` on stdin.
fn eval_with(scene: &Path, args: &[&str], input: &[u8]) -> Output {
    let mut child = isoray()
        .arg("eval")
        .arg(scene)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The command may exit on bad input before it reads stdin.
    let _ = child.stdin.take().unwrap().write_all(input);
    child.wait_with_output().unwrap()
}

const MOVING: &str =
    "[params]\nk = { default = 1.0, range = [0.5, 2.0] }\n[[object]]\nshape = \"sphere(p - vec3(t, 0.0, 0.0), k)\"\n";

#[test]
fn time_and_parameters_are_inputs() {
    let scene = write_scene("moving.toml", MOVING);
    let dist = |args: &[&str]| -> f64 {
        let o = eval_with(&scene, args, b"0 0 0\n");
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).trim().parse().unwrap()
    };
    // |p − (t, 0, 0)| − k at the origin.
    assert_eq!(dist(&[]), -1.0);
    assert_eq!(dist(&["--time", "2.5"]), 1.5);
    assert_eq!(dist(&["--time", "-3"]), 2.0);
    assert_eq!(dist(&["--set", "params.k=1.75", "--time", "1"]), -0.75);
    // A value outside the declared range names the range; exit 2.
    let o = eval_with(&scene, &["--set", "params.k=5"], b"0 0 0\n");
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("`params.k` = 5 is outside its range [0.5, 2]"),
        "{}",
        stderr(&o)
    );
    let o = eval_with(&scene, &["--time", "inf"], b"0 0 0\n");
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("finite"), "{}", stderr(&o));
    // `t` cannot be a parameter's name.
    let bad = write_scene(
        "param-t.toml",
        "[params]\nt = 1.0\n[[object]]\nshape = \"sphere(p, t)\"\n",
    );
    let o = eval_with(&bad, &[], b"0 0 0\n");
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("built-in time"), "{}", stderr(&o));
}

#[test]
fn every_scene_command_takes_a_time() {
    let scene = write_scene(
        "moving-render.toml",
        &format!("[camera]\nposition = [0.0, 0.0, 6.0]\n[render]\nwidth = 24\nheight = 16\n{MOVING}"),
    );
    let a = tmp("t0.png");
    let b = tmp("t1.png");
    for (t, out) in [("0", &a), ("1.5", &b)] {
        let o = run(isoray()
            .arg("render")
            .arg(&scene)
            .args(["--time", t, "-q", "-o"])
            .arg(out));
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_ne!(
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        "the sphere moved"
    );
    let o = run(isoray().arg("check").arg(&scene).args(["--time", "1"]));
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(isoray()
        .arg("raster")
        .arg(&scene)
        .args(["--time", "1", "-q", "-o"])
        .arg(tmp("r.png")));
    assert!(o.status.success(), "{}", stderr(&o));
    let mesh = tmp("moved.obj");
    let o = run(isoray()
        .arg("mesh")
        .arg(&scene)
        .args(["--time", "3", "-q", "--resolution", "16", "-o"])
        .arg(&mesh));
    assert!(o.status.success(), "{}", stderr(&o));
    // The mesh is the unit sphere moved to x = 3.
    let text = std::fs::read_to_string(&mesh).unwrap();
    let xs: Vec<f64> = text
        .lines()
        .filter(|l| l.starts_with("v "))
        .map(|l| l.split_whitespace().nth(1).unwrap().parse().unwrap())
        .collect();
    let mean = xs.iter().sum::<f64>() / xs.len() as f64;
    assert!((mean - 3.0).abs() < 0.05, "mean x {mean}");
}

#[test]
fn set_writes_a_scene_that_renders_like_the_overrides() {
    let src = examples().join("csg.toml");
    let saved = tmp("csg-set.toml");
    let edits = [
        "params.radius=1.2",
        "render.width=48",
        "render.height=32",
        "light.0.intensity=0.7",
    ];
    let o = run(isoray().arg("set").arg(&src).args(edits).arg("-o").arg(&saved));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("(4 edits)"));
    let (a, b) = (tmp("csg-overrides.png"), tmp("csg-saved.png"));
    let mut with_sets = isoray();
    with_sets.arg("render").arg(&src).arg("-q").arg("-o").arg(&a);
    for e in edits {
        with_sets.args(["--set", e]);
    }
    assert!(run(&mut with_sets).status.success());
    let o = run(isoray().arg("render").arg(&saved).arg("-q").arg("-o").arg(&b));
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        "the same image bytes"
    );
    // A bad edit exits 2 and leaves the file as it was.
    let before = std::fs::read(&saved).unwrap();
    let o = run(isoray().arg("set").arg(&saved).arg("render.aa=0"));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("render.aa"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&saved).unwrap(), before);
}

/// Runs `isoray ARGS… -o OUT` over an existing OUT, sends SIGINT after
/// `after_ms` and checks: exit 130, OUT untouched; returns how long the
/// process took to end after the signal.
fn interrupt(args: &[&str], name: &str, after_ms: u64) -> std::time::Duration {
    let out = tmp(name);
    std::fs::write(&out, b"an earlier output").unwrap();
    let mut child = isoray()
        .args(args)
        .args(["-q", "-o"])
        .arg(&out)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(after_ms));
    let sent = std::time::Instant::now();
    // The shell's built-in `kill` (no procps needed).
    let kill = Command::new("sh")
        .args(["-c", &format!("kill -INT {}", child.id())])
        .status();
    assert!(kill.is_ok_and(|s| s.success()), "kill -INT");
    let status = child.wait().unwrap();
    let waited = sent.elapsed();
    assert_eq!(status.code(), Some(130));
    assert_eq!(std::fs::read(&out).unwrap(), b"an earlier output");
    waited
}

#[test]
fn ctrl_c_stops_a_render_with_130_and_writes_nothing() {
    let scene = examples().join("showcase.toml");
    let scene = scene.to_str().unwrap();
    let args = ["render", scene, "--width", "1280", "--height", "720", "--aa", "2"];
    let waited = interrupt(&args, "cancelled.png", 400);
    // The renderer stops within a tile; the grace period bounds the rest.
    assert!(waited < std::time::Duration::from_secs(2), "{waited:?}");
}

#[test]
fn ctrl_c_stops_a_raster_inside_its_maps_or_shading() {
    let scene = examples().join("reflections.toml");
    let scene = scene.to_str().unwrap();
    let args = [
        "raster",
        scene,
        "--width",
        "1280",
        "--height",
        "720",
        "--shadows",
        "envmap",
        "--reflections",
        "abuffer-map",
    ];
    // Past the meshing (a few tenths of a second): in the maps or the shading.
    let waited = interrupt(&args, "cancelled-raster.png", 1500);
    // Milliseconds in practice (per triangle, texel and pixel); generous for a loaded machine.
    assert!(waited < std::time::Duration::from_secs(2), "{waited:?}");
}

/// `--backend gpu` names the backend in the summary; a build without the
/// GPU feature says how to get one; `--timing` needs the GPU backend.
#[test]
fn the_backend_flag() {
    let out = tmp("backend.png");
    let scene = examples().join("csg.toml");
    let o = run(isoray()
        .arg("render")
        .arg(&scene)
        .args(["--width", "32", "--height", "18", "-o"])
        .arg(&out));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains(" on cpu ("), "{}", stderr(&o));
    let o = run(isoray()
        .arg("render")
        .arg(&scene)
        .args(["--width", "32", "--height", "18", "--timing", "-o"])
        .arg(&out));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--timing needs --backend gpu"), "{}", stderr(&o));
    let o = run(isoray()
        .arg("render")
        .arg(&scene)
        .args(["--width", "32", "--height", "18", "--gpu-kernel", "interpreted", "-o"])
        .arg(&out));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--gpu-kernel needs --backend gpu"),
        "{}",
        stderr(&o)
    );
    let o = run(isoray()
        .arg("render")
        .arg(&scene)
        .args(["--width", "32", "--height", "18", "--backend", "gpu", "--timing", "-o"])
        .arg(&out));
    if cfg!(feature = "gpu") {
        assert!(o.status.success(), "{}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains(" on gpu ") && e.contains("timing: compiled kernel"), "{e}");
    } else {
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(stderr(&o).contains("--features gpu"), "{}", stderr(&o));
    }
}

#[test]
fn depth_command_rasterizes_a_vm_model() {
    // fidget's tangle cube x⁴ − 5x² + y⁴ − 5y² + z⁴ − 5z² + 10 seen along −z
    // at scale 0.25 (model = 4 · world): the pixel column at model
    // (x, y) = (0, 0) first enters the solid where z⁴ − 5z² + 10 < 0 …
    // never (its minimum is 3.75), so the center is empty, while the column
    // at (1.5, 1.5) meets it.
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/models/tanglecube.vm");
    let scene = write_scene(
        "tangle.toml",
        &format!(
            "[surface.tangle]\nvm = \"{}\"\n\n[[object]]\nshape = \"tangle(p)\"\n",
            model.display()
        ),
    );
    let (depth, normals) = (tmp("tangle-depth.png"), tmp("tangle-normals.png"));
    let o = run(isoray()
        .arg("depth")
        .arg(&scene)
        .arg("-o")
        .arg(&depth)
        .arg("--normals")
        .arg(&normals)
        .args(["--size", "64", "--scale", "0.25"]));
    assert!(o.status.success(), "{}", stderr(&o));
    let d = image::open(&depth).unwrap().to_luma8();
    assert_eq!(d.dimensions(), (64, 64));
    // Pixel (x, y) has world ((x + 0.5 − 32)/32, −(y + 0.5 − 31)/32), model 4× that.
    assert_eq!(d.get_pixel(31, 30)[0], 0, "the center column is empty");
    assert!(d.get_pixel(44, 18)[0] > 0, "the column at model (1.5, 1.5) is filled");
    assert!(image::open(&normals).is_ok());
    let o = run(isoray()
        .arg("depth")
        .arg(&scene)
        .arg("-o")
        .arg(&depth)
        .args(["--scale", "0"]));
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--scale must be a positive number"),
        "{}",
        stderr(&o)
    );
}
