//! Objects compile one at a time, cached by content: an edit to one object
//! recompiles only that object, and a reused object is the object a fresh
//! compile would give, bit for bit.

use isoray_scene::{load_str_with, CacheStats, LoadOptions, ObjectCache, Scene};
use isoray_shape::Value;

const SCENE: &str = r#"
[params]
R = 1.0
k = 0.3
[surface.ball]
implicit = "x*x + y*y + z*z - r*r"
params = { r = 1.0 }
[surface.ring]
sdf = "length(vec2(length(p.xz) - 1.0, p.y)) - w"
params = { w = 0.25 }
[[object]]
shape = "ball(p, R)"
[[object]]
shape = "ring(p - vec3(2.5, 0.0, 0.0), k)"
position = ["sin(t)", 0.0, 0.0]
[[object]]
shape = "box(p - vec3(-2.5, 0.0, 0.0), 0.5)"
[[object]]
shape = "plane(p, vec3(0.0, 1.0, 0.0), 1.0)"
"#;

fn load(text: &str, cache: &ObjectCache) -> Scene {
    let opts = LoadOptions {
        objects: Some(cache.clone()),
        ..LoadOptions::default()
    };
    load_str_with(text, "t.toml", &[], &opts).unwrap_or_else(|e| panic!("{}", e.rendered))
}

/// The scene's distances at a few points, as bits.
fn bits(s: &Scene) -> Vec<u64> {
    let mut out = Vec::new();
    for i in 0..40 {
        let a = i as f64 * 0.37;
        let p = [3.0 * a.cos(), 1.5 * (0.7 * a).sin(), 2.0 * a.sin()];
        out.push(s.distance(p).to_bits());
        for o in &s.objects {
            out.push(o.shape.eval_with(&s.inputs, p).to_bits());
        }
        out.push(s.derived().surfaces.eval_with(&s.inputs, p).to_bits());
    }
    out
}

#[test]
fn an_edit_to_one_object_recompiles_only_that_object() {
    let cache = ObjectCache::new();
    let first = load(SCENE, &cache);
    assert_eq!(cache.stats(), CacheStats { compiled: 4, reused: 0 });
    // Loading the same text again compiles nothing.
    let again = load(SCENE, &cache);
    assert_eq!(cache.stats(), CacheStats { compiled: 4, reused: 4 });
    assert_eq!(bits(&first), bits(&again));
    // Editing the box compiles the box alone.
    let edited_text = SCENE.replace(
        "box(p - vec3(-2.5, 0.0, 0.0), 0.5)",
        "box(p - vec3(-2.5, 0.0, 0.0), 0.75)",
    );
    let edited = load(&edited_text, &cache);
    assert_eq!(cache.stats(), CacheStats { compiled: 5, reused: 7 });
    // ... and gives what a load without a cache gives, bit for bit.
    let fresh = load(&edited_text, &ObjectCache::new());
    assert_eq!(bits(&edited), bits(&fresh));
    assert_ne!(bits(&edited), bits(&first));
    // Moving an object (its placement is inputs) and reordering objects reuse them.
    let moved = SCENE.replace("[\"sin(t)\", 0.0, 0.0]", "[\"cos(t)\", 1.0, 0.0]");
    load(&moved, &cache);
    assert_eq!(
        cache.stats(),
        CacheStats {
            compiled: 5,
            reused: 11
        }
    );
    // Redefining a surface recompiles the objects that call it, no others.
    let ring = SCENE.replace("length(p.xz) - 1.0", "length(p.xz) - 1.25");
    load(&ring, &cache);
    assert_eq!(
        cache.stats(),
        CacheStats {
            compiled: 6,
            reused: 14
        }
    );
}

#[test]
fn a_bound_parameter_recompiles_only_the_objects_that_bound_it() {
    let cache = ObjectCache::new();
    let mut s = load(SCENE, &cache);
    assert_eq!(s.objects[0].bound_inputs, vec![1], "R is bound by the implicit ball");
    let before = cache.stats();
    s.set_param("R", Value::Float(1.5)).unwrap();
    let after = cache.stats();
    assert_eq!(after.compiled - before.compiled, 1, "only the ball recompiles");
    assert_eq!(after.reused - before.reused, 3);
    let text = SCENE.replace("R = 1.0", "R = 1.5");
    let fresh = load(&text, &ObjectCache::new());
    assert_eq!(bits(&s), bits(&fresh));
    // A live parameter recompiles nothing.
    s.set_param("k", Value::Float(0.4)).unwrap();
    assert_eq!(cache.stats(), after);
    // Back to R = 1: the first ball is still cached.
    s.set_param("R", Value::Float(1.0)).unwrap();
    assert_eq!(cache.stats().compiled, after.compiled);
}

#[test]
fn closed_forms_change_without_recompiling() {
    let text = "[params]\nr = 1.0\n[[object]]\nshape = \"sphere(p, r)\"\n[[object]]\nshape = \"box(p - vec3(3.0, 0.0, 0.0), 0.5)\"\n";
    let cache = ObjectCache::new();
    let mut s = load(text, &cache);
    assert!(s.derived().analytic[0].is_some());
    assert!(s.derived().rest.is_some());
    s.set_param("r", Value::Float(0.0)).unwrap();
    assert_eq!(cache.stats().compiled, 2, "nothing recompiled");
    // Whatever it derives, the scene stays what a fresh load at r gives.
    let fresh = load(&text.replace("r = 1.0", "r = 0.0"), &ObjectCache::new());
    assert_eq!(s.derived().analytic[0].is_some(), fresh.derived().analytic[0].is_some());
    assert_eq!(bits(&s), bits(&fresh));
}

#[test]
fn every_value_knows_where_it_was_written() {
    let text = "[camera]\nfov = 35.0\n[[light]]\nintensity = 2.0\n[[object]]\nshape = \"sphere(p, 1.0)\"\nposition = [1.0, \"t\", 0.0]\n";
    let s = load_str_with(
        text,
        "t.toml",
        &["camera.position=[0.0, 0.0, 6.0]".to_string()],
        &LoadOptions::default(),
    )
    .unwrap();
    let at = |key: &str| match s.origin_of(key) {
        Some(isoray_scene::doc::Origin::File(span)) => &text[span.start..span.end],
        other => panic!("{key}: {other:?}"),
    };
    assert_eq!(at("camera.fov"), "35.0");
    assert_eq!(at("light.0.intensity"), "2.0");
    assert_eq!(at("object.0.shape"), "\"sphere(p, 1.0)\"");
    assert_eq!(at("object.0.position.1"), "\"t\"");
    assert_eq!(
        s.origin_of("camera.position"),
        Some(isoray_scene::doc::Origin::Override(0))
    );
    assert_eq!(s.origin_of("light.3.intensity"), None);
}

/// Records the stages and updates a load reports.
#[derive(Default)]
struct Recorder(std::sync::Mutex<Vec<(String, u64, u64)>>);

impl isoray_job::Progress for Recorder {
    fn update(&self, done: u64, total: u64) {
        let mut v = self.0.lock().unwrap();
        let stage = v.last().map(|s| s.0.clone()).unwrap_or_default();
        v.push((stage, done, total));
    }
    fn stage(&self, name: &str) {
        self.0.lock().unwrap().push((name.to_string(), 0, 0));
    }
}

#[test]
fn a_load_reports_its_surface_analyses_and_objects() {
    let text = "[surface.ball]\nparametric = { x = \"2*s/(s^2+t^2+1)\", y = \"2*t/(s^2+t^2+1)\", z = \"(s^2+t^2-1)/(s^2+t^2+1)\" }\n\
                [[object]]\nshape = \"ball(p)\"\n[[object]]\nshape = \"sphere(p - vec3(3.0, 0.0, 0.0), 1.0)\"\n";
    let rec = std::sync::Arc::new(Recorder::default());
    let opts = LoadOptions {
        progress: Some(rec.clone()),
        ..LoadOptions::default()
    };
    let s = load_str_with(text, "t.toml", &[], &opts).unwrap_or_else(|e| panic!("{}", e.rendered));
    assert_eq!(s.objects.len(), 2);
    let seen = rec.0.lock().unwrap().clone();
    let stages: Vec<&str> = seen.iter().filter(|e| e.2 == 0).map(|e| e.0.as_str()).collect();
    assert!(
        stages.iter().any(|s| s.starts_with("surface `ball`: ")),
        "the implicitization reports its stages: {stages:?}"
    );
    assert_eq!(stages.last(), Some(&"objects"));
    let objects: Vec<(u64, u64)> = seen
        .iter()
        .filter(|e| e.0 == "objects" && e.2 > 0)
        .map(|e| (e.1, e.2))
        .collect();
    assert_eq!(objects, vec![(1, 2), (2, 2)]);
}
