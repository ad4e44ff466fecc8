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
fn unimplemented_options_are_rejected_with_code_2() {
    let scene = scene_file();
    let out = tmp("never.png");
    for args in [
        &["--reflections", "blinn-newell"][..],
        &["--shadows", "buffer"][..],
        &["--error-vs-raytrace", "r.json"][..],
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
        assert!(err.contains("not implemented yet"), "{args:?}: {err}");
        assert!(!out.exists());
    }
}
