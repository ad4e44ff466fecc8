//! Triangle meshes on the GPU: the renderer draws `[[mesh]]` tables as the
//! CPU does (the same tree, Möller–Trumbore, the mesh capping the march),
//! with shadows both ways: a mesh on an SDF floor and an SDF sphere on a
//! mesh floor, each darkening the floor under it; a sphere drawn as a mesh
//! looks like the sphere drawn as a distance field.

use std::path::{Path, PathBuf};

use isoray_gpu::{GpuRenderOptions, GpuRenderer};
use isoray_render::{render, RenderOptions, RenderedImage};
use isoray_shade::srgb::to_srgb8;

const W: u32 = 96;
const H: u32 = 72;

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("isoray-gpu-meshes-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    isoray_mesh::io::write(&d.join("sphere.obj"), &isoray_mesh::Mesh::uv_sphere(1.0, 48, 96)).unwrap();
    let quad = isoray_mesh::Mesh {
        positions: vec![
            [-20.0, 0.0, -20.0],
            [20.0, 0.0, -20.0],
            [20.0, 0.0, 20.0],
            [-20.0, 0.0, 20.0],
        ],
        triangles: vec![[0, 3, 2], [0, 2, 1]],
        ..isoray_mesh::Mesh::default()
    };
    isoray_mesh::io::write(&d.join("floor.obj"), &quad).unwrap();
    d
}

fn scene(d: &Path, name: &str, body: &str) -> isoray_scene::Scene {
    let text = format!(
        "[camera]\nposition = [0.0, 2.0, 5.0]\ntarget = [0.0, 0.8, 0.0]\n\
         [render]\nwidth = {W}\nheight = {H}\nshadows = \"hard\"\nao = false\n\
         [material.red]\ndiffuse = [0.8, 0.2, 0.1]\n[material.grey]\ndiffuse = [0.6, 0.6, 0.6]\n\
         [[light]]\nkind = \"directional\"\ndirection = [0.3, 1.0, 0.2]\n{body}"
    );
    let path = d.join(name);
    std::fs::write(&path, text).unwrap();
    isoray_scene::load(&path, &[]).unwrap_or_else(|e| panic!("{e}"))
}

fn gpu_image(gpu: &mut GpuRenderer, scene: &isoray_scene::Scene) -> RenderedImage {
    let opts = GpuRenderOptions {
        aovs: true,
        ..Default::default()
    };
    gpu.render(scene, &opts).unwrap_or_else(|e| panic!("{e}")).0
}

/// Mean and worst-1% differences of two images, in 1/255 of sRGB.
fn differ(a: &RenderedImage, b: &RenderedImage) -> (f64, u8) {
    let (a, b) = (to_srgb8(&a.color), to_srgb8(&b.color));
    let mut d: Vec<u8> = a.iter().zip(&b).map(|(x, y)| x.abs_diff(*y)).collect();
    let mean = d.iter().map(|&x| x as f64).sum::<f64>() / d.len() as f64;
    d.sort_unstable();
    (mean, d[d.len() * 99 / 100])
}

/// The luminance at the pixel nearest the image of the world point p.
fn at(scene: &isoray_scene::Scene, img: &RenderedImage, p: glam::Vec3) -> f32 {
    let cam = isoray_render::camera::RayCamera::new(&scene.camera, W, H);
    let o = cam.origin().as_vec3();
    let mut best = (0usize, f32::INFINITY);
    for y in 0..H {
        for x in 0..W {
            let dir = cam.direction(x as f64 + 0.5, y as f64 + 0.5).as_vec3();
            let off = (o + dir * (p - o).dot(dir) - p).length();
            if off < best.1 {
                best = ((y * W + x) as usize, off);
            }
        }
    }
    let c = img.color[best.0];
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

#[test]
fn meshes_draw_as_on_the_cpu_with_shadows_both_ways() {
    let d = dir();
    let mut gpu = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    let sdf_floor = "[[object]]\nshape = \"p.y\"\nmaterial = \"grey\"\n";
    let mesh_floor = "[[mesh]]\nfile = \"floor.obj\"\nmaterial = \"grey\"\n";
    let sdf_ball = "[[object]]\nshape = \"sphere(p, 0.5)\"\nposition = [0.0, 1.0, 0.0]\nmaterial = \"red\"\n";
    let mesh_ball = "[[mesh]]\nfile = \"sphere.obj\"\nposition = [0.0, 1.0, 0.0]\nscale = 0.5\nmaterial = \"red\"\n";
    // Under the ball along the light: its shadow's centre on the floor.
    let shadow = glam::Vec3::new(-0.3, 0.0, -0.2);
    for (floor, ball, what) in [
        (sdf_floor, mesh_ball, "a mesh ball on an SDF floor"),
        (mesh_floor, sdf_ball, "an SDF ball on a mesh floor"),
    ] {
        let open = scene(&d, "open.toml", floor);
        let open_img = gpu_image(&mut gpu, &open);
        let cast = scene(&d, "cast.toml", &format!("{floor}{ball}"));
        let img = gpu_image(&mut gpu, &cast);
        let (lit, dark) = (at(&open, &open_img, shadow), at(&cast, &img, shadow));
        assert!(lit > 0.2 && dark < 0.3 * lit, "{what}: {dark} in shadow vs {lit} lit");
        let (cpu, _) = render(
            &cast,
            &RenderOptions {
                aovs: true,
                ..Default::default()
            },
        );
        let (mean, p99) = differ(&cpu, &img);
        assert!(
            mean < 1.0 && p99 <= 8,
            "{what}: GPU vs CPU mean {mean}/255, 99th percentile {p99}/255"
        );
        // Depths agree wherever both hit.
        for (a, b) in cpu.depth.unwrap().iter().zip(img.depth.as_ref().unwrap()) {
            assert_eq!(a.is_finite(), b.is_finite());
            if a.is_finite() {
                assert!((a - b).abs() <= 1e-3 * a, "{what}: depth {a} vs {b}");
            }
        }
    }
    // The same sphere as a mesh and as a distance field, on the GPU.
    let as_sdf = gpu_image(&mut gpu, &scene(&d, "s.toml", &format!("{sdf_floor}{sdf_ball}")));
    let as_mesh = gpu_image(&mut gpu, &scene(&d, "m.toml", &format!("{sdf_floor}{mesh_ball}")));
    let (mean, p99) = differ(&as_sdf, &as_mesh);
    assert!(
        mean < 1.0 && p99 <= 16,
        "sphere: mesh vs SDF mean {mean}/255, 99th percentile {p99}/255"
    );
}

/// The share of pixels whose colours differ by more than 2/255.
fn share_differing(a: &RenderedImage, b: &RenderedImage) -> f64 {
    let (a, b) = (to_srgb8(&a.color), to_srgb8(&b.color));
    let n = a
        .chunks(3)
        .zip(b.chunks(3))
        .filter(|(x, y)| x.iter().zip(*y).any(|(p, q)| p.abs_diff(*q) > 2))
        .count();
    n as f64 / (a.len() / 3) as f64
}

#[test]
fn the_raster_prepass_serves_grid_primary_rays_and_matches_the_tree_walk() {
    let d = dir();
    let mut gpu = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    // A mesh ball in front of, and partly behind, an SDF ball, on an SDF floor.
    let body = "[[object]]\nshape = \"p.y\"\nmaterial = \"grey\"\n\
                [[object]]\nshape = \"sphere(p, 0.45)\"\nposition = [0.7, 0.9, 0.3]\nmaterial = \"red\"\n\
                [[mesh]]\nfile = \"sphere.obj\"\nposition = [0.0, 1.0, 0.0]\nscale = 0.6\nmaterial = \"red\"\n";
    scene(&d, "raster.toml", body);
    for (aa, pattern, rastered) in [
        (1, "grid", true),
        (2, "grid", true),
        (3, "grid", true),
        (2, "jittered", false),
    ] {
        let sets = [format!("render.aa={aa}"), format!("render.aa_pattern=\"{pattern}\"")];
        let s = isoray_scene::load(&d.join("raster.toml"), &sets).unwrap_or_else(|e| panic!("{e}"));
        let opts = |walk| GpuRenderOptions {
            aovs: true,
            no_mesh_raster: walk,
            ..Default::default()
        };
        let (prepass, _, timing) = gpu.render(&s, &opts(false)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(timing.mesh_raster, rastered, "aa {aa} {pattern}");
        let (walked, _, timing) = gpu.render(&s, &opts(true)).unwrap_or_else(|e| panic!("{e}"));
        assert!(!timing.mesh_raster);
        // The same triangles, intersected by the same test: at most a
        // few samples on triangle edges differ.
        let share = share_differing(&prepass, &walked);
        assert!(
            share < 0.002,
            "aa {aa} {pattern}: {:.3}% of pixels differ",
            100.0 * share
        );
        let hits = |img: &RenderedImage| img.depth.as_ref().unwrap().iter().filter(|t| t.is_finite()).count();
        assert_eq!(hits(&prepass), hits(&walked), "aa {aa} {pattern}: centre rays that hit");
    }
}
