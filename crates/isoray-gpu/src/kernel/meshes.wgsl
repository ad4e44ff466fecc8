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
