//! Loading a scene: TOML → located tree → `--set` overrides → typed, checked
//! model → compiled shapes. Every error names the file, line and column (or
//! the override) and what was expected.

use std::path::Path;

use isoray_shape::{Library, Span};
use toml::de::{DeTable, DeValue};

use crate::doc::{convert, from_toml, Entry, Item, Located, Origin};
use crate::error::{SceneError, Sources};
use crate::model::*;
use crate::read::{check_scale, environment, Build, TRANSFORM_INPUTS};
use crate::reader::Reader;

type Result<T> = std::result::Result<T, SceneError>;

/// How a scene is loaded.
#[derive(Clone, Default)]
pub struct LoadOptions {
    /// The time `t` in seconds (default 0).
    pub time: f64,
    /// A cache of surface analyses to use (and fill), shared with earlier
    /// loads: a surface already derived for the same content and values is
    /// not derived again.
    pub analyses: Option<isoray_shape::Analyses>,
    /// Stops a load in a long surface analysis (implicitization); the
    /// load then fails with [`SceneError::cancelled`] set.
    pub cancel: Option<isoray_job::CancelToken>,
    /// Compiled objects to reuse (and fill), shared with earlier loads: an
    /// object whose shape, placement and called surfaces are unchanged is
    /// not compiled again. The scene keeps the cache for its own
    /// recompilations.
    pub objects: Option<crate::compile::ObjectCache>,
    /// Told how far the load got: the stages of a surface's implicitization
    /// (`surface `NAME`: …`, with their units) and `objects` (objects
    /// compiled or reused of all).
    pub progress: Option<std::sync::Arc<dyn isoray_job::Progress + Send>>,
}

impl std::fmt::Debug for LoadOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoadOptions")
            .field("time", &self.time)
            .field("analyses", &self.analyses)
            .field("cancel", &self.cancel)
            .field("objects", &self.objects)
            .field("progress", &self.progress.is_some())
            .finish()
    }
}

/// Reads and loads a scene file, applying `--set KEY=VALUE` overrides.
pub fn load(path: &Path, overrides: &[String]) -> Result<Scene> {
    load_with(path, overrides, &LoadOptions::default())
}

/// Reads and loads a scene file at the given options (the time).
pub fn load_with(path: &Path, overrides: &[String], options: &LoadOptions) -> Result<Scene> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(&name, "read", &e))?;
    load_str_with(&text, &name, overrides, options)
}

/// Loads a scene from text; `name` is used in error messages.
pub fn load_str(text: &str, name: &str, overrides: &[String]) -> Result<Scene> {
    load_str_with(text, name, overrides, &LoadOptions::default())
}

/// Loads a scene from text at the given options (the time).
pub fn load_str_with(text: &str, name: &str, overrides: &[String], options: &LoadOptions) -> Result<Scene> {
    if !options.time.is_finite() {
        return Err(SceneError::usage(format!(
            "the time must be a finite number of seconds, found {}",
            options.time
        )));
    }
    let src = Sources {
        path: name.to_string(),
        text: text.to_string(),
        overrides: overrides.to_vec(),
    };
    let table = DeTable::parse(text).map_err(|e| {
        let span = e.span().map(|r| Span::new(r.start, r.end)).unwrap_or_default();
        let msg = e.message().trim().to_string();
        src.error_at(span, &format!("invalid TOML: {msg}"), None, &[])
    })?;
    let mut root = from_toml(table.get_ref(), text);
    for (i, ov) in overrides.iter().enumerate() {
        apply_override(&src, &mut root, i, ov)?;
    }
    let scene = build(&src, &root, options);
    if options.cancel.as_ref().is_some_and(|c| c.is_cancelled()) {
        let mut e = SceneError::usage(format!("loading `{name}` was cancelled"));
        e.cancelled = true;
        return Err(e);
    }
    scene
}

const TOP_KEYS: &[&str] = &[
    "animation",
    "physics",
    "track",
    "midi",
    "bone",
    "skeleton",
    "camera",
    "render",
    "light",
    "material",
    "surface",
    "object",
    "mesh",
    "params",
    "environment",
    // isoray-studio's own table (the node graph's layout): never read here.
    "studio",
];

fn apply_override(src: &Sources, root: &mut Vec<Entry>, index: usize, text: &str) -> Result<()> {
    let origin = Origin::Override(index);
    let Some((key, value)) = text.split_once('=') else {
        return Err(src.error(
            origin,
            format!("override `{text}` must have the form KEY=VALUE"),
            Some("expected KEY=VALUE"),
            &["for example: --set render.shadows=hard".into()],
        ));
    };
    let key = key.trim();
    let value_text = value.trim();
    let value = match DeValue::parse(value_text) {
        Ok(v) => convert(v.get_ref(), Span::default(), value_text, origin),
        Err(_) => Located {
            item: Item::Str(value_text.to_string(), (0..=value_text.len()).collect()),
            origin,
        },
    };
    let path: Vec<&str> = key.split('.').collect();
    if path.iter().any(|s| s.is_empty()) {
        return Err(src.error(
            origin,
            format!("malformed key `{key}` in override"),
            Some("expected a dotted key such as render.aa or light.0.intensity"),
            &[],
        ));
    }
    let mut table: &mut Vec<Entry> = root;
    let mut i = 0;
    loop {
        let seg = path[i];
        let last = i + 1 == path.len();
        let pos = table.iter().position(|e| e.key == seg);
        if last {
            match pos {
                // A parameter given as { default, range } keeps its range:
                // the override sets the default, which is then checked against it.
                Some(p) if is_param_spec(&table[p].value) && !matches!(value.item, Item::Table(_)) => {
                    if let Item::Table(spec) = &mut table[p].value.item {
                        if let Some(d) = spec.iter_mut().find(|e| e.key == "default") {
                            d.value = value;
                        }
                    }
                }
                Some(p) => table[p].value = value,
                None => table.push(Entry {
                    key: seg.to_string(),
                    key_origin: origin,
                    value,
                }),
            }
            return Ok(());
        }
        let p = match pos {
            Some(p) => p,
            None if path[i + 1].parse::<usize>().is_ok() => {
                return Err(src.error(
                    origin,
                    format!(
                        "the scene has no `{seg}` array, so `{}` does not exist",
                        path[..=i + 1].join(".")
                    ),
                    Some("no such element"),
                    &[format!("add a [[{seg}]] table to the scene first")],
                ));
            }
            None => {
                table.push(Entry {
                    key: seg.to_string(),
                    key_origin: origin,
                    value: Located {
                        item: Item::Table(Vec::new()),
                        origin: Origin::Implicit,
                    },
                });
                table.len() - 1
            }
        };
        let next = &mut table[p].value;
        match &mut next.item {
            Item::Table(t) => {
                table = t;
                i += 1;
            }
            Item::Array(items) => {
                let Some(idx_seg) = path.get(i + 1) else { unreachable!() };
                let n = items.len();
                let Ok(idx) = idx_seg.parse::<usize>() else {
                    return Err(src.error(
                        origin,
                        format!("`{seg}` is an array: expected an index after `{seg}.`, found `{idx_seg}`"),
                        Some("expected an index"),
                        &[format!("for example: --set {seg}.0.…")],
                    ));
                };
                let Some(elem) = items.get_mut(idx) else {
                    return Err(src.error(
                        origin,
                        format!("`{seg}` has {n} element(s); index {idx} is out of range"),
                        Some("no such element"),
                        &[],
                    ));
                };
                if i + 2 == path.len() {
                    *elem = value;
                    return Ok(());
                }
                match &mut elem.item {
                    Item::Table(t) => {
                        table = t;
                        i += 2;
                    }
                    other => {
                        return Err(src.error(
                            origin,
                            format!("`{seg}.{idx}` is {}, not a table", other.type_name()),
                            None,
                            &[],
                        ))
                    }
                }
            }
            other => {
                let tn = other.type_name();
                return Err(src.error(
                    origin,
                    format!("`{}` is {tn}, so it has no key `{}`", path[..=i].join("."), path[i + 1]),
                    Some("cannot set a key inside a value"),
                    &[],
                ));
            }
        }
    }
}

/// True for a parameter written as `{ default = ..., range = [...] }`.
fn is_param_spec(v: &Located) -> bool {
    matches!(&v.item, Item::Table(t) if t.iter().any(|e| e.key == "default"))
}

fn build(src: &Sources, root: &[Entry], options: &LoadOptions) -> Result<Scene> {
    let root_item = Located {
        item: Item::Table(root.to_vec()),
        origin: Origin::Implicit,
    };
    let mut top = Reader::new(src, &root_item, "scene")?;
    let mut lib = Library::new();
    lib.set_time(options.time);
    if let Some(cache) = &options.analyses {
        lib.use_analyses(cache.clone());
    }
    if let Some(token) = &options.cancel {
        lib.set_cancel(token.clone());
    }
    if let Some(p) = &options.progress {
        lib.set_progress(p.clone());
    }
    let mut b = Build {
        src,
        root,
        snippets: Vec::new(),
        lib,
        driven: Vec::new(),
        param_ranges: Vec::new(),
        surface_materials: Vec::new(),
    };
    let mut params = b.read_params(top.get("params"))?;
    let animation = match top.get("animation") {
        Some(v) => Some(crate::animation::read_animation(src, v)?),
        None => None,
    };
    let physics = match top.get("physics") {
        Some(v) => Some(crate::physics::read_physics(src, v)?),
        None => None,
    };
    let mut tracks = match top.get("track") {
        Some(v) => crate::animation::read_tracks(src, v)?,
        None => Vec::new(),
    };
    let mut bones = match top.get("bone") {
        Some(v) => crate::skeleton::read_bones(src, v)?,
        None => Vec::new(),
    };
    if let Some(v) = top.get("skeleton") {
        if !bones.is_empty() {
            return Err(src
                .error(
                    v.origin,
                    "a scene's bones come from [[bone]] tables or from a [skeleton] glTF file, not both",
                    Some("a second skeleton"),
                    &[],
                )
                .with_key("skeleton"));
        }
        let dir = std::path::Path::new(&src.path)
            .parent()
            .map(std::path::Path::to_path_buf)
            .unwrap_or_default();
        let (b, t) = crate::skeleton::read_gltf_skeleton(src, v, &dir)?;
        bones = b;
        tracks.extend(t);
    }
    let mut midi = match top.get("midi") {
        Some(v) => crate::midi::read_mappings(src, v)?,
        None => Vec::new(),
    };
    // MIDI mappings resolve and check their targets as tracks of their
    // extreme values (probes) would.
    let file_tracks = tracks.len();
    tracks.extend(midi.iter().enumerate().map(|(i, m)| m.probe(i)));
    let placed = crate::animation::resolve_early(src, &b.lib, &mut tracks, &params, &b.param_ranges, &bones)?;
    crate::animation::apply_param_tracks(&mut b.lib, &tracks[..file_tracks], &mut params, options.time);
    let camera = b.read_camera(top.get("camera"))?;
    let environment = match top.get("environment") {
        None => None,
        Some(v) => Some(environment(src, v, &src.path)?),
    };

    let render = match top.get("render") {
        Some(v) => {
            let mut r = Reader::new(src, v, "render")?;
            let s = RenderSettings::read(&mut r)?;
            r.finish_keys(render_keys())?;
            s
        }
        None => RenderSettings::default(),
    };

    let lights = b.read_lights(top.get("light"))?;
    let materials = b.read_materials(top.get("material"))?;
    b.read_surfaces(top.get("surface"), &materials)?;
    let cache = options.objects.clone().unwrap_or_default();
    let mut objects = b.read_objects(top.get("object"), &materials, &cache, &placed, &bones)?;
    crate::animation::resolve_late(src, root, &mut tracks, objects.len(), &b.driven)?;
    let scene_dir = std::path::Path::new(&src.path)
        .parent()
        .map(std::path::Path::to_path_buf)
        .unwrap_or_default();
    let meshes = crate::meshes::read_meshes(src, top.get("mesh"), &materials, &scene_dir, &cache)?;
    let probes = tracks.split_off(file_tracks);
    for (m, p) in midi.iter_mut().zip(&probes) {
        m.drive = p.drive.clone();
    }
    // isoray-studio's layout: accepted and never read.
    let _ = top.get("studio");
    top.finish(TOP_KEYS)?;

    let lib = b.lib;
    // The inputs: the time, the parameters, then seven per placed object.
    let mut input_names = lib.input_names();
    let mut inputs = lib.input_values();
    let frames = crate::model::bone_frames(&bones, &tracks, options.time);
    for (i, o) in objects.iter().enumerate() {
        if let Some(tr) = &o.transform {
            for (k, name) in TRANSFORM_INPUTS.iter().enumerate() {
                input_names.push(format!("object.{i}.{name}"));
                inputs.push(tr.values[k].eval_with(&inputs, [0.0; 3]));
            }
            crate::model::place_by_tracks(&tracks, i, options.time, &mut inputs[tr.inputs as usize..]);
            if let Some(b) = o.bone {
                crate::skeleton::carry(&frames[b], &mut inputs[tr.inputs as usize..]);
            }
            check_scale(src, i, tr, inputs[tr.inputs as usize + 6])?;
        }
    }
    // The scene's distance and what renderers derive from the objects.
    let (shape, derived) = crate::derive::assemble(&mut objects, &materials, &render, &inputs);
    let mut scene = Scene {
        animation,
        physics,
        tracks,
        bones,
        midi,
        midi_tracks: Vec::new(),
        camera,
        render,
        lights,
        materials,
        objects,
        meshes,
        params,
        shape,
        derived,
        environment,
        input_names,
        inputs,
        driven: b.driven,
        library: lib,
        param_ranges: b.param_ranges,
        origin: std::sync::Arc::new(SceneOrigin {
            sources: src.clone(),
            root: root.to_vec(),
        }),
        cache,
    };
    scene.start_tracks()?;
    Ok(scene)
}
