//! Time: the `[animation]` table (frame rate and duration) and `[[track]]`
//! keyframes that drive numeric scene values.
//!
//! A track holds keys `[[time, value], …]` with strictly increasing times
//! and samples them by step, linear or Catmull–Rom interpolation, once or
//! looped. Scenes apply their tracks whenever the time changes
//! ([`crate::Scene::set_time`]): the driven values are runtime inputs or
//! scene values, so nothing is recompiled from frame to frame.
//!
//! ```
//! use isoray_scene::{Interpolation, Track};
//! let track = Track::new("params.k", vec![(0.0, vec![0.0]), (2.0, vec![1.0])], Interpolation::Linear, false);
//! assert_eq!(track.sample(1.0), Some(vec![0.5]));
//! assert_eq!(track.sample(5.0), Some(vec![1.0])); // held after the last key
//! ```

use crate::doc::{Item, Located, Origin};
use crate::error::{SceneError, Sources};
use crate::reader::{describe, Reader};
use crate::schema::{key, key_without_default, KeySpec, Kind, Range};

type Result<T> = std::result::Result<T, SceneError>;

/// The scene's clock (`[animation]`): frame n is shown at t = n / fps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Animation {
    /// Frames per second.
    pub fps: f64,
    /// Length in seconds: the frames are those with n / fps < duration.
    pub duration: f64,
}

impl Animation {
    /// The time of frame `n`, seconds: exactly `n / fps`.
    pub fn time_of(&self, n: u64) -> f64 {
        n as f64 / self.fps
    }

    /// How many frames the animation has: those with n / fps < duration
    /// (at least one).
    pub fn frame_count(&self) -> u64 {
        let n = (self.duration * self.fps).ceil().max(1.0) as u64;
        // ceil of a product that rounds up past an integer would add a
        // frame at exactly t = duration.
        if n > 1 && self.time_of(n - 1) >= self.duration {
            n - 1
        } else {
            n
        }
    }
}

/// A track's keys: (time, value) pairs.
pub(crate) type Keys = Vec<(f64, Vec<f64>)>;

/// How a track fills the time between its keys.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interpolation {
    /// The value of the last key at or before the time.
    Step,
    /// Straight lines between keys.
    Linear,
    /// A Catmull–Rom spline: a cubic through every key whose slope at a
    /// key is the slope between its two neighbours (one-sided at the ends
    /// of a track that does not loop).
    Smooth,
}

impl Interpolation {
    /// The name written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Interpolation::Step => "step",
            Interpolation::Linear => "linear",
            Interpolation::Smooth => "smooth",
        }
    }
}

/// Keyframes that drive one numeric scene value (`[[track]]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// The dotted key driven: `params.k`, `object.2.position`,
    /// `light.0.intensity`, `camera.position`, `bone.NAME.rotation`.
    pub target: String,
    /// (time, value) pairs, times strictly increasing, values all of one
    /// width.
    pub keys: Vec<(f64, Vec<f64>)>,
    /// How values between keys are found.
    pub interpolation: Interpolation,
    /// Repeats with the period last − first key time when true; holds the
    /// end values outside the keys when false.
    pub looped: bool,
    /// Before the first key: the first key's value (true), or the scene's
    /// own value (false, as for values recorded from MIDI; see `rest`).
    pub hold_first: bool,
    /// Where the track's `target` was written.
    pub(crate) origin: Origin,
    /// What it drives (resolved when the scene is loaded).
    pub(crate) drive: Drive,
    /// How errors name it: `track.3`, or `midi.0` for a MIDI mapping.
    pub(crate) label: String,
    /// The value before the first key of a track that does not hold it:
    /// the scene's own value when a MIDI take was started.
    pub(crate) rest: Option<Vec<f64>>,
    /// Keys are quaternions [x, y, z, w] (a bone's rotation): linear
    /// interpolation is a slerp, smooth interpolation is normalised.
    pub(crate) quaternion: bool,
}

impl Track {
    /// A track (keys must have increasing times and one width).
    pub fn new(target: &str, keys: Vec<(f64, Vec<f64>)>, interpolation: Interpolation, looped: bool) -> Track {
        Track {
            target: target.to_string(),
            keys,
            interpolation,
            looped,
            hold_first: true,
            origin: Origin::Implicit,
            drive: Drive::Unresolved,
            label: format!("track on {target}"),
            rest: None,
            quaternion: false,
        }
    }

    /// The number of components of the values (1 for numbers, 3 for vectors).
    pub fn width(&self) -> usize {
        self.keys.first().map_or(0, |k| k.1.len())
    }

    /// The value at time `t`; None before the first key of a track that
    /// does not hold it, or for a track without keys.
    pub fn sample(&self, t: f64) -> Option<Vec<f64>> {
        let keys = &self.keys;
        let (first, last) = (keys.first()?.0, keys.last()?.0);
        let period = last - first;
        let t = if self.looped && period > 0.0 && t.is_finite() {
            first + (t - first).rem_euclid(period)
        } else {
            t
        };
        if t < first {
            return match self.hold_first {
                true => Some(keys[0].1.clone()),
                false => self.rest.clone(),
            };
        }
        // The segment [keys[i], keys[i + 1]] that holds t.
        let i = keys.partition_point(|k| k.0 <= t).saturating_sub(1);
        if i + 1 >= keys.len() {
            return Some(keys[keys.len() - 1].1.clone());
        }
        let ((t0, p0), (t1, p1)) = (&keys[i], &keys[i + 1]);
        let h = t1 - t0;
        let u = (t - t0) / h;
        Some(match self.interpolation {
            Interpolation::Step => p0.clone(),
            Interpolation::Linear if self.quaternion => {
                let (a, b) = (crate::skeleton::rotation_of(p0), crate::skeleton::rotation_of(p1));
                // The shorter way round.
                let b = if a.dot(b) < 0.0 { -b } else { b };
                a.slerp(b, u).to_array().to_vec()
            }
            Interpolation::Linear => p0.iter().zip(p1).map(|(a, b)| a + (b - a) * u).collect(),
            Interpolation::Smooth => {
                let (m0, m1) = (self.slope(i), self.slope(i + 1));
                let (u2, u3) = (u * u, u * u * u);
                let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
                let h10 = u3 - 2.0 * u2 + u;
                let h01 = -2.0 * u3 + 3.0 * u2;
                let h11 = u3 - u2;
                let v: Vec<f64> = (0..p0.len())
                    .map(|c| h00 * p0[c] + h10 * h * m0[c] + h01 * p1[c] + h11 * h * m1[c])
                    .collect();
                if self.quaternion {
                    crate::skeleton::rotation_of(&v).to_array().to_vec()
                } else {
                    v
                }
            }
        })
    }

    /// The Catmull–Rom slope at key `i`: between its neighbours, across
    /// the seam of a looped track (whose last key stands for its first).
    fn slope(&self, i: usize) -> Vec<f64> {
        let keys = &self.keys;
        let n = keys.len();
        let period = keys[n - 1].0 - keys[0].0;
        let at = |j: usize, shift: f64| (keys[j].0 + shift, &keys[j].1);
        let (prev, next) = match (i, self.looped && n > 2) {
            (0, true) => (at(n - 2, -period), at(1, 0.0)),
            (i, true) if i == n - 1 => (at(n - 2, 0.0), at(1, period)),
            (0, false) => (at(0, 0.0), at(1, 0.0)),
            (i, false) if i == n - 1 => (at(n - 2, 0.0), at(n - 1, 0.0)),
            (i, _) => (at(i - 1, 0.0), at(i + 1, 0.0)),
        };
        let dt = next.0 - prev.0;
        next.1.iter().zip(prev.1).map(|(b, a)| (b - a) / dt).collect()
    }
}

/// The keys of `[animation]`.
pub fn animation_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key(
                "fps",
                Kind::Num(Range::POSITIVE),
                "24.0",
                "frames per second: frame n is rendered at t = n / fps",
            ),
            key_without_default(
                "duration",
                Kind::Num(Range::POSITIVE),
                "required",
                "length in seconds: the frames are those with n / fps < duration",
            ),
        ]
    });
    &KEYS
}

/// The keys of a `[[track]]`.
pub fn track_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key_without_default(
                "target",
                Kind::Str,
                "required",
                "the dotted key driven: `params.NAME`, `object.N.position` (or `rotation`, `scale`), `light.N.KEY`, `camera.KEY`, `material.NAME.KEY`, `bone.NAME.rotation`",
            ),
            key_without_default(
                "keys",
                Kind::Text("array of [time, value]"),
                "required",
                "times in seconds, strictly increasing; values numbers or `[x, y, z]` arrays, all of one width",
            ),
            key(
                "interpolation",
                Kind::Choice(vec!["step", "linear", "smooth"]),
                "\"linear\"",
                "`step` holds each key; `linear` draws straight lines; `smooth` is a Catmull–Rom spline through every key",
            ),
            key(
                "loop",
                Kind::Bool,
                "false",
                "repeat with the period of the keys (last time − first time); otherwise the end values hold",
            ),
        ]
    });
    &KEYS
}

/// Reads `[animation]`.
pub(crate) fn read_animation(src: &Sources, v: &Located) -> Result<Animation> {
    let mut r = Reader::new(src, v, "animation")?;
    let keys = animation_keys();
    let fps = r.num_key(crate::schema::spec(keys, "fps"))?;
    let Some(d) = r.get("duration") else {
        return Err(src
            .error(
                v.origin,
                "`animation` needs a `duration` in seconds",
                Some("add duration = 4.0"),
                &[],
            )
            .with_key("animation.duration"));
    };
    let duration = match d.item {
        Item::Num(x, _) if x.is_finite() && x > 0.0 => x,
        _ => return Err(r.err(d, "duration", "a positive number of seconds")),
    };
    r.finish_keys(keys)?;
    Ok(Animation { fps, duration })
}

/// Reads the `[[track]]` tables: their keys checked, their targets not yet
/// (the scene resolves them once it knows its values).
pub(crate) fn read_tracks(src: &Sources, v: &Located) -> Result<Vec<Track>> {
    let items = crate::read::array_of_tables(src, v, "track", false)?;
    let mut tracks = Vec::new();
    for (i, tv) in items.into_iter().enumerate() {
        let ctx = format!("track.{i}");
        let mut r = Reader::new(src, tv, &ctx)?;
        let Some((target, target_loc)) = r.string("target")? else {
            return Err(src
                .error(
                    tv.origin,
                    format!("`{ctx}` needs a `target`: the dotted key it drives"),
                    Some("add target = \"params.k\""),
                    &[],
                )
                .with_key(format!("{ctx}.target")));
        };
        let Some(kv) = r.get("keys") else {
            return Err(src
                .error(
                    tv.origin,
                    format!("`{ctx}` needs `keys`: [[time, value], …]"),
                    Some("add keys = [[0.0, 0.0], [1.0, 1.0]]"),
                    &[],
                )
                .with_key(format!("{ctx}.keys")));
        };
        let keys = read_keys(src, kv, &format!("{ctx}.keys"))?;
        let specs = track_keys();
        let interpolation = match r.choice_key(crate::schema::spec(specs, "interpolation"))? {
            "step" => Interpolation::Step,
            "smooth" => Interpolation::Smooth,
            _ => Interpolation::Linear,
        };
        let looped = r.bool_key(crate::schema::spec(specs, "loop"))?;
        r.finish_keys(specs)?;
        tracks.push(Track {
            target: target.to_string(),
            keys,
            interpolation,
            looped,
            hold_first: true,
            origin: target_loc.origin,
            drive: Drive::Unresolved,
            label: ctx.clone(),
            rest: None,
            quaternion: false,
        });
    }
    Ok(tracks)
}

/// `[[time, value], …]` with increasing times and values of one width.
fn read_keys(src: &Sources, v: &Located, ctx: &str) -> Result<Vec<(f64, Vec<f64>)>> {
    let bad = |at: &Located, expected: &str| {
        src.error(
            at.origin,
            format!("`{ctx}`: expected {expected}, found {}", describe(&at.item)),
            Some(&format!("expected {expected}")),
            &["for example keys = [[0.0, 1.0], [2.0, 0.5]] or [[0.0, [0, 1, 0]], [1.0, [0, 2, 0]]]".into()],
        )
        .with_key(ctx.to_string())
    };
    let Item::Array(items) = &v.item else {
        return Err(bad(v, "an array of [time, value] pairs"));
    };
    if items.is_empty() {
        return Err(bad(v, "at least one [time, value] pair"));
    }
    let num = |at: &Located| match at.item {
        Item::Num(x, _) if x.is_finite() => Some(x),
        _ => None,
    };
    let mut keys: Vec<(f64, Vec<f64>)> = Vec::new();
    for item in items {
        let Item::Array(pair) = &item.item else {
            return Err(bad(item, "a [time, value] pair"));
        };
        let [tv, vv] = &pair[..] else {
            return Err(bad(item, "a [time, value] pair (two elements)"));
        };
        let Some(t) = num(tv) else {
            return Err(bad(tv, "a time in seconds"));
        };
        let value = match &vv.item {
            Item::Array(xs) if !xs.is_empty() => {
                let mut out = Vec::with_capacity(xs.len());
                for x in xs {
                    out.push(num(x).ok_or_else(|| bad(x, "a number"))?);
                }
                out
            }
            _ => vec![num(vv).ok_or_else(|| bad(vv, "a number or an array of numbers"))?],
        };
        if let Some((t0, v0)) = keys.last() {
            if t <= *t0 {
                return Err(bad(tv, &format!("a time after the previous key's {t0}")));
            }
            if v0.len() != value.len() {
                return Err(bad(
                    vv,
                    &format!("a value of {} component(s), as the first key's", v0.len()),
                ));
            }
        }
        keys.push((t, value));
    }
    Ok(keys)
}

/// What a track drives, once the scene knows its values.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Drive {
    /// Not resolved yet (a track made by [`Track::new`]).
    Unresolved,
    /// A parameter's inputs from `at` on.
    Param {
        /// The parameter's name.
        name: String,
        /// Its first input.
        at: u32,
    },
    /// Object `object`'s placement: position (0), rotation (3) or scale (6).
    Placement {
        /// The object's index.
        object: usize,
        /// The first of the placement's inputs driven, from the object's first.
        first: usize,
    },
    /// A camera, light or material value, set through [`crate::Scene::set_value`].
    Value,
    /// A bone's local rotation (`rotation` true) or position.
    Bone {
        /// The bone's index.
        bone: usize,
        /// Its rotation rather than its position.
        rotation: bool,
    },
}

/// The numbers of a value: a number, or an array of numbers.
pub(crate) fn numbers(v: &Located) -> Option<Vec<f64>> {
    let num = |at: &Located| match at.item {
        Item::Num(x, _) if x.is_finite() => Some(x),
        _ => None,
    };
    match &v.item {
        Item::Array(xs) => xs.iter().map(num).collect(),
        _ => num(v).map(|x| vec![x]),
    }
}

/// The placement parts a track can drive, with their first input and width.
const PLACEMENT_PARTS: [(&str, usize, usize); 3] = [("position", 0, 3), ("rotation", 3, 3), ("scale", 6, 1)];

/// Which object placement a target names: (object, first input, width);
/// None when it names no object.
pub(crate) fn placement_target(target: &str) -> Option<std::result::Result<(usize, usize, usize), String>> {
    let rest = target.strip_prefix("object.")?;
    let (index, part) = rest.split_once('.').unwrap_or((rest, ""));
    let Ok(object) = index.parse::<usize>() else {
        return Some(Err(format!(
            "`{target}`: expected an object index after `object.`, like `object.0.position`"
        )));
    };
    match PLACEMENT_PARTS.iter().find(|(name, ..)| *name == part) {
        Some(&(_, first, width)) => Some(Ok((object, first, width))),
        None => Some(Err(format!(
            "`{target}`: an object's track drives its `position`, `rotation` or `scale`"
        ))),
    }
}

/// Resolves the parameter targets of `tracks` (file tracks and the probes
/// of MIDI mappings) and finds the objects they place, which must get
/// placement inputs even when their file places them nowhere. Other
/// targets are resolved by [`resolve_late`].
pub(crate) fn resolve_early(
    src: &Sources,
    lib: &isoray_shape::Library,
    tracks: &mut [Track],
    params: &[(String, isoray_shape::Value)],
    ranges: &[crate::ParamRange],
    bones: &[crate::skeleton::Bone],
) -> Result<Vec<usize>> {
    let mut placed = Vec::new();
    for tr in tracks.iter_mut() {
        let label = tr.label.clone();
        if let Some(rest) = tr.target.strip_prefix("bone.") {
            let (name, part) = rest.rsplit_once('.').unwrap_or((rest, ""));
            let Some(bone) = bones.iter().position(|b| b.name == name) else {
                let mut notes = vec![];
                if let Some(s) = isoray_shape::diag::suggest(name, bones.iter().map(|b| b.name.as_str())) {
                    notes.push(format!("did you mean `bone.{s}.{part}`?"));
                }
                return Err(tr.error(
                    src,
                    format!("`{label}`: the scene has no bone named \"{name}\""),
                    &notes,
                ));
            };
            match part {
                "rotation" => {
                    if tr.width() != 3 && tr.width() != 4 {
                        return Err(tr.error(
                            src,
                            format!(
                                "`{label}`: a bone's rotation takes [x, y, z] degrees or a quaternion [x, y, z, w], found {} component(s)",
                                tr.width()
                            ),
                            &[],
                        ));
                    }
                    tr.quaternion = tr.width() == 4;
                }
                "position" => tr.check_width(src, 3, "a position")?,
                _ => {
                    return Err(tr.error(
                        src,
                        format!("`{label}`: a bone's track drives its `rotation` or `position`, not `{part}`"),
                        &[],
                    ))
                }
            }
            tr.drive = Drive::Bone {
                bone,
                rotation: part == "rotation",
            };
            continue;
        }
        if let Some(name) = tr.target.strip_prefix("params.") {
            let Some((at, ty)) = lib.param_input(name) else {
                let names: Vec<&str> = params.iter().map(|(n, _)| n.as_str()).collect();
                let mut notes = vec![];
                if let Some(s) = isoray_shape::diag::suggest(name, names.iter().copied()) {
                    notes.push(format!("did you mean `params.{s}`?"));
                }
                return Err(tr.error(
                    src,
                    format!("`{label}`: the scene has no parameter `{name}` in `[params]`"),
                    &notes,
                ));
            };
            tr.check_width(src, ty.width(), &format!("a `{ty}` parameter"))?;
            if let Some(r) = ranges.iter().find(|r| r.key == tr.target) {
                if let Some((t, v)) = tr.keys.iter().find(|(_, v)| v[0] < r.range[0] || v[0] > r.range[1]) {
                    let which = if tr.is_midi() {
                        "its range".to_string()
                    } else {
                        format!("the key at t = {t}")
                    };
                    return Err(tr.error(
                        src,
                        format!(
                            "`{label}`: {which} sets `{}` = {} outside the parameter's range [{}, {}]",
                            tr.target, v[0], r.range[0], r.range[1]
                        ),
                        &[],
                    ));
                }
            }
            tr.drive = Drive::Param {
                name: name.to_string(),
                at,
            };
        } else if let Some(p) = placement_target(&tr.target) {
            let (object, _, width) = p.map_err(|m| tr.error(src, format!("`{label}`: {m}"), &[]))?;
            tr.check_width(src, width, if width == 1 { "a number" } else { "a vector" })?;
            if tr.target.ends_with(".scale") {
                if let Some((t, v)) = tr.keys.iter().find(|(_, v)| v[0] <= 0.0) {
                    return Err(tr.error(
                        src,
                        format!("`{label}`: a scale must be positive, found {} (at t = {t})", v[0]),
                        &[],
                    ));
                }
            }
            placed.push(object);
        }
    }
    // Two drivers of one value would fight: the second is an error.
    for (i, tr) in tracks.iter().enumerate() {
        if let Some(other) = tracks[..i].iter().find(|o| o.target == tr.target) {
            return Err(tr.error(
                src,
                format!(
                    "`{}` drives `{}`, which `{}` drives already",
                    tr.label, tr.target, other.label
                ),
                &["give one value one track or MIDI mapping".into()],
            ));
        }
    }
    Ok(placed)
}

/// Puts the values of the parameter tracks at `time` into the library
/// (before anything is compiled) and the scene's parameter list.
pub(crate) fn apply_param_tracks(
    lib: &mut isoray_shape::Library,
    tracks: &[Track],
    params: &mut [(String, isoray_shape::Value)],
    time: f64,
) {
    for tr in tracks {
        let Drive::Param { name, .. } = &tr.drive else { continue };
        if let Some(v) = tr.sample(time) {
            let value = isoray_shape::Value::from_components(&v);
            lib.set_param(name, value);
            if let Some(p) = params.iter_mut().find(|(n, _)| n == name) {
                p.1 = value;
            }
        }
    }
}

/// Resolves the object and value targets once the objects are read:
/// an object must exist, and a value written as an expression of `t`
/// cannot also have a track (the error names both places).
pub(crate) fn resolve_late(
    src: &Sources,
    root: &[crate::doc::Entry],
    tracks: &mut [Track],
    objects: usize,
    driven: &[crate::Driven],
) -> Result<()> {
    for tr in tracks.iter_mut() {
        if matches!(tr.drive, Drive::Param { .. } | Drive::Bone { .. }) {
            continue;
        }
        let label = tr.label.clone();
        let both = |tr: &Track, at: Origin| {
            let place = match at {
                Origin::File(span) => {
                    let (line, col) = isoray_shape::diag::line_col(&src.text, span.start);
                    format!("{}:{line}:{col}", src.path)
                }
                Origin::Override(k) => format!("--set #{}", k + 1),
                Origin::Implicit => src.path.clone(),
            };
            tr.error(
                src,
                format!(
                    "`{}` is written as an expression of `t` ({place}) and driven by `{label}`: use one or the other",
                    tr.target
                ),
                &["a track replaces a number; an expression and a track cannot both set one value".into()],
            )
        };
        if let Some(p) = placement_target(&tr.target) {
            let (object, first, _) = p.expect("checked early");
            if object >= objects {
                return Err(tr.error(
                    src,
                    format!(
                        "`{label}`: `{}` names object {object}, but the scene has {objects}",
                        tr.target
                    ),
                    &[],
                ));
            }
            if let Some(v) = crate::doc::find(root, &tr.target) {
                let text = match &v.item {
                    Item::Str(..) => true,
                    Item::Array(xs) => xs.iter().any(|x| matches!(x.item, Item::Str(..))),
                    _ => false,
                };
                if text {
                    return Err(both(tr, v.origin));
                }
            }
            tr.drive = Drive::Placement { object, first };
            continue;
        }
        let valued = ["camera.", "light.", "material."]
            .iter()
            .any(|p| tr.target.starts_with(p));
        if !valued {
            return Err(tr.error(
                src,
                format!("`{label}`: `{}` is not a value a track can drive", tr.target),
                &["targets: `params.NAME`, `object.N.position` (`rotation`, `scale`), `camera.KEY`, `light.N.KEY`, `material.NAME.KEY`, `bone.NAME.rotation` (`position`)".into()],
            ));
        }
        if let Some(d) = driven.iter().find(|d| d.key == tr.target) {
            return Err(both(tr, d.origin));
        }
        tr.drive = Drive::Value;
    }
    Ok(())
}

impl Track {
    /// An error at the track's target.
    pub(crate) fn error(&self, src: &Sources, message: String, notes: &[String]) -> SceneError {
        src.error(self.origin, message, Some("this target"), notes)
            .with_key(format!("{}.target", self.label))
    }

    /// True for the probe of a MIDI mapping.
    pub(crate) fn is_midi(&self) -> bool {
        self.label.starts_with("midi.")
    }

    /// Checks that every key has `width` components (`what` names the target).
    pub(crate) fn check_width(&self, src: &Sources, width: usize, what: &str) -> Result<()> {
        if self.width() == width {
            return Ok(());
        }
        let message = if self.is_midi() {
            format!(
                "`{}`: `{}` is {what}, but a MIDI mapping drives one number",
                self.label, self.target
            )
        } else {
            format!(
                "`{}`: `{}` is {what}, so its keys need values of {width} component(s), found {}",
                self.label,
                self.target,
                self.width()
            )
        };
        Err(self.error(src, message, &[]))
    }

    /// What the track drives.
    pub(crate) fn drive(&self) -> &Drive {
        &self.drive
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(keys: &[(f64, f64)], how: Interpolation, looped: bool) -> Track {
        Track::new(
            "params.k",
            keys.iter().map(|&(t, v)| (t, vec![v])).collect(),
            how,
            looped,
        )
    }

    fn at(t: &Track, x: f64) -> f64 {
        t.sample(x).unwrap()[0]
    }

    #[test]
    fn step_holds_the_last_key_at_or_before_the_time() {
        let t = track(&[(0.0, 1.0), (1.0, 2.0), (2.0, 3.0)], Interpolation::Step, false);
        assert_eq!(at(&t, -1.0), 1.0);
        assert_eq!(at(&t, 0.999), 1.0);
        assert_eq!(at(&t, 1.0), 2.0);
        assert_eq!(at(&t, 7.0), 3.0);
    }

    #[test]
    fn linear_gives_the_mean_at_the_midpoint() {
        let t = track(&[(1.0, 2.0), (3.0, 6.0)], Interpolation::Linear, false);
        assert_eq!(at(&t, 2.0), 4.0);
        assert_eq!(at(&t, 1.5), 3.0);
        assert_eq!(at(&t, 0.0), 2.0);
        assert_eq!(at(&t, 9.0), 6.0);
    }

    #[test]
    fn smooth_passes_through_every_key_and_matches_the_uniform_catmull_rom_matrix() {
        let ps = [(0.0, 0.0), (1.0, 2.0), (2.0, -1.0), (3.0, 4.0), (4.0, 1.0)];
        let t = track(&ps, Interpolation::Smooth, false);
        for &(x, v) in &ps {
            assert!((at(&t, x) - v).abs() < 1e-12, "{x}");
        }
        // The textbook form on the uniform segment [p1, p2]:
        // ½(2p1 + (p2 − p0)u + (2p0 − 5p1 + 4p2 − p3)u² + (−p0 + 3p1 − 3p2 + p3)u³).
        let (p0, p1, p2, p3) = (ps[0].1, ps[1].1, ps[2].1, ps[3].1);
        for k in 0..=10 {
            let u = k as f64 / 10.0;
            let want = 0.5
                * (2.0 * p1
                    + (p2 - p0) * u
                    + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u * u
                    + (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * u * u * u);
            assert!((at(&t, 1.0 + u) - want).abs() < 1e-12, "u = {u}");
        }
    }

    #[test]
    fn a_looped_track_repeats_with_the_period_of_its_keys() {
        let t = track(&[(0.0, 0.0), (1.0, 1.0), (2.0, 0.0)], Interpolation::Linear, true);
        assert_eq!(at(&t, 0.5), 0.5);
        assert_eq!(at(&t, 2.5), 0.5);
        assert_eq!(at(&t, -1.5), 0.5);
        assert_eq!(at(&t, 3.0), 1.0);
        // A smooth loop is smooth across the seam: equal slopes from both sides.
        let s = track(
            &[(0.0, 0.0), (1.0, 1.0), (2.0, 0.0), (3.0, -1.0), (4.0, 0.0)],
            Interpolation::Smooth,
            true,
        );
        let e = 1e-6;
        let left = (at(&s, 4.0 - e) - at(&s, 4.0 - 2.0 * e)) / e;
        let right = (at(&s, 4.0 + 2.0 * e) - at(&s, 4.0 + e)) / e;
        assert!((left - right).abs() < 1e-4, "{left} vs {right}");
    }

    #[test]
    fn vectors_interpolate_per_component() {
        let t = Track::new(
            "camera.position",
            vec![(0.0, vec![0.0, 1.0, 2.0]), (2.0, vec![2.0, 1.0, 0.0])],
            Interpolation::Linear,
            false,
        );
        assert_eq!(t.sample(1.0), Some(vec![1.0, 1.0, 1.0]));
    }

    #[test]
    fn frames_are_those_before_the_duration() {
        let a = Animation {
            fps: 24.0,
            duration: 2.0,
        };
        assert_eq!(a.frame_count(), 48);
        assert_eq!(a.time_of(47), 47.0 / 24.0);
        let b = Animation {
            fps: 30.0,
            duration: 0.1,
        };
        assert_eq!(b.frame_count(), 3);
        let c = Animation {
            fps: 10.0,
            duration: 0.25,
        };
        assert_eq!(c.frame_count(), 3);
    }

    #[test]
    fn before_the_first_key_a_recorded_track_leaves_the_value_alone() {
        let mut t = track(&[(1.0, 5.0)], Interpolation::Step, false);
        t.hold_first = false;
        assert_eq!(t.sample(0.5), None);
        assert_eq!(t.sample(1.0), Some(vec![5.0]));
    }
}
