//! Editing a track's keys as curves: moving a key in time and value,
//! adding one on the curve, deleting one, and the `keys = […]` text each
//! edit writes (one undo step each). The timeline's curve editor calls
//! these; they know nothing of egui.
//!
//! ```
//! use isoray_studio::curves::{keys_text, move_key};
//! let keys = vec![(0.0, vec![0.4]), (0.5, vec![0.9]), (1.0, vec![0.5])];
//! // Key 1 dragged to t = 0.6, value 1.0: it stays between its neighbours.
//! let moved = move_key(&keys, 1, 0.6, 0, 1.0);
//! assert_eq!(keys_text(&moved), "[[0.0, 0.4], [0.6, 1.0], [1.0, 0.5]]");
//! // Dragged past the next key, it stops just before it.
//! let moved = move_key(&keys, 1, 2.0, 0, 0.9);
//! assert!(moved[1].0 < 1.0 && moved[1].0 > 0.99);
//! ```

use isoray_scene::Track;

/// The smallest gap kept between the times of neighbouring keys, seconds.
pub const MIN_GAP: f64 = 1e-3;

/// A number as the curve editor writes it: rounded to 6 decimals, with a
/// decimal point (`0.0`, `1.25`).
pub fn number_text(x: f64) -> String {
    let r = (x * 1e6).round() / 1e6;
    let r = if r == 0.0 { 0.0 } else { r }; // no "-0.0"
    let s = format!("{r}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// The TOML array of `keys`: `[[t, v], …]`, a vector value as `[x, y, z]`.
pub fn keys_text(keys: &[(f64, Vec<f64>)]) -> String {
    let items: Vec<String> = keys
        .iter()
        .map(|(t, v)| {
            let value = match v.as_slice() {
                [x] => number_text(*x),
                v => format!("[{}]", v.iter().map(|x| number_text(*x)).collect::<Vec<_>>().join(", ")),
            };
            format!("[{}, {value}]", number_text(*t))
        })
        .collect();
    format!("[{}]", items.join(", "))
}

/// The edit that writes `keys` to the file's track `index`.
pub fn keys_edit(index: usize, keys: &[(f64, Vec<f64>)]) -> String {
    format!("track.{index}.keys={}", keys_text(keys))
}

/// `keys` with key `k` moved to `time` (kept [`MIN_GAP`] inside its
/// neighbours, so times stay increasing) and its component `component`
/// set to `value`.
pub fn move_key(keys: &[(f64, Vec<f64>)], k: usize, time: f64, component: usize, value: f64) -> Vec<(f64, Vec<f64>)> {
    let mut out = keys.to_vec();
    // The first key does not go below 0 (or where it already is).
    let lo = if k > 0 {
        keys[k - 1].0 + MIN_GAP
    } else {
        keys[0].0.min(0.0)
    };
    let hi = keys.get(k + 1).map_or(f64::INFINITY, |n| n.0 - MIN_GAP);
    out[k].0 = if lo <= hi { time.clamp(lo, hi) } else { keys[k].0 };
    if let Some(c) = out[k].1.get_mut(component) {
        *c = value;
    }
    out
}

/// The track's keys with one more at `time`, on the curve (the track's
/// value there), its component `component` set to `value` when given.
/// None when a key is already within [`MIN_GAP`] of `time`.
pub fn add_key(track: &Track, time: f64, set: Option<(usize, f64)>) -> Option<Vec<(f64, Vec<f64>)>> {
    if track.keys.iter().any(|(t, _)| (t - time).abs() < MIN_GAP) {
        return None;
    }
    let mut value = track.sample(time)?;
    if let Some((c, v)) = set {
        if let Some(x) = value.get_mut(c) {
            *x = v;
        }
    }
    let mut out = track.keys.clone();
    let at = out.partition_point(|(t, _)| *t < time);
    out.insert(at, (time, value));
    Some(out)
}

/// `keys` without key `k`; None when it is the only one (a track needs one).
pub fn delete_key(keys: &[(f64, Vec<f64>)], k: usize) -> Option<Vec<(f64, Vec<f64>)>> {
    if keys.len() < 2 || k >= keys.len() {
        return None;
    }
    let mut out = keys.to_vec();
    out.remove(k);
    Some(out)
}

/// The range of values the editor shows for `keys` (every component, and
/// the curve between them sampled by `track`), padded by a tenth.
pub fn value_range(track: &Track, duration: f64) -> [f64; 2] {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    let mut see = |v: &[f64]| {
        for &x in v {
            if x.is_finite() {
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
    };
    for (_, v) in &track.keys {
        see(v);
    }
    for i in 0..=64 {
        if let Some(v) = track.sample(duration * i as f64 / 64.0) {
            see(&v);
        }
    }
    if !lo.is_finite() {
        return [-1.0, 1.0];
    }
    let pad = ((hi - lo) * 0.1).max(0.05 * hi.abs().max(lo.abs())).max(1e-3);
    [lo - pad, hi + pad]
}

#[cfg(test)]
mod tests {
    use super::*;
    use isoray_scene::Interpolation;

    #[test]
    fn texts_load_back_as_the_same_keys() {
        let keys = vec![(0.0, vec![1.0, -0.5, 0.0]), (1.25, vec![-1.0, 0.5, 2.0])];
        let text = format!("[[track]]\ntarget = \"camera.position\"\nkeys = {}\n", keys_text(&keys));
        let scene = isoray_scene::load_str(&text, "t.toml", &[]).unwrap();
        assert_eq!(scene.tracks[0].keys, keys);
        assert_eq!(number_text(-0.0), "0.0");
        assert_eq!(number_text(2.0), "2.0");
        assert_eq!(number_text(0.1 + 0.2), "0.3");
    }

    #[test]
    fn adding_on_the_curve_keeps_the_curve_and_deleting_undoes_it() {
        let keys = vec![(0.0, vec![0.0]), (1.0, vec![2.0])];
        let track = Track::new("params.k", keys.clone(), Interpolation::Linear, false);
        let added = add_key(&track, 0.25, None).unwrap();
        assert_eq!(added, vec![(0.0, vec![0.0]), (0.25, vec![0.5]), (1.0, vec![2.0])]);
        let with = Track::new("params.k", added.clone(), Interpolation::Linear, false);
        for i in 0..=20 {
            let t = i as f64 / 20.0;
            let (a, b) = (track.sample(t).unwrap()[0], with.sample(t).unwrap()[0]);
            assert!((a - b).abs() < 1e-12, "t = {t}: {a} vs {b}");
        }
        assert_eq!(delete_key(&added, 1).unwrap(), keys);
        assert!(add_key(&track, 1.0005, None).is_none(), "too close to a key");
        assert!(delete_key(&[(0.0, vec![1.0])], 0).is_none(), "the last key stays");
        let set = add_key(&track, 0.5, Some((0, 7.0))).unwrap();
        assert_eq!(set[1], (0.5, vec![7.0]));
    }
}
