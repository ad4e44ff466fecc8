//! Cancellation inside the long stages (shadow buffers, environment maps,
//! drawing and shading): a cancelled token stops each of them with
//! `Cancelled`, a token cancelled from another thread mid-render stops the
//! render within milliseconds, and a token that is never cancelled changes
//! nothing in the image.

use std::time::{Duration, Instant};

use glam::DVec3;
use isoray_job::{CancelToken, Cancelled};
use isoray_raster::draw::{gbuffer_with, project, Cull};
use isoray_raster::envmap::{CubeMap, MapKind};
use isoray_raster::pipeline::ViewTransform;
use isoray_raster::render::{raster_meshes, HiddenSurface, RasterError, RasterOptions, ReflectionMethod, ShadowMethod};
use isoray_raster::scene::{mesh_scene, MeshedScene};
use isoray_raster::shading::Shading;
use isoray_raster::shadow::ShadowBuffers;
use isoray_raster::triangles::SceneTriangles;
use isoray_scene::{load_str, Scene};

const SCENE: &str = r#"
[camera]
position = [0.0, 1.6, 4.5]
target = [0.0, 0.5, 0.0]
fov = 45.0

[render]
width = 320
height = 180
background = [0.4, 0.5, 0.7]

[[light]]
kind = "point"
position = [2.0, 5.0, 3.0]

[material.floor]
diffuse = [0.7, 0.7, 0.7]
checker = "dark"

[material.dark]
diffuse = [0.2, 0.2, 0.2]

[material.mirror]
diffuse = [0.05, 0.05, 0.05]
reflectivity = 0.8

[material.glass]
diffuse = [0.0, 0.0, 0.0]
transparency = 0.9
ior = 1.5

[[object]]
material = "floor"
shape = "box(p - vec3(0.0, -0.1, 0.0), vec3(3.0, 0.1, 3.0))"

[[object]]
material = "mirror"
shape = "sphere(p - vec3(-0.6, 0.5, 0.0), 0.5)"

[[object]]
material = "glass"
shape = "sphere(p - vec3(0.7, 0.4, 0.3), 0.4)"
"#;

fn scene() -> (Scene, MeshedScene) {
    let s = load_str(SCENE, "cancel.toml", &[]).expect("scene loads");
    let m = mesh_scene(&s, 24).expect("meshes");
    (s, m)
}

fn cancelled() -> CancelToken {
    let t = CancelToken::new();
    t.cancel();
    t
}

/// Every combination of the long stages: both buffers, every shadow and reflection method.
fn configurations() -> Vec<RasterOptions> {
    let mut out = Vec::new();
    for (hidden, shading, shadows, reflections) in [
        (
            HiddenSurface::ZBuffer,
            Shading::Phong,
            ShadowMethod::Buffer,
            ReflectionMethod::BlinnNewell,
        ),
        (
            HiddenSurface::ZBuffer,
            Shading::Gouraud,
            ShadowMethod::EnvMap,
            ReflectionMethod::ZBufferMap,
        ),
        (
            HiddenSurface::ABuffer,
            Shading::Phong,
            ShadowMethod::EnvMap,
            ReflectionMethod::ABufferMap,
        ),
        (
            HiddenSurface::ABuffer,
            Shading::Flat,
            ShadowMethod::None,
            ReflectionMethod::None,
        ),
    ] {
        out.push(RasterOptions {
            hidden,
            shading,
            resolution: 24,
            shadows,
            reflections,
            map_size: 64,
            probes: true,
            ..RasterOptions::default()
        });
    }
    out
}

#[test]
fn a_token_never_cancelled_changes_nothing() {
    let (s, m) = scene();
    for opts in configurations() {
        let plain = raster_meshes(&s, &m, &opts).unwrap();
        let with_token = RasterOptions {
            cancel: Some(CancelToken::new()),
            ..opts.clone()
        };
        let watched = raster_meshes(&s, &m, &with_token).unwrap();
        assert_eq!(plain.color, watched.color, "{opts:?}");
        assert_eq!(plain.probes, watched.probes, "{opts:?}");
        assert_eq!(plain.map_fragments, watched.map_fragments, "{opts:?}");
    }
}

#[test]
fn the_long_stages_check_the_token_themselves() {
    let (s, m) = scene();
    let tris = SceneTriangles::new(&m);
    let token = cancelled();
    for kind in [MapKind::ZBuffer, MapKind::ABuffer] {
        let map = CubeMap::build_with(&tris, DVec3::new(0.0, 0.5, 0.0), 32, kind, None, 1e-3, Some(&token));
        assert!(matches!(map, Err(Cancelled)), "{kind:?}");
        let live = CubeMap::build_with(&tris, DVec3::new(0.0, 0.5, 0.0), 32, kind, None, 1e-3, None).unwrap();
        let plain = CubeMap::build(&tris, DVec3::new(0.0, 0.5, 0.0), 32, kind, None, 1e-3);
        assert_eq!(live.sample_count(), plain.sample_count());
    }
    assert!(matches!(
        ShadowBuffers::build_with(&s, &tris, 32, 1e-3, Some(&token)),
        Err(Cancelled)
    ));
    let view = ViewTransform::new(&s.camera, 320, 180);
    let projected = project(&tris, &view, DVec3::from(s.camera.position), 1e-3, |_| Cull::Back);
    assert!(!projected.is_empty());
    assert!(matches!(
        gbuffer_with(&projected, 320, 180, Some(&token)),
        Err(Cancelled)
    ));
    for opts in configurations() {
        let opts = RasterOptions {
            cancel: Some(token.clone()),
            ..opts
        };
        assert!(matches!(raster_meshes(&s, &m, &opts), Err(RasterError::Cancelled)));
    }
}

#[test]
fn cancelling_from_another_thread_stops_the_render_quickly() {
    let (_, m) = scene();
    // Large enough that every stage takes a while, even in an optimised build.
    let opts = RasterOptions {
        hidden: HiddenSurface::ABuffer,
        resolution: 24,
        shadows: ShadowMethod::EnvMap,
        reflections: ReflectionMethod::ABufferMap,
        map_size: 256,
        ..RasterOptions::default()
    };
    let big = load_str(
        &SCENE
            .replace("width = 320", "width = 640")
            .replace("height = 180", "height = 360"),
        "cancel.toml",
        &[],
    )
    .expect("scene loads");
    assert_eq!(big.render.width, 640);
    let t0 = Instant::now();
    raster_meshes(&big, &m, &opts).unwrap();
    let full = t0.elapsed();
    // Cancel at several moments of the render: in the maps, in drawing, in shading.
    for fraction in [0.1, 0.4, 0.7] {
        let token = CancelToken::new();
        let opts = RasterOptions {
            cancel: Some(token.clone()),
            ..opts.clone()
        };
        let (result, latency) = std::thread::scope(|sc| {
            let worker = sc.spawn(|| {
                let r = raster_meshes(&big, &m, &opts);
                (r, Instant::now())
            });
            std::thread::sleep(full.mul_f64(fraction));
            let sent = Instant::now();
            token.cancel();
            let (r, done) = worker.join().unwrap();
            (r, done.saturating_duration_since(sent))
        });
        assert!(
            matches!(result, Err(RasterError::Cancelled)),
            "cancelled at {fraction} of {full:?}: {:?}",
            result.map(|i| i.timings)
        );
        eprintln!("cancelled at {fraction} of {full:?}: stopped {latency:?} later");
        // Milliseconds in practice; generous for a loaded machine and an unoptimised build.
        assert!(
            latency < Duration::from_millis(250),
            "stopped {latency:?} after the cancel (render {full:?})"
        );
    }
}
