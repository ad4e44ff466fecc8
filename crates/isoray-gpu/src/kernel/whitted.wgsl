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
    var ds: array<f32, N_OBJECTS>;
    if (COMPILED_OBJECTS) { ds = iso_all(p); }
    for (var j = 0u; j < cfg.n_objects; j++) {
        if (!is_clear(j)) { continue; }
        var d: f32;
        if (COMPILED_OBJECTS) { d = ds[j]; } else { d = iso_object(j, p); }
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
        var on_mesh = false;
        if (HAS_MESHES) {
            on_mesh = h.mesh != NO_MESH;
            if (on_mesh) { surf = mesh_surface(h.mesh, h.p); }
        }
        if (!on_mesh) {
            surf = material_at(h.p, inside);
            // Dented objects' normals tilted by their normal maps (where
            // some object has them: the buffer is one word otherwise).
            if (HAS_DENTS) { hn = dent_normal(surf.obj, h.p, h.n, -ray.d); }
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
        // Only where some material reflects or refracts (a uniform branch).
        if (HAS_OPTICS) {
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
