//! `[[midi]]` mappings and MIDI takes: a file with a known ramp (and a
//! tempo change) drives a parameter, and every frame sees the value of the
//! last control change at or before its time.

use isoray_scene::midi::{read_midi_file, MidiEvent};
use isoray_scene::{load_str, Scene, SceneError};
use midly::num::{u15, u24, u28, u4, u7};
use midly::{Format, Header, MetaMessage, MidiMessage, Smf, Timing, TrackEvent, TrackEventKind};

const SCENE: &str = r#"
[animation]
fps = 8
duration = 4.0
[params]
k = { default = 200.0, range = [0.0, 300.0] }
[[light]]
[[object]]
shape = "sphere(p, 1.0 + k)"
[[object]]
shape = "box(p, vec3(0.5))"
[[midi]]
cc = 7
channel = 3
target = "params.k"
range = [0.0, 254.0]
[[midi]]
note = 36
target = "object.1.scale"
range = [0.5, 2.0]
curve = "exponential"
"#;

fn scene(text: &str) -> Scene {
    load_str(text, "midi.toml", &[]).unwrap_or_else(|e| panic!("{}", e.rendered))
}

fn error(text: &str) -> SceneError {
    match load_str(text, "midi.toml", &[]) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e,
    }
}

/// A ramp of CC 7 on channel 3: value v = 0, 1, …, 40, one every 24 ticks
/// from tick 10, at 96 ticks a beat; 120 beats a minute until tick 250,
/// then 240. Noise on other channels and controllers. Returns the file's
/// bytes and each ramp event's (time in seconds, value), computed here.
fn ramp() -> (Vec<u8>, Vec<(f64, u8)>) {
    let ev = |delta: u32, kind| TrackEvent {
        delta: u28::new(delta),
        kind,
    };
    let cc = |ch: u8, c: u8, v: u8| TrackEventKind::Midi {
        channel: u4::new(ch - 1),
        message: MidiMessage::Controller {
            controller: u7::new(c),
            value: u7::new(v),
        },
    };
    // Absolute ticks of every event, then deltas.
    let mut abs: Vec<(u32, TrackEventKind)> = vec![(0, TrackEventKind::Meta(MetaMessage::Tempo(u24::new(500_000))))];
    abs.push((250, TrackEventKind::Meta(MetaMessage::Tempo(u24::new(250_000)))));
    let mut want = Vec::new();
    let seconds = |tick: u32| -> f64 {
        if tick <= 250 {
            f64::from(tick) / 96.0 * 0.5
        } else {
            250.0 / 96.0 * 0.5 + f64::from(tick - 250) / 96.0 * 0.25
        }
    };
    for v in 0..=40u8 {
        let tick = 10 + 24 * u32::from(v);
        abs.push((tick, cc(3, 7, v)));
        abs.push((tick + 3, cc(4, 7, 127 - v))); // another channel: not heard
        abs.push((tick + 5, cc(3, 8, 99))); // another controller: not heard
        want.push((seconds(tick), v));
    }
    abs.sort_by_key(|e| e.0);
    let mut track = Vec::new();
    let mut last = 0;
    for (tick, kind) in abs {
        track.push(ev(tick - last, kind));
        last = tick;
    }
    track.push(ev(0, TrackEventKind::Meta(MetaMessage::EndOfTrack)));
    let smf = Smf {
        header: Header::new(Format::SingleTrack, Timing::Metrical(u15::new(96))),
        tracks: vec![track],
    };
    let mut bytes = Vec::new();
    smf.write_std(&mut bytes).unwrap();
    (bytes, want)
}

#[test]
fn a_recorded_ramp_drives_the_parameter_at_every_frame() {
    let (bytes, want) = ramp();
    let dir = std::env::temp_dir().join(format!("isoray-midi-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("ramp.mid");
    std::fs::write(&path, &bytes).unwrap();
    let events: Vec<MidiEvent> = read_midi_file(&path).unwrap();
    let mut s = scene(SCENE);
    s.play_midi(&events).unwrap();
    let anim = s.animation.unwrap();
    let mut seen_before_first = 0;
    for n in 0..anim.frame_count() {
        let t = anim.time_of(n);
        s.set_time(t).unwrap();
        // No ramp event sits on a frame's time, so "at or before" is clear.
        assert!(want.iter().all(|(et, _)| (et - t).abs() > 1e-6));
        let expected = match want.iter().rev().find(|(et, _)| *et <= t) {
            Some((_, v)) => 254.0 * f64::from(*v) / 127.0,
            None => {
                seen_before_first += 1;
                200.0 // the scene's own value
            }
        };
        let k = match s.params[0].1 {
            isoray_shape::Value::Float(k) => k,
            other => panic!("{other:?}"),
        };
        assert!(
            (k - expected).abs() < 1e-12,
            "frame {n} (t = {t}): k = {k}, expected {expected}"
        );
        // The sphere reads it: the distance at the origin is −(1 + k).
        assert!((s.distance([0.0, 0.0, 0.0]) + 1.0 + expected).abs() < 1e-9);
    }
    assert_eq!(seen_before_first, 1, "frame 0 comes before the first event");
    // Scrubbing back before the first event gives the scene's own value again.
    s.set_time(0.0).unwrap();
    assert_eq!(s.params[0].1, isoray_shape::Value::Float(200.0));
    // The tempo change: the last event (v = 40, tick 970) is at 250/96·0.5 + 720/96·0.25 s.
    assert!((want[40].0 - (250.0 / 96.0 * 0.5 + 720.0 / 96.0 * 0.25)).abs() < 1e-12);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn live_values_and_notes_drive_their_targets() {
    let mut s = scene(SCENE);
    // A pad: velocity 127 gives 2x, as the exponential range says.
    s.set_midi_value(1, 127).unwrap();
    let d = s.objects[1].shape.eval_with(&s.inputs, [2.0, 0.0, 0.0]);
    assert!((d - 1.0).abs() < 1e-9, "a box of half-size 1 at 2x: {d}");
    s.set_midi_value(0, 127).unwrap();
    assert_eq!(s.params[0].1, isoray_shape::Value::Float(254.0));
    assert!(s.set_midi_value(5, 1).is_err());
}

#[test]
fn bad_mappings_are_errors_at_their_place() {
    let with = |m: &str| {
        format!("[params]\nk = {{ default = 1.0, range = [0.0, 2.0] }}\nv = [0.0, 0.0, 0.0]\n[[object]]\nshape = \"sphere(p, k)\"\n[[midi]]\n{m}\n")
    };
    let cases = [
        ("target = \"params.k\"", "needs a `cc`", 6),
        ("cc = 1\nnote = 2\ntarget = \"params.k\"", "both `cc` and `note`", 6),
        ("cc = 128\ntarget = \"params.k\"", "an integer from 0 to 127", 7),
        (
            "cc = 1\nchannel = 0\ntarget = \"params.k\"",
            "an integer from 1 to 16",
            8,
        ),
        ("cc = 1", "needs a `target`", 6),
        ("cc = 1\ntarget = \"params.v\"", "a MIDI mapping drives one number", 8),
        (
            "cc = 1\ntarget = \"params.k\"\nrange = [0.0, 5.0]",
            "its range sets `params.k` = 5",
            8,
        ),
        (
            "cc = 1\ntarget = \"params.k\"\nrange = [0.0, 1.0]\ncurve = \"exponential\"",
            "of one sign, not 0",
            9,
        ),
        ("cc = 1\ntarget = \"object.0.position\"", "drives one number", 8),
        ("cc = 1\ntarget = \"light.0.intensity\"", "the scene has 0 light(s)", 8),
    ];
    for (m, want, line) in cases {
        let e = error(&with(m));
        assert!(e.message.contains(want), "{m}: expected `{want}` in {}", e.rendered);
        assert_eq!(e.line, Some(line), "{m}: {}", e.rendered);
    }
    // A mapping and a track on one value.
    let text = format!(
        "{}[[track]]\ntarget = \"params.k\"\nkeys = [[0.0, 1.0]]\n",
        with("cc = 1\ntarget = \"params.k\"")
    );
    let e = error(&text);
    assert!(
        e.message
            .contains("`midi.0` drives `params.k`, which `track.0` drives already"),
        "{}",
        e.message
    );
}
