//! Node thumbnails: a small CPU render of the distance each node computes,
//! seen through the scene's camera and lights, made on a background thread
//! and cached by shape text (an edit re-renders only the nodes whose text
//! changed: the edited node and those below it in the graph).

use std::collections::HashMap;
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Mutex};

use isoray_render::RenderOptions;

/// Thumbnail size in pixels.
pub const SIZE: [u32; 2] = [96, 64];

/// What the cache holds for one shape text.
#[derive(Clone)]
pub enum Thumb {
    /// Being rendered.
    Pending,
    /// Rendered (RGBA bytes at [`SIZE`]) and uploaded when first drawn.
    Image(Arc<Vec<u8>>, Option<egui::TextureHandle>),
    /// The text is not a distance (a point, a vector) or does not load:
    /// no thumbnail.
    None,
}

/// A job: the scene text to base the render on, the file name it is read
/// as (relative paths in it resolve from there), and the shape.
type Job = (String, String, String);

/// Finished jobs: shape text and the result.
type Done = Arc<Mutex<Vec<(String, Outcome)>>>;

/// How a job ended.
enum Outcome {
    /// Rendered: RGBA bytes.
    Image(Vec<u8>),
    /// Not a distance, or the scene does not load.
    Nothing,
    /// Dropped unrendered (newer jobs came in, as while a value is
    /// dragged); asked again when the node is drawn.
    Skipped,
}

/// Jobs waiting beyond this many are skipped, newest kept.
const QUEUE: usize = 8;

/// The cache and its worker.
pub struct Thumbnails {
    cache: HashMap<String, Thumb>,
    jobs: Option<Sender<Job>>,
    done: Done,
    /// Whether thumbnails are drawn at all.
    pub enabled: bool,
}

impl Default for Thumbnails {
    fn default() -> Self {
        Thumbnails {
            cache: HashMap::new(),
            jobs: None,
            done: Arc::new(Mutex::new(Vec::new())),
            enabled: true,
        }
    }
}

impl Thumbnails {
    /// The thumbnail of `shape` in the scene of `scene_text` (read as the
    /// file `scene_name`), asking the worker for it the first time; the
    /// window repaints when it is ready.
    pub fn get(&mut self, shape: &str, scene_text: &str, scene_name: &str, ctx: &egui::Context) -> Thumb {
        self.collect();
        if let Some(t) = self.cache.get_mut(shape) {
            if let Thumb::Image(bytes, tex @ None) = t {
                let image = egui::ColorImage::from_rgba_unmultiplied([SIZE[0] as usize, SIZE[1] as usize], bytes);
                *tex = Some(ctx.load_texture(format!("thumb:{shape}"), image, egui::TextureOptions::LINEAR));
            }
            return t.clone();
        }
        let jobs = self.jobs.get_or_insert_with(|| spawn(self.done.clone(), ctx.clone()));
        if jobs
            .send((scene_text.to_string(), scene_name.to_string(), shape.to_string()))
            .is_ok()
        {
            self.cache.insert(shape.to_string(), Thumb::Pending);
        }
        Thumb::Pending
    }

    /// How many thumbnails are still being rendered.
    pub fn pending(&mut self) -> usize {
        self.collect();
        self.cache.values().filter(|t| matches!(t, Thumb::Pending)).count()
    }

    /// Forgets every thumbnail (the scene's camera, lights or materials
    /// changed, so all of them are stale).
    pub fn clear(&mut self) {
        self.cache.clear();
    }

    fn collect(&mut self) {
        let done = std::mem::take(&mut *self.done.lock().unwrap_or_else(|e| e.into_inner()));
        for (shape, outcome) in done {
            match outcome {
                Outcome::Image(b) => {
                    self.cache.insert(shape, Thumb::Image(Arc::new(b), None));
                }
                Outcome::Nothing => {
                    self.cache.insert(shape, Thumb::None);
                }
                Outcome::Skipped => {
                    self.cache.remove(&shape);
                }
            }
        }
    }
}

fn spawn(done: Done, ctx: egui::Context) -> Sender<Job> {
    let (tx, rx) = channel::<Job>();
    std::thread::Builder::new()
        .name("isoray-studio thumbnails".into())
        .spawn(move || work(&rx, &done, &ctx))
        .expect("the thumbnail thread starts");
    tx
}

fn work(rx: &Receiver<Job>, done: &Done, ctx: &egui::Context) {
    while let Ok(first) = rx.recv() {
        let mut jobs = vec![first];
        jobs.extend(rx.try_iter());
        let keep = jobs.split_off(jobs.len().saturating_sub(QUEUE));
        let skipped: Vec<(String, Outcome)> = jobs.into_iter().map(|(_, _, s)| (s, Outcome::Skipped)).collect();
        done.lock().unwrap_or_else(|e| e.into_inner()).extend(skipped);
        for (scene_text, name, shape) in keep {
            let outcome = render(&scene_text, &name, &shape).map_or(Outcome::Nothing, Outcome::Image);
            done.lock().unwrap_or_else(|e| e.into_inner()).push((shape, outcome));
            ctx.request_repaint();
        }
    }
}

/// The scene of `scene_text` (read as the file `name`) with `shape` as
/// its only object (with the first object's material when `material`),
/// at `size` pixels, with one sample per pixel; `analyses` is a cache of
/// implicitizations to reuse.
pub fn scene_of_shape(
    scene_text: &str,
    name: &str,
    shape: &str,
    size: [u32; 2],
    material: bool,
    analyses: Option<isoray_shape::Analyses>,
) -> Option<isoray_scene::Scene> {
    let mut doc: toml_edit::DocumentMut = scene_text.parse().ok()?;
    let first = doc
        .get("object")
        .and_then(|o| o.as_array_of_tables())
        .and_then(|a| a.get(0))
        .and_then(|t| t.get("material"))
        .and_then(|m| m.as_str())
        .map(str::to_string);
    let mut object = toml_edit::Table::new();
    object.insert("shape", toml_edit::value(shape));
    if let Some(m) = first.filter(|_| material) {
        object.insert("material", toml_edit::value(m));
    }
    let mut list = toml_edit::ArrayOfTables::new();
    list.push(object);
    doc.insert("object", toml_edit::Item::ArrayOfTables(list));
    let overrides = [
        format!("render.width={}", size[0]),
        format!("render.height={}", size[1]),
        "render.aa=1".to_string(),
    ];
    let options = isoray_scene::LoadOptions {
        analyses,
        ..Default::default()
    };
    isoray_scene::load_str_with(&doc.to_string(), name, &overrides, &options).ok()
}

fn render(scene_text: &str, name: &str, shape: &str) -> Option<Vec<u8>> {
    // A node's thumbnail: in the first object's material.
    let scene = scene_of_shape(scene_text, name, shape, SIZE, true, None)?;
    let (img, _) = isoray_render::render(&scene, &RenderOptions::default());
    Some(crate::preview::rgba(&img.color))
}
