//! The per-function parity harness: each WGSL twin of an isoray-shade
//! function (lights, Phong and Blinn-Phong, Fresnel and the interface
//! split, the material blend and mix, the checker, Beer–Lambert) and of
//! `Scene::dent_normal` (planar and spherical maps, with and without
//! parallax occlusion, whose uv is `parallax_uv`'s) runs on
//! the GPU at sampled inputs inside the tracer's own module, and is held to
//! the Rust function with tolerances, as the evaluator conformance suite
//! holds the tapes: not only whole images.

use glam::Vec3;
use isoray_scene::{Fresnel, Scene, ShadingModel, SpecularFunction};
use isoray_shade::{lights, material, optics, phong, MaterialSample};
use wgpu::util::DeviceExt;

use crate::layout::{Light, Mat};
use crate::{Gpu, Kernel, SceneCode};

/// Input words per record (the first is the function's number).
const IN: usize = 64;
/// Output words per record.
const OUT: usize = 20;

/// The probe entry point appended to the tracer's module: record i's
/// inputs at `probe_in[64 i ..]`, its outputs at `probe_out[20 i ..]`.
const PROBE: &str = r#"
@group(0) @binding(20) var<storage, read> probe_in: array<u32>;
@group(0) @binding(21) var<storage, read_write> probe_out: array<u32>;
var<private> probe_a: u32;
var<private> probe_b: u32;
fn pu(k: u32) -> u32 { return probe_in[probe_a + k]; }
fn pf(k: u32) -> f32 { return bitcast<f32>(probe_in[probe_a + k]); }
fn pv(k: u32) -> vec3<f32> { return vec3<f32>(pf(k), pf(k + 1u), pf(k + 2u)); }
fn put_f(k: u32, x: f32) { probe_out[probe_b + k] = bitcast<u32>(x); }
fn put_v(k: u32, v: vec3<f32>) { put_f(k, v.x); put_f(k + 1u, v.y); put_f(k + 2u, v.z); }
fn probe_light(k: u32) -> Light {
    return Light(pu(k), pu(k + 1u), pf(k + 2u), pf(k + 3u), pf(k + 4u), pf(k + 5u), pf(k + 6u), pf(k + 7u),
        pf(k + 8u), pf(k + 9u), pf(k + 10u), pf(k + 11u), pf(k + 12u), pf(k + 13u), pf(k + 14u), pf(k + 15u),
        pf(k + 16u), pf(k + 17u), pf(k + 18u), pf(k + 19u));
}
fn probe_mat(k: u32) -> Mat {
    return Mat(pv(k), pf(k + 3u), pv(k + 4u), pf(k + 7u), pv(k + 8u), pf(k + 11u), pv(k + 12u), pu(k + 15u),
        pv(k + 16u), pu(k + 19u), pv(k + 20u), pu(k + 23u), pu(k + 24u), pf(k + 25u), pu(k + 26u), pu(k + 27u));
}
@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&probe_in) / 64u) { return; }
    probe_a = id.x * 64u;
    probe_b = id.x * 20u;
    switch pu(0u) {
        case 0u: { probe_out[probe_b] = hash(pu(1u)); }
        case 1u: { let uv = lattice(pu(1u), pu(2u), pu(3u)); put_f(0u, uv.x); put_f(1u, uv.y); }
        case 2u: {
            let inc = light_sample(probe_light(8u), pv(1u), pu(4u), pu(5u), pu(6u));
            put_v(0u, inc.dir); put_f(3u, inc.dist); put_f(4u, inc.attenuation);
        }
        case 3u: { put_v(0u, direct_light(probe_mat(32u), pv(1u), pv(4u), pv(7u), pv(10u), pv(13u))); }
        case 4u: { put_f(0u, fresnel(pu(1u), pf(2u), pf(3u), pf(4u))); }
        case 5u: {
            let s = surface_interface(probe_mat(32u), pv(1u), pv(4u), pf(7u), pf(8u), pf(9u));
            put_v(0u, s.reflect); put_v(3u, s.transmit); put_v(6u, s.local);
            put_v(9u, s.refracted); put_f(12u, select(0.0, 1.0, s.can_refract));
        }
        case 6u: { put_f(0u, blend_weight(pf(1u), pf(2u), pf(3u))); put_f(1u, shade_smooth_min(pf(1u), pf(2u), pf(3u))); }
        case 7u: { put_f(0u, select(0.0, 1.0, checker_odd(pv(1u), pf(4u)))); }
        case 8u: { put_v(0u, beer_lambert(pv(1u), pf(4u))); }
        case 9u: { put_f(0u, specular_factor(pu(1u), pf(2u), pf(3u))); }
        case 10u: {
            let m = mix_mat(probe_mat(8u), probe_mat(36u), pf(1u));
            put_v(0u, m.ambient); put_v(3u, m.diffuse); put_v(6u, m.specular); put_f(9u, m.shininess);
            put_f(10u, m.transparency); put_f(11u, m.ior); put_f(12u, bitcast<f32>(m.model));
            put_f(13u, bitcast<f32>(m.fresnel)); put_v(14u, m.absorption);
        }
        case 11u: { put_v(0u, dent_normal(pu(1u), pv(2u), pv(5u), pv(8u))); }
        default: {}
    }
}
"#;

/// One record's inputs.
#[derive(Clone)]
struct Record([u32; IN]);

impl Record {
    fn new(function: u32) -> Record {
        let mut r = Record([0; IN]);
        r.0[0] = function;
        r
    }
    fn u(mut self, k: usize, x: u32) -> Self {
        self.0[k] = x;
        self
    }
    fn f(self, k: usize, x: f32) -> Self {
        self.u(k, x.to_bits())
    }
    fn v(self, k: usize, v: Vec3) -> Self {
        self.f(k, v.x).f(k + 1, v.y).f(k + 2, v.z)
    }
    fn words<T: bytemuck::Pod>(mut self, k: usize, t: &T) -> Self {
        let w: &[u32] = bytemuck::cast_slice(std::slice::from_ref(t));
        self.0[k..k + w.len()].copy_from_slice(w);
        self
    }
}

/// Runs the records on the GPU through the tracer's module (for `scene`):
/// each record's output words. None without an adapter.
fn run(scene: &Scene, records: &[Record]) -> Option<Vec<[u32; OUT]>> {
    let gpu = match Gpu::new() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("no GPU adapter ({e}): the parity harness is skipped");
            return None;
        }
    };
    let code = SceneCode::new(scene, Kernel::Compiled).unwrap();
    let source = format!("const USE_CELLS: bool = false;\n{}{PROBE}", code.source);
    let device = &gpu.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("probe"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("probe"),
        layout: None,
        module: &module,
        entry_point: Some("probe"),
        compilation_options: Default::default(),
        cache: None,
    });
    let words: Vec<u32> = records.iter().flat_map(|r| r.0).collect();
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("probe_in"),
        contents: bytemuck::cast_slice(&words),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (records.len() * OUT * 4) as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe_out"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let read = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe_read"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    // What dent_normal reads: the settings (parallax), the objects (their
    // dent headers) and the dent maps.
    let (dent_words, dent_offsets) = crate::pack::dents(scene, &mut Default::default());
    let band = crate::pack::Band {
        x0: 0,
        y0: 0,
        width: scene.render.width,
        height: scene.render.height,
    };
    let scratch = crate::pack::Scratch::of(scene, Kernel::Compiled, false);
    let reaches = isoray_render::reaches(scene, scene.camera.position, Some(1));
    let settings = crate::pack::settings(scene, band, false, scratch, None, &reaches);
    let buffer = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage,
        })
    };
    let settings = buffer("settings", bytemuck::bytes_of(&settings), wgpu::BufferUsages::UNIFORM);
    let objects = crate::layout::bytes_of_all(&code.objects(scene, &dent_offsets));
    let objects = code.table_buffer(device, 4, "objects", &objects);
    let dents = buffer("dents", &dent_words.bytes(), wgpu::BufferUsages::STORAGE);
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("probe"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 1,
                resource: settings.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: objects.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 12,
                resource: dents.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 20,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 21,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((records.len() as u32).div_ceil(64), 1, 1);
    }
    enc.copy_buffer_to_buffer(&output, 0, &read, 0, size);
    gpu.queue.submit([enc.finish()]);
    let slice = read.slice(..);
    slice.map_async(wgpu::MapMode::Read, |r| r.unwrap());
    device
        .poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: None,
        })
        .unwrap();
    let data: Vec<u32> = bytemuck::cast_slice(&slice.get_mapped_range().unwrap()).to_vec();
    Some(data.chunks_exact(OUT).map(|c| c.try_into().unwrap()).collect())
}

/// A reproducible stream of numbers (a 64-bit LCG's high bits).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }
    fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            if v.length_squared() > 0.01 && v.length_squared() < 1.0 {
                return v.normalize();
            }
        }
    }
    fn colour(&mut self) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next())
    }
}

/// The scene whose lights and materials the harness samples.
const SCENE: &str = r#"
[[light]]
direction = [-1.0, 2.0, 0.5]
[[light]]
kind = "point"
position = [1.0, 3.0, -2.0]
attenuation = [1.0, 0.2, 0.05]
[[light]]
kind = "sphere"
position = [0.5, 4.0, 1.0]
radius = 0.7
samples = 9
[[light]]
kind = "rect"
position = [-2.0, 3.0, 0.0]
u = [1.0, 0.0, 0.5]
v = [0.0, 0.0, 2.0]
samples = 4
[material.phong]
diffuse = [0.8, 0.3, 0.2]
specular = [0.9, 0.9, 0.9]
shininess = 40.0
[material.blinn]
model = "blinn-phong"
specular_function = "schlick"
specular_fresnel = true
fresnel = false
shininess = 12.0
reflectivity = [0.2, 0.3, 0.4]
[material.glass]
transparency = 0.9
ior = 1.5
fresnel_model = "exact"
absorption = [0.1, 0.5, 1.0]
[material.schlick_glass]
transparency = 0.6
ior = 1.33
reflectivity = [0.05, 0.05, 0.05]
[[object]]
shape = "sphere(p, 1.0)"
material = "glass"
"#;

fn scene() -> Scene {
    isoray_scene::load_str(SCENE, "parity.toml", &[]).unwrap()
}

fn f(w: u32) -> f32 {
    f32::from_bits(w)
}

fn vec(out: &[u32; OUT], k: usize) -> Vec3 {
    Vec3::new(f(out[k]), f(out[k + 1]), f(out[k + 2]))
}

/// |gpu − cpu| within `rel`·max(1, |cpu|), infinities and NaNs alike.
fn close(gpu: f32, cpu: f32, rel: f32) -> bool {
    if !cpu.is_finite() || !gpu.is_finite() {
        return gpu == cpu || (gpu.is_nan() && cpu.is_nan());
    }
    (gpu - cpu).abs() <= rel * cpu.abs().max(1.0)
}

fn close3(gpu: Vec3, cpu: Vec3, rel: f32) -> bool {
    close(gpu.x, cpu.x, rel) && close(gpu.y, cpu.y, rel) && close(gpu.z, cpu.z, rel)
}

/// Samples every function at `n` inputs each, runs them on the GPU and
/// checks each against its Rust twin; the failures, described.
fn failures(n: usize) -> Option<Vec<String>> {
    let scene = scene();
    let gpu_lights = crate::pack::lights(&scene);
    let gpu_mats = crate::pack::materials(&scene);
    let samples: Vec<MaterialSample> = scene.materials.iter().map(MaterialSample::from).collect();
    let mut rng = Rng(41);
    type Check = Box<dyn Fn(&[u32; OUT]) -> Result<(), String>>;
    let mut records = Vec::new();
    let mut checks: Vec<Check> = Vec::new();
    for i in 0..n {
        // hash
        let x = (rng.next() * 4294967040.0) as u32 ^ i as u32;
        records.push(Record::new(0).u(1, x));
        checks.push(Box::new(move |o| {
            let want = lights::hash(x);
            (o[0] == want)
                .then_some(())
                .ok_or(format!("hash({x}) = {} on the GPU, {want}", o[0]))
        }));
        // lattice
        let (j, m, seed) = (i as u32 % 17, 1 + i as u32 % 23, (rng.next() * 1e9) as u32);
        records.push(Record::new(1).u(1, j).u(2, m).u(3, seed));
        checks.push(Box::new(move |o| {
            let (u, v) = lights::lattice(j, m, seed);
            (close(f(o[0]), u, 1e-6) && close(f(o[1]), v, 1e-6))
                .then_some(())
                .ok_or(format!(
                    "lattice({j}, {m}, {seed}) = ({}, {}), CPU ({u}, {v})",
                    f(o[0]),
                    f(o[1])
                ))
        }));
        // light samples of every kind of light
        let li = i % scene.lights.len();
        let p = Vec3::new(rng.range(-3.0, 3.0), rng.range(-1.0, 1.0), rng.range(-3.0, 3.0));
        let (j, m, seed) = (i as u32 % 9, 9, (rng.next() * 1e9) as u32);
        records.push(
            Record::new(2)
                .v(1, p)
                .u(4, j)
                .u(5, m)
                .u(6, seed)
                .words::<Light>(8, &gpu_lights[li]),
        );
        let light = scene.lights[li].clone();
        checks.push(Box::new(move |o| {
            let want = lights::sample(&light, p, j, m, seed);
            let ok = close3(vec(o, 0), want.dir, 2e-5)
                && close(f(o[3]), want.dist, 2e-5)
                && close(f(o[4]), want.attenuation, 2e-5);
            ok.then_some(()).ok_or(format!(
                "light {li} sample {j} at {p}: GPU dir {} dist {} att {}, CPU {want:?}",
                vec(o, 0),
                f(o[3]),
                f(o[4])
            ))
        }));
        // Phong / Blinn-Phong with one light
        let mi = i % samples.len();
        let (nn, v, l) = (rng.unit(), rng.unit(), rng.unit());
        let (local, arriving) = (rng.colour(), rng.colour() * 3.0);
        records.push(
            Record::new(3)
                .v(1, nn)
                .v(4, v)
                .v(7, l)
                .v(10, local)
                .v(13, arriving)
                .words::<Mat>(32, &gpu_mats[mi]),
        );
        let s = samples[mi];
        checks.push(Box::new(move |o| {
            let want = phong::direct_light(&s, nn, v, l, local, arriving);
            close3(vec(o, 0), want, 1e-4).then_some(()).ok_or(format!(
                "direct_light (material {mi}, n {nn}, v {v}, l {l}) = {}, CPU {want}",
                vec(o, 0)
            ))
        }));
        // Fresnel, each model, both ways through the interface
        let model = i as u32 % 3;
        let (cos1, n1, n2) = (rng.range(-0.1, 1.1), rng.range(1.0, 2.4), rng.range(1.0, 2.4));
        records.push(Record::new(4).u(1, model).f(2, cos1).f(3, n1).f(4, n2));
        checks.push(Box::new(move |o| {
            let fm = [Fresnel::Off, Fresnel::Schlick, Fresnel::Exact][model as usize];
            let want = optics::fresnel(fm, cos1, n1, n2);
            close(f(o[0]), want, 2e-5)
                .then_some(())
                .ok_or(format!("fresnel({fm:?}, {cos1}, {n1}, {n2}) = {}, CPU {want}", f(o[0])))
        }));
        // The interface split
        let nrm = rng.unit();
        let mut dir = rng.unit();
        if dir.dot(nrm) > 0.0 {
            dir = -dir;
        }
        let c1 = -nrm.dot(dir);
        let (n1, n2) = if i % 2 == 0 {
            (1.0, samples[mi].ior)
        } else {
            (samples[mi].ior, 1.0)
        };
        records.push(
            Record::new(5)
                .v(1, dir)
                .v(4, nrm)
                .f(7, c1)
                .f(8, n1)
                .f(9, n2)
                .words::<Mat>(32, &gpu_mats[mi]),
        );
        checks.push(Box::new(move |o| {
            let want = optics::interface(&s, dir, nrm, c1, n1, n2);
            let ok = close3(vec(o, 0), want.split.reflect, 2e-5)
                && close3(vec(o, 3), want.split.transmit, 2e-5)
                && close3(vec(o, 6), want.split.local, 2e-5)
                && (f(o[12]) == 1.0) == want.refracted.is_some()
                && want.refracted.is_none_or(|r| close3(vec(o, 9), r, 2e-5));
            ok.then_some(()).ok_or(format!(
                "interface (material {mi}, i {dir}, n {nrm}, {n1} -> {n2}): GPU reflect {} transmit {} local {} refracted {} ({}), CPU {want:?}",
                vec(o, 0),
                vec(o, 3),
                vec(o, 6),
                vec(o, 9),
                f(o[12])
            ))
        }));
        // The material blend's weight and smooth minimum
        let (a, b, k) = (rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(0.01, 0.5));
        records.push(Record::new(6).f(1, a).f(2, b).f(3, k));
        checks.push(Box::new(move |o| {
            let (w, m) = (material::blend_weight(a, b, k), material::smooth_min(a, b, k));
            (close(f(o[0]), w, 1e-5) && close(f(o[1]), m, 1e-5))
                .then_some(())
                .ok_or(format!(
                    "blend({a}, {b}, {k}) = ({}, {}), CPU ({w}, {m})",
                    f(o[0]),
                    f(o[1])
                ))
        }));
        // The checker, away from its squares' edges
        let size = rng.range(0.2, 2.0);
        let q = Vec3::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0), rng.range(-5.0, 5.0));
        let edge = (q / size).to_array().iter().any(|c| (c - c.round()).abs() < 1e-3);
        if !edge {
            records.push(Record::new(7).v(1, q).f(4, size));
            checks.push(Box::new(move |o| {
                let want = material::checker_odd(q, size);
                ((f(o[0]) == 1.0) == want)
                    .then_some(())
                    .ok_or(format!("checker_odd({q}, {size}) = {}, CPU {want}", f(o[0])))
            }));
        }
        // Beer–Lambert
        let (sigma, len) = (rng.colour() * 4.0, rng.range(0.0, 3.0));
        records.push(Record::new(8).v(1, sigma).f(4, len));
        checks.push(Box::new(move |o| {
            let want = optics::beer_lambert(sigma, len);
            close3(vec(o, 0), want, 1e-5)
                .then_some(())
                .ok_or(format!("beer_lambert({sigma}, {len}) = {}, CPU {want}", vec(o, 0)))
        }));
        // The specular factor, both functions
        let sf = i as u32 % 2;
        let (c, sh) = (rng.range(-0.2, 1.2), rng.range(1.0, 200.0));
        records.push(Record::new(9).u(1, sf).f(2, c).f(3, sh));
        checks.push(Box::new(move |o| {
            let func = [SpecularFunction::Pow, SpecularFunction::Schlick][sf as usize];
            let want = phong::specular_factor(func, c, sh);
            close(f(o[0]), want, 1e-4).then_some(()).ok_or(format!(
                "specular_factor({func:?}, {c}, {sh}) = {}, CPU {want}",
                f(o[0])
            ))
        }));
        // Mixing two materials
        let (ma, mb) = (i % samples.len(), (i + 1) % samples.len());
        // The tracer mixes with blend weights, which lie in [0, 1].
        let h = match i % 8 {
            0 => 0.0,
            1 => 1.0,
            _ => rng.next(),
        };
        records.push(
            Record::new(10)
                .f(1, h)
                .words::<Mat>(8, &gpu_mats[ma])
                .words::<Mat>(36, &gpu_mats[mb]),
        );
        let (sa, sb) = (samples[ma], samples[mb]);
        checks.push(Box::new(move |o| {
            let m = sa.mix(&sb, h);
            let model = match m.model {
                ShadingModel::Phong => 0,
                ShadingModel::BlinnPhong => 1,
            };
            let fresnel = match m.fresnel {
                Fresnel::Off => 0,
                Fresnel::Schlick => 1,
                Fresnel::Exact => 2,
            };
            let ok = close3(vec(o, 0), m.ambient, 1e-6)
                && close3(vec(o, 3), m.diffuse, 1e-6)
                && close3(vec(o, 6), m.specular, 1e-6)
                && close(f(o[9]), m.shininess, 1e-6)
                && close(f(o[10]), m.transparency, 1e-6)
                && close(f(o[11]), m.ior, 1e-6)
                && o[12] == model
                && o[13] == fresnel
                && close3(vec(o, 14), m.absorption, 1e-6);
            ok.then_some(())
                .ok_or(format!("mix(material {ma}, material {mb}, {h}): GPU {o:?}, CPU {m:?}"))
        }));
    }
    let out = run(&scene, &records)?;
    Some(
        out.iter()
            .zip(&checks)
            .filter_map(|(o, check)| check(o).err())
            .collect(),
    )
}

#[test]
fn every_shading_function_on_the_gpu_matches_its_rust_twin() {
    let Some(failures) = failures(256) else { return };
    assert!(
        failures.is_empty(),
        "{} of the sampled calls differ:\n{}",
        failures.len(),
        failures[..failures.len().min(20)].join("\n")
    );
}

#[test]
fn the_harness_sees_a_wrong_answer() {
    // A probe whose Rust side is off by one ulp in hash is caught: the
    // comparison is exact where it should be.
    let Some(out) = run(&scene(), &[Record::new(0).u(1, 12345)]) else {
        return;
    };
    assert_eq!(out[0][0], lights::hash(12345));
    assert_ne!(out[0][0], lights::hash(12345) ^ 1);
}

/// A ball with a spherical dent map and a turned plate with a planar one,
/// each struck once; `parallax` is `render.parallax`.
fn dented(parallax: &str) -> Scene {
    use isoray_dent::field::March;
    use isoray_dent::imprint::{imprint_texel, Sphere};
    let text = format!(
        "[render]\nparallax = \"{parallax}\"\n\
         [[object]]\nshape = \"sphere(p, 0.5)\"\nposition = [0.4, 0.2, -0.3]\n\
         dents = \"bump\"\ndent_map = {{ size = 128, range = 0.4, uv = \"spherical\", extent = 0.5 }}\n\
         [[object]]\nshape = \"box(p, vec3(1.0, 0.1, 1.0))\"\nrotation = [0.0, 20.0, 0.0]\n\
         dents = \"bump\"\ndent_map = {{ size = 128, range = 0.4, uv = \"planar-xz\", extent = 1.0 }}\n"
    );
    let mut s = isoray_scene::load_str(&text, "dented.toml", &[]).unwrap();
    let ball = |p: [f64; 3]| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 0.5;
    let plate = |p: [f64; 3]| {
        let q = [p[0].abs() - 1.0, p[1].abs() - 0.1, p[2].abs() - 1.0];
        let o = q.map(|x| x.max(0.0));
        (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt() + q[0].max(q[1]).max(q[2]).min(0.0)
    };
    type Own<'a> = &'a dyn Fn([f64; 3]) -> f64;
    let strikes: [(Own, [f64; 3], f64); 2] = [(&ball, [0.0, 0.7, 0.0], 0.3), (&plate, [0.2, 0.34, 0.1], 0.3)];
    for (i, (own, c, r)) in strikes.into_iter().enumerate() {
        let mut maps = s.objects[i].physics.dent_map.blank().unwrap();
        let dent = |p: [f64; 3]| ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt() - r;
        let mapping = maps.mapping.clone();
        let out = imprint_texel(
            &mut maps.height,
            &mapping,
            &own,
            &dent,
            Sphere { centre: c, radius: r },
            March::default(),
        );
        assert!(out.lowered > 20, "object {i}: {} texels lowered", out.lowered);
        maps.update_normals();
        s.objects[i].physics.maps = Some(std::sync::Arc::new(maps));
    }
    s
}

#[test]
fn dent_normals_on_the_gpu_match_the_scenes() {
    for parallax in ["none", "occlusion"] {
        let scene = dented(parallax);
        let mut rng = Rng(7);
        let mut records = Vec::new();
        let mut wanted = Vec::new();
        for i in 0..512 {
            // Points on each undented surface around its dent, seen from above.
            let (obj, p, n) = if i % 2 == 0 {
                let mut d = rng.unit();
                d.y = d.y.abs() + 0.8;
                let d = d.normalize();
                (0u32, Vec3::new(0.4, 0.2, -0.3) + d * 0.5, d)
            } else {
                let (c, s) = 20f32.to_radians().sin_cos();
                let (x, z) = (rng.range(-0.5, 0.8), rng.range(-0.5, 0.7));
                // The plate turned by 20° about y: its top at y = 0.1.
                let p = Vec3::new(x * s + z * c, 0.1, -x * c + z * s);
                (1u32, p, Vec3::Y)
            };
            let mut e = rng.unit();
            if e.dot(n) < 0.2 {
                e = (e + n * 1.5).normalize();
            }
            records.push(Record::new(11).u(1, obj).v(2, p).v(5, n).v(8, e));
            let f = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
            let want = scene
                .dent_normal(obj as usize, f(p), f(n), f(e))
                .map_or(n, |w| Vec3::new(w[0] as f32, w[1] as f32, w[2] as f32));
            wanted.push((obj, p, n, want));
        }
        let Some(out) = run(&scene, &records) else { return };
        let mut tilted = 0;
        let mut failures = Vec::new();
        for (o, &(obj, p, n, want)) in out.iter().zip(&wanted) {
            let got = vec(o, 0);
            tilted += (want.dot(n) < 0.999) as usize;
            // The GPU's texel normals are packed in 2×16-bit snorm.
            if !close3(got, want, 2e-3) {
                failures.push(format!("object {obj} at {p}, n {n}: GPU {got}, CPU {want}"));
            }
        }
        eprintln!(
            "parallax {parallax}: {tilted} of {} normals tilted by a dent, {} differ",
            wanted.len(),
            failures.len()
        );
        assert!(
            tilted > 20,
            "{parallax}: only {tilted} sampled normals are tilted by a dent"
        );
        assert!(
            failures.len() <= wanted.len() / 100,
            "{parallax}: {} of {} dent normals differ:\n{}",
            failures.len(),
            wanted.len(),
            failures[..failures.len().min(10)].join("\n")
        );
    }
}
