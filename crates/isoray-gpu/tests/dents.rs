//! Normal mapping on the GPU: a turned, moved plate with a planar dent
//! map and a ball with a spherical one, each dented by a ball pressed
//! into it, draw on the GPU as on the CPU: the shading normals (the
//! normals AOV) agree with the CPU's over the dents, where they differ
//! from the undented surface's by tens of degrees, and the colours agree.

use std::sync::Arc;

use isoray_dent::field::March;
use isoray_dent::imprint::{imprint_texel, Sphere};
use isoray_gpu::{GpuRenderOptions, GpuRenderer};
use isoray_render::{render, RenderOptions, RenderedImage};
use isoray_shade::srgb::to_srgb8;

const W: u32 = 128;
const H: u32 = 96;

fn scene() -> isoray_scene::Scene {
    let text = format!(
        "[camera]\nposition = [0.0, 2.2, 3.2]\ntarget = [0.0, 0.2, 0.0]\nfov = 40.0\n\
         [render]\nwidth = {W}\nheight = {H}\nshadows = \"hard\"\nao = false\n\
         [[light]]\nkind = \"directional\"\ndirection = [-0.6, 0.8, 0.3]\n\
         [material.m]\ndiffuse = [0.7, 0.7, 0.7]\nspecular = [0.4, 0.4, 0.4]\nshininess = 30.0\n\
         [[object]]\nname = \"plate\"\nshape = \"box(p, vec3(1.0, 0.1, 1.0))\"\nmaterial = \"m\"\n\
         position = [-0.3, 0.0, 0.0]\nrotation = [0.0, 30.0, 8.0]\n\
         dents = \"bump\"\ndent_map = {{ size = 256, range = 0.4, uv = \"planar-xz\", extent = 1.0 }}\n\
         [[object]]\nname = \"ball\"\nshape = \"sphere(p, 0.5)\"\nmaterial = \"m\"\nposition = [0.9, 0.6, 0.4]\n\
         dents = \"bump\"\ndent_map = {{ size = 256, range = 0.4, uv = \"spherical\", extent = 0.5 }}\n"
    );
    isoray_scene::load_str(&text, "dents.toml", &[]).unwrap_or_else(|e| panic!("{e}"))
}

/// Presses a ball of radius r, centred at `c` (the object's own
/// coordinates), into object `i`'s map, whose own distance is `own`.
fn dent(s: &mut isoray_scene::Scene, i: usize, own: &dyn Fn([f64; 3]) -> f64, c: [f64; 3], r: f64) {
    let mut maps = s.objects[i].physics.dent_map.blank().unwrap();
    let ball = |p: [f64; 3]| ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt() - r;
    let mapping = maps.mapping.clone();
    let out = imprint_texel(
        &mut maps.height,
        &mapping,
        &own,
        &ball,
        Sphere { centre: c, radius: r },
        March::default(),
    );
    assert!(out.lowered > 100, "{}", out.lowered);
    maps.update_normals();
    s.objects[i].physics.maps = Some(Arc::new(maps));
}

fn dented() -> isoray_scene::Scene {
    let mut s = scene();
    let plate = |p: [f64; 3]| {
        let q = [p[0].abs() - 1.0, p[1].abs() - 0.1, p[2].abs() - 1.0];
        let o = q.map(|x| x.max(0.0));
        (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt() + q[0].max(q[1]).max(q[2]).min(0.0)
    };
    dent(&mut s, 0, &plate, [0.1, 0.1 + 0.35 - 0.07, 0.2], 0.35);
    let ball = |p: [f64; 3]| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 0.5;
    // Facing the camera and the light: up and towards +z, −x.
    let n = [-0.3f64, 0.5, 0.81];
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let c = n.map(|x| x / l * (0.5 + 0.2 - 0.05));
    dent(&mut s, 1, &ball, c, 0.2);
    s
}

fn cpu(s: &isoray_scene::Scene) -> RenderedImage {
    let opts = RenderOptions {
        aovs: true,
        ..Default::default()
    };
    render(s, &opts).0
}

fn gpu(g: &mut GpuRenderer, s: &isoray_scene::Scene) -> RenderedImage {
    let opts = GpuRenderOptions {
        aovs: true,
        ..Default::default()
    };
    g.render(s, &opts).unwrap_or_else(|e| panic!("{e}")).0
}

fn angle(a: [f32; 3], b: [f32; 3]) -> f64 {
    let d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) as f64;
    d.clamp(-1.0, 1.0).acos().to_degrees()
}

#[test]
fn dent_maps_shade_on_the_gpu_as_on_the_cpu() {
    let Ok(mut g) = GpuRenderer::new() else {
        eprintln!("no GPU adapter (install mesa-vulkan-drivers): skipped");
        return;
    };
    let flat = cpu(&scene());
    let s = dented();
    let (c, d) = (cpu(&s), gpu(&mut g, &s));
    let (cn, dn, fln) = (
        c.normals.as_ref().unwrap(),
        d.normals.as_ref().unwrap(),
        flat.normals.as_ref().unwrap(),
    );
    let (cd, dd) = (c.depth.as_ref().unwrap(), d.depth.as_ref().unwrap());
    // The dents' pixels: where the CPU's normal is tilted from the flat one.
    let mut dent_px = 0;
    let mut agree = 0;
    let mut tilt: f64 = 0.0;
    for i in 0..cn.len() {
        if !(cd[i].is_finite() && dd[i].is_finite()) || (cd[i] - dd[i]).abs() > 1e-3 * cd[i] {
            continue;
        }
        let t = angle(cn[i], fln[i]);
        if t > 2.0 {
            dent_px += 1;
            tilt = tilt.max(t);
            agree += usize::from(angle(cn[i], dn[i]) < 0.5);
        }
    }
    assert!(dent_px > 150, "{dent_px} dent pixels");
    assert!(tilt > 20.0, "the dents tilt the normals by up to {tilt}°");
    assert!(
        agree as f64 > 0.98 * dent_px as f64,
        "{agree} of {dent_px} dent pixels agree within 0.5°"
    );
    // The colours: mean within 1/255, 99 % of channels within 4/255.
    let (a, b) = (to_srgb8(&c.color), to_srgb8(&d.color));
    let mut diff: Vec<u8> = a.iter().zip(&b).map(|(x, y)| x.abs_diff(*y)).collect();
    let mean = diff.iter().map(|&x| x as f64).sum::<f64>() / diff.len() as f64;
    diff.sort_unstable();
    assert!(
        mean < 1.0 && diff[diff.len() * 99 / 100] <= 4,
        "mean {mean}, p99 {}",
        diff[diff.len() * 99 / 100]
    );
    // The same maps a second time come from the cache: the same image.
    let again = gpu(&mut g, &s);
    assert_eq!(again.color, d.color);
    // Parallax mapping: each mode moves the CPU's normals over the dents,
    // and the GPU's follow.
    for mode in [
        isoray_scene::Parallax::Offset,
        isoray_scene::Parallax::Steep,
        isoray_scene::Parallax::Occlusion,
    ] {
        let mut p = s.clone();
        p.render.parallax = mode;
        let (c2, d2) = (cpu(&p), gpu(&mut g, &p));
        let (c2n, d2n) = (c2.normals.as_ref().unwrap(), d2.normals.as_ref().unwrap());
        let (c2d, d2d) = (c2.depth.as_ref().unwrap(), d2.depth.as_ref().unwrap());
        let (mut moved, mut px, mut agree) = (0, 0, 0);
        for i in 0..c2n.len() {
            if !(c2d[i].is_finite() && d2d[i].is_finite()) || angle(cn[i], fln[i]) <= 2.0 {
                continue;
            }
            px += 1;
            moved += usize::from(angle(c2n[i], cn[i]) > 1.0);
            agree += usize::from(angle(c2n[i], d2n[i]) < 0.5);
        }
        assert!(moved * 4 > px, "{mode:?}: parallax moved {moved} of {px} dent pixels");
        assert!(
            agree as f64 > 0.95 * px as f64,
            "{mode:?}: {agree} of {px} agree within 0.5°"
        );
    }
}
