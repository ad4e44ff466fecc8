//! Reading the tables of a scene into its typed model: parameters, the
//! camera, lights, materials, user surfaces and objects (each compiled,
//! or reused from the object cache), with values written as shape text of
//! `t` and the parameters. Every error names its place.

use std::path::Path;
use std::sync::Arc;

use isoray_shape::diag::suggest;
use isoray_shape::surface::{BoundMethod, SurfaceOptions, DEFAULT_DOMAIN};
use isoray_shape::{Builder, Diagnostic, Library, Shape, Span, SurfaceMode, Value};

use crate::doc::{Entry, Item, Located, Origin};
use crate::env::{EnvMap, Environment, RgbImage};
use crate::error::{SceneError, Sources};
use crate::model::*;
use crate::reader::{describe, Reader};
use crate::schema::{spec, KeySpec};

type Result<T> = std::result::Result<T, SceneError>;

/// The state of one load while its tables are read: the sources, the
/// shape-text snippets (to locate errors inside shape text), the library
/// the tables build, and what they add besides.
pub(crate) struct Build<'a> {
    pub(crate) src: &'a Sources,
    pub(crate) root: &'a [Entry],
    pub(crate) snippets: Vec<(&'a Located, &'a [usize])>,
    pub(crate) lib: Library,
    pub(crate) driven: Vec<Driven>,
    pub(crate) param_ranges: Vec<ParamRange>,
    /// The default material of each user surface that names one.
    pub(crate) surface_materials: Vec<(String, usize)>,
}

/// The entries of a table of named tables (`[material.NAME]`), or the error `message`.
fn named_tables<'v>(src: &Sources, v: &'v Located, message: &str) -> Result<&'v [Entry]> {
    match &v.item {
        Item::Table(entries) => Ok(entries),
        _ => Err(src.error(v.origin, message, None, &[])),
    }
}

/// The tables of an array of tables (`[[key]]`); a single table counts as
/// one when `single` allows it.
pub(crate) fn array_of_tables<'v>(src: &Sources, v: &'v Located, key: &str, single: bool) -> Result<Vec<&'v Located>> {
    match &v.item {
        Item::Array(items) => Ok(items.iter().collect()),
        Item::Table(_) if single => Ok(vec![v]),
        other => Err(src.error(
            v.origin,
            format!(
                "`{key}` must be an array of tables ([[{key}]]), found {}",
                other.type_name()
            ),
            None,
            &[],
        )),
    }
}

/// A shape-text diagnostic as a scene error at its place in the file (or
/// the override), with the dotted key of the value it is in.
fn shape_error_at(src: &Sources, root: &[Entry], snips: &[(&Located, &[usize])], d: Diagnostic) -> SceneError {
    let Some((loc, map)) = snips.get(d.source) else {
        return src.error(Origin::Implicit, d.message.clone(), None, &d.notes);
    };
    let at = |i: usize| map.get(i).copied().unwrap_or_else(|| map.last().copied().unwrap_or(0));
    let e = match loc.origin {
        Origin::File(_) => {
            let span = Span::new(at(d.span.start), at(d.span.end.max(d.span.start)));
            src.error_at(span, &d.message, d.label.as_deref(), &d.notes)
        }
        o => {
            let mut notes = d.notes.clone();
            notes.insert(0, format!("at byte {} of the value", d.span.start));
            src.error(o, d.message.clone(), d.label.as_deref(), &notes)
        }
    };
    // The key of the value the shape text is in, for editors.
    let key = match loc.origin {
        Origin::Override(i) => src
            .overrides
            .get(i)
            .and_then(|o| o.split_once('='))
            .map(|(k, _)| k.trim().to_string()),
        o => key_at(root, o),
    };
    match key {
        Some(k) => e.with_key(k),
        None => e,
    }
}

impl<'a> Build<'a> {
    /// Turns shape-text diagnostics into scene errors at their place
    /// (see [`shape_error_at`]); holds no borrow of `self`.
    fn shape_errors(&self) -> impl Fn(&[(&Located, &[usize])], Diagnostic) -> SceneError + 'a {
        let (src, root) = (self.src, self.root);
        move |snips, d| shape_error_at(src, root, snips, d)
    }

    /// `[params]`: the scene's named parameters, added to the library.
    pub(crate) fn read_params(&mut self, table: Option<&'a Located>) -> Result<Vec<(String, Value)>> {
        let src = self.src;
        let lib = &mut self.lib;
        let param_ranges = &mut self.param_ranges;
        let mut params = Vec::new();
        if let Some(v) = table {
            let entries = named_tables(src, v, "`params` must be a table of named numbers or vectors")?;
            for e in entries {
                let key = format!("params.{}", e.key);
                let val = param_spec(src, &e.value, &key, param_ranges)?;
                check_name(src, &e.key, e.key_origin)?;
                if e.key == "t" {
                    return Err(src.error(
                        e.key_origin,
                        "`params.t`: `t` is the built-in time in shape text",
                        Some("choose another name"),
                        &["shape text reads the time (seconds, `--time`) as `t`".into()],
                    ));
                }
                lib.set_param(&e.key, val);
                params.push((e.key.clone(), val));
            }
        }

        Ok(params)
    }

    /// `[camera]`, with values that are shape text of `t` and the parameters.
    pub(crate) fn read_camera(&mut self, table: Option<&'a Located>) -> Result<Camera> {
        let src = self.src;
        let shape_error = self.shape_errors();
        let lib = &self.lib;
        let snippets = &mut self.snippets;
        let driven = &mut self.driven;
        let camera_table = match table {
            Some(v) => Some(
                resolve_exprs(src, lib, v, "camera", camera_keys(), snippets, driven)
                    .map_err(|e| e.into_scene(snippets, &shape_error))?,
            ),
            None => None,
        };
        let camera = match camera_table.as_ref() {
            Some(v) => {
                let mut r = Reader::new(src, v, "camera")?;
                let camera = Camera::read(&mut r)?;
                let check_origin = r
                    .get("target")
                    .or(r.get("position"))
                    .map(|l| l.origin)
                    .unwrap_or(v.origin);
                r.finish_keys(camera_keys())?;
                if let Err(problem) = camera.check() {
                    let (message, label) = match problem {
                        CameraProblem::NoDirection => (
                            "camera `target` equals `position`: the camera has no direction",
                            "move the target away from the position",
                        ),
                        CameraProblem::UpAlongView => (
                            "camera `up` is parallel to the viewing direction (or zero)",
                            "choose an `up` that is not along target − position",
                        ),
                    };
                    return Err(src.error(check_origin, message, Some(label), &[]));
                }
                camera
            }
            None => Camera::default(),
        };

        Ok(camera)
    }

    /// `[[light]]`.
    pub(crate) fn read_lights(&mut self, table: Option<&'a Located>) -> Result<Vec<Light>> {
        let src = self.src;
        let shape_error = self.shape_errors();
        let lib = &self.lib;
        let snippets = &mut self.snippets;
        let driven = &mut self.driven;
        let mut lights = Vec::new();
        if let Some(v) = table {
            // A single `[light]` table is one light.
            let items = array_of_tables(src, v, "light", true)?;
            for (i, lv) in items.into_iter().enumerate() {
                let ctx = format!("light.{i}");
                let resolved = resolve_exprs(src, lib, lv, &ctx, light_keys(), snippets, driven)
                    .map_err(|e| e.into_scene(snippets, &shape_error))?;
                let lv = &resolved;
                let mut r = Reader::new(src, lv, &ctx)?;
                let keys = light_keys();
                let kind_name = r.choice_key(spec(keys, "kind"))?;
                let need = |r: &mut Reader, key: &str, what: &str| -> Result<Vec3> {
                    r.vec3_opt(key)?.ok_or_else(|| {
                        src.error(
                            lv.origin,
                            format!("{what} light `light.{i}` needs a `{key}`"),
                            Some(&format!("add {key} = [x, y, z]")),
                            &[],
                        )
                    })
                };
                let kind = match kind_name {
                    "directional" => {
                        let dir = r.vec3("direction", spec(keys, "direction").default_vec3())?;
                        if norm(dir) < 1e-12 {
                            let o = r.get("direction").map(|l| l.origin).unwrap_or(lv.origin);
                            return Err(src.error(
                                o,
                                format!("`light.{i}.direction` must not be zero"),
                                Some("expected a direction towards the light"),
                                &[],
                            ));
                        }
                        LightKind::Directional {
                            direction: normalize(dir),
                        }
                    }
                    "point" => LightKind::Point {
                        position: need(&mut r, "position", "point")?,
                    },
                    "sphere" => {
                        let position = need(&mut r, "position", "sphere")?;
                        let radius = r.num_key(spec(keys, "radius"))?;
                        LightKind::Sphere { position, radius }
                    }
                    _ => {
                        let position = need(&mut r, "position", "rect")?;
                        let u = need(&mut r, "u", "rect")?;
                        let v = need(&mut r, "v", "rect")?;
                        if norm(cross(u, v)) < 1e-12 {
                            let o = r.get("v").map(|l| l.origin).unwrap_or(lv.origin);
                            return Err(src.error(
                                o,
                                format!("`light.{i}`: the edges `u` and `v` must not be parallel or zero"),
                                Some("expected a second edge across the first"),
                                &[],
                            ));
                        }
                        LightKind::Rect { position, u, v }
                    }
                };
                let light = Light {
                    kind,
                    ..Light::read(&mut r)?
                };
                r.finish_keys(keys)?;
                lights.push(light);
            }
        }

        Ok(lights)
    }

    /// `[material.NAME]`: the default material first, then each table.
    pub(crate) fn read_materials(&mut self, table: Option<&'a Located>) -> Result<Vec<Material>> {
        let src = self.src;
        let shape_error = self.shape_errors();
        let lib = &self.lib;
        let snippets = &mut self.snippets;
        let driven = &mut self.driven;
        let mut pending_checkers: Vec<(String, String, Located, f64)> = Vec::new();
        let mut materials = vec![Material::default_named("default")];
        if let Some(v) = table {
            let entries = named_tables(
                src,
                v,
                "`material` must be a table of named materials ([material.NAME])",
            )?;
            for e in entries {
                let ctx = format!("material.{}", e.key);
                let resolved = resolve_exprs(src, lib, &e.value, &ctx, material_keys(), snippets, driven)
                    .map_err(|e| e.into_scene(snippets, &shape_error))?;
                let mut r = Reader::new(src, &resolved, &ctx)?;
                let keys = material_keys();
                let m = Material {
                    name: e.key.clone(),
                    fresnel: fresnel_setting(&mut r, keys)?,
                    ..Material::read(&mut r)?
                };
                let checker_size = r.num_key(spec(keys, "checker_size"))?;
                if let Some((other, loc)) = r.string("checker")? {
                    pending_checkers.push((e.key.clone(), other.to_string(), loc.clone(), checker_size));
                } else if let Some(v) = r.get("checker_size") {
                    return Err(src.error(
                        v.origin,
                        format!("`material.{}.checker_size` needs `checker`", e.key),
                        Some("no checker"),
                        &["add checker = \"OTHER_MATERIAL\"".into()],
                    ));
                }
                r.finish_keys(keys)?;
                if let Some(slot) = materials.iter_mut().find(|x| x.name == m.name) {
                    *slot = m;
                } else {
                    materials.push(m);
                }
            }
        }
        // Checkers name other materials, defined before or after.
        for (name, other, loc, size) in pending_checkers {
            let k = material_index(src, &materials, &other, &loc, &format!("material.{name}.checker"))?;
            if let Some(m) = materials.iter_mut().find(|x| x.name == name) {
                m.checker = Some((k, size));
            }
        }

        Ok(materials)
    }

    /// `[surface.NAME]`: user surfaces, added to the library and checked.
    pub(crate) fn read_surfaces(&mut self, table: Option<&'a Located>, materials: &[Material]) -> Result<()> {
        let src = self.src;
        let shape_error = self.shape_errors();
        let lib = &mut self.lib;
        let snippets = &mut self.snippets;
        let param_ranges = &mut self.param_ranges;
        let surface_materials = &mut self.surface_materials;
        if let Some(v) = table {
            let entries = named_tables(src, v, "`surface` must be a table of named surfaces ([surface.NAME])")?;
            for e in entries {
                let ctx = format!("surface.{}", e.key);
                check_name(src, &e.key, e.key_origin)?;
                if isoray_shape::library::is_function(&e.key) {
                    return Err(src.error(
                        e.key_origin,
                        format!("surface name `{}` is already a built-in function", e.key),
                        Some("choose another name"),
                        &[],
                    ));
                }
                let mut r = Reader::new(src, &e.value, &ctx)?;
                let mut sparams = Vec::new();
                if let Some(pv) = r.get("params") {
                    let Item::Table(pe) = &pv.item else {
                        return Err(src.error(
                            pv.origin,
                            format!("`{ctx}.params` must be a table such as {{ R = 1.0, r = 0.25 }}"),
                            None,
                            &[],
                        ));
                    };
                    for p in pe {
                        check_name(src, &p.key, p.key_origin)?;
                        sparams.push((
                            p.key.clone(),
                            param_spec(src, &p.value, &format!("{ctx}.params.{}", p.key), param_ranges)?,
                        ));
                    }
                }
                let options = surface_options(&mut r)?;
                if let Some((m, loc)) = r.string("material")? {
                    let k = material_index(src, materials, m, loc, &format!("{ctx}.material"))?;
                    surface_materials.push((e.key.clone(), k));
                }
                let sdf = r.string("sdf")?;
                let implicit = r.string("implicit")?;
                let parametric = r.get("parametric");
                let vm = r.string("vm")?;
                let given: Vec<&Located> = [sdf.map(|x| x.1), implicit.map(|x| x.1), parametric, vm.map(|x| x.1)]
                    .into_iter()
                    .flatten()
                    .collect();
                if given.len() > 1 {
                    return Err(src.error(
                        given[1].origin,
                        format!("`{ctx}` has more than one of `sdf`, `implicit`, `parametric` and `vm`: a surface has exactly one mode"),
                        Some("remove all but one"),
                        &[],
                    ));
                }
                if let Some(pv) = parametric {
                    let coords = parametric_coords(src, pv, &ctx)?;
                    let domain = parametric_domain(&mut r, &ctx)?;
                    r.finish_keys(surface_keys())?;
                    let mut texts = Vec::new();
                    for (text, loc) in coords {
                        let Item::Str(_, map) = &loc.item else { unreachable!() };
                        texts.push((text, snippets.len()));
                        snippets.push((loc, map));
                    }
                    let texts: [(&str, usize); 3] = [texts[0], texts[1], texts[2]];
                    lib.add_parametric_surface(&e.key, sparams, texts, domain, options)
                        .map_err(|d| shape_error(snippets, d))?;
                    continue;
                }
                for key in ["domain", "image_only"] {
                    if let Some(v) = r.get(key) {
                        return Err(src.error(
                            v.origin,
                            format!("`{ctx}.{key}` applies only to parametric surfaces"),
                            Some("only for `parametric`"),
                            &[],
                        ));
                    }
                }
                if let Some((file, loc)) = vm {
                    r.finish_keys(surface_keys())?;
                    let text = vm_surface_text(src, loc, file, &ctx)?;
                    let Item::Str(_, map) = &loc.item else { unreachable!() };
                    // Shape-level errors point at the path (the text is generated).
                    let id = snippets.len();
                    snippets.push((loc, &map[..map.len().min(1)]));
                    lib.add_surface_with_mode(&e.key, sparams, &text, id, SurfaceMode::Sdf)
                        .map_err(|d| shape_error(snippets, d))?;
                    lib.set_surface_options(&e.key, options);
                    continue;
                }
                let (text, loc, mode) = match (sdf, implicit) {
                    (Some((t, l)), None) => (t, l, SurfaceMode::Sdf),
                    (None, Some((t, l))) => (t, l, SurfaceMode::Implicit),
                    _ => {
                        return Err(src.error(
                            e.value.origin,
                            format!("`{ctx}` needs an `sdf` expression, an `implicit` equation, a `parametric` x, y, z or a `vm` file"),
                            Some("add sdf = \"...\", implicit = \"...\" or parametric = { x = \"...\", y = \"...\", z = \"...\" }"),
                            &[],
                        ))
                    }
                };
                r.finish_keys(surface_keys())?;
                let Item::Str(_, map) = &loc.item else { unreachable!() };
                let id = snippets.len();
                snippets.push((loc, map));
                let param_keys = r_params_origins(&e.value).unwrap_or_default();
                lib.add_surface_with_mode(&e.key, sparams, text, id, mode)
                    .map_err(|d| shape_error(snippets, d))?;
                lib.set_surface_options(&e.key, options);
                if mode == SurfaceMode::Implicit {
                    let used = lib.surface(&e.key).map(|s| s.program.names_used()).unwrap_or_default();
                    if let Some((name, origin)) = param_keys.iter().find(|(n, _)| !used.contains(n)) {
                        return Err(src.error(
                            *origin,
                            format!(
                                "parameter `{name}` of surface `{}` is never used in its equation",
                                e.key
                            ),
                            Some("unused parameter"),
                            &["remove it, or use it in the equation".into()],
                        ));
                    }
                }
            }
        }
        lib.check().map_err(|d| shape_error(snippets, d))?;

        Ok(())
    }

    /// `[[object]]`: each object compiled (or taken from `cache`).
    pub(crate) fn read_objects(
        &mut self,
        table: Option<&'a Located>,
        materials: &[Material],
        cache: &crate::compile::ObjectCache,
        placed: &[usize],
        bones: &[crate::skeleton::Bone],
    ) -> Result<Vec<Object>> {
        let src = self.src;
        let shape_error = self.shape_errors();
        let lib = &self.lib;
        let snippets = &mut self.snippets;
        let surface_materials = &self.surface_materials;
        let mut transformed = 0usize;
        let mut objects = Vec::new();
        match table {
            None => {}
            Some(v) => {
                let items = array_of_tables(src, v, "object", false)?;
                let count = items.len() as u64;
                // The values exact algebra binds now (the cache checks them).
                let inputs = lib.input_values();
                if let Some(p) = lib.progress() {
                    p.stage("objects");
                }
                for (i, ov) in items.into_iter().enumerate() {
                    let mut r = Reader::new(src, ov, &format!("object.{i}"))?;
                    let name = r.string("name")?.map(|(s, _)| s.to_string());
                    let material = match r.string("material")? {
                        None => None,
                        Some((m, loc)) => {
                            Some(material_index(src, materials, m, loc, &format!("object.{i}.material"))?)
                        }
                    };
                    let Some((text, loc)) = r.string("shape")? else {
                        return Err(src.error(
                            ov.origin,
                            format!("`object.{i}` needs a `shape`"),
                            Some("add shape = \"sphere(p, 1.0)\""),
                            &[],
                        ));
                    };
                    // The placement: each value a number or shape text of t and parameters.
                    let mut placement: Vec<(&str, Option<&Located>)> = Vec::new();
                    for key in TRANSFORM_KEYS {
                        placement.push((key, r.get(key)));
                    }
                    let bone = match r.string("bone")? {
                        None => None,
                        Some((name, loc)) => match bones.iter().position(|b| b.name == name) {
                            Some(k) => Some(k),
                            None => {
                                let mut notes = vec![];
                                if let Some(s) =
                                    isoray_shape::diag::suggest(name, bones.iter().map(|b| b.name.as_str()))
                                {
                                    notes.push(format!("did you mean \"{s}\"?"));
                                }
                                if bones.is_empty() {
                                    notes.push("define bones with [[bone]] tables".into());
                                }
                                return Err(src
                                    .error(
                                        loc.origin,
                                        format!("`object.{i}.bone`: the scene has no bone named \"{name}\""),
                                        Some("unknown bone"),
                                        &notes,
                                    )
                                    .with_key(format!("object.{i}.bone")));
                            }
                        },
                    };
                    let mut physics = crate::physics::read_object_physics(src, &mut r, &format!("object.{i}"))?;
                    let sdf_dents = crate::sdf_dents::read(src, &mut r, &format!("object.{i}"))?;
                    r.finish_keys(object_keys())?;
                    // Placed in the file, by a track or by the simulation
                    // (which need the inputs).
                    let moves = matches!(
                        physics.body,
                        crate::physics::BodyKind::Dynamic | crate::physics::BodyKind::Kinematic
                    );
                    let transform =
                        if placement.iter().any(|(_, v)| v.is_some()) || placed.contains(&i) || bone.is_some() || moves
                        {
                            let mut values: Vec<Shape> = Vec::with_capacity(7);
                            for (key, v) in &placement {
                                let ctx = format!("object.{i}.{key}");
                                let (width, default) = if *key == "scale" { (1, 1.0) } else { (3, 0.0) };
                                let Some(v) = v else {
                                    values.extend((0..width).map(|_| constant_shape(default)));
                                    continue;
                                };
                                let vals = uniform_values(src, lib, v, &ctx, width, snippets)
                                    .map_err(|e| e.into_scene(snippets, &shape_error))?;
                                values.extend(vals);
                            }
                            let inputs = lib.input_count() as u32 + 7 * transformed as u32;
                            transformed += 1;
                            Some(Transform {
                                inputs,
                                values: values.try_into().expect("seven values"),
                                scale_origin: placement[2].1.map(|l| l.origin),
                            })
                        } else {
                            None
                        };
                    let Item::Str(_, map) = &loc.item else { unreachable!() };
                    let id = snippets.len();
                    snippets.push((loc, map));
                    // The functions the text calls (remembered per text: an
                    // object taken from the cache is not even parsed).
                    let mut program = None;
                    let called = match cache.called(text) {
                        Some(c) => c,
                        None => {
                            let p = isoray_shape::syntax::parse(text, id).map_err(|d| shape_error(snippets, d))?;
                            let c = p.functions_called();
                            cache.remember_called(text, c.clone());
                            program = Some(p);
                            c
                        }
                    };
                    // The impactors' shape texts of the object's SDF dents,
                    // parsed once per distinct text.
                    let mut called = called;
                    let mut dent_programs: Vec<(String, isoray_shape::syntax::Program, isoray_shape::SourceId)> =
                        Vec::new();
                    let mut dent_program_of = Vec::with_capacity(sdf_dents.len());
                    for (dent, loc) in &sdf_dents {
                        let k = match dent_programs.iter().position(|(t, _, _)| *t == dent.shape) {
                            Some(k) => k,
                            None => {
                                let Item::Str(_, map) = &loc.item else { unreachable!() };
                                let did = snippets.len();
                                snippets.push((loc, map));
                                let p = isoray_shape::syntax::parse(&dent.shape, did)
                                    .map_err(|d| shape_error(snippets, d))?;
                                for c in p.functions_called() {
                                    if !called.contains(&c) {
                                        called.push(c);
                                    }
                                }
                                dent_programs.push((dent.shape.clone(), p, did));
                                dent_programs.len() - 1
                            }
                        };
                        dent_program_of.push(k);
                    }
                    physics.sdf_dents = sdf_dents.into_iter().map(|(d, _)| d).collect();
                    let mut key = crate::compile::object_key(lib, text, transform.is_some(), &called);
                    key.push_str(&crate::sdf_dents::cache_key(&physics.sdf_dents));
                    let dents = &physics.sdf_dents;
                    let fragment = cache
                        .get_or_compile(key, &inputs, || {
                            let program = match program.take() {
                                Some(p) => p,
                                None => isoray_shape::syntax::parse(text, id)?,
                            };
                            let mut b = Builder::new();
                            let p = match &transform {
                                Some(tr) => tr.lower_point_at(&mut b, crate::compile::FRAGMENT_INPUTS),
                                None => [b.x(), b.y(), b.z()],
                            };
                            let mut compiled = lib.compile_at(&mut b, &program, id, p)?;
                            let mut bound = std::mem::take(&mut compiled.bound);
                            let mut guards = std::mem::take(&mut compiled.guards);
                            let dented = crate::sdf_dents::lower(&mut b, p, compiled.node, dents, &mut |b, k, q| {
                                let (_, program, did) = &dent_programs[dent_program_of[k]];
                                let c = lib.compile_at(b, program, *did, q)?;
                                bound.extend(c.bound);
                                guards.extend(c.guards);
                                Ok::<_, Diagnostic>(c.node)
                            })?;
                            bound.sort_unstable();
                            bound.dedup();
                            compiled.bound = bound;
                            compiled.guards = guards;
                            let node = match &transform {
                                Some(_) => {
                                    Transform::lower_distance_at(&mut b, dented, crate::compile::FRAGMENT_INPUTS)
                                }
                                None => dented,
                            };
                            let guards = compiled
                                .guards
                                .iter()
                                .map(|(n, what)| (Shape::from_tape(b.tape(*n)), what.clone()))
                                .collect();
                            Ok(crate::compile::Compiled {
                                graph: b,
                                node,
                                bound: compiled.bound,
                                called,
                                guards,
                            })
                        })
                        .map_err(|d| shape_error(snippets, d))?;
                    // uv = "parametric": the (s, t) of the parametric surface it calls.
                    if physics.dent_map.uv == "parametric" {
                        let key = format!("object.{i}.dent_map");
                        let at = ov.origin;
                        let surface = fragment.called.iter().find(|c| {
                            lib.surface(c)
                                .is_some_and(|s| s.mode == isoray_shape::SurfaceMode::Parametric)
                        });
                        let Some(name) = surface else {
                            return Err(src
                                .error(
                                    at,
                                    format!("`{key}.uv = \"parametric\"` needs the object's shape to call a parametric surface"),
                                    Some("no parametric surface called"),
                                    &["define one with [surface.NAME] x, y, z of s and t, and call it: shape = \"NAME(p)\"".into()],
                                )
                                .with_key(key));
                        };
                        let m = crate::physics::parametric_mapping(lib, name)
                            .map_err(|e| src.error(at, format!("`{key}`: {e}"), None, &[]).with_key(key.clone()))?;
                        physics.dent_map.parametric = Some(m);
                    }
                    // Without a material of its own, an object takes the default
                    // material of the first surface its shape calls.
                    let material = material.unwrap_or_else(|| {
                        fragment
                            .called
                            .iter()
                            .find_map(|c| surface_materials.iter().find(|(n, _)| n == c).map(|(_, k)| *k))
                            .unwrap_or(0)
                    });
                    objects.push(Object {
                        name,
                        bone,
                        material,
                        source: text.to_string(),
                        shape: constant_shape(EMPTY),
                        bound_inputs: fragment.bound.clone(),
                        transform,
                        fragment,
                        physics,
                    });
                    if let Some(p) = lib.progress() {
                        p.update(i as u64 + 1, count);
                    }
                }
            }
        }
        Ok(objects)
    }
}

/// A copy of the table `v` in which every numeric key of `keys` written as shape
/// text (or an array with shape text in it) is replaced by its value now,
/// at the value's origin, so the table reads and checks like numbers; each
/// such value is recorded in `driven` to be computed again when the time or
/// a parameter changes.
fn resolve_exprs<'a>(
    src: &Sources,
    lib: &Library,
    v: &'a Located,
    ctx: &str,
    keys: &[KeySpec],
    snippets: &mut Vec<(&'a Located, &'a [usize])>,
    driven: &mut Vec<Driven>,
) -> std::result::Result<Located, ValueError> {
    let Item::Table(entries) = &v.item else {
        return Ok(v.clone());
    };
    let vars = lib.input_values();
    let mut out = v.clone();
    let Item::Table(out_entries) = &mut out.item else {
        unreachable!()
    };
    for (e, o) in entries.iter().zip(out_entries.iter_mut()) {
        if !keys.iter().any(|k| k.name == e.key && k.is_numeric()) {
            continue;
        }
        let has_text = match &e.value.item {
            Item::Str(..) => true,
            Item::Array(items) => items.iter().any(|it| matches!(it.item, Item::Str(..))),
            _ => false,
        };
        if !has_text {
            continue;
        }
        let key = format!("{ctx}.{}", e.key);
        let width = match &e.value.item {
            Item::Array(items) => items.len(),
            _ => 0,
        };
        let values = match width {
            0 => {
                // One string: a float or a vec3.
                let Item::Str(text, map) = &e.value.item else {
                    unreachable!()
                };
                let id = snippets.len();
                snippets.push((&e.value, map));
                let mut b = Builder::new();
                let (_, comps) = lib.compile_uniform(&mut b, text, id).map_err(ValueError::Shape)?;
                comps.into_iter().map(|n| Shape::from_tape(b.tape(n))).collect()
            }
            _ => uniform_values(src, lib, &e.value, &key, width, snippets)?,
        };
        let now: Vec<f64> = values.iter().map(|s| s.eval_with(&vars, [0.0; 3])).collect();
        o.value.item = match now[..] {
            [x] => Item::Num(x, false),
            _ => Item::Array(
                now.iter()
                    .map(|&x| Located {
                        item: Item::Num(x, false),
                        origin: e.value.origin,
                    })
                    .collect(),
            ),
        };
        driven.push(Driven {
            key,
            values,
            origin: e.value.origin,
        });
    }
    Ok(out)
}

/// The dotted key of the value written at `origin` (`object.2.shape`,
/// `surface.s.parametric.x`, `object.0.position.1`).
fn key_at(entries: &[Entry], origin: Origin) -> Option<String> {
    fn walk(item: &Located, origin: Origin, path: &mut Vec<String>) -> bool {
        if item.origin == origin && !matches!(item.item, Item::Table(_)) {
            return true;
        }
        match &item.item {
            Item::Table(es) => {
                for e in es {
                    path.push(e.key.clone());
                    if walk(&e.value, origin, path) {
                        return true;
                    }
                    path.pop();
                }
                false
            }
            Item::Array(items) => {
                for (i, it) in items.iter().enumerate() {
                    path.push(i.to_string());
                    if walk(it, origin, path) {
                        return true;
                    }
                    path.pop();
                }
                false
            }
            _ => false,
        }
    }
    let root = Located {
        item: Item::Table(entries.to_vec()),
        origin: Origin::Implicit,
    };
    let mut path = Vec::new();
    walk(&root, origin, &mut path).then(|| path.join("."))
}

/// The distance of empty space (no object), far beyond any ray.
use crate::derive::EMPTY;

/// The placement keys of an `[[object]]`, in input order.
const TRANSFORM_KEYS: [&str; 3] = ["position", "rotation", "scale"];

/// The names of an object's seven transform inputs.
pub(crate) const TRANSFORM_INPUTS: [&str; 7] = [
    "position.x",
    "position.y",
    "position.z",
    "rotation.x",
    "rotation.y",
    "rotation.z",
    "scale",
];

/// A scale must be positive (a distance is scaled by it).
pub(crate) fn check_scale(src: &Sources, object: usize, tr: &Transform, s: f64) -> Result<()> {
    if s.is_finite() && s > 0.0 {
        return Ok(());
    }
    let msg = format!("`object.{object}.scale` must be a positive number, found {s}");
    Err(match tr.scale_origin {
        Some(o) => src.error(o, msg, Some("expected a scale > 0"), &[]),
        None => SceneError::usage(msg),
    })
}

/// A shape that is the constant `v` (a fixed value of the scene).
fn constant_shape(v: f64) -> Shape {
    let mut b = Builder::new();
    let n = b.constant(v);
    Shape::from_tape(b.tape(n))
}

/// Shape text snippets: per source id, the value it came from and the byte
/// map of its text into the file or override.
type Snippets<'a> = [(&'a Located, &'a [usize])];

/// A failure reading a value that may be shape text.
enum ValueError {
    Scene(SceneError),
    Shape(Diagnostic),
}

impl ValueError {
    fn into_scene(self, snippets: &Snippets, shape_error: &dyn Fn(&Snippets, Diagnostic) -> SceneError) -> SceneError {
        match self {
            ValueError::Scene(e) => e,
            ValueError::Shape(d) => shape_error(snippets, d),
        }
    }
}

/// A number, shape text (a `float`, or a `vec3` when `width` is 3), or for
/// width 3 an array of three such: each component as a tape of the inputs.
fn uniform_values<'a>(
    src: &Sources,
    lib: &Library,
    v: &'a Located,
    ctx: &str,
    width: usize,
    snippets: &mut Vec<(&'a Located, &'a [usize])>,
) -> std::result::Result<Vec<Shape>, ValueError> {
    let expected = if width == 1 {
        "a number, or shape text such as \"1.0 + 0.5*sin(t)\"".to_string()
    } else {
        "an array of 3 numbers (or shape text for any of them), or shape text giving a vec3".to_string()
    };
    let bad = |v: &Located| {
        ValueError::Scene(src.error(
            v.origin,
            format!("`{ctx}`: expected {expected}, found {}", describe(&v.item)),
            Some("expected a value"),
            &[],
        ))
    };
    let text_values = |loc: &'a Located, want: usize, snippets: &mut Vec<(&'a Located, &'a [usize])>| {
        let Item::Str(text, map) = &loc.item else {
            unreachable!()
        };
        let id = snippets.len();
        snippets.push((loc, map));
        let mut b = Builder::new();
        let (ty, comps) = lib.compile_uniform(&mut b, text, id).map_err(ValueError::Shape)?;
        if ty.width() != want {
            let want_ty = if want == 1 { "float" } else { "vec3" };
            return Err(ValueError::Scene(src.error(
                loc.origin,
                format!("`{ctx}`: the expression is a `{ty}`, expected a `{want_ty}`"),
                Some(&format!("expected a {want_ty}")),
                &[],
            )));
        }
        Ok(comps
            .into_iter()
            .map(|n| Shape::from_tape(b.tape(n)))
            .collect::<Vec<_>>())
    };
    match &v.item {
        Item::Num(x, _) if width == 1 && x.is_finite() => Ok(vec![constant_shape(*x)]),
        Item::Str(..) => text_values(v, width, snippets),
        Item::Array(items) if width > 1 && items.len() == width => {
            let mut out = Vec::new();
            for it in items {
                match &it.item {
                    Item::Num(x, _) if x.is_finite() => out.push(constant_shape(*x)),
                    Item::Str(..) => out.extend(text_values(it, 1, snippets)?),
                    _ => return Err(bad(it)),
                }
            }
            Ok(out)
        }
        _ => Err(bad(v)),
    }
}

/// The directory files named in the scene `scene_name` are relative to
/// (empty, the working directory, for a scene without one).
fn scene_dir(scene_name: &str) -> std::path::PathBuf {
    Path::new(scene_name)
        .parent()
        .filter(|p| p.is_dir())
        .map(Path::to_path_buf)
        .unwrap_or_default()
}

/// The shape text of `[surface.NAME] vm = "FILE"`: fidget's `.vm` tape
/// format read from FILE (relative to the scene file's directory) and
/// translated by [`isoray_shape::vm::vm_to_shape_text`]; errors name the
/// file, line and column.
fn vm_surface_text(src: &Sources, loc: &Located, file: &str, ctx: &str) -> Result<String> {
    let path = scene_dir(&src.path).join(file);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        src.error(
            loc.origin,
            format!("`{ctx}.vm`: cannot read `{}`: {e}", path.display()),
            Some("cannot read this file"),
            &["a `.vm` file is fidget's tape format, relative to the scene file".into()],
        )
    })?;
    isoray_shape::vm::vm_to_shape_text(&text).map_err(|e| {
        src.error(
            loc.origin,
            format!("`{ctx}.vm`: {}:{}:{}: {}", path.display(), e.line, e.column, e.message),
            Some("in this model"),
            &[],
        )
    })
}

/// `[environment]`: an equirectangular `image` or a `cube` of six faces,
/// with `rotation` (degrees about +y) and `intensity`. Paths are relative to
/// the scene file's directory.
pub(crate) fn environment(src: &Sources, v: &Located, scene_name: &str) -> Result<Environment> {
    let mut r = Reader::new(src, v, "environment")?;
    let base = scene_dir(scene_name);
    let read = |src: &Sources, loc: &Located, text: &str, key: &str| -> Result<RgbImage> {
        let path = base.join(text);
        crate::env::read_image(&path).map_err(|e| {
            src.error(
                loc.origin,
                format!("`environment.{key}`: cannot read `{}`: {e}", path.display()),
                Some("cannot read this image"),
                &["environment maps are .hdr, .exr or .png files, relative to the scene file".into()],
            )
        })
    };
    let image = r.string("image")?;
    let cube = r.get("cube");
    if let Some(gv) = r.get("gradient") {
        if let Some(other) = image.map(|x| x.1).or(cube) {
            return Err(src.error(
                other.origin,
                "`environment` has a `gradient` and an image: give one",
                Some("remove one of them"),
                &[],
            ));
        }
        let mut g = Reader::new(src, gv, "environment.gradient")?;
        let f = |c: Vec3| c.map(|x| x as f32);
        let map = EnvMap::Gradient {
            zenith: f(g.color("zenith", [0.35, 0.5, 0.8])?),
            horizon: f(g.color("horizon", [0.85, 0.88, 0.93])?),
            nadir: f(g.color("nadir", [0.3, 0.3, 0.32])?),
        };
        g.finish(&["zenith", "horizon", "nadir"])?;
        let keys = environment_keys();
        let rotation = r.num_key(spec(keys, "rotation"))?;
        let intensity = r.num_key(spec(keys, "intensity"))?;
        r.finish_keys(environment_keys())?;
        return Ok(Environment {
            map,
            rotation,
            intensity,
        });
    }
    let map = match (image, cube) {
        (Some((text, loc)), None) => EnvMap::Equirect(Arc::new(read(src, loc, text, "image")?)),
        (None, Some(cv)) => {
            let mut c = Reader::new(src, cv, "environment.cube")?;
            let mut faces = Vec::new();
            for key in ["px", "nx", "py", "ny", "pz", "nz"] {
                let Some((text, loc)) = c.string(key)? else {
                    return Err(src.error(
                        cv.origin,
                        format!("`environment.cube` needs `{key}`: the six faces px, nx, py, ny, pz, nz"),
                        Some(&format!("missing `{key}`")),
                        &[],
                    ));
                };
                let img = read(src, loc, text, &format!("cube.{key}"))?;
                if img.width != img.height || faces.first().is_some_and(|f: &RgbImage| f.width != img.width) {
                    return Err(src.error(
                        loc.origin,
                        format!(
                            "`environment.cube.{key}` is {}x{}: cube faces must be square and all the same size",
                            img.width, img.height
                        ),
                        Some("wrong size"),
                        &[],
                    ));
                }
                faces.push(img);
            }
            c.finish(&["px", "nx", "py", "ny", "pz", "nz"])?;
            let faces: [RgbImage; 6] = faces.try_into().expect("six faces");
            EnvMap::Cube(Arc::new(faces))
        }
        (Some(_), Some(cv)) => {
            return Err(src.error(
                cv.origin,
                "`environment` has both `image` and `cube`: give one",
                Some("remove one of them"),
                &[],
            ))
        }
        (None, None) => {
            return Err(src.error(
                v.origin,
                "`environment` needs an equirectangular `image`, a `cube` of six faces or a `gradient`",
                Some("add image = \"sky.hdr\" or gradient = {}"),
                &[],
            ))
        }
    };
    let keys = environment_keys();
    let rotation = r.num_key(spec(keys, "rotation"))?;
    let intensity = r.num_key(spec(keys, "intensity"))?;
    r.finish_keys(environment_keys())?;
    Ok(Environment {
        map,
        rotation,
        intensity,
    })
}

/// `fresnel = true | false` and `fresnel_model = "schlick" | "exact"`.
fn fresnel_setting(r: &mut Reader, keys: &[KeySpec]) -> Result<Fresnel> {
    let on = r.bool_key(spec(keys, "fresnel"))?;
    let model = match r.choice_key(spec(keys, "fresnel_model"))? {
        "exact" => Fresnel::Exact,
        _ => Fresnel::Schlick,
    };
    Ok(if on { model } else { Fresnel::Off })
}

/// The index of a named material, or an error at `loc` naming the defined ones.
pub(crate) fn material_index(
    src: &Sources,
    materials: &[Material],
    m: &str,
    loc: &Located,
    ctx: &str,
) -> Result<usize> {
    if let Some(k) = materials.iter().position(|x| x.name == m) {
        return Ok(k);
    }
    let names: Vec<&str> = materials.iter().map(|x| x.name.as_str()).collect();
    let mut notes = vec![format!("defined materials: {}", names.join(", "))];
    if let Some(s) = suggest(m, names.iter().copied()) {
        notes.insert(0, format!("did you mean \"{s}\"?"));
    }
    Err(src.error(
        loc.origin,
        format!("`{ctx}`: no material named \"{m}\""),
        Some("unknown material"),
        &notes,
    ))
}

/// `bound`, `lipschitz_factor` and `image_only` of a surface.
fn surface_options(r: &mut Reader) -> Result<SurfaceOptions> {
    let keys = surface_keys();
    let bound = match r.choice_key(spec(keys, "bound"))? {
        "taylor" => BoundMethod::Taylor,
        "lipschitz" => BoundMethod::Lipschitz,
        "first-order" => BoundMethod::FirstOrder,
        _ => BoundMethod::Auto,
    };
    let lipschitz_factor = r.num_key(spec(keys, "lipschitz_factor"))?;
    Ok(SurfaceOptions {
        bound,
        lipschitz_factor,
        image_only: r.peek_bool("image_only")?,
    })
}

/// The x, y, z strings of `parametric = { x = "...", y = "...", z = "..." }`.
fn parametric_coords<'a>(src: &'a Sources, v: &'a Located, ctx: &str) -> Result<Vec<(&'a str, &'a Located)>> {
    let mut r = Reader::new(src, v, &format!("{ctx}.parametric"))?;
    let mut out = Vec::new();
    for key in ["x", "y", "z"] {
        match r.string(key)? {
            Some(c) => out.push(c),
            None => {
                return Err(src.error(
                    v.origin,
                    format!("`{ctx}.parametric` needs `{key}`: the coordinates x, y and z as expressions in s and t"),
                    Some(&format!("missing `{key}`")),
                    &["for example parametric = { x = \"s\", y = \"t\", z = \"s^2 + t^2\" }".into()],
                ))
            }
        }
    }
    r.finish(&["x", "y", "z"])?;
    Ok(out)
}

/// `domain = { s = [min, max], t = [min, max] }` (each optional).
fn parametric_domain(r: &mut Reader, ctx: &str) -> Result<[[f64; 2]; 2]> {
    let mut domain = DEFAULT_DOMAIN;
    let Some(v) = r.get("domain") else {
        return Ok(domain);
    };
    let mut d = Reader::new(r.src, v, &format!("{ctx}.domain"))?;
    for (i, key) in ["s", "t"].iter().enumerate() {
        let Some(item) = d.get(key) else { continue };
        let range = match &item.item {
            Item::Array(xs) if xs.len() == 2 => match (&xs[0].item, &xs[1].item) {
                (Item::Num(a, _), Item::Num(b, _)) if a.is_finite() && b.is_finite() && a < b => Some([*a, *b]),
                _ => None,
            },
            _ => None,
        };
        match range {
            Some(rg) => domain[i] = rg,
            None => return Err(d.err(item, key, "[min, max] with min < max, like [-1.0, 1.0]")),
        }
    }
    d.finish(&["s", "t"])?;
    Ok(domain)
}

/// The names and key origins of a surface table's `params`.
fn r_params_origins(surface: &Located) -> Option<Vec<(String, Origin)>> {
    let Item::Table(entries) = &surface.item else {
        return None;
    };
    let params = entries.iter().rev().find(|e| e.key == "params")?;
    let Item::Table(pe) = &params.value.item else {
        return None;
    };
    Some(pe.iter().map(|p| (p.key.clone(), p.key_origin)).collect())
}

fn check_name(src: &Sources, name: &str, origin: Origin) -> Result<()> {
    let ok = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !ok || isoray_shape::syntax::KEYWORDS.contains(&name) || name == "p" {
        return Err(src.error(
            origin,
            format!("`{name}` cannot be used as a name in shape text"),
            Some("expected letters, digits and `_`, not a keyword or `p`"),
            &[],
        ));
    }
    Ok(())
}

/// A parameter: a value, or `{ default = value, range = [min, max] }` (the
/// range, for sliders, is recorded in `ranges` under `ctx`).
fn param_spec(src: &Sources, v: &Located, ctx: &str, ranges: &mut Vec<ParamRange>) -> Result<Value> {
    let Item::Table(_) = &v.item else {
        return param_value(src, v, ctx);
    };
    let mut r = Reader::new(src, v, ctx)?;
    let Some(dv) = r.get("default") else {
        return Err(src.error(
            v.origin,
            format!("`{ctx}` needs a `default` value"),
            Some("add default = ..."),
            &["for example { default = 1.0, range = [0.5, 2.0] }".into()],
        ));
    };
    let value = param_value(src, dv, &format!("{ctx}.default"))?;
    if let Some(rv) = r.get("range") {
        let range = match &rv.item {
            Item::Array(xs) if xs.len() == 2 => match (&xs[0].item, &xs[1].item) {
                (Item::Num(a, _), Item::Num(b, _)) if a.is_finite() && b.is_finite() && a < b => Some([*a, *b]),
                _ => None,
            },
            _ => None,
        };
        let Some(range) = range else {
            return Err(r.err(rv, "range", "[min, max] with min < max"));
        };
        let Value::Float(x) = value else {
            return Err(src.error(
                rv.origin,
                format!("`{ctx}.range` applies to number parameters only"),
                Some("the default is a vector"),
                &[],
            ));
        };
        if x < range[0] || x > range[1] {
            let key = match dv.origin {
                Origin::Override(_) => ctx.to_string(),
                _ => format!("{ctx}.default"),
            };
            return Err(src.error(
                dv.origin,
                format!("`{key}` = {x} is outside its range [{}, {}]", range[0], range[1]),
                Some("outside the range"),
                &[],
            ));
        }
        ranges.push(ParamRange {
            key: ctx.to_string(),
            range,
        });
    }
    r.finish(&["default", "range"])?;
    Ok(value)
}

fn param_value(src: &Sources, v: &Located, ctx: &str) -> Result<Value> {
    let bad = || {
        src.error(
            v.origin,
            format!(
                "`{ctx}`: expected a number or an array of 2 or 3 numbers, found {}",
                describe(&v.item)
            ),
            Some("expected a number or vector"),
            &[],
        )
    };
    match &v.item {
        Item::Num(x, _) if x.is_finite() => Ok(Value::Float(*x)),
        Item::Array(items) => {
            let mut xs = Vec::new();
            for it in items {
                match it.item {
                    Item::Num(x, _) if x.is_finite() => xs.push(x),
                    _ => return Err(bad()),
                }
            }
            match xs[..] {
                [x, y] => Ok(Value::Vec2([x, y])),
                [x, y, z] => Ok(Value::Vec3([x, y, z])),
                _ => Err(bad()),
            }
        }
        _ => Err(bad()),
    }
}

use crate::model::{cross3 as cross, norm3 as norm, unit as normalize};
