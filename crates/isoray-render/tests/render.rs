//! Known-answer render tests: analytic sphere intersections, shadows,
//! antialiasing coverage, determinism across thread counts.

use glam::DVec3;
use isoray_render::camera::RayCamera;
use isoray_render::{render, RenderOptions};
use isoray_scene::{load_str, Scene};

fn scene(text: &str, overrides: &[&str]) -> Scene {
    let ov: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    load_str(text, "test.toml", &ov).unwrap_or_else(|e| panic!("{e}"))
}

fn aovs() -> RenderOptions {
    RenderOptions {
        aovs: true,
        ..RenderOptions::default()
    }
}

const SPHERE: &str = r#"
[camera]
position = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
[render]
width = 64
height = 48
[[light]]
direction = [1.0, 1.0, 1.0]
[[object]]
shape = "sphere(p - vec3(0.3, -0.2, 0.1), 1.0)"
"#;

/// Ray-sphere intersection: the nearest t ≥ 0, and the closest approach.
fn ray_sphere(o: DVec3, d: DVec3, c: DVec3, r: f64) -> (Option<f64>, f64) {
    let oc = o - c;
    let b = oc.dot(d);
    let closest = (oc - b * d).length();
    let disc = b * b - (oc.length_squared() - r * r);
    if disc < 0.0 {
        return (None, closest);
    }
    (Some(-b - disc.sqrt()), closest)
}

#[test]
fn sphere_depth_and_normals_match_ray_sphere_intersection() {
    for normals in ["central", "forward", "tetrahedron", "analytic"] {
        let s = scene(SPHERE, &[&format!("render.normals=\"{normals}\"")]);
        let (img, _) = render(&s, &aovs());
        let depth = img.depth.as_ref().unwrap();
        let nrm = img.normals.as_ref().unwrap();
        let cam = RayCamera::new(&s.camera, 64, 48);
        let c = DVec3::new(0.3, -0.2, 0.1);
        let (mut hits, mut misses) = (0, 0);
        for j in 0..48u32 {
            for i in 0..64u32 {
                let d = cam.direction(i as f64 + 0.5, j as f64 + 0.5);
                let (t, closest) = ray_sphere(cam.origin(), d, c, 1.0);
                if (closest - 1.0).abs() < 0.02 {
                    continue; // grazing the silhouette
                }
                let k = (j * 64 + i) as usize;
                match t {
                    Some(t) => {
                        hits += 1;
                        assert!(
                            (depth[k] as f64 - t).abs() < 2e-3,
                            "pixel ({i},{j}): depth {} vs {t}",
                            depth[k]
                        );
                        let n = ((cam.origin() + d * t) - c).normalize();
                        let got = DVec3::new(nrm[k][0] as f64, nrm[k][1] as f64, nrm[k][2] as f64);
                        assert!(
                            (got - n).length() < 5e-3,
                            "{normals}: pixel ({i},{j}): normal {got} vs {n}"
                        );
                    }
                    None => {
                        misses += 1;
                        assert_eq!(depth[k], f32::INFINITY);
                        assert_eq!(nrm[k], [0.0; 3]);
                    }
                }
            }
        }
        assert!(hits > 300 && misses > 300, "{hits} hits, {misses} misses");
    }
}

#[test]
fn relative_epsilon_still_finds_the_sphere() {
    let s = scene(SPHERE, &["render.relative_epsilon=true", "render.hit_epsilon=1e-4"]);
    let (img, _) = render(&s, &aovs());
    let d = img.depth.unwrap();
    // The centre ray of a 64x48 image is between pixels; take pixel (32, 24) near the centre.
    let cam = RayCamera::new(&s.camera, 64, 48);
    let dir = cam.direction(32.5, 24.5);
    let t = ray_sphere(cam.origin(), dir, DVec3::new(0.3, -0.2, 0.1), 1.0)
        .0
        .unwrap();
    assert!((d[24 * 64 + 32] as f64 - t).abs() < 2e-3);
}

const SHADOW: &str = r#"
[camera]
position = [0.0, 3.0, 6.0]
target = [0.0, 0.0, 0.0]
[render]
width = 33
height = 33
ao = false
[[light]]
direction = [0.0, 1.0, 0.0]
size = 0.2
[material.m]
ambient = [0.1, 0.1, 0.1]
diffuse = [0.8, 0.8, 0.8]
specular = [0.0, 0.0, 0.0]
[[object]]
material = "m"
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"
[[object]]
material = "m"
shape = "sphere(p - vec3(0.0, 1.5, 0.0), 0.5)"
"#;

#[test]
fn shadows_present_and_absent() {
    let centre = 16 * 33 + 16; // looks exactly at (0, 0, 0), under the sphere
    let corner = 32 * 33 + 32; // ground far from the sphere's shadow
    let lum = |mode: &str| {
        let (img, _) = render(
            &scene(SHADOW, &[&format!("render.shadows=\"{mode}\"")]),
            &RenderOptions::default(),
        );
        (img.color[centre][0], img.color[corner][0])
    };
    let (none_c, none_far) = lum("none");
    let (hard_c, hard_far) = lum("hard");
    let (soft_c, soft_far) = lum("soft");
    let (imp_c, imp_far) = lum("improved");
    // Unshadowed ground under a light straight above: ambient + diffuse·1.
    assert!((none_c - 0.9).abs() < 1e-3, "{none_c}");
    // Hard shadow: only the ambient term remains.
    assert!((hard_c - 0.1).abs() < 1e-3, "{hard_c}");
    // Soft shadows: the umbra centre is dark too.
    assert!(soft_c < 0.2 && imp_c < 0.2, "{soft_c} {imp_c}");
    // Away from the sphere, shadows change nothing.
    for far in [hard_far, soft_far, imp_far] {
        assert!((far - none_far).abs() < 0.02, "{far} vs {none_far}");
    }
    // The shadow exponent darkens partial shadow and leaves full light alone.
    let (img1, _) = render(
        &scene(SHADOW, &["render.shadows=\"soft\"", "light.0.size=1.0"]),
        &RenderOptions::default(),
    );
    let (img2, _) = render(
        &scene(
            SHADOW,
            &[
                "render.shadows=\"soft\"",
                "light.0.size=1.0",
                "render.shadow_exponent=3",
            ],
        ),
        &RenderOptions::default(),
    );
    let partial = (0..33 * 33)
        .find(|&k| img1.color[k][0] > 0.2 && img1.color[k][0] < 0.8)
        .expect("a penumbra pixel");
    assert!(img2.color[partial][0] < img1.color[partial][0]);
    let (lit, _) = render(&scene(SHADOW, &["render.shadows=\"none\""]), &RenderOptions::default());
    let full: Vec<usize> = (0..33 * 33).filter(|&k| img1.color[k] == lit.color[k]).collect();
    assert!(!full.is_empty());
    for k in full {
        assert_eq!(img2.color[k], img1.color[k]);
    }
}

const DISC: &str = r#"
[camera]
position = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov = 30.0
[render]
width = 48
height = 48
background = [0.0, 0.0, 0.0]
ao = false
shadows = "none"
[material.white]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
emission = [1.0, 1.0, 1.0]
[[object]]
material = "white"
shape = "sphere(p, 1.0)"
"#;

#[test]
fn antialiasing_gives_coverage() {
    // The silhouette of a sphere of radius 1 seen from distance 5 is a circle of
    // angular radius asin(1/5); its image radius in pixels follows from the fov.
    let radius_px = (0.2f64.asin()).tan() / (15f64.to_radians()).tan() * 24.0;
    let area = std::f64::consts::PI * radius_px * radius_px;
    let (hard, _) = render(&scene(DISC, &["render.aa=1"]), &RenderOptions::default());
    assert!(
        hard.color.iter().all(|c| c[0] == 0.0 || c[0] == 1.0),
        "aa=1 has only inside/outside pixels"
    );
    let (soft, _) = render(&scene(DISC, &["render.aa=4"]), &RenderOptions::default());
    let partial = soft.color.iter().filter(|c| c[0] > 0.05 && c[0] < 0.95).count();
    assert!(partial > 20, "{partial} edge pixels with intermediate values");
    let covered: f64 = soft.color.iter().map(|c| c[0] as f64).sum();
    assert!(
        (covered - area).abs() / area < 0.01,
        "coverage {covered} vs disc area {area}"
    );
}

#[test]
fn same_image_whatever_the_thread_count() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/showcase.toml")).unwrap();
    let s = scene(&text, &["render.width=96", "render.height=54", "render.aa=2"]);
    let run = |n: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
        pool.install(|| render(&s, &RenderOptions::default()).0)
    };
    let one = run(1);
    for n in [2, 3, 5] {
        assert!(one == run(n), "{n} threads differ from 1");
    }
}

#[test]
fn step_view_shows_more_steps_near_silhouettes() {
    let s = scene(SPHERE, &["render.view=\"steps\""]);
    let (img, _) = render(&s, &RenderOptions::default());
    // Every pixel gets a heat-map colour, and they are not all the same.
    let first = img.color[0];
    assert!(img.color.iter().any(|c| *c != first));
}

#[test]
fn implicit_sphere_depth_matches_ray_sphere_intersection() {
    let text = SPHERE.replace(
        "[[object]]\nshape = \"sphere(p - vec3(0.3, -0.2, 0.1), 1.0)\"",
        "[surface.sphere_eq]\nparams = { r = 1.0 }\nimplicit = \"x^2 + y^2 + z^2 - r\"\n[[object]]\nshape = \"sphere_eq(p - vec3(0.3, -0.2, 0.1))\"",
    );
    assert_ne!(text, SPHERE);
    let s = scene(&text, &[]);
    let (img, _) = render(&s, &aovs());
    let depth = img.depth.unwrap();
    let cam = RayCamera::new(&s.camera, 64, 48);
    let mut hits = 0;
    for j in 0..48u32 {
        for i in 0..64u32 {
            let d = cam.direction(i as f64 + 0.5, j as f64 + 0.5);
            let (t, closest) = ray_sphere(cam.origin(), d, DVec3::new(0.3, -0.2, 0.1), 1.0);
            if (closest - 1.0).abs() < 0.02 {
                continue;
            }
            let k = (j * 64 + i) as usize;
            match t {
                Some(t) => {
                    hits += 1;
                    assert!((depth[k] as f64 - t).abs() < 2e-3, "({i},{j}): {} vs {t}", depth[k]);
                }
                None => assert_eq!(depth[k], f32::INFINITY),
            }
        }
    }
    assert!(hits > 300);
}
