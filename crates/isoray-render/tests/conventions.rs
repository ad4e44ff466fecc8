//! The Unity thesis's shading conventions (realtime-raymarcher.md §5.4),
//! against values worked by hand: a floor point in the hard shadow of a
//! ball, lit by a directional light at 45°.

use isoray_render::{render, RenderOptions};
use isoray_scene::load_str;

/// The camera looks straight at the plane z = 0 (the centre pixel hits the
/// origin); the light comes from (1, 0, 1)/√2; a ball at (1.5, 0, 1.5),
/// outside the view, shadows the origin. Material: ambient 0.1, diffuse
/// 0.8, no specular: lit, the origin is 0.1 + 0.8·cos 45° = 0.6657.
const SCENE: &str = r#"
[camera]
position = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov = 20.0
[render]
width = 9
height = 9
shadows = "hard"
ao = false
background = [0.0, 0.0, 1.0]
[[light]]
kind = "directional"
direction = [1.0, 0.0, 1.0]
[material.m]
ambient = [0.1, 0.1, 0.1]
diffuse = [0.8, 0.8, 0.8]
specular = [0.0, 0.0, 0.0]
[[object]]
material = "m"
shape = "plane(p, vec3(0.0, 0.0, 1.0), 0.0)"
[[object]]
material = "m"
shape = "sphere(p - vec3(1.5, 0.0, 1.5), 0.5)"
"#;

fn centre(overrides: &[&str]) -> [f32; 3] {
    let ov: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let scene = load_str(SCENE, "conventions.toml", &ov).unwrap_or_else(|e| panic!("{e}"));
    let (img, _) = render(&scene, &RenderOptions::default());
    img.color[4 * 9 + 4]
}

fn close(got: [f32; 3], want: f32) {
    for c in got {
        assert!((c - want).abs() < 1e-4, "got {got:?}, want {want}");
    }
}

const COS45: f32 = std::f32::consts::FRAC_1_SQRT_2;

#[test]
fn in_full_shadow_only_the_ambient_term_is_left() {
    close(centre(&[]), 0.1);
    close(centre(&["render.shadows=none"]), 0.1 + 0.8 * COS45);
}

#[test]
fn a_shadow_floor_lets_that_fraction_of_the_direct_light_through() {
    close(centre(&["render.shadow_floor=0.5"]), 0.1 + 0.5 * 0.8 * COS45);
}

#[test]
fn shadows_applied_to_all_darken_the_ambient_term_too() {
    close(
        centre(&["render.shadow_floor=0.5", "render.shadow_applies_to=\"all\""]),
        0.5 * (0.1 + 0.8 * COS45),
    );
    // With no floor the whole point is black.
    close(centre(&["render.shadow_applies_to=\"all\""]), 0.0);
}

#[test]
fn the_scene_ambient_light_is_multiplied_by_the_diffuse_colour() {
    close(centre(&["render.ambient=[0.2, 0.2, 0.2]"]), 0.1 + 0.2 * 0.8);
}

#[test]
fn a_ray_out_of_steps_is_a_hit_or_a_miss() {
    // Marched (not in closed form), one step from the camera lands exactly
    // on the plane (d = 5).
    close(centre(&["render.max_steps=1", "render.analytic=false"]), 0.1);
    let miss = centre(&[
        "render.max_steps=1",
        "render.analytic=false",
        "render.on_step_limit=\"miss\"",
    ]);
    assert_eq!(miss, [0.0, 0.0, 1.0]);
}

#[test]
fn ao_weights_and_what_ao_darkens() {
    // AO samples along the normal at h = 1 and 2: at 1 the plane is the
    // nearest (no occlusion), at 2 the ball is, √2.5 − 0.5 away.
    let lit = 0.1 + 0.8 * COS45;
    let occ2 = (2.0 - (2.5f32.sqrt() - 0.5)) / 2.0;
    let base = [
        "render.shadows=none",
        "render.ao=true",
        "render.ao_samples=2",
        "render.ao_step=1.0",
    ];
    // Halving weights 2/3, 1/3; AO darkens the ambient term.
    close(centre(&base), 0.1 * (1.0 - occ2 / 3.0) + 0.8 * COS45);
    // Uniform weights 1, 1 (the plain sum); AO darkens everything.
    let mut all = base.to_vec();
    all.push("render.ao_applies_to=\"all\"");
    all.push("render.ao_weights=\"uniform\"");
    close(centre(&all), lit * (1.0 - occ2));
}

/// Aaltonen's improved soft shadow estimates the closest approach between
/// two steps from their spheres: for a ray passing a ball it never lets
/// more light through than the exact k·h/t at the closest approach (the
/// plain soft estimate does, by 2 % at h = 1.5), and is within 15 % of it.
#[test]
fn aaltonens_shadow_finds_the_closest_approach() {
    use isoray_render::trace::{shadow_march, Field, Rays, Scratch};
    use isoray_scene::ShadowMode;
    let text = "[[object]]\nshape = \"sphere(p - vec3(0.0, 0.0, 5.0), 1.0)\"\n";
    let scene = load_str(text, "ball.toml", &["render.shadow_start=0.01".into()]).unwrap();
    let tape = scene.objects[0].shape.tape();
    // From (0, h, 0) along +z: the closest approach to the centre is h at t = 5.
    for h in [1.05f32, 1.2, 1.5] {
        let exact = (h - 1.0) / 5.0; // size 1: k = 1
        let mut rays = Rays::default();
        rays.push([0.0, h, 0.0], [0.0, 0.0, 1.0]);
        let est = |mode| {
            let mut field = Field::new(tape, &scene.inputs);
            let mut vis = Vec::new();
            shadow_march(
                &mut field,
                &rays,
                &[10.0],
                mode,
                1.0,
                &scene.render,
                &mut Scratch::default(),
                &mut vis,
            );
            vis[0]
        };
        let (soft, aaltonen) = (est(ShadowMode::Soft), est(ShadowMode::Aaltonen));
        assert!(
            aaltonen <= exact * 1.0001,
            "h {h}: aaltonen {aaltonen} leaks light (exact {exact})"
        );
        assert!(aaltonen >= 0.85 * exact, "h {h}: aaltonen {aaltonen}, exact {exact}");
        assert!(
            (soft - exact).abs() <= 0.05 * exact,
            "h {h}: soft {soft}, exact {exact}"
        );
    }
}

/// Fixed-step raymarching (the Granada thesis's Algorithm 7): the hit is
/// the first step whose distance is below the epsilon, so depths come in
/// multiples of the step, and a slab thinner than a step is missed.
#[test]
fn fixed_steps_land_on_multiples_of_the_step_and_miss_thin_slabs() {
    let text = r#"
[camera]
position = [0.0, 0.0, 1.0]
target = [0.0, 0.0, 0.0]
fov = 10.0
[render]
width = 3
height = 3
analytic = false
max_distance = 50.0
[[object]]
shape = "SHAPE"
"#;
    let depth = |shape: &str, over: &[&str]| {
        let ov: Vec<String> = over.iter().map(|s| s.to_string()).collect();
        let scene = load_str(&text.replace("SHAPE", shape), "fixed.toml", &ov).unwrap_or_else(|e| panic!("{e}"));
        let opts = RenderOptions {
            aovs: true,
            ..Default::default()
        };
        render(&scene, &opts).0.depth.unwrap()[4]
    };
    let plane = "plane(p, vec3(0.0, 0.0, 1.0), 0.0)";
    let fixed = ["render.march=\"fixed\"", "render.fixed_step=0.3"];
    assert!((depth(plane, &[]) - 1.0).abs() < 1e-3);
    assert!((depth(plane, &fixed) - 1.2).abs() < 1e-5, "{}", depth(plane, &fixed));
    // A slab 0.05 thick at distance 1.0 … 1.05: steps at 0.9 and 1.2 jump it.
    let slab = "box(p + vec3(0.0, 0.0, 0.025), vec3(1.0, 1.0, 0.025))";
    assert!((depth(slab, &[]) - 1.0).abs() < 1e-3);
    assert!(depth(slab, &fixed).is_infinite());
}

/// `shadow_epsilon` sets the occluder threshold of shadow rays: a ball the
/// shadow ray passes 0.2 from lets the light through at the default
/// threshold (`hit_epsilon`, 1e-4) and stops it at 0.3.
#[test]
fn the_shadow_epsilon_is_the_occluder_threshold() {
    // The shadow ray from the origin along (1, 0, 1)/√2 passes 0.5 from the
    // centre (1.5 + 0.5/√2, 0, 1.5 − 0.5/√2); radius 0.3 leaves 0.2.
    let c = 0.5 * std::f32::consts::FRAC_1_SQRT_2;
    let ball = format!("sphere(p - vec3({}, 0.0, {}), 0.3)", 1.5 + c, 1.5 - c);
    let text = SCENE.replace("sphere(p - vec3(1.5, 0.0, 1.5), 0.5)", &ball);
    let at = |over: &[&str]| {
        let ov: Vec<String> = over.iter().map(|s| s.to_string()).collect();
        let scene = load_str(&text, "eps.toml", &ov).unwrap_or_else(|e| panic!("{e}"));
        render(&scene, &RenderOptions::default()).0.color[4 * 9 + 4]
    };
    close(at(&[]), 0.1 + 0.8 * COS45);
    close(at(&["render.shadow_epsilon=0.3"]), 0.1);
}
