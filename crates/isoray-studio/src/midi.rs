//! Live MIDI in the studio: messages from an input port (midir, with the
//! `midi` cargo feature, on by default; it needs ALSA's development files
//! on Linux) drive the scene's `[[midi]]` mappings in the preview; MIDI
//! learn remembers the last control moved so that clicking a slider maps
//! it; recording keeps every message with its time and writes a take (a
//! `.mid` file that `isoray render --midi` replays to the same values).
//!
//! Messages reach [`MidiLive`] through a channel, from the port's thread or
//! from [`MidiLive::sender`] (tests, other sources), and are handled on
//! the UI thread by [`MidiLive::poll`].
//!
//! ```
//! use isoray_scene::midi::Message;
//! use isoray_studio::midi::parse_message;
//! // Control change 21, value 64, on channel 2 (status 0xB1).
//! assert_eq!(parse_message(&[0xB1, 21, 64]), Some((2, Message::Cc { controller: 21, value: 64 })));
//! // A note-on of velocity 0 is a note-off.
//! assert_eq!(parse_message(&[0x90, 60, 0]), Some((1, Message::NoteOff { key: 60 })));
//! ```

use std::path::Path;
use std::sync::mpsc;
use std::time::Instant;

use isoray_scene::midi::{Message, MidiEvent, Source};
use isoray_scene::Scene;

/// A raw MIDI message as bytes, with the time it arrived.
pub type Raw = (Instant, Vec<u8>);

/// The channel (1–16) and message of raw MIDI bytes, for the messages
/// mappings hear (control changes, notes); None for any other.
pub fn parse_message(bytes: &[u8]) -> Option<(u8, Message)> {
    let (&status, data) = bytes.split_first()?;
    let channel = (status & 0x0F) + 1;
    let (a, b) = (*data.first()? & 0x7F, data.get(1).map(|x| x & 0x7F));
    let message = match status & 0xF0 {
        0xB0 => Message::Cc {
            controller: a,
            value: b?,
        },
        0x90 if b? == 0 => Message::NoteOff { key: a },
        0x90 => Message::NoteOn { key: a, velocity: b? },
        0x80 => Message::NoteOff { key: a },
        _ => return None,
    };
    Some((channel, message))
}

/// The control a message comes from (what a mapping would listen to).
pub fn source_of(message: &Message) -> Source {
    match *message {
        Message::Cc { controller, .. } => Source::Cc(controller),
        Message::NoteOn { key, .. } | Message::NoteOff { key } => Source::Note(key),
    }
}

/// The live MIDI state of a studio window.
pub struct MidiLive {
    tx: mpsc::Sender<Raw>,
    rx: mpsc::Receiver<Raw>,
    #[cfg(feature = "midi")]
    connection: Option<midir::MidiInputConnection<()>>,
    /// The port connected, if any.
    port: Option<String>,
    /// MIDI learn: waiting for a control to move (then for a click).
    learning: bool,
    /// The control heard last while learning: channel 1–16 and source.
    heard: Option<(u8, Source)>,
    /// A take being recorded: its start and the events so far.
    recording: Option<(Instant, Vec<MidiEvent>)>,
    /// The last controller value each mapping received (mapping, value).
    values: Vec<(usize, u8)>,
}

impl Default for MidiLive {
    fn default() -> Self {
        let (tx, rx) = mpsc::channel();
        MidiLive {
            tx,
            rx,
            #[cfg(feature = "midi")]
            connection: None,
            port: None,
            learning: false,
            heard: None,
            recording: None,
            values: Vec::new(),
        }
    }
}

impl std::fmt::Debug for MidiLive {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MidiLive")
            .field("port", &self.port)
            .field("learning", &self.learning)
            .field("heard", &self.heard)
            .field("recording", &self.recording.as_ref().map(|r| r.1.len()))
            .field("values", &self.values)
            .finish()
    }
}

impl MidiLive {
    /// A sender of raw messages, as a port would send them.
    pub fn sender(&self) -> mpsc::Sender<Raw> {
        self.tx.clone()
    }

    /// The port connected, if any.
    pub fn port(&self) -> Option<&str> {
        self.port.as_deref()
    }

    /// Connects to the first input port whose name contains `wanted` (the
    /// first port when None). Returns the port's name.
    ///
    /// # Errors
    /// No MIDI system, no such port, or a build without the `midi` feature.
    pub fn connect(&mut self, wanted: Option<&str>) -> Result<String, String> {
        #[cfg(feature = "midi")]
        {
            let input = midir::MidiInput::new("isoray studio").map_err(|e| format!("no MIDI input: {e}"))?;
            let ports = input.ports();
            let named: Vec<(midir::MidiInputPort, String)> = ports
                .into_iter()
                .filter_map(|p| input.port_name(&p).ok().map(|n| (p, n)))
                .collect();
            if named.is_empty() {
                return Err("no MIDI input ports (connect a controller, or start a virtual one)".into());
            }
            let Some((port, name)) = named.into_iter().find(|(_, n)| wanted.is_none_or(|w| n.contains(w))) else {
                return Err(format!("no MIDI input port named like \"{}\"", wanted.unwrap_or("")));
            };
            let tx = self.tx.clone();
            let conn = input
                .connect(
                    &port,
                    "isoray studio input",
                    move |_, bytes, _| {
                        let _ = tx.send((Instant::now(), bytes.to_vec()));
                    },
                    (),
                )
                .map_err(|e| format!("cannot connect to \"{name}\": {e}"))?;
            self.connection = Some(conn);
            self.port = Some(name.clone());
            Ok(name)
        }
        #[cfg(not(feature = "midi"))]
        {
            let _ = wanted;
            Err("this studio was built without the `midi` feature (cargo build --features midi)".into())
        }
    }

    /// Starts or stops MIDI learn.
    pub fn set_learning(&mut self, on: bool) {
        self.learning = on;
        self.heard = None;
    }

    /// True while MIDI learn is on.
    pub fn learning(&self) -> bool {
        self.learning
    }

    /// The control heard while learning (channel 1–16, source), waiting
    /// for the click on what it should drive.
    pub fn heard(&self) -> Option<(u8, Source)> {
        self.heard.filter(|_| self.learning)
    }

    /// Starts recording a take (dropping one in progress).
    pub fn start_recording(&mut self) {
        self.recording = Some((Instant::now(), Vec::new()));
    }

    /// True while recording.
    pub fn recording(&self) -> bool {
        self.recording.is_some()
    }

    /// Stops recording and writes the take to `path` (a standard MIDI
    /// file: `isoray render --midi` replays it). Returns the events written.
    ///
    /// # Errors
    /// Not recording, or the file could not be written (an existing file
    /// is then left as it was).
    pub fn stop_recording(&mut self, path: &Path) -> Result<usize, String> {
        let (_, events) = self.recording.take().ok_or("not recording")?;
        isoray_scene::midi::write_midi_file(path, &events)?;
        Ok(events.len())
    }

    /// The last controller value of each mapping that received one.
    pub fn values(&self) -> &[(usize, u8)] {
        &self.values
    }

    /// Handles the messages that arrived: learn, recording, and the values
    /// of `scene`'s mappings. Returns true when a mapping's value changed
    /// (the preview should follow).
    pub fn poll(&mut self, scene: &Scene) -> bool {
        let mut changed = false;
        while let Ok((at, bytes)) = self.rx.try_recv() {
            let Some((channel, kind)) = parse_message(&bytes) else {
                continue;
            };
            if self.learning {
                self.heard = Some((channel, source_of(&kind)));
            }
            if let Some((start, events)) = &mut self.recording {
                events.push(MidiEvent {
                    time: at.saturating_duration_since(*start).as_secs_f64(),
                    channel,
                    kind,
                });
            }
            let event = MidiEvent {
                time: 0.0,
                channel,
                kind,
            };
            for (i, m) in scene.midi.iter().enumerate() {
                if let Some(v) = m.hears(&event) {
                    match self.values.iter_mut().find(|(k, _)| *k == i) {
                        Some(slot) => slot.1 = v,
                        None => self.values.push((i, v)),
                    }
                    changed = true;
                }
            }
        }
        changed
    }

    /// Applies the live values to a scene (the preview's).
    pub fn apply(&self, scene: &mut Scene) {
        for &(i, v) in &self.values {
            let _ = scene.set_midi_value(i, v);
        }
    }

    /// Forgets the live values (the scene's mappings changed).
    pub fn clear_values(&mut self) {
        self.values.clear();
    }
}

/// The `[[midi]]` table MIDI learn writes: `source` on `channel` driving
/// `target` over `range`, as (key, TOML value) entries for
/// `Document::push_table`.
pub fn learned_table(channel: u8, source: Source, target: &str, range: [f64; 2]) -> Vec<(&'static str, String)> {
    let n = crate::curves::number_text;
    let mut out = match source {
        Source::Cc(c) => vec![("cc", c.to_string())],
        Source::Note(k) => vec![("note", k.to_string())],
    };
    out.push(("channel", channel.to_string()));
    out.push(("target", format!("\"{target}\"")));
    out.push(("range", format!("[{}, {}]", n(range[0]), n(range[1]))));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recorded_take_replays_to_the_live_values() {
        let scene = isoray_scene::load_str(
            "[params]\nk = { default = 1.0, range = [0.5, 2.0] }\n\
             [[midi]]\ncc = 7\ntarget = \"params.k\"\nrange = [0.5, 2.0]\n\
             [[object]]\nshape = \"sphere(p, k)\"\n",
            "m.toml",
            &[],
        )
        .unwrap();
        let mut live = MidiLive::default();
        live.start_recording();
        let tx = live.sender();
        let t0 = Instant::now();
        let ramp = [0u8, 40, 90, 127];
        let mut seen = Vec::new();
        for (i, &v) in ramp.iter().enumerate() {
            let at = t0 + std::time::Duration::from_millis(100 * i as u64 + 10);
            tx.send((at, vec![0xB0, 7, v])).unwrap();
            tx.send((at, vec![0xF8])).unwrap(); // a clock tick: ignored
            assert!(live.poll(&scene));
            let mut s = scene.clone();
            live.apply(&mut s);
            seen.push(s.params[0].1);
        }
        let path = std::env::temp_dir().join(format!("isoray-take-{}.mid", std::process::id()));
        assert_eq!(live.stop_recording(&path).unwrap(), 4);
        let events = isoray_scene::midi::read_midi_file(&path).unwrap();
        assert_eq!(events.len(), 4);
        let mut replay = scene.clone();
        replay.play_midi(&events).unwrap();
        for (e, want) in events.iter().zip(&seen) {
            // Just after each event, the take gives what the live value gave.
            replay.set_time(e.time + 1e-3).unwrap();
            assert_eq!(&replay.params[0].1, want);
        }
        let _ = std::fs::remove_file(path);
    }

    #[test]
    fn learn_hears_the_last_control_and_writes_its_table() {
        let scene = isoray_scene::load_str("[[object]]\nshape = \"sphere(p, 1.0)\"\n", "s.toml", &[]).unwrap();
        let mut live = MidiLive::default();
        live.sender().send((Instant::now(), vec![0xB3, 74, 10])).unwrap();
        live.poll(&scene);
        assert_eq!(live.heard(), None, "not learning");
        live.set_learning(true);
        live.sender().send((Instant::now(), vec![0xB3, 74, 10])).unwrap();
        live.sender().send((Instant::now(), vec![0x92, 36, 100])).unwrap();
        live.poll(&scene);
        assert_eq!(live.heard(), Some((3, Source::Note(36))), "the last one heard");
        let table = learned_table(4, Source::Cc(74), "light.0.intensity", [0.0, 2.5]);
        let text = table.iter().map(|(k, v)| format!("{k} = {v}\n")).collect::<String>();
        assert_eq!(
            text,
            "cc = 74\nchannel = 4\ntarget = \"light.0.intensity\"\nrange = [0.0, 2.5]\n"
        );
    }
}
