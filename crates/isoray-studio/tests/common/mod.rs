//! What the studio's test files share.

use std::path::PathBuf;

/// The repository's `examples` folder.
pub fn examples_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// Every example scene (`examples/*.toml` and `examples/realtime/*.toml`), sorted.
pub fn examples() -> Vec<PathBuf> {
    let root = examples_dir();
    let mut out = Vec::new();
    for dir in [root.clone(), root.join("realtime")] {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}
