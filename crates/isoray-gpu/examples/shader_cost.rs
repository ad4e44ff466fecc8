//! Developer tool: how long the driver takes to compile a tracer module.
//!
//! `shader_cost dump SCENE OUT.wgsl [compiled|interpreted]` writes a scene's module;
//! `shader_cost time FILE.wgsl` builds it and runs one empty dispatch (lavapipe
//! compiles at the first dispatch), printing both times. Set
//! `MESA_SHADER_CACHE_DISABLE=true` to measure cold compiles.

use std::time::Instant;

use isoray_gpu::{Kernel, SceneCode};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    match args.get(1).map(String::as_str) {
        Some("dump") => {
            let scene = isoray_scene::load(std::path::Path::new(&args[2]), &[]).expect("scene");
            let kernel = match args.get(4).map(String::as_str) {
                Some("interpreted") => Kernel::Interpreted,
                _ => Kernel::Compiled,
            };
            let code = SceneCode::new(&scene, kernel).expect("code");
            std::fs::write(&args[3], code.source).expect("write");
        }
        Some("time") => time(&std::fs::read_to_string(&args[2]).expect("read")),
        _ => eprintln!("usage: shader_cost dump SCENE OUT.wgsl [kernel] | time FILE.wgsl"),
    }
}

fn time(source: &str) {
    let gpu = isoray_gpu::Gpu::new().expect("adapter");
    let (device, queue) = (&gpu.device, &gpu.queue);
    let ty = |i: usize| match i {
        1 => wgpu::BufferBindingType::Uniform,
        6 | 7 | 9 => wgpu::BufferBindingType::Storage { read_only: false },
        _ => wgpu::BufferBindingType::Storage { read_only: true },
    };
    let layout_entries: Vec<wgpu::BindGroupLayoutEntry> = (0..10)
        .map(|i| wgpu::BindGroupLayoutEntry {
            binding: i as u32,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: ty(i),
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        })
        .collect();
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &layout_entries,
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let start = Instant::now();
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: None,
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let built = start.elapsed();
    let n = 10;
    let bufs: Vec<wgpu::Buffer> = (0..n)
        .map(|i| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: None,
                size: 4096,
                usage: if i == 1 {
                    wgpu::BufferUsages::UNIFORM
                } else {
                    wgpu::BufferUsages::STORAGE
                },
                mapped_at_creation: false,
            })
        })
        .collect();
    let entries: Vec<wgpu::BindGroupEntry> = bufs
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &layout,
        entries: &entries,
    });
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    queue.submit([enc.finish()]);
    device
        .poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: None,
        })
        .expect("poll");
    println!(
        "pipeline {:.2} s, first dispatch done at {:.2} s",
        built.as_secs_f64(),
        start.elapsed().as_secs_f64()
    );
}
