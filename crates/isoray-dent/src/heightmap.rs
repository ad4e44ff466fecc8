//! A height (bump) map: one value per texel in [0, 1], 0.5 untouched, 0
//! the deepest dent and 1 the highest bump; a value h stands for a
//! displacement of (h − 0.5)·range along the surface normal (`range` is
//! the thesis's k, in scene units, so a map holds dents down to range/2).
//!
//! Impacts lower texels with [`HeightMap::lower_min`]: where several
//! samples address one texel, the deepest wins whatever the order (the
//! thesis's depth-tested points, §2.4.2). The map remembers the rectangle
//! changed since it was last asked ([`HeightMap::take_dirty`]), so that
//! only that part is written back and only its normals recomputed, and
//! counts the texels that reached 0 (saturated).

use std::path::Path;

/// A half-open rectangle of texels: x0 ≤ x < x1, y0 ≤ y < y1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Rect {
    /// Columns x0..x1 of rows y0..y1.
    pub const fn new(x0: u32, y0: u32, x1: u32, y1: u32) -> Rect {
        Rect { x0, y0, x1, y1 }
    }

    /// The rectangle of one texel.
    pub fn texel(x: u32, y: u32) -> Rect {
        Rect {
            x0: x,
            y0: y,
            x1: x + 1,
            y1: y + 1,
        }
    }

    /// The smallest rectangle holding both.
    pub fn union(self, o: Rect) -> Rect {
        Rect {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }

    /// Columns × rows.
    pub fn area(self) -> u64 {
        (self.x1.saturating_sub(self.x0)) as u64 * (self.y1.saturating_sub(self.y0)) as u64
    }

    /// Whether it holds no texel.
    pub fn is_empty(self) -> bool {
        self.area() == 0
    }
}

/// Errors of reading and writing maps.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// The file could not be read or written.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
}

/// A height map: see the module's documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightMap {
    width: u32,
    height: u32,
    /// Scene units of one whole height unit (the thesis's k).
    pub range: f64,
    texels: Vec<f32>,
    dirty: Option<Rect>,
    saturated: u64,
    /// The lowest and highest values of the map.
    lo: f32,
    hi: f32,
}

/// The value of an untouched texel.
pub const NEUTRAL: f32 = 0.5;

impl HeightMap {
    /// An untouched `width` × `height` map whose heights span `range` scene units.
    pub fn new(width: u32, height: u32, range: f64) -> HeightMap {
        HeightMap {
            width,
            height,
            range,
            texels: vec![NEUTRAL; width as usize * height as usize],
            dirty: None,
            saturated: 0,
            lo: NEUTRAL,
            hi: NEUTRAL,
        }
    }

    /// A map of the given texels (row-major, each clamped to [0, 1]).
    pub fn from_texels(width: u32, height: u32, range: f64, texels: Vec<f32>) -> HeightMap {
        assert_eq!(texels.len(), width as usize * height as usize, "texel count");
        let texels: Vec<f32> = texels.into_iter().map(|h| h.clamp(0.0, 1.0)).collect();
        let lo = texels.iter().copied().fold(NEUTRAL, f32::min);
        let hi = texels.iter().copied().fold(NEUTRAL, f32::max);
        HeightMap {
            width,
            height,
            range,
            texels,
            dirty: None,
            saturated: 0,
            lo,
            hi,
        }
    }

    /// Columns.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The texels, row-major.
    pub fn texels(&self) -> &[f32] {
        &self.texels
    }

    /// The value at texel (x, y).
    pub fn get(&self, x: u32, y: u32) -> f32 {
        self.texels[(y * self.width + x) as usize]
    }

    /// The displacement at texel (x, y) in scene units along the normal
    /// (negative in a dent).
    pub fn displacement(&self, x: u32, y: u32) -> f64 {
        (self.get(x, y) as f64 - NEUTRAL as f64) * self.range
    }

    /// The value of a displacement `d` (scene units), unclamped.
    pub fn value_of(&self, d: f64) -> f64 {
        NEUTRAL as f64 + d / self.range
    }

    /// Lowers texel (x, y) to `h` where that is lower (the deepest dent
    /// wins), clamping at 0 (saturation, counted); returns whether the
    /// texel changed.
    pub fn lower_min(&mut self, x: u32, y: u32, h: f64) -> bool {
        let i = (y * self.width + x) as usize;
        if h < 0.0 && self.texels[i] > 0.0 {
            self.saturated += 1;
        }
        let h = h.clamp(0.0, 1.0) as f32;
        if h < self.texels[i] {
            self.texels[i] = h;
            self.lo = self.lo.min(h);
            let r = Rect::texel(x, y);
            self.dirty = Some(self.dirty.map_or(r, |d| d.union(r)));
            true
        } else {
            false
        }
    }

    /// The largest |displacement| of any texel, scene units: no surface
    /// point of the map is farther than this from the undented surface.
    pub fn deepest(&self) -> f64 {
        (NEUTRAL - self.lo).max(self.hi - NEUTRAL) as f64 * self.range
    }

    /// The rectangle changed since the last call, and forgets it.
    pub fn take_dirty(&mut self) -> Option<Rect> {
        self.dirty.take()
    }

    /// Texels pushed below 0 (clamped) so far: the map saturated there.
    pub fn saturated(&self) -> u64 {
        self.saturated
    }

    /// Writes the map as a 16-bit grey PNG (0.5 untouched; value · 65535),
    /// atomically.
    pub fn write_png16(&self, path: &Path) -> Result<(), MapError> {
        let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(self.width, self.height, |x, y| {
            image::Luma([(self.get(x, y) as f64 * 65535.0).round() as u16])
        });
        write_image(path, &image::DynamicImage::ImageLuma16(img))
    }

    /// Reads a grey PNG (8 or 16 bits) as a map of the given range.
    pub fn read_png(path: &Path, range: f64) -> Result<HeightMap, MapError> {
        let img = image::open(path).map_err(|e| io_error(path, e))?.into_luma16();
        let (w, h) = img.dimensions();
        let texels = img.pixels().map(|p| p.0[0] as f32 / 65535.0).collect();
        Ok(HeightMap::from_texels(w, h, range, texels))
    }
}

fn io_error(path: &Path, e: impl std::fmt::Display) -> MapError {
    MapError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Writes `img` as a PNG at `path` atomically (a failed write leaves the
/// old file).
pub(crate) fn write_image(path: &Path, img: &image::DynamicImage) -> Result<(), MapError> {
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| io_error(path, e))?;
    isoray_job::file::write_atomic(path, &bytes).map_err(|e| io_error(path, e))
}

/// The thesis's update of one texel from an ortho imprint (§2.4.2):
/// h' = h − ΔD·(z_far − z_near)/k, clamped to [0, 1], with ΔD the depth
/// difference in window units (0 to 1 across the ortho camera's depth
/// range `z_range`) and k the map's range.
pub fn ortho_update(h: f64, delta_window: f64, z_range: f64, k: f64) -> f64 {
    (h - delta_window * z_range / k).clamp(0.0, 1.0)
}

/// The thesis's depth offset of a fragment of height h in the imprint's
/// pass A (towards the camera; pass B uses the opposite sign): h·k'/(z_far − z_near).
pub fn depth_offset(h: f64, k_prime: f64, z_range: f64) -> f64 {
    h * k_prime / z_range
}

#[cfg(test)]
mod tests {
    use super::*;

    /// dents.md §2.5, KAT 5.
    #[test]
    fn the_ortho_update_is_the_theses() {
        assert!((ortho_update(0.5, 0.01, 2.0, 0.2) - 0.4).abs() < 1e-12);
        assert_eq!(ortho_update(0.5, 0.1, 2.0, 0.2), 0.0);
    }

    /// KAT 6.
    #[test]
    fn the_depth_offset_is_the_theses() {
        assert!((depth_offset(0.5, 0.1, 2.0) - 0.025).abs() < 1e-15);
    }

    /// KAT 8: two samples on one texel leave the deeper, in either order.
    #[test]
    fn the_deepest_dent_wins_a_texel_in_either_order() {
        for order in [[0.4, 0.3], [0.3, 0.4]] {
            let mut m = HeightMap::new(4, 4, 0.2);
            for h in order {
                m.lower_min(1, 2, h);
            }
            assert!((m.get(1, 2) - 0.3).abs() < 1e-7);
            assert_eq!(m.take_dirty(), Some(Rect::texel(1, 2)));
            assert_eq!(m.take_dirty(), None);
        }
    }

    #[test]
    fn a_higher_value_changes_nothing_and_saturation_is_counted() {
        let mut m = HeightMap::new(8, 8, 0.1);
        assert!(!m.lower_min(3, 3, 0.7));
        assert_eq!(m.take_dirty(), None);
        assert!(m.lower_min(3, 3, -0.5));
        assert_eq!(m.get(3, 3), 0.0);
        assert_eq!(m.saturated(), 1);
        assert!((m.displacement(3, 3) + 0.05).abs() < 1e-9);
        assert!(m.lower_min(5, 6, 0.45));
        assert_eq!(m.take_dirty(), Some(Rect::new(3, 3, 6, 7)));
    }

    #[test]
    fn maps_round_trip_through_16_bit_png() {
        let d = std::env::temp_dir().join(format!("isoray-dent-hm-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let mut m = HeightMap::new(5, 3, 0.2);
        m.lower_min(2, 1, 0.25);
        let p = d.join("h.png");
        m.write_png16(&p).unwrap();
        let back = HeightMap::read_png(&p, 0.2).unwrap();
        assert_eq!((back.width(), back.height()), (5, 3));
        for (a, b) in m.texels().iter().zip(back.texels()) {
            assert!((a - b).abs() < 1.0 / 65535.0, "{a} vs {b}");
        }
        let err = HeightMap::read_png(&d.join("missing.png"), 0.2)
            .unwrap_err()
            .to_string();
        assert!(err.contains("missing.png"), "{err}");
    }
}
