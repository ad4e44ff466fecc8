//! MIDI control: `[[midi]]` mappings from a controller (a control change
//! or a note) to a numeric scene value, MIDI files read into timed events
//! (tempo changes honoured) and written back, and a take of events turned
//! into step tracks the scene applies at every time.
//!
//! A controller value v of 0–127 gives lo + (hi − lo)·v/127 with the
//! linear curve, and lo·(hi/lo)^(v/127) with the exponential one.
//!
//! ```
//! use isoray_scene::midi::{Curve, MidiMapping, Source};
//! let m = MidiMapping::new(Source::Cc(1), None, "params.k", [0.5, 2.0], Curve::Linear);
//! assert_eq!(m.value(0), 0.5);
//! assert_eq!(m.value(127), 2.0);
//! ```

use std::path::Path;

use crate::animation::{Drive, Interpolation, Track};
use crate::doc::{Item, Located, Origin};
use crate::error::{SceneError, Sources};
use crate::reader::Reader;
use crate::schema::{key, key_without_default, KeySpec, Kind};

type Result<T> = std::result::Result<T, SceneError>;

/// What a mapping listens to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// A control change number (a knob or fader), 0–127.
    Cc(u8),
    /// A note number (a pad or key), 0–127: its velocity while held, 0
    /// after its note-off.
    Note(u8),
}

/// How a controller value maps into the range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Curve {
    /// lo + (hi − lo)·v/127.
    Linear,
    /// lo·(hi/lo)^(v/127): equal turns of the knob multiply the value by
    /// equal factors (a range of positive numbers).
    Exponential,
}

/// A `[[midi]]` mapping.
#[derive(Debug, Clone, PartialEq)]
pub struct MidiMapping {
    /// The controller.
    pub source: Source,
    /// The channel 1–16 as musicians count them; None for any.
    pub channel: Option<u8>,
    /// The dotted key driven (a number: `params.k`, `object.0.scale`,
    /// `light.0.intensity`, …).
    pub target: String,
    /// [lo, hi]: the values of controller values 0 and 127.
    pub range: [f64; 2],
    /// How values in between are spread.
    pub curve: Curve,
    /// A part of the input port's name to listen to (live input only).
    pub port: Option<String>,
    pub(crate) origin: Origin,
    pub(crate) drive: Drive,
}

impl MidiMapping {
    /// A mapping (not yet resolved against a scene).
    pub fn new(source: Source, channel: Option<u8>, target: &str, range: [f64; 2], curve: Curve) -> MidiMapping {
        MidiMapping {
            source,
            channel,
            target: target.to_string(),
            range,
            curve,
            port: None,
            origin: Origin::Implicit,
            drive: Drive::Unresolved,
        }
    }

    /// A stand-in track of the mapping's two extreme values, resolved and
    /// checked like a track's keys (mapping `index` in the file); it drives
    /// what the mapping drives.
    pub(crate) fn probe(&self, index: usize) -> Track {
        let mut t = Track::new(
            &self.target,
            vec![(0.0, vec![self.range[0]]), (1.0, vec![self.range[1]])],
            Interpolation::Step,
            false,
        );
        t.hold_first = false;
        t.origin = self.origin;
        t.label = format!("midi.{index}");
        t.drive = self.drive.clone();
        t
    }

    /// The value a controller value `v` (0–127) gives.
    pub fn value(&self, v: u8) -> f64 {
        let [lo, hi] = self.range;
        let u = f64::from(v.min(127)) / 127.0;
        match self.curve {
            Curve::Linear => lo + (hi - lo) * u,
            Curve::Exponential => lo * (hi / lo).powf(u),
        }
    }

    /// The controller value an event sends to this mapping, if it does.
    pub fn hears(&self, e: &MidiEvent) -> Option<u8> {
        if self.channel.is_some_and(|c| c != e.channel) {
            return None;
        }
        match (self.source, e.kind) {
            (Source::Cc(n), Message::Cc { controller, value }) if n == controller => Some(value),
            (Source::Note(n), Message::NoteOn { key, velocity }) if n == key => Some(velocity),
            (Source::Note(n), Message::NoteOff { key }) if n == key => Some(0),
            _ => None,
        }
    }
}

/// One MIDI message at a time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MidiEvent {
    /// Seconds from the start of the take.
    pub time: f64,
    /// The channel, 1–16.
    pub channel: u8,
    /// The message.
    pub kind: Message,
}

/// The messages mappings hear.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Message {
    /// A control change.
    Cc {
        /// The controller number.
        controller: u8,
        /// Its value, 0–127.
        value: u8,
    },
    /// A note pressed (velocity 0 is a release, as MIDI says).
    NoteOn {
        /// The note number.
        key: u8,
        /// How hard, 1–127.
        velocity: u8,
    },
    /// A note released.
    NoteOff {
        /// The note number.
        key: u8,
    },
}

/// The keys of a `[[midi]]` mapping.
pub fn midi_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key_without_default(
                "cc",
                Kind::Int { lo: 0, hi: 127 },
                "none",
                "the control change number it listens to (a knob or fader); give `cc` or `note`",
            ),
            key_without_default(
                "note",
                Kind::Int { lo: 0, hi: 127 },
                "none",
                "the note number it listens to (a pad): its velocity while held, 0 after release",
            ),
            key_without_default(
                "channel",
                Kind::Int { lo: 1, hi: 16 },
                "any",
                "the MIDI channel, 1–16 as musicians count them",
            ),
            key_without_default(
                "target",
                Kind::Str,
                "required",
                "the number it drives: `params.NAME`, `object.N.scale`, `light.N.KEY`, `camera.fov`, `material.NAME.KEY`",
            ),
            key(
                "range",
                Kind::Text("[lo, hi]"),
                "[0.0, 1.0]",
                "the values of controller values 0 and 127",
            ),
            key(
                "curve",
                Kind::Choice(vec!["linear", "exponential"]),
                "\"linear\"",
                "`linear`: lo + (hi − lo)·v/127; `exponential`: lo·(hi/lo)^(v/127), for a range of positive numbers",
            ),
            key_without_default(
                "port",
                Kind::Str,
                "any",
                "live input: a part of the input port's name to listen to",
            ),
        ]
    });
    &KEYS
}

/// Reads the `[[midi]]` tables (targets are resolved with the tracks').
pub(crate) fn read_mappings(src: &Sources, v: &Located) -> Result<Vec<MidiMapping>> {
    let items = crate::read::array_of_tables(src, v, "midi", false)?;
    let mut out = Vec::new();
    for (i, mv) in items.into_iter().enumerate() {
        let ctx = format!("midi.{i}");
        let mut r = Reader::new(src, mv, &ctx)?;
        let cc = r.get("cc").map(|_| ());
        let note = r.get("note").map(|_| ());
        let source = match (cc, note) {
            (Some(_), None) => Source::Cc(r.int("cc", 0, 0, 127)? as u8),
            (None, Some(_)) => Source::Note(r.int("note", 0, 0, 127)? as u8),
            (Some(_), Some(_)) => {
                return Err(src
                    .error(
                        mv.origin,
                        format!("`{ctx}` has both `cc` and `note`: a mapping listens to one controller"),
                        Some("keep one"),
                        &[],
                    )
                    .with_key(format!("{ctx}.note")))
            }
            (None, None) => {
                return Err(src
                    .error(
                        mv.origin,
                        format!("`{ctx}` needs a `cc` (a knob) or a `note` (a pad) to listen to"),
                        Some("add cc = 1"),
                        &[],
                    )
                    .with_key(format!("{ctx}.cc")))
            }
        };
        let channel = match r.get("channel") {
            Some(_) => Some(r.int("channel", 1, 1, 16)? as u8),
            None => None,
        };
        let Some((target, target_loc)) = r.string("target")? else {
            return Err(src
                .error(
                    mv.origin,
                    format!("`{ctx}` needs a `target`: the number it drives"),
                    Some("add target = \"params.k\""),
                    &[],
                )
                .with_key(format!("{ctx}.target")));
        };
        let range = match r.get("range") {
            None => [0.0, 1.0],
            Some(rv) => match &rv.item {
                Item::Array(xs) if xs.len() == 2 => match (&xs[0].item, &xs[1].item) {
                    (Item::Num(a, _), Item::Num(b, _)) if a.is_finite() && b.is_finite() => [*a, *b],
                    _ => return Err(r.err(rv, "range", "[lo, hi]: two numbers")),
                },
                _ => return Err(r.err(rv, "range", "[lo, hi]: two numbers")),
            },
        };
        let curve = match r.choice_key(crate::schema::spec(midi_keys(), "curve"))? {
            "exponential" => Curve::Exponential,
            _ => Curve::Linear,
        };
        if curve == Curve::Exponential && range[0] * range[1] <= 0.0 {
            let rv = r.get("range").unwrap_or(mv);
            return Err(r.err(
                rv,
                "range",
                "a range of two numbers of one sign, not 0, for the exponential curve",
            ));
        }
        let port = r.string("port")?.map(|(s, _)| s.to_string());
        r.finish_keys(midi_keys())?;
        out.push(MidiMapping {
            source,
            channel,
            target: target.to_string(),
            range,
            curve,
            port,
            origin: target_loc.origin,
            drive: Drive::Unresolved,
        });
    }
    Ok(out)
}

/// A MIDI file's channel messages that mappings hear (control changes,
/// notes), in time order, with times in seconds: ticks are converted
/// through the file's tempo changes (120 beats a minute until the first),
/// or by its SMPTE frame rate.
pub fn read_midi_file(path: &Path) -> std::result::Result<Vec<MidiEvent>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read `{}`: {e}", path.display()))?;
    parse_midi(&bytes).map_err(|e| format!("`{}`: {e}", path.display()))
}

/// [`read_midi_file`] of bytes.
pub fn parse_midi(bytes: &[u8]) -> std::result::Result<Vec<MidiEvent>, String> {
    use midly::{MetaMessage, MidiMessage, Timing, TrackEventKind};
    let smf = midly::Smf::parse(bytes).map_err(|e| format!("not a MIDI file: {e}"))?;
    // Every event with its absolute tick; tempo changes apply to all tracks.
    let mut tempos: Vec<(u64, u32)> = Vec::new();
    let mut events: Vec<(u64, usize, u8, Message)> = Vec::new();
    let mut order = 0usize;
    for track in &smf.tracks {
        let mut tick = 0u64;
        for ev in track {
            tick += u64::from(ev.delta.as_int());
            match ev.kind {
                TrackEventKind::Meta(MetaMessage::Tempo(t)) => tempos.push((tick, t.as_int())),
                TrackEventKind::Midi { channel, message } => {
                    let kind = match message {
                        MidiMessage::Controller { controller, value } => Message::Cc {
                            controller: controller.as_int(),
                            value: value.as_int(),
                        },
                        MidiMessage::NoteOn { key, vel } if vel.as_int() > 0 => Message::NoteOn {
                            key: key.as_int(),
                            velocity: vel.as_int(),
                        },
                        MidiMessage::NoteOn { key, .. } | MidiMessage::NoteOff { key, .. } => {
                            Message::NoteOff { key: key.as_int() }
                        }
                        _ => continue,
                    };
                    events.push((tick, order, channel.as_int() + 1, kind));
                    order += 1;
                }
                _ => {}
            }
        }
    }
    tempos.sort_by_key(|t| t.0);
    events.sort_by_key(|e| (e.0, e.1));
    let seconds = |tick: u64| -> f64 {
        match smf.header.timing {
            Timing::Metrical(tpb) => {
                let tpb = f64::from(tpb.as_int().max(1));
                let (mut at, mut us_per_beat, mut secs) = (0u64, 500_000.0, 0.0);
                for &(t, tempo) in tempos.iter().take_while(|(t, _)| *t <= tick) {
                    secs += (t - at) as f64 / tpb * us_per_beat * 1e-6;
                    at = t;
                    us_per_beat = f64::from(tempo);
                }
                secs + (tick - at) as f64 / tpb * us_per_beat * 1e-6
            }
            Timing::Timecode(fps, sub) => tick as f64 / (f64::from(fps.as_f32()) * f64::from(sub.max(1))),
        }
    };
    Ok(events
        .into_iter()
        .map(|(tick, _, channel, kind)| MidiEvent {
            time: seconds(tick),
            channel,
            kind,
        })
        .collect())
}

/// Ticks a second in the files [`write_midi_file`] writes (480 a beat at
/// 120 beats a minute).
pub const TICKS_PER_SECOND: f64 = 960.0;

/// Writes events as a one-track MIDI file (480 ticks a beat, 120 beats a
/// minute, so times are kept to 1/960 s), atomically.
pub fn write_midi_file(path: &Path, events: &[MidiEvent]) -> std::result::Result<(), String> {
    use midly::num::{u15, u24, u28, u4, u7};
    use midly::{Format, Header, MetaMessage, MidiMessage, Smf, Timing, TrackEvent, TrackEventKind};
    let mut sorted: Vec<&MidiEvent> = events.iter().collect();
    sorted.sort_by(|a, b| a.time.total_cmp(&b.time));
    let mut track = vec![TrackEvent {
        delta: u28::new(0),
        kind: TrackEventKind::Meta(MetaMessage::Tempo(u24::new(500_000))),
    }];
    let mut last = 0u64;
    for e in sorted {
        let tick = (e.time.max(0.0) * TICKS_PER_SECOND).round() as u64;
        let delta = u32::try_from(tick - last)
            .ok()
            .and_then(u28::try_from)
            .ok_or_else(|| format!("the event at {} s is too far from the one before", e.time))?;
        last = tick;
        let message = match e.kind {
            Message::Cc { controller, value } => MidiMessage::Controller {
                controller: u7::new(controller.min(127)),
                value: u7::new(value.min(127)),
            },
            Message::NoteOn { key, velocity } => MidiMessage::NoteOn {
                key: u7::new(key.min(127)),
                vel: u7::new(velocity.clamp(1, 127)),
            },
            Message::NoteOff { key } => MidiMessage::NoteOff {
                key: u7::new(key.min(127)),
                vel: u7::new(0),
            },
        };
        track.push(TrackEvent {
            delta,
            kind: TrackEventKind::Midi {
                channel: u4::new(e.channel.clamp(1, 16) - 1),
                message,
            },
        });
    }
    track.push(TrackEvent {
        delta: u28::new(0),
        kind: TrackEventKind::Meta(MetaMessage::EndOfTrack),
    });
    let smf = Smf {
        header: Header::new(Format::SingleTrack, Timing::Metrical(u15::new(480))),
        tracks: vec![track],
    };
    let mut bytes = Vec::new();
    smf.write_std(&mut bytes).map_err(|e| e.to_string())?;
    isoray_job::file::write_atomic(path, &bytes).map_err(|e| format!("cannot write `{}`: {e}", path.display()))
}

/// The step tracks a take of events gives the mappings: each mapping's
/// value is the last one its controller sent at or before the time, and
/// the scene's own value before the first.
pub(crate) fn take_tracks(mappings: &[MidiMapping], events: &[MidiEvent]) -> Vec<Track> {
    let mut out = Vec::new();
    for m in mappings {
        let mut keys: Vec<(f64, Vec<f64>)> = Vec::new();
        for e in events {
            let Some(v) = m.hears(e) else { continue };
            let value = vec![m.value(v)];
            match keys.last_mut() {
                // Events at one time: the last one counts.
                Some(k) if k.0 >= e.time => k.1 = value,
                _ => keys.push((e.time, value)),
            }
        }
        if keys.is_empty() {
            continue;
        }
        let mut t = Track::new(&m.target, keys, Interpolation::Step, false);
        t.hold_first = false;
        t.origin = m.origin;
        t.drive = m.drive.clone();
        t.label = format!("the MIDI take on {}", m.target);
        out.push(t);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cc(time: f64, channel: u8, controller: u8, value: u8) -> MidiEvent {
        MidiEvent {
            time,
            channel,
            kind: Message::Cc { controller, value },
        }
    }

    #[test]
    fn controller_values_map_into_the_range() {
        let m = MidiMapping::new(Source::Cc(1), None, "params.k", [0.5, 2.0], Curve::Linear);
        assert_eq!(m.value(0), 0.5);
        assert_eq!(m.value(127), 2.0);
        assert_eq!(m.value(64), 0.5 + 1.5 * 64.0 / 127.0);
        let e = MidiMapping::new(Source::Cc(1), None, "params.k", [0.5, 2.0], Curve::Exponential);
        assert!((e.value(127) - 2.0).abs() < 1e-12);
        assert!((e.value(0) - 0.5).abs() < 1e-12);
        // Equal turns multiply by equal factors: 0.5·4^(64/127), about 1.0055,
        // just past the geometric middle 1 at v = 63.5.
        assert!((e.value(64) - 0.5 * 4f64.powf(64.0 / 127.0)).abs() < 1e-12);
        assert!((e.value(64) / e.value(32) - e.value(32) / e.value(0)).abs() < 1e-12);
    }

    #[test]
    fn channels_and_controllers_filter_what_a_mapping_hears() {
        let mut m = MidiMapping::new(Source::Cc(7), Some(2), "params.k", [0.0, 1.0], Curve::Linear);
        assert_eq!(m.hears(&cc(0.0, 2, 7, 100)), Some(100));
        assert_eq!(m.hears(&cc(0.0, 3, 7, 100)), None);
        assert_eq!(m.hears(&cc(0.0, 2, 8, 100)), None);
        m.channel = None;
        assert_eq!(m.hears(&cc(0.0, 16, 7, 5)), Some(5));
        let pad = MidiMapping::new(Source::Note(36), None, "params.k", [0.0, 1.0], Curve::Linear);
        let on = MidiEvent {
            time: 0.0,
            channel: 10,
            kind: Message::NoteOn { key: 36, velocity: 90 },
        };
        let off = MidiEvent {
            kind: Message::NoteOff { key: 36 },
            ..on
        };
        assert_eq!(pad.hears(&on), Some(90));
        assert_eq!(pad.hears(&off), Some(0));
    }

    #[test]
    fn a_written_file_reads_back_with_its_times() {
        let dir = std::env::temp_dir().join(format!("isoray-midi-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("take.mid");
        let events: Vec<MidiEvent> = (0..20)
            .map(|i| cc(i as f64 * 0.125, 1 + (i % 3) as u8, 1, i as u8 * 6))
            .collect();
        write_midi_file(&path, &events).unwrap();
        let back = read_midi_file(&path).unwrap();
        assert_eq!(back, events);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn tempo_changes_stretch_time() {
        use midly::num::{u15, u24, u28, u4, u7};
        use midly::{Format, Header, MetaMessage, MidiMessage, Smf, Timing, TrackEvent, TrackEventKind};
        let ev = |delta: u32, kind| TrackEvent {
            delta: u28::new(delta),
            kind,
        };
        let knob = |v: u8| TrackEventKind::Midi {
            channel: u4::new(0),
            message: MidiMessage::Controller {
                controller: u7::new(1),
                value: u7::new(v),
            },
        };
        // 100 ticks a beat: a beat at 120 bpm (0.5 s), then at 60 bpm (1 s).
        let track = vec![
            ev(100, knob(1)),
            ev(0, TrackEventKind::Meta(MetaMessage::Tempo(u24::new(1_000_000)))),
            ev(100, knob(2)),
            ev(50, knob(3)),
            ev(0, TrackEventKind::Meta(MetaMessage::EndOfTrack)),
        ];
        let smf = Smf {
            header: Header::new(Format::SingleTrack, Timing::Metrical(u15::new(100))),
            tracks: vec![track],
        };
        let mut bytes = Vec::new();
        smf.write_std(&mut bytes).unwrap();
        let times: Vec<f64> = parse_midi(&bytes).unwrap().iter().map(|e| e.time).collect();
        assert_eq!(times, vec![0.5, 1.5, 2.0]);
    }

    #[test]
    fn a_take_becomes_a_step_track_that_leaves_the_value_alone_before_its_first_event() {
        let m = MidiMapping::new(Source::Cc(1), Some(1), "params.k", [0.0, 127.0], Curve::Linear);
        let events = [
            cc(0.5, 1, 1, 10),
            cc(0.5, 1, 1, 20),
            cc(1.0, 2, 1, 99),
            cc(1.5, 1, 1, 30),
        ];
        let t = &take_tracks(&[m], &events)[0];
        assert_eq!(t.sample(0.2), None);
        assert_eq!(t.sample(0.5), Some(vec![20.0]), "the last of simultaneous events");
        assert_eq!(t.sample(1.2), Some(vec![20.0]), "channel 2 is not heard");
        assert_eq!(t.sample(9.0), Some(vec![30.0]));
    }
}
