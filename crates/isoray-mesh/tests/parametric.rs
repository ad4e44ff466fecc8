//! Tessellation of parametric surfaces against known answers: flat patches,
//! spheres, tori, crack-freedom of adaptive meshes, determinism.

use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_2, PI};

use isoray_mesh::parametric::{tessellate, TessellateError, TessellationSettings, TessellationStats};
use isoray_mesh::Mesh;
use isoray_shape::surface::{ParametricCoords, SurfaceOptions};
use isoray_shape::Library;

fn coords(xyz: [&str; 3], domain: [[f64; 2]; 2]) -> ParametricCoords {
    let mut lib = Library::new();
    lib.add_parametric_surface(
        "surf",
        vec![],
        [(xyz[0], 0), (xyz[1], 1), (xyz[2], 2)],
        domain,
        SurfaceOptions::default(),
    )
    .unwrap();
    lib.parametric_coords("surf", None).unwrap()
}

/// The unit sphere, outward: ∂s × ∂t = cos(t) p.
fn sphere() -> ParametricCoords {
    coords(
        ["cos(t) * cos(s)", "cos(t) * sin(s)", "sin(t)"],
        [[0.0, 2.0 * PI], [-FRAC_PI_2, FRAC_PI_2]],
    )
}

/// z = exp(-20 (s² + t²)) over [-1, 1]²: refines near the origin only.
fn bump() -> ParametricCoords {
    coords(["s", "t", "exp(-20.0 * (s^2 + t^2))"], [[-1.0, 1.0], [-1.0, 1.0]])
}

fn run(c: &ParametricCoords, settings: &TessellationSettings) -> (Mesh, TessellationStats) {
    let (m, st) = tessellate(c, settings).unwrap();
    assert_eq!(m.triangles.len(), st.triangles);
    assert_eq!(m.positions.len(), st.vertices);
    assert_eq!(m.normals.len(), m.positions.len());
    assert_eq!(m.uvs.len(), m.positions.len());
    assert!(m.positions.iter().flatten().all(|v| v.is_finite()));
    (m, st)
}

/// Undirected edge → number of triangles using it.
fn edge_uses(m: &Mesh) -> HashMap<(u32, u32), usize> {
    let mut e = HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *e.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    e
}

fn tri_normal(m: &Mesh, i: usize) -> [f64; 3] {
    let [a, b, c] = m.corners(i);
    let (u, v) = (
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
        [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
    );
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// Every triangle's normal agrees with its vertices' normals.
fn assert_winding_agrees(m: &Mesh) {
    for (i, t) in m.triangles.iter().enumerate() {
        let n = tri_normal(m, i);
        for &v in t {
            let vn = m.normals[v as usize].map(f64::from);
            let d = n[0] * vn[0] + n[1] * vn[1] + n[2] * vn[2];
            assert!(d > 0.0, "triangle {i} {t:?} winds against vertex {v}'s normal");
        }
    }
}

#[test]
fn a_flat_square_stays_on_the_base_grid() {
    let c = coords(["s", "t", "0.0"], [[0.0, 1.0], [0.0, 1.0]]);
    let (m, st) = run(&c, &TessellationSettings::default());
    assert_eq!(st.max_depth_reached, 0);
    assert_eq!(st.leaves, 256);
    assert_eq!(m.triangle_count(), 512);
    assert_eq!(m.positions.len(), 17 * 17);
    assert_eq!(m.area(), 1.0);
    for (p, uv) in m.positions.iter().zip(&m.uvs) {
        assert_eq!([p[0], p[1]], *uv);
        assert_eq!(p[2], 0.0);
    }
    assert!(m.normals.iter().all(|n| *n == [0.0, 0.0, 1.0]));
    assert_winding_agrees(&m);
    let topo = m.topology();
    assert_eq!(topo.boundary_edges, 64);
    assert_eq!(
        topo.misoriented_edges + topo.nonmanifold_edges + topo.degenerate_triangles,
        0
    );
    assert_eq!(st.skipped_triangles + st.degenerate_triangles, 0);
}

#[test]
fn a_sphere_lies_on_the_sphere_with_outward_normals_and_converging_area() {
    let c = sphere();
    let mut errors = Vec::new();
    for tol in [3e-2, 1e-2, 3e-3, 1e-3] {
        // Only the chord tolerance decides here.
        let settings = TessellationSettings {
            tolerance: Some(tol),
            max_angle_deg: 180.0,
            max_edge: Some(1e9),
            ..Default::default()
        };
        let (m, st) = run(&c, &settings);
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let p = p.map(f64::from);
            let n = n.map(f64::from);
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            assert!((r - 1.0).abs() < 1e-6, "radius {r}");
            // Outward unit normals: n = p.
            let np = n[0] * p[0] + n[1] * p[1] + n[2] * p[2];
            assert!((np - 1.0).abs() < 1e-5, "n·p = {np} at {p:?}");
        }
        // The poles' vertices got the limit normal; the triangles touching
        // a pole along an edge were dropped.
        assert!(st.fallback_normals > 0 && st.missing_normals == 0);
        assert!(st.degenerate_triangles > 0);
        assert_eq!(m.topology().degenerate_triangles, 0);
        assert_winding_agrees(&m);
        // A closed surface wound outward: positive volume.
        assert!(m.volume() > 0.0);
        errors.push((m.area() - 4.0 * PI).abs() / (4.0 * PI));
    }
    assert!(errors.windows(2).all(|e| e[1] < e[0]), "{errors:?}");
    assert!(errors[3] < 1e-3, "{errors:?}");
    // The default settings are within 1%.
    let (m, _) = run(&c, &TessellationSettings::default());
    assert!((m.area() - 4.0 * PI).abs() < 0.01 * 4.0 * PI);
}

#[test]
fn a_torus_has_area_four_pi_squared_r_r() {
    let (big, small) = (1.0, 0.25);
    let c = coords(
        [
            "(1.0 + 0.25 * cos(t)) * cos(s)",
            "(1.0 + 0.25 * cos(t)) * sin(s)",
            "0.25 * sin(t)",
        ],
        [[0.0, 2.0 * PI], [0.0, 2.0 * PI]],
    );
    let want = 4.0 * PI * PI * big * small;
    // The error does not shrink monotonically: on the inner half (negative
    // curvature) the triangles overestimate the area, on the outer half they
    // underestimate it. The first tolerance refines only the outer half.
    for (tol, max_err) in [(3e-3, 2e-3), (1e-3, 5e-4), (5e-4, 5e-4)] {
        let settings = TessellationSettings {
            tolerance: Some(tol),
            ..Default::default()
        };
        let (m, st) = run(&c, &settings);
        let err = (m.area() - want).abs() / want;
        assert!(err < max_err, "tolerance {tol}: relative error {err}");
        assert_eq!(st.degenerate_triangles + st.fallback_normals, 0);
        assert_winding_agrees(&m);
        // The distance to the core circle is the tube radius.
        for p in &m.positions {
            let p = p.map(f64::from);
            let d = ((p[0] * p[0] + p[1] * p[1]).sqrt() - big).hypot(p[2]);
            assert!((d - small).abs() < 1e-6);
        }
    }
}

#[test]
fn adaptive_meshes_are_crack_free() {
    let c = bump();
    let settings = TessellationSettings {
        tolerance: Some(2e-4),
        max_depth: 4,
        ..Default::default()
    };
    let (m, st) = run(&c, &settings);
    // Refined non-uniformly.
    let depths: Vec<usize> = st
        .leaves_per_depth
        .iter()
        .enumerate()
        .filter(|(_, &n)| n > 0)
        .map(|(d, _)| d)
        .collect();
    assert!(depths.len() >= 3, "{:?}", st.leaves_per_depth);
    assert_eq!(st.max_depth_reached, 4);
    assert!(st.leaves_per_depth[0] > 0);
    // Every edge inside the domain has two triangles; those on its boundary one.
    let on_boundary = |a: u32, b: u32| {
        let (ua, ub) = (m.uvs[a as usize], m.uvs[b as usize]);
        (0..2).any(|k| ua[k] == ub[k] && ua[k].abs() == 1.0)
    };
    let mut boundary = 0;
    for (&(a, b), &n) in &edge_uses(&m) {
        if on_boundary(a, b) {
            assert_eq!(n, 1, "boundary edge {a}-{b}");
            boundary += 1;
        } else {
            assert_eq!(
                n, 2,
                "interior edge {a}-{b} ({:?} - {:?})",
                m.uvs[a as usize], m.uvs[b as usize]
            );
        }
    }
    // The boundary is the base grid's, never refined there (the bump is flat at the edge).
    assert_eq!(boundary, 4 * 16);
    let topo = m.topology();
    assert_eq!(topo.misoriented_edges, 0);
    assert_eq!(topo.nonmanifold_edges, 0);
    assert_eq!(topo.nonmanifold_vertices, 0);
    assert_eq!(topo.components, 1);
    assert_winding_agrees(&m);
    // Shared vertices are shared indices: one vertex per (s, t).
    let mut uvs: Vec<[u32; 2]> = m.uvs.iter().map(|uv| uv.map(f32::to_bits)).collect();
    uvs.sort_unstable();
    uvs.dedup();
    assert_eq!(uvs.len(), m.positions.len());
    // Euler characteristic of a disk.
    let (v, e, f) = (m.positions.len() as i64, topo.edges as i64, m.triangle_count() as i64);
    assert_eq!(v - e + f, 1);
    // The area is the graph's: ∫∫ sqrt(1 + |∇z|²) by the midpoint rule.
    let n = 1000;
    let h = 2.0 / n as f64;
    let mut want = 0.0;
    for i in 0..n {
        for j in 0..n {
            let (s, t) = (-1.0 + (i as f64 + 0.5) * h, -1.0 + (j as f64 + 0.5) * h);
            let g = -40.0 * (-20.0 * (s * s + t * t)).exp();
            want += (1.0 + g * g * (s * s + t * t)).sqrt() * h * h;
        }
    }
    assert!((m.area() - want).abs() < 1e-3 * want, "{} vs {want}", m.area());
}

/// Every edge inside the domain has exactly two triangles, wound oppositely,
/// and every edge on its boundary one; one vertex per (s, t).
fn assert_crack_free(m: &Mesh, domain: [[f64; 2]; 2]) {
    let on_boundary = |a: u32, b: u32| {
        let (ua, ub) = (m.uvs[a as usize], m.uvs[b as usize]);
        (0..2).any(|k| ua[k] == ub[k] && (ua[k] == domain[k][0] as f32 || ua[k] == domain[k][1] as f32))
    };
    for (&(a, b), &n) in &edge_uses(m) {
        let want = if on_boundary(a, b) { 1 } else { 2 };
        assert_eq!(n, want, "edge {:?} - {:?}", m.uvs[a as usize], m.uvs[b as usize]);
    }
    let topo = m.topology();
    assert_eq!(
        topo.misoriented_edges + topo.nonmanifold_edges + topo.nonmanifold_vertices,
        0
    );
    let mut uvs: Vec<[u32; 2]> = m.uvs.iter().map(|uv| uv.map(f32::to_bits)).collect();
    uvs.sort_unstable();
    uvs.dedup();
    assert_eq!(uvs.len(), m.positions.len());
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(16))]

    /// Bumps anywhere, of any width, on base grids of any shape: no cracks.
    #[test]
    fn random_bumps_on_random_grids_are_crack_free(
        cs in -1.5f64..1.5,
        ct in -1.5f64..1.5,
        k in 3.0f64..80.0,
        ns in 1u32..7,
        nt in 1u32..7,
        depth in 1u32..6,
    ) {
        let domain = [[-1.0, 1.0], [-0.5, 1.5]];
        let c = coords(
            ["s", "t", &format!("exp(-{k} * ((s - {cs})^2 + (t - {ct})^2))")],
            domain,
        );
        let settings = TessellationSettings {
            initial: [ns, nt],
            max_depth: depth,
            tolerance: Some(1e-3),
            ..Default::default()
        };
        let (m, _) = run(&c, &settings);
        assert_crack_free(&m, domain);
        // A graph over (s, t) wound counter-clockwise in (s, t) faces +z,
        // however coarse the triangles.
        for i in 0..m.triangle_count() {
            assert!(tri_normal(&m, i)[2] > 0.0, "triangle {i}");
        }
    }
}

#[test]
fn adaptive_meshes_are_smaller_than_uniform_ones() {
    let c = bump();
    let settings = TessellationSettings {
        initial: [8, 8],
        tolerance: Some(2e-4),
        max_depth: 5,
        ..Default::default()
    };
    let (m, st) = run(&c, &settings);
    let d = st.max_depth_reached;
    assert_eq!(d, 5);
    let uniform_cells = (8usize << d) * (8usize << d);
    assert!(
        m.triangle_count() * 4 < 2 * uniform_cells,
        "{} vs {}",
        m.triangle_count(),
        2 * uniform_cells
    );
    // A zero tolerance refines everything to the bottom: the uniform grid.
    let (u, ust) = run(
        &c,
        &TessellationSettings {
            tolerance: Some(0.0),
            ..settings
        },
    );
    assert_eq!(ust.leaves_per_depth[d as usize], uniform_cells);
    assert_eq!(u.triangle_count(), 2 * uniform_cells);
    assert!((u.area() - m.area()).abs() < 1e-3 * u.area());
}

#[test]
fn the_same_input_gives_the_same_mesh_whatever_the_threads() {
    let c = bump();
    let settings = TessellationSettings {
        tolerance: Some(1e-4),
        max_depth: 4,
        ..Default::default()
    };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let many = rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap();
    let (a, sa) = one.install(|| tessellate(&c, &settings).unwrap());
    let (b, sb) = many.install(|| tessellate(&c, &settings).unwrap());
    let (c2, _) = tessellate(&c, &settings).unwrap();
    assert_eq!(sa, sb);
    let bits = |m: &Mesh| {
        let mut out: Vec<u32> = Vec::new();
        out.extend(m.positions.iter().flatten().map(|v| v.to_bits()));
        out.extend(m.normals.iter().flatten().map(|v| v.to_bits()));
        out.extend(m.uvs.iter().flatten().map(|v| v.to_bits()));
        out.extend(m.triangles.iter().flatten());
        out
    };
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(bits(&a), bits(&c2));
}

#[test]
fn points_that_are_not_finite_are_skipped() {
    // The upper unit hemisphere as a graph: not finite outside the unit disk.
    let c = coords(["s", "t", "sqrt(1.0 - s^2 - t^2)"], [[-1.0, 1.0], [-1.0, 1.0]]);
    let settings = TessellationSettings {
        max_depth: 4,
        ..Default::default()
    };
    let (m, st) = run(&c, &settings);
    assert!(st.skipped_triangles > 0);
    assert_eq!(st.max_depth_reached, 4);
    for p in &m.positions {
        let p = p.map(f64::from);
        assert!(((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0).abs() < 1e-6);
    }
    // Most of the hemisphere is there (the rim is steep and partly missing).
    let area = m.area();
    assert!(area > 0.8 * 2.0 * PI && area < 2.0 * PI, "{area}");
    assert_eq!(m.topology().nonmanifold_edges, 0);
}

#[test]
fn bad_domains_settings_and_surfaces_are_errors() {
    let flat = coords(["s", "t", "0.0"], [[0.0, 1.0], [0.0, 1.0]]);
    let mut empty = flat.clone();
    empty.domain = [[1.0, 1.0], [0.0, 1.0]];
    let e = tessellate(&empty, &TessellationSettings::default()).unwrap_err();
    assert!(matches!(e, TessellateError::EmptyDomain { .. }));
    assert!(e.to_string().contains("empty"), "{e}");
    let mut inf = flat.clone();
    inf.domain = [[0.0, f64::INFINITY], [0.0, 1.0]];
    assert!(matches!(
        tessellate(&inf, &TessellationSettings::default()),
        Err(TessellateError::EmptyDomain { .. })
    ));
    for bad in [
        TessellationSettings {
            initial: [0, 4],
            ..Default::default()
        },
        TessellationSettings {
            max_depth: 40,
            ..Default::default()
        },
        TessellationSettings {
            tolerance: Some(-1.0),
            ..Default::default()
        },
        TessellationSettings {
            max_angle_deg: f64::NAN,
            ..Default::default()
        },
    ] {
        assert!(matches!(
            tessellate(&flat, &bad),
            Err(TessellateError::InvalidSettings(_))
        ));
    }
    let nowhere = coords(["s", "t", "sqrt(-1.0 - s^2)"], [[0.0, 1.0], [0.0, 1.0]]);
    assert!(matches!(
        tessellate(&nowhere, &TessellationSettings::default()),
        Err(TessellateError::NotFinite { .. })
    ));
}

#[test]
fn stretched_cells_are_split_until_their_sides_are_short() {
    // x = 10 s over [0, 1]: the base grid's cells are 10/16 long in x.
    let c = coords(["10.0 * s", "t", "0.0"], [[0.0, 1.0], [0.0, 1.0]]);
    let settings = TessellationSettings {
        max_edge: Some(0.2),
        ..Default::default()
    };
    let (m, st) = run(&c, &settings);
    assert!(st.max_depth_reached >= 2, "{st:?}");
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (m.positions[t[k] as usize], m.positions[t[(k + 1) % 3] as usize]);
            let (dx, dy) = ((a[0] - b[0]) as f64, (a[1] - b[1]) as f64);
            // Cell sides at most 0.2, so triangle edges at most a diagonal.
            assert!((dx * dx + dy * dy).sqrt() <= 0.2 * 2f64.sqrt() + 1e-6);
        }
    }
    assert_crack_free(&m, [[0.0, 1.0], [0.0, 1.0]]);
}
