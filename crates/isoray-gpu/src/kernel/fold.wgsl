// ---- the fields and their objects (isoray-shape's fold, isoray-render's objects) ----
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

// Whether a loop over the objects reads their distances from iso_all (the
// compiled kernel without cells: every object's code once, in a row) or
// calls iso_object(i, p) per object (the interpreter, or cells' lists).
const ALL_AT_ONCE: bool = COMPILED_OBJECTS && !USE_CELLS;

// ---- fold cells (isoray-gpu's cells: the objects that can change each
// field's fold in a cell of an octree over the domain) ----
@group(0) @binding(13) var<storage, read> cells: array<u32>;
const NO_CELL: u32 = 0xffffffffu;
const CELL_HEADER: u32 = 8u;
const CELL_NODE_WORDS: u32 = 9u;
// The last cell a lane found, and its box: the next point is usually in it.
var<private> cell_node: u32 = 0xffffffffu;
var<private> cell_lo: vec3<f32>;
var<private> cell_hi: vec3<f32>;

fn cell_f(i: u32) -> f32 { return bitcast<f32>(cells[i]); }

// The leaf cell that holds p, or NO_CELL (no cells, or p outside them).
fn find_cell(p: vec3<f32>) -> u32 {
    if (!USE_CELLS || cells[6] == 0u) { return NO_CELL; }
    if (cell_node != NO_CELL && all(p >= cell_lo) && all(p <= cell_hi)) { return cell_node; }
    var lo = vec3<f32>(cell_f(0u), cell_f(1u), cell_f(2u));
    var hi = vec3<f32>(cell_f(3u), cell_f(4u), cell_f(5u));
    if (!(all(p >= lo) && all(p <= hi))) { return NO_CELL; }
    var node = 0u;
    loop {
        let child = cells[CELL_HEADER + CELL_NODE_WORDS * node];
        if (child == 0u) { break; }
        let mid = (lo + hi) * 0.5;
        var oct = 0u;
        if (p.x >= mid.x) { oct |= 1u; lo.x = mid.x; } else { hi.x = mid.x; }
        if (p.y >= mid.y) { oct |= 2u; lo.y = mid.y; } else { hi.y = mid.y; }
        if (p.z >= mid.z) { oct |= 4u; lo.z = mid.z; } else { hi.z = mid.z; }
        node = child + oct;
    }
    cell_node = node;
    cell_lo = lo;
    cell_hi = hi;
    return node;
}

// The cells' list for the field `kind` (x: first word, y: length), or
// x = NO_CELL where every object is folded.
fn cell_list(kind: u32, p: vec3<f32>) -> vec2<u32> {
    if (!USE_CELLS) { return vec2<u32>(NO_CELL, cfg.n_objects); }
    var slot = 0u;
    switch kind {
        case 0u: { slot = 0u; }
        case 2u: { slot = 1u; }
        case 3u: { slot = 2u; }
        case 4u: { slot = 3u; }
        default: { return vec2<u32>(NO_CELL, cfg.n_objects); }
    }
    let node = find_cell(p);
    if (node == NO_CELL) { return vec2<u32>(NO_CELL, cfg.n_objects); }
    let b = CELL_HEADER + CELL_NODE_WORDS * node + 1u + 2u * slot;
    return vec2<u32>(cells[b], cells[b + 1u]);
}

// The q-th object of a list (see cell_list), or NO_CELL for an object the
// field leaves out.
fn list_object(list: vec2<u32>, q: u32, kind: u32) -> u32 {
    if (USE_CELLS && list.x != NO_CELL) { return cells[list.x + q]; }
    if (!wanted(kind, q)) { return NO_CELL; }
    return q;
}

// The distance of the field `kind` at p (as isoray-scene's derive builds it).
fn field(kind: u32, p: vec3<f32>) -> f32 {
    n_evals += 1u;
    var acc = EMPTY;
    var have = false;
    let list = cell_list(kind, p);
    // Without cells every object is evaluated once, up front (iso_all).
    var ds: array<f32, N_OBJECTS>;
    if (ALL_AT_ONCE) { ds = iso_all(p); }
    for (var q = 0u; q < list.y; q++) {
        let i = list_object(list, q, kind);
        if (i == NO_CELL) { continue; }
        var d: f32;
        if (ALL_AT_ONCE) { d = ds[i]; } else { d = iso_object(i, p); }
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
    let list = cell_list(kind, p);
    var ds: array<vec4<f32>, N_OBJECTS>;
    if (ALL_AT_ONCE) { ds = iso_all_dual(p); }
    for (var q = 0u; q < list.y; q++) {
        let i = list_object(list, q, kind);
        if (i == NO_CELL) { continue; }
        var d: vec4<f32>;
        if (ALL_AT_ONCE) { d = ds[i]; } else { d = iso_object_dual(i, p); }
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
    // A divergent branch runs for every lane on lavapipe: the dual path is
    // compiled only where some ray can ask for it (pack::Features::dual).
    if (HAS_DUAL) {
        if (mode == N_DUAL) {
            n_evals += 1u;
            return field_dual(kind, p).yzw;
        }
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
