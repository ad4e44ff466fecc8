//! A scene as the GPU tracer reads it: the generated WGSL of its objects
//! (the only part that depends on the shapes' structure) and the buffers
//! of everything else, laid out as `render.wgsl` declares them.

use std::sync::Arc;

use isoray_dent::normalmap::sobel_normal;
use isoray_dent::uv::UvMapping;
use isoray_dent::{DentMaps, Wrap};
use isoray_scene::analytic::Analytic;
use isoray_scene::env::{EnvMap, RgbImage};
use isoray_scene::DentMode;
use isoray_scene::{
    AaPattern, AoTarget, AoWeights, LightKind, March, NormalMethod, Projection, Scene, ShadowMode, ShadowTarget,
    StepLimit, View,
};
use isoray_shade::MaterialSample;
use isoray_shape::wgsl::{
    emit_tape, emit_tape_dual, encode_tape, interpreter, WgslFunction, MAX_INTERPRETED_SLOTS, PRELUDE,
};

/// Words of `Settings` in `render.wgsl`.
pub(crate) const SETTINGS_WORDS: usize = 76;
/// Words of one `Light`.
const LIGHT_WORDS: usize = 20;
/// Words of one `Mat`.
const MAT_WORDS: usize = 28;
/// Words of one `Obj`.
const OBJ_WORDS: usize = 12;
/// Words per pixel of the output: colour, then depth, normal and albedo.
pub(crate) const RECORD_AOVS: u32 = 10;
/// Words per pixel of the output without AOVs: the colour.
pub(crate) const RECORD_COLOUR: u32 = 3;

/// The tracer's source: the generated objects, then `render.wgsl`.
pub(crate) const TRACER: &str = include_str!("render.wgsl");

/// How the GPU evaluates the objects' distances.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    /// Each object's tape written as WGSL functions: the fastest frames,
    /// but a new pipeline (compiled by the driver) for every structural edit.
    Compiled,
    /// One fixed shader that interprets the objects' tapes from a buffer:
    /// a structural edit is a new buffer, never a new pipeline.
    Interpreted,
}

impl Kernel {
    /// The kernel named `compiled` or `interpreted` (None for any other name).
    pub fn from_name(name: &str) -> Option<Kernel> {
        [Kernel::Compiled, Kernel::Interpreted]
            .into_iter()
            .find(|k| k.name() == name)
    }

    /// `compiled` or `interpreted`.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Compiled => "compiled",
            Kernel::Interpreted => "interpreted",
        }
    }
}

impl Kernel {
    /// The kernel the renderer uses by default: compiled. Its frames are
    /// faster and its compile per structural edit is 2–14 s on lavapipe
    /// (well under a second on a real GPU); the interpreted kernel needs
    /// no compile per edit, but on lavapipe it draws the example scenes
    /// with the largest tapes wrongly (see docs/BENCHMARKS.md, "GPU
    /// renderer"), so it is chosen only by name.
    pub fn choose(_scene: &Scene) -> Kernel {
        Kernel::Compiled
    }
}

/// Where one object's inputs and program live.
#[derive(Debug, Clone)]
struct ObjectCode {
    /// Its tape's slots whose prologue values go to the input buffer.
    uniform_slots: Vec<u32>,
    /// First word of its program in the code buffer, instructions, result slot.
    program: (u32, u32, u32),
}

/// A scene's shader module and its per-structure buffers: the generated
/// functions (compiled kernel) or the programs (interpreted kernel).
#[derive(Debug, Clone)]
pub struct SceneCode {
    /// The kernel.
    pub kernel: Kernel,
    /// The whole WGSL module (prelude, objects, tracer); the same for
    /// every scene with the interpreted kernel.
    pub source: String,
    objects: Vec<ObjectCode>,
    /// The interpreted kernel's programs, all objects.
    pub(crate) code: Vec<u32>,
}

impl SceneCode {
    /// Writes the module for the scene's objects as they are now. With the
    /// interpreted kernel, a tape with too many slots is an error.
    pub fn new(scene: &Scene, kernel: Kernel) -> Result<SceneCode, String> {
        let mut source = String::from(PRELUDE);
        source.push_str("@group(0) @binding(0) var<storage, read> iso_in: array<f32>;\n");
        let mut objects = Vec::new();
        let mut code = Vec::new();
        let mut base = 0u32;
        match kernel {
            Kernel::Compiled => {
                let mut value_cases = String::new();
                let mut dual_cases = String::new();
                for (i, o) in scene.objects.iter().enumerate() {
                    let tape = o.shape.tape();
                    let f = emit_tape(tape, &format!("iso_o{i}"), "iso_in", base);
                    let g = emit_tape_dual(tape, &format!("iso_g{i}"), "iso_in", base);
                    source.push_str(&f.code);
                    source.push_str(&g.code);
                    value_cases.push_str(&format!("        case {i}u: {{ return iso_o{i}(p); }}\n"));
                    dual_cases.push_str(&format!("        case {i}u: {{ return iso_g{i}(p); }}\n"));
                    base += f.uniform_slots.len() as u32;
                    objects.push(ObjectCode {
                        uniform_slots: f.uniform_slots,
                        program: (0, 0, 0),
                    });
                }
                source.push_str(&format!(
                    "fn iso_object(i: u32, p: vec3<f32>) -> f32 {{\n    switch i {{\n{value_cases}        \
                     default: {{ return 1e9; }}\n    }}\n}}\n\
                     fn iso_object_dual(i: u32, p: vec3<f32>) -> vec4<f32> {{\n    switch i {{\n{dual_cases}        \
                     default: {{ return vec4<f32>(1e9, 0.0, 0.0, 0.0); }}\n    }}\n}}\n"
                ));
            }
            Kernel::Interpreted => {
                for (i, o) in scene.objects.iter().enumerate() {
                    let p = encode_tape(o.shape.tape(), base).ok_or_else(|| {
                        format!(
                            "object {i}'s distance needs {} registers; the interpreting GPU kernel has {MAX_INTERPRETED_SLOTS}",
                            o.shape.tape().slots()
                        )
                    })?;
                    base += p.uniform_slots.len() as u32;
                    objects.push(ObjectCode {
                        uniform_slots: p.uniform_slots.clone(),
                        program: (code.len() as u32, p.len() as u32, p.output),
                    });
                    code.extend(&p.code);
                }
                source.push_str(&interpreter("iso_code", "iso_in"));
                source.push_str(
                    "fn iso_object(i: u32, p: vec3<f32>) -> f32 {\n    let o = objs[i];\n    \
                     return iso_run(o.code_start, o.code_len, o.out_slot, p);\n}\n\
                     fn iso_object_dual(i: u32, p: vec3<f32>) -> vec4<f32> {\n    let o = objs[i];\n    \
                     return iso_run_dual(o.code_start, o.code_len, o.out_slot, p);\n}\n",
                );
            }
        }
        if code.is_empty() {
            code.extend([0; 4]); // a storage buffer may not be empty
        }
        source.push_str(TRACER);
        Ok(SceneCode {
            kernel,
            source,
            objects,
            code,
        })
    }

    /// The input buffer at the scene's current inputs: each object's
    /// prologue values, in object order.
    pub fn inputs(&self, scene: &Scene) -> Vec<f32> {
        let mut out = Vec::new();
        for (c, o) in self.objects.iter().zip(&scene.objects) {
            let f = WgslFunction {
                code: String::new(),
                uniform_slots: c.uniform_slots.clone(),
            };
            out.extend(f.fill(o.shape.tape(), &scene.inputs));
        }
        if out.is_empty() {
            out.push(0.0);
        }
        out
    }

    /// The `Obj` array: material, closed form and program of each object.
    /// `dents[i]`: object i's header in the dent buffer ([`dents`]), or `NO_DENT`.
    pub(crate) fn objects(&self, scene: &Scene, dents: &[u32]) -> Words {
        let mut out = Words::default();
        for (((o, a), c), &dent) in scene
            .objects
            .iter()
            .zip(&scene.derived().analytic)
            .zip(&self.objects)
            .zip(dents)
        {
            let (kind, v) = match a {
                None => (0, [0.0f32; 4]),
                Some(Analytic::Plane { n, h }) => (1, [n[0] as f32, n[1] as f32, n[2] as f32, *h as f32]),
                Some(Analytic::Sphere { c, r }) => (2, [c[0] as f32, c[1] as f32, c[2] as f32, (r * r) as f32]),
            };
            let (start, len, slot) = c.program;
            out.u(o.material as u32).u(kind).u(start).u(len);
            out.u(slot).u(dent).u(0).u(0);
            for x in v {
                out.f(x);
            }
        }
        if scene.objects.is_empty() {
            out.0.resize(OBJ_WORDS, 0);
        }
        debug_assert_eq!(out.0.len() % OBJ_WORDS, 0);
        out
    }
}

/// Little-endian words for a storage buffer.
#[derive(Debug, Default)]
pub(crate) struct Words(pub(crate) Vec<u32>);

impl Words {
    fn f(&mut self, x: f32) -> &mut Self {
        self.0.push(x.to_bits());
        self
    }
    fn u(&mut self, x: u32) -> &mut Self {
        self.0.push(x);
        self
    }
    fn v3(&mut self, v: [f32; 3]) -> &mut Self {
        self.f(v[0]).f(v[1]).f(v[2])
    }
    fn d3(&mut self, v: [f64; 3]) -> &mut Self {
        self.v3(v.map(|x| x as f32))
    }
    pub(crate) fn bytes(&self) -> Vec<u8> {
        Words::bytes_of(&self.0)
    }
    /// Words as little-endian bytes.
    pub(crate) fn bytes_of(words: &[u32]) -> Vec<u8> {
        words.iter().flat_map(|w| w.to_le_bytes()).collect()
    }
}

/// Where a dispatch writes: the region of the image it covers.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Band {
    pub(crate) x0: u32,
    pub(crate) y0: u32,
    pub(crate) width: u32,
    pub(crate) height: u32,
}

/// The scratch each sample's lane needs (binding 9, in vec4s of 16 bytes):
/// its ray stack and its interpreter registers, at least one vec4 (where
/// the lane leaves its colour for the resolve pass); and the lanes per
/// pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Scratch {
    /// Ray-stack entries (6 vec4s each): at most one waiting ray per
    /// bounce plus one when some material reflects or refracts; none when
    /// no ray ever bounces.
    pub(crate) stack_cap: u32,
    /// Registers of the interpreting kernel (the most slots of any
    /// object's tape); none for the compiled kernel.
    pub(crate) reg_slots: u32,
    /// Lanes per pixel: its aa × aa samples, and its centre ray with AOVs.
    pub(crate) lanes: u32,
}

impl Scratch {
    /// What the scene needs with `kernel` (and the AOVs or not).
    pub(crate) fn of(scene: &Scene, kernel: Kernel, aovs: bool) -> Scratch {
        let optical = scene.materials.iter().any(|m| {
            let s = MaterialSample::from(m);
            s.transparency > 0.0 || s.reflectivity.max_element() > 0.0
        });
        let stack_cap = if optical && scene.render.max_depth > 0 {
            scene.render.max_depth + 1
        } else {
            0
        };
        let reg_slots = match kernel {
            Kernel::Compiled => 0,
            Kernel::Interpreted => scene.objects.iter().map(|o| o.shape.tape().slots()).max().unwrap_or(0) as u32,
        };
        let lanes = scene.render.aa * scene.render.aa + aovs as u32;
        Scratch {
            stack_cap,
            reg_slots,
            lanes,
        }
    }

    /// Bytes per lane (as the shader's `lane_words`).
    pub(crate) fn bytes_per_lane(self) -> u64 {
        16 * (6 * self.stack_cap as u64 + self.reg_slots as u64).max(1)
    }

    /// Bytes per pixel (all its lanes).
    pub(crate) fn bytes_per_pixel(self) -> u64 {
        self.lanes as u64 * self.bytes_per_lane()
    }
}

/// The `Settings` buffer for one band of the image; `raster` is the row
/// stride (words) of the meshes' raster prepass ids when the primary rays
/// read them (see `raster`).
pub(crate) fn settings(scene: &Scene, band: Band, aovs: bool, scratch: Scratch, raster: Option<u32>) -> Words {
    let record = if aovs { RECORD_AOVS } else { RECORD_COLOUR };
    let r = &scene.render;
    let c = &scene.camera;
    let (w, h) = (r.width, r.height);
    let [fwd, right, up] = c.basis();
    let normals = match r.normals {
        NormalMethod::Central => 0,
        NormalMethod::Forward => 1,
        NormalMethod::Tetrahedron => 2,
        NormalMethod::Analytic => 3,
    };
    let shadows = match r.shadows {
        ShadowMode::None => 0,
        ShadowMode::Hard => 1,
        ShadowMode::Soft => 2,
        ShadowMode::Improved => 3,
        ShadowMode::Aaltonen => 4,
    };
    let view = match r.view {
        View::Shaded => 0,
        View::Steps => 1,
        View::Normals => 2,
        View::Uv => 3,
        View::Mask => 4,
        View::Gradient => 5,
    };
    let n_clear = scene
        .objects
        .iter()
        .filter(|o| scene.materials[o.material].transparency > 0.0)
        .count() as u32;
    let (env_kind, env_cos, env_sin, env_k) = match &scene.environment {
        None => (0, 1.0, 0.0, 1.0),
        Some(e) => {
            let (s, c) = (-(e.rotation as f32).to_radians()).sin_cos();
            let kind = match e.map {
                EnvMap::Equirect(_) => 1,
                EnvMap::Cube(_) => 2,
                EnvMap::Gradient { .. } => 3,
            };
            (kind, c, s, e.intensity as f32)
        }
    };
    let blend = r.blend as f32;
    let mut out = Words::default();
    out.u(w).u(h).u(band.x0).u(band.y0);
    out.u(band.width).u(band.height).u(r.aa).u(r.max_steps);
    out.f(r.hit_epsilon as f32)
        .u(r.relative_epsilon as u32)
        .f(r.max_distance as f32)
        .f(r.step_scale as f32);
    out.u(normals)
        .f(r.normal_epsilon as f32)
        .f((1.0 / r.normal_epsilon) as f32)
        .u(shadows);
    out.f(r.shadow_exponent as f32)
        .f(r.shadow_start as f32)
        .f(r.shadow_max_distance as f32)
        .u(r.shadow_max_steps);
    out.u(r.ao as u32)
        .u(r.ao_samples)
        .f(r.ao_step as f32)
        .f(r.ao_intensity as f32);
    let quarter = if r.blend > 0.0 { (0.25 / r.blend) as f32 } else { 0.0 };
    out.f(blend).f(quarter).f(blend * r.material_blend as f32).u(view);
    out.u(r.max_depth)
        .f(r.min_weight as f32)
        .u(scene.lights.len() as u32)
        .u(scene.objects.len() as u32);
    out.d3(r.background).u(aovs as u32);
    out.d3(c.position).u((c.projection == Projection::Equirect) as u32);
    out.d3(fwd).f(c.tan_half_fov() as f32);
    out.d3(right).f((w as f64 / h as f64) as f32);
    out.d3(up).u(n_clear);
    out.u(env_kind).f(env_cos).f(env_sin).f(env_k);
    let any_analytic = scene.derived().analytic.iter().any(Option::is_some);
    out.u(any_analytic as u32)
        .u(record)
        .u(scratch.stack_cap)
        .u(scratch.reg_slots);
    out.u((r.on_step_limit == StepLimit::Miss) as u32)
        .f(r.shadow_floor as f32)
        .u((r.shadow_applies_to == ShadowTarget::All) as u32)
        .u((r.ao_weights == AoWeights::Uniform) as u32);
    out.u((r.ao_applies_to == AoTarget::All) as u32).d3(r.ambient);
    let aa_pattern = match r.aa_pattern {
        AaPattern::Grid => 0,
        AaPattern::Rotated => 1,
        AaPattern::Jittered => 2,
    };
    out.u((r.march == March::Fixed) as u32)
        .f(r.fixed_step as f32)
        .u(aa_pattern)
        .f(r.shadow_epsilon as f32);
    let parallax = match r.parallax {
        isoray_scene::Parallax::None => 0,
        isoray_scene::Parallax::Offset => 1,
        isoray_scene::Parallax::Steep => 2,
        isoray_scene::Parallax::Occlusion => 3,
    };
    out.u(raster.is_some() as u32)
        .u(raster.unwrap_or(0))
        .u(parallax)
        .u(r.parallax_steps);
    debug_assert_eq!(out.0.len(), SETTINGS_WORDS);
    out
}

/// The `Light` array (one dummy entry when there are none).
pub(crate) fn lights(scene: &Scene) -> Words {
    let mut out = Words::default();
    for l in &scene.lights {
        let (kind, pos, radius, u, v) = match l.kind {
            LightKind::Directional { direction } => (0, direction, 0.0, [0.0; 3], [0.0; 3]),
            LightKind::Point { position } => (1, position, 0.0, [0.0; 3], [0.0; 3]),
            LightKind::Sphere { position, radius } => (2, position, radius, [0.0; 3], [0.0; 3]),
            LightKind::Rect { position, u, v } => (3, position, 0.0, u, v),
        };
        out.u(kind).u(l.samples).f(l.size as f32).f(l.intensity as f32);
        out.d3(l.color).f(l.attenuation[0] as f32);
        out.f(l.attenuation[1] as f32).f(l.attenuation[2] as f32);
        out.d3(pos).f(radius as f32).d3(u).d3(v);
    }
    if scene.lights.is_empty() {
        out.0.resize(LIGHT_WORDS, 0);
    }
    debug_assert_eq!(out.0.len() % LIGHT_WORDS, 0);
    out
}

/// The `Mat` array, as isoray-shade rounds each material to f32.
pub(crate) fn materials(scene: &Scene) -> Words {
    let mut out = Words::default();
    for m in &scene.materials {
        let s = MaterialSample::from(m);
        let model = match s.model {
            isoray_scene::ShadingModel::Phong => 0,
            isoray_scene::ShadingModel::BlinnPhong => 1,
        };
        let spec = match s.specular_function {
            isoray_scene::SpecularFunction::Pow => 0,
            isoray_scene::SpecularFunction::Schlick => 1,
        };
        let fresnel = match s.fresnel {
            isoray_scene::Fresnel::Off => 0,
            isoray_scene::Fresnel::Schlick => 1,
            isoray_scene::Fresnel::Exact => 2,
        };
        let (other, size) = m.checker.map_or((u32::MAX, 1.0), |(o, sz)| (o as u32, sz as f32));
        out.v3(s.ambient.to_array()).f(s.shininess);
        out.v3(s.diffuse.to_array()).f(s.transparency);
        out.v3(s.specular.to_array()).f(s.ior);
        out.v3(s.emission.to_array()).u(model);
        out.v3(s.reflectivity.to_array()).u(spec);
        out.v3(s.absorption.to_array()).u(fresnel);
        out.u(other).f(size).u(s.specular_fresnel as u32).u(0);
    }
    if scene.materials.is_empty() {
        out.0.resize(MAT_WORDS, 0);
    }
    debug_assert_eq!(out.0.len() % MAT_WORDS, 0);
    out
}

/// The environment buffer: for images, a header of (width, height,
/// offset) per face (u32 bits) and the texels (RGB); for a gradient, its
/// zenith, horizon and nadir colours; one word when there is none.
pub(crate) fn environment(scene: &Scene) -> Words {
    let mut out = Words::default();
    let faces: Vec<&RgbImage> = match scene.environment.as_ref().map(|e| &e.map) {
        None => return Words(vec![0]), // a storage buffer may not be empty
        Some(EnvMap::Equirect(img)) => vec![img.as_ref()],
        Some(EnvMap::Cube(faces)) => faces.iter().collect(),
        Some(EnvMap::Gradient { zenith, horizon, nadir }) => {
            out.v3(*zenith).v3(*horizon).v3(*nadir);
            return out;
        }
    };
    let mut offset = 18usize;
    for img in &faces {
        out.u(img.width).u(img.height).u(offset as u32);
        offset += img.pixels.len() * 3;
    }
    out.0.resize(18, 0);
    for img in &faces {
        for p in &img.pixels {
            out.v3(*p);
        }
    }
    out
}

/// Words of one mesh's record in [`meshes`].
const MESH_RECORD: usize = 16;
/// No vertex normals (a mesh record's normal base).
const NO_NORMALS: u32 = u32::MAX;

/// The scene's meshes as `render.wgsl`'s `mesh_data` reads them: the
/// number of meshes; one 16-word record each (rotation quaternion x, y, z,
/// w; translation; scale; node base, node count, triangle base, normal
/// base or `u32::MAX`, material, triangle count, 2 unused); then each mesh's nodes (8
/// words: box min, escape index, box max, first triangle << 4 | count,
/// count 0 for an interior node), triangles (9 floats, in leaf order) and
/// vertex normals (9 floats a triangle, when the mesh has them). Bases are
/// word offsets; a node's escape index is the node to visit after its
/// subtree (the node count at the end), so the shader walks the tree
/// without a stack.
pub(crate) fn meshes(scene: &Scene) -> Words {
    let mut out = Words::default();
    out.u(scene.meshes.len() as u32);
    let header = out.0.len();
    out.0.resize(header + MESH_RECORD * scene.meshes.len(), 0);
    for (k, m) in scene.meshes.iter().enumerate() {
        let bvh = m.bvh();
        let nodes = bvh.nodes();
        // Escape indices: a left child escapes to its sibling, a right
        // child to its parent's escape.
        let mut escape = vec![nodes.len() as u32; nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            if n.count == 0 {
                escape[i + 1] = n.index;
                escape[n.index as usize] = escape[i];
            }
        }
        let node_base = out.0.len() as u32;
        for (n, esc) in nodes.iter().zip(&escape) {
            let packed = if n.count == 0 { 0 } else { (n.index << 4) | n.count };
            out.v3(n.min).u(*esc).v3(n.max).u(packed);
        }
        let tri_base = out.0.len() as u32;
        for t in bvh.triangles() {
            for c in t {
                out.v3(*c);
            }
        }
        let mesh = m.mesh();
        let normal_base = if mesh.normals.is_empty() {
            NO_NORMALS
        } else {
            let base = out.0.len() as u32;
            for &i in bvh.order() {
                for v in mesh.triangles[i as usize] {
                    out.v3(mesh.normals[v as usize]);
                }
            }
            base
        };
        let (q, shift, scale) = m.placement();
        let r = header + MESH_RECORD * k;
        let words = [
            q[0].to_bits(),
            q[1].to_bits(),
            q[2].to_bits(),
            q[3].to_bits(),
            shift[0].to_bits(),
            shift[1].to_bits(),
            shift[2].to_bits(),
            scale.to_bits(),
            node_base,
            nodes.len() as u32,
            tri_base,
            normal_base,
            m.material as u32,
            bvh.triangles().len() as u32,
            0,
            0,
        ];
        out.0[r..r + MESH_RECORD].copy_from_slice(&words);
    }
    out
}

/// An object without dent maps in the `Obj` array.
pub(crate) const NO_DENT: u32 = u32::MAX;

/// Words of a dented object's header in the dent buffer: mapping kind
/// (1 planar, 2 spherical), axis, width, height, whether columns clamp,
/// the offset of its texel normals, of its texel depths, and the map's
/// range; the planar picture's min u, v and max u, v;
/// the placement's position and scale, and the columns of its rotation.
pub(crate) const DENT_HEADER: usize = 28;

/// The texel normals of a dent map, kept across frames while the map is
/// the same (the scene holds it in an `Arc`).
#[derive(Debug, Default)]
pub(crate) struct DentCache(Vec<(Arc<DentMaps>, Arc<Vec<u32>>)>);

/// A map's texels for the GPU: the normals ([`texel_normals`]), then each
/// texel's depth below the untouched surface (f32, scene units, ≥ 0).
fn texel_words(maps: &DentMaps) -> Vec<u32> {
    let (w, h) = (maps.height.width(), maps.height.height());
    let mut out = texel_normals(maps);
    for y in 0..h {
        for x in 0..w {
            out.push(((-maps.height.displacement(x, y)).max(0.0) as f32).to_bits());
        }
    }
    out
}

/// Each texel's Sobel normal (isoray-dent's, in full precision) as a
/// `pack2x16snorm` of its x and y; z = sqrt(1 − x² − y²) ≥ 0.
fn texel_normals(maps: &DentMaps) -> Vec<u32> {
    let (w, h) = (maps.height.width(), maps.height.height());
    let snorm = |x: f64| ((x.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let (n, _) = sobel_normal(maps.height.texels(), w, h, x, y, &maps.options);
            out.push(snorm(n[0]) | (snorm(n[1]) << 16));
        }
    }
    out
}

/// The dent buffer: a header per object drawn with dent maps (`dents =
/// "bump"` or `"auto"` with maps), then their texel normals; and each
/// object's header offset (or `NO_DENT`). The normals come from `cache`
/// where the map is unchanged; the cache keeps this frame's maps only.
pub(crate) fn dents(scene: &Scene, cache: &mut DentCache) -> (Words, Vec<u32>) {
    let dented: Vec<(usize, &Arc<DentMaps>)> = scene
        .objects
        .iter()
        .enumerate()
        .filter(|(_, o)| matches!(o.physics.dents, DentMode::Bump | DentMode::Auto))
        .filter_map(|(i, o)| o.physics.maps.as_ref().map(|m| (i, m)))
        // Parametric mappings are inverted on the CPU only: drawn undented here.
        .filter(|(_, m)| !matches!(m.mapping, UvMapping::Parametric(_)))
        .collect();
    let mut offsets = vec![NO_DENT; scene.objects.len()];
    let mut out = Words::default();
    let mut next = (dented.len() * DENT_HEADER) as u32;
    let mut texels: Vec<Arc<Vec<u32>>> = Vec::new();
    let mut kept = DentCache::default();
    for (i, maps) in &dented {
        let words = match cache.0.iter().find(|(m, _)| Arc::ptr_eq(m, maps)) {
            Some((_, w)) => w.clone(),
            None => Arc::new(texel_words(maps)),
        };
        kept.0.push(((*maps).clone(), words.clone()));
        offsets[*i] = out.0.len() as u32;
        let (kind, axis, min, max) = match maps.mapping {
            UvMapping::Planar { axis, min, max, .. } => (1, axis as u32, min, max),
            UvMapping::Spherical { .. } => (2, 0, [0.0; 2], [1.0; 2]),
            UvMapping::Parametric(_) => unreachable!("left out above"),
        };
        let clamp_cols = maps.options.wrap == Wrap::Clamp;
        out.u(kind).u(axis).u(maps.height.width()).u(maps.height.height());
        let count = maps.height.width() * maps.height.height();
        out.u(clamp_cols as u32)
            .u(next)
            .u(next + count)
            .f(maps.height.range as f32);
        out.f(min[0] as f32).f(min[1] as f32).f(max[0] as f32).f(max[1] as f32);
        let place = scene.placement(*i);
        out.d3(place.position).f(place.scale as f32);
        for k in 0..3 {
            let mut e = [0.0; 3];
            e[k] = 1.0;
            out.d3(place.dir_to_world(e));
        }
        out.u(0).u(0).u(0);
        debug_assert_eq!(out.0.len() % DENT_HEADER, 0);
        next += words.len() as u32;
        texels.push(words);
    }
    for t in texels {
        out.0.extend_from_slice(&t);
    }
    if out.0.is_empty() {
        out.0.push(0);
    }
    *cache = kept;
    (out, offsets)
}
