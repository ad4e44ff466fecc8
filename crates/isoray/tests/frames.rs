//! `isoray render --frames`, `--shard`, `--tile` and `isoray merge`: every
//! split gives the bytes of a single-process render, and frame n is
//! `isoray render --time n/fps`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn isoray() -> Command {
    Command::new(env!("CARGO_BIN_EXE_isoray"))
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("isoray-frames-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(cmd: &mut Command) -> Output {
    cmd.output().expect("isoray runs")
}

fn ok(cmd: &mut Command) -> Output {
    let o = run(cmd);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// examples/tracks.toml at 48×32: a parameter on a smooth track, an object
/// moved by a linear track, a light's intensity on a step track, and a
/// camera whose height is an expression of t; 4 frames a second for 1.5 s
/// (6 frames).
fn scene(d: &Path) -> PathBuf {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/tracks.toml")).unwrap();
    let text = text
        .replace("width = 640", "width = 48")
        .replace("height = 360", "height = 32");
    let p = d.join("anim.toml");
    std::fs::write(&p, text).unwrap();
    p
}

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn each_frame_is_the_render_at_its_time_and_shards_write_the_same_frames() {
    let d = dir("frames");
    let s = scene(&d);
    // All frames to the end of the duration: 0..5.
    let o = ok(isoray()
        .args(["render"])
        .arg(&s)
        .args(["--frames", "0.."])
        .arg("-o")
        .arg(d.join("f_%04d.png")));
    assert!(stderr(&o).contains("6 frames"), "{}", stderr(&o));
    assert!(!d.join("f_0006.png").exists());
    let mut distinct = std::collections::HashSet::new();
    for n in 0..6 {
        let still = d.join(format!("still_{n}.png"));
        ok(isoray()
            .arg("render")
            .arg(&s)
            .args(["--time", &format!("{n}/4"), "-q", "-o"])
            .arg(&still));
        let frame = read(&d.join(format!("f_{n:04}.png")));
        assert_eq!(frame, read(&still), "frame {n} differs from --time {n}/4");
        distinct.insert(frame);
    }
    assert_eq!(distinct.len(), 6, "every frame moves");
    // Four shards of 0..5, each its own process, write the same bytes.
    for i in 0..4 {
        ok(isoray()
            .arg("render")
            .arg(&s)
            .args(["--frames", "0..5", "--shard", &format!("{i}/4"), "-q", "-o"])
            .arg(d.join("s_%04d.png")));
    }
    for n in 0..6 {
        assert_eq!(
            read(&d.join(format!("s_{n:04}.png"))),
            read(&d.join(format!("f_{n:04}.png"))),
            "frame {n}"
        );
    }
    // A sub-range renders only its frames.
    ok(isoray()
        .arg("render")
        .arg(&s)
        .args(["--frames", "2..3", "-q", "-o"])
        .arg(d.join("sub_%02d.png")));
    assert!(d.join("sub_02.png").exists() && d.join("sub_03.png").exists());
    assert!(!d.join("sub_01.png").exists() && !d.join("sub_04.png").exists());
}

#[test]
fn gif_and_apng_hold_every_frame() {
    let d = dir("movies");
    let s = scene(&d);
    ok(isoray()
        .arg("render")
        .arg(&s)
        .args(["--frames", "0..3", "-q", "-o"])
        .arg(d.join("f_%04d.png")));
    ok(isoray()
        .arg("render")
        .arg(&s)
        .args(["--frames", "0..3", "-q", "-o"])
        .arg(d.join("anim.apng")));
    // The APNG's frames are the PNG frames, pixel for pixel.
    let dec = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(d.join("anim.apng")).unwrap(),
    ));
    let mut r = dec.read_info().unwrap();
    let actl = r.info().animation_control.expect("an animated PNG");
    assert_eq!(actl.num_frames, 4);
    for n in 0..4 {
        let mut buf = vec![0; r.output_buffer_size().unwrap()];
        r.next_frame(&mut buf).unwrap();
        let fc = r.info().frame_control.expect("frame control");
        assert_eq!((fc.delay_num, fc.delay_den), (1, 4));
        let want = image::open(d.join(format!("f_{n:04}.png"))).unwrap().to_rgb8();
        assert_eq!(&buf[..want.as_raw().len()], want.as_raw().as_slice(), "frame {n}");
    }
    ok(isoray()
        .arg("render")
        .arg(&s)
        .args(["--frames", "0..3", "-q", "-o"])
        .arg(d.join("anim.gif")));
    use image::AnimationDecoder;
    let gif = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(
        std::fs::File::open(d.join("anim.gif")).unwrap(),
    ))
    .unwrap();
    let frames = gif.into_frames().collect_frames().unwrap();
    assert_eq!(frames.len(), 4);
    for (n, f) in frames.iter().enumerate() {
        assert_eq!(f.delay().numer_denom_ms(), (250, 1));
        // 256 colours per frame: close to the PNG, not equal.
        let want = image::open(d.join(format!("f_{n:04}.png"))).unwrap().to_rgba8();
        let diff: f64 = f
            .buffer()
            .as_raw()
            .iter()
            .zip(want.as_raw())
            .map(|(a, b)| (*a as f64 - *b as f64).abs())
            .sum::<f64>()
            / want.as_raw().len() as f64;
        assert!(diff < 3.0, "frame {n}: mean difference {diff}");
    }
}

#[test]
fn bands_merge_into_the_bytes_of_one_render() {
    let d = dir("tiles");
    let s = scene(&d);
    ok(isoray()
        .arg("render")
        .arg(&s)
        .args(["--time", "0.3", "-q", "-o"])
        .arg(d.join("whole.png")));
    for n in [1u32, 3, 5] {
        let mut bands = vec![];
        // Rendered out of order, merged in any order.
        for i in (0..n).rev() {
            let b = d.join(format!("band_{n}_{i}.png"));
            ok(isoray()
                .arg("render")
                .arg(&s)
                .args(["--time", "0.3", "--tile", &format!("{i}/{n}"), "-q", "-o"])
                .arg(&b));
            bands.push(b);
        }
        let out = d.join(format!("merged_{n}.png"));
        ok(isoray().arg("merge").args(&bands).arg("-o").arg(&out));
        assert_eq!(read(&out), read(&d.join("whole.png")), "{n} bands");
    }
    // A missing band and a band of another split are errors that say so.
    let o = run(isoray()
        .arg("merge")
        .arg(d.join("band_3_0.png"))
        .arg(d.join("band_3_2.png"))
        .arg("-o")
        .arg(d.join("bad.png")));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("band(s) 1 of 3 are missing"), "{}", stderr(&o));
    let o = run(isoray()
        .arg("merge")
        .arg(d.join("band_3_0.png"))
        .arg(d.join("band_5_1.png"))
        .arg("-o")
        .arg(d.join("bad.png")));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("is band 1 of 5"), "{}", stderr(&o));
    let o = run(isoray()
        .arg("merge")
        .arg(d.join("whole.png"))
        .arg("-o")
        .arg(d.join("bad.png")));
    assert!(stderr(&o).contains("not a band"), "{}", stderr(&o));
    assert!(!d.join("bad.png").exists());
}

#[test]
fn frames_say_what_they_need() {
    let d = dir("errors");
    let s = scene(&d);
    let still = d.join("still.toml");
    std::fs::write(&still, "[[light]]\n[[object]]\nshape = \"sphere(p, 1.0)\"\n").unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                still.display().to_string(),
                "--frames".into(),
                "0..2".into(),
                "-o".into(),
                "x_%04d.png".into(),
            ],
            "no [animation] table",
        ),
        (
            vec![
                s.display().to_string(),
                "--frames".into(),
                "0..2".into(),
                "-o".into(),
                "x.png".into(),
            ],
            "a pattern with %04d",
        ),
        (
            vec![
                s.display().to_string(),
                "--frames".into(),
                "0..2".into(),
                "--shard".into(),
                "0/2".into(),
                "-o".into(),
                "x.gif".into(),
            ],
            "--shard writes its own frames",
        ),
        (
            vec![
                s.display().to_string(),
                "--frames".into(),
                "9..".into(),
                "-o".into(),
                "x_%d.png".into(),
            ],
            "past the animation's last frame 5",
        ),
        (
            vec![
                s.display().to_string(),
                "--frames".into(),
                "0..1".into(),
                "--time".into(),
                "1".into(),
                "-o".into(),
                "x_%d.png".into(),
            ],
            "leave out --time",
        ),
        (
            vec![
                s.display().to_string(),
                "--frames".into(),
                "3..1".into(),
                "-o".into(),
                "x_%d.png".into(),
            ],
            "before the first",
        ),
        (
            vec![
                s.display().to_string(),
                "--tile".into(),
                "3/3".into(),
                "-o".into(),
                "x.png".into(),
            ],
            "0 <= I < N",
        ),
    ];
    for (args, want) in cases {
        let o = run(isoray().current_dir(&d).arg("render").args(&args));
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(want),
            "{args:?}: expected `{want}` in {}",
            stderr(&o)
        );
    }
}

#[test]
fn mp4_goes_through_ffmpeg_or_says_how_to_get_it() {
    let d = dir("mp4");
    let s = scene(&d);
    let out = d.join("anim.mp4");
    let o = run(isoray()
        .arg("render")
        .arg(&s)
        .args(["--frames", "0..3", "-q", "-o"])
        .arg(&out));
    let has_ffmpeg = Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    if has_ffmpeg {
        assert!(o.status.success(), "{}", stderr(&o));
        let bytes = read(&out);
        assert_eq!(&bytes[4..8], b"ftyp", "an MP4 file");
    } else {
        assert_eq!(o.status.code(), Some(1));
        assert!(stderr(&o).contains("needs `ffmpeg` on the PATH"), "{}", stderr(&o));
        assert!(!out.exists());
    }
}

#[test]
fn a_midi_take_drives_eval_and_render_at_their_times() {
    use isoray_scene::midi::{write_midi_file, Message, MidiEvent};
    let d = dir("midi");
    let s = d.join("knob.toml");
    std::fs::write(
        &s,
        "[animation]\nfps = 4\nduration = 1.0\n[params]\nk = 1.0\n[[light]]\n[[object]]\nshape = \"sphere(p, k)\"\n[[midi]]\ncc = 1\ntarget = \"params.k\"\nrange = [0.0, 127.0]\n",
    )
    .unwrap();
    let take = d.join("take.mid");
    let cc = |time: f64, value: u8| MidiEvent {
        time,
        channel: 1,
        kind: Message::Cc { controller: 1, value },
    };
    write_midi_file(&take, &[cc(0.1, 10), cc(0.3, 20), cc(0.6, 30)]).unwrap();
    let eval = |t: &str| -> f64 {
        let mut cmd = isoray();
        cmd.arg("eval").arg(&s).args(["--midi"]).arg(&take).args(["--time", t]);
        cmd.stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped());
        let mut child = cmd.spawn().unwrap();
        use std::io::Write;
        child.stdin.take().unwrap().write_all(b"0 0 0\n").unwrap();
        let o = child.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).trim().parse().unwrap()
    };
    // Frames 0..3 at t = n/4: the scene's own k, then the last value sent.
    for (t, k) in [("0/4", 1.0), ("1/4", 10.0), ("2/4", 20.0), ("3/4", 30.0)] {
        assert_eq!(eval(t), -k, "t = {t}");
    }
    ok(isoray()
        .arg("render")
        .arg(&s)
        .arg("--midi")
        .arg(&take)
        .args(["--frames", "0..", "--width", "16", "--height", "16", "-q", "-o"])
        .arg(d.join("m_%d.png")));
    assert!(d.join("m_3.png").exists());
    // A scene without mappings, and a file that is not MIDI.
    let o = run(isoray()
        .arg("render")
        .arg(d.join("knob.toml"))
        .arg("--midi")
        .arg(&s)
        .args(["-o"])
        .arg(d.join("x.png")));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("not a MIDI file"), "{}", stderr(&o));
    let plain = d.join("plain.toml");
    std::fs::write(&plain, "[[object]]\nshape = \"sphere(p, 1.0)\"\n").unwrap();
    let o = run(isoray()
        .arg("render")
        .arg(&plain)
        .arg("--midi")
        .arg(&take)
        .arg("-o")
        .arg(d.join("x.png")));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("has no [[midi]] mappings"), "{}", stderr(&o));
}
