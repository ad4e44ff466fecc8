// The meshes' raster prepass (isoray-gpu's raster.rs): every triangle of
// every `[[mesh]]`, drawn with the camera of the primary rays into a
// target of one texel per primary sample, keeps the nearest triangle's id
// per sample ((mesh + 1) << 24 | triangle; 0 where no triangle covers it).
// The tracer then intersects that one triangle exactly instead of walking
// the mesh trees for the primary ray.

// The camera: its position, and the rows that take p − position to clip
// space (x / (tan · aspect), y / tan, then forward), near in cam.w.
struct Camera {
    cam: vec4<f32>,
    rx: vec4<f32>,
    ry: vec4<f32>,
    rz: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> mesh_data: array<u32>;
@group(0) @binding(1) var<uniform> camera: Camera;

fn mesh_f(i: u32) -> f32 { return bitcast<f32>(mesh_data[i]); }
fn mesh_v3(i: u32) -> vec3<f32> { return vec3<f32>(mesh_f(i), mesh_f(i + 1u), mesh_f(i + 2u)); }

// q · v · q⁻¹ for a unit quaternion (as the tracer's quat_rotate).
fn quat_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let b = q.xyz;
    return v * (q.w * q.w - dot(b, b)) + b * (dot(v, b) * 2.0) + cross(b, v) * (q.w * 2.0);
}

struct Corner {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) id: u32,
}

// Corner vertex % 3 of triangle vertex / 3 of mesh `instance`.
@vertex
fn vs(@builtin(vertex_index) vertex: u32, @builtin(instance_index) k: u32) -> Corner {
    let b = 1u + 16u * k;
    let q = vec4<f32>(mesh_f(b), mesh_f(b + 1u), mesh_f(b + 2u), mesh_f(b + 3u));
    let tri = vertex / 3u;
    let local = mesh_v3(mesh_data[b + 10u] + 9u * tri + 3u * (vertex % 3u));
    let world = mesh_v3(b + 4u) + quat_rotate(q, local * mesh_f(b + 7u));
    let r = world - camera.cam.xyz;
    var out: Corner;
    // Reversed depth with the far plane at infinity: near / forward.
    out.clip = vec4<f32>(dot(camera.rx.xyz, r), dot(camera.ry.xyz, r), camera.cam.w, dot(camera.rz.xyz, r));
    out.id = ((k + 1u) << 24u) | tri;
    return out;
}

@fragment
fn fs(c: Corner) -> @location(0) u32 {
    return c.id;
}
