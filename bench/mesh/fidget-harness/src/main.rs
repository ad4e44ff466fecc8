//! fidget-csg DEPTH OUT.stl [BOUND]
//!
//! Meshes the CSG classic (sphere r 1.35 ∩ box of half extent 1, minus three
//! cylinders of radius 0.55 along x, y and z, centred at the origin) with
//! fidget's manifold dual contouring on the cube [-BOUND, BOUND]^3 (default
//! 1.05): an octree of depth DEPTH, i.e. cells of side 2 BOUND / 2^DEPTH at the
//! finest level, all cores (rayon's global pool), JIT evaluator.  Writes a binary STL and prints
//!   triangles: N
//!   vertices: N
//!   time: build S s, walk S s, total S s (without the STL write)
use std::time::Instant;

use fidget::context::Tree;
use fidget::jit::JitShape;
use fidget::mesh::{Octree, Settings};

/// Default half side of the meshed cube (the part spans [-1, 1]^3).
const BOUND: f32 = 1.05;

fn csg() -> Tree {
    let (x, y, z) = Tree::axes();
    let len3 = |a: &Tree, b: &Tree, c: &Tree| (a.square() + b.square() + c.square()).sqrt();
    let len2 = |a: &Tree, b: &Tree| (a.square() + b.square()).sqrt();

    let sphere = len3(&x, &y, &z) - 1.35;
    // Exact box SDF: length(max(q, 0)) + min(max(qx, qy, qz), 0), q = |p| - 1
    let (qx, qy, qz) = (x.abs() - 1.0, y.abs() - 1.0, z.abs() - 1.0);
    let outside = len3(&qx.max(0.0), &qy.max(0.0), &qz.max(0.0));
    let inside = qx.max(qy.clone()).max(qz.clone()).min(0.0);
    let boxed = outside + inside;
    let body = sphere.max(boxed);

    let r = 0.55;
    let cx = len2(&y, &z) - r;
    let cy = len2(&x, &z) - r;
    let cz = len2(&x, &y) - r;
    let holes = cx.min(cy).min(cz);
    body.max(holes.neg())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 3 && args.len() != 4 {
        eprintln!("usage: {} DEPTH OUT.stl [BOUND]", args[0]);
        std::process::exit(2);
    }
    let depth: u8 = args[1].parse().expect("DEPTH: an integer");
    let out = &args[2];
    let bound: f32 = args.get(3).map_or(BOUND, |b| b.parse().expect("BOUND: a number"));
    assert!(bound >= 1.0, "BOUND must hold the part: >= 1");

    let t0 = Instant::now();
    let shape = JitShape::from(csg());
    let bound_shape = shape.try_into().expect("no extra variables");
    let settings = Settings {
        depth,
        world_to_model: nalgebra::Matrix4::new_scaling(bound),
        ..Default::default()
    };
    let octree = Octree::build(&bound_shape, &settings).expect("not cancelled");
    let t1 = Instant::now();
    let mesh = octree.walk_dual();
    let t2 = Instant::now();

    let mut f = std::fs::File::create(out).expect("create the STL file");
    mesh.write_stl(&mut f).expect("write the STL file");

    println!("triangles: {}", mesh.triangles.len());
    println!("vertices: {}", mesh.vertices.len());
    println!(
        "time: build {:.3} s, walk {:.3} s, total {:.3} s (without the STL write)",
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        (t2 - t0).as_secs_f64()
    );
}
