//! The studio's MIDI menu and MIDI learn: connect an input port, learn a
//! mapping (move a control, then click the slider it should drive: a
//! `[[midi]]` table is added as one undo step), and record a take to a
//! `.mid` file beside the scene. Live values move the preview through
//! `Scene::set_midi_value` (runtime inputs: nothing is compiled).

use eframe::egui;
use isoray_scene::midi::Source;

use super::Studio;

impl Studio {
    /// The live MIDI state (for tests: its sender stands in for a port).
    pub fn midi(&self) -> &crate::midi::MidiLive {
        &self.midi
    }

    /// The last MIDI take the studio wrote.
    pub fn last_take(&self) -> Option<&std::path::Path> {
        self.last_take.as_deref()
    }

    /// The MIDI menu.
    pub(super) fn midi_menu(&mut self, ui: &mut egui::Ui) {
        ui.menu_button("MIDI", |ui| {
            let connect = match self.midi.port() {
                Some(p) => format!("Connected: {p}"),
                None => "Connect MIDI input".into(),
            };
            if ui.button(connect).clicked() {
                self.status = match self.midi.connect(None) {
                    Ok(name) => format!("MIDI input: {name}"),
                    Err(e) => format!("MIDI: {e}"),
                };
            }
            let mut learning = self.midi.learning();
            if ui
                .checkbox(&mut learning, "MIDI learn")
                .on_hover_text("move a knob or press a pad, then click the slider it should drive")
                .changed()
            {
                self.midi.set_learning(learning);
            }
            let record = if self.midi.recording() {
                "Stop recording"
            } else {
                "Record take"
            };
            if ui.button(record).clicked() {
                self.toggle_recording();
            }
        });
    }

    /// Starts a take, or stops it and writes it beside the scene as
    /// `STEM-take-N.mid` (the first N free).
    fn toggle_recording(&mut self) {
        if !self.midi.recording() {
            self.midi.start_recording();
            self.status = "recording a MIDI take…".into();
            return;
        }
        let (dir, stem) = match self.doc.path() {
            Some(p) => (
                p.parent().map(std::path::Path::to_path_buf).unwrap_or_default(),
                p.file_stem()
                    .map_or("scene".into(), |s| s.to_string_lossy().into_owned()),
            ),
            None => (std::path::PathBuf::from("."), "scene".to_string()),
        };
        let path = (1..)
            .map(|n| dir.join(format!("{stem}-take-{n}.mid")))
            .find(|p| !p.exists())
            .expect("a free name");
        self.status = match self.midi.stop_recording(&path) {
            Ok(n) => format!(
                "wrote {n} MIDI events to {} (isoray render SCENE --midi {} --frames 0..)",
                path.display(),
                path.display()
            ),
            Err(e) => format!("MIDI take not written: {e}"),
        };
        self.last_take = Some(path);
    }

    /// Reads the messages that arrived; the preview follows live values.
    pub(super) fn poll_midi(&mut self, ctx: &egui::Context) {
        if self.midi.poll(self.doc.scene()) {
            self.request_preview();
        }
        if self.midi.port().is_some() || self.midi.recording() || self.midi.learning() {
            ctx.request_repaint_after(std::time::Duration::from_millis(30));
        }
    }

    /// With a control heard in MIDI learn, a click on the slider of `key`
    /// maps it there over `range` (one edit). True when it did.
    pub(super) fn learn_on(&mut self, r: &egui::Response, key: &str, range: [f64; 2]) -> bool {
        // The press that learned is not a change of the value: the slider
        // is left alone until the button is let go.
        if self.learn_hold.as_deref() == Some(key) {
            if r.drag_stopped() || !(r.dragged() || r.is_pointer_button_down_on()) {
                self.learn_hold = None;
            }
            return true;
        }
        let Some((channel, source)) = self.midi.heard() else {
            return false;
        };
        if !(r.clicked() || r.drag_started()) {
            return false;
        }
        let entries = crate::midi::learned_table(channel, source, key, range);
        let entries: Vec<(&str, &str)> = entries.iter().map(|(k, v)| (*k, v.as_str())).collect();
        let result = self.doc.push_table("midi", &entries);
        let ok = result.is_ok();
        self.done(result);
        if ok {
            let what = match source {
                Source::Cc(c) => format!("CC {c}"),
                Source::Note(n) => format!("note {n}"),
            };
            self.status = format!("MIDI learn: {what} on channel {channel} drives {key}");
        }
        self.midi.set_learning(false);
        self.live = None;
        self.learn_hold = Some(key.to_string());
        true
    }

    /// The status bar's MIDI part.
    pub(super) fn midi_status(&self, ui: &mut egui::Ui) {
        if self.midi.learning() {
            let text = match self.midi.heard() {
                None => "MIDI learn: move a control…".to_string(),
                Some((ch, Source::Cc(c))) => format!("MIDI learn: CC {c} (channel {ch}), click a slider"),
                Some((ch, Source::Note(n))) => format!("MIDI learn: note {n} (channel {ch}), click a slider"),
            };
            ui.colored_label(egui::Color32::from_rgb(0xe0, 0xb0, 0x40), text);
        }
        if self.midi.recording() {
            ui.colored_label(egui::Color32::from_rgb(0xe0, 0x50, 0x50), "● recording MIDI");
        }
    }
}
