// ---- sphere tracing (isoray-render's sphere_trace_capped) ----

struct Hit { t: f32, steps: u32 }

// The parameter range (t0, t1) where o + t·d is inside the box (empty when t0 > t1).
fn box_range(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    var r = vec2<f32>(-iso_inf(), iso_inf());
    for (var k = 0u; k < 3u; k++) {
        if (d[k] == 0.0) {
            if (o[k] < lo[k] || o[k] > hi[k]) { return vec2<f32>(iso_inf(), -iso_inf()); }
            continue;
        }
        let inv = 1.0 / d[k];
        let a = (lo[k] - o[k]) * inv;
        let b = (hi[k] - o[k]) * inv;
        r = vec2<f32>(max(r.x, min(a, b)), min(r.y, max(a, b)));
    }
    return r;
}

fn inside_box(lo: vec3<f32>, hi: vec3<f32>, p: vec3<f32>) -> bool {
    return all(p >= lo) && all(p <= hi);
}

// Which reach reach_far reads.
const R_SCENE: u32 = 0u;
const R_REST: u32 = 1u;
const R_PENUMBRA: u32 = 2u;

// isoray-render's Reach::far: the parameter beyond which the ray meets no
// surface of the field (`which`: the scene's, the rest's, or where the
// shadow rays' field is below the penumbra's distance), 0 <= t <= tmax:
// negative when it meets none at all, +inf when that is not known.
fn reach_far(which: u32, o: vec3<f32>, d: vec3<f32>, tmax: f32) -> f32 {
    var kind = cfg.reach_scene;
    var lo = cfg.reach_scene_lo.xyz;
    var hi = cfg.reach_scene_hi.xyz;
    if (which == R_REST) {
        kind = cfg.reach_rest;
        lo = cfg.reach_rest_lo.xyz;
        hi = cfg.reach_rest_hi.xyz;
    } else if (which == R_PENUMBRA) {
        kind = cfg.reach_penumbra;
        lo = cfg.reach_penumbra_lo.xyz;
        hi = cfg.reach_penumbra_hi.xyz;
    }
    let dlo = cfg.reach_domain_lo.xyz;
    let dhi = cfg.reach_domain_hi.xyz;
    if (kind == 0u || !(tmax < iso_inf()) || !inside_box(dlo, dhi, o) || !inside_box(dlo, dhi, o + d * tmax)) {
        return iso_inf();
    }
    if (kind == 1u) { return -1.0; }
    let r = box_range(lo, hi, o, d);
    if (r.x > r.y || r.y < 0.0) { return -1.0; }
    return r.y + 1e-5 * (1.0 + r.y);
}

fn sphere_trace(kind: u32, o: vec3<f32>, dir: vec3<f32>, cap: f32, far: f32) -> Hit {
    let eps = cfg.hit_eps;
    let tmax = cfg.max_dist;
    var t = 0.0;
    var last = iso_nan();
    var step = 0u;
    // Past the field's last surface: the cap's hit, or a miss.
    var beyond = iso_inf();
    if (cap <= tmax) { beyond = max(cap - 0.5 * eps, 0.0); }
    if (far < 0.0) { return Hit(beyond, 0u); }
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
        } else if (t > far) {
            t = beyond;
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
    if (HAS_MESHES) {
        if (primary_texel.x != NO_TEXEL) {
            mh = raster_hit(o, d, primary_texel);
        } else {
            mh = mesh_cast(o, d, iso_inf(), false);
        }
        cap = iso_min(cap, mh.t);
    }
    primary_texel.x = NO_TEXEL;
    var far = iso_inf();
    if (!inside) { far = reach_far(select(R_SCENE, R_REST, kind == F_REST), o, d, cfg.max_dist); }
    let h = sphere_trace(kind, o, d, cap, far);
    var r = Traced(h.t, h.steps, vec3<f32>(0.0), vec3<f32>(0.0), 0.0, NO_MESH);
    if (!(abs(h.t) < iso_inf())) { return r; }
    if (HAS_MESHES) {
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
