//! `[physics]` and the body, dent and material keys: defaults, values,
//! placements, and located errors.

#![allow(clippy::result_large_err)]

use isoray_scene::{BodyKind, Collider, DentMode};

fn load(text: &str) -> Result<isoray_scene::Scene, isoray_scene::SceneError> {
    isoray_scene::load_str(text, "t.toml", &[])
}

#[test]
fn physics_and_dent_keys_have_their_defaults() {
    let s = load("[[object]]\nshape = \"sphere(p, 1.0)\"\n").unwrap();
    assert!(s.physics.is_none());
    let o = &s.objects[0].physics;
    assert_eq!(
        (o.body, o.collider, o.dents),
        (BodyKind::None, Collider::Auto, DentMode::None)
    );
    assert_eq!(o.dent_map.size, 512);
    assert_eq!(o.dent_map.uv, "planar-xz");
    let m = &s.materials[s.objects[0].material];
    assert_eq!(
        (m.density, m.restitution, m.dent_compliance, m.thickness),
        (1000.0, 0.5, 0.0, 1.0)
    );
}

#[test]
fn physics_and_dent_keys_are_read() {
    let s = load(
        "[physics]\ngravity = [0.0, -1.62, 0.0]\ntimestep = 0.01\nduration = 3.0\n\
         [material.clay]\nrestitution = 0.2\ndent_compliance = 0.02\nthickness = 0.5\ndensity = 1800.0\n\
         [[object]]\nname = \"plate\"\nshape = \"p.y\"\nmaterial = \"clay\"\nbody = \"fixed\"\ndents = \"bump\"\n\
         dent_map = { size = 128, range = 0.02, uv = \"spherical\", extent = 3.0 }\n\
         [[object]]\nname = \"ball\"\nshape = \"sphere(p, 0.1)\"\nposition = [1.0, 2.0, 3.0]\nrotation = [0.0, 90.0, 0.0]\n\
         body = \"dynamic\"\nvelocity = [0.0, -2.0, 0.0]\nangular_velocity = [0.0, 0.0, 1.0]\ncollider = \"hull\"\n",
    )
    .unwrap();
    let p = s.physics.unwrap();
    assert_eq!((p.gravity, p.timestep, p.duration), ([0.0, -1.62, 0.0], 0.01, 3.0));
    let plate = &s.objects[s.object_named("plate").unwrap()];
    assert_eq!(
        (plate.physics.body, plate.physics.dents),
        (BodyKind::Fixed, DentMode::Bump)
    );
    assert_eq!(plate.physics.dent_map.size, 128);
    assert_eq!(plate.physics.dent_map.uv, "spherical");
    let m = &s.materials[plate.material];
    assert_eq!(
        (m.restitution, m.dent_compliance, m.thickness, m.density),
        (0.2, 0.02, 0.5, 1800.0)
    );
    let b = s.object_named("ball").unwrap();
    let ball = &s.objects[b].physics;
    assert_eq!((ball.body, ball.collider), (BodyKind::Dynamic, Collider::Hull));
    assert_eq!(
        (ball.velocity, ball.angular_velocity),
        ([0.0, -2.0, 0.0], [0.0, 0.0, 1.0])
    );
    // Its placement as numbers: the local +z turned 90° about y is world +x.
    let place = s.placement(b);
    let w = place.to_world([0.0, 0.0, 1.0]);
    assert!(
        (w[0] - 2.0).abs() < 1e-12 && (w[1] - 2.0).abs() < 1e-12 && (w[2] - 3.0).abs() < 1e-12,
        "{w:?}"
    );
    assert!((s.objects[b].shape.eval_with(&s.inputs, w) - 0.9).abs() < 1e-9);
}

#[test]
fn bad_physics_and_dent_keys_name_the_place_and_what_was_expected() {
    for (text, want) in [
        (
            "[[object]]\nshape = \"p.y\"\nbody = \"floating\"\n",
            "`object.0.body`: expected one of \"none\", \"fixed\", \"dynamic\", \"kinematic\"",
        ),
        (
            "[[object]]\nshape = \"p.y\"\ndent_map = { uv = \"triplanar\" }\n",
            "`object.0.dent_map.uv`: triplanar is not one-to-one",
        ),
        (
            "[[object]]\nshape = \"p.y\"\ndent_map = { uv = \"planar-xx\" }\n",
            "unknown uv mapping `planar-xx`",
        ),
        (
            "[[object]]\nshape = \"p.y\"\ndent_map = { size = 4 }\n",
            "`object.0.dent_map.size`: expected an integer from 8 to 16384",
        ),
        (
            "[[object]]\nshape = \"p.y\"\ndent_map = { range = 0.0 }\n",
            "`object.0.dent_map.range`: expected a positive number",
        ),
        (
            "[[object]]\nshape = \"p.y\"\ndent_map = { sizes = 64 }\n",
            "unknown key `sizes` in `object.0.dent_map`",
        ),
        (
            "[material.m]\nrestitution = 1.5\n[[object]]\nshape = \"p.y\"\n",
            "restitution",
        ),
        ("[physics]\ntimestep = -1.0\n", "`physics.timestep`"),
        (
            "[physics]\ngravity = 9.81\n",
            "`physics.gravity`: expected an array of 3 numbers",
        ),
    ] {
        let e = load(text).unwrap_err();
        assert!(e.rendered.contains(want), "{text}\n---\n{}", e.rendered);
        assert!(e.rendered.contains("t.toml:"), "located: {}", e.rendered);
    }
}

#[test]
fn dent_maps_attach_from_a_folder_by_name() {
    let dir = std::env::temp_dir().join(format!("isoray-scene-maps-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = "[[object]]\nname = \"plate\"\nshape = \"p.y\"\ndents = \"bump\"\ndent_map = { size = 32 }\n\
                [[object]]\nname = \"other\"\nshape = \"sphere(p, 1.0)\"\n";
    let mut s = load(text).unwrap();
    assert_eq!(s.attach_dent_maps(&dir).unwrap(), Vec::<String>::new());
    let mut maps = s.objects[0].physics.dent_map.blank().unwrap();
    maps.height.lower_min(3, 4, 0.2);
    maps.update_normals();
    maps.write(&dir, "plate").unwrap();
    assert_eq!(s.attach_dent_maps(&dir).unwrap(), vec!["plate".to_string()]);
    let got = s.objects[0].physics.maps.as_ref().unwrap();
    assert!((got.height.get(3, 4) - 0.2).abs() < 1e-4);
    assert!(s.objects[1].physics.maps.is_none());
    // A map of another size is refused, naming the file.
    let mut small = load(&text.replace("size = 32", "size = 16")).unwrap();
    let e = small.attach_dent_maps(&dir).unwrap_err();
    assert!(e.contains("plate-height.png") && e.contains("16x16"), "{e}");
    assert!(s
        .attach_dent_maps(&dir.join("missing"))
        .unwrap_err()
        .contains("no such folder"));
}
