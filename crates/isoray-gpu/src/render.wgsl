// isoray's sphere and ray tracer on the GPU: the WGSL twin of
// isoray-render (tracing, normals, materials, Whitted paths) and
// isoray-shade (Phong/Blinn-Phong, lights, optics), formula for formula.
// The generated part before this file defines `iso_in`, the prelude,
// `iso_object(i, p)` and `iso_object_dual(i, p)`; everything a scene sets
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
@group(0) @binding(2) var<storage, read> lights: array<Light>;
@group(0) @binding(3) var<storage, read> mats: array<Mat>;
@group(0) @binding(4) var<storage, read> objs: array<Obj>;
@group(0) @binding(5) var<storage, read> env: array<f32>;
@group(0) @binding(6) var<storage, read_write> out: array<u32>;
// Work counters of the whole render: (low, high) words of five 64-bit sums
// (evaluations, reflected, refracted and shadow rays, overshoots), then the
// worst overshoot factor's bits.
@group(0) @binding(7) var<storage, read_write> stats: array<atomic<u32>, 12>;
var<workgroup> wg_stats: array<atomic<u32>, 6>;
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

fn is_clear(i: u32) -> bool { return mats[objs[i].material].transparency > 0.0; }

fn wanted(kind: u32, i: u32) -> bool {
    switch kind {
        case 2u: { return objs[i].analytic == 0u; }
        case 3u: { return !is_clear(i); }
        case 4u, 5u: { return is_clear(i); }
        default: { return true; }
    }
}

// The IR's smooth_union: min(a,b) − max(k−|a−b|,0)²·(¼/k), or min(a, b) at k = 0.
fn smooth_union(x: f32, y: f32) -> f32 {
    if (cfg.blend <= 0.0) { return iso_min(x, y); }
    let h = iso_max(cfg.blend - abs(x - y), 0.0);
    return iso_min(x, y) - (h * h) * cfg.blend_quarter_over_k;
}

fn dual_min(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(iso_min(a.x, b.x), select(a.yzw, b.yzw, b.x < a.x || iso_is_nan(a.x)));
}

fn dual_abs(a: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(abs(a.x), a.yzw * select(1.0, -1.0, a.x < 0.0));
}

fn smooth_union_dual(x: vec4<f32>, y: vec4<f32>) -> vec4<f32> {
    if (cfg.blend <= 0.0) { return dual_min(x, y); }
    let d = x - y;
    let ad = dual_abs(d);
    let kd = vec4<f32>(cfg.blend - ad.x, -ad.yzw);
    let h = select(kd, vec4<f32>(0.0), 0.0 > kd.x || iso_is_nan(kd.x));
    let h2 = vec4<f32>(h.x * h.x, h.yzw * (2.0 * h.x));
    let corr = vec4<f32>(h2.x * cfg.blend_quarter_over_k, h2.yzw * cfg.blend_quarter_over_k);
    return dual_min(x, y) - corr;
}

fn unsigned_field(kind: u32) -> bool { return kind == F_SURFACES || kind == F_CLEAR_SURFACES; }

// The distance of the field `kind` at p (as isoray-scene's derive builds it).
fn field(kind: u32, p: vec3<f32>) -> f32 {
    n_evals += 1u;
    var acc = EMPTY;
    var have = false;
    for (var i = 0u; i < cfg.n_objects; i++) {
        if (!wanted(kind, i)) { continue; }
        var d = iso_object(i, p);
        if (unsigned_field(kind)) { d = abs(d); }
        if (!have) {
            acc = d;
            have = true;
        } else if (unsigned_field(kind) || kind == F_REST) {
            acc = iso_min(acc, d);
        } else {
            acc = smooth_union(acc, d);
        }
    }
    return acc;
}

fn field_dual(kind: u32, p: vec3<f32>) -> vec4<f32> {
    var acc = vec4<f32>(EMPTY, 0.0, 0.0, 0.0);
    var have = false;
    for (var i = 0u; i < cfg.n_objects; i++) {
        if (!wanted(kind, i)) { continue; }
        var d = iso_object_dual(i, p);
        if (unsigned_field(kind)) { d = dual_abs(d); }
        if (!have) {
            acc = d;
            have = true;
        } else if (unsigned_field(kind) || kind == F_REST) {
            acc = dual_min(acc, d);
        } else {
            acc = smooth_union_dual(acc, d);
        }
    }
    return acc;
}

// ---- gradients (isoray-shape's GradientMode and stencils) ----
const N_DUAL: u32 = 3u;

fn gradient(kind: u32, p: vec3<f32>, mode: u32) -> vec3<f32> {
    if (mode == N_DUAL) {
        n_evals += 1u;
        return field_dual(kind, p).yzw;
    }
    let h = cfg.normal_h;
    var g = vec3<f32>(0.0);
    var n = 6u;
    if (mode != 0u) { n = 4u; }
    for (var k = 0u; k < n; k++) {
        var o: vec3<f32>;
        var w: vec3<f32>;
        if (mode == 0u) {
            // Central: ±h along each axis, weights ±½.
            let axis = k / 2u;
            let s = select(1.0, -1.0, (k & 1u) == 1u);
            o = vec3<f32>(0.0);
            o[axis] = s;
            w = o * 0.5;
        } else if (mode == 1u) {
            // Forward: f(p) with weight −1, then +h along each axis.
            if (k == 0u) {
                o = vec3<f32>(0.0);
                w = vec3<f32>(-1.0);
            } else {
                o = vec3<f32>(0.0);
                o[k - 1u] = 1.0;
                w = o;
            }
        } else {
            // Tetrahedron (1,−1,−1), (−1,−1,1), (−1,1,−1), (1,1,1), weights k/4.
            switch k {
                case 0u: { o = vec3<f32>(1.0, -1.0, -1.0); }
                case 1u: { o = vec3<f32>(-1.0, -1.0, 1.0); }
                case 2u: { o = vec3<f32>(-1.0, 1.0, -1.0); }
                default: { o = vec3<f32>(1.0, 1.0, 1.0); }
            }
            w = o * 0.25;
        }
        let f = field(kind, p + o * h) * cfg.normal_inv_h;
        g = g + w * f;
    }
    return g;
}

// glam's normalize_or_zero: v·(1/|v|) when that is finite and positive.
fn normalize_or_zero(v: vec3<f32>) -> vec3<f32> {
    let r = 1.0 / sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    if (r > 0.0 && r < iso_inf()) { return v * r; }
    return vec3<f32>(0.0);
}

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 { return a.x * b.x + a.y * b.y + a.z * b.z; }
fn max3(v: vec3<f32>) -> f32 { return max(max(v.x, v.y), v.z); }

// ---- closed forms (isoray-scene's Analytic::intersect) ----
fn analytic_cap(o: vec3<f32>, d: vec3<f32>) -> f32 {
    var best = iso_inf();
    for (var i = 0u; i < cfg.n_objects; i++) {
        let ob = objs[i];
        var t = iso_inf();
        if (ob.analytic == 1u) {
            let den = ob.a.x * d.x + ob.a.y * d.y + ob.a.z * d.z;
            let num = ob.a.x * o.x + ob.a.y * o.y + ob.a.z * o.z + ob.a.w;
            let s = -num / den;
            if (s > 0.0 && abs(s) < iso_inf()) { t = s; }
        } else if (ob.analytic == 2u) {
            let oc = o - ob.a.xyz;
            let b = oc.x * d.x + oc.y * d.y + oc.z * d.z;
            let cc = oc.x * oc.x + oc.y * oc.y + oc.z * oc.z - ob.a.w;
            let disc = b * b - cc;
            if (disc >= 0.0) {
                let q = sqrt(disc);
                let t0 = -b - q;
                let t1 = -b + q;
                if (t0 > 0.0) { t = t0; } else if (t1 > 0.0) { t = t1; }
            }
        }
        best = iso_min(best, t);
    }
    return best;
}

// ---- triangle meshes (isoray-mesh's Bvh, isoray-render's meshes) ----
const NO_MESH: u32 = 0xffffffffu;
struct MeshHit { t: f32, mesh: u32, tri: u32, u: f32, v: f32 }

fn mesh_f(i: u32) -> f32 { return bitcast<f32>(mesh_data[i]); }
fn mesh_v3(i: u32) -> vec3<f32> { return vec3<f32>(mesh_f(i), mesh_f(i + 1u), mesh_f(i + 2u)); }
fn min3(v: vec3<f32>) -> f32 { return min(min(v.x, v.y), v.z); }

// q · v · q⁻¹ for a unit quaternion (glam's formula).
fn quat_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let b = q.xyz;
    return v * (q.w * q.w - dot3(b, b)) + b * (dot3(v, b) * 2.0) + cross(b, v) * (q.w * 2.0);
}

fn mesh_quat(k: u32) -> vec4<f32> {
    let b = 1u + 16u * k;
    return vec4<f32>(mesh_f(b), mesh_f(b + 1u), mesh_f(b + 2u), mesh_f(b + 3u));
}

// Möller–Trumbore, two-sided: (t, u, v) where the ray lo + t·ld meets
// the triangle at word tb of mesh_data, t = -1 where it does not.
fn tri_hit(tb: u32, lo: vec3<f32>, ld: vec3<f32>) -> vec3<f32> {
    let miss = vec3<f32>(-1.0, 0.0, 0.0);
    let a = mesh_v3(tb);
    let e1 = mesh_v3(tb + 3u) - a;
    let e2 = mesh_v3(tb + 6u) - a;
    let p = cross(ld, e2);
    let det = dot3(e1, p);
    if (det == 0.0 || !(abs(det) < iso_inf())) { return miss; }
    let id = 1.0 / det;
    let sv = lo - a;
    let u = dot3(sv, p) * id;
    if (!(u >= 0.0 && u <= 1.0)) { return miss; }
    let qv = cross(sv, e1);
    let v = dot3(ld, qv) * id;
    if (v < 0.0 || u + v > 1.0) { return miss; }
    return vec3<f32>(dot3(e2, qv) * id, u, v);
}

// The ray o + t·d in mesh k's own coordinates (the same t): origin, direction.
fn mesh_local_ray(k: u32, o: vec3<f32>, d: vec3<f32>) -> array<vec3<f32>, 2> {
    let b = 1u + 16u * k;
    let q = mesh_quat(k);
    let qi = vec4<f32>(-q.xyz, q.w);
    let s = 1.0 / mesh_f(b + 7u);
    return array<vec3<f32>, 2>(quat_rotate(qi, o - mesh_v3(b + 4u)) * s, quat_rotate(qi, d) * s);
}

// The nearest triangle of any mesh on o + t·d with 0 < t < tmax (with
// `any`, the first one found): each mesh's tree walked without a stack,
// in the mesh's own coordinates (the same t).
fn mesh_cast(o: vec3<f32>, d: vec3<f32>, tmax: f32, any: bool) -> MeshHit {
    var best = MeshHit(tmax, NO_MESH, 0u, 0.0, 0.0);
    let nm = mesh_data[0];
    for (var k = 0u; k < nm; k++) {
        let b = 1u + 16u * k;
        let local = mesh_local_ray(k, o, d);
        let lo = local[0];
        let ld = local[1];
        let inv = 1.0 / ld;
        let node_base = mesh_data[b + 8u];
        let node_count = mesh_data[b + 9u];
        let tri_base = mesh_data[b + 10u];
        var i = 0u;
        loop {
            if (i >= node_count) { break; }
            let nb = node_base + 8u * i;
            let t0 = (mesh_v3(nb) - lo) * inv;
            let t1 = (mesh_v3(nb + 4u) - lo) * inv;
            let near = max(max3(min(t0, t1)), 0.0);
            let far = min(min3(max(t0, t1)), best.t);
            let esc = mesh_data[nb + 3u];
            if (!(near <= far)) { i = esc; continue; }
            let packed = mesh_data[nb + 7u];
            let count = packed & 15u;
            if (count == 0u) { i += 1u; continue; }
            let first = packed >> 4u;
            for (var j = first; j < first + count; j++) {
                let tuv = tri_hit(tri_base + 9u * j, lo, ld);
                if (tuv.x > 0.0 && tuv.x < best.t) {
                    best = MeshHit(tuv.x, k, j, tuv.y, tuv.z);
                    if (any) { return best; }
                }
            }
            i = esc;
        }
    }
    return best;
}

// The primary ray's mesh hit from the raster prepass: the triangles the
// rasteriser kept at `texel` and its four neighbours, each intersected
// exactly (the t the tree walk finds), the nearest hit; none where no
// triangle covers them. The neighbours catch the samples a rasteriser
// (which snaps corners to a sub-pixel grid) leaves to the triangle behind
// an edge; where the rasteriser covered a texel but no exact test hits
// (an edge), the trees are walked.
fn raster_hit(o: vec3<f32>, d: vec3<f32>, texel: vec2<u32>) -> MeshHit {
    var best = MeshHit(iso_inf(), NO_MESH, 0u, 0.0, 0.0);
    var covered = false;
    let gw = cfg.width * cfg.aa;
    let gh = cfg.height * cfg.aa;
    var ids = array<u32, 5>(0u, 0u, 0u, 0u, 0u);
    ids[0] = raster_ids[texel.y * cfg.raster_stride + texel.x];
    if (texel.x > 0u) { ids[1] = raster_ids[texel.y * cfg.raster_stride + texel.x - 1u]; }
    if (texel.x + 1u < gw) { ids[2] = raster_ids[texel.y * cfg.raster_stride + texel.x + 1u]; }
    if (texel.y > 0u) { ids[3] = raster_ids[(texel.y - 1u) * cfg.raster_stride + texel.x]; }
    if (texel.y + 1u < gh) { ids[4] = raster_ids[(texel.y + 1u) * cfg.raster_stride + texel.x]; }
    for (var i = 0u; i < 5u; i++) {
        let id = ids[i];
        if (id == 0u) { continue; }
        covered = true;
        var seen = false;
        for (var j = 0u; j < i; j++) { seen = seen || ids[j] == id; }
        if (seen) { continue; }
        let k = (id >> 24u) - 1u;
        let tri = id & 0xffffffu;
        let local = mesh_local_ray(k, o, d);
        let tuv = tri_hit(mesh_data[1u + 16u * k + 10u] + 9u * tri, local[0], local[1]);
        if (tuv.x > 0.0 && tuv.x < best.t) { best = MeshHit(tuv.x, k, tri, tuv.y, tuv.z); }
    }
    if (best.mesh == NO_MESH && covered) { return mesh_cast(o, d, iso_inf(), false); }
    return best;
}

// The world-space unit normal at a mesh hit: the vertex normals
// interpolated, or the triangle's own.
fn mesh_normal(h: MeshHit) -> vec3<f32> {
    let b = 1u + 16u * h.mesh;
    let nb = mesh_data[b + 11u];
    var n = vec3<f32>(0.0);
    if (nb != 0xffffffffu) {
        let c = nb + 9u * h.tri;
        n = normalize_or_zero(mesh_v3(c) * (1.0 - h.u - h.v) + mesh_v3(c + 3u) * h.u + mesh_v3(c + 6u) * h.v);
    }
    if (n.x == 0.0 && n.y == 0.0 && n.z == 0.0) {
        let tb = mesh_data[b + 10u] + 9u * h.tri;
        let a = mesh_v3(tb);
        n = normalize_or_zero(cross(mesh_v3(tb + 3u) - a, mesh_v3(tb + 6u) - a));
    }
    return quat_rotate(mesh_quat(h.mesh), n);
}

// ---- sphere tracing (isoray-render's sphere_trace_capped) ----
// ---- Normal mapping of dented objects: isoray-scene's Scene::dent_normal ----

const NO_DENT: u32 = 0xffffffffu;

fn dent_f(i: u32) -> f32 { return bitcast<f32>(dent_data[i]); }
fn dent_v3(i: u32) -> vec3<f32> { return vec3<f32>(dent_f(i), dent_f(i + 1u), dent_f(i + 2u)); }

// The texel normal at column x, row y of the map whose header is at o.
fn dent_texel(o: u32, x: u32, y: u32) -> vec3<f32> {
    let xy = unpack2x16snorm(dent_data[dent_data[o + 5u] + y * dent_data[o + 2u] + x]);
    return vec3<f32>(xy, sqrt(max(0.0, 1.0 - xy.x * xy.x - xy.y * xy.y)));
}

// The four texels around uv and their bilinear weights (isoray-dent's
// DentMaps::corners): columns wrap unless the map clamps, rows clamp.
struct Corners { x: array<u32, 4>, y: array<u32, 4>, w: array<f32, 4> }

fn dent_corners(o: u32, uv: vec2<f32>) -> Corners {
    let w = i32(dent_data[o + 2u]);
    let h = i32(dent_data[o + 3u]);
    let fx = uv.x * f32(w) - 0.5;
    let fy = uv.y * f32(h) - 0.5;
    let x0 = i32(floor(fx));
    let y0 = i32(floor(fy));
    let tx = fx - f32(x0);
    let ty = fy - f32(y0);
    var c: Corners;
    for (var k = 0; k < 4; k++) {
        let dx = k & 1;
        let dy = k >> 1u;
        var x = x0 + dx;
        if (dent_data[o + 4u] != 0u) { x = clamp(x, 0, w - 1); } else { x = ((x % w) + w) % w; }
        c.x[k] = u32(x);
        c.y[k] = u32(clamp(y0 + dy, 0, h - 1));
        c.w[k] = select(1.0 - tx, tx, dx == 1) * select(1.0 - ty, ty, dy == 1);
    }
    return c;
}

// How deep the dents are at uv (DentMaps::depth_at).
fn dent_depth_at(o: u32, uv: vec2<f32>) -> f32 {
    let c = dent_corners(o, uv);
    var d = 0.0;
    for (var k = 0; k < 4; k++) {
        d += c.w[k] * bitcast<f32>(dent_data[dent_data[o + 6u] + c.y[k] * dent_data[o + 2u] + c.x[k]]);
    }
    return d;
}

// The tangent-space normal at uv, bilinear over the texel normals
// (isoray-dent's DentMaps::normal_at).
fn dent_normal_at(o: u32, uv: vec2<f32>) -> vec3<f32> {
    let c = dent_corners(o, uv);
    var n = vec3<f32>(0.0);
    for (var k = 0; k < 4; k++) {
        n += c.w[k] * dent_texel(o, c.x[k], c.y[k]);
    }
    return n / sqrt(dot3(n, n));
}

// The uv of the map at o of the object's point q (x, y), and whether q
// is in the mapped region (z = 1) or not (z = 0): UvMapping::uv.
fn dent_uv(o: u32, q: vec3<f32>) -> vec3<f32> {
    if (dent_data[o] == 1u) {
        // Planar along `axis`: the picture's axes (a, sa) and (b, sb) as
        // isoray-dent's `picture`.
        let axis = dent_data[o + 1u];
        var a = 0u; var sa = 1.0; var b = 2u; var sb = 1.0;
        if (axis == 0u) { a = 2u; sa = -1.0; b = 1u; sb = -1.0; }
        if (axis == 2u) { b = 1u; sb = -1.0; }
        let lo = vec2<f32>(dent_f(o + 8u), dent_f(o + 9u));
        let hi = vec2<f32>(dent_f(o + 10u), dent_f(o + 11u));
        let uv = (vec2<f32>(sa * q[a], sb * q[b]) - lo) / (hi - lo);
        let inside = all(uv >= vec2<f32>(0.0)) && all(uv <= vec2<f32>(1.0));
        return vec3<f32>(uv, select(0.0, 1.0, inside));
    }
    // Spherical: longitude from +z towards +x, colatitude from +y.
    let r = sqrt(dot3(q, q));
    if (r == 0.0) { return vec3<f32>(0.0); }
    let u = atan2(q.x, q.z) / 6.283185307179586 + 0.5;
    return vec3<f32>(u - floor(u), acos(clamp(q.y / r, -1.0, 1.0)) / 3.141592653589793, 1.0);
}

// The uv a view towards e (the object's axes) sees at q, by the parallax
// mapping cfg.parallax asks for (isoray-scene's parallax_uv), in the
// tangent frame t, b, nl; uv0 where it finds none.
fn dent_parallax(o: u32, q: vec3<f32>, t: vec3<f32>, b: vec3<f32>, nl: vec3<f32>, e: vec3<f32>, uv0: vec2<f32>) -> vec2<f32> {
    let v = vec3<f32>(dot3(e, t), dot3(e, b), dot3(e, nl));
    if (!(v.z > 1e-6)) { return uv0; }
    if (cfg.parallax == 1u) {
        let d = dent_depth_at(o, uv0);
        let r = dent_uv(o, q + (-d * v.x) * t + (-d * v.y) * b);
        return select(uv0, r.xy, r.z > 0.0);
    }
    let range = dent_f(o + 7u);
    let steps = cfg.parallax_steps;
    let layer = 0.5 * range / f32(steps);
    let sd = -v.xy / v.z;
    var s0 = 0.0;
    var g0 = 0.0;
    var have = false;
    for (var i = 0u; i <= steps; i++) {
        let s = f32(i) * layer;
        let r = dent_uv(o, q + (s * sd.x) * t + (s * sd.y) * b);
        if (r.z == 0.0) { return uv0; }
        let gap = dent_depth_at(o, r.xy) - s;
        if (gap <= 0.0) {
            if (cfg.parallax == 2u) { return r.xy; }
            var sc = s;
            if (have) { sc = s0 + (s - s0) * g0 / (g0 - gap); }
            let r2 = dent_uv(o, q + (sc * sd.x) * t + (sc * sd.y) * b);
            return select(uv0, r2.xy, r2.z > 0.0);
        }
        s0 = s;
        g0 = gap;
        have = true;
    }
    let h = 0.5 * range;
    let r = dent_uv(o, q + (h * sd.x) * t + (h * sd.y) * b);
    return select(uv0, r.xy, r.z > 0.0);
}

// The normal at world point p of object obj whose undented normal is n,
// seen towards to_eye, tilted by its dent maps (Scene::dent_normal); n
// where it has none or p is off the mapped side or region.
fn dent_normal(obj: u32, p: vec3<f32>, n: vec3<f32>, to_eye: vec3<f32>) -> vec3<f32> {
    let o = objs[obj].dent;
    if (o == NO_DENT) { return n; }
    let r0 = dent_v3(o + 16u);
    let r1 = dent_v3(o + 19u);
    let r2 = dent_v3(o + 22u);
    let d = (p - dent_v3(o + 12u)) / dent_f(o + 15u);
    let q = vec3<f32>(dot3(r0, d), dot3(r1, d), dot3(r2, d));
    let nl = vec3<f32>(dot3(r0, n), dot3(r1, n), dot3(r2, n));
    var du: vec3<f32>;
    var dv: vec3<f32>;
    if (dent_data[o] == 1u) {
        let axis = dent_data[o + 1u];
        if (!(nl[axis] > 0.0)) { return n; }
        var a = 0u; var sa = 1.0; var b = 2u; var sb = 1.0;
        if (axis == 0u) { a = 2u; sa = -1.0; b = 1u; sb = -1.0; }
        if (axis == 2u) { b = 1u; sb = -1.0; }
        du = vec3<f32>(0.0);
        du[a] = sa;
        dv = vec3<f32>(0.0);
        dv[b] = sb;
    } else {
        if (!(dot3(nl, q) > 0.0)) { return n; }
        du = vec3<f32>(q.z, 0.0, -q.x);
        dv = cross(normalize_or_zero(du), q / sqrt(dot3(q, q)));
    }
    let at = dent_uv(o, q);
    if (at.z == 0.0) { return n; }
    let t = normalize_or_zero(du - nl * dot3(du, nl));
    var b = -normalize_or_zero(dv - nl * dot3(dv, nl));
    if (dot3(b, b) == 0.0) { b = cross(nl, t); }
    var uv = at.xy;
    if (cfg.parallax != 0u) {
        let e = vec3<f32>(dot3(r0, to_eye), dot3(r1, to_eye), dot3(r2, to_eye));
        uv = dent_parallax(o, q, t, b, nl, e, uv);
    }
    let ts = dent_normal_at(o, uv);
    let local = ts.x * t + ts.y * b + ts.z * nl;
    let w = r0 * local.x + r1 * local.y + r2 * local.z;
    let l = sqrt(dot3(w, w));
    if (!(l > 0.0) || !(l < iso_inf())) { return n; }
    return w / l;
}

struct Hit { t: f32, steps: u32 }

fn sphere_trace(kind: u32, o: vec3<f32>, dir: vec3<f32>, cap: f32) -> Hit {
    let eps = cfg.hit_eps;
    let tmax = cfg.max_dist;
    var t = 0.0;
    var last = iso_nan();
    var step = 0u;
    loop {
        let d = field(kind, o + dir * t);
        step += 1u;
        var threshold = eps;
        if (cfg.relative_eps != 0u) { threshold = eps * t; }
        if (d < threshold) {
            // A bound never steps from outside to clearly inside.
            if (cfg.fixed_march == 0u && last > 0.0 && d < -max(threshold, eps) * 4.0) {
                n_overshoots += 1u;
                worst_overshoot = max(worst_overshoot, (last * cfg.step_scale + (-d)) / last);
            }
            break;
        }
        last = d;
        if (iso_is_nan(d)) { t = iso_inf(); break; }
        if (cfg.fixed_march != 0u) { t += cfg.fixed_step; } else { t += d * cfg.step_scale; }
        if (t >= cap && cap <= tmax) {
            t = max(cap - 0.5 * eps, 0.0);
            break;
        } else if (t > tmax) {
            t = iso_inf();
            break;
        } else if (step >= cfg.max_steps) {
            // Out of steps inside the range: a grazing hit, or a miss.
            if (cfg.step_limit_miss != 0u) { t = iso_inf(); }
            break;
        }
    }
    return Hit(t, step);
}

// A traced ray: its hit, and at a hit the point and the normal facing the ray.
struct Traced { t: f32, steps: u32, p: vec3<f32>, n: vec3<f32>, gnorm: f32, mesh: u32 }

fn trace(o: vec3<f32>, d: vec3<f32>, inside: bool) -> Traced {
    // One call of each (the GPU compiler inlines every call of a field).
    var kind = F_SCENE;
    var cap = iso_inf();
    if (inside) {
        kind = F_SURFACES;
    } else if (cfg.any_analytic != 0u) {
        kind = F_REST;
        cap = analytic_cap(o, d);
    }
    // The nearest triangle caps the march too.
    var mh = MeshHit(iso_inf(), NO_MESH, 0u, 0.0, 0.0);
    if (mesh_data[0] > 0u) {
        if (primary_texel.x != NO_TEXEL) {
            mh = raster_hit(o, d, primary_texel);
        } else {
            mh = mesh_cast(o, d, iso_inf(), false);
        }
        cap = iso_min(cap, mh.t);
    }
    primary_texel.x = NO_TEXEL;
    let h = sphere_trace(kind, o, d, cap);
    var r = Traced(h.t, h.steps, vec3<f32>(0.0), vec3<f32>(0.0), 0.0, NO_MESH);
    if (!(abs(h.t) < iso_inf())) { return r; }
    if (mh.mesh != NO_MESH && h.t >= mh.t - cfg.hit_eps && mh.t <= cap) {
        // The march stopped at a triangle: a hit on the mesh, exactly there.
        r.t = mh.t;
        r.p = o + d * mh.t;
        r.mesh = mh.mesh;
        r.gnorm = 1.0;
        var n = mesh_normal(mh);
        if (dot3(n, d) > 0.0) { n = -n; }
        r.n = n;
        return r;
    }
    r.p = o + d * h.t;
    // Inside, the field is unsigned: normals from dual numbers.
    var gkind = F_SCENE;
    var mode = cfg.normals;
    if (inside) {
        gkind = F_SURFACES;
        mode = N_DUAL;
    }
    let g = gradient(gkind, r.p, mode);
    r.gnorm = sqrt(dot3(g, g));
    var n = normalize_or_zero(g);
    if (n.x == 0.0 && n.y == 0.0 && n.z == 0.0) {
        n = -d;
    } else if (dot3(n, d) > 0.0) {
        n = -n;
    }
    r.n = n;
    return r;
}

// ---- shadows (isoray-render's shadow_march) ----
const SH_NONE: u32 = 0u;
const SH_HARD: u32 = 1u;
const SH_SOFT: u32 = 2u;
const SH_IMPROVED: u32 = 3u;
const SH_AALTONEN: u32 = 4u;

fn shadow_march(kind: u32, o: vec3<f32>, l: vec3<f32>, tmax: f32, mode: u32, size: f32) -> f32 {
    var vis = 1.0;
    if (mode == SH_NONE) { return 1.0; }
    var eps = cfg.hit_eps;
    if (cfg.shadow_eps > 0.0) { eps = cfg.shadow_eps; }
    let start = cfg.shadow_start;
    let min_step = max(0.5 * start, eps);
    var t = start;
    if (!(start < tmax)) { return 1.0; }
    var ph = 1e20; // Aaltonen's: the previous step's distance
    for (var step = 0u; step < cfg.shadow_max_steps; step++) {
        let d = field(kind, o + l * t);
        var keep = true;
        if (mode == SH_HARD) {
            if (d < eps) { vis = 0.0; keep = false; } else { t += d; }
        } else if (mode == SH_AALTONEN) {
            if (d < eps) {
                vis = 0.0;
                keep = false;
            } else {
                let y = d * d / (2.0 * ph);
                let dd = sqrt(max(d * d - y * y, 0.0));
                vis = iso_min(vis, dd / (size * max(t - y, 0.0)));
                ph = d;
                t += d;
            }
        } else if (mode == SH_SOFT) {
            if (d < eps) {
                vis = 0.0;
                keep = false;
            } else {
                vis = iso_min(vis, d / (size * t));
                t += d;
            }
        } else {
            vis = iso_min(vis, d / (size * t));
            t += max(d, min_step);
            keep = vis > -1.0;
        }
        if (!(keep && t < tmax)) { break; }
    }
    if (mode == SH_SOFT || mode == SH_AALTONEN) { return clamp(vis, 0.0, 1.0); }
    if (mode == SH_IMPROVED) {
        let r = clamp(vis, -1.0, 1.0);
        return 0.25 * (1.0 + r) * (1.0 + r) * (2.0 - r);
    }
    return vis;
}

// ---- media: the objects a ray is inside, innermost last ----
struct Media { objs: array<u32, 6>, len: u32 }

fn media_top(m: Media) -> u32 { return m.objs[m.len - 1u]; }
fn media_contains(m: Media, o: u32) -> bool {
    for (var i = 0u; i < m.len; i++) { if (m.objs[i] == o) { return true; } }
    return false;
}
fn media_push(m: ptr<function, Media>, o: u32) {
    if ((*m).len < MEDIA) {
        (*m).objs[(*m).len] = o;
        (*m).len += 1u;
    }
}
fn media_remove(m: ptr<function, Media>, o: u32) {
    var i = i32((*m).len) - 1;
    loop {
        if (i < 0) { return; }
        if ((*m).objs[i] == o) { break; }
        i -= 1;
    }
    for (var k = u32(i); k + 1u < (*m).len; k++) { (*m).objs[k] = (*m).objs[k + 1u]; }
    (*m).len -= 1u;
}

fn beer_lambert(sigma: vec3<f32>, length: f32) -> vec3<f32> { return exp(-sigma * length); }

fn interface_transmittance(m: Mat) -> vec3<f32> {
    return vec3<f32>(m.transparency) * (vec3<f32>(1.0) - m.reflectivity);
}

// Object i's material; i past the objects is mesh i − n_objects.
fn object_mat(i: u32) -> Mat {
    if (i >= cfg.n_objects) { return mats[mesh_data[1u + 16u * (i - cfg.n_objects) + 12u]]; }
    return mats[objs[i].material];
}

// The transparent object whose surface is nearest p.
fn nearest_clear(p: vec3<f32>) -> u32 {
    if (cfg.n_objects <= 1u) { return 0u; }
    var best = iso_inf();
    var obj = 0u;
    for (var j = 0u; j < cfg.n_objects; j++) {
        if (!is_clear(j)) { continue; }
        let d = abs(iso_object(j, p));
        n_evals += 1u;
        if (d < best) { best = d; obj = j; }
    }
    return obj;
}

// What straight shadow rays keep through the transparent objects
// (isoray-render's Worker::transmission, one ray).
fn transmission(o: vec3<f32>, l: vec3<f32>, tmax: f32, start: Media) -> vec3<f32> {
    let off = OFFSET * cfg.hit_eps;
    var out = vec3<f32>(1.0);
    var origin = o;
    var left = tmax;
    var media = start;
    // The step past the last interface (absorbed over too).
    var step = off;
    for (var seg = 0u; seg < MAX_SHADOW_SEGMENTS; seg++) {
        let inside = media.len > 0u;
        var kind = F_CLEAR;
        if (inside) { kind = F_CLEAR_SURFACES; }
        var h = sphere_trace(kind, origin, l, iso_inf());
        var obj = 0u;
        if (inside && field(F_CLEAR, origin) > 0.0) {
            // The step carried the ray out of every transparent object (a
            // grazing chord shorter than it): it left the top one within it.
            h.t = 0.0;
            obj = media_top(media);
        } else {
            if (!(h.t < left)) {
                if (inside) { out *= beer_lambert(object_mat(media_top(media)).absorption, min(left, 1e4)); }
                break;
            }
            obj = nearest_clear(origin + l * h.t);
        }
        let p = origin + l * h.t;
        if (inside) { out *= beer_lambert(object_mat(media_top(media)).absorption, h.t + step); }
        if (media_contains(media, obj)) {
            media_remove(&media, obj);
        } else {
            out *= interface_transmittance(object_mat(obj));
            media_push(&media, obj);
        }
        // OFFSET hit epsilons of depth past the interface, not of length
        // along the ray (the CPU's MIN_COS bounds the cosine).
        let c = abs(dot3(normalize_or_zero(gradient(F_CLEAR, p, cfg.normals)), l));
        step = off / max(c, 0.05);
        origin = p + l * step;
        left -= h.t + step;
        if (!(max3(out) > 1e-4 && left > 0.0)) { break; }
    }
    return out;
}

// ---- lights (isoray-shade's lights) ----
fn hash(x0: u32) -> u32 {
    var x = x0;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

fn fract1(x: f32) -> f32 { return x - trunc(x); }

fn lattice(j: u32, n: u32, seed: u32) -> vec2<f32> {
    let h1 = f32(hash(seed)) / 4294967295.0;
    let h2 = f32(hash(seed ^ 0x68e31da4u)) / 4294967295.0;
    let u = fract1((f32(j) + 0.5) / f32(n) + h1);
    let v = fract1(f32(j) * 0.618034 + h2);
    return vec2<f32>(u, v);
}

struct Incident { dir: vec3<f32>, dist: f32, attenuation: f32 }

fn attenuation(li: Light, d: f32) -> f32 {
    if (abs(d) < iso_inf()) {
        return 1.0 / max(li.att_c + li.att_l * d + li.att_q * d * d, 1e-12);
    }
    return 1.0;
}

fn towards(p: vec3<f32>, q: vec3<f32>) -> Incident {
    let d = q - p;
    return Incident(normalize_or_zero(d), sqrt(dot3(d, d)), 0.0);
}

fn is_area(li: Light) -> bool { return li.kind >= 2u; }

fn light_sample(li: Light, p: vec3<f32>, j: u32, n: u32, seed: u32) -> Incident {
    var inc: Incident;
    let pos = vec3<f32>(li.px, li.py, li.pz);
    switch li.kind {
        case 0u: { inc = Incident(pos, iso_inf(), 0.0); }
        case 1u: { inc = towards(p, pos); }
        case 2u: {
            let w = normalize_or_zero(pos - p);
            var a = vec3<f32>(1.0, 0.0, 0.0);
            if (abs(w.x) > 0.9) { a = vec3<f32>(0.0, 1.0, 0.0); }
            let e1 = normalize_or_zero(cross(w, a));
            let e2 = cross(w, e1);
            let uv = lattice(j, n, seed);
            let r = li.radius * sqrt(uv.x);
            let phi = 6.2831855 * uv.y;
            inc = towards(p, pos + e1 * (r * cos(phi)) + e2 * (r * sin(phi)));
        }
        default: {
            let ab = lattice(j, n, seed);
            let u = vec3<f32>(li.ux, li.uy, li.uz);
            let v = vec3<f32>(li.vx, li.vy, li.vz);
            inc = towards(p, pos + u * (ab.x - 0.5) + v * (ab.y - 0.5));
        }
    }
    inc.attenuation = attenuation(li, inc.dist);
    return inc;
}

// ---- materials (isoray-shade's MaterialSample, blend and checker) ----
fn lerp3(a: vec3<f32>, b: vec3<f32>, h: f32) -> vec3<f32> { return a * (1.0 - h) + b * h; }

fn mix_mat(a: Mat, b: Mat, h: f32) -> Mat {
    var m = a;
    m.ambient = lerp3(a.ambient, b.ambient, h);
    m.diffuse = lerp3(a.diffuse, b.diffuse, h);
    m.specular = lerp3(a.specular, b.specular, h);
    m.shininess = a.shininess + (b.shininess - a.shininess) * h;
    m.emission = lerp3(a.emission, b.emission, h);
    m.reflectivity = lerp3(a.reflectivity, b.reflectivity, h);
    m.transparency = a.transparency + (b.transparency - a.transparency) * h;
    m.ior = a.ior + (b.ior - a.ior) * h;
    m.absorption = lerp3(a.absorption, b.absorption, h);
    if (h >= 0.5) {
        m.model = b.model;
        m.specular_function = b.specular_function;
        m.fresnel = b.fresnel;
        m.spec_fresnel = b.spec_fresnel;
    }
    return m;
}

fn blend_weight(a: f32, b: f32, k: f32) -> f32 { return clamp(0.5 + 0.5 * (a - b) / k, 0.0, 1.0); }

fn shade_smooth_min(a: f32, b: f32, k: f32) -> f32 {
    let h = max(k - abs(a - b), 0.0);
    return min(a, b) - h * h * 0.25 / k;
}

fn checker_odd(p: vec3<f32>, size: f32) -> bool {
    let inv = 1.0 / size;
    let cell = floor(p * inv);
    let c = cell.x + cell.y + cell.z;
    return c - 2.0 * floor(c * 0.5) == 1.0;
}

struct Surface { m: Mat, obj: u32 }

// The material at p and its object: the nearest object's, or blended
// across the smooth union (isoray-render's Worker::materials).
fn material_at(p: vec3<f32>, unsigned: bool) -> Surface {
    var out = object_mat(0u);
    var obj = 0u;
    if (cfg.n_objects > 1u) {
        var k = cfg.blend;
        var km = cfg.material_blend_k;
        if (unsigned) {
            k = 0.0;
            km = 0.0;
        }
        var acc = 0.0;
        var best = 0.0;
        for (var j = 0u; j < cfg.n_objects; j++) {
            let b = iso_object(j, p);
            n_evals += 1u;
            var key = b;
            if (unsigned) { key = abs(b); }
            if (j == 0u) {
                acc = b;
                best = key;
                continue;
            }
            let a = acc;
            if (key < best) {
                best = key;
                obj = j;
            }
            if (k > 0.0) {
                out = mix_mat(out, object_mat(j), blend_weight(a, b, km));
                acc = shade_smooth_min(a, b, k);
            } else if (obj == j) {
                out = object_mat(j);
                acc = b;
            }
        }
    }
    let own = object_mat(obj);
    if (own.checker_other != NO_CHECKER && checker_odd(p, own.checker_size)) {
        out = mats[own.checker_other];
    }
    return Surface(out, obj);
}

// A mesh's material at p (its checker applied), and its object index
// after the objects'.
fn mesh_surface(k: u32, p: vec3<f32>) -> Surface {
    let obj = cfg.n_objects + k;
    var out = object_mat(obj);
    if (out.checker_other != NO_CHECKER && checker_odd(p, out.checker_size)) {
        out = mats[out.checker_other];
    }
    return Surface(out, obj);
}

// ---- local illumination (isoray-shade's phong) ----
fn specular_factor(f: u32, c0: f32, n: f32) -> f32 {
    let c = clamp(c0, 0.0, 1.0);
    if (f == 0u) { return iso_pow(c, n); }
    return c / (n - n * c + c);
}

fn direct_light(s: Mat, n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, local: vec3<f32>, arriving: vec3<f32>) -> vec3<f32> {
    let ndl = dot3(n, l);
    if (ndl <= 0.0) { return vec3<f32>(0.0); }
    var c: f32;
    if (s.model == 0u) {
        let r = 2.0 * ndl * n - l;
        c = dot3(r, v);
    } else {
        c = dot3(n, normalize_or_zero(l + v));
    }
    let diffuse = s.diffuse * ndl;
    var specular = s.specular * specular_factor(s.specular_function, c, s.shininess);
    if (s.spec_fresnel != 0u) {
        // isoray-shade's specular_fresnel: 0.04 + 0.96·(1 − h·l)⁵.
        let hv = normalize_or_zero(l + v);
        let x = clamp(1.0 - max(dot3(hv, l), 0.0), 0.0, 1.0);
        let x2 = x * x;
        specular *= 0.04 + 0.96 * (x2 * x2 * x);
    }
    return arriving * (local * diffuse + specular);
}

// ---- optics (isoray-shade's optics) ----
fn reflect_dir(i: vec3<f32>, n: vec3<f32>) -> vec3<f32> { return i - 2.0 * dot3(n, i) * n; }

struct Split { reflect: vec3<f32>, transmit: vec3<f32>, local: vec3<f32>, refracted: vec3<f32>, can_refract: bool }

fn fresnel(model: u32, cos1_in: f32, n1: f32, n2: f32) -> f32 {
    let cos1 = clamp(cos1_in, 0.0, 1.0);
    let sin2 = n1 / n2 * sqrt(max(1.0 - cos1 * cos1, 0.0));
    if (sin2 >= 1.0) { return 1.0; }
    let cos2 = sqrt(1.0 - sin2 * sin2);
    if (model == 0u) { return 0.0; }
    if (model == 1u) {
        let q = (n1 - n2) / (n1 + n2);
        let r0 = q * q;
        var c = cos1;
        if (n1 > n2) { c = cos2; }
        let m = 1.0 - c;
        return r0 + (1.0 - r0) * (m * m * m * m * m);
    }
    let rs = (n1 * cos1 - n2 * cos2) / (n1 * cos1 + n2 * cos2);
    let rp = (n1 * cos2 - n2 * cos1) / (n1 * cos2 + n2 * cos1);
    return 0.5 * (rs * rs + rp * rp);
}

fn surface_interface(s: Mat, i: vec3<f32>, n: vec3<f32>, cos1: f32, n1: f32, n2: f32) -> Split {
    var out: Split;
    out.can_refract = false;
    if (s.transparency > 0.0) {
        let eta = n1 / n2;
        let c1 = clamp(-dot3(n, i), -1.0, 1.0);
        let k = 1.0 - eta * eta * (1.0 - c1 * c1);
        if (k >= 0.0) {
            out.refracted = normalize_or_zero(eta * i + (eta * c1 - sqrt(k)) * n);
            out.can_refract = true;
        }
    }
    let f = fresnel(s.fresnel, cos1, n1, n2);
    let tir = s.transparency > 0.0 && !out.can_refract;
    let kr = s.reflectivity;
    let reflect = kr + (vec3<f32>(1.0) - kr) * f;
    let rest = vec3<f32>(1.0) - reflect;
    if (tir) {
        out.reflect = reflect + rest * s.transparency;
        out.transmit = vec3<f32>(0.0);
    } else {
        out.reflect = reflect;
        out.transmit = rest * s.transparency;
    }
    out.local = rest * (1.0 - s.transparency);
    return out;
}

fn is_optical(s: Mat) -> bool { return max3(s.reflectivity) > 0.0 || s.transparency > 0.0; }

// ---- environment (isoray-scene's Environment::radiance) ----
fn env_texel(base: u32, w: u32, h: u32, x: f32, y: f32) -> vec3<f32> {
    let xi = i32(x) % i32(w);
    let xw = u32(select(xi, xi + i32(w), xi < 0));
    let yr = min(u32(y), h - 1u);
    let k = base + 3u * (yr * w + xw);
    return vec3<f32>(env[k], env[k + 1u], env[k + 2u]);
}

fn env_bilinear(face: u32, u: f32, v: f32) -> vec3<f32> {
    // Header: per face (up to 6) width, height, offset of its texels.
    let w = bitcast<u32>(env[3u * face]);
    let h = bitcast<u32>(env[3u * face + 1u]);
    let base = bitcast<u32>(env[3u * face + 2u]);
    let fw = f32(w);
    let fh = f32(h);
    let x = u * fw - 0.5;
    let y = clamp(v * fh - 0.5, 0.0, fh - 1.0);
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let a = env_texel(base, w, h, x0, y0);
    let b = env_texel(base, w, h, x0 + 1.0, y0);
    let c = env_texel(base, w, h, x0, y0 + 1.0);
    let d = env_texel(base, w, h, x0 + 1.0, y0 + 1.0);
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    return top + (bottom - top) * fy;
}

fn sky(d0: vec3<f32>) -> vec3<f32> {
    if (cfg.env_kind == 0u) { return vec3<f32>(cfg.bg_r, cfg.bg_g, cfg.bg_b); }
    let c = cfg.env_cos;
    let s = cfg.env_sin;
    let d = vec3<f32>(c * d0.x + s * d0.z, d0.y, -s * d0.x + c * d0.z);
    var rgb: vec3<f32>;
    if (cfg.env_kind == 1u) {
        let u = 0.5 + iso_atan2(d.x, -d.z) / 6.2831855;
        let v = iso_acos(clamp(d.y, -1.0, 1.0)) / 3.1415927;
        rgb = env_bilinear(0u, u, v);
    } else if (cfg.env_kind == 2u) {
        let ax = abs(d.x);
        let ay = abs(d.y);
        let az = abs(d.z);
        var face: u32;
        var sc: f32;
        var tc: f32;
        var ma: f32;
        if (ax >= ay && ax >= az) {
            if (d.x > 0.0) { face = 0u; sc = -d.z; tc = -d.y; } else { face = 1u; sc = d.z; tc = -d.y; }
            ma = ax;
        } else if (ay >= az) {
            if (d.y > 0.0) { face = 2u; sc = d.x; tc = d.z; } else { face = 3u; sc = d.x; tc = -d.z; }
            ma = ay;
        } else {
            if (d.z > 0.0) { face = 4u; sc = d.x; tc = -d.y; } else { face = 5u; sc = -d.x; tc = -d.y; }
            ma = az;
        }
        ma = max(ma, 1e-30);
        let u = 0.5 * (sc / ma + 1.0);
        let v = 0.5 * (tc / ma + 1.0);
        rgb = env_bilinear(face, clamp(u, 0.0, 1.0), v);
    } else {
        // Gradient: header holds zenith, horizon, nadir.
        let zenith = vec3<f32>(env[0], env[1], env[2]);
        let horizon = vec3<f32>(env[3], env[4], env[5]);
        let nadir = vec3<f32>(env[6], env[7], env[8]);
        var to = zenith;
        var w = d.y;
        if (!(d.y >= 0.0)) { to = nadir; w = -d.y; }
        w = clamp(w, 0.0, 1.0);
        rgb = horizon + (to - horizon) * w;
    }
    return rgb * cfg.env_k;
}

// ---- shading (isoray-render's Worker::shade, one hit) ----
fn ambient_occlusion(p: vec3<f32>, n: vec3<f32>) -> f32 {
    if (cfg.ao == 0u || cfg.ao_intensity == 0.0) { return 1.0; }
    var wsum = 0.0;
    var w = 1.0;
    for (var i = 1u; i <= cfg.ao_samples; i++) {
        w *= 0.5;
        wsum += w;
    }
    var occ = 0.0;
    w = 1.0;
    for (var i = 1u; i <= cfg.ao_samples; i++) {
        let h = cfg.ao_step * f32(i);
        w *= 0.5;
        let d = field(F_SCENE, p + n * h);
        var wi = w / wsum;
        if (cfg.ao_uniform != 0u) { wi = 1.0; }
        occ += wi * (h - d) / h;
    }
    return clamp(1.0 - cfg.ao_intensity * occ, 0.0, 1.0);
}

fn shade(p: vec3<f32>, n: vec3<f32>, dir: vec3<f32>, s: Mat, local: vec3<f32>, media: Media, seed: u32) -> vec3<f32> {
    var ao = ambient_occlusion(p, n);
    if (media.len > 0u) { ao = 1.0; }
    // The Unity thesis's conventions: AO and shadows may darken the whole
    // colour (`factor`) instead of the ambient and direct terms.
    var a = ao;
    if (cfg.ao_all != 0u) { a = 1.0; }
    let ambient_light = vec3<f32>(cfg.amb_r, cfg.amb_g, cfg.amb_b);
    var color = s.emission + local * s.ambient * a + local * ambient_light * s.diffuse * a;
    let shadow_all = cfg.shadow_all != 0u && cfg.shadows != SH_NONE;
    var factor = 1.0;
    let v = -dir;
    var occluders = F_SCENE;
    if (cfg.n_clear > 0u) { occluders = F_OPAQUE; }
    for (var li = 0u; li < cfg.n_lights; li++) {
        let light = lights[li];
        var ns = 1u;
        if (is_area(light)) { ns = light.samples; }
        let area = ns > 1u || is_area(light);
        var mode = cfg.shadows;
        if (area && cfg.shadows != SH_NONE) { mode = SH_HARD; }
        let radiance = vec3<f32>(light.cr, light.cg, light.cb) * (light.intensity / f32(ns));
        var light_factor = 0.0;
        for (var j = 0u; j < ns; j++) {
            let inc = light_sample(light, p, j, ns, seed + li * 0x9E3779B9u);
            let l = inc.dir;
            if (!(dot3(n, l) > 0.0)) {
                light_factor += cfg.shadow_floor / f32(ns);
                continue;
            }
            let o = p + n * (2.0 * cfg.hit_eps);
            let tmax = min(inc.dist, cfg.shadow_max_dist);
            var vis = shadow_march(occluders, o, l, tmax, mode, light.size);
            // Meshes block what reaches them (hard shadows).
            if (mode != SH_NONE && vis > 0.0 && mesh_data[0] > 0u) {
                if (mesh_cast(o, l, tmax, true).mesh != NO_MESH) { vis = 0.0; }
            }
            var through = vec3<f32>(1.0);
            if (cfg.n_clear > 0u && cfg.shadows != SH_NONE && vis > 0.0) {
                through = transmission(o, l, tmax, media);
            }
            if (mode != SH_NONE) {
                n_shadow += 1u;
                if (cfg.shadow_exponent != 1.0) { vis = iso_pow(vis, cfg.shadow_exponent); }
                vis = cfg.shadow_floor + (1.0 - cfg.shadow_floor) * vis;
            }
            if (shadow_all) {
                light_factor += vis / f32(ns);
                vis = 1.0;
            }
            let arriving = radiance * inc.attenuation * vis * through;
            color += direct_light(s, n, v, l, local, arriving);
        }
        if (shadow_all) { factor *= light_factor; }
    }
    if (cfg.ao_all != 0u) { factor *= ao; }
    return color * factor;
}

// ---- paths (isoray-render's whitted module), depth first ----
struct PathRay { o: vec3<f32>, d: vec3<f32>, w: vec3<f32>, src: vec3<f32>, media: Media, depth: u32 }

// Each lane's scratch, in a storage buffer: first its stack of rays
// waiting to be traced, `cfg.stack_cap` entries of 6 vec4s (max_depth + 1
// when some material reflects or refracts, else none), then the
// interpreting kernel's `cfg.reg_slots` registers (`iso_regs`,
// `iso_reg_base`: see isoray_shape::wgsl::interpreter). Not private
// arrays: lavapipe compiles a private array of structures indexed at run
// time for minutes (72 s for a stack of 66, 3 s for 4), and every lane
// would hold its whole size in registers.
var<private> stack_base: u32;

fn ray_push(k: u32, r: PathRay) {
    let b = stack_base + 6u * k;
    let m = r.media.objs;
    iso_regs[b] = vec4<f32>(r.o, 0.0);
    iso_regs[b + 1u] = vec4<f32>(r.d, 0.0);
    iso_regs[b + 2u] = vec4<f32>(r.w, 0.0);
    iso_regs[b + 3u] = vec4<f32>(r.src, 0.0);
    iso_regs[b + 4u] = bitcast<vec4<f32>>(vec4<u32>(m[0], m[1], m[2], m[3]));
    iso_regs[b + 5u] = bitcast<vec4<f32>>(vec4<u32>(m[4], m[5], r.media.len, r.depth));
}

fn ray_pop(k: u32) -> PathRay {
    let b = stack_base + 6u * k;
    let m0 = bitcast<vec4<u32>>(iso_regs[b + 4u]);
    let m1 = bitcast<vec4<u32>>(iso_regs[b + 5u]);
    var media: Media;
    media.objs = array<u32, 6>(m0.x, m0.y, m0.z, m0.w, m1.x, m1.y);
    media.len = m1.z;
    return PathRay(iso_regs[b].xyz, iso_regs[b + 1u].xyz, iso_regs[b + 2u].xyz, iso_regs[b + 3u].xyz, media, m1.w);
}

// The objects whose surfaces pass within a few hit epsilons of p (the
// nearest first): touching transparent objects share an interface.
struct Touching { objs: array<u32, 6>, len: u32 }

fn touching(p: vec3<f32>, nearest: u32) -> Touching {
    var t: Touching;
    t.objs[0] = nearest;
    t.len = 1u;
    if (cfg.n_clear < 2u) { return t; }
    let near = 4.0 * OFFSET * cfg.hit_eps;
    for (var j = 0u; j < cfg.n_objects; j++) {
        if (!is_clear(j)) { continue; }
        let d = iso_object(j, p);
        n_evals += 1u;
        if (abs(d) < near && j != nearest && t.len < 6u) {
            t.objs[t.len] = j;
            t.len += 1u;
        }
    }
    return t;
}

// What a path gives: its colour, or with `first` the primary hit alone
// (its distance, steps, normal and albedo; nothing is shaded).
struct PathResult { color: vec3<f32>, t: f32, steps: u32, n: vec3<f32>, albedo: vec3<f32>, gnorm: f32 }

fn trace_path(o: vec3<f32>, d: vec3<f32>, seed0: u32, first: bool) -> PathResult {
    var res = PathResult(vec3<f32>(0.0), iso_inf(), 0u, vec3<f32>(0.0), vec3<f32>(0.0), 0.0);
    var sum = vec3<f32>(0.0);
    var top = 0u;
    var m0: Media;
    m0.len = 0u;
    var ray = PathRay(o, d, vec3<f32>(1.0), o, m0, 0u);
    let eps = cfg.hit_eps;
    loop {
        let inside = ray.media.len > 0u;
        let h = trace(ray.o, ray.d, inside);
        if (first) {
            res.t = h.t;
            res.steps = h.steps;
            res.n = h.n;
            res.gnorm = h.gnorm;
        }
        if (!(abs(h.t) < iso_inf())) {
            if (!inside) { sum += ray.w * sky(ray.d); }
            continue;
        }
        var surf: Surface;
        var hn = h.n;
        if (h.mesh != NO_MESH) {
            surf = mesh_surface(h.mesh, h.p);
        } else {
            surf = material_at(h.p, inside);
            // Dented objects' normals tilted by their normal maps.
            hn = dent_normal(surf.obj, h.p, h.n, -ray.d);
        }
        if (first) {
            res.n = hn;
            res.albedo = surf.m.diffuse;
            return res;
        }
        if (inside) {
            let q = h.p - ray.src;
            ray.w *= beer_lambert(object_mat(media_top(ray.media)).absorption, sqrt(dot3(q, q)));
        }
        var local = vec3<f32>(1.0);
        if (is_optical(surf.m)) {
            let media = ray.media;
            var n1 = 1.0;
            if (media.len > 0u) { n1 = object_mat(media_top(media)).ior; }
            var after = media;
            let tch = touching(h.p, surf.obj);
            for (var k = 0u; k < tch.len; k++) {
                let ob = tch.objs[k];
                if (media_contains(after, ob)) { media_remove(&after, ob); } else { media_push(&after, ob); }
            }
            var n2 = 1.0;
            if (after.len > 0u) { n2 = object_mat(media_top(after)).ior; }
            let at = surface_interface(surf.m, ray.d, hn, -dot3(hn, ray.d), n1, n2);
            local = at.local;
            if (ray.depth < cfg.max_depth) {
                let off = OFFSET * eps;
                let wr = ray.w * at.reflect;
                if (max3(wr) >= cfg.min_weight && top < cfg.stack_cap) {
                    ray_push(top, PathRay(h.p + hn * off, reflect_dir(ray.d, hn), wr, h.p, media, ray.depth + 1u));
                    top += 1u;
                    n_reflected += 1u;
                }
                if (at.can_refract) {
                    let wt = ray.w * at.transmit;
                    if (max3(wt) >= cfg.min_weight && top < cfg.stack_cap) {
                        ray_push(top, PathRay(h.p - hn * off, at.refracted, wt, h.p, after, ray.depth + 1u));
                        top += 1u;
                        n_refracted += 1u;
                    }
                }
            }
        }
        let seed = seed0 + ray.depth;
        sum += ray.w * shade(h.p, hn, ray.d, surf.m, local, ray.media, seed);
        continuing {
            // Depth first, as the CPU recurses: the last ray pushed next.
            let done = top == 0u;
            if (!done) {
                top -= 1u;
                ray = ray_pop(top);
            }
            break if done;
        }
    }
    res.color = sum;
    return res;
}

// ---- cameras and pixels ----
fn camera_dir(x: f32, y: f32) -> vec3<f32> {
    let fw = f32(cfg.width);
    let fh = f32(cfg.height);
    if (cfg.projection == 1u) {
        let phi = (x / fw - 0.5) * 6.2831855;
        let theta = y / fh * 3.1415927;
        return vec3<f32>(sin(theta) * sin(phi), cos(theta), -sin(theta) * cos(phi));
    }
    let ndc_x = x / fw * 2.0 - 1.0;
    let ndc_y = 1.0 - y / fh * 2.0;
    let fwd = vec3<f32>(cfg.fwd_x, cfg.fwd_y, cfg.fwd_z);
    let right = vec3<f32>(cfg.right_x, cfg.right_y, cfg.right_z);
    let up = vec3<f32>(cfg.up_x, cfg.up_y, cfg.up_z);
    let v = fwd + ndc_x * cfg.tan_half * cfg.aspect * right + ndc_y * cfg.tan_half * up;
    return v / sqrt(dot3(v, v));
}

fn heat(x0: f32) -> vec3<f32> {
    var stops = array<vec3<f32>, 5>(
        vec3<f32>(0.0, 0.0, 0.5),
        vec3<f32>(0.0, 0.3, 1.0),
        vec3<f32>(0.0, 0.8, 0.2),
        vec3<f32>(1.0, 0.9, 0.0),
        vec3<f32>(1.0, 0.0, 0.0),
    );
    let x = clamp(x0, 0.0, 1.0) * 4.0;
    let i = min(u32(floor(x)), 3u);
    let f = x - f32(i);
    return stops[i] + (stops[i + 1u] - stops[i]) * f;
}

const V_SHADED: u32 = 0u;
const V_STEPS: u32 = 1u;
const V_NORMALS: u32 = 2u;
const V_UV: u32 = 3u;
const V_MASK: u32 = 4u;
const V_GRADIENT: u32 = 5u;

// isoray-render's uv_colour: the image-plane coordinates of a camera ray
// as red and green, darkened on a grid every 0.25.
fn uv_colour(d: vec3<f32>) -> vec3<f32> {
    let fwd = vec3<f32>(cfg.fwd_x, cfg.fwd_y, cfg.fwd_z);
    let right = vec3<f32>(cfg.right_x, cfg.right_y, cfg.right_z);
    let up = vec3<f32>(cfg.up_x, cfg.up_y, cfg.up_z);
    let z = dot3(d, fwd) * cfg.tan_half;
    let u = dot3(d, right) / z;
    let v = dot3(d, up) / z;
    let c = vec3<f32>(clamp(0.5 + 0.5 * u / cfg.aspect, 0.0, 1.0), clamp(0.5 + 0.5 * v, 0.0, 1.0), 0.25);
    let lines = 2.9 / f32(cfg.height);
    let ou = abs(4.0 * u - iso_round(4.0 * u));
    let ov = abs(4.0 * v - iso_round(4.0 * v));
    if (ou < lines || ov < lines) { return c * 0.25; }
    return c;
}

fn put(base: u32, k: u32, v: f32) { out[base + k] = bitcast<u32>(v); }

fn add64(k: u32, v: u32) {
    let old = atomicAdd(&stats[2u * k], v);
    if (old + v < old) { atomicAdd(&stats[2u * k + 1u], 1u); }
}

// isoray-render's sample_offset: where sample (sx, sy) of pixel (px, py)
// lies in the pixel (grid, rotated grid, jittered).
fn sample_offset(aa: u32, sx: u32, sy: u32, px: u32, py: u32) -> vec2<f32> {
    let n = f32(aa);
    if (cfg.aa_pattern == 1u) {
        return vec2<f32>((f32(sx * aa + sy) + 0.5) / (n * n), (f32(sy * aa + aa - 1u - sx) + 0.5) / (n * n));
    }
    if (cfg.aa_pattern == 2u) {
        let h1 = hash(hash(hash(px) ^ py) ^ (sy * aa + sx));
        let h2 = hash(h1);
        let u = f32(h1 >> 8u) / 16777216.0;
        let v = f32(h2 >> 8u) / 16777216.0;
        return vec2<f32>((f32(sx) + u) / n, (f32(sy) + v) / n);
    }
    return vec2<f32>((f32(sx) + 0.5) / n, (f32(sy) + 0.5) / n);
}

// The lanes of one pixel: its aa × aa samples, then (with `cfg.aovs`)
// its centre ray. One sample per lane, not a loop over the samples in one
// lane: lavapipe draws wrong pixels when the interpreting kernel's tracer
// sits inside such a loop (see docs/BENCHMARKS.md, "GPU renderer"), and
// more, shorter lanes suit a GPU better.
fn lanes_per_pixel() -> u32 {
    var rays = cfg.aa * cfg.aa;
    if (cfg.aovs != 0u) { rays += 1u; }
    return rays;
}

// Words (vec4s) of lane scratch: the ray stack and the registers, at least
// one, where a sample lane leaves its colour for `resolve`.
fn lane_words() -> u32 { return max(1u, 6u * cfg.stack_cap + cfg.reg_slots); }

// Sample k of pixel (x, y). A colour sample returns what it adds to the
// pixel's sum (its colour, or its debug view); the centre ray (k = aa²,
// with AOVs) writes the depth, normal and albedo at `base` in `out`
// (colour, depth, normal, albedo: 10 words, or 3 without AOVs).
fn render_sample(x: u32, y: u32, k: u32, base: u32) -> vec3<f32> {
    let origin = vec3<f32>(cfg.cam_x, cfg.cam_y, cfg.cam_z);
    let bg = vec3<f32>(cfg.bg_r, cfg.bg_g, cfg.bg_b);
    // Seeds as the CPU's tiles of 16 × 16 pixels number their samples.
    let tx = (x / 16u) * 16u;
    let ty = (y / 16u) * 16u;
    let tw = min(16u, cfg.width - tx);
    let tile_seed = hash(hash(tx) ^ ty);
    let aa = cfg.aa;
    let sample = k < aa * aa;
    let sx = k % aa;
    let sy = k / aa;
    var fx = f32(x) + 0.5;
    var fy = f32(y) + 0.5;
    if (sample) {
        let off = sample_offset(aa, sx, sy, x, y);
        fx = f32(x) + off.x;
        fy = f32(y) + off.y;
    }
    let d = camera_dir(fx, fy);
    // The prepass's texel of this ray: a sample of the grid, or the
    // centre ray where it is the middle sample (aa odd).
    if (cfg.raster != 0u) {
        if (sample) {
            primary_texel = vec2<u32>(x * aa + sx, y * aa + sy);
        } else if (aa % 2u == 1u) {
            primary_texel = vec2<u32>(x * aa + aa / 2u, y * aa + aa / 2u);
        }
    }
    let index = (((y - ty) * tw + (x - tx)) * aa + sy) * aa + sx;
    let first = !sample || cfg.view != V_SHADED;
    let r = trace_path(origin, d, hash(tile_seed ^ index), first);
    if (!sample) {
        put(base, 3u, r.t);
        put(base, 4u, r.n.x);
        put(base, 5u, r.n.y);
        put(base, 6u, r.n.z);
        put(base, 7u, r.albedo.x);
        put(base, 8u, r.albedo.y);
        put(base, 9u, r.albedo.z);
        return vec3<f32>(0.0);
    }
    if (cfg.view == V_SHADED) { return r.color; }
    if (cfg.view == V_STEPS) { return heat(f32(r.steps) / f32(cfg.max_steps)); }
    if (cfg.view == V_UV) { return uv_colour(d); }
    if (cfg.view == V_MASK) {
        if (abs(r.t) < iso_inf()) { return vec3<f32>(1.0); }
        return vec3<f32>(0.0);
    }
    if (cfg.view == V_GRADIENT && abs(r.t) < iso_inf()) { return heat(0.5 * r.gnorm); }
    if (cfg.view == V_NORMALS && abs(r.t) < iso_inf()) { return r.n * 0.5 + 0.5; }
    return bg;
}

// One lane per sample: lane x of a band row is sample x % lanes_per_pixel()
// of pixel x / lanes_per_pixel(). A colour sample leaves its colour in its
// scratch for `resolve`.
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    if (lane == 0u) {
        for (var k = 0u; k < 6u; k++) { atomicStore(&wg_stats[k], 0u); }
    }
    workgroupBarrier();
    let rays = lanes_per_pixel();
    if (id.x < cfg.region_w * rays && id.y < cfg.region_h) {
        n_evals = 0u;
        n_reflected = 0u;
        n_refracted = 0u;
        n_shadow = 0u;
        n_overshoots = 0u;
        worst_overshoot = 0.0;
        let px = id.x / rays;
        let k = id.x % rays;
        let lane_index = id.y * cfg.region_w * rays + id.x;
        stack_base = lane_index * lane_words();
        iso_reg_base = stack_base + 6u * cfg.stack_cap;
        let c = render_sample(cfg.x0 + px, cfg.y0 + id.y, k, cfg.record * (id.y * cfg.region_w + px));
        iso_regs[stack_base] = vec4<f32>(c, 0.0);
        atomicAdd(&wg_stats[0], n_evals);
        atomicAdd(&wg_stats[1], n_reflected);
        atomicAdd(&wg_stats[2], n_refracted);
        atomicAdd(&wg_stats[3], n_shadow);
        atomicAdd(&wg_stats[4], n_overshoots);
        atomicMax(&wg_stats[5], bitcast<u32>(worst_overshoot));
    }
    workgroupBarrier();
    if (lane == 0u) {
        for (var k = 0u; k < 5u; k++) { add64(k, atomicLoad(&wg_stats[k])); }
        atomicMax(&stats[10], atomicLoad(&wg_stats[5]));
    }
}

// Each pixel's colour: the mean of its samples' colours, summed in sample
// order as the CPU sums them.
@compute @workgroup_size(64)
fn resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = id.x;
    if (pixel >= cfg.region_w * cfg.region_h) { return; }
    let rays = lanes_per_pixel();
    let first = (pixel / cfg.region_w) * cfg.region_w * rays + (pixel % cfg.region_w) * rays;
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < cfg.aa * cfg.aa; k++) {
        sum += iso_regs[(first + k) * lane_words()].xyz;
    }
    let color = sum * (1.0 / f32(cfg.aa * cfg.aa));
    let base = cfg.record * pixel;
    put(base, 0u, color.x);
    put(base, 1u, color.y);
    put(base, 2u, color.z);
}
