//! The examples of `docs/SCENE.md` work: every ```toml block that is a complete
//! scene (contains `[[object]]`) loads, and every ```glsl block (one shape)
//! compiles. Every primitive, operator and domain operator has an example.

use std::path::Path;

use isoray_shape::library::{Category, FUNCTIONS};

/// A fenced code block: its tag, the 1-based line of its opening fence, its text.
struct Block {
    tag: String,
    line: usize,
    text: String,
}

fn scene_md() -> String {
    doc("SCENE.md")
}

fn doc(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs").join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

fn blocks(md: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut open: Option<Block> = None;
    for (i, line) in md.lines().enumerate() {
        let trimmed = line.trim_start();
        if let Some(info) = trimmed.strip_prefix("```") {
            match open.take() {
                Some(b) => out.push(b),
                None => {
                    open = Some(Block {
                        tag: info.split_whitespace().next().unwrap_or("").to_string(),
                        line: i + 1,
                        text: String::new(),
                    })
                }
            }
            continue;
        }
        if let Some(b) = &mut open {
            b.text.push_str(line);
            b.text.push('\n');
        }
    }
    assert!(open.is_none(), "SCENE.md ends inside a code block");
    out
}

/// True when `text` calls `name(` (not as the tail of a longer name).
fn calls(text: &str, name: &str) -> bool {
    let pat = format!("{name}(");
    text.match_indices(&pat).any(|(i, _)| {
        !text[..i]
            .chars()
            .next_back()
            .is_some_and(|c| c.is_ascii_alphanumeric() || c == '_')
    })
}

#[test]
fn surfaces_md_scenes_load() {
    let md = doc("SURFACES.md");
    let mut scenes = 0;
    for b in blocks(&md).iter().filter(|b| b.tag == "toml") {
        scenes += 1;
        if let Err(e) = isoray_scene::load_str(&b.text, "SURFACES.md", &[]) {
            panic!("the ```toml block at SURFACES.md line {} does not load:\n{e}", b.line);
        }
    }
    assert!(scenes >= 1);
}

#[test]
fn example_scenes_load() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let path = e.unwrap().path();
        if path.extension().is_some_and(|x| x == "toml") {
            n += 1;
            if let Err(e) = isoray_scene::load(&path, &[]) {
                panic!("{} does not load:\n{e}", path.display());
            }
        }
    }
    assert!(n >= 5, "{n} example scenes");
}

#[test]
fn toml_scenes_load() {
    let md = scene_md();
    let mut scenes = 0;
    for b in blocks(&md).iter().filter(|b| b.tag == "toml") {
        if !b.text.contains("[[object]]") {
            continue;
        }
        scenes += 1;
        if let Err(e) = isoray_scene::load_str(&b.text, "SCENE.md", &[]) {
            panic!("the ```toml block at SCENE.md line {} does not load:\n{e}", b.line);
        }
    }
    assert!(scenes >= 5, "only {scenes} complete scenes found in SCENE.md");
}

#[test]
fn glsl_shapes_compile() {
    let md = scene_md();
    let lib = isoray_shape::Library::new();
    let shapes: Vec<Block> = blocks(&md).into_iter().filter(|b| b.tag == "glsl").collect();
    for b in &shapes {
        if let Err(e) = isoray_shape::compile(&lib, &b.text) {
            panic!(
                "the ```glsl block at SCENE.md line {} does not compile: {} (at bytes {}..{} of the block)\n{}",
                b.line, e.message, e.span.start, e.span.end, b.text
            );
        }
    }
    // Every primitive, operator and domain operator is shown in a shape example.
    for f in FUNCTIONS.iter().filter(|f| f.category != Category::Builtin) {
        assert!(
            shapes.iter().any(|b| calls(&b.text, f.name)),
            "SCENE.md has no ```glsl example calling `{}`",
            f.name
        );
    }
}

/// The rows of the Markdown table that follows `heading` in SCENE.md.
fn table_after(md: &str, heading: &str) -> Vec<String> {
    let start = md
        .find(heading)
        .unwrap_or_else(|| panic!("SCENE.md has no `{heading}`"));
    md[start..]
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2) // the header and its rule
        .map(str::to_string)
        .collect()
}

#[test]
fn key_tables_are_the_schema() {
    let md = scene_md();
    for (heading, keys) in isoray_scene::key_tables() {
        let want: Vec<String> = keys.iter().map(|k| k.doc_row()).collect();
        let have = table_after(&md, heading);
        if have != want {
            panic!(
                "the table under {heading} in SCENE.md differs from the key schema (crates/isoray-scene/src/model.rs); it should read:\n{}",
                want.join("\n")
            );
        }
    }
}

/// Unknown keys are reported with the known keys of their table, from the schema.
#[test]
fn unknown_keys_list_the_schema() {
    for (table, text, keys) in [
        (
            "light.0",
            "[[light]]\nkind = \"point\"\nposition = [0.0, 1.0, 0.0]\nbogus = 1",
            isoray_scene::light_keys(),
        ),
        ("material.m", "[material.m]\nbogus = 1", isoray_scene::material_keys()),
        (
            "object.0",
            "[[object]]\nshape = \"sphere(p, 1.0)\"\nbogus = 1",
            isoray_scene::object_keys(),
        ),
        (
            "surface.s",
            "[surface.s]\nsdf = \"length(p) - 1.0\"\nbogus = 1",
            isoray_scene::surface_keys(),
        ),
        (
            "environment",
            "[environment]\ngradient = {}\nbogus = 1",
            isoray_scene::environment_keys(),
        ),
    ] {
        let e = isoray_scene::load_str(text, "t.toml", &[]).unwrap_err();
        let names: Vec<&str> = keys.iter().map(|k| k.name).collect();
        assert!(
            e.message.contains(&format!("unknown key `bogus` in `{table}`")),
            "{}",
            e.message
        );
        assert!(
            e.notes
                .iter()
                .any(|n| n == &format!("known keys: {}", names.join(", "))),
            "{:?}",
            e.notes
        );
    }
}
