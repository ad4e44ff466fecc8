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
    var obj = 0u;
    var k = cfg.blend;
    var km = cfg.material_blend_k;
    // Outside, the scene field's list (made with the blend's width) folds
    // the materials too; inside, every object by |d|.
    var list = vec2<u32>(NO_CELL, cfg.n_objects);
    if (unsigned) {
        k = 0.0;
        km = 0.0;
    } else {
        list = cell_list(F_SCENE, p);
    }
    obj = list_object(list, 0u, F_SCENE);
    var out = object_mat(obj);
    if (list.y > 1u) {
        var acc = 0.0;
        var best = 0.0;
        var ds: array<f32, N_OBJECTS>;
        if (ALL_AT_ONCE) { ds = iso_all(p); }
        for (var q = 0u; q < list.y; q++) {
            let j = list_object(list, q, F_SCENE);
            var b: f32;
            if (ALL_AT_ONCE) { b = ds[j]; } else { b = iso_object(j, p); }
            n_evals += 1u;
            var key = b;
            if (unsigned) { key = abs(b); }
            if (q == 0u) {
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
            // Past the box where occluders are nearer than the penumbra's
            // distance nothing changes the ray's visibility (the CPU's
            // penumbra reach): the march stops there; meshes and
            // transparent objects beyond it still count, below.
            let reach_t = min(tmax, reach_far(R_PENUMBRA, o, l, tmax));
            var vis = shadow_march(occluders, o, l, reach_t, mode, light.size);
            // Meshes block what reaches them (hard shadows).
            if (HAS_MESHES && mode != SH_NONE) {
                if (vis > 0.0) {
                    if (mesh_cast(o, l, tmax, true).mesh != NO_MESH) { vis = 0.0; }
                }
            }
            var through = vec3<f32>(1.0);
            if (HAS_CLEAR && cfg.shadows != SH_NONE) {
                if (vis > 0.0) { through = transmission(o, l, tmax, media); }
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
