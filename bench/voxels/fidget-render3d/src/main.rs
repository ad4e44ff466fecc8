//! fidget-render3d MODEL.vm SIZE DEPTH SCALE PITCH YAW ROLL jit|vm THREADS OUT.png
//!
//! Renders depth and normals of a fidget `.vm` model with fidget's voxel
//! renderer: a SIZE × SIZE image of columns of DEPTH voxels, the view
//! model = Ry(yaw)·Rz(roll)·Rx(pitch)·world/scale (fidget's render3d
//! --isometric; the same matrix `isoray depth` builds), THREADS rayon
//! threads. Writes the depth as a gray PNG (nearer brighter) and prints
//!   load: S s (parse and, for jit, nothing yet: JIT compilation is lazy)
//!   render: S s
//!   filled: N pixels
use std::time::Instant;

use fidget::context::Context;
use fidget::raster::voxel::{render, EvalConfig, RenderConfig};
use fidget::render::{CancelToken, ThreadPool, VoxelSize};
use nalgebra::{Matrix4, Rotation3, Vector3};

fn view(scale: f32, pitch: f32, yaw: f32, roll: f32) -> Matrix4<f32> {
    let r = |axis: Vector3<f32>, deg: f32| Rotation3::new(axis * deg.to_radians()).to_homogeneous();
    r(Vector3::y(), yaw) * r(Vector3::z(), roll) * r(Vector3::x(), pitch) * Matrix4::new_scaling(1.0 / scale)
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() != 11 {
        eprintln!("usage: {} MODEL.vm SIZE DEPTH SCALE PITCH YAW ROLL jit|vm THREADS OUT.png", a[0]);
        std::process::exit(2);
    }
    let num = |i: usize| -> f32 { a[i].parse().unwrap_or_else(|_| panic!("argument {i}: a number")) };
    let (size, depth) = (num(2) as u32, num(3) as u32);
    let m = view(num(4), num(5), num(6), num(7));
    let threads: usize = a[9].parse().expect("THREADS: an integer");
    let t0 = Instant::now();
    let file = std::fs::File::open(&a[1]).expect("open the model");
    let (ctx, root) = Context::from_text(file).expect("parse the model");
    let pool = ThreadPool::Custom(rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap());
    let cfg = RenderConfig {
        image_size: VoxelSize::new(size, size, depth),
        world_to_model: m,
    };
    let eval = EvalConfig {
        tile_sizes: None,
        threads: Some(&pool),
        cancel: CancelToken::new(),
    };
    let t1 = Instant::now();
    let image = match a[8].as_str() {
        "jit" => {
            let shape = fidget::jit::JitShape::new(&ctx, root).expect("a shape");
            render(shape.try_into().expect("x, y, z only"), &cfg, &eval)
        }
        "vm" => {
            let shape = fidget::vm::VmShape::new(&ctx, root).expect("a shape");
            render(shape.try_into().expect("x, y, z only"), &cfg, &eval)
        }
        e => panic!("evaluator: jit or vm, found {e}"),
    }
    .expect("not cancelled");
    let t2 = Instant::now();
    let gray: Vec<u8> = image.iter().map(|p| (p.depth as u64 * 255 / depth.max(1) as u64) as u8).collect();
    image::save_buffer(&a[10], &gray, size, size, image::ColorType::L8).expect("write the PNG");
    println!("load: {:.4} s", (t1 - t0).as_secs_f64());
    println!("render: {:.4} s", (t2 - t1).as_secs_f64());
    println!("filled: {} pixels", image.iter().filter(|p| p.depth > 0).count());
}
