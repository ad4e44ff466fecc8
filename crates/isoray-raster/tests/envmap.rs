//! Environment maps and shadows, against geometry with known answers: the
//! cube-map texel mapping, lookups and searches on planes, the hidden-object
//! scene (Z-buffered map against A-buffered map, asserted on pixels), and
//! shadows of a square occluder from a point light (shadow buffers and the
//! environment-map walk).

use glam::DVec3;
use isoray_mesh::Mesh;
use isoray_raster::envmap::{face_axis, face_of, CubeFaces, CubeMap, MapKind, SearchTolerance};
use isoray_raster::pipeline::ViewTransform;
use isoray_raster::render::{raster_meshes, RasterOptions, ReflectionMethod, ShadowMethod};
use isoray_raster::scene::{MeshedScene, ObjectMesh};
use isoray_raster::triangles::SceneTriangles;
use isoray_scene::{load_str, Scene};

/// A one-sided quad (two triangles) with corners `c` counter-clockwise seen from its front.
fn quad(c: [DVec3; 4]) -> Mesh {
    let n = (c[1] - c[0]).cross(c[2] - c[0]).normalize();
    Mesh {
        positions: c.iter().map(|p| p.as_vec3().to_array()).collect(),
        normals: vec![n.as_vec3().to_array(); 4],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        ..Mesh::default()
    }
}

/// A quad centred at `centre` facing `normal`, with half-sizes `hu` along `u` and `hv` along normal × u.
fn facing_quad(centre: DVec3, normal: DVec3, u: DVec3, hu: f64, hv: f64) -> Mesh {
    let n = normal.normalize();
    let u = (u - n * u.dot(n)).normalize();
    let v = n.cross(u);
    quad([
        centre - u * hu - v * hv,
        centre + u * hu - v * hv,
        centre + u * hu + v * hv,
        centre - u * hu + v * hv,
    ])
}

fn meshed(objects: Vec<(usize, Mesh)>) -> MeshedScene {
    MeshedScene {
        objects: objects
            .into_iter()
            .enumerate()
            .map(|(i, (material, mesh))| ObjectMesh {
                object: i,
                material,
                mesh,
                unbounded: false,
                two_sided: false,
            })
            .collect(),
        warnings: Vec::new(),
    }
}

fn scene(text: &str) -> Scene {
    load_str(text, "test.toml", &[]).expect("scene loads")
}

fn material(sc: &Scene, name: &str) -> usize {
    sc.materials.iter().position(|m| m.name == name).unwrap()
}

#[test]
fn faces_and_texels_round_trip() {
    for f in 0..6 {
        assert_eq!(face_of(face_axis(f)), f);
    }
    let faces = CubeFaces::new(DVec3::new(1.0, -2.0, 0.5), 64);
    let mut k = 0u32;
    for i in 0..500 {
        // Directions spread over the sphere.
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / 500.0;
        let phi = i as f64 * 2.399_963;
        let r = (1.0 - z * z).sqrt();
        let u = DVec3::new(r * phi.cos(), r * phi.sin(), z);
        let t = faces.texel(u);
        assert_eq!(t.face, face_of(u));
        let p = faces.stored_point(t.face, t.x, t.y, 3.0);
        let d = (p - faces.centre).normalize();
        // Within a texel's half diagonal (2/64 at the face centre, less at its edges).
        let angle = d.dot(u).clamp(-1.0, 1.0).acos();
        assert!(angle < 0.75 * 2.0 / 64.0 * 1.5, "{u:?}: {angle}");
        // Depth is along the face's axis.
        assert!(((p - faces.centre).dot(face_axis(t.face)) - 3.0).abs() < 1e-9);
        k += t.c + t.r;
    }
    assert!(k > 0, "subsample positions vary");
}

/// Two parallel quads in front of the map centre: the Z-buffered map keeps
/// the near one, the A-buffered map both (and the far one's back face too
/// when it is turned around).
#[test]
fn z_map_keeps_the_nearest_a_map_every_layer() {
    let near = facing_quad(DVec3::new(0.0, 0.0, -5.0), DVec3::Z, DVec3::X, 2.0, 2.0);
    let far = facing_quad(DVec3::new(0.0, 0.0, -8.0), -DVec3::Z, DVec3::X, 3.0, 3.0);
    let tris = SceneTriangles::new(&meshed(vec![(0, near), (0, far)]));
    let z = CubeMap::build(&tris, DVec3::ZERO, 64, MapKind::ZBuffer, None, 1e-3);
    let a = CubeMap::build(&tris, DVec3::ZERO, 64, MapKind::ABuffer, None, 1e-3);
    let t = CubeFaces::new(DVec3::ZERO, 64).texel(-DVec3::Z);
    let zs = z.samples_at(t.face, t.x, t.y);
    assert_eq!(zs.len(), 1);
    assert!((zs[0].z - 5.0).abs() < 1e-4, "{zs:?}");
    let as_ = a.samples_at(t.face, t.x, t.y);
    assert_eq!(as_.len(), 2, "{as_:?}");
    assert!(
        (as_[0].z - 5.0).abs() < 1e-4 && (as_[1].z - 8.0).abs() < 1e-4,
        "{as_:?}"
    );
    assert!(as_[0].front && !as_[1].front, "the far quad faces away from the centre");
    // Blinn–Newell lookup: the point the centre sees.
    let (tri, p) = z.lookup(DVec3::new(0.1, 0.05, -1.0)).unwrap();
    assert!(tri < 2);
    assert!((p - DVec3::new(0.5, 0.25, -5.0)).length() < 0.1, "{p:?}");
    assert!(z.lookup(DVec3::Z).is_none());
}

/// A ray searched through a map finds the plane it crosses, within the
/// angle threshold, from an origin away from the map's centre.
#[test]
fn the_search_finds_the_surface_on_the_ray() {
    let wall = facing_quad(DVec3::new(0.0, 0.0, -6.0), DVec3::Z, DVec3::X, 6.0, 6.0);
    let tris = SceneTriangles::new(&meshed(vec![(0, wall)]));
    for kind in [MapKind::ZBuffer, MapKind::ABuffer] {
        let map = CubeMap::build(&tris, DVec3::ZERO, 256, kind, None, 1e-3);
        for (o, target) in [
            (DVec3::new(2.0, 0.5, 1.0), DVec3::new(-1.0, 2.0, -6.0)),
            (DVec3::new(-3.0, -1.0, -2.0), DVec3::new(2.5, 1.0, -6.0)),
            (DVec3::new(0.0, 3.0, 4.0), DVec3::new(0.0, -3.0, -6.0)),
        ] {
            let d = (target - o).normalize();
            let hit = map
                .search(o, d, 1e-3, f64::INFINITY, &SearchTolerance::default(), |_| true)
                .unwrap_or_else(|| panic!("{kind:?}: no hit from {o:?}"));
            assert!(
                (hit.point - target).length() < 0.1,
                "{kind:?}: {:?} vs {target:?}",
                hit.point
            );
            assert!(hit.angle < 0.02, "{kind:?}: {}", hit.angle);
            // Pointing away from the wall finds nothing.
            assert!(map
                .search(o, -d, 1e-3, f64::INFINITY, &SearchTolerance::default(), |_| true)
                .is_none());
        }
    }
}

const HIDDEN: &str = r#"
[camera]
position = [0.0, 0.0, 6.0]
target = [0.0, 0.0, 0.0]
fov = 60.0

[render]
width = 160
height = 120
background = [0.0, 0.0, 0.0]

[material.mirror]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
emission = [0.05, 0.05, 0.05]
reflectivity = 0.9
fresnel = false

[material.red]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
emission = [1.0, 0.0, 0.0]

[material.green]
ambient = [0.0, 0.0, 0.0]
diffuse = [0.0, 0.0, 0.0]
specular = [0.0, 0.0, 0.0]
emission = [0.0, 1.0, 0.0]

[[object]]
material = "mirror"
shape = "sphere(p, 1.0)"

[[object]]
material = "red"
shape = "sphere(p, 1.0)"

[[object]]
material = "green"
shape = "sphere(p, 1.0)"
"#;

/// The issue's hidden-object scene: a white reflective triangle (here a
/// mirror quad off to the side), a red triangle partly hiding a green one
/// from the camera. The mirror sees all of the green one. With the
/// Z-buffered map, the part hidden from the camera (the map's centre) is
/// missing from the reflection; with the A-buffered map it is there.
#[test]
fn the_a_buffered_map_reflects_what_the_camera_cannot_see() {
    let sc = scene(HIDDEN);
    let eye = DVec3::new(0.0, 0.0, 6.0);
    let green_c = DVec3::new(0.0, 0.0, -3.0);
    let mirror_c = DVec3::new(3.0, 0.0, -1.0);
    let n = ((eye - mirror_c).normalize() + (green_c - mirror_c).normalize()).normalize();
    let mirror = facing_quad(mirror_c, n, DVec3::Y, 1.2, 1.2);
    // Red at z = 0 hides green for x_green in [−1, 0.3] (projection factor 6/9).
    let red = quad([
        DVec3::new(-1.5, -1.5, 0.0),
        DVec3::new(0.2, -1.5, 0.0),
        DVec3::new(0.2, 1.5, 0.0),
        DVec3::new(-1.5, 1.5, 0.0),
    ]);
    let green = quad([
        DVec3::new(-1.0, -1.0, -3.0),
        DVec3::new(1.0, -1.0, -3.0),
        DVec3::new(1.0, 1.0, -3.0),
        DVec3::new(-1.0, 1.0, -3.0),
    ]);
    let m = meshed(vec![
        (material(&sc, "mirror"), mirror),
        (material(&sc, "red"), red),
        (material(&sc, "green"), green),
    ]);
    let render = |reflections| {
        let opts = RasterOptions {
            reflections,
            map_size: 256,
            ..RasterOptions::default()
        };
        raster_meshes(&sc, &m, &opts).unwrap().color
    };
    let zmap = render(ReflectionMethod::ZBufferMap);
    let amap = render(ReflectionMethod::ABufferMap);
    if let Some(dir) = std::env::var_os("ISORAY_TEST_OUT") {
        let dir = std::path::PathBuf::from(dir);
        for (name, rgb) in [("hidden-zmap.png", &zmap), ("hidden-amap.png", &amap)] {
            let bytes = isoray_shade::srgb::to_srgb8(rgb);
            image::save_buffer(dir.join(name), &bytes, 160, 120, image::ColorType::Rgb8).unwrap();
        }
    }

    // Classify the mirror's pixels by where their exact reflected ray meets the green plane.
    let view = ViewTransform::new(&sc.camera, 160, 120);
    let (u, v) = {
        let u = (DVec3::Y - n * DVec3::Y.dot(n)).normalize();
        (u, n.cross(u))
    };
    let (mut hidden, mut visible) = (Vec::new(), Vec::new());
    for y in 0..120 {
        for x in 0..160 {
            let d = (DVec3::from(view.screen_to_world(x as f64, y as f64, 1.0)) - eye).normalize();
            let t = (mirror_c - eye).dot(n) / d.dot(n);
            let p = eye + d * t;
            let q = p - mirror_c;
            if t <= 0.0 || q.dot(u).abs() > 1.1 || q.dot(v).abs() > 1.1 {
                continue;
            }
            let r = d - n * 2.0 * d.dot(n);
            if r.z >= 0.0 {
                continue;
            }
            let s = (-3.0 - p.z) / r.z;
            let g = p + r * s;
            if g.y.abs() > 0.85 {
                continue;
            }
            let i = y * 160 + x;
            if (-0.85..0.15).contains(&g.x) {
                hidden.push(i);
            } else if (0.45..0.85).contains(&g.x) {
                visible.push(i);
            }
        }
    }
    assert!(
        hidden.len() > 50 && visible.len() > 40,
        "{} {}",
        hidden.len(),
        visible.len()
    );
    let green_share = |img: &[[f32; 3]], px: &[usize]| {
        px.iter().filter(|&&i| img[i][1] > 0.5 && img[i][0] < 0.2).count() as f64 / px.len() as f64
    };
    // Both maps reflect the part of the green triangle the camera sees.
    assert!(green_share(&zmap, &visible) > 0.9, "{}", green_share(&zmap, &visible));
    assert!(green_share(&amap, &visible) > 0.9, "{}", green_share(&amap, &visible));
    // Only the A-buffered map reflects the part hidden behind the red one.
    assert!(green_share(&zmap, &hidden) < 0.1, "{}", green_share(&zmap, &hidden));
    assert!(green_share(&amap, &hidden) > 0.9, "{}", green_share(&amap, &hidden));
}

const SHADOW: &str = r#"
[camera]
position = [0.0, 7.0, 7.0]
target = [0.0, 0.0, 0.0]
fov = 45.0

[render]
width = 120
height = 90
background = [0.0, 0.0, 0.0]

[[light]]
kind = "point"
position = [0.0, 5.0, 0.0]

[material.floor]
ambient = [0.1, 0.1, 0.1]
diffuse = [0.8, 0.8, 0.8]
specular = [0.0, 0.0, 0.0]

[[object]]
material = "floor"
shape = "sphere(p, 1.0)"

[[object]]
material = "floor"
shape = "sphere(p, 1.0)"
"#;

/// A 1×1 square at height 2 under a point light at height 5 shadows the
/// square [−5/6, 5/6]² of the floor (similar triangles: 0.5 · 5/3).
#[test]
fn shadows_of_a_square_from_a_point_light() {
    let sc = scene(SHADOW);
    let floor = facing_quad(DVec3::ZERO, DVec3::Y, DVec3::X, 4.0, 4.0);
    let occluder = facing_quad(DVec3::new(0.0, 2.0, 0.0), DVec3::Y, DVec3::X, 0.5, 0.5);
    let f = material(&sc, "floor");
    let m = meshed(vec![(f, floor), (f, occluder)]);
    let view = ViewTransform::new(&sc.camera, 120, 90);
    let eye = DVec3::from(sc.camera.position);
    let (mut inside, mut outside) = (Vec::new(), Vec::new());
    for y in 0..90 {
        for x in 0..120 {
            let d = (DVec3::from(view.screen_to_world(x as f64, y as f64, 1.0)) - eye).normalize();
            // Skip pixels that see the occluder.
            let to_occ = (2.0 - eye.y) / d.y;
            let o = eye + d * to_occ;
            if o.x.abs() < 0.6 && o.z.abs() < 0.6 {
                continue;
            }
            let p = eye + d * (-eye.y / d.y);
            let e = p.x.abs().max(p.z.abs());
            if p.x.abs() > 3.5 || p.z.abs() > 3.5 {
                continue;
            }
            if e < 5.0 / 6.0 - 0.12 {
                inside.push(y * 120 + x);
            } else if e > 5.0 / 6.0 + 0.12 {
                outside.push(y * 120 + x);
            }
        }
    }
    assert!(inside.len() > 100 && outside.len() > 1000);
    for shadows in [ShadowMethod::Buffer, ShadowMethod::EnvMap] {
        let opts = RasterOptions {
            shadows,
            map_size: 256,
            ..RasterOptions::default()
        };
        let img = raster_meshes(&sc, &m, &opts).unwrap().color;
        // In shadow: ambient only (0.1); lit: ambient + diffuse over 0.1 + 0.8 · cos > 0.4.
        let dark = inside.iter().filter(|&&i| img[i][0] < 0.12).count() as f64 / inside.len() as f64;
        let lit = outside.iter().filter(|&&i| img[i][0] > 0.25).count() as f64 / outside.len() as f64;
        assert!(dark > 0.98, "{shadows:?}: {dark}");
        assert!(lit > 0.98, "{shadows:?}: {lit}");
        // Without shadows nothing is dark.
        let none = raster_meshes(&sc, &m, &RasterOptions::default()).unwrap().color;
        assert!(inside.iter().all(|&i| none[i][0] > 0.25));
    }
}
