//! File ▸ Export: the final image through the CPU renderer (`.png`, `.exr`)
//! or the objects as one mesh (`.stl`, `.obj`, `.ply`, `.glb`) through
//! isoray-mesh, on a background thread with progress and cancel. The writers
//! write beside the destination and rename into place, so a failed or
//! cancelled export leaves an existing file as it was.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use isoray_job::CancelToken;
use isoray_mesh::{Control, Mesh, MeshError, MeshMaterial, MeshSettings, Stage};
use isoray_scene::Scene;

/// What an export writes, from the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportKind {
    /// The rendered image (PNG or EXR).
    Image,
    /// A mesh of the scene's bounded objects.
    Mesh,
}

impl ExportKind {
    /// The kind of export a path asks for, or what was expected.
    pub fn of(path: &Path) -> Result<ExportKind, String> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        match ext.as_str() {
            "png" | "exr" => Ok(ExportKind::Image),
            "stl" | "obj" | "ply" | "glb" => Ok(ExportKind::Mesh),
            _ => Err(format!(
                "`{}`: expected a file ending in .png or .exr (the image) or .stl, .obj, .ply, .glb (a mesh)",
                path.display()
            )),
        }
    }
}

/// How an export ended.
#[derive(Debug, Clone, PartialEq)]
pub enum ExportEnd {
    /// Written: a one-line summary.
    Done(String),
    /// Cancelled; nothing was written.
    Cancelled,
    /// Failed: why; nothing was written.
    Failed(String),
}

#[derive(Debug, Default)]
struct State {
    /// Fraction done, 0..1, and the stage shown.
    progress: (f32, String),
    end: Option<ExportEnd>,
}

/// An export running on its own thread.
#[derive(Debug)]
pub struct Export {
    /// Where it writes.
    pub path: PathBuf,
    state: Arc<Mutex<State>>,
    cancel: CancelToken,
}

impl Export {
    /// Starts exporting `scene` to `path` (its kind from the extension).
    pub fn start(scene: Scene, path: PathBuf) -> Result<Export, String> {
        let kind = ExportKind::of(&path)?;
        let state = Arc::new(Mutex::new(State::default()));
        let cancel = CancelToken::new();
        let (s, c, p) = (state.clone(), cancel.clone(), path.clone());
        std::thread::Builder::new()
            .name("export".into())
            .spawn(move || {
                let end = run(&scene, &p, kind, &s, &c);
                lock(&s).end = Some(end);
            })
            .map_err(|e| format!("could not start the export: {e}"))?;
        Ok(Export { path, state, cancel })
    }

    /// The fraction done (0..1) and the stage.
    pub fn progress(&self) -> (f32, String) {
        lock(&self.state).progress.clone()
    }

    /// How it ended, once it has.
    pub fn end(&self) -> Option<ExportEnd> {
        lock(&self.state).end.clone()
    }

    /// Asks it to stop (it ends as [`ExportEnd::Cancelled`]).
    pub fn cancel(&self) {
        self.cancel.cancel();
    }

    /// Waits for the end (for tests and scripts).
    pub fn wait(&self) -> ExportEnd {
        loop {
            if let Some(e) = self.end() {
                return e;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }
}

fn lock(s: &Mutex<State>) -> std::sync::MutexGuard<'_, State> {
    s.lock().unwrap_or_else(|e| e.into_inner())
}

/// Reports the renderer's progress into the state.
struct Report(Arc<Mutex<State>>);

impl isoray_job::Progress for Report {
    fn update(&self, done: u64, total: u64) {
        lock(&self.0).progress.0 = done as f32 / total.max(1) as f32;
    }
    fn stage(&self, name: &str) {
        lock(&self.0).progress.1 = name.to_string();
    }
}

fn run(scene: &Scene, path: &Path, kind: ExportKind, state: &Arc<Mutex<State>>, cancel: &CancelToken) -> ExportEnd {
    // The writers are atomic (a temporary file beside the target, renamed
    // over it when complete; an OBJ's `.mtl` with it), so an export that
    // fails or is cancelled leaves the old file and no leftovers.
    let result = match kind {
        ExportKind::Image => image(scene, path, state, cancel),
        ExportKind::Mesh => mesh(scene, path, state, cancel),
    };
    match result {
        Ok(summary) => ExportEnd::Done(format!("exported {}: {summary}", path.display())),
        Err(end) => end,
    }
}

fn image(scene: &Scene, out: &Path, state: &Arc<Mutex<State>>, cancel: &CancelToken) -> Result<String, ExportEnd> {
    lock(state).progress.1 = "rendering".into();
    let opts = isoray_render::RenderOptions {
        progress: Some(Arc::new(Report(state.clone()))),
        cancel: Some(cancel.clone()),
        ..Default::default()
    };
    let (img, _) = isoray_render::render_with(scene, &opts).map_err(|_| ExportEnd::Cancelled)?;
    let (w, h) = (img.width, img.height);
    let written = if out.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        isoray_render::output::write_exr_rgb(out, w, h, &img.color)
    } else {
        isoray_render::output::write_png(out, w, h, &img.color)
    };
    written.map_err(|e| ExportEnd::Failed(e.to_string()))?;
    Ok(format!("{w}×{h}, aa {}", scene.render.aa))
}

fn mesh(scene: &Scene, out: &Path, state: &Arc<Mutex<State>>, cancel: &CancelToken) -> Result<String, ExportEnd> {
    let settings = MeshSettings {
        lipschitz: (1.0 / scene.render.step_scale.clamp(1e-6, 1.0)).max(1.0),
        ..MeshSettings::default()
    };
    let stop = AtomicBool::new(false);
    let n = scene.objects.len();
    let mut all = Mesh::default();
    let mut skipped = Vec::new();
    for (i, o) in scene.objects.iter().enumerate() {
        let report = |stage: Stage, f: f64| {
            if cancel.is_cancelled() {
                stop.store(true, Ordering::Relaxed);
            }
            let mut s = lock(state);
            s.progress = (
                ((i as f64 + f) / n as f64) as f32,
                format!("object {i}: {}", stage.name()),
            );
        };
        let ctl = Control::new(Some(&report), Some(&stop));
        match isoray_mesh::mesh_shape_with(o.shape.tape(), &settings, &ctl) {
            Ok((part, _)) => {
                let m = &scene.materials[o.material];
                all.append(
                    part,
                    Some(MeshMaterial::from_diffuse(&m.name, m.diffuse, m.transparency)),
                );
            }
            Err(MeshError::Cancelled) => return Err(ExportEnd::Cancelled),
            // Unbounded objects (planes) and empty ones have no mesh.
            Err(MeshError::Unbounded | MeshError::NoSurface | MeshError::NoSignChange) => skipped.push(i),
            Err(e) => return Err(ExportEnd::Failed(format!("object {i}: {e}"))),
        }
        if cancel.is_cancelled() {
            return Err(ExportEnd::Cancelled);
        }
    }
    if all.triangles.is_empty() {
        return Err(ExportEnd::Failed(
            "no object could be meshed (planes and other unbounded objects have no mesh; use `isoray mesh --bounds`)"
                .into(),
        ));
    }
    isoray_mesh::io::write(out, &all).map_err(|e| ExportEnd::Failed(e.to_string()))?;
    let mut summary = format!("{} triangles", all.triangles.len());
    if !skipped.is_empty() {
        let list: Vec<String> = skipped.iter().map(|i| i.to_string()).collect();
        summary.push_str(&format!(
            " (objects {} are unbounded or empty: left out)",
            list.join(", ")
        ));
    }
    Ok(summary)
}
