//! The timeline: for a scene with an `[animation]`, a strip under the
//! preview with play and pause, frame steps, a time slider to scrub, and a
//! row per track with its keys marked at their times (click one to go
//! there). The time is the preview's, not the file's: the preview's scene
//! is moved to it with `Scene::set_time`, so playing and scrubbing compile
//! nothing and change no byte of the file. While playing or scrubbing the
//! preview draws reduced frames, as for any drag.

use eframe::egui;

use super::Studio;

/// The timeline's state.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Timeline {
    /// The preview's time, seconds.
    pub time: f64,
    /// Playing: the time follows the clock, looping at the duration.
    pub playing: bool,
    /// The time slider is being dragged.
    pub scrubbing: bool,
}

impl Studio {
    /// The timeline's state (for tests).
    pub fn timeline(&self) -> Timeline {
        self.timeline
    }

    /// Moves the preview to time `t` (seconds).
    fn go_to(&mut self, t: f64) {
        if t.to_bits() != self.timeline.time.to_bits() {
            self.timeline.time = t;
            self.request_preview();
        }
    }

    /// The timeline panel, when the scene has an `[animation]`.
    pub(super) fn timeline_panel(&mut self, ui: &mut egui::Ui) {
        let scene = self.doc.scene();
        let Some(anim) = scene.animation else {
            self.timeline = Timeline::default();
            return;
        };
        let tracks: Vec<(String, Vec<f64>)> = scene
            .tracks
            .iter()
            .map(|t| (t.target.clone(), t.keys.iter().map(|k| k.0).collect()))
            .collect();
        let (fps, duration) = (anim.fps, anim.duration);
        let last = anim.frame_count() - 1;
        let frame = ((self.timeline.time * fps + 1e-9).floor() as u64).min(last);
        if self.timeline.playing {
            let dt = ui.input(|i| f64::from(i.stable_dt)).clamp(0.0, 0.1);
            let next = (self.timeline.time + dt) % duration;
            self.go_to(next);
            ui.ctx().request_repaint();
        }
        ui.horizontal(|ui| {
            let label = if self.timeline.playing { "Pause" } else { "Play" };
            if ui.button(label).clicked() {
                self.timeline.playing = !self.timeline.playing;
                self.request_preview();
            }
            if ui.button("Start").on_hover_text("go to frame 0").clicked() {
                self.timeline.playing = false;
                self.go_to(0.0);
            }
            if ui.button("Previous frame").clicked() {
                self.timeline.playing = false;
                self.go_to(anim.time_of(frame.saturating_sub(1)));
            }
            if ui.button("Next frame").clicked() {
                self.timeline.playing = false;
                self.go_to(anim.time_of((frame + 1).min(last)));
            }
            let mut t = self.timeline.time;
            ui.spacing_mut().slider_width = (ui.available_width() - 260.0).clamp(120.0, 600.0);
            let slider = ui.add(
                // No rounding of the value (a rounded time would read as
                // the user's change and stop playback).
                egui::Slider::new(&mut t, 0.0..=duration).text("time").suffix(" s"),
            );
            let scrubbing = slider.dragged();
            if scrubbing != self.timeline.scrubbing {
                self.timeline.scrubbing = scrubbing;
                // The full frame once the slider is let go.
                self.request_preview();
            }
            if slider.changed() && t.to_bits() != self.timeline.time.to_bits() {
                self.timeline.playing = false;
                self.go_to(t);
            }
            ui.label(format!("frame {frame} of 0..{last} at {fps} fps"));
        });
        // One row per track: its target and its keys on a strip.
        egui::ScrollArea::vertical()
            .max_height(112.0)
            .show(ui, |ui| self.track_rows(ui, &tracks, duration));
    }

    /// The tracks' rows: each target and its keys on a strip (click a key
    /// to go to its time).
    fn track_rows(&mut self, ui: &mut egui::Ui, tracks: &[(String, Vec<f64>)], duration: f64) {
        for (target, times) in tracks {
            ui.horizontal(|ui| {
                ui.add_sized(
                    [160.0, 16.0],
                    egui::Label::new(egui::RichText::new(target).monospace()).truncate(),
                );
                let (rect, _) = ui.allocate_exact_size(egui::vec2(ui.available_width(), 16.0), egui::Sense::hover());
                let painter = ui.painter_at(rect);
                painter.rect_filled(rect, 2.0, ui.visuals().extreme_bg_color);
                let x_of = |t: f64| rect.left() + rect.width() * (t / duration).clamp(0.0, 1.0) as f32;
                let now = x_of(self.timeline.time);
                painter.line_segment(
                    [egui::pos2(now, rect.top()), egui::pos2(now, rect.bottom())],
                    egui::Stroke::new(1.0, ui.visuals().selection.stroke.color),
                );
                for (k, &kt) in times.iter().enumerate() {
                    let c = egui::pos2(x_of(kt), rect.center().y);
                    let hit = egui::Rect::from_center_size(c, egui::vec2(10.0, 14.0));
                    let id = ui.id().with((target.as_str(), k));
                    let r = ui.interact(hit, id, egui::Sense::click());
                    let r = r.on_hover_text(format!("{target}: key at t = {kt} s (click to go there)"));
                    r.widget_info(|| {
                        egui::WidgetInfo::labeled(egui::WidgetType::Button, true, format!("{target} key {k}"))
                    });
                    let color = if r.hovered() {
                        ui.visuals().strong_text_color()
                    } else {
                        ui.visuals().text_color()
                    };
                    painter.add(egui::Shape::convex_polygon(
                        vec![
                            c + egui::vec2(0.0, -5.0),
                            c + egui::vec2(4.0, 0.0),
                            c + egui::vec2(0.0, 5.0),
                            c + egui::vec2(-4.0, 0.0),
                        ],
                        color,
                        egui::Stroke::NONE,
                    ));
                    if r.clicked() {
                        self.timeline.playing = false;
                        self.go_to(kt);
                    }
                }
            });
        }
    }
}
