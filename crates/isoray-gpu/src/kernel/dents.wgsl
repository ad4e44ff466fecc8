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
