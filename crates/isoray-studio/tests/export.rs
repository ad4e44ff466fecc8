//! File ▸ Export: the image is the CPU renderer's, byte for byte; a mesh
//! export holds the bounded objects (a unit sphere's vertices lie on it)
//! and leaves planes out; a cancelled export leaves the old file intact;
//! an unknown extension is an error that says what is expected.

use isoray_studio::export::{Export, ExportEnd};

const SCENE: &str = r#"
[camera]
position = [0.0, 1.5, 4.0]
target = [0.0, 0.5, 0.0]
[render]
width = 80
height = 50
[[light]]
direction = [-1.0, 2.0, 1.0]
[[object]]
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"
[[object]]
shape = "sphere(p - vec3(0.0, 1.0, 0.0), 1.0)"
"#;

fn scene() -> isoray_scene::Scene {
    isoray_scene::load_str(SCENE, "export.toml", &[]).unwrap()
}

#[test]
fn an_exported_image_is_the_cpu_renderers_png() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("still.png");
    let x = Export::start(scene(), out.clone()).unwrap();
    let end = x.wait();
    assert!(matches!(&end, ExportEnd::Done(s) if s.contains("80×50")), "{end:?}");
    let (img, _) = isoray_render::render(&scene(), &Default::default());
    let reference = dir.path().join("reference.png");
    isoray_render::output::write_png(&reference, img.width, img.height, &img.color).unwrap();
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&reference).unwrap());
    // No temporary file is left beside it.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
}

#[test]
fn a_mesh_export_holds_the_bounded_objects() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["stl", "obj", "ply", "glb"] {
        let out = dir.path().join(format!("scene.{ext}"));
        let end = Export::start(scene(), out.clone()).unwrap().wait();
        let ExportEnd::Done(summary) = end else {
            panic!("{ext}: {end:?}");
        };
        assert!(summary.contains("objects 0 are unbounded"), "{summary}");
        let mesh = isoray_mesh::io::read(&out).unwrap();
        assert!(mesh.triangles.len() > 500, "{ext}: {} triangles", mesh.triangles.len());
        for p in &mesh.positions {
            let r = (p[0] as f64).hypot(p[1] as f64 - 1.0).hypot(p[2] as f64);
            assert!(
                (r - 1.0).abs() < 0.02,
                "{ext}: a vertex at distance {r} from the centre"
            );
        }
    }
}

#[test]
fn a_cancelled_export_keeps_the_old_file_and_a_bad_name_is_explained() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.png");
    std::fs::write(&out, b"the old file").unwrap();
    let mut big = scene();
    big.render.width = 4000;
    big.render.height = 3000;
    big.render.aa = 4;
    let x = Export::start(big, out.clone()).unwrap();
    x.cancel();
    assert_eq!(x.wait(), ExportEnd::Cancelled);
    assert_eq!(std::fs::read(&out).unwrap(), b"the old file");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "no partial file left"
    );

    let e = Export::start(scene(), dir.path().join("scene.jpg")).unwrap_err();
    assert!(
        e.contains("scene.jpg") && e.contains(".png or .exr") && e.contains(".glb"),
        "{e}"
    );
}
