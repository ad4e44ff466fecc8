//! Dented objects drawn by normal mapping: a dent written into a plate's
//! height map shades like the same dent cut into the plate's geometry (a
//! ball subtracted), also when the plate is turned and moved; an
//! untouched map changes nothing.

use std::sync::Arc;

use isoray_dent::field::March;
use isoray_dent::imprint::{imprint_texel, Sphere};
use isoray_render::{render, RenderOptions, RenderedImage};

const R: f64 = 0.4;
const D: f64 = 0.08;

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

/// The plate with a dent of depth D by a ball of radius R at its origin, in its map.
fn dented(placement: &str) -> isoray_scene::Scene {
    let mut s = scene("max(p.y, -p.y - 0.2)", placement);
    let mut maps = s.objects[0].physics.dent_map.blank().unwrap();
    let plate = |p: [f64; 3]| p[1].max(-p[1] - 0.2);
    let ball = |p: [f64; 3]| (p[0] * p[0] + (p[1] - (R - D)).powi(2) + p[2] * p[2]).sqrt() - R;
    let reach = Sphere {
        centre: [0.0, R - D, 0.0],
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

fn image(s: &isoray_scene::Scene) -> RenderedImage {
    render(s, &RenderOptions::default()).0
}

/// Mean |a − b| of the luminance over the pixels marked `inside`.
fn mean_diff(a: &RenderedImage, b: &RenderedImage, inside: &[bool]) -> f64 {
    let lum = |c: [f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let (mut sum, mut n) = (0.0, 0);
    for (i, &on) in inside.iter().enumerate() {
        if on {
            sum += (lum(a.color[i]) - lum(b.color[i])).abs() as f64;
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

#[test]
fn a_bump_dent_shades_like_the_same_dent_in_the_geometry() {
    for placement in ["", "position = [0.1, -0.05, 0.0]\nrotation = [10.0, 25.0, 0.0]\n"] {
        let flat = image(&scene("max(p.y, -p.y - 0.2)", placement));
        let bump = image(&dented(placement));
        let cut = format!(
            "max(max(p.y, -p.y - 0.2), -(length(p - vec3(0.0, {}, 0.0)) - {R}))",
            R - D
        );
        let geometry = image(&scene(&cut, placement));
        // The dent's pixels: where the cut plate differs from the flat one.
        let lum = |c: [f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        let inside: Vec<bool> = flat
            .color
            .iter()
            .zip(&geometry.color)
            .map(|(a, b)| (lum(*a) - lum(*b)).abs() > 0.02)
            .collect();
        let n = inside.iter().filter(|&&x| x).count();
        assert!(n > 300, "{placement}: the dent covers {n} pixels");
        let dent = mean_diff(&flat, &geometry, &inside);
        let err = mean_diff(&bump, &geometry, &inside);
        eprintln!("{placement:?}: {n} dent pixels; mean luminance error bump {err:.4}, flat {dent:.4}");
        assert!(
            err < 0.25 * dent,
            "{placement}: bump vs geometry {err:.4}, flat vs geometry {dent:.4}"
        );
        // Away from the dent, the bump changes nothing.
        let outside: Vec<bool> = inside.iter().map(|x| !x).collect();
        assert!(mean_diff(&bump, &flat, &outside) < 2e-3, "{placement}");
    }
}

#[test]
fn an_untouched_map_changes_nothing() {
    let mut s = scene("p.y", "");
    let before = image(&s);
    s.objects[0].physics.maps = Some(Arc::new(s.objects[0].physics.dent_map.blank().unwrap()));
    let after = image(&s);
    for (a, b) in before.color.iter().zip(&after.color) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() < 1e-4, "{a:?} vs {b:?}");
        }
    }
}
