//! The thesis's scene: a ball dropped on a fixed plane (dents.md §2.5,
//! KATs 2–4 end to end). The ball falls as gravity says, strikes at
//! sqrt(2gh) with the elastic impulse 2mv, dents the plane exactly as
//! deep as t·κ·(|j| − Y) above the threshold and not at all below it, and
//! the same scene always gives the same impacts.

use isoray_sim::{dent_impact, ImprintMethod, Simulation};

/// A plane of clay (ε = 0.5: Y = 1 N·s; t = 0.1, κ = 0.01) and a ball of
/// radius 0.1 whose bottom is `h` above it, of 1 kg.
fn scene(h: f64) -> isoray_scene::Scene {
    let density = 1.0 / (4.0 / 3.0 * std::f64::consts::PI * 0.001);
    let text = format!(
        "[physics]\ngravity = [0.0, -9.81, 0.0]\ntimestep = 0.0005\n\
         [material.clay]\nrestitution = 0.5\ndent_compliance = 0.01\nthickness = 0.1\n\
         [material.steel]\nrestitution = 0.9\ndensity = {density}\n\
         [[object]]\nname = \"plane\"\nshape = \"p.y\"\nmaterial = \"clay\"\nbody = \"fixed\"\ndents = \"bump\"\n\
         dent_map = {{ size = 256, range = 0.02, uv = \"planar-xz\", extent = 0.5 }}\n\
         [[object]]\nname = \"ball\"\nshape = \"sphere(p, 0.1)\"\nmaterial = \"steel\"\nposition = [0.0, {}, 0.0]\nbody = \"dynamic\"\n",
        0.1 + h
    );
    isoray_scene::load_str(&text, "drop.toml", &[]).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs until the first impact (or `max` seconds); the scene follows.
fn first_impact(s: &mut isoray_scene::Scene, max: f64) -> Option<isoray_sim::Impact> {
    let mut sim = Simulation::new(s).unwrap();
    while sim.time() < max {
        let impacts = sim.step();
        sim.place(s).unwrap();
        if let Some(i) = impacts.into_iter().next() {
            return Some(i);
        }
    }
    None
}

#[test]
fn a_ball_falls_as_gravity_says() {
    let mut s = scene(1.0);
    let mut sim = Simulation::new(&s).unwrap();
    assert!((sim.mass(1).unwrap() - 1.0).abs() < 1e-3, "{:?}", sim.mass(1));
    assert_eq!(sim.mass(0), Some(f64::INFINITY));
    let n = 400;
    for _ in 0..n {
        assert!(sim.step().is_empty());
    }
    sim.place(&mut s).unwrap();
    // y = y0 − g·t²/2 (within what the integrator's steps leave).
    let t = n as f64 * 0.0005;
    let want = 1.1 - 9.81 * t * t / 2.0;
    let y = s.placement(1).position[1];
    assert!((y - want).abs() < 1e-3, "{y} vs {want}");
    // The scene moved with it: the ball's surface is 0.1 below its centre.
    assert!(s.distance([0.0, y - 0.1, 0.0]).abs() < 1e-4);
}

#[test]
fn the_impact_speed_and_impulse_are_the_drops() {
    for h in [0.05, 0.2, 0.5] {
        let mut s = scene(h);
        let i = first_impact(&mut s, 2.0).expect("an impact");
        let v = (2.0 * 9.81 * h).sqrt();
        assert_eq!((i.a, i.b), (0, 1));
        assert!(i.approaching);
        assert!((i.normal[1] - 1.0).abs() < 1e-5, "{:?}", i.normal);
        let speed = -i.velocities[1][1];
        assert!((speed - v).abs() < 0.01 * v + 9.81 * 0.0005, "h {h}: {speed} vs {v}");
        // j = 2mv on a fixed plane (KAT 2).
        assert!(
            (i.impulse - 2.0 * speed).abs() < 1e-4,
            "{} vs {}",
            i.impulse,
            2.0 * speed
        );
        assert_eq!(i.inverse_masses[0], 0.0);
    }
}

#[test]
fn a_drop_dents_the_plane_only_above_the_threshold() {
    // KAT 3: the threshold is 0.5 m/s, a drop of 12.7 mm.
    let mut low = scene(0.008);
    let i = first_impact(&mut low, 2.0).unwrap();
    let rec = dent_impact(&mut low, &i, ImprintMethod::Texel).unwrap();
    assert_eq!(rec.len(), 1);
    assert_eq!((rec[0].depth, rec[0].texels), (0.0, 0));
    assert!(
        low.objects[0].physics.maps.is_none(),
        "no map written below the threshold"
    );
    // KAT 4: above it, the centre of the dent is t·κ·(|j| − Y) deep.
    let mut high = scene(0.2);
    let i = first_impact(&mut high, 2.0).unwrap();
    let rec = dent_impact(&mut high, &i, ImprintMethod::Texel).unwrap();
    let want = 0.1 * 0.01 * (i.impulse - 1.0);
    assert!(
        (rec[0].depth - want).abs() < 1e-12 && want > 0.002,
        "{} vs {want}",
        rec[0].depth
    );
    assert!(rec[0].texels > 20);
    let maps = high.objects[0].physics.maps.as_ref().unwrap();
    // The deepest texel, near the contact (0, 0, 0) at texel (128, 128).
    let mut deepest: f64 = 0.0;
    for y in 120..136 {
        for x in 120..136 {
            deepest = deepest.max(-maps.height.displacement(x, y));
        }
    }
    assert!((deepest - want).abs() < 0.02 * want, "{deepest} vs {want}");
}

#[test]
fn the_same_scene_gives_the_same_impacts() {
    let run = || {
        let mut s = scene(0.3);
        let mut sim = Simulation::new(&s).unwrap();
        let mut all = Vec::new();
        for _ in 0..2000 {
            all.extend(sim.step());
        }
        sim.place(&mut s).unwrap();
        (format!("{all:?}"), s.placement(1))
    };
    let (a, pa) = run();
    let (b, pb) = run();
    assert!(a.contains("Impact"), "the ball bounced");
    assert_eq!(a, b);
    assert_eq!(pa, pb);
}

/// A run's record replayed without physics gives the same dents and the
/// same placements at every frame; the record survives its JSON file.
#[test]
fn a_recorded_run_replays_to_the_same_dents_and_frames() {
    use isoray_sim::run::{replay, run, Record, RunOptions};
    #[derive(Debug)]
    struct E(String);
    impl From<isoray_sim::SimError> for E {
        fn from(e: isoray_sim::SimError) -> E {
            E(e.to_string())
        }
    }
    impl From<isoray_scene::SceneError> for E {
        fn from(e: isoray_scene::SceneError) -> E {
            E(e.rendered)
        }
    }
    let opts = RunOptions {
        duration: 0.6,
        fps: 30.0,
        dents: None,
        imprint: ImprintMethod::Texel,
    };
    let mut s = scene(0.3);
    let mut seen = Vec::new();
    let record = run(&mut s, &opts, |n, sc: &isoray_scene::Scene| -> Result<(), E> {
        seen.push((n, sc.placement(1)));
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{}", e.0));
    assert_eq!(seen.len(), 18);
    let dents: Vec<_> = record
        .impacts
        .iter()
        .filter(|i| i.dents.iter().any(|d| d.depth > 0.0))
        .collect();
    assert!(!dents.is_empty(), "{:?}", record.impacts);
    let path = std::env::temp_dir().join(format!("isoray-sim-record-{}.json", std::process::id()));
    record.write(&path).unwrap();
    let back = Record::read(&path).unwrap();
    assert_eq!(back, record);
    let mut fresh = scene(0.3);
    let mut again = Vec::new();
    replay(
        &mut fresh,
        &back,
        &opts,
        |n, sc: &isoray_scene::Scene| -> Result<(), E> {
            again.push((n, sc.placement(1)));
            Ok(())
        },
    )
    .unwrap();
    assert_eq!(again, seen);
    let (a, b) = (
        s.objects[0].physics.maps.as_ref().unwrap(),
        fresh.objects[0].physics.maps.as_ref().unwrap(),
    );
    assert_eq!(a.height, b.height);
    assert_eq!(a.normals, b.normals);
    // A file that is not a record says where.
    std::fs::write(&path, "{\"timestep\": 0.1, \"fps\": }").unwrap();
    let e = Record::read(&path).unwrap_err();
    assert!(e.contains(":1:") && e.contains("isoray simulate --record"), "{e}");
}

/// `dents = "sdf"`: the same drop cuts the ball out of the plane's
/// geometry; the crater's bottom is t·κ·(|j| − Y) below the plane, under
/// the contact, and the scene's text reloads to the same dented plane.
#[test]
fn a_drop_cuts_a_crater_as_deep_as_the_model_says() {
    let mut s = scene(0.2);
    s.objects[0].physics.dents = isoray_scene::DentMode::Sdf;
    let i = first_impact(&mut s, 2.0).unwrap();
    let rec = dent_impact(&mut s, &i, ImprintMethod::Texel).unwrap();
    let want = 0.1 * 0.01 * (i.impulse - 1.0);
    assert!(rec[0].geometry && (rec[0].depth - want).abs() < 1e-12);
    assert!(s.objects[0].physics.maps.is_none(), "no map: the dent is geometry");
    let dents = &s.objects[0].physics.sdf_dents;
    assert_eq!(dents.len(), 1);
    let plane = |sc: &isoray_scene::Scene, p: [f64; 3]| sc.objects[0].shape.eval_with(&sc.inputs, p);
    let (x, z) = (i.point[0], i.point[2]);
    // 1 mm above the crater's bottom, the plane's distance is 1 mm.
    for h in [0.001, 0.0005] {
        let d = plane(&s, [x, -want + h, z]);
        assert!((d - h).abs() < 1e-6, "{d} vs {h}");
    }
    // The crater's rim: at ρ = sqrt(2rd − d²) from the contact the surface is back at y = 0.
    let rho = (2.0 * 0.1 * want - want * want).sqrt();
    assert!(plane(&s, [x + 1.05 * rho, -1e-4, z]) < 0.0);
    assert!(plane(&s, [x + 0.95 * rho, -1e-4, z]) > 0.0);
    // The bound holds the cap and is not much larger.
    let r = dents[0].bound[3];
    assert!(r > rho && r < 2.0 * rho, "bound {r} for a cap of radius {rho}");
    // Saved and reloaded, the plane is the same.
    let again = isoray_scene::load_str(s.source_text(), "drop.toml", &[]).unwrap();
    for p in [[x, -want + 0.001, z], [x + 0.5 * rho, 0.0, z], [0.3, 0.1, 0.2]] {
        assert_eq!(plane(&again, p), plane(&s, p));
    }
    // `auto` imprints this shallow dent into the map (it is under a quarter
    // of the map's range 0.02)...
    let mut s = scene(0.2);
    s.objects[0].physics.dents = isoray_scene::DentMode::Auto;
    let i = first_impact(&mut s, 2.0).unwrap();
    assert!(want < 0.25 * 0.02);
    let rec = dent_impact(&mut s, &i, ImprintMethod::Texel).unwrap();
    assert!(!rec[0].geometry && rec[0].texels > 0);
    // ... and cuts one that is deeper (a map of range 0.008 takes dents to 2 mm).
    let mut s = scene(0.2);
    s.objects[0].physics.dents = isoray_scene::DentMode::Auto;
    s.objects[0].physics.dent_map.range = 0.008;
    let i = first_impact(&mut s, 2.0).unwrap();
    let rec = dent_impact(&mut s, &i, ImprintMethod::Texel).unwrap();
    assert!(rec[0].geometry && s.objects[0].physics.sdf_dents.len() == 1);
}

/// examples/dents-dome.toml: balls strike a parametric dome, which
/// collides as its sampled (s, t) grid and is dented in its own (s, t).
#[test]
fn balls_strike_and_dent_a_parametric_surface() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/dents-dome.toml");
    let mut s = isoray_scene::load(&path, &[]).unwrap_or_else(|e| panic!("{e}"));
    let i = first_impact(&mut s, 2.0).expect("an impact");
    assert_eq!((i.a, i.b), (0, 1), "ball1 strikes the dome first");
    // The contact is on the dome y = −(x² + z²)/4 (the grid's chords are
    // within a millimetre of it), under the ball dropped at (0.35, ·, 0.15).
    let p = i.point;
    assert!((p[1] + 0.25 * (p[0] * p[0] + p[2] * p[2])).abs() < 5e-3, "{p:?}");
    assert!((p[0] - 0.35).abs() < 0.05 && (p[2] - 0.15).abs() < 0.05, "{p:?}");
    let rec = dent_impact(&mut s, &i, ImprintMethod::Texel).unwrap();
    let want = 0.5 * 0.00006 * (i.impulse - 0.3 / 0.7);
    assert!((rec[0].depth - want).abs() < 1e-12 && rec[0].texels > 50, "{rec:?}");
    let maps = s.objects[0].physics.maps.as_ref().unwrap();
    assert!(
        (maps.height.deepest() - want).abs() < 0.05 * want,
        "{} vs {want}",
        maps.height.deepest()
    );
}

/// A body's mass is its density times its volume: exact for a ball (an
/// exact collider) and, through the hull of its sharp-edged mesh, for a
/// box within a thousandth.
#[test]
fn masses_are_density_times_volume() {
    let text = "[material.m]\ndensity = 1000.0\n\
                [[object]]\nshape = \"box(p, vec3(0.5, 0.25, 0.1))\"\nmaterial = \"m\"\nposition = [0.0, 2.0, 0.0]\nbody = \"dynamic\"\n\
                [[object]]\nshape = \"sphere(p, 0.2)\"\nmaterial = \"m\"\nposition = [3.0, 2.0, 0.0]\nbody = \"dynamic\"\n";
    let s = isoray_scene::load_str(text, "m.toml", &[]).unwrap();
    let sim = Simulation::new(&s).unwrap();
    let box_mass = sim.mass(0).unwrap();
    assert!((box_mass - 100.0).abs() < 0.1, "{box_mass}");
    let ball = 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.008;
    assert!((sim.mass(1).unwrap() - ball).abs() < 1e-3 * ball, "{:?}", sim.mass(1));
}
