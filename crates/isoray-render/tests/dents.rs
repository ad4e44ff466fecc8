//! Dented objects drawn by normal mapping, by the ray tracer and by the
//! polygon pipeline: a dent written into a plate's height map shades like
//! the same dent cut into the plate's geometry (a ball subtracted), also
//! when the plate is turned and moved; nothing changes away from the
//! dent; an untouched map changes nothing.

use std::sync::Arc;

use isoray_dent::field::March;
use isoray_dent::imprint::{imprint_texel, Sphere};
use isoray_render::{render, RenderOptions};

const R: f64 = 0.4;
const D: f64 = 0.08;
/// The plate: a box of half height 0.1, its top at y = 0.1.
const PLATE: &str = "box(p, vec3(1.0, 0.1, 1.0))";
const TOP: f64 = 0.1;

fn scene(shape: &str, placement: &str) -> isoray_scene::Scene {
    let text = format!(
        "[camera]\nposition = [0.0, 1.6, 1.6]\ntarget = [0.0, 0.0, 0.0]\nfov = 30.0\n\
         [render]\nwidth = 120\nheight = 90\nshadows = \"none\"\nao = false\n\
         [[light]]\nkind = \"directional\"\ndirection = [-0.7, 0.6, 0.3]\n\
         [material.m]\ndiffuse = [0.8, 0.8, 0.8]\nspecular = [0.0, 0.0, 0.0]\n\
         [[object]]\nname = \"plate\"\nshape = \"{shape}\"\nmaterial = \"m\"\n{placement}\
         dents = \"bump\"\ndent_map = {{ size = 512, range = 0.4, uv = \"planar-xz\", extent = 1.0 }}\n"
    );
    isoray_scene::load_str(&text, "dents.toml", &[]).unwrap_or_else(|e| panic!("{e}"))
}

/// The plate with a dent of depth D by a ball of radius R at the middle of
/// its top, in its map.
fn dented(placement: &str) -> isoray_scene::Scene {
    let mut s = scene(PLATE, placement);
    let mut maps = s.objects[0].physics.dent_map.blank().unwrap();
    let plate = |p: [f64; 3]| {
        let q = [p[0].abs() - 1.0, p[1].abs() - TOP, p[2].abs() - 1.0];
        let o = [q[0].max(0.0), q[1].max(0.0), q[2].max(0.0)];
        (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt() + q[0].max(q[1]).max(q[2]).min(0.0)
    };
    let ball = |p: [f64; 3]| (p[0] * p[0] + (p[1] - (TOP + R - D)).powi(2) + p[2] * p[2]).sqrt() - R;
    let reach = Sphere {
        centre: [0.0, TOP + R - D, 0.0],
        radius: R,
    };
    let out = imprint_texel(
        &mut maps.height,
        &maps.mapping.clone(),
        &plate,
        &ball,
        reach,
        March::default(),
    );
    assert!(out.lowered > 1000);
    maps.update_normals();
    s.objects[0].physics.maps = Some(Arc::new(maps));
    s
}

/// A renderer: the colours of a scene's image.
type Draw = fn(&isoray_scene::Scene) -> Vec<[f32; 3]>;

fn traced(s: &isoray_scene::Scene) -> Vec<[f32; 3]> {
    render(s, &RenderOptions::default()).0.color
}

fn rastered(s: &isoray_scene::Scene) -> Vec<[f32; 3]> {
    let opts = isoray_raster::render::RasterOptions {
        resolution: 160,
        ..Default::default()
    };
    isoray_raster::render::raster(s, &opts).unwrap().color
}

fn lum(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Mean |a − b| of the luminance over the pixels whose `inside` is `on`.
fn mean_diff(a: &[[f32; 3]], b: &[[f32; 3]], inside: &[bool], on: bool) -> f64 {
    let (mut sum, mut n) = (0.0, 0);
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        if inside[i] == on {
            sum += (lum(*x) - lum(*y)).abs() as f64;
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

#[test]
fn a_bump_dent_shades_like_the_same_dent_in_the_geometry_in_both_renderers() {
    let renderers: [(&str, Draw); 2] = [("trace", traced), ("raster", rastered)];
    for (name, draw) in renderers {
        for placement in ["", "position = [0.1, -0.05, 0.0]\nrotation = [10.0, 25.0, 0.0]\n"] {
            let flat = draw(&scene(PLATE, placement));
            let bump = draw(&dented(placement));
            let cut = format!("max({PLATE}, -(length(p - vec3(0.0, {}, 0.0)) - {R}))", TOP + R - D);
            let geometry = draw(&scene(&cut, placement));
            // The dent's pixels: where the cut plate differs from the flat one.
            let inside: Vec<bool> = flat
                .iter()
                .zip(&geometry)
                .map(|(a, b)| (lum(*a) - lum(*b)).abs() > 0.02)
                .collect();
            let n = inside.iter().filter(|&&x| x).count();
            assert!(n > 300, "{name} {placement:?}: the dent covers {n} pixels");
            let dent = mean_diff(&flat, &geometry, &inside, true);
            let err = mean_diff(&bump, &geometry, &inside, true);
            eprintln!("{name} {placement:?}: {n} dent pixels; mean luminance error bump {err:.4}, flat {dent:.4}");
            assert!(
                err < 0.3 * dent,
                "{name} {placement:?}: bump vs geometry {err:.4}, flat vs geometry {dent:.4}"
            );
            assert!(mean_diff(&bump, &flat, &inside, false) < 2e-3, "{name} {placement:?}");
        }
    }
}

#[test]
fn an_untouched_map_changes_nothing() {
    let mut s = scene("p.y", "");
    let before = traced(&s);
    s.objects[0].physics.maps = Some(Arc::new(s.objects[0].physics.dent_map.blank().unwrap()));
    let after = traced(&s);
    for (a, b) in before.iter().zip(&after) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() < 1e-4, "{a:?} vs {b:?}");
        }
    }
}
