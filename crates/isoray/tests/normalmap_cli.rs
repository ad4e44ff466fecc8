//! End-to-end tests of `isoray normalmap`: the thesis's G3D bytes from an
//! 8-bit grey PNG, the fragment of `--rect`, the options, and errors.

use std::path::PathBuf;
use std::process::{Command, Output};

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isoray-normalmap-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn normalmap(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isoray"))
        .arg("normalmap")
        .args(args)
        .output()
        .expect("isoray runs")
}

/// An 8 × 8 grey PNG, 0 everywhere but 255 at (4, 4).
fn spike() -> PathBuf {
    let p = tmp("spike.png");
    let img = image::GrayImage::from_fn(8, 8, |x, y| image::Luma([if (x, y) == (4, 4) { 255 } else { 0 }]));
    img.save(&p).unwrap();
    p
}

fn rgba(path: &PathBuf) -> image::RgbaImage {
    let img = image::open(path).unwrap();
    assert_eq!(img.color(), image::ColorType::Rgba8, "an 8-bit RGBA PNG");
    img.to_rgba8()
}

/// dents.md §2.5, KAT 9: the spike's neighbours, byte for byte.
#[test]
fn a_spike_converts_to_g3ds_bytes() {
    let (input, out) = (spike(), tmp("spike-n.png"));
    let o = normalmap(&[input.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let n = rgba(&out);
    assert_eq!(n.get_pixel(4, 4).0, [128, 128, 255, 255]);
    assert_eq!(n.get_pixel(3, 4).0, [13, 128, 185, 0]);
    assert_eq!(n.get_pixel(4, 3).0, [128, 242, 185, 0]);
    assert_eq!(n.get_pixel(5, 5).0, [201, 54, 201, 0]);
    let lp = tmp("spike-lp.png");
    let o = normalmap(&[input.to_str().unwrap(), "-o", lp.to_str().unwrap(), "--low-pass", "-q"]);
    assert!(o.status.success());
    assert_eq!(rgba(&lp).get_pixel(4, 4).0[3], 28);
}

#[test]
fn a_rect_writes_the_fragment_with_lookups_over_the_whole_map() {
    let (input, whole, part) = (spike(), tmp("w.png"), tmp("r.png"));
    assert!(
        normalmap(&[input.to_str().unwrap(), "-o", whole.to_str().unwrap(), "-q"])
            .status
            .success()
    );
    let o = normalmap(&[
        input.to_str().unwrap(),
        "-o",
        part.to_str().unwrap(),
        "--rect",
        "3,3,6,5",
        "-q",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (w, p) = (rgba(&whole), rgba(&part));
    assert_eq!(p.dimensions(), (3, 2));
    for y in 0..2 {
        for x in 0..3 {
            assert_eq!(p.get_pixel(x, y), w.get_pixel(3 + x, 3 + y));
        }
    }
}

#[test]
fn a_white_height_and_clamped_borders_change_the_slopes() {
    let input = tmp("ramp.png");
    image::GrayImage::from_fn(8, 8, |x, _| image::Luma([10 * x as u8]))
        .save(&input)
        .unwrap();
    let out = tmp("ramp-n.png");
    let run = |extra: &[&str]| {
        let mut args = vec![input.to_str().unwrap(), "-o", out.to_str().unwrap(), "-q"];
        args.extend_from_slice(extra);
        assert!(normalmap(&args).status.success());
        rgba(&out)
    };
    assert_eq!(
        run(&[]).get_pixel(0, 3).0,
        [215, 128, 220, 0],
        "wrapped: the jump from 70 to 0"
    );
    assert_eq!(run(&["--wrap", "clamp"]).get_pixel(3, 3).0, [89, 128, 249, 30]);
    assert!(run(&["--wrap", "clamp"]).get_pixel(0, 3).0[0] > 89);
    let flatter = run(&["--white-height", "4"]).get_pixel(3, 3).0[0];
    assert!(flatter > 89 && flatter < 128, "{flatter}");
    let steeper = run(&["--white-height", "16"]).get_pixel(3, 3).0[0];
    assert!(steeper < 89, "{steeper}");
}

#[test]
fn bad_input_gets_clear_errors() {
    let input = spike();
    let out = tmp("bad.png");
    let err = |args: &[&str]| {
        let o = normalmap(args);
        (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let (code, e) = err(&[input.to_str().unwrap(), "-o", out.to_str().unwrap(), "--wrap", "mirror"]);
    assert_eq!(code, Some(2));
    assert!(e.contains("--wrap mirror: expected repeat or clamp"), "{e}");
    let (code, e) = err(&[
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--rect",
        "3,3,9,5",
    ]);
    assert_eq!(code, Some(2));
    assert!(e.contains("the map is 8x8"), "{e}");
    let (code, e) = err(&[
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--white-height",
        "0",
    ]);
    assert_eq!(code, Some(2));
    assert!(e.contains("positive"), "{e}");
    let (code, e) = err(&["/nonexistent/h.png", "-o", out.to_str().unwrap()]);
    assert_eq!(code, Some(1));
    assert!(e.contains("/nonexistent/h.png"), "{e}");
    let text = tmp("not-a-png.png");
    std::fs::write(&text, "hello").unwrap();
    let (code, e) = err(&[text.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(code, Some(2));
    assert!(e.contains("not-a-png.png"), "{e}");
    assert!(!out.exists(), "nothing written on errors");
}
