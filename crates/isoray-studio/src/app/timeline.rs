//! The timeline: for a scene with an `[animation]`, a strip under the
//! preview with play and pause, frame steps, a time slider to scrub, and a
//! row per track with its keys marked at their times (click one to go
//! there). The time is the preview's, not the file's: the preview's scene
//! is moved to it with `Scene::set_time`, so playing and scrubbing compile
//! nothing and change no byte of the file. While playing or scrubbing the
//! preview draws reduced frames, as for any drag.
//!
//! Click a track's name to open its curves: each component's value over
//! time, with its keys as handles. Drag a key to move it in time and
//! value; double-click the curves to add a key on them; right-click a key
//! to delete it. Each of these writes the track's `keys` as one edit (one
//! undo step). Tracks from a glTF file are shown but not edited.

use crate::curves;
use eframe::egui;

use super::Studio;

/// A key being dragged in the curve editor.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveDrag {
    /// The track (index in the scene and in the file).
    pub track: usize,
    /// The key and the component dragged.
    pub key: usize,
    component: usize,
    /// The keys before the drag and with it.
    original: Vec<(f64, Vec<f64>)>,
    keys: Vec<(f64, Vec<f64>)>,
    /// The value range shown when the drag started (held while dragging).
    range: [f64; 2],
}

/// The timeline's state.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Timeline {
    /// The preview's time, seconds.
    pub time: f64,
    /// Playing: the time follows the clock, looping at the duration.
    pub playing: bool,
    /// The time slider is being dragged.
    pub scrubbing: bool,
    /// The track whose curves are open (index in the scene's tracks).
    pub selected: Option<usize>,
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
        if let Some(index) = self.timeline.selected {
            self.curve_editor(ui, index, duration);
        }
    }

    /// The curves of track `index`: each component over time, keys as
    /// handles to drag, double-click to add a key, right-click to delete.
    fn curve_editor(&mut self, ui: &mut egui::Ui, index: usize, duration: f64) {
        let scene = self.doc.scene();
        let Some(track) = scene.tracks.get(index).cloned() else {
            self.timeline.selected = None;
            return;
        };
        // Only the file's [[track]] tables are edited (not a glTF's).
        let editable = matches!(
            scene.origin_of(&format!("track.{index}.keys")),
            Some(isoray_scene::doc::Origin::File(_))
        );
        let drag = self.curve_drag.clone().filter(|d| d.track == index);
        let mut shown = track.clone();
        if let Some(d) = &drag {
            shown.keys = d.keys.clone();
        }
        let range = drag
            .as_ref()
            .map_or_else(|| curves::value_range(&shown, duration), |d| d.range);
        let width = track.width();
        let colours = [
            egui::Color32::from_rgb(0xe0, 0x60, 0x50),
            egui::Color32::from_rgb(0x60, 0xc0, 0x60),
            egui::Color32::from_rgb(0x60, 0x90, 0xe0),
            egui::Color32::from_rgb(0xd0, 0xb0, 0x50),
        ];
        let text_colour = ui.visuals().text_color();
        let colour = move |c: usize| if width == 1 { text_colour } else { colours[c % 4] };
        let names = ["x", "y", "z", "w"];
        ui.horizontal(|ui| {
            ui.label(egui::RichText::new(&track.target).monospace().strong());
            if width > 1 {
                for (c, name) in names.iter().enumerate().take(width) {
                    ui.colored_label(colour(c), *name);
                }
            }
            if editable {
                ui.weak("drag a key to move it · double-click to add one · right-click a key to delete it");
            } else {
                ui.weak("from a glTF file: shown, not edited");
            }
        });
        let (rect, area) = ui.allocate_exact_size(egui::vec2(ui.available_width(), 140.0), egui::Sense::click());
        area.widget_info(|| {
            egui::WidgetInfo::labeled(egui::WidgetType::Other, true, format!("{} curves", track.target))
        });
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 2.0, ui.visuals().extreme_bg_color);
        let inner = rect.shrink2(egui::vec2(6.0, 8.0));
        let x_of = |t: f64| inner.left() + inner.width() * (t / duration) as f32;
        let t_of = |x: f32| ((x - inner.left()) / inner.width()) as f64 * duration;
        let y_of = |v: f64| inner.bottom() - inner.height() * ((v - range[0]) / (range[1] - range[0])) as f32;
        let v_of = |y: f32| range[0] + ((inner.bottom() - y) / inner.height()) as f64 * (range[1] - range[0]);
        // Zero, if in view, and the time cursor.
        if range[0] < 0.0 && range[1] > 0.0 {
            let y = y_of(0.0);
            painter.line_segment(
                [egui::pos2(rect.left(), y), egui::pos2(rect.right(), y)],
                egui::Stroke::new(1.0, ui.visuals().weak_text_color()),
            );
        }
        let now = x_of(self.timeline.time);
        painter.line_segment(
            [egui::pos2(now, rect.top()), egui::pos2(now, rect.bottom())],
            egui::Stroke::new(1.0, ui.visuals().selection.stroke.color),
        );
        let samples: Vec<(f64, Vec<f64>)> = (0..=200)
            .filter_map(|i| {
                let t = duration * i as f64 / 200.0;
                shown.sample(t).map(|v| (t, v))
            })
            .collect();
        for c in 0..width {
            let points: Vec<egui::Pos2> = samples
                .iter()
                .filter_map(|(t, v)| v.get(c).map(|&x| egui::pos2(x_of(*t), y_of(x))))
                .collect();
            painter.add(egui::Shape::line(points, egui::Stroke::new(1.5, colour(c))));
        }
        let mut on_key = false;
        for (k, (kt, kv)) in shown.keys.iter().enumerate() {
            for (c, &x) in kv.iter().enumerate() {
                let centre = egui::pos2(x_of(*kt), y_of(x));
                let hit = egui::Rect::from_center_size(centre, egui::vec2(12.0, 12.0));
                let id = ui.id().with(("curve key", index, k, c));
                let r = ui.interact(hit, id, egui::Sense::click_and_drag());
                let label = if width == 1 {
                    format!("{} curve key {k}", track.target)
                } else {
                    format!("{} curve key {k} {}", track.target, names[c % 4])
                };
                let r = r.on_hover_text(format!("{label}: t = {kt} s, value {x}"));
                r.widget_info(|| egui::WidgetInfo::labeled(egui::WidgetType::Button, true, &label));
                on_key |= r.hovered() || r.dragged();
                let radius = if r.hovered() || r.dragged() { 5.0 } else { 3.5 };
                painter.circle_filled(centre, radius, colour(c));
                if !editable {
                    continue;
                }
                if r.drag_started() {
                    self.curve_drag = Some(CurveDrag {
                        track: index,
                        key: k,
                        component: c,
                        original: track.keys.clone(),
                        keys: track.keys.clone(),
                        range,
                    });
                }
                if r.dragged() {
                    if let (Some(d), Some(p)) = (self.curve_drag.as_mut(), r.interact_pointer_pos()) {
                        d.keys = curves::move_key(&d.original, d.key, t_of(p.x), d.component, v_of(p.y));
                        ui.ctx().request_repaint();
                    }
                }
                if r.drag_stopped() {
                    if let Some(d) = self.curve_drag.take() {
                        if d.keys != d.original {
                            self.edit(vec![curves::keys_edit(index, &d.keys)]);
                        }
                    }
                }
                if r.secondary_clicked() {
                    match curves::delete_key(&track.keys, k) {
                        Some(keys) => self.edit(vec![curves::keys_edit(index, &keys)]),
                        None => self.status = "a track keeps at least one key".into(),
                    }
                }
            }
        }
        if editable && area.double_clicked() && !on_key {
            if let Some(p) = area.interact_pointer_pos() {
                let t = t_of(p.x).clamp(0.0, duration);
                // The component whose curve passes nearest the click.
                let here = shown.sample(t).unwrap_or_default();
                let c = (0..here.len())
                    .min_by(|&a, &b| (y_of(here[a]) - p.y).abs().total_cmp(&(y_of(here[b]) - p.y).abs()))
                    .unwrap_or(0);
                match curves::add_key(&track, t, Some((c, v_of(p.y)))) {
                    Some(keys) => self.edit(vec![curves::keys_edit(index, &keys)]),
                    None => self.status = "a key is already there".into(),
                }
            }
        }
    }

    /// The tracks' rows: each target and its keys on a strip (click a key
    /// to go to its time).
    fn track_rows(&mut self, ui: &mut egui::Ui, tracks: &[(String, Vec<f64>)], duration: f64) {
        for (index, (target, times)) in tracks.iter().enumerate() {
            ui.horizontal(|ui| {
                let open = self.timeline.selected == Some(index);
                let name = ui
                    .add_sized(
                        [160.0, 16.0],
                        egui::Button::selectable(open, egui::RichText::new(target).monospace()).truncate(),
                    )
                    .on_hover_text("show or hide the curves");
                name.widget_info(|| {
                    egui::WidgetInfo::labeled(egui::WidgetType::Button, true, format!("{target} track"))
                });
                if name.clicked() {
                    self.timeline.selected = if open { None } else { Some(index) };
                }
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
