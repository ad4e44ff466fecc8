//! Developer tool: what a software Vulkan driver (lavapipe) charges for
//! the shapes of code the tracer is made of, measured on one compute
//! dispatch of 2^20 lanes (`bash bench/gpu/lavapipe-costs.sh`; the table
//! and what it says are in docs/BENCHMARKS.md, "What lavapipe charges").
//!
//! Each case is a shader whose lanes do `WORK` (400 lines of sin and cos)
//! in some construct, with a condition read from a buffer so that the
//! compiler cannot know it; the flag pattern says which lanes want the
//! work. A second set reads 64 buffer values in a loop, from a storage
//! buffer, from a uniform buffer and from a texture, inside and outside
//! divergent code.

use std::time::Instant;
use wgpu::util::DeviceExt;

const LANES: u32 = 1 << 20;

/// Where the table the reads come from lives.
#[derive(Clone, Copy)]
enum Table {
    Storage,
    Uniform,
    Texture,
}
const WORKGROUP: u32 = 64;

fn main() {
    let mut work = String::new();
    for k in 0..400 {
        work.push_str(&format!("        x = sin(x) * 1.01 + cos(x * 0.7 + {}.0);\n", k % 7));
    }
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    desc.flags = wgpu::InstanceFlags::empty();
    let instance = wgpu::Instance::new(desc);
    let adapter = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN))
        .into_iter()
        .next()
        .expect("a Vulkan adapter");
    println!("adapter: {}", adapter.get_info().name);
    let (device, queue) =
        pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default())).expect("a device");
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: 4 * LANES as u64,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let table: Vec<f32> = (0..1024).map(|i| i as f32 * 0.001).collect();
    let table_bytes: &[u8] = bytemuck::cast_slice(&table);
    let storage_table = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: table_bytes,
        usage: wgpu::BufferUsages::STORAGE,
    });
    let uniform_table = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: table_bytes,
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let texture = device.create_texture_with_data(
        &queue,
        &wgpu::TextureDescriptor {
            label: None,
            size: wgpu::Extent3d {
                width: 32,
                height: 32,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        table_bytes,
    );
    let texture_view = texture.create_view(&Default::default());
    let run = |body: &str, every: u32, table: Table| -> f64 {
        let decl = match table {
            Table::Uniform => "@group(0) @binding(2) var<uniform> table: array<vec4<f32>, 256>;\nfn at(i: u32) -> f32 { return table[i / 4u][i % 4u]; }\n",
            Table::Storage => "@group(0) @binding(2) var<storage, read> table: array<f32>;\nfn at(i: u32) -> f32 { return table[i]; }\n",
            Table::Texture => "@group(0) @binding(2) var table: texture_2d<f32>;\nfn at(i: u32) -> f32 { return textureLoad(table, vec2<u32>(i % 32u, i / 32u), 0).x; }\n",
        };
        let src = format!(
            "@group(0) @binding(0) var<storage, read_write> out: array<f32>;\n\
             @group(0) @binding(1) var<storage, read> flag: array<u32>;\n{decl}\
             @compute @workgroup_size({WORKGROUP})\nfn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
             \x20   var x = f32(id.x) * 1e-6;\n    let c = flag[id.x] != 0u;\n{body}    out[id.x] = x + at(0u) * 0.0;\n}}\n"
        );
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: None,
            source: wgpu::ShaderSource::Wgsl(src.into()),
        });
        let pipe = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: None,
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let flags: Vec<u32> = (0..LANES).map(|i| (every != 0 && i % every == 0) as u32).collect();
        let fbuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::cast_slice(&flags),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let resource = match table {
            Table::Uniform => uniform_table.as_entire_binding(),
            Table::Storage => storage_table.as_entire_binding(),
            Table::Texture => wgpu::BindingResource::TextureView(&texture_view),
        };
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipe.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: out.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: fbuf.as_entire_binding(),
                },
                wgpu::BindGroupEntry { binding: 2, resource },
            ],
        });
        // The best of three dispatches (the first also compiles).
        let mut best = f64::MAX;
        for _ in 0..3 {
            let start = Instant::now();
            let mut enc = device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipe);
                pass.set_bind_group(0, &bg, &[]);
                pass.dispatch_workgroups(LANES / WORKGROUP, 1, 1);
            }
            queue.submit([enc.finish()]);
            device.poll(wgpu::PollType::wait_indefinitely()).expect("the dispatch");
            best = best.min(start.elapsed().as_secs_f64());
        }
        best * 1e3
    };
    let shapes = [
        ("no work", String::new()),
        ("the work, unconditionally", work.clone()),
        ("if (c) { work }", format!("    if (c) {{\n{work}    }}\n")),
        (
            "for (i < flag) { work } (0 or 1 turn)",
            format!("    for (var i = 0u; i < flag[id.x]; i++) {{\n{work}    }}\n"),
        ),
    ];
    println!("\n| construct | no lane wants it | 1 lane in 64 | 1 lane in 8 | every lane |");
    println!("|---|---|---|---|---|");
    for (name, body) in &shapes {
        let t: Vec<String> = [0, 64, 8, 1]
            .iter()
            .map(|&e| format!("{:.0} ms", run(body, e, Table::Storage)))
            .collect();
        println!("| `{name}` | {} |", t.join(" | "));
    }
    let reads = "    for (var k = 0u; k < 64u; k++) { x += at((id.x + k * 7u) % 16u); }\n";
    let divergent = format!("    if (c) {{\n{reads}    }}\n");
    println!("\n| 64 table reads a lane | storage buffer | uniform buffer | texture (textureLoad) |");
    println!("|---|---|---|---|");
    for (name, body, every) in [
        ("in uniform control flow", reads.to_string(), 0),
        ("inside an `if` every lane takes", divergent, 1),
    ] {
        println!(
            "| {name} | {:.1} ms | {:.1} ms | {:.1} ms |",
            run(&body, every, Table::Storage),
            run(&body, every, Table::Uniform),
            run(&body, every, Table::Texture)
        );
    }
}
