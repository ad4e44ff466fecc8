//! Triangle meshes inside SDF scenes (`[[mesh]]`): a sphere drawn as a
//! mesh looks like the same sphere drawn as a distance field; meshes and
//! objects hide each other by depth; each casts shadows on the other.

use std::path::{Path, PathBuf};

use isoray_render::{render, RenderOptions, RenderedImage};

/// A square of side 2·half in the plane y = 0, facing +y, as OBJ.
fn write_quad_obj(path: &Path, half: f64) {
    let h = half;
    std::fs::write(
        path,
        format!(
            "v {} 0 {}\nv {h} 0 {}\nv {h} 0 {h}\nv {} 0 {h}\nf 1 4 3\nf 1 3 2\n",
            -h, -h, -h, -h
        ),
    )
    .unwrap();
}

/// A folder of the test's own, with the mesh files.
fn dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("isoray-meshes-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    isoray_mesh::io::write(&d.join("sphere.obj"), &isoray_mesh::Mesh::uv_sphere(1.0, 96, 192)).unwrap();
    write_quad_obj(&d.join("floor.obj"), 20.0);
    write_quad_obj(&d.join("card.obj"), 0.6);
    d
}

/// A point light up and to the right (for the first two tests).
const LIGHT: &str = "[[light]]\nkind = \"point\"\nposition = [3.0, 6.0, 4.0]\n";

const HEAD: &str = r#"
[camera]
position = [0.0, 2.0, 5.0]
target = [0.0, 0.8, 0.0]
[render]
width = 160
height = 120
shadows = "hard"
ao = false
[material.red]
diffuse = [0.8, 0.2, 0.1]
specular = [0.4, 0.4, 0.4]
[material.grey]
diffuse = [0.6, 0.6, 0.6]
"#;

fn draw(dir: &Path, name: &str, body: &str) -> RenderedImage {
    let path = dir.join(name);
    std::fs::write(&path, format!("{HEAD}{body}")).unwrap();
    let scene = isoray_scene::load(&path, &[]).unwrap_or_else(|e| panic!("{e}"));
    let opts = RenderOptions {
        aovs: true,
        ..RenderOptions::default()
    };
    render(&scene, &opts).0
}

fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

#[test]
fn a_sphere_as_a_mesh_looks_like_the_sphere_as_a_distance_field() {
    let d = dir("sphere");
    let floor = &format!("{LIGHT}[[object]]\nshape = \"p.y\"\nmaterial = \"grey\"\n");
    let sdf = draw(
        &d,
        "sdf.toml",
        &format!("{floor}[[object]]\nshape = \"sphere(p, 1.0)\"\nposition = [0.0, 1.0, 0.0]\nmaterial = \"red\"\n"),
    );
    // The mesh is the unit sphere, placed and scaled as a mesh is.
    let mesh = draw(
        &d,
        "mesh.toml",
        &format!(
            "{floor}[[mesh]]\nfile = \"sphere.obj\"\nposition = [0.0, 1.0, 0.0]\nrotation = [10.0, 20.0, 30.0]\nmaterial = \"red\"\n"
        ),
    );
    let n = sdf.color.len();
    let mut diffs: Vec<f32> = sdf
        .color
        .iter()
        .zip(&mesh.color)
        .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f32::max))
        .collect();
    let mean = diffs.iter().sum::<f32>() / n as f32;
    diffs.sort_by(f32::total_cmp);
    let p99 = diffs[n * 99 / 100];
    // Only silhouette pixels (the tessellation is within 1/4 pixel of the
    // sphere) and the shadow's edge differ.
    assert!(mean < 0.004, "mean difference {mean}");
    assert!(p99 < 0.05, "99th percentile {p99}");
    // The depths agree wherever both hit the sphere (the polygon lies
    // inside the sphere by at most 1 − cos(π/96)).
    let (ds, dm) = (sdf.depth.unwrap(), mesh.depth.unwrap());
    let centre = (60 * 160 + 80) as usize;
    assert!(
        (ds[centre] - dm[centre]).abs() < 2e-3,
        "{} vs {}",
        ds[centre],
        dm[centre]
    );
    let (ns, nm) = (sdf.normals.unwrap(), mesh.normals.unwrap());
    let dot: f32 = (0..3).map(|k| ns[centre][k] * nm[centre][k]).sum();
    assert!(dot > 0.9999, "normals {:?} {:?}", ns[centre], nm[centre]);
    assert_eq!(mesh.albedo.unwrap()[centre], [0.8, 0.2, 0.1]);
}

#[test]
fn meshes_and_objects_hide_each_other_by_depth() {
    let d = dir("depth");
    // A small card (mesh) standing in front of an SDF box, and an SDF
    // sphere in front of a large mesh wall.
    let scene = &format!(
        "{LIGHT}{}",
        "
[[object]]
shape = \"box(p, vec3(0.5))\"
position = [-1.2, 0.8, -1.0]
material = \"grey\"
[[mesh]]
file = \"card.obj\"
position = [-1.2, 0.8, 0.5]
rotation = [90.0, 0.0, 0.0]
material = \"red\"
[[mesh]]
file = \"floor.obj\"
position = [0.0, 0.0, -3.0]
rotation = [90.0, 0.0, 0.0]
material = \"grey\"
[[object]]
shape = \"sphere(p, 0.6)\"
position = [1.2, 0.8, 0.0]
material = \"red\"
"
    );
    let img = draw(&d, "depth.toml", scene);
    let depth = img.depth.unwrap();
    let cam = isoray_render::camera::RayCamera::new(
        &isoray_scene::load(&d.join("depth.toml"), &[]).unwrap().camera,
        160,
        120,
    );
    let origin = cam.origin().as_vec3();
    // The pixel looking at a world point p, and the distance to p.
    let look = |p: glam::Vec3| -> (usize, f32) {
        let mut best = (0usize, f32::INFINITY);
        for y in 0..120 {
            for x in 0..160 {
                let dir = cam.direction(x as f64 + 0.5, y as f64 + 0.5).as_vec3();
                let along = (p - origin).dot(dir);
                let off = (origin + dir * along - p).length();
                if off < best.1 {
                    best = ((y * 160 + x) as usize, off);
                }
            }
        }
        (best.0, (p - origin).length())
    };
    // The card's centre is in front of the box: the depth is the card's.
    let (px, dist) = look(glam::Vec3::new(-1.2, 0.8, 0.5));
    assert!((depth[px] - dist).abs() < 0.02, "card {} vs {dist}", depth[px]);
    // The sphere's front is in front of the wall mesh: the sphere's depth.
    let (px, dist) = look(glam::Vec3::new(1.2, 0.8, 0.6));
    assert!((depth[px] - dist).abs() < 0.05, "sphere {} vs {dist}", depth[px]);
    // Between the box and the sphere, above them, the wall (a mesh) is
    // seen, at z = −3.
    let (px, _) = look(glam::Vec3::new(0.0, 2.2, -3.0));
    let p = origin
        + cam
            .direction((px % 160) as f64 + 0.5, (px / 160) as f64 + 0.5)
            .as_vec3()
            * depth[px];
    assert!((p.z + 3.0).abs() < 1e-3, "wall at {p}");
}

#[test]
fn meshes_and_objects_cast_shadows_on_each_other() {
    let d = dir("shadow");
    // Light straight above; the floor 0.5 below a caster at x = ±1.5.
    let lit = |floor: &str, caster: &str| {
        let body = format!("{floor}{caster}[[light]]\nkind = \"directional\"\ndirection = [0.0, 1.0, 0.0]\n");
        draw(&d, "shadow.toml", &body)
    };
    let sdf_floor = "[[object]]\nshape = \"p.y\"\nmaterial = \"grey\"\n";
    let mesh_floor = "[[mesh]]\nfile = \"floor.obj\"\nmaterial = \"grey\"\n";
    let sdf_caster = "[[object]]\nshape = \"sphere(p, 0.4)\"\nposition = [0.0, 1.2, 0.0]\nmaterial = \"red\"\n";
    let mesh_caster = "[[mesh]]\nfile = \"card.obj\"\nposition = [0.0, 1.2, 0.0]\nmaterial = \"red\"\n";
    // The floor point under the caster, seen by the camera past its side.
    let floor_point = |img: &RenderedImage| {
        let scene = isoray_scene::load(&d.join("shadow.toml"), &[]).unwrap();
        let cam = isoray_render::camera::RayCamera::new(&scene.camera, 160, 120);
        let o = cam.origin().as_vec3();
        // Look at (0.15, 0, 0.15): under the caster, in its shadow from above.
        let target = glam::Vec3::new(0.15, 0.0, 0.15);
        let mut best = (0usize, f32::INFINITY);
        for y in 0..120 {
            for x in 0..160 {
                let dir = cam.direction(x as f64 + 0.5, y as f64 + 0.5).as_vec3();
                let off = (o + dir * (target - o).dot(dir) - target).length();
                if off < best.1 {
                    best = ((y * 160 + x) as usize, off);
                }
            }
        }
        luminance(img.color[best.0])
    };
    for (floor, caster, what) in [
        (sdf_floor, mesh_caster, "a mesh on an SDF floor"),
        (mesh_floor, sdf_caster, "an SDF sphere on a mesh floor"),
        (mesh_floor, mesh_caster, "a mesh on a mesh floor"),
    ] {
        let open = lit(floor, "");
        let open_lum = floor_point(&open);
        let shadowed = lit(floor, caster);
        let shadow_lum = floor_point(&shadowed);
        assert!(open_lum > 0.2, "{what}: the open floor is lit ({open_lum})");
        // In shadow only the ambient term is left.
        assert!(shadow_lum < 0.3 * open_lum, "{what}: {shadow_lum} vs {open_lum}");
    }
}

#[test]
fn bad_mesh_tables_name_the_place() {
    let d = dir("bad");
    let err = |body: &str| {
        let path = d.join("bad.toml");
        std::fs::write(&path, format!("{HEAD}{body}")).unwrap();
        isoray_scene::load(&path, &[]).unwrap_err().to_string()
    };
    let e = err("[[mesh]]\nfile = \"missing.obj\"\n");
    assert!(
        e.contains("mesh.0.file") && e.contains("missing.obj") && e.contains(":16:"),
        "{e}"
    );
    let e = err("[[mesh]]\nmaterial = \"red\"\n");
    assert!(e.contains("`mesh.0` needs a `file`"), "{e}");
    let e = err("[material.glass]\ntransparency = 0.9\n[[mesh]]\nfile = \"card.obj\"\nmaterial = \"glass\"\n");
    assert!(e.contains("transparent") && e.contains("mesh.0.material"), "{e}");
    let e = err("[[mesh]]\nfile = \"card.obj\"\nscale = -1.0\n");
    assert!(e.contains("mesh.0.scale"), "{e}");
    let e = err("[[mesh]]\nfile = \"card.obj\"\ncolour = 1\n");
    assert!(e.contains("colour"), "{e}");
}
