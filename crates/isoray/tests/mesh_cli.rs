//! End-to-end tests of `isoray mesh`: formats, summaries, materials,
//! parametric surfaces, bounds, and errors.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn isoray() -> Command {
    Command::new(env!("CARGO_BIN_EXE_isoray"))
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn bench_csg() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/mesh/csg.toml")
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isoray-mesh-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn mesh(args: &[&str]) -> Output {
    isoray().arg("mesh").args(args).output().expect("isoray runs")
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The number after `triangles: ` in the summary.
fn printed_triangles(stdout: &str) -> usize {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("triangles: "))
        .expect("a triangles line");
    line["triangles: ".len()..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn every_format_holds_the_printed_closed_mesh() {
    let scene = bench_csg();
    for ext in ["stl", "obj", "ply", "glb"] {
        let out = tmp(&format!("csg.{ext}"));
        let o = mesh(&[
            scene.to_str().unwrap(),
            "csg",
            "-o",
            out.to_str().unwrap(),
            "--resolution",
            "40",
            "-q",
        ]);
        let (so, se) = text(&o);
        assert!(o.status.success(), "{ext}: {se}");
        assert!(so.contains("watertight: yes"), "{so}");
        assert!(so.contains("distance error: max"), "{so}");
        assert!(so.lines().any(|l| l.starts_with("time: ")), "{so}");
        let m = isoray_mesh::io::read(&out).unwrap();
        assert_eq!(m.triangles.len(), printed_triangles(&so), "{ext}");
        assert!(m.topology().is_closed_manifold(), "{ext}: {:?}", m.topology());
        if ext != "stl" {
            assert_eq!(m.normals.len(), m.positions.len(), "{ext}: normals");
        }
    }
}

#[test]
fn a_whole_scene_keeps_materials_and_skips_the_floor() {
    let out = tmp("showcase.glb");
    let scene = examples().join("showcase.toml");
    let o = mesh(&[
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--resolution",
        "32",
        "-q",
    ]);
    let (so, se) = text(&o);
    assert!(o.status.success(), "{se}");
    assert!(
        se.contains("warning: skipping object 0") && se.contains("unbounded"),
        "{se}"
    );
    assert!(so.contains("watertight: yes"), "{so}");
    let m = isoray_mesh::io::read(&out).unwrap();
    let sc = isoray_scene::load(&scene, &[]).unwrap();
    // Every material of a meshed object is in the file with its diffuse colour.
    for o in sc.objects.iter().skip(1) {
        let mat = &sc.materials[o.material];
        let found = m.materials.iter().find(|x| x.name == mat.name).expect("the material");
        for k in 0..3 {
            assert!((found.base_color[k] - mat.diffuse[k] as f32).abs() < 1e-6);
        }
    }
}

#[test]
fn bounds_cut_an_unbounded_plane_into_a_closed_slab() {
    let out = tmp("slab.ply");
    let scene = examples().join("showcase.toml");
    // Object 0 of the showcase is the floor plane y = 0; inside is below.
    let sc = isoray_scene::load(&scene, &[]).unwrap();
    assert!(sc.objects[0].name.is_none());
    let text_scene = tmp("plane.toml");
    std::fs::write(
        &text_scene,
        "[[object]]\nname = \"floor\"\nshape = \"plane(p, vec3(0.0, 1.0, 0.0), 0.0)\"\n",
    )
    .unwrap();
    let o = mesh(&[
        text_scene.to_str().unwrap(),
        "floor",
        "-o",
        out.to_str().unwrap(),
        "--bounds",
        "-1,-1,-1,1,1,1",
        "--resolution",
        "20",
        "-q",
    ]);
    let (so, se) = text(&o);
    assert!(o.status.success(), "{se}");
    assert!(so.contains("watertight: yes"), "{so}");
    let m = isoray_mesh::io::read(&out).unwrap();
    // The slab [-1, 1] x [-1, 0] x [-1, 1] with sharp edges: volume 4 (less
    // the 1/1000 of a cell that vertices keep inside their cells).
    assert!((m.volume() - 4.0).abs() < 2e-3, "{}", m.volume());
}

#[test]
fn a_parametric_surface_is_tessellated_with_st_coordinates() {
    let out = tmp("saddle.obj");
    let scene = examples().join("surfaces.toml");
    let o = mesh(&[scene.to_str().unwrap(), "saddle", "-o", out.to_str().unwrap(), "-q"]);
    let (so, se) = text(&o);
    assert!(o.status.success(), "{se}");
    assert!(so.starts_with("tessellated surface `saddle`"), "{so}");
    let m = isoray_mesh::io::read(&out).unwrap();
    assert_eq!(m.uvs.len(), m.positions.len());
    // saddle: x = t, y = s, z = t² − s², over [-0.9, 0.9]².
    for (p, uv) in m.positions.iter().zip(&m.uvs) {
        let (s, t) = (uv[0], uv[1]);
        assert!((p[0] - t).abs() < 1e-5 && (p[1] - s).abs() < 1e-5, "{p:?} {uv:?}");
        assert!((p[2] - (t * t - s * s)).abs() < 1e-5);
    }
}

#[test]
fn bad_requests_are_clear_errors() {
    let scene = bench_csg();
    let s = scene.to_str().unwrap();
    let out = tmp("x.stl");
    let o = out.to_str().unwrap();
    let cases: [(&[&str], &str); 5] = [
        (&[s, "cgs", "-o", o], "did you mean `csg`?"),
        (&[s, "csg", "-o", "out.xyz"], ".xyz"),
        (
            &[s, "csg", "-o", o, "--bounds", "1,1,1,0,0,0"],
            "--bounds expects six numbers",
        ),
        (
            &[s, "csg", "-o", o, "--resolution", "1"],
            "--resolution must be at least 2",
        ),
        (&[s, "csg", "-o", o, "--lipschitz", "0.5"], "lipschitz"),
    ];
    for (args, needle) in cases {
        let r = mesh(args);
        let (_, se) = text(&r);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {se}");
        assert!(se.contains(needle), "{args:?}: {se}");
    }
}

#[test]
fn a_failed_write_keeps_the_old_file() {
    let scene = bench_csg();
    let dir = tmp("ro");
    std::fs::create_dir_all(&dir).unwrap();
    // A directory named like the target: the rename must fail.
    let target = dir.join("taken.stl");
    std::fs::create_dir_all(&target).unwrap();
    let o = mesh(&[
        scene.to_str().unwrap(),
        "csg",
        "-o",
        target.to_str().unwrap(),
        "--resolution",
        "16",
        "-q",
    ]);
    let (_, se) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{se}");
    assert!(se.contains("taken.stl"), "{se}");
    assert!(target.is_dir());
    // No temporary files left behind.
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(left.len(), 1);
}
