//! A scene as the GPU tracer reads it: the generated WGSL of its objects
//! (the only part that depends on the shapes' structure) and the buffers
//! of everything else, laid out as `kernel/layout.wgsl` declares them.

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

use crate::layout::{Light, Mat, Obj, Settings};
use isoray_shape::wgsl::{
    emit_tape, emit_tape_dual, encode_tape, input_slots, interpreter, InputBuffer, WgslFunction, MAX_INTERPRETED_SLOTS,
    PRELUDE,
};

/// Words per pixel of the output: colour, then depth, normal and albedo.
pub(crate) const RECORD_AOVS: u32 = 10;
/// Words per pixel of the output without AOVs: the colour.
pub(crate) const RECORD_COLOUR: u32 = 3;

/// The tracer's source, after the generated objects: `kernel/*.wgsl`
/// joined (see `kernel/layout.wgsl` for what each file mirrors).
pub(crate) const TRACER: &str = concat!(
    include_str!("kernel/layout.wgsl"),
    include_str!("kernel/fold.wgsl"),
    include_str!("kernel/tracer.wgsl"),
    include_str!("kernel/meshes.wgsl"),
    include_str!("kernel/dents.wgsl"),
    include_str!("kernel/optics.wgsl"),
    include_str!("kernel/shade.wgsl"),
    include_str!("kernel/environment.wgsl"),
    include_str!("kernel/whitted.wgsl"),
    include_str!("kernel/pixels.wgsl"),
);

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

/// What of the tracer a scene can reach, written into its module as
/// constants so that the driver compiles the rest out: on a software
/// adapter (lavapipe) every branch some lane takes runs for all lanes, so
/// code that no pixel needs still costs every pixel its time, and every
/// line costs compile time. Each is a property of the scene's structure or
/// of its materials; a change of one builds a new pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Features {
    /// Triangle meshes (`[[mesh]]`).
    pub meshes: bool,
    /// Objects drawn with dent maps (the GPU's planar and spherical ones).
    pub dents: bool,
    /// A material that reflects or refracts.
    pub optics: bool,
    /// A transparent object (shadow rays pass through it).
    pub clear: bool,
    /// Normals by dual numbers: `render.normals = "analytic"`, or rays
    /// inside transparent objects (whose unsigned field has them). Without
    /// it the objects' dual-number functions are not written at all (they
    /// are most of a module's size, and of its compile time).
    pub dual: bool,
    /// The lights, materials and objects as uniform arrays of these many
    /// elements (a power of two at least their count), or None where they
    /// do not fit one (64 KiB) and are storage arrays.
    pub tables: [Option<u32>; 3],
}

/// The largest uniform buffer the tracer binds (WebGPU's default limit,
/// which isoray's device asks for).
pub const UNIFORM_BYTES: usize = 65536;

/// The tracer's tables read in its loops: lights, materials, objects
/// (bindings 2, 3 and 4), each its WGSL struct and element size.
const TABLES: [(&str, &str, usize); 3] = [
    ("lights", "Light", std::mem::size_of::<Light>()),
    ("mats", "Mat", std::mem::size_of::<Mat>()),
    ("objs", "Obj", std::mem::size_of::<Obj>()),
];

/// The uniform array length for `count` elements of `size` bytes: a power
/// of two at least `count` (so that a few more need no new pipeline), or
/// None past [`UNIFORM_BYTES`].
fn uniform_length(count: usize, size: usize) -> Option<u32> {
    let n = count.max(4).next_power_of_two();
    (n * size <= UNIFORM_BYTES).then_some(n as u32)
}

impl Features {
    /// The scene's.
    pub fn of(scene: &Scene) -> Features {
        let clear = scene
            .objects
            .iter()
            .any(|o| scene.materials[o.material].transparency > 0.0);
        Features {
            meshes: !scene.meshes.is_empty(),
            dents: scene.objects.iter().any(|o| {
                matches!(o.physics.dents, DentMode::Bump | DentMode::Auto)
                    && o.physics
                        .maps
                        .as_ref()
                        .is_some_and(|m| !matches!(m.mapping, UvMapping::Parametric(_)))
            }),
            optics: scene.materials.iter().any(|m| MaterialSample::from(m).is_optical()),
            clear,
            dual: clear || scene.render.normals == NormalMethod::Analytic,
            tables: {
                let counts = [scene.lights.len(), scene.materials.len(), scene.objects.len()];
                std::array::from_fn(|k| uniform_length(counts[k], TABLES[k].2))
            },
        }
    }

    /// The declarations of the lights, materials and objects (bindings 2
    /// to 4): uniform arrays where they fit, which lavapipe reads with one
    /// load where a storage read in divergent code is a loop over the lanes.
    fn table_declarations(self) -> String {
        let mut out = String::new();
        for (k, ((name, ty, _), len)) in TABLES.iter().zip(self.tables).enumerate() {
            let binding = 2 + k;
            out.push_str(&match len {
                Some(n) => format!("@group(0) @binding({binding}) var<uniform> {name}: array<{ty}, {n}>;\n"),
                None => format!("@group(0) @binding({binding}) var<storage, read> {name}: array<{ty}>;\n"),
            });
        }
        out
    }

    /// The constants of the tracer (`kernel/*.wgsl`).
    fn wgsl(self) -> String {
        format!(
            "const HAS_MESHES: bool = {};\nconst HAS_DENTS: bool = {};\nconst HAS_OPTICS: bool = {};\n\
             const HAS_CLEAR: bool = {};\nconst HAS_DUAL: bool = {};\n",
            self.meshes, self.dents, self.optics, self.clear, self.dual
        )
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
    /// What of the tracer it compiles in.
    pub features: Features,
    /// The whole WGSL module (prelude, objects, tracer); the same for
    /// every scene with the interpreted kernel.
    pub source: String,
    objects: Vec<ObjectCode>,
    /// The interpreted kernel's programs, all objects.
    pub(crate) code: Vec<u32>,
    /// The length of the inputs' uniform array (vec4s), or None where
    /// they are a storage array.
    input_vec4s: Option<u32>,
}

impl SceneCode {
    /// Writes the module for the scene's objects as they are now. With the
    /// interpreted kernel, a tape with too many slots is an error.
    pub fn new(scene: &Scene, kernel: Kernel) -> Result<SceneCode, String> {
        let features = Features::of(scene);
        let mut source = String::from(PRELUDE);
        source.push_str(&features.wgsl());
        source.push_str(&features.table_declarations());
        // The compiled kernel's inputs in a uniform buffer where they fit
        // (the interpreter reads them at run-time indices, from storage).
        let n_inputs: usize = scene.objects.iter().map(|o| input_slots(o.shape.tape()).len()).sum();
        let input_vec4s =
            (kernel == Kernel::Compiled && n_inputs * 4 <= UNIFORM_BYTES).then_some(n_inputs.div_ceil(4).max(1) as u32);
        let inputs = match input_vec4s {
            Some(n) => {
                source.push_str(&format!(
                    "@group(0) @binding(0) var<uniform> iso_in: array<vec4<f32>, {n}>;\n"
                ));
                InputBuffer::Vec4s("iso_in")
            }
            None => {
                source.push_str("@group(0) @binding(0) var<storage, read> iso_in: array<f32>;\n");
                InputBuffer::Floats("iso_in")
            }
        };
        let mut objects = Vec::new();
        let mut code = Vec::new();
        let mut base = 0u32;
        match kernel {
            Kernel::Compiled => {
                let mut value_cases = String::new();
                let mut dual_cases = String::new();
                for (i, o) in scene.objects.iter().enumerate() {
                    let tape = o.shape.tape();
                    let f = emit_tape(tape, &format!("iso_o{i}"), inputs, base);
                    source.push_str(&f.code);
                    value_cases.push_str(&format!("        case {i}u: {{ return iso_o{i}(p); }}\n"));
                    if features.dual {
                        let g = emit_tape_dual(tape, &format!("iso_g{i}"), inputs, base);
                        source.push_str(&g.code);
                        dual_cases.push_str(&format!("        case {i}u: {{ return iso_g{i}(p); }}\n"));
                    }
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
                source.push_str(&all_objects(scene.objects.len(), features.dual));
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
                source.push_str(&all_objects_looped(scene.objects.len()));
            }
        }
        if code.is_empty() {
            code.extend([0; 4]); // a storage buffer may not be empty
        }
        source.push_str(TRACER);
        Ok(SceneCode {
            kernel,
            features,
            source,
            objects,
            code,
            input_vec4s,
        })
    }

    /// The size in bytes of binding `b`'s uniform buffer where it is a
    /// uniform array (the inputs, the lights, the materials, the objects:
    /// bindings 0 and 2 to 4), or None.
    pub(crate) fn uniform_bytes(&self, b: usize) -> Option<u64> {
        match b {
            0 => self.input_vec4s.map(|n| n as u64 * 16),
            2..=4 => self.features.tables[b - 2].map(|n| n as u64 * TABLES[b - 2].2 as u64),
            _ => None,
        }
    }

    /// The buffer of binding `b` holding `bytes`: a uniform buffer padded
    /// to its array's length where the module declares one
    /// ([`SceneCode::uniform_bytes`]), else a storage buffer.
    pub(crate) fn table_buffer(&self, device: &wgpu::Device, b: usize, label: &str, bytes: &[u8]) -> wgpu::Buffer {
        let (contents, usage) = match self.uniform_bytes(b) {
            Some(size) => {
                let mut padded = bytes.to_vec();
                padded.resize(size as usize, 0);
                (std::borrow::Cow::Owned(padded), wgpu::BufferUsages::UNIFORM)
            }
            None => (std::borrow::Cow::Borrowed(bytes), wgpu::BufferUsages::STORAGE),
        };
        wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &contents,
                usage,
            },
        )
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
    pub(crate) fn objects(&self, scene: &Scene, dents: &[u32]) -> Vec<Obj> {
        scene
            .objects
            .iter()
            .zip(&scene.derived().analytic)
            .zip(&self.objects)
            .zip(dents)
            .map(|(((o, a), c), &dent)| {
                let (analytic, a) = match a {
                    None => (0, [0.0f32; 4]),
                    Some(Analytic::Plane { n, h }) => (1, [n[0] as f32, n[1] as f32, n[2] as f32, *h as f32]),
                    Some(Analytic::Sphere { c, r }) => (2, [c[0] as f32, c[1] as f32, c[2] as f32, (r * r) as f32]),
                };
                let (code_start, code_len, out_slot) = c.program;
                Obj {
                    material: o.material as u32,
                    analytic,
                    code_start,
                    code_len,
                    out_slot,
                    dent,
                    pad1: 0,
                    pad2: 0,
                    a,
                }
            })
            .collect()
    }
}

/// `iso_all(p)` and `iso_all_dual(p)`: every object's distance at p in
/// one array (`N_OBJECTS` long), each object's function called once in
/// straight-line code. A loop over the objects that calls
/// `iso_object(i, p)` costs every case of its `switch` at every turn on a
/// driver that runs divergent branches with lanes masked off (lavapipe),
/// so n objects cost n² evaluations; read from this array they cost n.
/// Without `with_dual` (see [`Features::dual`]) `iso_all_dual` is a stub.
fn all_objects(n: usize, with_dual: bool) -> String {
    let mut value = String::new();
    let mut dual = String::new();
    for i in 0..n {
        value.push_str(&format!("    d[{i}] = iso_o{i}(p);\n"));
        if with_dual {
            dual.push_str(&format!("    d[{i}] = iso_g{i}(p);\n"));
        }
    }
    format!(
        "const N_OBJECTS: u32 = {}u;\nconst COMPILED_OBJECTS: bool = true;\n\
         fn iso_all(p: vec3<f32>) -> array<f32, N_OBJECTS> {{\n    var d: array<f32, N_OBJECTS>;\n{value}    return d;\n}}\n\
         fn iso_all_dual(p: vec3<f32>) -> array<vec4<f32>, N_OBJECTS> {{\n    \
         var d: array<vec4<f32>, N_OBJECTS>;\n{dual}    return d;\n}}\n",
        n.max(1)
    )
}

/// [`all_objects`] for the interpreted kernel: a loop over the programs
/// (`COMPILED_OBJECTS` false: the tracer calls `iso_object(i, p)` in its
/// loops instead, as the interpreter has no `switch` to pay for).
fn all_objects_looped(n: usize) -> String {
    format!(
        "const N_OBJECTS: u32 = {}u;\nconst COMPILED_OBJECTS: bool = false;\n\
         fn iso_all(p: vec3<f32>) -> array<f32, N_OBJECTS> {{\n    var d: array<f32, N_OBJECTS>;\n    \
         for (var i = 0u; i < cfg.n_objects; i++) {{ d[i] = iso_object(i, p); }}\n    return d;\n}}\n\
         fn iso_all_dual(p: vec3<f32>) -> array<vec4<f32>, N_OBJECTS> {{\n    \
         var d: array<vec4<f32>, N_OBJECTS>;\n    \
         for (var i = 0u; i < cfg.n_objects; i++) {{ d[i] = iso_object_dual(i, p); }}\n    return d;\n}}\n",
        n.max(1)
    )
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
        let optical = scene.materials.iter().any(|m| MaterialSample::from(m).is_optical());
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
pub(crate) fn settings(
    scene: &Scene,
    band: Band,
    aovs: bool,
    scratch: Scratch,
    raster: Option<u32>,
    reaches: &isoray_render::Reaches,
) -> Settings {
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
    let f3 = |v: [f64; 3]| v.map(|x| x as f32);
    let ([bg_r, bg_g, bg_b], [cam_x, cam_y, cam_z]) = (f3(r.background), f3(c.position));
    let ([fwd_x, fwd_y, fwd_z], [right_x, right_y, right_z], [up_x, up_y, up_z]) = (f3(fwd), f3(right), f3(up));
    let [amb_r, amb_g, amb_b] = f3(r.ambient);
    let aa_pattern = match r.aa_pattern {
        AaPattern::Grid => 0,
        AaPattern::Rotated => 1,
        AaPattern::Jittered => 2,
    };
    let parallax = match r.parallax {
        isoray_scene::Parallax::None => 0,
        isoray_scene::Parallax::Offset => 1,
        isoray_scene::Parallax::Steep => 2,
        isoray_scene::Parallax::Occlusion => 3,
    };
    Settings {
        width: w,
        height: h,
        x0: band.x0,
        y0: band.y0,
        region_w: band.width,
        region_h: band.height,
        aa: r.aa,
        max_steps: r.max_steps,
        hit_eps: r.hit_epsilon as f32,
        relative_eps: r.relative_epsilon as u32,
        max_dist: r.max_distance as f32,
        step_scale: r.step_scale as f32,
        normals,
        normal_h: r.normal_epsilon as f32,
        normal_inv_h: (1.0 / r.normal_epsilon) as f32,
        shadows,
        shadow_exponent: r.shadow_exponent as f32,
        shadow_start: r.shadow_start as f32,
        shadow_max_dist: r.shadow_max_distance as f32,
        shadow_max_steps: r.shadow_max_steps,
        ao: r.ao as u32,
        ao_samples: r.ao_samples,
        ao_step: r.ao_step as f32,
        ao_intensity: r.ao_intensity as f32,
        blend,
        blend_quarter_over_k: if r.blend > 0.0 { (0.25 / r.blend) as f32 } else { 0.0 },
        material_blend_k: blend * r.material_blend as f32,
        view,
        max_depth: r.max_depth,
        min_weight: r.min_weight as f32,
        n_lights: scene.lights.len() as u32,
        n_objects: scene.objects.len() as u32,
        bg_r,
        bg_g,
        bg_b,
        aovs: aovs as u32,
        cam_x,
        cam_y,
        cam_z,
        projection: (c.projection == Projection::Equirect) as u32,
        fwd_x,
        fwd_y,
        fwd_z,
        tan_half: c.tan_half_fov() as f32,
        right_x,
        right_y,
        right_z,
        aspect: (w as f64 / h as f64) as f32,
        up_x,
        up_y,
        up_z,
        n_clear,
        env_kind,
        env_cos,
        env_sin,
        env_k,
        any_analytic: scene.derived().analytic.iter().any(Option::is_some) as u32,
        record,
        stack_cap: scratch.stack_cap,
        reg_slots: scratch.reg_slots,
        step_limit_miss: (r.on_step_limit == StepLimit::Miss) as u32,
        shadow_floor: r.shadow_floor as f32,
        shadow_all: (r.shadow_applies_to == ShadowTarget::All) as u32,
        ao_uniform: (r.ao_weights == AoWeights::Uniform) as u32,
        ao_all: (r.ao_applies_to == AoTarget::All) as u32,
        amb_r,
        amb_g,
        amb_b,
        fixed_march: (r.march == March::Fixed) as u32,
        fixed_step: r.fixed_step as f32,
        aa_pattern,
        shadow_eps: r.shadow_epsilon as f32,
        raster: raster.is_some() as u32,
        raster_stride: raster.unwrap_or(0),
        parallax,
        parallax_steps: r.parallax_steps,
        ..reach_settings(reaches)
    }
}

/// The settings' reach fields: the scene's, the rest's and the penumbra's
/// boxes in their domain, as `reach_far` in `kernel/tracer.wgsl` reads them.
fn reach_settings(reaches: &isoray_render::Reaches) -> Settings {
    let corner = |p: [f64; 3]| [p[0] as f32, p[1] as f32, p[2] as f32, 0.0];
    let mut s = Settings::default();
    let domain = reaches.scene.as_ref().or(reaches.rest.as_ref()).map(|r| r.boxes().0);
    if let Some(d) = domain {
        s.reach_domain_lo = corner(d.lo);
        s.reach_domain_hi = corner(d.hi);
    }
    let one = |reach: &Option<isoray_render::reach::Reach>| -> (u32, [f32; 4], [f32; 4]) {
        match reach.as_ref().map(|r| r.boxes()) {
            None => (0, [0.0; 4], [0.0; 4]),
            Some((d, _)) if domain.is_some_and(|e| e != d) => (0, [0.0; 4], [0.0; 4]),
            Some((_, None)) => (1, [0.0; 4], [0.0; 4]),
            Some((_, Some(b))) => (2, corner(b.lo), corner(b.hi)),
        }
    };
    (s.reach_scene, s.reach_scene_lo, s.reach_scene_hi) = one(&reaches.scene);
    (s.reach_rest, s.reach_rest_lo, s.reach_rest_hi) = one(&reaches.rest);
    (s.reach_penumbra, s.reach_penumbra_lo, s.reach_penumbra_hi) = one(&reaches.penumbra);
    s
}

/// The `Light` array.
pub(crate) fn lights(scene: &Scene) -> Vec<Light> {
    let f3 = |v: [f64; 3]| v.map(|x| x as f32);
    scene
        .lights
        .iter()
        .map(|l| {
            let (kind, pos, radius, u, v) = match l.kind {
                LightKind::Directional { direction } => (0, direction, 0.0, [0.0; 3], [0.0; 3]),
                LightKind::Point { position } => (1, position, 0.0, [0.0; 3], [0.0; 3]),
                LightKind::Sphere { position, radius } => (2, position, radius, [0.0; 3], [0.0; 3]),
                LightKind::Rect { position, u, v } => (3, position, 0.0, u, v),
            };
            let ([cr, cg, cb], [px, py, pz], [ux, uy, uz], [vx, vy, vz]) = (f3(l.color), f3(pos), f3(u), f3(v));
            let [att_c, att_l, att_q] = l.attenuation.map(|x| x as f32);
            Light {
                kind,
                samples: l.samples,
                size: l.size as f32,
                intensity: l.intensity as f32,
                cr,
                cg,
                cb,
                att_c,
                att_l,
                att_q,
                px,
                py,
                pz,
                radius: radius as f32,
                ux,
                uy,
                uz,
                vx,
                vy,
                vz,
            }
        })
        .collect()
}

/// The `Mat` array, as isoray-shade rounds each material to f32.
pub(crate) fn materials(scene: &Scene) -> Vec<Mat> {
    scene
        .materials
        .iter()
        .map(|m| {
            let s = MaterialSample::from(m);
            let model = match s.model {
                isoray_scene::ShadingModel::Phong => 0,
                isoray_scene::ShadingModel::BlinnPhong => 1,
            };
            let specular_function = match s.specular_function {
                isoray_scene::SpecularFunction::Pow => 0,
                isoray_scene::SpecularFunction::Schlick => 1,
            };
            let fresnel = match s.fresnel {
                isoray_scene::Fresnel::Off => 0,
                isoray_scene::Fresnel::Schlick => 1,
                isoray_scene::Fresnel::Exact => 2,
            };
            let (checker_other, checker_size) = m.checker.map_or((u32::MAX, 1.0), |(o, sz)| (o as u32, sz as f32));
            Mat {
                ambient: s.ambient.to_array(),
                shininess: s.shininess,
                diffuse: s.diffuse.to_array(),
                transparency: s.transparency,
                specular: s.specular.to_array(),
                ior: s.ior,
                emission: s.emission.to_array(),
                model,
                reflectivity: s.reflectivity.to_array(),
                specular_function,
                absorption: s.absorption.to_array(),
                fresnel,
                checker_other,
                checker_size,
                spec_fresnel: s.specular_fresnel as u32,
                pad1: 0,
            }
        })
        .collect()
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

/// The scene's meshes as `kernel/meshes.wgsl`'s `mesh_data` reads them: the
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_tables_round_up_and_stop_at_64_kib() {
        let obj = std::mem::size_of::<Obj>();
        assert_eq!(obj, 48);
        assert_eq!(uniform_length(0, obj), Some(4));
        assert_eq!(uniform_length(5, obj), Some(8));
        assert_eq!(uniform_length(1000, obj), Some(1024)); // 48 KiB
        assert_eq!(uniform_length(1025, obj), None); // 2048 × 48 B > 64 KiB
        let mat = std::mem::size_of::<Mat>();
        assert_eq!(uniform_length(512, mat), Some(512)); // 56 KiB
        assert_eq!(uniform_length(600, mat), None);
    }

    /// Soft shadow rays stop past the penumbra's box, the CPU's own: the
    /// lighting example's box holds its objects. (It is large: the floor
    /// plane's distance is below the penumbra's, light size × shadow
    /// distance, far up.)
    #[test]
    fn the_penumbras_reach_reaches_the_settings() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/lighting.toml");
        let scene = isoray_scene::load(&path, &[]).unwrap_or_else(|e| panic!("{}", e.rendered));
        let reaches = isoray_render::reaches(&scene, scene.camera.position, Some(640 * 360));
        let (_, Some(b)) = reaches.penumbra.as_ref().expect("a penumbra reach").boxes() else {
            panic!("the penumbra has a box")
        };
        let s = reach_settings(&reaches);
        assert_eq!(s.reach_penumbra, 2);
        let (lo, hi) = (s.reach_penumbra_lo, s.reach_penumbra_hi);
        assert_eq!([lo[0], lo[1], lo[2]], b.lo.map(|v| v as f32));
        assert_eq!([hi[0], hi[1], hi[2]], b.hi.map(|v| v as f32));
        // The sphere at (-1.8, 0.7, 0) of radius 0.7 is inside.
        assert!(
            lo[0] <= -2.5 && hi[0] >= -1.1 && lo[1] <= 0.0 && hi[1] >= 1.4,
            "{lo:?} {hi:?}"
        );
    }

    /// A fifth light outgrows a table of four, so the pipeline is rebuilt
    /// (`Features` is part of its cache key); a third does not.
    #[test]
    fn a_light_past_the_tables_capacity_changes_the_features() {
        let light = "[[light]]\nkind = \"point\"\nposition = [1.0, 4.0, 2.0]\n";
        let scene = |lights: usize| {
            let text = format!("[[object]]\nshape = \"sphere(p, 1.0)\"\n{}", light.repeat(lights));
            isoray_scene::load_str(&text, "lights.toml", &[]).unwrap_or_else(|e| panic!("{}", e.rendered))
        };
        let f = |n| Features::of(&scene(n));
        assert_eq!(f(2).tables[0], Some(4));
        assert_eq!(f(2), f(3));
        assert_eq!(f(5).tables[0], Some(8));
        assert_ne!(f(4), f(5));
        // The module declares what the features say.
        let code = SceneCode::new(&scene(5), Kernel::Compiled).unwrap();
        assert!(code.source.contains("var<uniform> lights: array<Light, 8>;"));
        assert_eq!(code.uniform_bytes(2), Some(8 * 80));
        assert!(code.source.contains("var<uniform> iso_in: array<vec4<f32>,"));
    }
}
