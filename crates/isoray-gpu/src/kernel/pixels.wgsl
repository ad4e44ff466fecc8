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
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
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
        // The work counters straight into the sums (no workgroup barrier:
        // lavapipe runs a shader with barriers as coroutines, far slower).
        add64(0u, n_evals);
        if (n_reflected > 0u) { add64(1u, n_reflected); }
        if (n_refracted > 0u) { add64(2u, n_refracted); }
        if (n_shadow > 0u) { add64(3u, n_shadow); }
        if (n_overshoots > 0u) {
            add64(4u, n_overshoots);
            atomicMax(&stats[10], bitcast<u32>(worst_overshoot));
        }
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
