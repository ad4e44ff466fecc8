//! Dents as geometry: `[[object.sdf_dent]]` edits against their analytic
//! distances, the bounding tree against an eager evaluation, errors, and
//! `Scene::add_sdf_dents`.

use isoray_scene::{load_str, Placement, SdfDent};

fn ball_dent(c: [f64; 3], r: f64, depth: f64) -> SdfDent {
    // A ball of radius r whose lowest point is `depth` below the plane y = 0.
    let centre = [c[0], r - depth, c[2]];
    let cap = (2.0 * r * depth - depth * depth).sqrt();
    SdfDent {
        shape: format!("length(p) - {r:?}"),
        placement: Placement {
            position: centre,
            ..Default::default()
        },
        rim: 0.0,
        bound: [c[0], -0.5 * depth, c[2], 1.05 * (cap.max(depth))],
    }
}

fn plane_with(dents: &[SdfDent]) -> isoray_scene::Scene {
    let base = "[[object]]\nname = \"floor\"\nshape = \"p.y\"\ndents = \"sdf\"\n";
    let text = isoray_scene::append_sdf_dents_to_text(base, "t.toml", 0, dents).unwrap();
    load_str(&text, "t.toml", &[]).unwrap()
}

/// The dented plane's distance, by brute force: max(y, max_i(r_i − |p − c_i|)).
fn brute(p: [f64; 3], dents: &[(f64, [f64; 3])]) -> f64 {
    dents.iter().fold(p[1], |d, &(r, c)| {
        let l = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt();
        d.max(r - l)
    })
}

#[test]
fn one_dent_is_the_plane_minus_the_ball() {
    let (r, depth) = (0.25, 0.05);
    let scene = plane_with(&[ball_dent([0.0; 3], r, depth)]);
    let c = [0.0, r - depth, 0.0];
    // The crater's bottom is `depth` below the plane: a point above it.
    assert!((scene.distance([0.0, 0.1, 0.0]) - (0.1 + depth)).abs() < 1e-12);
    for &p in &[
        [0.0, 0.3, 0.0],
        [0.05, -0.01, 0.02],
        [0.1, 0.01, 0.0],
        [0.3, 0.2, 0.0],
        [2.0, 0.5, -1.0],
        [0.0, -0.5, 0.0],
    ] {
        let want = brute(p, &[(r, c)]);
        let have = scene.distance(p);
        assert!((have - want).abs() < 1e-12, "at {p:?}: {have} vs {want}");
    }
}

#[test]
fn a_thousand_dents_in_a_tree_of_bounds_match_brute_force_outside() {
    // 1,000 dents on a 40 x 25 grid of spacing 0.1, depths varying.
    let mut dents = Vec::new();
    let mut analytic = Vec::new();
    for i in 0..40 {
        for j in 0..25 {
            let (r, depth) = (0.04, 0.004 + 0.00001 * ((i * 7 + j * 3) % 50) as f64);
            let c = [i as f64 * 0.1 - 2.0, 0.0, j as f64 * 0.1 - 1.25];
            dents.push(ball_dent(c, r, depth));
            analytic.push((r, [c[0], r - depth, c[2]]));
        }
    }
    let scene = plane_with(&dents);
    assert_eq!(scene.objects[0].physics.sdf_dents.len(), 1000);
    // Above the plane, outside the impactors, the tree of skips changes
    // nothing; inside an impactor but outside its dent's bound it gives
    // the plane's distance, smaller than the edit's: still a bound of the
    // same sign, so sphere tracing stays safe.
    let mut worst: f64 = 0.0;
    let mut lowered = 0;
    for k in 0..4000 {
        let a = k as f64 * 0.618;
        let p = [
            (a * 1.3).sin() * 2.2,
            0.0005 + 0.2 * ((a * 0.7).cos() * 0.5 + 0.5).powi(3),
            (a * 0.9).cos() * 1.4,
        ];
        let (have, want) = (scene.distance(p), brute(p, &analytic));
        let in_an_impactor = analytic
            .iter()
            .any(|&(r, c)| ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt() < r);
        if in_an_impactor {
            assert!(have <= want + 1e-12 && have > 0.0, "at {p:?}: {have} vs {want}");
            lowered += usize::from(have < want - 1e-12);
        } else {
            worst = worst.max((have - want).abs());
        }
    }
    assert!(lowered > 0, "some points inside an impactor were tested");
    // Points inside the craters (below y = 0, above the crater floors).
    for (_, c) in analytic.iter().step_by(37) {
        let p = [c[0] + 0.001, -0.001, c[2] - 0.002];
        worst = worst.max((scene.distance(p) - brute(p, &analytic)).abs());
    }
    assert!(worst < 1e-12, "largest difference {worst}");
    // The tape nests the bounds: far from the dents, one test skips them all.
    let tape = scene.objects[0].shape.tape();
    let skips = tape
        .instrs()
        .iter()
        .filter(|i| matches!(i, isoray_shape::ir::Instr::Skip { .. }))
        .count();
    assert_eq!(skips, 1999, "a leaf per dent and 999 inner nodes");
}

#[test]
fn a_rim_rounds_the_edge_and_keeps_the_bottom() {
    let mut d = ball_dent([0.0; 3], 0.25, 0.05);
    d.rim = 0.02;
    d.bound[3] += 0.02;
    let sharp = plane_with(&[ball_dent([0.0; 3], 0.25, 0.05)]);
    let soft = plane_with(&[d]);
    // The bottom is as deep; at the edge (|x| = cap radius) the soft
    // crater is lower: material is rounded off.
    let bottom = [0.0, -0.04, 0.0];
    assert!((soft.distance(bottom) - sharp.distance(bottom)).abs() < 1e-9);
    let cap = (2.0f64 * 0.25 * 0.05 - 0.05 * 0.05).sqrt();
    let edge = [cap, 0.001, 0.0];
    assert!(soft.distance(edge) > sharp.distance(edge) + 1e-3);
    // Far away it is the plane.
    assert_eq!(soft.distance([1.0, 0.3, 0.0]), 0.3);
}

#[test]
fn dents_follow_a_placed_object_and_errors_are_located() {
    // The plate is moved and turned: the dent moves with it.
    let base =
        "[[object]]\nshape = \"p.y\"\nposition = [1.0, 2.0, 3.0]\nrotation = [0.0, 0.0, 90.0]\ndents = \"sdf\"\n";
    let text = isoray_scene::append_sdf_dents_to_text(base, "t.toml", 0, &[ball_dent([0.0; 3], 0.25, 0.05)]).unwrap();
    let scene = load_str(&text, "t.toml", &[]).unwrap();
    // The plate's local +y is world −x: the crater's bottom is at (1.05, 2, 3).
    assert!((scene.distance([0.9, 2.0, 3.0]) - 0.15).abs() < 1e-12);
    assert!((scene.distance([0.9, 2.5, 3.0]) - 0.1).abs() < 1e-12);

    let bad = format!("{base}\n[[object.sdf_dent]]\nshape = \"length(q) - 0.2\"\nbound = [0.0, 0.0, 0.0, 0.3]\n");
    let e = load_str(&bad, "t.toml", &[]).unwrap_err();
    assert!(e.rendered.contains("t.toml:8:"), "{}", e.rendered);
    let missing = format!("{base}\n[[object.sdf_dent]]\nshape = \"length(p) - 0.2\"\n");
    let e = load_str(&missing, "t.toml", &[]).unwrap_err();
    assert!(e.rendered.contains("needs a `bound`"), "{}", e.rendered);
    let wrong = format!("{base}\n[[object.sdf_dent]]\nshape = \"length(p) - 0.2\"\nbound = [0.0, 0.0, -1.0]\n");
    let e = load_str(&wrong, "t.toml", &[]).unwrap_err();
    assert!(e.rendered.contains("object.0.sdf_dent.0.bound"), "{}", e.rendered);
}

#[test]
fn add_sdf_dents_recompiles_one_object_and_keeps_placements() {
    let text = "[[object]]\nname = \"floor\"\nshape = \"p.y\"\ndents = \"sdf\"\n\n[[object]]\nname = \"ball\"\nshape = \"length(p) - 0.25\"\nposition = [0.0, 1.0, 0.0]\nbody = \"dynamic\"\n";
    let mut scene = load_str(text, "t.toml", &[]).unwrap();
    let moved = Placement {
        position: [0.5, 0.7, 0.0],
        ..Default::default()
    };
    scene.set_placement(1, moved).unwrap();
    let before = scene.object_cache().stats();
    scene.add_sdf_dents(0, &[ball_dent([0.0; 3], 0.25, 0.05)]).unwrap();
    let after = scene.object_cache().stats();
    assert_eq!(after.compiled - before.compiled, 1, "only the dented floor compiles");
    assert_eq!(scene.placement(1), moved);
    assert!((scene.distance([0.0, 0.1, 0.0]) - 0.15).abs() < 1e-12);
    assert!(scene.source_text().contains("[[object.sdf_dent]]"));
    // The text reloads to the same dents.
    let again = load_str(scene.source_text(), "t.toml", &[]).unwrap();
    assert_eq!(again.objects[0].physics.sdf_dents, scene.objects[0].physics.sdf_dents);
    // A dent on an object that is not there is an error; the scene is unchanged.
    assert!(scene.add_sdf_dents(5, &[ball_dent([0.0; 3], 0.1, 0.01)]).is_err());
    assert_eq!(scene.objects[0].physics.sdf_dents.len(), 1);
}
