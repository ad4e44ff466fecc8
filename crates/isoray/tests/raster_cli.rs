//! End-to-end tests of `isoray raster`.

use std::path::PathBuf;
use std::process::Command;

fn isoray() -> Command {
    Command::new(env!("CARGO_BIN_EXE_isoray"))
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isoray-raster-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

const SCENE: &str = r#"
[camera]
position = [0.0, 2.0, 5.0]
target = [0.0, 0.3, 0.0]
fov = 40.0

[render]
width = 48
height = 32

[[light]]
kind = "point"
position = [2.0, 3.0, 2.0]

[material.grey]
diffuse = [0.6, 0.6, 0.6]

[[object]]
material = "grey"
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"

[[object]]
material = "grey"
shape = "sphere(p - vec3(0.0, 0.5, 0.0), 0.5)"
"#;

fn scene_file() -> PathBuf {
    let p = tmp("scene.toml");
    std::fs::write(&p, SCENE).unwrap();
    p
}

#[test]
fn writes_a_png_with_a_ground_plane() {
    let scene = scene_file();
    for hidden in ["zbuffer", "abuffer"] {
        let out = tmp(&format!("out-{hidden}.png"));
        let o = isoray()
            .args(["raster"])
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .args([
                "--hidden",
                hidden,
                "--shading",
                "gouraud",
                "--resolution",
                "24",
                "--shadows",
                "none",
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let img = image::open(&out).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (48, 32));
    }
}

#[test]
fn bad_options_are_rejected_with_code_2() {
    let scene = scene_file();
    let out = tmp("never.png");
    for (args, expect) in [
        (&["--map-size", "0"][..], "--map-size"),
        (&["--error-vs-raytrace", "r.txt"][..], ".json"),
        (&["--reflections", "mirror"][..], "mirror"),
        (&["--shadows", "soft"][..], "soft"),
    ] {
        let o = isoray()
            .arg("raster")
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .args(args)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(expect), "{args:?}: {err}");
        assert!(!out.exists());
    }
}

#[test]
fn reflections_shadows_and_the_report() {
    let scene = tmp("mirror.toml");
    std::fs::write(
        &scene,
        SCENE
            .replace(
                "[material.grey]",
                "[material.mirror]\ndiffuse = [0.1, 0.1, 0.1]\nreflectivity = 0.8\n\n[material.grey]",
            )
            .replace(
                "material = \"grey\"\nshape = \"sphere",
                "material = \"mirror\"\nshape = \"sphere",
            ),
    )
    .unwrap();
    for (reflections, shadows) in [
        ("blinn-newell", "buffer"),
        ("zbuffer-map", "buffer"),
        ("abuffer-map", "envmap"),
    ] {
        let out = tmp(&format!("{reflections}.png"));
        let report = tmp(&format!("{reflections}.json"));
        let o = isoray()
            .arg("raster")
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .args(["--resolution", "24", "--map-size", "64", "--reflections", reflections])
            .args(["--shadows", shadows, "--error-vs-raytrace"])
            .arg(&report)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(image::open(&out).unwrap().to_rgb8().dimensions(), (48, 32));
        let json = std::fs::read_to_string(&report).unwrap();
        for key in [
            "\"reflective_pixels\"",
            "\"angular_error_deg\"",
            "\"wrong_fraction\"",
            "\"psnr_db\"",
            "\"raytrace_image\"",
        ] {
            assert!(json.contains(key), "{key} missing from {json}");
        }
        assert!(json.contains(&format!("\"reflections\": \"{reflections}\"")), "{json}");
        let reflective: usize = json
            .split("\"reflective_pixels\": ")
            .nth(1)
            .and_then(|r| r.split(',').next())
            .and_then(|v| v.trim().parse().ok())
            .unwrap();
        assert!(reflective > 50, "{json}");
        let reference = report.with_extension("raytrace.png");
        assert_eq!(image::open(&reference).unwrap().to_rgb8().dimensions(), (48, 32));
    }
}

#[test]
fn mesh_files_and_parametric_surfaces_are_drawn_too() {
    let scene = scene_file();
    // A mesh file: a ball beside the scene's sphere, meshed by isoray itself.
    let ball_scene = tmp("ball.toml");
    std::fs::write(
        &ball_scene,
        SCENE.replace("sphere(p - vec3(0.0, 0.5, 0.0)", "sphere(p - vec3(1.2, 0.4, 0.0)"),
    )
    .unwrap();
    let stl = tmp("ball.stl");
    let o = isoray()
        .args(["mesh"])
        .arg(&ball_scene)
        .arg("-o")
        .arg(&stl)
        .args(["--resolution", "24", "-q"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A parametric surface: a flat patch over the ground.
    let with_surface = tmp("surface.toml");
    std::fs::write(
        &with_surface,
        format!(
            "{SCENE}\n[surface.patch]\nparametric = {{ x = \"s\", y = \"0.05\", z = \"t\" }}\ndomain = {{ s = [-1.5, -0.5], t = [-0.5, 0.5] }}\n"
        ),
    )
    .unwrap();
    let render = |scene: &std::path::Path, extra: &[&str], name: &str| {
        let out = tmp(name);
        let o = isoray()
            .arg("raster")
            .arg(scene)
            .arg("-o")
            .arg(&out)
            .args(["--resolution", "24"])
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{extra:?}: {}", String::from_utf8_lossy(&o.stderr));
        image::open(&out).unwrap().to_rgb8()
    };
    let base = render(&scene, &[], "base.png");
    let stl_arg = format!("{}@grey", stl.display());
    let with_mesh = render(&scene, &["--add-mesh", &stl_arg], "mesh.png");
    let with_patch = render(&with_surface, &["--add-surface", "patch"], "patch.png");
    let differ = |a: &image::RgbImage, b: &image::RgbImage| a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
    assert!(differ(&base, &with_mesh) > 20, "{}", differ(&base, &with_mesh));
    assert!(differ(&base, &with_patch) > 20, "{}", differ(&base, &with_patch));
    // An unknown material or surface is a usage error.
    let bad = format!("{}@nope", stl.display());
    for args in [&["--add-mesh", bad.as_str()][..], &["--add-surface", "nope"][..]] {
        let o = isoray()
            .arg("raster")
            .arg(&with_surface)
            .arg("-o")
            .arg(tmp("never2.png"))
            .args(args)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}");
    }
}
