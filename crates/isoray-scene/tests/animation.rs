//! `[animation]` and `[[track]]`: tracks drive parameters, placements,
//! lights and the camera as runtime values (nothing recompiles), conflicts
//! and bad keys are errors at their place.

use isoray_scene::{load_str, load_str_with, Interpolation, LoadOptions, Scene, SceneError};
use isoray_shape::Value;

fn scene(text: &str) -> Scene {
    load_str(text, "anim.toml", &[]).unwrap_or_else(|e| panic!("{}", e.rendered))
}

fn error(text: &str) -> SceneError {
    match load_str(text, "anim.toml", &[]) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e,
    }
}

const BASE: &str = r#"
[animation]
fps = 10
duration = 2.0
[params]
r = { default = 1.0, range = [0.1, 3.0] }
[[light]]
intensity = 1.0
[[object]]
shape = "sphere(p, r)"
[[object]]
shape = "box(p, vec3(0.5))"
"#;

#[test]
fn the_animation_table_gives_the_clock() {
    let s = scene(BASE);
    let a = s.animation.expect("[animation]");
    assert_eq!((a.fps, a.duration), (10.0, 2.0));
    assert_eq!(a.frame_count(), 20);
    assert_eq!(a.time_of(7), 0.7);
}

#[test]
fn a_parameter_track_drives_its_input_without_recompiling() {
    let text = format!("{BASE}[[track]]\ntarget = \"params.r\"\nkeys = [[0.0, 1.0], [1.0, 2.0]]\n");
    let mut s = scene(&text);
    let tape = s.objects[0].shape.tape().clone();
    assert_eq!(s.distance([3.0, 0.0, 0.0]), 2.0, "r = 1 at t = 0");
    s.set_time(0.5).unwrap();
    assert_eq!(s.objects[0].shape.tape(), &tape, "nothing recompiled");
    assert_eq!(
        s.distance([3.0, 0.0, 0.0]),
        1.5,
        "r = 1.5, the mean of the keys, at the midpoint"
    );
    assert_eq!(s.params[0].1, Value::Float(1.5));
    s.set_time(9.0).unwrap();
    assert_eq!(s.distance([3.0, 0.0, 0.0]), 1.0, "held at the last key");
    // A tracked parameter is not set by hand.
    let e = s.set_param("r", Value::Float(0.5)).unwrap_err();
    assert!(e.message.contains("driven by `track.0`"), "{}", e.message);
}

#[test]
fn an_object_track_places_an_object_that_the_file_does_not() {
    let text = format!(
        "{BASE}[[track]]\ntarget = \"object.1.position\"\nkeys = [[0.0, [0.0, 0.0, 0.0]], [2.0, [4.0, 0.0, 0.0]]]\n"
    );
    let mut s = scene(&text);
    assert!(
        s.objects[1].transform.is_some(),
        "the track gives the object placement inputs"
    );
    let tape = s.objects[1].shape.tape().clone();
    s.set_time(1.0).unwrap();
    assert_eq!(s.objects[1].shape.tape(), &tape);
    // The box's centre is at x = 2: the distance there is −0.5.
    let d = s.objects[1].shape.eval_with(&s.inputs, [2.0, 0.0, 0.0]);
    assert!((d + 0.5).abs() < 1e-12, "{d}");
}

#[test]
fn light_and_camera_tracks_set_their_values() {
    let text = format!(
        "{BASE}[camera]\nposition = [0.0, 0.0, 5.0]\n[[track]]\ntarget = \"light.0.intensity\"\nkeys = [[0.0, 1.0], [1.0, 0.0]]\ninterpolation = \"step\"\n[[track]]\ntarget = \"camera.position\"\nkeys = [[0.0, [0.0, 0.0, 5.0]], [1.0, [0.0, 2.0, 5.0]]]\ninterpolation = \"linear\"\n"
    );
    let mut s = scene(&text);
    s.set_time(0.5).unwrap();
    assert_eq!(s.lights[0].intensity, 1.0, "a step holds the key at 0");
    assert_eq!(s.camera.position, [0.0, 1.0, 5.0]);
    s.set_time(1.0).unwrap();
    assert_eq!(s.lights[0].intensity, 0.0);
    assert_eq!(s.camera.position, [0.0, 2.0, 5.0]);
    assert_eq!(
        s.track_of("camera.position").unwrap().interpolation,
        Interpolation::Linear
    );
}

#[test]
fn a_load_at_a_time_equals_a_load_moved_to_it() {
    let text = format!(
        "{BASE}[[track]]\ntarget = \"params.r\"\nkeys = [[0.0, 1.0], [0.5, 2.5], [1.0, 0.5], [2.0, 1.0]]\ninterpolation = \"smooth\"\nloop = true\n[[track]]\ntarget = \"object.1.rotation\"\nkeys = [[0.0, [0.0, 0.0, 0.0]], [2.0, [0.0, 90.0, 0.0]]]\n[[track]]\ntarget = \"light.0.intensity\"\nkeys = [[0.0, 1.0], [2.0, 3.0]]\n"
    );
    let mut moved = scene(&text);
    for t in [0.3, 1.7, 2.6] {
        moved.set_time(t).unwrap();
        let opts = LoadOptions {
            time: t,
            ..LoadOptions::default()
        };
        let loaded = load_str_with(&text, "anim.toml", &[], &opts).unwrap();
        assert_eq!(loaded.inputs, moved.inputs, "t = {t}");
        assert_eq!(loaded.lights[0].intensity, moved.lights[0].intensity);
    }
}

#[test]
fn a_value_with_an_expression_and_a_track_is_an_error_that_names_both() {
    let text = "[animation]\nduration = 1.0\n[[light]]\nintensity = \"1.0 + t\"\n[[object]]\nshape = \"sphere(p, 1.0)\"\n[[track]]\ntarget = \"light.0.intensity\"\nkeys = [[0.0, 1.0]]\n";
    let e = error(text);
    assert!(
        e.message.contains("anim.toml:4:13"),
        "the expression's place: {}",
        e.message
    );
    assert!(e.message.contains("track.0"), "{}", e.message);
    assert_eq!(e.line, Some(8), "the error is at the track's target");
    let text = "[[object]]\nshape = \"sphere(p, 1.0)\"\nposition = [\"t\", 0.0, 0.0]\n[[track]]\ntarget = \"object.0.position\"\nkeys = [[0.0, [1.0, 0.0, 0.0]]]\n";
    let e = error(text);
    assert!(
        e.message.contains("expression of `t` (anim.toml:3:12)"),
        "{}",
        e.message
    );
    // A plain number and a track: the track drives it.
    let text = "[[object]]\nshape = \"sphere(p, 1.0)\"\nposition = [5.0, 0.0, 0.0]\n[[track]]\ntarget = \"object.0.position\"\nkeys = [[0.0, [1.0, 0.0, 0.0]]]\n";
    let s = scene(text);
    assert_eq!(s.distance([1.0, 0.0, 0.0]), -1.0);
}

#[test]
fn bad_tracks_are_errors_at_their_place() {
    let with = |track: &str| format!("{BASE}[[track]]\n{track}\n");
    let cases = [
        ("target = \"params.q\"\nkeys = [[0.0, 1.0]]", "no parameter `q`", 14),
        (
            "target = \"params.r\"\nkeys = [[0.0, [1.0, 2.0, 3.0]]]",
            "1 component(s), found 3",
            14,
        ),
        (
            "target = \"params.r\"\nkeys = [[0.0, 9.0]]",
            "outside the parameter's range [0.1, 3]",
            14,
        ),
        (
            "target = \"object.5.position\"\nkeys = [[0.0, [0, 0, 0]]]",
            "the scene has 2",
            14,
        ),
        (
            "target = \"object.0.colour\"\nkeys = [[0.0, 1.0]]",
            "`position`, `rotation` or `scale`",
            14,
        ),
        (
            "target = \"render.aa\"\nkeys = [[0.0, 1.0]]",
            "not a value a track can drive",
            14,
        ),
        (
            "target = \"light.0.intensity\"\nkeys = [[0.0, -1.0]]",
            "the key at t = 0",
            14,
        ),
        (
            "target = \"params.r\"\nkeys = [[1.0, 1.0], [0.5, 2.0]]",
            "a time after the previous key's 1",
            15,
        ),
        ("target = \"params.r\"\nkeys = []", "at least one", 15),
        (
            "target = \"params.r\"\nkeys = [[0.0, 1.0]]\ninterpolation = \"cubic\"",
            "\"step\", \"linear\", \"smooth\"",
            16,
        ),
        ("keys = [[0.0, 1.0]]", "needs a `target`", 13),
    ];
    for (track, want, line) in cases {
        let e = error(&with(track));
        assert!(e.message.contains(want), "{track}: expected `{want}` in {}", e.rendered);
        assert_eq!(e.line, Some(line), "{track}: {}", e.rendered);
    }
    // Two tracks on one value.
    let text = format!("{BASE}[[track]]\ntarget = \"params.r\"\nkeys = [[0.0, 1.0]]\n[[track]]\ntarget = \"params.r\"\nkeys = [[0.0, 2.0]]\n");
    assert!(error(&text).message.contains("`track.0` drives already"));
    // [animation] needs a duration.
    let e = error("[animation]\nfps = 24\n");
    assert!(e.message.contains("needs a `duration`"), "{}", e.message);
}
