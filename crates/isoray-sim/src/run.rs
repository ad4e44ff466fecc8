//! A whole simulation run, as `isoray simulate` drives it: the scene is
//! stepped at its fixed timestep, each impact dents what it strikes, and a
//! callback sees the scene at each frame's time (frame n at t = n / fps).
//! The run's record lists every impact and every frame's placements; a
//! replay of that record gives the same dents and the same frames without
//! the physics.

use std::path::Path;

use isoray_scene::{DentMode, Placement, Scene};
use serde::{Deserialize, Serialize};

use crate::{dent_impact, Impact, ImprintMethod, SimError, Simulation};

/// What a run does.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOptions {
    /// Seconds simulated.
    pub duration: f64,
    /// Frames per second of the callback.
    pub fps: f64,
    /// Overrides every dentable object's `dents` (None: as the scene says).
    pub dents: Option<DentMode>,
    /// How dents are measured.
    pub imprint: ImprintMethod,
}

/// One impact in the record, with what it did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImpactRecord {
    /// Seconds.
    pub time: f64,
    /// The step.
    pub step: u64,
    /// The two objects (indices into the scene's objects) and their names.
    pub objects: [usize; 2],
    /// Their names, when they have them.
    pub names: [Option<String>; 2],
    /// The contact point.
    pub point: [f64; 3],
    /// The contact normal, from the first object towards the second.
    pub normal: [f64; 3],
    /// Their overlap at the end of the step.
    pub penetration: f64,
    /// Velocities before the step.
    pub velocities: [[f64; 3]; 2],
    /// |j| of the elastic impulse, N·s.
    pub impulse: f64,
    /// Whether they were closing.
    pub approaching: bool,
    /// Both objects' placements at the impact ([position, rotation degrees, scale]).
    pub placements: [[f64; 7]; 2],
    /// The dents it made.
    pub dents: Vec<DentEntry>,
}

/// One dent of an impact.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DentEntry {
    /// The struck object.
    pub object: usize,
    /// Its yield impulse, N·s.
    #[serde(rename = "yield")]
    pub yield_impulse: f64,
    /// The depth, scene units (0: none).
    pub depth: f64,
    /// Texels lowered.
    pub texels: u64,
    /// The height map's rectangle written [x0, y0, x1, y1].
    pub rect: Option<[u32; 4]>,
    /// Imprint time, ms.
    pub imprint_ms: f64,
    /// Normal-map update time, ms.
    pub normals_ms: f64,
    /// Cut into the geometry (`[[object.sdf_dent]]`) rather than imprinted in the maps.
    #[serde(default)]
    pub geometry: bool,
}

/// A run's record: `isoray simulate --record`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Record {
    /// The run's step, seconds.
    pub timestep: f64,
    /// Frames per second.
    pub fps: f64,
    /// Every impact, in order.
    pub impacts: Vec<ImpactRecord>,
    /// Per frame, the moving objects' placements: (object, [7 values]).
    pub frames: Vec<Vec<(usize, [f64; 7])>>,
}

impl Record {
    /// Writes the record as JSON, atomically.
    pub fn write(&self, path: &Path) -> Result<(), String> {
        let text = serde_json::to_string_pretty(self).map_err(|e| e.to_string())?;
        isoray_scene::write_atomic(path, text.as_bytes()).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Reads a record written by [`Record::write`]; errors name the file,
    /// line and column.
    pub fn read(path: &Path) -> Result<Record, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        serde_json::from_str(&text).map_err(|e| {
            format!(
                "{}:{}:{}: {e}; expected a record written by `isoray simulate --record`",
                path.display(),
                e.line(),
                e.column()
            )
        })
    }
}

/// The number of frames of `duration` seconds at `fps`: those with n / fps < duration.
pub fn frame_count(duration: f64, fps: f64) -> u64 {
    ((duration * fps).ceil() as u64).max(1)
}

fn set_dents(scene: &mut Scene, mode: Option<DentMode>) {
    if let Some(mode) = mode {
        for o in &mut scene.objects {
            if o.physics.dents != DentMode::None {
                o.physics.dents = mode;
            }
        }
    }
}

/// Runs the simulation of `scene`: `frame(n, scene)` is called at each
/// frame's time with the scene moved and dented so far. Returns the record.
pub fn run<E: From<SimError> + From<isoray_scene::SceneError>>(
    scene: &mut Scene,
    opts: &RunOptions,
    mut frame: impl FnMut(u64, &Scene) -> Result<(), E>,
) -> Result<Record, E> {
    set_dents(scene, opts.dents);
    let mut sim = Simulation::new(scene)?;
    let mut record = Record {
        timestep: sim.timestep(),
        fps: opts.fps,
        ..Default::default()
    };
    let frames = frame_count(opts.duration, opts.fps);
    for n in 0..frames {
        let t = n as f64 / opts.fps;
        while sim.time() + 0.5 * sim.timestep() < t {
            let impacts = sim.step();
            sim.place(scene)?;
            for i in impacts {
                // `--dents none` left no object dentable: nothing is dented.
                let dents = dent_impact(scene, &i, opts.imprint)?;
                record.impacts.push(entry(scene, &i, &dents));
            }
        }
        // The frame sees the bodies where the record has them.
        sim.place(scene)?;
        record
            .frames
            .push(sim.placements().iter().map(|(i, p)| (*i, p.values())).collect());
        frame(n, scene)?;
    }
    Ok(record)
}

fn entry(scene: &Scene, i: &Impact, dents: &[crate::DentRecord]) -> ImpactRecord {
    let name = |k: usize| scene.objects[k].name.clone();
    ImpactRecord {
        time: i.time,
        step: i.step,
        objects: [i.a, i.b],
        names: [name(i.a), name(i.b)],
        point: i.point,
        normal: i.normal,
        penetration: i.penetration,
        velocities: i.velocities,
        impulse: i.impulse,
        approaching: i.approaching,
        placements: [scene.placement(i.a).values(), scene.placement(i.b).values()],
        dents: dents
            .iter()
            .map(|d| DentEntry {
                object: d.object,
                yield_impulse: d.yield_impulse,
                depth: d.depth,
                texels: d.texels,
                rect: d.rect.map(|r| [r.x0, r.y0, r.x1, r.y1]),
                imprint_ms: d.imprint_ms,
                normals_ms: d.normals_ms,
                geometry: d.geometry,
            })
            .collect(),
    }
}

/// Replays `record` on `scene` without physics: each impact's objects are
/// put where the record has them and dented again, and each frame's
/// moving objects are placed as recorded. The dents and frames are those
/// of the run that wrote the record.
pub fn replay<E: From<SimError> + From<isoray_scene::SceneError>>(
    scene: &mut Scene,
    record: &Record,
    opts: &RunOptions,
    mut frame: impl FnMut(u64, &Scene) -> Result<(), E>,
) -> Result<(), E> {
    set_dents(scene, opts.dents);
    let mut next = 0;
    for (n, placed) in record.frames.iter().enumerate() {
        let t = n as f64 / record.fps;
        while next < record.impacts.len() && record.impacts[next].time <= t + 0.5 * record.timestep {
            let r = &record.impacts[next];
            next += 1;
            for (k, &o) in r.objects.iter().enumerate() {
                if o >= scene.objects.len() {
                    return Err(SimError::Object {
                        object: o,
                        message: "the record names an object the scene does not have".into(),
                    }
                    .into());
                }
                if scene.objects[o].transform.is_some() {
                    scene.set_placement(o, Placement::from_values(&r.placements[k]))?;
                }
            }
            let impact = Impact {
                time: r.time,
                step: r.step,
                a: r.objects[0],
                b: r.objects[1],
                point: r.point,
                normal: r.normal,
                penetration: r.penetration,
                velocities: r.velocities,
                inverse_masses: [0.0; 2],
                impulse: r.impulse,
                approaching: r.approaching,
            };
            dent_impact(scene, &impact, opts.imprint)?;
        }
        for (o, v) in placed {
            scene.set_placement(*o, Placement::from_values(v))?;
        }
        frame(n as u64, scene)?;
    }
    Ok(())
}
