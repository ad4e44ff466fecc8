//! The polygon pipeline (`isoray-raster`) against the ray tracer
//! (`isoray-render`) on the same scene: they share one shading model
//! (`isoray-shade`), so away from silhouettes the images agree. (The
//! `--error-vs-raytrace` report is tested in `src/compare.rs` and
//! `tests/raster_cli.rs`.)

use isoray_raster::render::{raster, HiddenSurface, RasterOptions};
use isoray_raster::shading::Shading;
use isoray_render::{render, RenderOptions};
use isoray_scene::{load_str, Scene};

const OPAQUE: &str = r#"
[camera]
position = [0.0, 1.0, 5.0]
target = [0.0, 0.3, 0.0]
fov = 40.0

[render]
width = 160
height = 120
aa = 1
shadows = "none"
ao = false
background = [0.1, 0.12, 0.15]

[[light]]
kind = "directional"
direction = [-1.0, 1.5, 1.0]
color = [1.0, 0.9, 0.8]
intensity = 0.9

[material.red]
ambient = [0.1, 0.05, 0.05]
diffuse = [0.8, 0.2, 0.2]
specular = [0.5, 0.5, 0.5]
shininess = 20.0

[material.blue]
ambient = [0.05, 0.05, 0.1]
diffuse = [0.2, 0.3, 0.8]
specular = [0.3, 0.3, 0.3]
shininess = 10.0

[[object]]
material = "red"
shape = "sphere(p - vec3(-0.3, 0.3, 0.8), 0.6)"

[[object]]
material = "blue"
shape = "box(p - vec3(0.5, 0.2, -0.5), vec3(0.7, 0.6, 0.5))"
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
fn phong_raster_matches_the_ray_tracer_off_silhouettes() {
    let s = scene(OPAQUE);
    let (rt, _) = render(&s, &RenderOptions::default());
    let img = raster(&s, &opts(HiddenSurface::ZBuffer, Shading::Phong, 64)).unwrap();
    assert_eq!((img.width, img.height), (160, 120));
    let differing = rt
        .color
        .iter()
        .zip(&img.color)
        .filter(|(a, b)| (0..3).any(|k| (a[k] - b[k]).abs() >= 0.1))
        .count();
    let fraction = differing as f64 / img.color.len() as f64;
    eprintln!("raster vs ray tracer: {differing} of {} pixels differ", img.color.len());
    assert!(fraction < 0.05, "{differing} pixels ({:.1}%) differ", 100.0 * fraction);
    // Something was drawn: not all background.
    let bg = [0.1f32, 0.12, 0.15];
    assert!(img.color.iter().filter(|c| **c != bg).count() > 1000);
}

#[test]
fn other_shadings_also_agree_roughly() {
    let s = scene(OPAQUE);
    let (rt, _) = render(&s, &RenderOptions::default());
    for shading in [Shading::Gouraud, Shading::Flat] {
        let img = raster(&s, &opts(HiddenSurface::ZBuffer, shading, 64)).unwrap();
        let differing = rt
            .color
            .iter()
            .zip(&img.color)
            .filter(|(a, b)| (0..3).any(|k| (a[k] - b[k]).abs() >= 0.1))
            .count();
        assert!(
            differing * 10 < img.color.len(),
            "{shading:?}: {differing} pixels differ"
        );
    }
}
