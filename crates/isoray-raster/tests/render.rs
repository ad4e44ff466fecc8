//! The A-buffer's antialiased edges (`raster` against the ray tracer is
//! tested in the command line's `tests/raster_vs_raytrace.rs`, which has
//! both renderers).

use isoray_raster::render::{raster, HiddenSurface, RasterOptions};
use isoray_raster::shading::Shading;
use isoray_scene::{load_str, Scene};

const WHITE: &str = r#"
[camera]
position = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
fov = 40.0

[render]
width = 64
height = 48
aa = 1
shadows = "none"
ao = false
background = [0.0, 0.0, 0.0]

[material.white]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
emission = [1.0, 1.0, 1.0]

[[object]]
material = "white"
shape = "sphere(p, 1.0)"
"#;

fn scene(text: &str) -> Scene {
    load_str(text, "test.toml", &[]).expect("scene loads")
}

fn opts(hidden: HiddenSurface, shading: Shading, resolution: u32) -> RasterOptions {
    RasterOptions {
        hidden,
        shading,
        resolution,
        ..RasterOptions::default()
    }
}

#[test]
fn abuffer_edges_are_multiples_of_one_32nd_and_zbuffer_edges_are_binary() {
    let s = scene(WHITE);
    let z = raster(&s, &opts(HiddenSurface::ZBuffer, Shading::Phong, 32)).unwrap();
    for c in &z.color {
        for &v in c {
            assert!(v.abs() < 1e-5 || (v - 1.0).abs() < 1e-5, "z-buffer value {v}");
        }
    }
    let a = raster(&s, &opts(HiddenSurface::ABuffer, Shading::Phong, 32)).unwrap();
    let mut partial = 0;
    for c in &a.color {
        let v = c[0];
        let k = v * 32.0;
        assert!(
            (k - k.round()).abs() < 1e-3,
            "a-buffer value {v} is not a multiple of 1/32"
        );
        assert!(c[1] == v && c[2] == v);
        if k.round() > 0.0 && k.round() < 32.0 {
            partial += 1;
        }
    }
    // The silhouette of a sphere of radius ~15 px: many partly covered pixels.
    assert!(partial > 40, "only {partial} partly covered pixels");
}
