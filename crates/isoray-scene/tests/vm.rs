//! `[surface.NAME] vm = "FILE"`: fidget's `.vm` models as surface bodies.

use isoray_scene::load_str;

/// The models, relative to this crate (the tests' working directory).
const MODELS: &str = "../../bench/models";

/// An independent reading of a `.vm` file: the value at (x, y, z) in f64,
/// clause by clause.
fn interpret(text: &str, x: f64, y: f64, z: f64) -> f64 {
    let mut vals: std::collections::HashMap<&str, f64> = Default::default();
    let mut last = f64::NAN;
    for line in text.lines() {
        let line = line.split('#').next().unwrap();
        let w: Vec<&str> = line.split_whitespace().collect();
        if w.is_empty() {
            continue;
        }
        let a = |i: usize| vals[w[i]];
        let v = match w[1] {
            "var-x" => x,
            "var-y" => y,
            "var-z" => z,
            "const" => w[2].parse().unwrap(),
            "add" => a(2) + a(3),
            "sub" => a(2) - a(3),
            "mul" => a(2) * a(3),
            "div" => a(2) / a(3),
            "min" => a(2).min(a(3)),
            "max" => a(2).max(a(3)),
            "neg" => -a(2),
            "square" => a(2) * a(2),
            "sqrt" => a(2).sqrt(),
            "abs" => a(2).abs(),
            "exp" => a(2).exp(),
            "ln" => a(2).ln(),
            "sin" => a(2).sin(),
            "cos" => a(2).cos(),
            op => panic!("opcode {op} not in this test's interpreter"),
        };
        vals.insert(w[0], v);
        last = v;
    }
    last
}

#[test]
fn models_load_and_agree_with_a_direct_reading() {
    for model in ["bear", "colonnade", "tanglecube", "hi"] {
        let file = format!("{MODELS}/{model}.vm");
        let scene = format!("[surface.m]\nvm = \"{file}\"\n\n[[object]]\nshape = \"m(p)\"\n");
        let s = load_str(&scene, "vm.toml", &[]).unwrap_or_else(|e| panic!("{model}: {}", e.rendered));
        let text = std::fs::read_to_string(&file).unwrap();
        let mut seed = 7u64;
        let mut coord = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % 2001) as f64 / 1000.0 - 1.0
        };
        for _ in 0..50 {
            let (x, y, z) = (coord(), coord(), coord());
            let want = interpret(&text, x, y, z);
            let got = s.distance([x, y, z]);
            assert!(
                (got - want).abs() <= 1e-9 * (1.0 + want.abs()),
                "{model} at ({x}, {y}, {z}): {got} vs {want}"
            );
        }
    }
}

#[test]
fn errors_name_the_file_line_and_column() {
    let dir = std::env::temp_dir().join(format!("isoray-vm-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bad.vm"), "_0 var-x\n_1 var-y\n_2 frob _0 _1\n").unwrap();
    let scene_path = dir.join("scene.toml");
    let text = "[surface.m]\nvm = \"bad.vm\"\n\n[[object]]\nshape = \"m(p)\"\n";
    let e = load_str(text, scene_path.to_str().unwrap(), &[]).unwrap_err();
    assert!(e.message.contains("bad.vm:3:4: unknown opcode `frob`"), "{}", e.message);
    assert_eq!(e.line, Some(2));
    let text = "[surface.m]\nvm = \"missing.vm\"\n\n[[object]]\nshape = \"m(p)\"\n";
    let e = load_str(text, scene_path.to_str().unwrap(), &[]).unwrap_err();
    assert!(
        e.message.contains("cannot read") && e.message.contains("missing.vm"),
        "{}",
        e.message
    );
    let text = "[surface.m]\nvm = \"bad.vm\"\nsdf = \"length(p)\"\n\n[[object]]\nshape = \"m(p)\"\n";
    let e = load_str(text, scene_path.to_str().unwrap(), &[]).unwrap_err();
    assert!(e.message.contains("more than one of"), "{}", e.message);
    std::fs::remove_dir_all(&dir).ok();
}
