//! Meshing shapes: closed manifold meshes, sharp corners, convergence of
//! volume and area to the analytic values, no self-intersections.

use isoray_mesh::{mesh_shape, self_intersections, Mesh, MeshSettings, MeshStats};
use isoray_shape::{compile, Library};
use std::f64::consts::PI;

fn mesh_text(text: &str, resolution: u32) -> (Mesh, MeshStats) {
    let shape = compile(&Library::new(), text).unwrap();
    let settings = MeshSettings {
        resolution,
        ..MeshSettings::default()
    };
    mesh_shape(shape.tape(), &settings).unwrap()
}

/// Asserts the mesh is closed, manifold, outward-wound, free of
/// self-intersections, and that its vertices lie within `tol` cells of the surface.
fn assert_quality(name: &str, mesh: &Mesh, stats: &MeshStats, tol_cells: f64) {
    let t = mesh.topology();
    assert!(t.is_closed_manifold(), "{name}: {t:?}");
    assert!(mesh.volume() > 0.0, "{name}: inward winding");
    let hits = self_intersections(mesh);
    assert!(
        hits.is_empty(),
        "{name}: {} self-intersecting pairs, first {:?}",
        hits.len(),
        &hits[..hits.len().min(5)]
    );
    assert!(
        stats.max_error < tol_cells * stats.cell_size,
        "{name}: max error {} vs cell {}",
        stats.max_error,
        stats.cell_size
    );
    assert_eq!(stats.missed_cells, 0, "{name}: the distance bound skipped cells");
    // Normals are unit gradients.
    for n in &mesh.normals {
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((l - 1.0).abs() < 1e-4, "{name}: normal {n:?}");
    }
}

/// Meshes `text` at each resolution and checks that the relative volume and
/// area errors against the analytic values shrink (at least by 0.6 per
/// doubling) down to `final_tol`. `tol_cells` gives each resolution's vertex tolerance.
fn assert_converges(name: &str, text: &str, volume: f64, area: f64, runs: &[(u32, f64)], final_tol: f64) {
    let mut last = (f64::INFINITY, f64::INFINITY);
    for &(res, tol_cells) in runs {
        let (m, s) = mesh_text(text, res);
        assert_quality(name, &m, &s, tol_cells);
        assert_eq!(m.topology().components, 1, "{name}");
        let ev = (m.volume() - volume).abs() / volume;
        let ea = (m.area() - area).abs() / area;
        assert!(
            ev < last.0 * 0.6 && ea < last.1 * 0.6,
            "{name} at {res}: volume error {ev}, area error {ea}, before {last:?}"
        );
        last = (ev, ea);
    }
    assert!(last.0 < final_tol && last.1 < final_tol, "{name}: {last:?}");
}

#[test]
fn sphere_volume_and_area_converge() {
    let text = "sphere(p - vec3(0.013, -0.021, 0.007), 1.0)";
    let runs = [(12, 0.01), (24, 0.01), (48, 0.01), (96, 0.01)];
    assert_converges("sphere", text, 4.0 / 3.0 * PI, 4.0 * PI, &runs, 2e-3);
}

#[test]
fn torus_volume_and_area_converge() {
    let (big, small) = (1.0, 0.35);
    let (v, a) = (2.0 * PI * PI * big * small * small, 4.0 * PI * PI * big * small);
    let runs = [(24, 0.06), (48, 0.03), (96, 0.03)];
    assert_converges("torus", "torus(rotate_x(p, 0.3), 1.0, 0.35)", v, a, &runs, 5e-3);
}

#[test]
fn a_box_keeps_its_eight_corners_sharp() {
    let half = [0.9, 0.6, 0.45];
    let centre = [0.031, -0.017, 0.011];
    let text = format!(
        "box(p - vec3({}, {}, {}), vec3({}, {}, {}))",
        centre[0], centre[1], centre[2], half[0], half[1], half[2]
    );
    let (m, s) = mesh_text(&text, 40);
    assert_quality("box", &m, &s, 0.01);
    let volume = 8.0 * half[0] * half[1] * half[2];
    assert!(
        (m.volume() - volume).abs() < 1e-3 * volume,
        "{} vs {volume}",
        m.volume()
    );
    for c in 0..8 {
        let corner: [f64; 3] = std::array::from_fn(|k| centre[k] + if c >> k & 1 == 1 { half[k] } else { -half[k] });
        let nearest = m
            .positions
            .iter()
            .map(|p| (0..3).map(|k| (p[k] as f64 - corner[k]).powi(2)).sum::<f64>().sqrt())
            .fold(f64::INFINITY, f64::min);
        assert!(
            nearest < 1e-3 * s.cell_size.max(1e-3) + 1e-5,
            "corner {corner:?}: nearest vertex {nearest}"
        );
    }
}

#[test]
fn csg_classic_is_closed_and_sharp() {
    let text = "difference(intersection(sphere(p, 1.35), box(p, vec3(1.0))), \
                union(cylinder(p, 2.0, 0.55), cylinder(rotate_x(p, PI / 2.0), 2.0, 0.55), \
                cylinder(rotate_z(p, PI / 2.0), 2.0, 0.55)))";
    let (m, s) = mesh_text(text, 64);
    assert_quality("csg", &m, &s, 0.05);
    assert_eq!(m.topology().components, 1);
    assert!(s.feature_vertices > 100, "{} feature vertices", s.feature_vertices);
}

#[test]
fn a_thin_onion_shell_is_two_closed_surfaces() {
    // A shell of thickness 0.1 around a sphere: inner and outer surfaces.
    let (m, s) = mesh_text("onion(sphere(p, 1.0), 0.05)", 48);
    assert_quality("onion", &m, &s, 0.01);
    assert_eq!(m.topology().components, 2);
    let v = 4.0 / 3.0 * PI * (1.05f64.powi(3) - 0.95f64.powi(3));
    assert!((m.volume() - v).abs() < 0.02 * v, "{} vs {v}", m.volume());
}

#[test]
fn normals_are_the_gradient() {
    let c = [0.013, -0.021, 0.007];
    let (m, _) = mesh_text("sphere(p - vec3(0.013, -0.021, 0.007), 1.0)", 32);
    for (p, n) in m.positions.iter().zip(&m.normals) {
        let r: Vec<f64> = (0..3).map(|k| p[k] as f64 - c[k]).collect();
        let len = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        let cos: f64 = (0..3).map(|k| r[k] / len * n[k] as f64).sum();
        assert!(cos > 1.0 - 1e-6, "normal {n:?} at {p:?}");
    }
}

#[test]
fn the_mesh_is_the_same_whatever_the_thread_count() {
    let text = "smooth_union(torus(p, 1.0, 0.3), box(p - vec3(0.0, 0.5, 0.0), vec3(0.4)), 0.2)";
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| mesh_text(text, 40).0)
    };
    let one = run(1);
    assert!(one.topology().is_closed_manifold());
    assert_eq!(one, run(3));
}

#[test]
fn cancelling_stops_meshing() {
    use isoray_mesh::{mesh_shape_with, Control, MeshError, Stage};
    use std::sync::atomic::{AtomicBool, Ordering};
    let shape = compile(&Library::new(), "sphere(p, 1.0)").unwrap();
    let cancel = AtomicBool::new(false);
    // Cancel as soon as the octree starts; the stages seen before it are reported.
    let seen = std::sync::Mutex::new(Vec::new());
    let progress = |stage: Stage, _f: f64| {
        seen.lock().unwrap().push(stage);
        if stage == Stage::Octree {
            cancel.store(true, Ordering::Relaxed);
        }
    };
    let ctl = Control::new(Some(&progress), Some(&cancel));
    let settings = MeshSettings {
        resolution: 256,
        ..MeshSettings::default()
    };
    assert_eq!(
        mesh_shape_with(shape.tape(), &settings, &ctl).unwrap_err(),
        MeshError::Cancelled
    );
    assert!(seen.lock().unwrap().contains(&Stage::Bounds));
}

#[test]
fn bad_settings_are_errors_not_panics() {
    let shape = compile(&Library::new(), "sphere(p, 1.0)").unwrap();
    let bad = [
        MeshSettings {
            resolution: 1,
            ..MeshSettings::default()
        },
        MeshSettings {
            lipschitz: 0.5,
            ..MeshSettings::default()
        },
        MeshSettings {
            feature_angle_deg: f64::NAN,
            ..MeshSettings::default()
        },
        MeshSettings {
            offset: f64::INFINITY,
            ..MeshSettings::default()
        },
        MeshSettings {
            bounds: Some([[1.0; 3], [0.0; 3]]),
            ..MeshSettings::default()
        },
        MeshSettings {
            resolution: 1 << 30,
            ..MeshSettings::default()
        },
    ];
    for s in bad {
        assert!(
            matches!(mesh_shape(shape.tape(), &s), Err(isoray_mesh::MeshError::Settings(_))),
            "{s:?}"
        );
    }
    // No surface in the search cube, none in the given box, and an unbounded one.
    let far = compile(&Library::new(), "sphere(p - vec3(50000.0, 0.0, 0.0), 1.0)").unwrap();
    assert_eq!(
        mesh_shape(far.tape(), &MeshSettings::default()).unwrap_err(),
        isoray_mesh::MeshError::NoSurface
    );
    let boxed = MeshSettings {
        bounds: Some([[-1.0; 3], [1.0; 3]]),
        ..MeshSettings::default()
    };
    assert_eq!(
        mesh_shape(far.tape(), &boxed).unwrap_err(),
        isoray_mesh::MeshError::NoSurface
    );
    let plane = compile(&Library::new(), "p.y").unwrap();
    assert_eq!(
        mesh_shape(plane.tape(), &MeshSettings::default()).unwrap_err(),
        isoray_mesh::MeshError::Unbounded
    );
}

#[test]
fn shells_thinner_than_a_cell_stay_manifold() {
    // Both sides of the shell pass through the same cells: ambiguous faces
    // whose two segments would join the same two patches are flipped.
    for (text, res) in [
        ("abs(sphere(p, 1.0)) - 0.02", 24),
        ("abs(sphere(p, 1.0)) - 0.02", 32),
        ("abs(sphere(p, 1.0)) - 0.02", 48),
        ("abs(abs(sphere(p, 1.0)) - 0.1) - 0.02", 48),
    ] {
        let (m, _) = mesh_text(text, res);
        let t = m.topology();
        assert!(t.is_closed_manifold(), "{text} at {res}: {t:?}");
        assert!(self_intersections(&m).is_empty(), "{text} at {res}");
    }
}

#[test]
fn nan_fields_are_reported() {
    let shape = compile(&Library::new(), "sqrt(-1.0) + sphere(p, 1.0)").unwrap();
    let boxed = MeshSettings {
        bounds: Some([[-1.0; 3], [1.0; 3]]),
        resolution: 16,
        ..MeshSettings::default()
    };
    for s in [boxed, MeshSettings::default()] {
        assert!(matches!(
            mesh_shape(shape.tape(), &s),
            Err(isoray_mesh::MeshError::NotANumber { .. })
        ));
    }
}

#[test]
fn steep_fields_put_vertices_on_the_surface() {
    // 100 × a sphere's distance: the slope seen at the crossings seeds the search.
    let shape = compile(&Library::new(), "100.0 * sphere(p, 1.0)").unwrap();
    let settings = MeshSettings {
        resolution: 32,
        lipschitz: 100.0,
        ..MeshSettings::default()
    };
    let (m, _) = mesh_shape(shape.tape(), &settings).unwrap();
    for p in &m.positions {
        let r = (p[0] as f64).hypot(p[1] as f64).hypot(p[2] as f64);
        assert!((r - 1.0).abs() < 1e-5, "radius {r}");
    }
}

#[test]
fn the_box_given_is_the_box_meshed() {
    // A sphere cut to |z| ≤ 0.3 by the box, at a resolution whose cells do
    // not fit the box's height.
    let shape = compile(&Library::new(), "sphere(p, 1.0)").unwrap();
    let settings = MeshSettings {
        resolution: 8,
        bounds: Some([[-2.0, -2.0, -0.3], [2.0, 2.0, 0.3]]),
        ..MeshSettings::default()
    };
    let (m, _) = mesh_shape(shape.tape(), &settings).unwrap();
    assert!(m.topology().is_closed_manifold());
    let b = m.bounds().unwrap();
    assert!(b[0][2] >= -0.3 - 1e-6 && b[1][2] <= 0.3 + 1e-6, "{b:?}");
    assert!(b[1][2] > 0.29, "{b:?}");
}

#[test]
fn job_control_reports_stages_and_cancels() {
    use isoray_job::{CancelToken, Progress};
    use isoray_mesh::{mesh_shape_with, Control, MeshError};
    struct Stages(std::sync::Mutex<Vec<String>>, CancelToken);
    impl Progress for Stages {
        fn update(&self, done: u64, total: u64) {
            assert!(done <= total && total == 1000);
        }
        fn stage(&self, name: &str) {
            self.0.lock().unwrap().push(name.to_string());
            if name == "octree" {
                self.1.cancel();
            }
        }
    }
    let shape = compile(&Library::new(), "sphere(p, 1.0)").unwrap();
    let token = CancelToken::new();
    let stages = Stages(Default::default(), token.clone());
    let settings = MeshSettings {
        resolution: 64,
        ..MeshSettings::default()
    };
    let err = mesh_shape_with(shape.tape(), &settings, &Control::job(&stages, &token)).unwrap_err();
    assert_eq!(err, MeshError::Cancelled);
    let seen = stages.0.lock().unwrap().clone();
    assert_eq!(seen.first().map(String::as_str), Some("bounds"), "{seen:?}");
    // Without cancellation the same control lets it finish.
    let token = CancelToken::new();
    let quiet = isoray_job::NoProgress;
    assert!(mesh_shape_with(shape.tape(), &settings, &Control::job(&quiet, &token)).is_ok());
}
