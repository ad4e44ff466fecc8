//! End-to-end tests of `isoray dent`, `--maps` and `isoray simulate`: a
//! dent written into the maps folder at the formula's depth, accumulated
//! over calls, drawn by `isoray render --maps`; an impulse below the yield
//! leaves the maps byte for byte; errors name what is wrong. `simulate`
//! without the `physics` feature says how to get it; with it, a ball
//! dropped on the dentable plane of examples/dents.toml dents it, and
//! replaying the run's record writes the same frames and maps byte for
//! byte.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn isoray(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isoray"))
        .args(args)
        .output()
        .expect("isoray runs")
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isoray-dent-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// A plate of clay: ε = 0.5 (yield 1 N·s), κ = 0.01, t = 0.1 (KAT 4).
fn scene() -> PathBuf {
    let p = tmp("plate.toml");
    std::fs::write(
        &p,
        "[camera]\nposition = [0.0, 1.5, 1.5]\ntarget = [0.0, 0.0, 0.0]\n\
         [render]\nwidth = 64\nheight = 48\n\
         [[light]]\nkind = \"directional\"\ndirection = [-0.6, 1.0, 0.3]\n\
         [material.clay]\nrestitution = 0.5\ndent_compliance = 0.01\nthickness = 0.1\n\
         [[object]]\nname = \"plate\"\nshape = \"p.y\"\nmaterial = \"clay\"\ndents = \"bump\"\n\
         dent_map = { size = 128, range = 0.02, uv = \"planar-xz\", extent = 1.0 }\n\
         [[object]]\nname = \"post\"\nshape = \"box(p, vec3(0.05, 0.3, 0.05))\"\nposition = [0.5, 0.3, 0.5]\n",
    )
    .unwrap();
    p
}

fn ok(o: &Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    err
}

fn height(dir: &Path) -> isoray_dent::HeightMap {
    isoray_dent::HeightMap::read_png(&dir.join("plate-height.png"), 0.02).unwrap()
}

#[test]
fn an_impulse_dents_as_deep_as_the_formula_and_renders() {
    let (s, maps) = (scene(), tmp("maps-a"));
    let (s, m) = (s.to_str().unwrap(), maps.to_str().unwrap());
    // |j| = 4 N·s: 0.1 · 0.01 · (4 − 1) = 0.003 deep (KAT 4).
    let err = ok(&isoray(&[
        "dent",
        s,
        "plate",
        "--at",
        "0,0,0",
        "--normal",
        "0,1,0",
        "--impulse",
        "4",
        "--maps",
        m,
    ]));
    assert!(err.contains("dent of 0.003000"), "{err}");
    let h = height(&maps);
    // Texel (64, 64) is centred at x = z = 1/128 off the contact: the cap
    // of the default ball (radius 0.25) is d − r + sqrt(r² − ρ²) there.
    let centre = -(h.get(64, 64) as f64 - 0.5) * 0.02;
    let rho2 = 2.0 * (1.0f64 / 128.0).powi(2);
    let want = 0.003 - 0.25 + (0.0625 - rho2).sqrt();
    assert!((centre - want).abs() < 1e-6, "{centre} vs {want}");
    assert!(maps.join("plate-normal.png").exists());
    // A second impact elsewhere keeps the first dent.
    ok(&isoray(&[
        "dent",
        s,
        "plate",
        "--at",
        "-0.5,0,0.5",
        "--normal",
        "0,1,0",
        "--depth",
        "0.004",
        "--maps",
        m,
        "-q",
    ]));
    let h2 = height(&maps);
    assert_eq!(h2.get(64, 64), h.get(64, 64));
    assert!(h2.get(32, 96) < 0.45, "{}", h2.get(32, 96));
    // Rendered with and without the maps: the dents show.
    let (a, b) = (tmp("with.png"), tmp("without.png"));
    ok(&isoray(&["render", s, "--maps", m, "-o", a.to_str().unwrap(), "-q"]));
    ok(&isoray(&["render", s, "-o", b.to_str().unwrap(), "-q"]));
    assert!(
        std::fs::read(&a).unwrap() != std::fs::read(&b).unwrap(),
        "the dents change the picture"
    );
}

#[test]
fn an_impulse_below_the_yield_leaves_the_maps_byte_for_byte() {
    let (s, maps) = (scene(), tmp("maps-b"));
    let (s, m) = (s.to_str().unwrap(), maps.to_str().unwrap());
    ok(&isoray(&[
        "dent", s, "plate", "--at", "0,0,0", "--normal", "0,1,0", "--depth", "0.002", "--maps", m, "-q",
    ]));
    let before = (
        std::fs::read(maps.join("plate-height.png")).unwrap(),
        std::fs::read(maps.join("plate-normal.png")).unwrap(),
    );
    let err = ok(&isoray(&[
        "dent",
        s,
        "plate",
        "--at",
        "0.3,0,0",
        "--normal",
        "0,1,0",
        "--impulse",
        "0.99",
        "--maps",
        m,
    ]));
    assert!(
        err.contains("dent of 0.000000") && err.contains("0 texels lowered"),
        "{err}"
    );
    let after = (
        std::fs::read(maps.join("plate-height.png")).unwrap(),
        std::fs::read(maps.join("plate-normal.png")).unwrap(),
    );
    assert!(before == after, "the maps changed below the yield impulse");
}

#[test]
fn an_impactor_object_dents_with_its_own_shape() {
    let (s, maps) = (scene(), tmp("maps-c"));
    let (s, m) = (s.to_str().unwrap(), maps.to_str().unwrap());
    // The post's square foot (0.1 × 0.1 at x, z = 0.5) pressed 0.005 in.
    ok(&isoray(&[
        "dent",
        s,
        "plate",
        "--at",
        "0.5,0,0.5",
        "--normal",
        "0,1,0",
        "--depth",
        "0.005",
        "--impactor",
        "post",
        "--maps",
        m,
        "-q",
    ]));
    let h = height(&maps);
    let texel = |x: f64, z: f64| (((x + 1.0) / 2.0 * 128.0) as u32, ((z + 1.0) / 2.0 * 128.0) as u32);
    let depth = |(x, y): (u32, u32)| -(h.get(x, y) as f64 - 0.5) * 0.02;
    assert!((depth(texel(0.5, 0.5)) - 0.005).abs() < 1e-4);
    assert!((depth(texel(0.53, 0.47)) - 0.005).abs() < 1e-4, "flat-bottomed");
    assert!(depth(texel(0.6, 0.5)).abs() < 1e-6, "outside the foot");
}

#[test]
fn bad_dents_get_clear_errors() {
    let (s, maps) = (scene(), tmp("maps-d"));
    let (s, m) = (s.to_str().unwrap(), maps.to_str().unwrap());
    for (args, code, want) in [
        (
            vec![
                "dent", s, "lid", "--at", "0,0,0", "--normal", "0,1,0", "--depth", "0.01", "--maps", m,
            ],
            2,
            "no object named `lid` (named objects: plate, post)",
        ),
        (
            vec![
                "dent", s, "post", "--at", "0,0,0", "--normal", "0,1,0", "--depth", "0.01", "--maps", m,
            ],
            2,
            "object `post` is not dentable",
        ),
        (
            vec!["dent", s, "plate", "--at", "0,0,0", "--normal", "0,1,0", "--maps", m],
            2,
            "give the dent's --depth D",
        ),
        (
            vec![
                "dent",
                s,
                "plate",
                "--at",
                "0,0,0",
                "--normal",
                "0,1,0",
                "--depth",
                "0.01",
                "--impulse",
                "3",
                "--maps",
                m,
            ],
            2,
            "not both",
        ),
        (
            vec![
                "dent", s, "plate", "--at", "0,0", "--normal", "0,1,0", "--depth", "0.01", "--maps", m,
            ],
            2,
            "--at: expected three numbers",
        ),
        (
            vec![
                "dent", s, "plate", "--at", "0,0,0", "--normal", "0,0,0", "--depth", "0.01", "--maps", m,
            ],
            2,
            "nonzero",
        ),
        (
            vec![
                "dent", s, "plate", "--at", "0,0,0", "--normal", "0,1,0", "--depth", "0.01",
            ],
            2,
            "needs --maps DIR",
        ),
        (
            vec![
                "dent",
                s,
                "plate",
                "--at",
                "0,0,0",
                "--normal",
                "0,1,0",
                "--depth",
                "0.01",
                "--imprint",
                "xray",
                "--maps",
                m,
            ],
            2,
            "--imprint xray",
        ),
        (
            vec!["render", s, "--maps", "/nonexistent/maps", "-o", "/tmp/x.png"],
            1,
            "no such folder",
        ),
    ] {
        let o = isoray(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
    }
}

fn example() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/dents.toml")
        .to_string_lossy()
        .into_owned()
}

#[test]
#[cfg(not(feature = "physics"))]
fn without_physics_it_says_how_to_build_it() {
    let o = isoray(&["simulate", &example(), "-o", tmp("x_%04d.png").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--features physics"));
}

#[test]
#[cfg(feature = "physics")]
fn a_drop_dents_the_plane_and_a_replay_gives_the_same_bytes() {
    let small = [
        "--set",
        "render.width=48",
        "--set",
        "render.height=27",
        "--fps",
        "10",
        "--duration",
        "0.6",
    ];
    let run = |dir: &str, extra: &[&str]| {
        let frames = tmp(&format!("{dir}/f_%04d.png"));
        let maps = tmp(&format!("{dir}/maps"));
        let mut args: Vec<String> = vec![
            "simulate".into(),
            example(),
            "-o".into(),
            frames.to_string_lossy().into_owned(),
        ];
        args.extend(small.iter().map(|s| s.to_string()));
        args.extend(["--maps".into(), maps.to_string_lossy().into_owned(), "-q".into()]);
        args.extend(extra.iter().map(|s| s.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = isoray(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let bytes = |p: PathBuf| std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        let frames: Vec<Vec<u8>> = (0..6).map(|n| bytes(tmp(&format!("{dir}/f_{n:04}.png")))).collect();
        (frames, bytes(maps.join("plane-height.png")))
    };
    let record = tmp("rec.json");
    let (frames, height) = run("a", &["--record", record.to_str().unwrap()]);
    let text = std::fs::read_to_string(&record).unwrap();
    assert!(text.contains("\"impacts\"") && text.contains("\"yield\""), "{text}");
    let h = image::open(tmp("a/maps/plane-height.png")).unwrap().into_luma16();
    assert!(h.pixels().any(|p| p.0[0] < 32000), "the plane was dented");
    let (again, height2) = run("b", &["--replay", record.to_str().unwrap()]);
    assert!(frames == again, "replayed frames differ");
    assert!(height == height2, "replayed maps differ");
}

/// `--dents sdf`: the impacts are cut into the plane's geometry, the scene
/// saved with them (`--save-scene`) reloads, and `isoray mesh` of it has
/// the craters: the mesh of a slab of the plane around the first dent
/// lacks exactly the spherical caps' volume π d² (3r − d) / 3.
#[test]
#[cfg(feature = "physics")]
fn sdf_dents_are_saved_and_meshed() {
    let saved = tmp("dented.toml");
    let record = tmp("sdf.json");
    let o = isoray(&[
        "simulate",
        &example(),
        "-o",
        tmp("sdf_%04d.png").to_str().unwrap(),
        "--set",
        "render.width=48",
        "--set",
        "render.height=27",
        "--fps",
        "10",
        "--dents",
        "sdf",
        "--save-scene",
        saved.to_str().unwrap(),
        "--record",
        record.to_str().unwrap(),
        "-q",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&record).unwrap();
    assert!(text.contains("\"geometry\": true"), "{text}");
    let scene = isoray_scene::load(&saved, &[]).unwrap_or_else(|e| panic!("{e}"));
    let dents = &scene.objects[0].physics.sdf_dents;
    assert!(!dents.is_empty());
    // A slab of the plane 0.1 deep around the first dent.
    let c0 = dents[0].placement.position;
    let (lo, hi) = ([c0[0] - 0.15, -0.1, c0[2] - 0.15], [c0[0] + 0.15, 0.05, c0[2] + 0.15]);
    let mut caps = 0.0;
    for d in dents {
        let (c, r) = (d.placement.position, 0.15);
        let depth = r - c[1];
        let rho = (2.0 * r * depth - depth * depth).sqrt();
        if c[0] - rho > lo[0] && c[0] + rho < hi[0] && c[2] - rho > lo[2] && c[2] + rho < hi[2] {
            caps += std::f64::consts::PI * depth * depth * (3.0 * r - depth) / 3.0;
        } else {
            assert!(c[0] - rho > hi[0] || c[0] + rho < lo[0], "a cap cut by the box");
        }
    }
    let out = tmp("dented.stl");
    let bounds = format!("{},{},{},{},{},{}", lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    let o = isoray(&[
        "mesh",
        saved.to_str().unwrap(),
        "plane",
        "-o",
        out.to_str().unwrap(),
        "--bounds",
        &bounds,
        "--resolution",
        "150",
        "-q",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m = isoray_mesh::io::read(&out).unwrap();
    let slab = 0.3 * 0.3 * 0.1;
    let missing = slab - m.volume();
    assert!(caps > 1e-4, "{caps}");
    assert!((missing - caps).abs() < 0.05 * caps, "missing {missing} vs caps {caps}");
}

/// `uv = "parametric"`: a dome given as x = t, y = −(s² + t²)/5, z = s
/// over [−1, 1]² is dented at (x, z) = (0.3, 0.2), on the surface, 3 cm
/// deep: the deepest texel is 3 cm down (the texel method along the true
/// normal), at the texel of (s, t) = (0.2, 0.3); the dent shades.
#[test]
fn a_parametric_surface_is_dented_in_its_own_s_t() {
    let path = tmp("dome.toml");
    std::fs::write(
        &path,
        "[camera]\nposition = [0.0, 1.6, 2.2]\ntarget = [0.0, 0.1, 0.0]\nfov = 40.0\n\
         [render]\nwidth = 96\nheight = 60\n\
         [[light]]\nkind = \"directional\"\ndirection = [-0.5, 1.0, 0.3]\n\
         [surface.dome]\nparametric = { x = \"t\", y = \"-0.2*(s^2+t^2)\", z = \"s\" }\n\
         domain = { s = [-1.0, 1.0], t = [-1.0, 1.0] }\n\
         [[object]]\nname = \"dome\"\nshape = \"dome(p)\"\ndents = \"bump\"\n\
         dent_map = { size = 256, range = 0.1, uv = \"parametric\" }\n",
    )
    .unwrap();
    let maps = tmp("maps-dome");
    let (s, m) = (path.to_str().unwrap(), maps.to_str().unwrap());
    let y = -0.2 * (0.3f64 * 0.3 + 0.2 * 0.2);
    let at = format!("0.3,{y},0.2");
    ok(&isoray(&[
        "dent",
        s,
        "dome",
        "--at",
        &at,
        "--normal",
        "0.12,1,0.08",
        "--depth",
        "0.03",
        "--radius",
        "0.25",
        "--maps",
        m,
    ]));
    let h = isoray_dent::HeightMap::read_png(&maps.join("dome-height.png"), 0.1).unwrap();
    let (mut deepest, mut at_xy) = (0.0f64, (0, 0));
    for y in 0..256 {
        for x in 0..256 {
            let d = -h.displacement(x, y);
            if d > deepest {
                (deepest, at_xy) = (d, (x, y));
            }
        }
    }
    assert!((deepest - 0.03).abs() < 0.001, "{deepest}");
    // u from s = z = 0.2, v from t = x = 0.3: texel (153.6, 166.4) − ½.
    assert!(at_xy.0.abs_diff(153) <= 2 && at_xy.1.abs_diff(166) <= 2, "{at_xy:?}");
    // Drawn with the maps, the dent shades; without, it does not.
    let (with, without) = (tmp("dome-with.png"), tmp("dome-without.png"));
    ok(&isoray(&["render", s, "--maps", m, "-o", with.to_str().unwrap()]));
    ok(&isoray(&["render", s, "-o", without.to_str().unwrap()]));
    let (a, b) = (
        image::open(&with).unwrap().into_rgb8(),
        image::open(&without).unwrap().into_rgb8(),
    );
    let changed = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
    assert!(changed > 5 && changed < 200, "{changed} pixels changed");
}
