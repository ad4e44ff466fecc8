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
    var ds: array<f32, N_OBJECTS>;
    if (COMPILED_OBJECTS) { ds = iso_all(p); }
    for (var j = 0u; j < cfg.n_objects; j++) {
        if (!is_clear(j)) { continue; }
        var d: f32;
        if (COMPILED_OBJECTS) { d = abs(ds[j]); } else { d = abs(iso_object(j, p)); }
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
        var h = sphere_trace(kind, origin, l, iso_inf(), iso_inf());
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
