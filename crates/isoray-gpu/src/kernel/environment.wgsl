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
