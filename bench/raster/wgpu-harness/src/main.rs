//! raster-bench: isoray's CPU Z-buffer rasterizer against Mesa's llvmpipe
//! (lavapipe, through wgpu's Vulkan backend) on the same triangles with the
//! same Phong shading, side by side in one process (bench/raster.sh).
//!
//! ```text
//! raster-bench SCENE [--resolution N] [--width W --height H] [--reps R] [--warmup K]
//!              [--out-dir DIR] [--json FILE] [--target rgba16f|rgba8srgb]
//! ```
//!
//! 1. Loads SCENE (with `render.width` / `render.height` overridden) and meshes
//!    it once with `isoray_raster::scene::mesh_scene`: the triangle set that
//!    `isoray raster` draws.
//! 2. Sets up wgpu on the Vulkan adapter whose name contains "llvmpipe":
//!    device, WGSL pipeline (src/phong.wgsl), vertex, index, material and
//!    light buffers, colour target (RGBA16F by default) + Depth32Float,
//!    read-back buffer. Setup is timed apart from the frames.
//! 3. Frames, isoray and llvmpipe alternating, K warm-up frames each, then R
//!    timed ones: isoray `raster_meshes` (Z-buffer, Phong); wgpu one render
//!    pass (clear, one indexed draw of every opaque triangle with back-face
//!    culling, one without culling for transparent materials, as isoray does),
//!    copy of the colour target to a buffer, map, copy of the pixels into CPU
//!    memory: a frame is done when its pixels are in CPU memory, as isoray's.
//! 4. Writes both images as sRGB PNGs (isoray_shade::srgb::to_srgb8 for
//!    both) plus a difference image, and a report (stdout and JSON).
//!
//! Culling: isoray culls a triangle when its face normal, oriented by the
//! vertex normals, faces away from the eye (whatever the winding). Here the
//! index buffer is re-wound once at upload so that every triangle is
//! counter-clockwise around that oriented normal; then the GPU's back-face
//! culling (front face CCW) culls exactly the same triangles.
//!
//! Camera: isoray's `ViewTransform` (camera::basis, tan_half_fov, aspect
//! W/H). isoray puts pixel (i, j)'s centre at screen (i, j), which is NDC
//! ((i + ½)·2/W − 1, 1 − (j + ½)·2/H), exactly where Vulkan samples pixel
//! (i, j) (framebuffer (i + ½, j + ½)): no offset is needed. Both use a
//! top-left fill rule.

use std::path::{Path, PathBuf};
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use isoray_raster::render::{raster_meshes, HiddenSurface, RasterOptions};
use isoray_raster::scene::{mesh_scene, MeshedScene};
use isoray_raster::shading::Shading;
use isoray_scene::{LightKind, Scene, ShadingModel, SpecularFunction};
use isoray_shade::srgb::to_srgb8;
use wgpu::util::DeviceExt;

const USAGE: &str = "usage: raster-bench SCENE [--resolution N] [--width W] [--height H] [--reps R] [--warmup K] \
[--out-dir DIR] [--json FILE] [--target rgba16f|rgba8srgb] [--near D]";

/// Distance of the near plane (isoray's RasterOptions::default().near).
fn default_near() -> f64 {
    RasterOptions::default().near
}

struct Args {
    scene: PathBuf,
    resolution: u32,
    width: u32,
    height: u32,
    reps: usize,
    warmup: usize,
    out_dir: PathBuf,
    json: Option<PathBuf>,
    target: Target,
    near: f64,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Target {
    Rgba16f,
    Rgba8Srgb,
}

impl Target {
    fn format(self) -> wgpu::TextureFormat {
        match self {
            Target::Rgba16f => wgpu::TextureFormat::Rgba16Float,
            Target::Rgba8Srgb => wgpu::TextureFormat::Rgba8UnormSrgb,
        }
    }
    fn bytes_per_pixel(self) -> u32 {
        match self {
            Target::Rgba16f => 8,
            Target::Rgba8Srgb => 4,
        }
    }
    fn name(self) -> &'static str {
        match self {
            Target::Rgba16f => "Rgba16Float",
            Target::Rgba8Srgb => "Rgba8UnormSrgb",
        }
    }
}

fn parse_args() -> Result<Args, String> {
    let mut it = std::env::args().skip(1);
    let mut scene = None;
    let mut a = Args {
        scene: PathBuf::new(),
        resolution: RasterOptions::default().resolution,
        width: 1280,
        height: 720,
        reps: 5,
        warmup: 2,
        out_dir: PathBuf::from("."),
        json: None,
        target: Target::Rgba16f,
        near: default_near(),
    };
    fn num<T: std::str::FromStr>(flag: &str, v: Option<String>) -> Result<T, String> {
        let v = v.ok_or_else(|| format!("{flag} needs a value"))?;
        v.parse().map_err(|_| format!("{flag}: not a valid number: {v}"))
    }
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--resolution" => a.resolution = num(&arg, it.next())?,
            "--width" => a.width = num(&arg, it.next())?,
            "--height" => a.height = num(&arg, it.next())?,
            "--reps" => a.reps = num(&arg, it.next())?,
            "--warmup" => a.warmup = num(&arg, it.next())?,
            "--near" => a.near = num(&arg, it.next())?,
            "--out-dir" => a.out_dir = PathBuf::from(it.next().ok_or("--out-dir needs a value")?),
            "--json" => a.json = Some(PathBuf::from(it.next().ok_or("--json needs a value")?)),
            "--target" => {
                a.target = match it.next().as_deref() {
                    Some("rgba16f") => Target::Rgba16f,
                    Some("rgba8srgb") => Target::Rgba8Srgb,
                    _ => return Err("--target: rgba16f or rgba8srgb".into()),
                }
            }
            "-h" | "--help" => {
                println!("{USAGE}");
                std::process::exit(0);
            }
            s if s.starts_with('-') => return Err(format!("unknown option {s}")),
            s => {
                if scene.replace(PathBuf::from(s)).is_some() {
                    return Err("more than one scene given".into());
                }
            }
        }
    }
    a.scene = scene.ok_or("no scene given")?;
    if a.reps == 0 || a.width == 0 || a.height == 0 || a.resolution < 2 {
        return Err("--reps, --width, --height must be positive and --resolution at least 2".into());
    }
    Ok(a)
}

fn main() {
    // llvmpipe reads LP_NUM_THREADS when the device is created; its own
    // default is the number of CPUs. Make it explicit (and recordable) before
    // any thread exists.
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    if std::env::var_os("LP_NUM_THREADS").is_none() {
        std::env::set_var("LP_NUM_THREADS", cores.to_string());
    }
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("raster-bench: {e}\n{USAGE}");
            std::process::exit(2);
        }
    };
    if let Err(e) = run(&args, cores) {
        eprintln!("raster-bench: error: {e}");
        std::process::exit(1);
    }
}

/// Process CPU time (user + system), seconds, from /proc/self/stat (USER_HZ = 100).
fn cpu_seconds() -> f64 {
    let Ok(s) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    let Some(rest) = s.rfind(')').map(|i| &s[i + 2..]) else {
        return f64::NAN;
    };
    let f: Vec<&str> = rest.split_whitespace().collect();
    // After "pid (comm) ", field 3 (state) is f[0]; utime is field 14, stime 15.
    let ticks = |k: usize| f.get(k - 3).and_then(|v| v.parse::<f64>().ok()).unwrap_or(f64::NAN);
    (ticks(14) + ticks(15)) / 100.0
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct GpuVertex {
    position: [f32; 3],
    normal: [f32; 3],
    material: u32,
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct Globals {
    eye: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    back: [f32; 4],
    proj: [f32; 4],
    counts: [u32; 4],
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct GpuMaterial {
    ambient: [f32; 4],
    diffuse: [f32; 4],
    specular: [f32; 4],
    emission: [f32; 4],
    params: [f32; 4],
    flags: [u32; 4],
}

#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct GpuLight {
    position: [f32; 4],
    radiance: [f32; 4],
    attenuation: [f32; 4],
}

fn f4(a: [f64; 3], w: f32) -> [f32; 4] {
    [a[0] as f32, a[1] as f32, a[2] as f32, w]
}

/// The shader's uniforms: isoray's ViewTransform and the eye.
fn globals(scene: &Scene, w: u32, h: u32, near: f64) -> Globals {
    let [forward, right, up] = scene.camera.basis();
    let t = scene.camera.tan_half_fov();
    let aspect = w as f64 / h as f64;
    Globals {
        eye: f4(scene.camera.position, 1.0),
        right: f4(right, 0.0),
        up: f4(up, 0.0),
        back: f4(forward.map(|x| -x), 0.0),
        proj: [(1.0 / (t * aspect)) as f32, (1.0 / t) as f32, near as f32, 0.0],
        counts: [scene.lights.len() as u32, 0, 0, 0],
    }
}

fn materials(scene: &Scene) -> Vec<GpuMaterial> {
    scene
        .materials
        .iter()
        .map(|m| GpuMaterial {
            ambient: f4(m.ambient, 0.0),
            diffuse: f4(m.diffuse, 0.0),
            specular: f4(m.specular, 0.0),
            emission: f4(m.emission, 0.0),
            params: [m.shininess as f32, m.checker.map_or(1.0, |c| c.1 as f32), 0.0, 0.0],
            flags: [
                match m.model {
                    ShadingModel::Phong => 0,
                    ShadingModel::BlinnPhong => 1,
                },
                match m.specular_function {
                    SpecularFunction::Pow => 0,
                    SpecularFunction::Schlick => 1,
                },
                m.checker.map_or(0, |c| c.0 as u32),
                m.checker.is_some() as u32,
            ],
        })
        .collect()
}

fn lights(scene: &Scene) -> Vec<GpuLight> {
    let mut out: Vec<GpuLight> = scene
        .lights
        .iter()
        .map(|l| {
            let (position, w) = match l.kind {
                LightKind::Directional { direction } => (direction, 0.0),
                LightKind::Point { position }
                | LightKind::Sphere { position, .. }
                | LightKind::Rect { position, .. } => (position, 1.0),
            };
            let c = l.color.map(|x| x as f32);
            let i = l.intensity as f32;
            GpuLight {
                position: f4(position, w),
                radiance: [c[0] * i, c[1] * i, c[2] * i, 0.0],
                attenuation: f4(l.attenuation, 0.0),
            }
        })
        .collect();
    if out.is_empty() {
        out.push(GpuLight::zeroed()); // a storage binding may not be empty; counts.x = 0
    }
    out
}

/// Vertices and indices of every object; opaque objects' triangles first
/// (`opaque` indices), re-wound counter-clockwise around the face normal
/// oriented by the vertex normals (isoray's culling orientation). Returns
/// (vertices, indices, opaque index count, triangles re-wound).
fn geometry(scene: &Scene, meshed: &MeshedScene) -> (Vec<GpuVertex>, Vec<u32>, u32, usize) {
    let mut verts = Vec::new();
    let mut opaque = Vec::new();
    let mut transparent = Vec::new();
    let mut flipped = 0;
    for om in &meshed.objects {
        let m = &scene.materials[om.material];
        let is_opaque = (1.0 - m.transparency as f32).clamp(0.0, 1.0) >= 1.0;
        let base = verts.len() as u32;
        let mesh = &om.mesh;
        verts.extend(mesh.positions.iter().zip(&mesh.normals).map(|(p, n)| GpuVertex {
            position: *p,
            normal: *n,
            material: om.material as u32,
        }));
        let out = if is_opaque { &mut opaque } else { &mut transparent };
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = mesh.corners(t);
            let (ab, ac) = (
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            let face = [
                ab[1] * ac[2] - ab[2] * ac[1],
                ab[2] * ac[0] - ab[0] * ac[2],
                ab[0] * ac[1] - ab[1] * ac[0],
            ];
            let ns = tri.map(|v| mesh.normals[v as usize].map(f64::from));
            let nsum: [f64; 3] = std::array::from_fn(|k| ns[0][k] + ns[1][k] + ns[2][k]);
            let dot = face[0] * nsum[0] + face[1] * nsum[1] + face[2] * nsum[2];
            if dot < 0.0 {
                flipped += 1;
                out.extend([base + tri[0], base + tri[2], base + tri[1]]);
            } else {
                out.extend([base + tri[0], base + tri[1], base + tri[2]]);
            }
        }
    }
    let n_opaque = opaque.len() as u32;
    opaque.extend(transparent);
    (verts, opaque, n_opaque, flipped)
}

/// IEEE half → f32.
fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1f) as i32;
    let mant = (h & 0x3ff) as f32;
    sign * match exp {
        0 => mant * 2f32.powi(-24),
        31 => {
            if mant == 0.0 {
                f32::INFINITY
            } else {
                f32::NAN
            }
        }
        e => (1.0 + mant / 1024.0) * 2f32.powi(e - 15),
    }
}

struct Gpu {
    adapter_name: String,
    driver: String,
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipelines: [wgpu::RenderPipeline; 2],
    bind_group: wgpu::BindGroup,
    vertex_buf: wgpu::Buffer,
    index_buf: wgpu::Buffer,
    n_opaque: u32,
    n_indices: u32,
    color: wgpu::Texture,
    color_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_row: u32,
    width: u32,
    height: u32,
    target: Target,
    background: wgpu::Color,
}

struct GpuSetup {
    device_s: f64,
    pipeline_s: f64,
    upload_s: f64,
    flipped: usize,
}

fn setup_gpu(scene: &Scene, meshed: &MeshedScene, a: &Args) -> Result<(Gpu, GpuSetup), String> {
    let t0 = Instant::now();
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    desc.flags = wgpu::InstanceFlags::empty();
    let instance = wgpu::Instance::new(desc);
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
    if adapters.is_empty() {
        return Err(
            "no Vulkan adapter found: install Mesa's lavapipe (bench/install-peers.sh: \
                    mesa-vulkan-drivers, libvulkan1); `vulkaninfo --summary` should list llvmpipe"
                .into(),
        );
    }
    let names: Vec<String> = adapters.iter().map(|ad| ad.get_info().name).collect();
    let adapter = adapters
        .into_iter()
        .find(|ad| ad.get_info().name.contains("llvmpipe"))
        .ok_or_else(|| format!("no llvmpipe (lavapipe) Vulkan adapter among: {}", names.join(", ")))?;
    let info = adapter.get_info();
    let limits = adapter.limits();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("raster-bench"),
        required_limits: wgpu::Limits {
            max_buffer_size: limits.max_buffer_size,
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            ..wgpu::Limits::default()
        },
        ..Default::default()
    }))
    .map_err(|e| format!("request_device: {e}"))?;
    let device_s = t0.elapsed().as_secs_f64();

    let t1 = Instant::now();
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("phong.wgsl"),
        source: wgpu::ShaderSource::Wgsl(include_str!("phong.wgsl").into()),
    });
    let storage = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("globals, materials, lights"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            storage(1),
            storage(2),
        ],
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("layout"),
        bind_group_layouts: &[Some(&bgl)],
        immediate_size: 0,
    });
    let attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Uint32];
    let pipeline = |cull: Option<wgpu::Face>| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("phong"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<GpuVertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attrs,
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: cull,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: a.target.format(),
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    };
    let pipelines = [pipeline(Some(wgpu::Face::Back)), pipeline(None)];
    let pipeline_s = t1.elapsed().as_secs_f64();

    let t2 = Instant::now();
    let (verts, indices, n_opaque, flipped) = geometry(scene, meshed);
    let init = |label, contents: &[u8], usage| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    };
    let vertex_buf = init("vertices", bytemuck::cast_slice(&verts), wgpu::BufferUsages::VERTEX);
    let index_buf = init("indices", bytemuck::cast_slice(&indices), wgpu::BufferUsages::INDEX);
    let g = globals(scene, a.width, a.height, a.near);
    let globals_buf = init("globals", bytemuck::bytes_of(&g), wgpu::BufferUsages::UNIFORM);
    let mats = materials(scene);
    let mats_buf = init("materials", bytemuck::cast_slice(&mats), wgpu::BufferUsages::STORAGE);
    let ls = lights(scene);
    let lights_buf = init("lights", bytemuck::cast_slice(&ls), wgpu::BufferUsages::STORAGE);
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("bind group"),
        layout: &bgl,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: globals_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: mats_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: lights_buf.as_entire_binding(),
            },
        ],
    });
    let size = wgpu::Extent3d {
        width: a.width,
        height: a.height,
        depth_or_array_layers: 1,
    };
    let texture = |label, format, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let color = texture(
        "colour",
        a.target.format(),
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let depth = texture(
        "depth",
        wgpu::TextureFormat::Depth32Float,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let row = a.width * a.target.bytes_per_pixel();
    let padded_row = row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read-back"),
        size: padded_row as u64 * a.height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let idx = queue.submit([]);
    device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(idx),
            timeout: None,
        })
        .map_err(|e| format!("poll: {e}"))?;
    let upload_s = t2.elapsed().as_secs_f64();
    let bg = scene.render.background;
    Ok((
        Gpu {
            adapter_name: info.name.clone(),
            driver: format!("{} {}", info.driver, info.driver_info),
            color_view: color.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            color,
            device,
            queue,
            pipelines,
            bind_group,
            vertex_buf,
            index_buf,
            n_opaque,
            n_indices: indices.len() as u32,
            readback,
            padded_row,
            width: a.width,
            height: a.height,
            target: a.target,
            // The clear value as isoray's Z-buffer starts: the background in f32.
            background: wgpu::Color {
                r: bg[0] as f32 as f64,
                g: bg[1] as f32 as f64,
                b: bg[2] as f32 as f64,
                a: 1.0,
            },
        },
        GpuSetup {
            device_s,
            pipeline_s,
            upload_s,
            flipped,
        },
    ))
}

impl Gpu {
    /// One frame: draw, copy to the read-back buffer, map, copy the rows
    /// into `out` (tightly packed). Returns when the pixels are in `out`.
    /// `draw` false: the same without the draw calls (clear and read-back only).
    fn frame(&self, out: &mut Vec<u8>, draw: bool) -> Result<(), String> {
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &self.color_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(self.background),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                ..Default::default()
            });
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.set_vertex_buffer(0, self.vertex_buf.slice(..));
            pass.set_index_buffer(self.index_buf.slice(..), wgpu::IndexFormat::Uint32);
            if draw && self.n_opaque > 0 {
                pass.set_pipeline(&self.pipelines[0]);
                pass.draw_indexed(0..self.n_opaque, 0, 0..1);
            }
            if draw && self.n_indices > self.n_opaque {
                pass.set_pipeline(&self.pipelines[1]);
                pass.draw_indexed(self.n_opaque..self.n_indices, 0, 0..1);
            }
        }
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.color,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
        let idx = self.queue.submit([enc.finish()]);
        let slice = self.readback.slice(..);
        slice.map_async(wgpu::MapMode::Read, |r| {
            if let Err(e) = r {
                eprintln!("raster-bench: map_async: {e}");
            }
        });
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(idx),
                timeout: None,
            })
            .map_err(|e| format!("poll: {e}"))?;
        {
            let view = slice.get_mapped_range().map_err(|e| format!("get_mapped_range: {e}"))?;
            let row = (self.width * self.target.bytes_per_pixel()) as usize;
            out.resize(row * self.height as usize, 0);
            for (dst, src) in out
                .chunks_exact_mut(row)
                .zip(view.chunks_exact(self.padded_row as usize))
            {
                dst.copy_from_slice(&src[..row]);
            }
        }
        self.readback.unmap();
        Ok(())
    }

    /// The read-back pixels as 8-bit sRGB RGB, the way isoray writes PNGs.
    fn srgb8(&self, px: &[u8]) -> Vec<u8> {
        match self.target {
            Target::Rgba16f => {
                let lin: Vec<[f32; 3]> = px
                    .chunks_exact(8)
                    .map(|c| std::array::from_fn(|k| f16_to_f32(u16::from_le_bytes([c[2 * k], c[2 * k + 1]]))))
                    .collect();
                to_srgb8(&lin)
            }
            Target::Rgba8Srgb => px.chunks_exact(4).flat_map(|c| [c[0], c[1], c[2]]).collect(),
        }
    }
}

fn write_png(path: &Path, w: u32, h: u32, rgb: &[u8]) -> Result<(), String> {
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut wr = enc.write_header().map_err(|e| format!("{}: {e}", path.display()))?;
    wr.write_image_data(rgb).map_err(|e| format!("{}: {e}", path.display()))
}

#[derive(Default)]
struct Stats {
    times: Vec<f64>,
    cpu: Vec<f64>,
}

impl Stats {
    fn min(&self) -> f64 {
        self.times.iter().copied().fold(f64::INFINITY, f64::min)
    }
    fn median(&self) -> f64 {
        median(&self.times)
    }
    /// CPU seconds per wall second over the timed frames (effective threads).
    fn parallelism(&self) -> f64 {
        self.cpu.iter().sum::<f64>() / self.times.iter().sum::<f64>()
    }
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        s[n / 2]
    } else {
        (s[n / 2 - 1] + s[n / 2]) / 2.0
    }
}

fn timed<T>(f: impl FnOnce() -> T) -> (T, f64, f64) {
    let c0 = cpu_seconds();
    let t0 = Instant::now();
    let r = f();
    let t = t0.elapsed().as_secs_f64();
    (r, t, cpu_seconds() - c0)
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

fn json_str(s: &str) -> String {
    let mut o = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => o.push_str("\\\""),
            '\\' => o.push_str("\\\\"),
            c if (c as u32) < 0x20 => o.push_str(&format!("\\u{:04x}", c as u32)),
            c => o.push(c),
        }
    }
    o.push('"');
    o
}

fn run(a: &Args, cores: usize) -> Result<(), String> {
    let overrides = [
        format!("render.width={}", a.width),
        format!("render.height={}", a.height),
    ];
    let scene = isoray_scene::load(&a.scene, &overrides).map_err(|e| e.to_string())?;
    let opts = RasterOptions {
        hidden: HiddenSurface::ZBuffer,
        shading: Shading::Phong,
        resolution: a.resolution,
        near: a.near,
        ..RasterOptions::default()
    };

    let (meshed, mesh_s, _) = timed(|| mesh_scene(&scene, a.resolution));
    let meshed = meshed.map_err(|e| e.to_string())?;
    for w in &meshed.warnings {
        eprintln!("raster-bench: warning: {w}");
    }
    let n_tris: usize = meshed.objects.iter().map(|o| o.mesh.triangles.len()).sum();
    let n_verts: usize = meshed.objects.iter().map(|o| o.mesh.positions.len()).sum();
    eprintln!(
        "raster-bench: meshed {} objects at resolution {}: {n_tris} triangles, {n_verts} vertices in {mesh_s:.2} s",
        meshed.objects.len(),
        a.resolution
    );

    let (gpu, setup) = setup_gpu(&scene, &meshed, a)?;
    let lp_threads = std::env::var("LP_NUM_THREADS").unwrap_or_default();
    let rayon_threads = rayon::current_num_threads();
    eprintln!(
        "raster-bench: adapter: {} ({}), LP_NUM_THREADS={lp_threads}; rayon threads: {rayon_threads}",
        gpu.adapter_name, gpu.driver
    );
    eprintln!(
        "raster-bench: wgpu setup: device {:.3} s, pipelines {:.3} s, upload {:.3} s ({} of {n_tris} triangles re-wound)",
        setup.device_s, setup.pipeline_s, setup.upload_s, setup.flipped
    );

    // Frames: warm-up, then the timed ones; isoray and llvmpipe alternate.
    let mut iso = Stats::default();
    let mut gpu_st = Stats::default();
    let mut iso_img = None;
    let mut px = Vec::new();
    let mut first_gpu = f64::NAN;
    let mut first_iso = f64::NAN;
    for r in 0..a.warmup + a.reps {
        let (img, t, c) = timed(|| raster_meshes(&scene, &meshed, &opts));
        let img = img.map_err(|e| e.to_string())?;
        let (res, tg, cg) = timed(|| gpu.frame(&mut px, true));
        res?;
        if r == 0 {
            first_iso = t;
            first_gpu = tg;
        }
        let tag = if r < a.warmup { "warm-up" } else { "frame" };
        eprintln!("raster-bench: {tag} {r}: isoray {t:.4} s (cpu {c:.2} s), llvmpipe {tg:.4} s (cpu {cg:.2} s)");
        if r >= a.warmup {
            iso.times.push(t);
            iso.cpu.push(c);
            gpu_st.times.push(tg);
            gpu_st.cpu.push(cg);
        }
        iso_img = Some(img);
    }
    let iso_img = iso_img.ok_or("no frame")?;
    // The fixed cost of a llvmpipe frame: clear, copy, map, copy out, no triangles.
    let mut empty = Stats::default();
    let mut scratch = Vec::new();
    for _ in 0..a.reps {
        let (res, t, c) = timed(|| gpu.frame(&mut scratch, false));
        res?;
        empty.times.push(t);
        empty.cpu.push(c);
    }
    let iso_triangles = iso_img.triangles;

    // Images and their agreement.
    std::fs::create_dir_all(&a.out_dir).map_err(|e| format!("{}: {e}", a.out_dir.display()))?;
    let iso8 = to_srgb8(&iso_img.color);
    let gpu8 = gpu.srgb8(&px);
    let (w, h) = (a.width, a.height);
    let iso_png = a.out_dir.join("isoray.png");
    let gpu_png = a.out_dir.join("llvmpipe.png");
    let diff_png = a.out_dir.join("diff.png");
    write_png(&iso_png, w, h, &iso8)?;
    write_png(&gpu_png, w, h, &gpu8)?;
    let mut diff = Vec::with_capacity(iso8.len());
    let (mut differ, mut max_d, mut sum_d) = (0usize, 0u8, 0u64);
    for (p, q) in iso8.chunks_exact(3).zip(gpu8.chunks_exact(3)) {
        let d = (0..3).map(|k| p[k].abs_diff(q[k])).max().unwrap_or(0);
        max_d = max_d.max(d);
        sum_d += (0..3).map(|k| p[k].abs_diff(q[k]) as u64).sum::<u64>();
        if d > 8 {
            differ += 1;
            diff.extend([255, 0, 0]);
        } else {
            let grey = ((p[0] as u32 + p[1] as u32 + p[2] as u32) / 6) as u8;
            diff.extend([grey, grey, grey]);
        }
    }
    write_png(&diff_png, w, h, &diff)?;
    let n_px = (w * h) as f64;
    let frac = differ as f64 / n_px;
    let mean_d = sum_d as f64 / (3.0 * n_px);

    let ratio_min = iso.min() / gpu_st.min();
    let ratio_med = iso.median() / gpu_st.median();
    let adapter = &gpu.adapter_name;
    let cpu = cpu_model();
    let iso_par = iso.parallelism();
    let gpu_par = gpu_st.parallelism();
    let setup_total = setup.device_s + setup.pipeline_s + setup.upload_s;
    println!("## Polygon pipeline: isoray Z-buffer vs llvmpipe (lavapipe via wgpu), same triangles, same Phong");
    println!();
    println!(
        "scene {}, {w}x{h}, mesh resolution {}: {n_tris} triangles ({n_verts} vertices) in {} objects; \
         meshing {mesh_s:.2} s (once, shared)",
        a.scene.display(),
        a.resolution,
        meshed.objects.len()
    );
    println!(
        "machine: {cpu}, {cores} cores; LP_NUM_THREADS={lp_threads}; rayon threads {rayon_threads}; adapter {adapter} ({})",
        gpu.driver
    );
    println!(
        "{} warm-up + {} timed frames each, alternating; a frame ends with its pixels in CPU memory",
        a.warmup, a.reps
    );
    println!();
    println!("| renderer | min s/frame | median s/frame | first frame s | CPU s / wall s |");
    println!("|---|---:|---:|---:|---:|");
    println!(
        "| isoray raster_meshes (ZBuffer, Phong; {iso_triangles} triangles drawn after culling) | {:.4} | {:.4} | {first_iso:.4} | {iso_par:.2} |",
        iso.min(),
        iso.median()
    );
    println!(
        "| llvmpipe via wgpu ({} target + Depth32Float, back faces culled) | {:.4} | {:.4} | {first_gpu:.4} | {gpu_par:.2} |",
        a.target.name(),
        gpu_st.min(),
        gpu_st.median()
    );
    println!(
        "| llvmpipe, empty frame (clear, copy, map, copy out: no draw) | {:.4} | {:.4} | – | {:.2} |",
        empty.min(),
        empty.median(),
        empty.parallelism()
    );
    println!();
    println!(
        "ratio isoray / llvmpipe: {ratio_med:.2} (medians), {ratio_min:.2} (minima); target: within 2x ({})",
        if ratio_med <= 2.0 { "met" } else { "not met" }
    );
    println!(
        "wgpu one-time setup: {setup_total:.3} s (instance + adapter + device {:.3} s, shader + pipelines {:.3} s, \
         buffers + upload {:.3} s)",
        setup.device_s, setup.pipeline_s, setup.upload_s
    );
    println!(
        "pixel agreement (8-bit sRGB): {:.3}% of pixels differ by more than 8 in some channel; max difference {max_d}, \
         mean |difference| {mean_d:.3}",
        100.0 * frac
    );
    println!(
        "images: {} {} {}",
        iso_png.display(),
        gpu_png.display(),
        diff_png.display()
    );

    if let Some(path) = &a.json {
        let list = |v: &[f64]| v.iter().map(|x| format!("{x:.6}")).collect::<Vec<_>>().join(", ");
        let j = format!(
            "{{\n  \"scene\": {},\n  \"width\": {w},\n  \"height\": {h},\n  \"resolution\": {},\n  \
             \"triangles\": {n_tris},\n  \"vertices\": {n_verts},\n  \"isoray_triangles_drawn\": {iso_triangles},\n  \
             \"triangles_rewound\": {},\n  \"meshing_s\": {mesh_s:.6},\n  \"warmup\": {},\n  \"reps\": {},\n  \
             \"isoray\": {{ \"min_s\": {:.6}, \"median_s\": {:.6}, \"first_s\": {first_iso:.6}, \"times_s\": [{}], \
             \"cpu_per_wall\": {iso_par:.3}, \"rayon_threads\": {rayon_threads} }},\n  \
             \"llvmpipe\": {{ \"min_s\": {:.6}, \"median_s\": {:.6}, \"first_s\": {first_gpu:.6}, \"times_s\": [{}], \
             \"cpu_per_wall\": {gpu_par:.3}, \"lp_num_threads\": {}, \"adapter\": {}, \"driver\": {}, \
             \"target\": {}, \"empty_frame_median_s\": {:.6} }},\n  \
             \"ratio_median\": {ratio_med:.4},\n  \"ratio_min\": {ratio_min:.4},\n  \
             \"wgpu_setup_s\": {{ \"device\": {:.6}, \"pipelines\": {:.6}, \"upload\": {:.6}, \"total\": {setup_total:.6} }},\n  \
             \"pixels_differing_gt8_fraction\": {frac:.6},\n  \"max_channel_difference\": {max_d},\n  \
             \"mean_abs_difference\": {mean_d:.4},\n  \"cpu\": {},\n  \"cores\": {cores},\n  \
             \"images\": {{ \"isoray\": {}, \"llvmpipe\": {}, \"diff\": {} }}\n}}\n",
            json_str(&a.scene.display().to_string()),
            a.resolution,
            setup.flipped,
            a.warmup,
            a.reps,
            iso.min(),
            iso.median(),
            list(&iso.times),
            gpu_st.min(),
            gpu_st.median(),
            list(&gpu_st.times),
            json_str(&lp_threads),
            json_str(adapter),
            json_str(&gpu.driver),
            json_str(a.target.name()),
            empty.median(),
            setup.device_s,
            setup.pipeline_s,
            setup.upload_s,
            json_str(&cpu),
            json_str(&iso_png.display().to_string()),
            json_str(&gpu_png.display().to_string()),
            json_str(&diff_png.display().to_string()),
        );
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        std::fs::write(path, j).map_err(|e| format!("{}: {e}", path.display()))?;
        eprintln!("raster-bench: report written to {}", path.display());
    }
    Ok(())
}
