//! The preview worker on the GPU renderer (lavapipe in CI): a request with
//! supersampling first shows one sample per pixel, then the full frame,
//! each exactly the GPU renderer's image of that scene; a newer request
//! cancels the one in progress, and only the newest is answered.

use std::time::{Duration, Instant};

use isoray_studio::preview::{rgba as rgba_of, Backend, Frame, Preview, PreviewChoice};

const SCENE: &str = r#"
[camera]
position = [0.0, 1.5, 4.0]
target = [0.0, 0.5, 0.0]
[render]
width = 160
height = 100
aa = 2
shadows = "soft"
[[light]]
direction = [-1.0, 2.0, 1.0]
[[object]]
shape = "plane(p, vec3(0.0, 1.0, 0.0), 0.0)"
[[object]]
shape = "sphere(p - vec3(0.0, 0.7, 0.0), 0.7)"
"#;

/// Frames of request `id` until its final one (every frame taken).
fn frames_of(preview: &Preview, id: u64) -> Vec<Frame> {
    let start = Instant::now();
    let mut frames = Vec::new();
    while start.elapsed() < Duration::from_secs(300) {
        if let Some(e) = preview.error() {
            panic!("the preview failed: {e}");
        }
        if let Some(f) = preview.take_frame() {
            let done = f.done && f.id == id;
            if f.id == id {
                frames.push(f);
            }
            if done {
                return frames;
            }
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    panic!("no final frame of request {id} in 300 s");
}

#[test]
fn a_supersampled_preview_refines_from_one_sample_to_the_full_frame() {
    let scene = isoray_scene::load_str(SCENE, "preview.toml", &[]).unwrap();
    let mut preview = Preview::start(PreviewChoice::Gpu, || {});
    let id = preview.request(scene.clone());
    let frames = frames_of(&preview, id);
    let backend = preview.backend().expect("the worker has started");
    let mut quick = scene.clone();
    quick.render.aa = 1;
    let (full_ref, quick_ref) = match &backend {
        Backend::Gpu(_) => {
            let mut g = isoray_gpu::GpuRenderer::new().unwrap();
            let opts = isoray_gpu::GpuRenderOptions::default();
            (
                rgba_of(&g.render(&scene, &opts).unwrap().0.color),
                rgba_of(&g.render(&quick, &opts).unwrap().0.color),
            )
        }
        Backend::Cpu(why) => {
            eprintln!("no GPU here ({why}): the CPU renderer's progressive passes");
            let opts = isoray_render::RenderOptions::default();
            (rgba_of(&isoray_render::render(&scene, &opts).0.color), Vec::new())
        }
    };
    let last = frames.last().unwrap();
    assert!(last.done);
    assert_eq!((last.width, last.height), (160, 100));
    assert!(last.rgba == full_ref, "the final frame is the renderer's image");
    if let Backend::Gpu(_) = backend {
        // Progressive: the one-sample frame came first, and it is the
        // one-sample image. (It is shown until the full frame, four times
        // the work, is done: polled every millisecond, it is not missed.)
        let partial: Vec<&Frame> = frames.iter().filter(|f| !f.done).collect();
        assert_eq!(partial.len(), 1, "one partial frame");
        assert!(partial[0].rgba == quick_ref, "the partial frame is the aa = 1 image");
        assert!(quick_ref != full_ref, "supersampling changes the image");
    }

    // Two requests at once: the first is cancelled or superseded, and the
    // newest is answered with its own image.
    let mut other = scene.clone();
    other.render.aa = 1;
    other.camera.position = [1.0, 1.5, 4.0];
    let _first = preview.request(scene.clone());
    let second = preview.request(other.clone());
    let frames = frames_of(&preview, second);
    let last = frames.last().unwrap();
    let want = match preview.backend().unwrap() {
        Backend::Gpu(_) => {
            let mut g = isoray_gpu::GpuRenderer::new().unwrap();
            rgba_of(&g.render(&other, &Default::default()).unwrap().0.color)
        }
        Backend::Cpu(_) => rgba_of(&isoray_render::render(&other, &Default::default()).0.color),
    };
    assert!(last.rgba == want);
}

/// The renderer's adapter: Some(true) for a software one, None for none.
fn software_adapter() -> Option<bool> {
    isoray_gpu::GpuRenderer::new().ok().map(|g| g.gpu().is_software())
}

#[test]
fn the_automatic_choice_takes_the_cpu_renderer_on_a_software_adapter_and_the_view_menu_switches() {
    let scene = isoray_scene::load_str(SCENE, "preview.toml", &[]).unwrap();
    let mut quick = scene.clone();
    quick.render.aa = 1;
    let mut preview = Preview::start(PreviewChoice::Auto, || {});
    let id = preview.request(quick.clone());
    let frames = frames_of(&preview, id);
    let cpu_image = rgba_of(&isoray_render::render(&quick, &Default::default()).0.color);
    match (software_adapter(), preview.backend().unwrap()) {
        (Some(true), Backend::Cpu(why)) => {
            assert!(why.contains("software adapter"), "the status bar says why: {why}");
            assert!(frames.last().unwrap().rgba == cpu_image, "the CPU renderer's image");
        }
        (None, Backend::Cpu(why)) => assert!(why.contains("no GPU adapter"), "{why}"),
        (Some(false), Backend::Gpu(_)) => {}
        (adapter, backend) => panic!("software adapter {adapter:?}, yet {backend:?}"),
    }
    assert_eq!(preview.choice(), PreviewChoice::Auto);

    // View ▸ Preview renderer ▸ GPU renderer: the GPU renderer's image,
    // and the status bar names the adapter.
    preview.choose(PreviewChoice::Gpu);
    let id = preview.request(quick.clone());
    let frames = frames_of(&preview, id);
    if let Ok(mut g) = isoray_gpu::GpuRenderer::new() {
        let want = rgba_of(&g.render(&quick, &Default::default()).unwrap().0.color);
        let Backend::Gpu(name) = preview.backend().unwrap() else {
            panic!("asked for the GPU renderer, got {:?}", preview.backend());
        };
        assert!(name.contains(&g.gpu().adapter_name()), "{name}");
        assert!(frames.last().unwrap().rgba == want, "the GPU renderer's image");
    }
    assert_eq!(preview.choice(), PreviewChoice::Gpu);

    // ... and back to the CPU renderer.
    preview.choose(PreviewChoice::Cpu);
    let id = preview.request(quick.clone());
    let frames = frames_of(&preview, id);
    assert!(matches!(preview.backend().unwrap(), Backend::Cpu(_)));
    assert!(frames.last().unwrap().rgba == cpu_image);
}
