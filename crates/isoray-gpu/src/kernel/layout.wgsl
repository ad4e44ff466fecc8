// isoray's sphere and ray tracer on the GPU: the WGSL twin of
// isoray-render (tracing, normals, materials, Whitted paths) and
// isoray-shade (Phong/Blinn-Phong, lights, optics), formula for formula.
// The tracer is the files of this folder joined in pack::TRACER's order
// (WGSL declarations may come in any order); each is named after what it
// mirrors:
//   layout.wgsl       the buffers and structures pack.rs writes
//   fold.wgsl         the fields folded from the objects, fold cells, gradients
//   tracer.wgsl       sphere tracing, closed-form caps, shadow rays
//   meshes.wgsl       triangle meshes (isoray-mesh's Bvh) and their raster prepass
//   dents.wgsl        dent maps' normals and parallax (Scene::dent_normal)
//   optics.wgsl       media, transmission, Fresnel (isoray-shade's optics)
//   shade.wgsl        lights, materials, Phong, AO, one hit's colour
//   environment.wgsl  environment maps and the sky
//   whitted.wgsl      depth-first Whitted paths (isoray-render's whitted)
//   pixels.wgsl       cameras, samples, views and the entry points
// The generated part before these files defines `iso_in`, the prelude,
// `iso_object(i, p)` and `iso_object_dual(i, p)`, and the constants
// HAS_MESHES, HAS_DENTS, HAS_OPTICS, HAS_CLEAR, HAS_DUAL (what of the tracer the
// scene can reach: see pack::Features) and USE_CELLS; everything a scene sets
// (settings, camera, lights, materials, placements, inputs) is read from
// the buffers below, so changing it never rebuilds this pipeline.

struct Settings {
    width: u32, height: u32, x0: u32, y0: u32,
    region_w: u32, region_h: u32, aa: u32, max_steps: u32,
    hit_eps: f32, relative_eps: u32, max_dist: f32, step_scale: f32,
    normals: u32, normal_h: f32, normal_inv_h: f32, shadows: u32,
    shadow_exponent: f32, shadow_start: f32, shadow_max_dist: f32, shadow_max_steps: u32,
    ao: u32, ao_samples: u32, ao_step: f32, ao_intensity: f32,
    blend: f32, blend_quarter_over_k: f32, material_blend_k: f32, view: u32,
    max_depth: u32, min_weight: f32, n_lights: u32, n_objects: u32,
    bg_r: f32, bg_g: f32, bg_b: f32, aovs: u32,
    cam_x: f32, cam_y: f32, cam_z: f32, projection: u32,
    fwd_x: f32, fwd_y: f32, fwd_z: f32, tan_half: f32,
    right_x: f32, right_y: f32, right_z: f32, aspect: f32,
    up_x: f32, up_y: f32, up_z: f32, n_clear: u32,
    env_kind: u32, env_cos: f32, env_sin: f32, env_k: f32,
    any_analytic: u32, record: u32, stack_cap: u32, reg_slots: u32,
    step_limit_miss: u32, shadow_floor: f32, shadow_all: u32, ao_uniform: u32,
    ao_all: u32, amb_r: f32, amb_g: f32, amb_b: f32,
    fixed_march: u32, fixed_step: f32, aa_pattern: u32, shadow_eps: f32,
    raster: u32, raster_stride: u32, parallax: u32, parallax_steps: u32,
    // The surfaces' reach (isoray-render's Reach): 0 unknown, 1 no surface
    // in the domain, 2 the surface's box; of the scene's field, of the
    // objects beside closed forms, and of the penumbra (shadow rays).
    reach_scene: u32, reach_rest: u32, reach_penumbra: u32, pad5: u32,
    reach_domain_lo: vec4<f32>, reach_domain_hi: vec4<f32>,
    reach_scene_lo: vec4<f32>, reach_scene_hi: vec4<f32>,
    reach_rest_lo: vec4<f32>, reach_rest_hi: vec4<f32>,
    reach_penumbra_lo: vec4<f32>, reach_penumbra_hi: vec4<f32>,
}

struct Light {
    kind: u32, samples: u32, size: f32, intensity: f32,
    cr: f32, cg: f32, cb: f32, att_c: f32,
    att_l: f32, att_q: f32, px: f32, py: f32,
    pz: f32, radius: f32, ux: f32, uy: f32,
    uz: f32, vx: f32, vy: f32, vz: f32,
}

struct Mat {
    ambient: vec3<f32>, shininess: f32,
    diffuse: vec3<f32>, transparency: f32,
    specular: vec3<f32>, ior: f32,
    emission: vec3<f32>, model: u32,
    reflectivity: vec3<f32>, specular_function: u32,
    absorption: vec3<f32>, fresnel: u32,
    checker_other: u32, checker_size: f32, spec_fresnel: u32, pad1: u32,
}

struct Obj {
    material: u32, analytic: u32, code_start: u32, code_len: u32,
    out_slot: u32, dent: u32, pad1: u32, pad2: u32,
    a: vec4<f32>,
}

@group(0) @binding(1) var<uniform> cfg: Settings;
// Bindings 0 (iso_in) and 2 to 4 (lights, mats, objs) are declared by
// pack: uniform arrays where they fit (Features::tables), storage ones else.
@group(0) @binding(5) var<storage, read> env: array<f32>;
@group(0) @binding(6) var<storage, read_write> out: array<u32>;
// Work counters of the whole render: (low, high) words of five 64-bit sums
// (evaluations, reflected, refracted and shadow rays, overshoots), then the
// worst overshoot factor's bits.
@group(0) @binding(7) var<storage, read_write> stats: array<atomic<u32>, 12>;
// The objects' programs, for the interpreting kernel (unused by the compiled one).
@group(0) @binding(8) var<storage, read> iso_code: array<u32>;
// The lanes' scratch: ray stacks and interpreter registers (see ray_push).
@group(0) @binding(9) var<storage, read_write> iso_regs: array<vec4<f32>>;
var<private> iso_reg_base: u32;
// The triangle meshes (`[[mesh]]`): see isoray-gpu's pack::meshes.
@group(0) @binding(10) var<storage, read> mesh_data: array<u32>;
// The meshes' raster prepass (isoray-gpu's raster): per primary sample of
// the supersampled grid, 0 or (mesh + 1) << 24 | triangle, with
// `cfg.raster_stride` words a row; a one-word buffer when `cfg.raster` is 0.
@group(0) @binding(11) var<storage, read> raster_ids: array<u32>;
// Dent maps (pack::dents): a header of DENT_HEADER words per object drawn
// with dent maps (Obj.dent), then each map's texel normals, x and y as
// pack2x16snorm (z ≥ 0 from them).
@group(0) @binding(12) var<storage, read> dent_data: array<u32>;
// The prepass's texel (column, row) of the ray `trace` is about to follow
// (the primary ray of the lane's sample), or NO_TEXEL in x: the trees are walked.
const NO_TEXEL: u32 = 0xffffffffu;
var<private> primary_texel: vec2<u32> = vec2<u32>(NO_TEXEL, 0u);

const EMPTY: f32 = 1e9;
const OFFSET: f32 = 10.0;
const MAX_SHADOW_SEGMENTS: u32 = 8u;
const MEDIA: u32 = 6u;
const NO_CHECKER: u32 = 0xffffffffu;

// Fields (which union of objects a ray marches).
const F_SCENE: u32 = 0u;       // all objects, smooth union of width `blend`
const F_SURFACES: u32 = 1u;    // min over objects of |d|
const F_REST: u32 = 2u;        // the objects not in closed form (plain union)
const F_OPAQUE: u32 = 3u;      // opaque objects (smooth union)
const F_CLEAR: u32 = 4u;       // transparent objects (smooth union)
const F_CLEAR_SURFACES: u32 = 5u;

// Work counters of one invocation.
var<private> n_evals: u32;
var<private> n_reflected: u32;
var<private> n_refracted: u32;
var<private> n_shadow: u32;
var<private> n_overshoots: u32;
var<private> worst_overshoot: f32;
