//! Writes each progressive pass of a scene as a PNG, to see what a preview
//! shows before the final image: `passes SCENE OUTDIR`.

use std::sync::Mutex;

use isoray_render::{passes, render_region, Pass, Region, RenderOptions, TileImage};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, out] = &args[..] else {
        eprintln!("usage: passes SCENE OUTDIR");
        std::process::exit(2);
    };
    let scene = isoray_scene::load(std::path::Path::new(scene), &[]).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2)
    });
    let (w, h) = (scene.render.width, scene.render.height);
    std::fs::create_dir_all(out).expect("the output folder can be made");
    for pass in passes(&scene) {
        let image = Mutex::new(vec![[0.0f32; 3]; (w * h) as usize]);
        let sink = |t: &TileImage| {
            let mut img = image.lock().expect("not poisoned");
            let r = t.region;
            for j in 0..r.height {
                for i in 0..r.width {
                    img[((r.y0 + j) * w + r.x0 + i) as usize] = t.color[(j * r.width + i) as usize];
                }
            }
        };
        render_region(&scene, Region::full(&scene), pass, &RenderOptions::default(), &sink).expect("not cancelled");
        let name = match pass {
            Pass::Blocks(n) => format!("blocks{n}.png"),
            Pass::Pixels => "pixels.png".to_string(),
            Pass::Final => "final.png".to_string(),
        };
        let path = std::path::Path::new(out).join(name);
        isoray_render::output::write_png(&path, w, h, &image.into_inner().expect("not poisoned")).expect("written");
        println!("{}", path.display());
    }
}
