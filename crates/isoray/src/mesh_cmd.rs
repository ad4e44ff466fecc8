//! `isoray mesh`: a scene's objects, one object, or one user surface as a
//! triangle mesh file (STL, OBJ, PLY, glTF binary).

use std::io::IsTerminal;
use std::path::Path;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use isoray_mesh::io::{self as mesh_io, Format};
use isoray_mesh::parametric::{tessellate, TessellationSettings};
use isoray_mesh::{mesh_shape_with, self_intersections, Control, Mesh, MeshError, MeshMaterial, MeshSettings, Stage};
use isoray_scene::Scene;
use isoray_shape::{Shape, SurfaceMode};

use crate::{io_failure, usage, Failure};

/// What `isoray mesh` was asked to do.
pub(crate) struct MeshArgs<'a> {
    pub input: &'a crate::SceneArgs,
    pub name: Option<&'a str>,
    pub output: &'a Path,
    pub resolution: Option<u32>,
    pub bounds: Option<&'a [f64]>,
    pub feature_angle: f64,
    pub lipschitz: Option<f64>,
    pub offset: f64,
    pub tolerance: Option<f64>,
    pub threads: Option<usize>,
    pub check_intersections: bool,
    pub quiet: bool,
}

/// The finest base grid of a parametric tessellation (cells per side).
const MAX_PARAMETRIC_GRID: u32 = 2048;

/// One thing to mesh: a shape with a label and a material.
struct Target<'s> {
    label: String,
    shape: &'s Shape,
    material: Option<MeshMaterial>,
}

pub(crate) fn cmd_mesh(a: &MeshArgs) -> Result<(), Failure> {
    let format = Format::from_path(a.output).map_err(|e| usage(e.to_string()))?;
    if a.threads == Some(0) {
        return Err(usage("--threads must be at least 1".into()));
    }
    let bounds = match a.bounds {
        None => None,
        Some(b) if b.len() == 6 && b.iter().all(|v| v.is_finite()) && (0..3).all(|k| b[k] < b[k + 3]) => {
            Some([[b[0], b[1], b[2]], [b[3], b[4], b[5]]])
        }
        Some(b) => {
            return Err(usage(format!(
                "--bounds expects six numbers xmin,ymin,zmin,xmax,ymax,zmax with each min below its max, found {}",
                b.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(",")
            )))
        }
    };
    if let Some(r) = a.resolution {
        if r < 2 {
            return Err(usage(format!("--resolution must be at least 2, found {r}")));
        }
    }
    if let Some(l) = a.lipschitz {
        if !(l.is_finite() && l >= 1.0) {
            return Err(usage(format!(
                "--lipschitz must be a number of at least 1 (how much the distance may overestimate), found {l}"
            )));
        }
    }
    let mut scene = a.input.load(&[])?;
    // The mesher takes a shape at one moment: fix the time and parameters.
    for i in 0..scene.objects.len() {
        scene.objects[i].shape = scene.frozen(&scene.objects[i].shape);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .map_err(|e| io_failure(format!("cannot start worker threads: {e}")))?;
    let cancel = crate::jobs::cancel_token();
    let start = Instant::now();

    // A parametric surface is tessellated over its domain.
    if let Some(name) = a.name {
        if !scene.objects.iter().any(|o| o.name.as_deref() == Some(name)) {
            if let Some(s) = scene.library.surface(name) {
                if s.mode == SurfaceMode::Parametric {
                    return pool.install(|| mesh_parametric(a, &scene, name, format, start));
                }
            }
        }
    }

    let compiled;
    let targets: Vec<Target> = match a.name {
        Some(name) => {
            if let Some(o) = scene.objects.iter().find(|o| o.name.as_deref() == Some(name)) {
                vec![Target {
                    label: format!("object `{name}`"),
                    shape: &o.shape,
                    material: Some(material(&scene, o.material)),
                }]
            } else if scene.library.surface(name).is_some() {
                compiled = isoray_shape::compile(&scene.library, &format!("{name}(p)"))
                    .map(|s| scene.frozen(&s))
                    .map_err(|d| {
                        usage(format!(
                            "cannot mesh surface `{name}` with its default parameters: {}",
                            d.message
                        ))
                    })?;
                vec![Target {
                    label: format!("surface `{name}`"),
                    shape: &compiled,
                    material: None,
                }]
            } else {
                return Err(usage(unknown_name(a.input.path(), &scene, name)));
            }
        }
        None => {
            if scene.objects.is_empty() {
                return Err(usage(format!(
                    "the scene `{}` has no objects to mesh",
                    a.input.path().display()
                )));
            }
            scene
                .objects
                .iter()
                .enumerate()
                .map(|(i, o)| Target {
                    label: match &o.name {
                        Some(n) => format!("object `{n}`"),
                        None => format!("object {i}"),
                    },
                    shape: &o.shape,
                    material: Some(material(&scene, o.material)),
                })
                .collect()
        }
    };

    let lipschitz = a
        .lipschitz
        .unwrap_or(1.0 / scene.render.step_scale.clamp(1e-6, 1.0))
        .max(1.0);
    let settings = MeshSettings {
        resolution: a.resolution.unwrap_or(MeshSettings::default().resolution),
        bounds,
        feature_angle_deg: a.feature_angle,
        offset: a.offset,
        lipschitz,
    };
    let single = a.name.is_some();
    let progress = MeshBar::new(a.quiet);
    let mut mesh = Mesh::default();
    let mut summaries = Vec::new();
    for t in &targets {
        progress.begin(&t.label);
        let ctl = Control::job(&progress, &cancel);
        let result = pool.install(|| mesh_shape_with(t.shape.tape(), &settings, &ctl));
        progress.end();
        let (part, stats) = match result {
            Ok(r) => r,
            Err(MeshError::Cancelled) => return Err(crate::jobs::cancelled()),
            Err(e @ MeshError::Unbounded) if !single => {
                eprintln!(
                    "warning: skipping {}: {e}\n  = help: give --bounds, or name the objects to mesh",
                    t.label
                );
                continue;
            }
            Err(e @ MeshError::NoSignChange) => {
                let help = format!(
                    "  = help: pass --offset {:.3} for a shell two cells thick",
                    stats_hint(&settings, t.shape)
                );
                if single {
                    return Err(usage(format!("{}: {e}\n{help}", t.label)));
                }
                eprintln!("warning: skipping {}: {e}\n{help}", t.label);
                continue;
            }
            Err(e @ MeshError::Unbounded) => {
                return Err(usage(format!(
                    "{}: {e}\n  = help: give --bounds xmin,ymin,zmin,xmax,ymax,zmax",
                    t.label
                )))
            }
            Err(e @ MeshError::NoSurface) => {
                return Err(usage(format!(
                    "{}: {e}\n  = help: give --bounds around the shape, or --lipschitz L if its field grows faster than the distance",
                    t.label
                )))
            }
            Err(e) => return Err(usage(format!("{}: {e}", t.label))),
        };
        mesh.append(part, t.material.clone());
        summaries.push((t.label.clone(), stats));
    }
    if summaries.is_empty() {
        return Err(usage(
            "nothing to mesh: every object was skipped (see the warnings above)\n  = help: give --bounds, --offset, or name an object".into(),
        ));
    }
    let mesh_secs = start.elapsed().as_secs_f64();
    let topo = mesh.topology();
    let hits = a
        .check_intersections
        .then(|| pool.install(|| self_intersections(&mesh)));
    let t_write = Instant::now();
    mesh_io::write(a.output, &mesh).map_err(|e| io_failure(e.to_string()))?;
    let write_secs = t_write.elapsed().as_secs_f64();

    for (label, s) in &summaries {
        println!(
            "meshed {label}: bounds [{}] .. [{}], {} x {} x {} cells of {:.5}, {} active, {} sharp-feature vertices",
            fmt3(s.bounds[0]),
            fmt3(s.bounds[1]),
            s.cells[0],
            s.cells[1],
            s.cells[2],
            s.cell_size,
            s.active_cells,
            s.feature_vertices
        );
        if s.unfolded_vertices > 0 {
            println!(
                "  {} vertices at folds moved back to their patch's mass point{}",
                s.unfolded_vertices,
                if s.folds_left > 0 {
                    format!("; {} crossing triangle pairs remain", s.folds_left)
                } else {
                    String::new()
                }
            );
        }
        if s.missed_cells > 0 {
            eprintln!(
                "warning: {label}: the distance bound skipped {} cells that the surface crosses (added back); the field overestimates the distance\n  = help: pass --lipschitz 2 (or more)",
                s.missed_cells
            );
        }
    }
    println!(
        "triangles: {} ({} vertices)",
        mesh.triangles.len(),
        mesh.positions.len()
    );
    println!("watertight: {}", watertight_text(&topo));
    let (max, rms, cell) = summaries.iter().fold((0.0f64, 0.0f64, 0.0f64), |acc, (_, s)| {
        (acc.0.max(s.max_error), acc.1.max(s.rms_error), acc.2.max(s.cell_size))
    });
    println!(
        "distance error: max {max:.3e}, rms {rms:.3e} (|f|/|grad f| at the vertices; {:.2}% of a cell at most)",
        100.0 * max / cell.max(1e-300)
    );
    if let Some(h) = &hits {
        if h.is_empty() {
            println!("self-intersections: none");
        } else {
            println!("self-intersections: {} pairs of triangles cross", h.len());
        }
    }
    println!(
        "time: {mesh_secs:.3} s meshing{}, {write_secs:.3} s writing",
        stage_times(&summaries)
    );
    println!("wrote {} ({})", a.output.display(), format);
    Ok(())
}

/// Tessellates the parametric surface `name` over its domain.
fn mesh_parametric(a: &MeshArgs, scene: &Scene, name: &str, format: Format, start: Instant) -> Result<(), Failure> {
    let coords = scene
        .library
        .parametric_coords(name, None)
        .map_err(|d| usage(d.message.clone()))?;
    let mut settings = TessellationSettings::default();
    if let Some(r) = a.resolution {
        if r > MAX_PARAMETRIC_GRID {
            return Err(usage(format!(
                "--resolution {r} is too fine for a parametric surface's base grid: at most {MAX_PARAMETRIC_GRID} (refinement adds detail where it is needed)"
            )));
        }
        settings.initial = [r, r];
    }
    settings.tolerance = a.tolerance;
    let (mesh, stats) = tessellate(&coords, &settings).map_err(|e| usage(format!("surface `{name}`: {e}")))?;
    let mesh_secs = start.elapsed().as_secs_f64();
    let topo = mesh.topology();
    let t_write = Instant::now();
    mesh_io::write(a.output, &mesh).map_err(|e| io_failure(e.to_string()))?;
    println!(
        "tessellated surface `{name}` over s in [{}, {}], t in [{}, {}]: base grid {} x {}, {} leaves, depth up to {}, chord tolerance {:.3e}",
        coords.domain[0][0],
        coords.domain[0][1],
        coords.domain[1][0],
        coords.domain[1][1],
        settings.initial[0],
        settings.initial[1],
        stats.leaves,
        stats.max_depth_reached,
        stats.tolerance
    );
    println!(
        "triangles: {} ({} vertices, with (s, t) texture coordinates)",
        mesh.triangles.len(),
        mesh.positions.len()
    );
    println!("watertight: {}", watertight_text(&topo));
    if stats.skipped_triangles > 0 {
        eprintln!(
            "warning: {} triangles skipped where the coordinates are not finite",
            stats.skipped_triangles
        );
    }
    println!(
        "time: {mesh_secs:.3} s tessellating, {:.3} s writing",
        t_write.elapsed().as_secs_f64()
    );
    println!("wrote {} ({})", a.output.display(), format);
    Ok(())
}

/// One cell of the resolution the shape would be meshed at (for advice).
fn stats_hint(settings: &MeshSettings, shape: &Shape) -> f64 {
    let bounds = settings
        .bounds
        .or_else(|| isoray_mesh::shape_bounds(shape.tape(), settings.offset, settings.lipschitz).ok());
    match bounds {
        Some(b) => {
            let longest = (0..3).map(|k| b[1][k] - b[0][k]).fold(0.0, f64::max);
            longest / settings.resolution.max(1) as f64
        }
        None => 0.01,
    }
}

fn material(scene: &Scene, i: usize) -> MeshMaterial {
    let m = &scene.materials[i];
    MeshMaterial::from_diffuse(&m.name, m.diffuse, m.transparency)
}

fn unknown_name(path: &Path, scene: &Scene, name: &str) -> String {
    let objects: Vec<&str> = scene.objects.iter().filter_map(|o| o.name.as_deref()).collect();
    let surfaces: Vec<&str> = scene.library.surface_names().iter().map(|s| s.as_str()).collect();
    let mut msg = format!("the scene `{}` has no object or surface named `{name}`", path.display());
    let all = objects.iter().chain(&surfaces).copied();
    if let Some(sg) = isoray_shape::diag::suggest(name, all) {
        msg.push_str(&format!("\n  = help: did you mean `{sg}`?"));
    }
    msg.push_str(&format!(
        "\n  = note: named objects: {}; surfaces: {}",
        if objects.is_empty() {
            "none".to_string()
        } else {
            objects.join(", ")
        },
        if surfaces.is_empty() {
            "none".to_string()
        } else {
            surfaces.join(", ")
        }
    ));
    msg
}

fn watertight_text(t: &isoray_mesh::Topology) -> String {
    if t.is_closed_manifold() {
        format!(
            "yes (closed manifold: every edge in exactly two triangles, consistent winding, no degenerate triangles; {} component{})",
            t.components,
            if t.components == 1 { "" } else { "s" }
        )
    } else {
        format!(
            "no ({} boundary edges, {} non-manifold edges, {} misoriented edges, {} non-manifold vertices, {} degenerate triangles)",
            t.boundary_edges, t.nonmanifold_edges, t.misoriented_edges, t.nonmanifold_vertices, t.degenerate_triangles
        )
    }
}

fn stage_times(summaries: &[(String, isoray_mesh::MeshStats)]) -> String {
    let mut acc: Vec<(Stage, f64)> = Vec::new();
    for (_, s) in summaries {
        for &(st, t) in &s.timings {
            match acc.iter_mut().find(|(x, _)| *x == st) {
                Some(e) => e.1 += t,
                None => acc.push((st, t)),
            }
        }
    }
    if acc.is_empty() {
        return String::new();
    }
    let parts: Vec<String> = acc.iter().map(|(s, t)| format!("{} {t:.3}", s.name())).collect();
    format!(" ({})", parts.join(", "))
}

fn fmt3(p: [f64; 3]) -> String {
    format!("{:.4}, {:.4}, {:.4}", p[0], p[1], p[2])
}

/// The stages of meshing in the order they run (the bar's sections).
const STAGES: [Stage; 7] = [
    Stage::Bounds,
    Stage::Octree,
    Stage::Corners,
    Stage::Edges,
    Stage::Vertices,
    Stage::Faces,
    Stage::Finish,
];

/// A progress bar on stderr (only on a terminal, and only after half a
/// second), fed by the mesher's [`isoray_job::Progress`] reports
/// ([`Control::job`]): each stage by its name, then its fraction done.
struct MeshBar {
    enabled: bool,
    state: Mutex<Option<Meshing>>,
}

/// What [`MeshBar`] shows while a target is meshed.
struct Meshing {
    /// The target's label.
    label: String,
    /// When it started.
    start: Instant,
    /// The bar, once shown.
    bar: Option<indicatif::ProgressBar>,
    /// The stage reported last.
    stage: Stage,
}

impl isoray_job::Progress for MeshBar {
    fn stage(&self, name: &str) {
        let Ok(mut guard) = self.state.lock() else { return };
        if let (Some(s), Some(m)) = (STAGES.iter().find(|s| s.name() == name), guard.as_mut()) {
            m.stage = *s;
        }
    }

    fn update(&self, done: u64, total: u64) {
        if !self.enabled {
            return;
        }
        let stage = match self.state.lock() {
            Ok(guard) => match guard.as_ref() {
                Some(m) => m.stage,
                None => return,
            },
            Err(_) => return,
        };
        self.show(stage, if total == 0 { 0.0 } else { done as f64 / total as f64 });
    }
}

impl MeshBar {
    fn new(quiet: bool) -> Self {
        MeshBar {
            enabled: !quiet && std::io::stderr().is_terminal(),
            state: Mutex::new(None),
        }
    }

    fn begin(&self, label: &str) {
        if let Ok(mut s) = self.state.lock() {
            *s = Some(Meshing {
                label: label.to_string(),
                start: Instant::now(),
                bar: None,
                stage: Stage::Bounds,
            });
        }
    }

    /// Shows `stage` `fraction` done.
    fn show(&self, stage: Stage, fraction: f64) {
        if !self.enabled {
            return;
        }
        let Ok(mut guard) = self.state.lock() else { return };
        let Some(Meshing { label, start, bar, .. }) = guard.as_mut() else {
            return;
        };
        if bar.is_none() && start.elapsed() > Duration::from_millis(500) {
            let b = indicatif::ProgressBar::new(1000);
            b.set_style(
                indicatif::ProgressStyle::with_template("{spinner} meshing {msg} [{bar:30}] {elapsed}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            b.enable_steady_tick(Duration::from_millis(100));
            *bar = Some(b);
        }
        if let Some(b) = bar {
            let i = STAGES.iter().position(|s| *s == stage).unwrap_or(0);
            let done = (i as f64 + fraction.clamp(0.0, 1.0)) / STAGES.len() as f64;
            b.set_message(format!("{label}: {}", stage.name()));
            b.set_position((done * 1000.0) as u64);
        }
    }

    fn end(&self) {
        if let Ok(mut s) = self.state.lock() {
            if let Some(Meshing { bar: Some(b), .. }) = s.take() {
                b.finish_and_clear();
            }
        }
    }
}
