//! The live preview: a worker thread that renders the latest scene it was
//! given, on the GPU renderer when there is a hardware adapter and otherwise
//! on the CPU renderer's progressive passes, and publishes frames for the UI.
//!
//! On a software adapter (lavapipe, llvmpipe, SwiftShader, WARP) the GPU
//! renderer runs on the same CPU cores as the CPU renderer and is slower
//! than it on every scene measured (docs/BENCHMARKS.md, "The GPU renderer
//! beside the CPU renderer"), so [`PreviewChoice::Auto`] takes the CPU
//! renderer there and says why; [`Preview::choose`] switches.
//!
//! A new request cancels the render in progress (the CPU renderer between
//! tiles, the GPU renderer between bands), so the preview always catches up
//! with the latest edit instead of queueing frames.

use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use isoray_job::CancelToken;
use isoray_render::{RenderOptions, TileImage, TileSink};
use isoray_scene::Scene;

/// Which renderer the user asked the preview to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PreviewChoice {
    /// The GPU renderer on a hardware adapter; the CPU renderer when there
    /// is none or the adapter is a software one (it is slower there).
    #[default]
    Auto,
    /// The GPU renderer whenever there is an adapter, software or not.
    Gpu,
    /// The CPU renderer.
    Cpu,
}

impl PreviewChoice {
    /// Its name in menus and on the command line.
    pub fn label(self) -> &'static str {
        match self {
            PreviewChoice::Auto => "Automatic (the faster here)",
            PreviewChoice::Gpu => "GPU renderer",
            PreviewChoice::Cpu => "CPU renderer",
        }
    }
}

/// Which renderer draws the preview.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Backend {
    /// The GPU renderer on this adapter.
    Gpu(String),
    /// The CPU renderer (no GPU adapter, or asked for): why.
    Cpu(String),
}

impl Backend {
    /// A short description for the status bar.
    pub fn describe(&self) -> String {
        match self {
            Backend::Gpu(a) => format!("GPU: {a}"),
            Backend::Cpu(why) => format!("CPU renderer ({why})"),
        }
    }
}

/// One finished (or, on the CPU, partly refined) preview image.
#[derive(Debug, Clone)]
pub struct Frame {
    /// The request it answers.
    pub id: u64,
    /// Size in pixels.
    pub width: u32,
    /// Size in pixels.
    pub height: u32,
    /// sRGB bytes, RGBA, row-major.
    pub rgba: Vec<u8>,
    /// True when this is the request's final image.
    pub done: bool,
    /// Time since the request was taken up, ms.
    pub ms: f64,
}

/// What the worker shares with the UI.
#[derive(Debug, Default)]
struct Shared {
    /// The image being drawn (linear RGB), the CPU renderer's tiles
    /// written in as they finish; converted for the UI when it asks.
    canvas: Canvas,
    frame: Option<Frame>,
    backend: Option<Backend>,
    error: Option<String>,
    /// The request being rendered and its cancel token.
    running: Option<(u64, CancelToken)>,
    /// The renderer choice the worker last took up.
    choice: PreviewChoice,
}

/// What the UI asks of the worker.
enum Message {
    /// Draw this scene for request `id`.
    Render(u64, Box<Scene>),
    /// Use this renderer from now on.
    Choose(PreviewChoice),
}

/// The worker's renderers: the GPU one made on first need, and the reason
/// there is none when making it failed.
#[derive(Default)]
struct Renderers {
    gpu: Option<Result<isoray_gpu::GpuRenderer, String>>,
}

impl Renderers {
    /// The renderer `choice` picks, with the status bar's description:
    /// `Some` GPU renderer, or `None` for the CPU renderer.
    fn pick(&mut self, choice: PreviewChoice) -> (Option<&mut isoray_gpu::GpuRenderer>, Backend) {
        if choice == PreviewChoice::Cpu {
            return (
                None,
                Backend::Cpu("chosen in View > Preview renderer or with --cpu".into()),
            );
        }
        let gpu = self
            .gpu
            .get_or_insert_with(|| isoray_gpu::GpuRenderer::new().map_err(|e| e.to_string()));
        match gpu {
            Err(e) => (None, Backend::Cpu(format!("no GPU adapter: {e}"))),
            Ok(g) if choice == PreviewChoice::Auto && g.gpu().is_software() => {
                let why = format!(
                    "{} is a software adapter, on which the CPU renderer is faster; View > Preview renderer switches",
                    g.gpu().adapter_name()
                );
                (None, Backend::Cpu(why))
            }
            Ok(g) => {
                let name = g.gpu().adapter_name();
                let name = if g.gpu().is_software() {
                    format!("{name}, a software adapter (the CPU renderer is faster here)")
                } else {
                    name
                };
                (Some(g), Backend::Gpu(name))
            }
        }
    }
}

/// A linear-RGB image and whether the UI has seen its latest pixels.
#[derive(Debug, Default)]
struct Canvas {
    id: u64,
    width: u32,
    height: u32,
    color: Vec<[f32; 3]>,
    dirty: bool,
    ms: f64,
}

/// The preview renderer's handle (the worker stops when it is dropped).
#[derive(Debug)]
pub struct Preview {
    tx: Sender<Message>,
    shared: Arc<Mutex<Shared>>,
    next_id: u64,
    /// The worker thread (it ends when `tx` is dropped).
    _worker: std::thread::JoinHandle<()>,
}

impl Preview {
    /// Starts the worker with the renderer `choice` picks; `wake` is
    /// called after every published frame.
    pub fn start(choice: PreviewChoice, wake: impl Fn() + Send + Sync + 'static) -> Preview {
        let (tx, rx) = channel();
        let shared = Arc::new(Mutex::new(Shared::default()));
        let s = shared.clone();
        let worker = std::thread::Builder::new()
            .name("preview".into())
            .spawn(move || worker(rx, s, choice, wake))
            .expect("a thread for the preview");
        Preview {
            tx,
            shared,
            next_id: 0,
            _worker: worker,
        }
    }

    /// Asks for a frame of `scene` (at its own image size); returns the
    /// request's id. The render in progress is cancelled.
    pub fn request(&mut self, scene: Scene) -> u64 {
        self.next_id += 1;
        if let Some((_, token)) = &self.lock().running {
            token.cancel();
        }
        // A closed channel means the worker panicked; the error says so.
        let _ = self.tx.send(Message::Render(self.next_id, Box::new(scene)));
        self.next_id
    }

    /// Switches the renderer (from the next request on; [`Preview::backend`]
    /// says which one `choice` gave once the worker has taken it up).
    pub fn choose(&mut self, choice: PreviewChoice) {
        let _ = self.tx.send(Message::Choose(choice));
    }

    /// The renderer choice in force.
    pub fn choice(&self) -> PreviewChoice {
        self.lock().choice
    }

    /// The latest frame, taken (None when no new one came since): a
    /// finished one, or else the CPU renderer's partial image.
    pub fn take_frame(&self) -> Option<Frame> {
        let mut s = self.lock();
        if let Some(f) = s.frame.take() {
            s.canvas.dirty = false;
            return Some(f);
        }
        let c = &mut s.canvas;
        if !c.dirty {
            return None;
        }
        c.dirty = false;
        Some(Frame {
            id: c.id,
            width: c.width,
            height: c.height,
            rgba: rgba(&c.color),
            done: false,
            ms: c.ms,
        })
    }

    /// Which renderer draws (None until the worker has started it).
    pub fn backend(&self) -> Option<Backend> {
        self.lock().backend.clone()
    }

    /// The last render's error, if it failed.
    pub fn error(&self) -> Option<String> {
        self.lock().error.clone()
    }

    /// True while a request is rendering.
    pub fn busy(&self) -> bool {
        self.lock().running.is_some()
    }

    /// The id of the last request made.
    pub fn last_request(&self) -> u64 {
        self.next_id
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Converts linear RGB to sRGB RGBA bytes (what [`Frame::rgba`] holds).
pub fn rgba(color: &[[f32; 3]]) -> Vec<u8> {
    let srgb = isoray_shade::srgb::to_srgb8(color);
    let mut out = Vec::with_capacity(color.len() * 4);
    for px in srgb.chunks_exact(3) {
        out.extend_from_slice(&[px[0], px[1], px[2], 255]);
    }
    out
}

fn worker(rx: Receiver<Message>, shared: Arc<Mutex<Shared>>, choice: PreviewChoice, wake: impl Fn() + Sync) {
    let lock = || shared.lock().unwrap_or_else(|e| e.into_inner());
    let mut renderers = Renderers::default();
    let mut choice = choice;
    let backend = renderers.pick(choice).1;
    {
        let mut s = lock();
        s.backend = Some(backend);
        s.choice = choice;
    }
    wake();
    while let Ok(first) = rx.recv() {
        // Take every message waiting; only the latest request matters.
        let mut job = None;
        for m in std::iter::once(first).chain(rx.try_iter()) {
            match m {
                Message::Render(id, scene) => job = Some((id, *scene)),
                Message::Choose(c) => {
                    choice = c;
                    let backend = renderers.pick(choice).1;
                    let mut s = lock();
                    s.backend = Some(backend);
                    s.choice = choice;
                    drop(s);
                    wake();
                }
            }
        }
        let Some((id, scene)) = job else { continue };
        let gpu = renderers.pick(choice).0;
        let token = CancelToken::new();
        lock().running = Some((id, token.clone()));
        let start = Instant::now();
        let (w, h) = (scene.render.width, scene.render.height);
        let result = match gpu {
            Some(g) => {
                let opts = isoray_gpu::GpuRenderOptions {
                    cancel: Some(token.clone()),
                    ..Default::default()
                };
                // Progressive refinement: with supersampling, one sample
                // per pixel first (a 1/aa² of the work), shown at once,
                // then the full frame.
                let quick = (scene.render.aa > 1).then(|| {
                    let mut q = scene.clone();
                    q.render.aa = 1;
                    q
                });
                let first = match &quick {
                    Some(q) => match g.render(q, &opts) {
                        Ok((img, _, _)) => {
                            let mut s = lock();
                            s.canvas = Canvas {
                                id,
                                width: w,
                                height: h,
                                color: img.color,
                                dirty: true,
                                ms: start.elapsed().as_secs_f64() * 1e3,
                            };
                            drop(s);
                            wake();
                            Ok(())
                        }
                        Err(e) => Err(e),
                    },
                    None => Ok(()),
                };
                match first.and_then(|()| g.render(&scene, &opts)) {
                    Ok((img, _, _)) => Ok(Some(img.color)),
                    Err(isoray_gpu::GpuError::Cancelled) => Ok(None),
                    Err(e) => Err(e.to_string()),
                }
            }
            None => {
                {
                    let mut s = lock();
                    let keep = s.canvas.width == w && s.canvas.height == h;
                    if !keep {
                        s.canvas.color = vec![[0.0; 3]; (w * h) as usize];
                    }
                    s.canvas.id = id;
                    s.canvas.width = w;
                    s.canvas.height = h;
                }
                let sink = Progressive {
                    shared: &shared,
                    start,
                    wake: &wake,
                };
                let opts = RenderOptions {
                    cancel: Some(token.clone()),
                    ..Default::default()
                };
                let region = isoray_render::Region::full(&scene);
                match isoray_render::render_progressive(&scene, region, &opts, &sink) {
                    Ok((img, _)) => Ok(Some(img.color)),
                    Err(_) => Ok(None),
                }
            }
        };
        let mut s = lock();
        s.running = None;
        match result {
            Ok(Some(color)) => {
                s.error = None;
                s.frame = Some(Frame {
                    id,
                    width: w,
                    height: h,
                    rgba: rgba(&color),
                    done: true,
                    ms: start.elapsed().as_secs_f64() * 1e3,
                });
            }
            Ok(None) => {}
            Err(e) => s.error = Some(e),
        }
        drop(s);
        wake();
    }
}

/// The CPU renderer's tiles, written into the shared canvas as they
/// finish (coarse passes first, so the image refines in place).
struct Progressive<'a, W: Fn() + Sync> {
    shared: &'a Mutex<Shared>,
    start: Instant,
    wake: &'a W,
}

impl<W: Fn() + Sync> TileSink for Progressive<'_, W> {
    fn tile(&self, tile: &TileImage) {
        let mut s = self.shared.lock().unwrap_or_else(|e| e.into_inner());
        let c = &mut s.canvas;
        let r = tile.region;
        for y in 0..r.height {
            let row = ((r.y0 + y) * c.width + r.x0) as usize;
            let src = (y * r.width) as usize;
            c.color[row..row + r.width as usize].copy_from_slice(&tile.color[src..src + r.width as usize]);
        }
        c.dirty = true;
        c.ms = self.start.elapsed().as_secs_f64() * 1e3;
        drop(s);
        (self.wake)();
    }
}
