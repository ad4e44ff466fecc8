//! Known-answer tests of the recursive ray tracer: a mirror sphere reflects a
//! checker plane where the analytic reflected ray says, and a glass sphere
//! refracts a stripe where Snell's law at both surfaces says (inverting it).

use glam::DVec3;
use isoray_render::camera::RayCamera;
use isoray_render::{render, RenderOptions};
use isoray_scene::load_str;

const W: u32 = 64;
const H: u32 = 48;

/// Ray–sphere: the entry and exit distances.
fn sphere_hits(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Option<(f64, f64)> {
    let oc = o - c;
    let b = oc.dot(d);
    let disc = b * b - (oc.length_squared() - r * r);
    (disc > 0.0).then(|| (-b - disc.sqrt(), -b + disc.sqrt()))
}

fn snell(i: DVec3, n: DVec3, eta: f64) -> DVec3 {
    let cos1 = -n.dot(i);
    let k = 1.0 - eta * eta * (1.0 - cos1 * cos1);
    assert!(k >= 0.0, "no total internal reflection through a sphere");
    eta * i + (eta * cos1 - k.sqrt()) * n
}

const CHECKER: &str = r#"
[camera]
position = [0.0, 1.6, 4.0]
target = [0.0, 0.7, 0.0]
fov = 40.0
[render]
width = 64
height = 48
shadows = "none"
ao = false
background = [0.5, 0.5, 0.5]
[[light]]
intensity = 0.0
[material.white]
emission = [1.0, 1.0, 1.0]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
[material.black]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
[material.mirror]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
reflectivity = 1.0
fresnel = false
[[object]]
material = "white"
shape = "min(box(repeat(p - vec3(0.0, -0.1, 0.0), vec3(2.0, 1000.0, 2.0)), vec3(0.5, 0.1, 0.5)), box(repeat(p - vec3(1.0, -0.1, 1.0), vec3(2.0, 1000.0, 2.0)), vec3(0.5, 0.1, 0.5)))"
[[object]]
material = "black"
shape = "min(box(repeat(p - vec3(1.0, -0.1, 0.0), vec3(2.0, 1000.0, 2.0)), vec3(0.5, 0.1, 0.5)), box(repeat(p - vec3(0.0, -0.1, 1.0), vec3(2.0, 1000.0, 2.0)), vec3(0.5, 0.1, 0.5)))"
[[object]]
material = "mirror"
shape = "sphere(p - vec3(0.0, 0.9, 0.0), 0.8)"
"#;

#[test]
fn mirror_sphere_reflects_the_checker_where_the_reflected_ray_lands() {
    let scene = load_str(CHECKER, "checker.toml", &[]).unwrap();
    let (img, stats) = render(&scene, &RenderOptions::default());
    let cam = RayCamera::new(&scene.camera, W, H);
    let o = cam.origin();
    let c = DVec3::new(0.0, 0.9, 0.0);
    let (mut white, mut black, mut sky) = (0, 0, 0);
    for j in 0..H {
        for i in 0..W {
            let d = cam.direction(i as f64 + 0.5, j as f64 + 0.5);
            let Some((t, _)) = sphere_hits(o, d, c, 0.8) else {
                continue;
            };
            let p = o + d * t;
            let n = (p - c) / 0.8;
            if n.dot(-d) < 0.3 {
                continue; // near the silhouette
            }
            let r = d - 2.0 * n.dot(d) * n;
            let got = img.color[(j * W + i) as usize][0] as f64;
            let want = if r.y >= -1e-9 {
                sky += 1;
                0.5
            } else {
                let q = p + r * (-p.y / r.y);
                let (fx, fz) = (q.x + 0.5 - (q.x + 0.5).floor(), q.z + 0.5 - (q.z + 0.5).floor());
                let edge = [fx, 1.0 - fx, fz, 1.0 - fz].into_iter().fold(1.0, f64::min);
                // Stay clear of tile edges (a pixel's footprint grows in the reflection).
                if edge < 0.15 || (q - p).length() > 8.0 {
                    continue;
                }
                let parity = (q.x.round() as i64 + q.z.round() as i64).rem_euclid(2);
                if parity == 0 {
                    white += 1;
                    1.0
                } else {
                    black += 1;
                    0.0
                }
            };
            assert!(
                (got - want).abs() < 0.1,
                "pixel ({i}, {j}): rendered {got}, reflected ray says {want}"
            );
        }
    }
    assert!(white > 20 && black > 20 && sky > 20, "{white} {black} {sky}");
    assert!(stats.evaluations > 0);
}

const GLASS: &str = r#"
[camera]
position = [0.0, 0.0, 6.0]
target = [0.0, 0.0, 0.0]
fov = 30.0
[render]
width = 64
height = 48
shadows = "none"
ao = false
background = [0.5, 0.5, 0.5]
[[light]]
intensity = 0.0
[material.glass]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
transparency = 1.0
ior = 1.5
fresnel = false
[material.lit]
emission = [1.0, 1.0, 1.0]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
[material.dark]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
[[object]]
material = "glass"
shape = "sphere(p, 1.0)"
[[object]]
material = "lit"
shape = "box(p - vec3(0.0, 0.9, -3.0), vec3(20.0, 0.6, 0.1))"
[[object]]
material = "dark"
shape = "box(p - vec3(0.0, 0.0, -3.2), vec3(20.0, 20.0, 0.1))"
"#;

#[test]
fn glass_sphere_refracts_the_stripe_where_snell_says_and_inverts_it() {
    let scene = load_str(GLASS, "glass.toml", &[]).unwrap();
    let (img, _) = render(&scene, &RenderOptions::default());
    let cam = RayCamera::new(&scene.camera, W, H);
    let o = cam.origin();
    let (mut lit_below, mut checked) = (0, 0);
    for j in 0..H {
        for i in 0..W {
            let d = cam.direction(i as f64 + 0.5, j as f64 + 0.5);
            let Some((t, _)) = sphere_hits(o, d, DVec3::ZERO, 1.0) else {
                continue;
            };
            let p = o + d * t;
            if p.dot(-d) < 0.3 {
                continue; // near the silhouette
            }
            // In at p, across the sphere, out at q.
            let inside = snell(d, p, 1.0 / 1.5).normalize();
            let (_, t2) = sphere_hits(p, inside, DVec3::ZERO, 1.0).unwrap();
            let q = p + inside * t2;
            let out = snell(inside, -q, 1.5).normalize();
            // The exit ray meets the stripe's front face (z = −2.9) or the dark wall.
            let s = q + out * ((-2.9 - q.z) / out.z);
            let dist_to_edge = (s.y - 0.3).abs().min((s.y - 1.5).abs());
            if dist_to_edge < 0.12 {
                continue;
            }
            let want = if (0.3..1.5).contains(&s.y) { 1.0 } else { 0.0 };
            let got = img.color[(j * W + i) as usize][0] as f64;
            assert!(
                (got - want).abs() < 0.1,
                "pixel ({i}, {j}): rendered {got}, two refractions say {want}"
            );
            checked += 1;
            if want == 1.0 && p.y < -0.1 {
                lit_below += 1;
            }
        }
    }
    // The stripe is above the axis, yet it is seen through the lower half of the sphere.
    assert!(checked > 300, "{checked}");
    assert!(lit_below > 10, "{lit_below}");
}

#[test]
fn two_refraction_deviation_matches_the_textbook_formula() {
    // For a ray parallel to the axis at impact parameter b through a sphere of
    // index n: deviation = 2(θi − θt), sin θi = b/R, sin θt = sin θi / n.
    for b in [0.1, 0.3, 0.5, 0.7, 0.9] {
        let d = DVec3::new(0.0, 0.0, -1.0);
        let o = DVec3::new(0.0, b, 5.0);
        let (t, _) = sphere_hits(o, d, DVec3::ZERO, 1.0).unwrap();
        let p = o + d * t;
        let inside = snell(d, p, 1.0 / 1.5).normalize();
        let (_, t2) = sphere_hits(p, inside, DVec3::ZERO, 1.0).unwrap();
        let q = p + inside * t2;
        let out = snell(inside, -q, 1.5).normalize();
        let deviation = out.angle_between(d);
        let (ti, tt) = (f64::asin(b), f64::asin(b / 1.5));
        assert!((deviation - 2.0 * (ti - tt)).abs() < 1e-9, "b = {b}: {deviation}");
    }
}

#[test]
fn reflective_renders_are_the_same_whatever_the_thread_count() {
    let scene = load_str(&CHECKER.replace("width = 64", "width = 96"), "c.toml", &[]).unwrap();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let a = one.install(|| render(&scene, &RenderOptions::default())).0;
    let b = two.install(|| render(&scene, &RenderOptions::default())).0;
    assert_eq!(a.color, b.color);
}

const SLAB: &str = r#"
[camera]
position = [0.0, 0.8, 6.0]
target = [0.0, 0.0, 0.0]
fov = 60.0
[render]
width = 48
height = 48
shadows = "hard"
ao = false
background = [0.0, 0.0, 0.0]
[[light]]
kind = "directional"
direction = [0.0, 1.0, 0.0]
[material.floor]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.8, 0.8, 0.8]
specular = [0.0, 0.0, 0.0]
[material.glass]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
transparency = 1.0
ior = 1.0
fresnel = false
absorption = [1.0, 0.0, 0.0]
[[object]]
material = "floor"
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"
[[object]]
material = "glass"
shape = "box(p - vec3(-1.5, 2.0, 0.0), vec3(1.0, 0.25, 1.0))"
[[object]]
material = "floor"
shape = "box(p - vec3(1.5, 2.0, 0.0), vec3(0.6, 0.1, 0.6))"
"#;

/// The colour of the pixel whose ray meets the floor (y = 0) nearest (x, 0, z),
/// and where that ray meets it.
fn floor_pixel(scene: &isoray_scene::Scene, color: &[[f32; 3]], x: f64, z: f64) -> ([f32; 3], DVec3) {
    let (w, h) = (scene.render.width, scene.render.height);
    let cam = RayCamera::new(&scene.camera, w, h);
    let mut best = (f64::INFINITY, 0usize, DVec3::ZERO);
    for j in 0..h {
        for i in 0..w {
            let d = cam.direction(i as f64 + 0.5, j as f64 + 0.5);
            let t = -cam.origin().y / d.y;
            if t <= 0.0 {
                continue;
            }
            let q = cam.origin() + d * t;
            let e = (q.x - x).hypot(q.z - z);
            if e < best.0 {
                best = (e, (j * w + i) as usize, q);
            }
        }
    }
    (color[best.1], best.2)
}

#[test]
fn shadows_through_glass_are_attenuated_not_blocked() {
    // Light straight down. Under the glass slab (0.5 thick, absorption 1 in
    // red) the floor keeps exp(−0.5) of its red light and all of its green;
    // under the opaque slab it is black. The camera looks at the floor from
    // low down, under the slabs.
    let scene = load_str(SLAB, "slab.toml", &[]).unwrap();
    let (img, _) = render(&scene, &RenderOptions::default());
    let floor_pixel = |x: f64, z: f64| floor_pixel(&scene, &img.color, x, z).0;
    let lit = floor_pixel(0.0, 1.8);
    let under_opaque = floor_pixel(1.5, 0.0);
    assert!(lit[0] > 0.5 && (lit[0] - lit[1]).abs() < 1e-3, "{lit:?}");
    assert!(under_opaque[0] < 0.02 && under_opaque[1] < 0.02, "{under_opaque:?}");
    let under_glass = floor_pixel(-1.5, 0.0);
    let red = under_glass[0] / lit[0];
    let green = under_glass[1] / lit[1];
    assert!((green - 1.0).abs() < 0.02, "{under_glass:?} vs {lit:?}");
    assert!(
        (red - (-0.5f32).exp()).abs() < 0.02,
        "red ratio {red}, want exp(-0.5) = {}",
        (-0.5f32).exp()
    );
}

/// A glass ball (radius 1, absorption 1 in red, no Fresnel, index 1) over
/// a floor, lit straight down: the floor at distance b from the point under
/// its centre keeps exp(−2·√(1 − b²)) of its red light (the chord), all of
/// its green. Closed-form shadow rays (the ball is a sphere: its two
/// crossings) and marched ones (`render.analytic = false`) alike, out to
/// the shadow's rim, where the marched rays cross the surface at grazing
/// angles (a step past the entry of fixed length left them within the hit
/// epsilon of it, and they found their exit at once: no absorption).
#[test]
fn shadows_through_a_glass_ball_keep_the_chord_s_share() {
    let end = SLAB.find("[[object]]").unwrap();
    let text = SLAB[..end]
        .replace("width = 48\nheight = 48", "width = 200\nheight = 120")
        .replace("position = [0.0, 0.8, 6.0]", "position = [0.0, 0.9, 3.0]")
        + "[[object]]\nmaterial = \"floor\"\nshape = \"plane(p, vec3(0.0, 1.0, 0.0), 0.0)\"\n"
        + "[[object]]\nmaterial = \"glass\"\nshape = \"sphere(p - vec3(0.0, 2.0, 0.0), 1.0)\"\n";
    for overrides in [vec![], vec!["render.analytic=false".to_string()]] {
        let scene = load_str(&text, "ball.toml", &overrides).unwrap();
        let (img, _) = render(&scene, &RenderOptions::default());
        let (lit, _) = floor_pixel(&scene, &img.color, 1.6, 0.0);
        assert!(lit[0] > 0.5 && (lit[0] - lit[1]).abs() < 1e-3, "{overrides:?}: {lit:?}");
        // Every pixel of the floor under the ball (its shadow's rim too).
        let cam = RayCamera::new(&scene.camera, 200, 120);
        let mut seen = 0;
        for j in 0..120u32 {
            for i in 0..200u32 {
                let d = cam.direction(i as f64 + 0.5, j as f64 + 0.5);
                let q = cam.origin() - d * (cam.origin().y / d.y);
                let b = q.x.hypot(q.z);
                if d.y >= 0.0 || b >= 1.0 {
                    continue;
                }
                let under = img.color[(j * 200 + i) as usize];
                let want = (-2.0 * (1.0 - b * b).sqrt()).exp() as f32;
                let (red, green) = (under[0] / lit[0], under[1] / lit[1]);
                assert!(
                    (green - 1.0).abs() < 0.03,
                    "{overrides:?} b = {b}: {under:?} vs {lit:?}"
                );
                assert!(
                    (red - want).abs() < 0.03,
                    "{overrides:?} b = {b}: red ratio {red}, want {want}"
                );
                seen += 1;
            }
        }
        assert!(seen > 500, "{seen} pixels under the ball");
    }
}

fn penumbra_scene(radius: f64) -> String {
    format!(
        r#"
[camera]
position = [0.0, 1.0, 6.0]
target = [0.0, 0.0, 0.0]
fov = 30.0
[render]
width = 96
height = 16
shadows = "soft"
ao = false
background = [0.0, 0.0, 0.0]
[[light]]
kind = "sphere"
position = [0.0, 4.0, 0.0]
radius = {radius:?}
samples = 64
[material.floor]
ambient = [0.0, 0.0, 0.0]
diffuse = [1.0, 1.0, 1.0]
specular = [0.0, 0.0, 0.0]
[[object]]
material = "floor"
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"
[[object]]
material = "floor"
shape = "box(p - vec3(-5.0, 2.0, 0.0), vec3(5.0, 0.02, 5.0))"
"#
    )
}

/// The width on the floor over which the light goes from 10 % to 90 % of full.
fn penumbra_width(radius: f64) -> f64 {
    let scene = load_str(&penumbra_scene(radius), "p.toml", &[]).unwrap();
    let (img, _) = render(&scene, &RenderOptions::default());
    let cam = RayCamera::new(&scene.camera, 96, 16);
    let row = 8u32;
    let xs: Vec<(f64, f32)> = (0..96u32)
        .map(|i| {
            let d = cam.direction(i as f64 + 0.5, row as f64 + 0.5);
            let q = cam.origin() + d * (-cam.origin().y / d.y);
            (q.x, img.color[(row * 96 + i) as usize][0])
        })
        .collect();
    let full = xs.iter().map(|x| x.1).fold(0.0f32, f32::max);
    let first = |f: f32| xs.iter().find(|x| x.1 >= f * full).map(|x| x.0).unwrap();
    first(0.9) - first(0.1)
}

#[test]
fn area_light_penumbra_grows_with_the_light() {
    // A light of radius r at height 4 over an occluder edge at height 2: the
    // penumbra on the floor spans from −r to +r around the edge's shadow, and
    // 10 %–90 % of it (for a disc seen edge-on, about 0.68 of the span) grows with r.
    let small = penumbra_width(0.25);
    let large = penumbra_width(0.75);
    assert!(large > 2.0 * small, "{small} {large}");
    for (r, w) in [(0.25, small), (0.75, large)] {
        assert!(w > 0.9 * r && w < 2.0 * r, "radius {r}: width {w}");
    }
}

#[test]
fn area_lights_are_deterministic_across_thread_counts() {
    let scene = load_str(&penumbra_scene(0.5), "p.toml", &[]).unwrap();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    let a = one.install(|| render(&scene, &RenderOptions::default()));
    let b = three.install(|| render(&scene, &RenderOptions::default()));
    assert_eq!(a.0.color, b.0.color);
    assert!(a.1.rays.shadow >= 96 * 16 * 64 / 2, "{:?}", a.1.rays);
}

/// An equirectangular map, red where directions have z > 0 (behind the
/// default camera), blue where z < 0, written as EXR into a temporary folder.
fn write_env() -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("isoray-env-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (64u32, 32u32);
    let mut px = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let d = isoray_scene::env::equirect_direction((i as f64 + 0.5) / w as f64, (j as f64 + 0.5) / h as f64);
            px.push(if d[2] > 0.0 { [1.0, 0.0, 0.0] } else { [0.0, 0.0, 1.0] });
        }
    }
    let path = dir.join("halves.exr");
    isoray_render::output::write_exr_rgb(&path, w, h, &px).unwrap();
    path
}

#[test]
fn environment_map_is_the_background_and_is_reflected() {
    let env = write_env();
    let text = format!(
        "[camera]\nposition = [0.0, 0.0, 5.0]\nfov = 30.0\n[render]\nwidth = 32\nheight = 24\nao = false\nshadows = \"none\"\n\
         [environment]\nimage = {:?}\n\
         [[light]]\nintensity = 0.0\n\
         [material.mirror]\nambient = [0.0, 0.0, 0.0]\ndiffuse = [0.0, 0.0, 0.0]\nspecular = [0.0, 0.0, 0.0]\nreflectivity = 1.0\nfresnel = false\n\
         [[object]]\nmaterial = \"mirror\"\nshape = \"sphere(p, 1.0)\"\n",
        env.display().to_string()
    );
    let scene = load_str(&text, "env.toml", &[]).unwrap();
    let (img, _) = render(&scene, &RenderOptions::default());
    // The background, straight ahead (−z), is blue; the mirror's centre reflects
    // the direction back towards the camera (+z), which is red.
    let corner = img.color[0];
    let centre = img.color[(12 * 32 + 16) as usize];
    assert!(corner[2] > 0.9 && corner[0] < 0.1, "{corner:?}");
    assert!(centre[0] > 0.9 && centre[2] < 0.1, "{centre:?}");
    // Errors name the key and the file.
    let bad = text.replace(&env.display().to_string(), "/no/such/map.hdr");
    let e = load_str(&bad, "env.toml", &[]).unwrap_err();
    assert!(
        e.message.contains("environment.image") && e.message.contains("/no/such/map.hdr"),
        "{e}"
    );
    assert_eq!(e.line, Some(10));
}

const NESTED: &str = r#"
[camera]
position = [0.0, 0.3, 6.0]
target = [0.0, 0.0, 0.0]
fov = 30.0
[render]
width = 48
height = 36
shadows = "none"
ao = false
background = [0.5, 0.5, 0.5]
[[light]]
intensity = 0.0
[material.block]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
transparency = 1.0
ior = 1.5
fresnel = false
[material.inner]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
transparency = 1.0
ior = 1.5
fresnel = false
[material.lamp]
emission = [1.0, 0.2, 0.1]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
[material.stripe]
emission = [0.0, 1.0, 0.0]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
[[object]]
material = "block"
shape = "box(p, vec3(1.2, 1.0, 1.0))"
[[object]]
material = "stripe"
shape = "box(p - vec3(0.0, 0.5, -4.0), vec3(10.0, 0.3, 0.1))"
"#;

#[test]
fn nested_objects_keep_track_of_the_medium() {
    let render_text = |extra: &str| {
        let scene = load_str(&format!("{NESTED}{extra}"), "n.toml", &[]).unwrap();
        render(&scene, &RenderOptions::default()).0.color
    };
    let plain = render_text("");
    // A glass sphere of the same index inside the block changes nothing: the
    // ray enters it and leaves it back into the block, not into air.
    let same = render_text("[[object]]\nmaterial = \"inner\"\nshape = \"sphere(p, 0.6)\"\n");
    let differing = plain
        .iter()
        .zip(&same)
        .filter(|(a, b)| (a[0] - b[0]).abs() + (a[1] - b[1]).abs() + (a[2] - b[2]).abs() > 0.05)
        .count();
    assert!(differing <= 10, "{differing} pixels differ");
    // An opaque lamp inside the block is seen through it.
    let lamp = render_text("[[object]]\nmaterial = \"lamp\"\nshape = \"sphere(p, 0.4)\"\n");
    let centre = lamp[(18 * 48 + 24) as usize];
    assert!(
        (centre[0] - 1.0).abs() < 0.05 && (centre[1] - 0.2).abs() < 0.05,
        "{centre:?}"
    );
    // And some of the stripe behind the block is seen through the glass.
    assert!(plain.iter().any(|c| c[1] > 0.9 && c[0] < 0.1));
}

#[test]
fn thin_glass_shells_are_crossed_wall_by_wall() {
    // A shell 0.005 thick (onion of a sphere): a ray through the centre
    // crosses two walls, 0.01 of glass in all, and keeps exp(−50 · 0.01) of
    // its red. Skipping a wall (tunnelling) or re-finding a wall just left
    // would change that.
    let text = r#"
[camera]
position = [0.0, 0.0, 5.0]
fov = 20.0
[render]
width = 9
height = 9
shadows = "none"
ao = false
background = [1.0, 1.0, 1.0]
[[light]]
intensity = 0.0
[material.shell]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
transparency = 1.0
ior = 1.0
fresnel = false
absorption = [50.0, 0.0, 0.0]
[[object]]
material = "shell"
shape = "onion(sphere(p, 1.0), 0.0025)"
"#;
    let scene = load_str(text, "shell.toml", &[]).unwrap();
    let (img, stats) = render(&scene, &RenderOptions::default());
    let centre = img.color[4 * 9 + 4];
    assert!((centre[0] - (-0.5f32).exp()).abs() < 0.02, "{centre:?}");
    assert!((centre[1] - 1.0).abs() < 1e-3, "{centre:?}");
    assert!(stats.rays.refracted >= 4 * 9, "{:?}", stats.rays);
}

#[test]
fn checker_materials_alternate_by_cell() {
    // The mirror scene with a plane whose material is a checker instead of
    // tiles: the cells are [k, k + 1) in x and z (y ≈ 0 on the floor).
    let text = CHECKER
        .split("[[object]]")
        .next()
        .unwrap()
        .replace("[material.white]\n", "[material.white]\nchecker = \"black\"\n")
        + "[[object]]\nmaterial = \"white\"\nshape = \"plane(p, vec3(0.0, 1.0, 0.0), 0.0)\"\n";
    let scene = load_str(&text, "checker.toml", &[]).unwrap();
    let (img, _) = render(&scene, &RenderOptions::default());
    let cam = RayCamera::new(&scene.camera, W, H);
    let o = cam.origin();
    let (mut white, mut black) = (0, 0);
    for j in 0..H {
        for i in 0..W {
            let d = cam.direction(i as f64 + 0.5, j as f64 + 0.5);
            if d.y >= -0.05 {
                continue;
            }
            let q = o + d * (-o.y / d.y);
            let (fx, fz) = (q.x - q.x.floor(), q.z - q.z.floor());
            if [fx, 1.0 - fx, fz, 1.0 - fz].into_iter().fold(1.0, f64::min) < 0.1 || (q - o).length() > 10.0 {
                continue;
            }
            let odd = (q.x.floor() as i64 + q.z.floor() as i64).rem_euclid(2) == 1;
            let got = img.color[(j * W + i) as usize][0];
            if odd {
                black += 1;
                assert!(got < 0.05, "({i}, {j}) at {q}: {got}");
            } else {
                white += 1;
                assert!(got > 0.95, "({i}, {j}) at {q}: {got}");
            }
        }
    }
    assert!(white > 50 && black > 50, "{white} {black}");
    // The other material must exist.
    let e = load_str(
        &text.replace("checker = \"black\"", "checker = \"blak\""),
        "c.toml",
        &[],
    )
    .unwrap_err();
    assert!(e.message.contains("no material named \"blak\""), "{e}");
}

/// A plane and a sphere (closed forms) and a torus (marched).
const PLANE_SPHERE_TORUS: &str = r#"[[object]]
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"
[[object]]
shape = "sphere(p - vec3(-1.0, 0.8, 0.0), 0.8)"
[[object]]
shape = "torus(p - vec3(1.2, 0.4, 0.0), 0.7, 0.3)"
"#;

#[test]
fn closed_form_planes_and_spheres_give_the_marched_depths() {
    // Spheres and the plane are intersected in closed form by default; the
    // depth must be what marching finds (within the hit epsilon).
    let text = &format!(
        "[camera]\nposition = [0.0, 2.0, 6.0]\ntarget = [0.0, 0.5, 0.0]\n[render]\nwidth = 48\nheight = 32\n[[light]]\n{PLANE_SPHERE_TORUS}"
    );
    let aovs = RenderOptions {
        aovs: true,
        ..RenderOptions::default()
    };
    let closed = load_str(text, "a.toml", &[]).unwrap();
    assert!(
        closed.derived().analytic[0].is_some()
            && closed.derived().analytic[1].is_some()
            && closed.derived().analytic[2].is_none()
    );
    let marched = load_str(text, "a.toml", &["render.analytic=false".to_string()]).unwrap();
    assert!(marched.derived().rest.is_none());
    let (a, _) = render(&closed, &aovs);
    let (b, _) = render(&marched, &aovs);
    let (da, db) = (a.depth.unwrap(), b.depth.unwrap());
    let mut far = 0;
    for (x, y) in da.iter().zip(&db) {
        if x.is_finite() && y.is_finite() {
            // Grazing rays near the horizon may run out of marching steps.
            if (x - y).abs() > 1e-3 * x.max(1.0) {
                far += 1;
            }
        } else {
            assert_eq!(x.is_finite(), y.is_finite());
        }
    }
    assert!(far <= da.len() / 50, "{far} of {} depths differ", da.len());
}

#[test]
fn touching_glass_blocks_act_as_one() {
    // Two glass blocks of the same index sharing a face bend light exactly as
    // one block of their union: the ray leaves one and enters the other at once.
    let base = NESTED.replace(
        "[[object]]\nmaterial = \"block\"\nshape = \"box(p, vec3(1.2, 1.0, 1.0))\"\n",
        "",
    );
    let one = format!("{base}[[object]]\nmaterial = \"block\"\nshape = \"box(p, vec3(1.2, 1.0, 1.0))\"\n");
    let two = format!(
        "{base}[[object]]\nmaterial = \"block\"\nshape = \"box(p - vec3(0.0, 0.0, 0.5), vec3(1.2, 1.0, 0.5))\"\n\
         [[object]]\nmaterial = \"inner\"\nshape = \"box(p + vec3(0.0, 0.0, 0.5), vec3(1.2, 1.0, 0.5))\"\n"
    );
    let img = |t: &str| {
        render(&load_str(t, "t.toml", &[]).unwrap(), &RenderOptions::default())
            .0
            .color
    };
    let (a, b) = (img(&one), img(&two));
    let differing = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| (x[0] - y[0]).abs() + (x[1] - y[1]).abs() + (x[2] - y[2]).abs() > 0.05)
        .count();
    assert!(differing <= a.len() / 50, "{differing} of {} pixels differ", a.len());
    assert!(
        a.iter().any(|c| c[1] > 0.9 && c[0] < 0.1),
        "the stripe is seen through the glass"
    );
}

#[test]
fn closed_form_hard_shadows_match_marched_ones() {
    // Hard shadow rays meet planes and spheres in closed form and march the
    // rest (here a torus, and with a glass sphere the opaque rest while the
    // glass transmits): the picture is the marched one but for a few rays
    // that graze a shadow's edge.
    let base = r#"
[camera]
position = [0.0, 2.0, 6.0]
target = [0.0, 0.5, 0.0]
[render]
width = 64
height = 48
shadows = "hard"
ao = false
[[light]]
kind = "point"
position = [-3.0, 5.0, 3.0]
[material.glass]
transparency = 0.9
ior = 1.4
"#;
    let base = format!("{base}{PLANE_SPHERE_TORUS}");
    let glass = format!("{base}[[object]]\nmaterial = \"glass\"\nshape = \"sphere(p - vec3(0.3, 1.6, 1.0), 0.4)\"\n");
    for text in [base.clone(), glass] {
        let closed = load_str(&text, "a.toml", &[]).unwrap();
        assert!(closed.derived().rest.is_some());
        let marched = load_str(&text, "a.toml", &["render.analytic=false".to_string()]).unwrap();
        let unshadowed = load_str(&text, "a.toml", &["render.shadows=none".to_string()]).unwrap();
        let img = |s: &isoray_scene::Scene| render(s, &RenderOptions::default()).0.color;
        let (a, b, c) = (img(&closed), img(&marched), img(&unshadowed));
        let differ = |x: &[[f32; 3]], y: &[[f32; 3]], by: f32| {
            x.iter()
                .zip(y)
                .filter(|(p, q)| (p[0] - q[0]).abs() + (p[1] - q[1]).abs() + (p[2] - q[2]).abs() > by)
                .count()
        };
        assert!(
            differ(&a, &b, 0.05) <= a.len() / 100,
            "{} of {} pixels differ",
            differ(&a, &b, 0.05),
            a.len()
        );
        // There are shadows to get right.
        assert!(
            differ(&a, &c, 0.1) > a.len() / 50,
            "only {} shadowed pixels",
            differ(&a, &c, 0.1)
        );
    }
}
