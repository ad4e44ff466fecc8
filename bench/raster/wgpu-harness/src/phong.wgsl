// isoray's polygon-pipeline Phong shading, for the llvmpipe side of
// bench/raster.sh. The same formulas as isoray_raster::shading::Lighting::shade
// and isoray_render::shade::{direct, direct_parts, specular_factor}:
// emission + ambient + Σ lights radiance · attenuation · (diffuse·n·l + specular·f(c)),
// checkers by the parity of ⌊x/s⌋ + ⌊y/s⌋ + ⌊z/s⌋, area lights lit from their centre.
//
// The camera is isoray's ViewTransform: camera space x right, y up, z backwards,
// w = −z; NDC x = x/w / (tan_half·aspect), y = y/w / tan_half. Depth is
// reversed and infinite: clip z = near, so depth = near / w (1 at the near
// plane, → 0 far away; compare "greater", clear 0); clipping z ≤ w is isoray's
// near plane w ≥ near, and there is no far plane, as in isoray.

struct Globals {
    eye: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    back: vec4<f32>,
    // x: 1 / (tan_half · aspect), y: 1 / tan_half, z: near
    proj: vec4<f32>,
    // x: number of lights
    counts: vec4<u32>,
};

struct Material {
    ambient: vec4<f32>,
    diffuse: vec4<f32>,
    specular: vec4<f32>,
    emission: vec4<f32>,
    // x: shininess, y: checker cell size
    params: vec4<f32>,
    // x: model (0 Phong, 1 Blinn-Phong), y: specular function (0 pow, 1 Schlick),
    // z: the checker's other material, w: 1 when checkered
    flags: vec4<u32>,
};

struct Light {
    // xyz: position, or the direction towards a directional light; w: 0 directional, 1 positional
    position: vec4<f32>,
    // colour × intensity
    radiance: vec4<f32>,
    // 1 / (x + y·d + z·d²)
    attenuation: vec4<f32>,
};

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(1) var<storage, read> materials: array<Material>;
@group(0) @binding(2) var<storage, read> lights: array<Light>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) material: u32,
};

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>, @location(2) material: u32) -> VsOut {
    let d = position - g.eye.xyz;
    let c = vec3<f32>(dot(d, g.right.xyz), dot(d, g.up.xyz), dot(d, g.back.xyz));
    var o: VsOut;
    o.clip = vec4<f32>(c.x * g.proj.x, c.y * g.proj.y, g.proj.z, -c.z);
    o.world = position;
    o.normal = normal;
    o.material = material;
    return o;
}

// glam's normalize_or_zero.
fn nz(v: vec3<f32>) -> vec3<f32> {
    let l = length(v);
    if (l > 0.0) {
        return v / l;
    }
    return vec3<f32>(0.0);
}

// isoray_render::shade::specular_factor: c^n, or Schlick's c / (n − n·c + c).
fn specular_factor(f: u32, c0: f32, n: f32) -> f32 {
    let c = clamp(c0, 0.0, 1.0);
    if (f == 1u) {
        return c / (n - n * c + c);
    }
    if (n == 0.0) {
        return 1.0;
    }
    if (c <= 0.0) {
        return 0.0;
    }
    return pow(c, n);
}

@fragment
fn fs_main(in: VsOut) -> @location(0) vec4<f32> {
    let p = in.world;
    var m = materials[in.material];
    if (m.flags.w != 0u) {
        let inv = 1.0 / m.params.y;
        let cell = i32(floor(p.x * inv) + floor(p.y * inv) + floor(p.z * inv));
        if (((cell % 2) + 2) % 2 == 1) {
            m = materials[m.flags.z];
        }
    }
    let n = nz(in.normal);
    let v = nz(g.eye.xyz - p);
    var c = m.emission.xyz + m.ambient.xyz;
    for (var i = 0u; i < g.counts.x; i++) {
        let li = lights[i];
        var l: vec3<f32>;
        var att = 1.0;
        if (li.position.w == 0.0) {
            l = nz(li.position.xyz);
        } else {
            let d = li.position.xyz - p;
            l = nz(d);
            let dist = length(d);
            let a = li.attenuation;
            att = 1.0 / max(a.x + a.y * dist + a.z * dist * dist, 1e-12);
        }
        let ndl = dot(n, l);
        if (ndl > 0.0) {
            var cs: f32;
            if (m.flags.x == 0u) {
                let r = 2.0 * ndl * n - l;
                cs = dot(r, v);
            } else {
                cs = dot(n, nz(l + v));
            }
            let direct = m.diffuse.xyz * ndl + m.specular.xyz * specular_factor(m.flags.y, cs, m.params.x);
            c += li.radiance.xyz * att * direct;
        }
    }
    return vec4<f32>(c, 1.0);
}
