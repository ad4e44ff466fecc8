//! The thesis's normal map of a height map (Anexo 1: G3D's
//! `GImage::computeNormalMap`), byte for byte: a Sobel filter over the
//! 3 × 3 neighbourhood of each texel, the normal (−∂h/∂x, ∂h/∂y, z)
//! normalised and packed as RGB = n·127.5 + 127.5 (rounded half away from
//! zero, clamped), A = the height byte. A height rising towards +x gives a
//! −x normal; +y points towards row 0 (up in the image).
//!
//! With heights in [0, 1] and z = 1, a full-scale step is 8 texels tall:
//! the *white height* is 8 texels. [`NormalMapOptions::white_height`]
//! generalises it (z = 8 / white height: a taller white, steeper slopes). Lookups wrap at the borders (the
//! map is a torus, as G3D) or clamp; `low_pass` writes the 3 × 3 mean
//! height in A, `scale_height_by_nz` multiplies it by the normal's z.
//!
//! A change to the heights in a rectangle R changes the normals in R grown
//! by one texel (wrapped or clipped); [`NormalMap::update`] recomputes
//! exactly that, so a partial update equals a full recompute, texel for
//! texel (the thesis recomputed R only and left a ring of stale normals).

use std::path::Path;

use crate::heightmap::{write_image, MapError, Rect};

/// What happens at the map's borders.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Wrap {
    /// Lookups wrap around (G3D's, the thesis's).
    #[default]
    Repeat,
    /// Lookups clamp to the edge.
    Clamp,
    /// Columns wrap around, rows clamp (a spherical map: longitude wraps,
    /// the poles do not).
    Columns,
}

/// How heights become normals (the defaults are the thesis's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalMapOptions {
    /// The height, in texels, of a full-scale (0 → 1) height step: 8 in G3D.
    pub white_height: f32,
    /// Borders.
    pub wrap: Wrap,
    /// A holds the 3 × 3 mean height instead of the texel's.
    pub low_pass: bool,
    /// A's height is multiplied by the normal's z.
    pub scale_height_by_nz: bool,
}

impl Default for NormalMapOptions {
    fn default() -> Self {
        NormalMapOptions {
            white_height: 8.0,
            wrap: Wrap::Repeat,
            low_pass: false,
            scale_height_by_nz: false,
        }
    }
}

/// An RGBA8 normal map (RGB the normal, A the height), row-major.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NormalMap {
    width: u32,
    height: u32,
    texels: Vec<[u8; 4]>,
}

/// G3D's iRound: to the nearest integer, halves away from zero.
fn iround(x: f64) -> i64 {
    (x + if x < 0.0 { -0.5 } else { 0.5 }) as i64
}

/// Heights of an 8-bit grey image: byte / 255.
pub fn heights_of_bytes(bytes: &[u8]) -> Vec<f32> {
    bytes.iter().map(|&b| b as f32 / 255.0).collect()
}

impl NormalMap {
    /// A map of flat normals (128, 128, 255) and height 128.
    pub fn flat(width: u32, height: u32) -> NormalMap {
        NormalMap {
            width,
            height,
            texels: vec![[128, 128, 255, 128]; width as usize * height as usize],
        }
    }

    /// The normal map of `heights` (row-major, `width` × `height`, in [0, 1]).
    pub fn of(heights: &[f32], width: u32, height: u32, opts: &NormalMapOptions) -> NormalMap {
        let mut n = NormalMap::flat(width, height);
        n.compute_rect(heights, opts, Rect::new(0, 0, width, height));
        n
    }

    /// A map of the given texels (row-major).
    pub fn from_texels(width: u32, height: u32, texels: Vec<[u8; 4]>) -> NormalMap {
        assert_eq!(texels.len(), width as usize * height as usize, "texel count");
        NormalMap { width, height, texels }
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
    pub fn texels(&self) -> &[[u8; 4]] {
        &self.texels
    }

    /// The RGBA bytes at (x, y).
    pub fn get(&self, x: u32, y: u32) -> [u8; 4] {
        self.texels[(y * self.width + x) as usize]
    }

    /// The unit normal at (x, y), decoded from its bytes (tangent space:
    /// x along the columns, y towards row 0, z out of the surface).
    pub fn normal(&self, x: u32, y: u32) -> [f32; 3] {
        let t = self.get(x, y);
        let d = |b: u8| (b as f32 - 127.5) / 127.5;
        let v = [d(t[0]), d(t[1]), d(t[2])];
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / l, v[1] / l, v[2] / l]
    }

    /// Recomputes the texels of `rect` exactly (what the thesis did after
    /// an impact; see [`NormalMap::update`] for what it should have done).
    pub fn compute_rect(&mut self, heights: &[f32], opts: &NormalMapOptions, rect: Rect) {
        for y in rect.y0..rect.y1.min(self.height) {
            for x in rect.x0..rect.x1.min(self.width) {
                self.texels[(y * self.width + x) as usize] = texel(heights, self.width, self.height, x, y, opts);
            }
        }
    }

    /// Recomputes every normal that a change of the heights inside
    /// `changed` can alter: the rectangle grown by one texel, wrapped
    /// around the borders that wrap, clipped at those that clamp. Returns
    /// the texels recomputed.
    pub fn update(&mut self, heights: &[f32], opts: &NormalMapOptions, changed: Rect) -> u64 {
        if changed.is_empty() {
            return 0;
        }
        let span = |a: u32, b: u32, n: u32, wraps: bool| -> Vec<u32> {
            let (lo, hi) = (a as i64 - 1, b as i64 + 1);
            if hi - lo >= n as i64 {
                (0..n).collect()
            } else if wraps {
                (lo..hi).map(|i| i.rem_euclid(n as i64) as u32).collect()
            } else {
                (lo.max(0)..hi.min(n as i64)).map(|i| i as u32).collect()
            }
        };
        let xs = span(changed.x0, changed.x1, self.width, opts.wrap != Wrap::Clamp);
        let ys = span(changed.y0, changed.y1, self.height, opts.wrap == Wrap::Repeat);
        for &y in &ys {
            for &x in &xs {
                self.texels[(y * self.width + x) as usize] = texel(heights, self.width, self.height, x, y, opts);
            }
        }
        (xs.len() * ys.len()) as u64
    }

    /// Writes the map as an 8-bit RGBA PNG, atomically.
    pub fn write_png(&self, path: &Path) -> Result<(), MapError> {
        let bytes: Vec<u8> = self.texels.iter().flatten().copied().collect();
        let img = image::RgbaImage::from_raw(self.width, self.height, bytes).expect("sized");
        write_image(path, &image::DynamicImage::ImageRgba8(img))
    }
}

/// The unit normal at texel (x, y) of a height map (tangent space: x
/// along the columns, y towards row 0), and the texel's alpha height: G3D's
/// Sobel kernels, with each kernel's opposite taps paired (so a flat
/// neighbourhood gives exactly 0 and the flat normal), in f64.
pub fn sobel_normal(heights: &[f32], w: u32, h: u32, x: u32, y: u32, opts: &NormalMapOptions) -> ([f64; 3], f64) {
    // The neighbours' columns and rows, wrapped or clamped once.
    let near = |i: u32, n: u32, wraps: bool| -> [usize; 3] {
        let prev = if i > 0 {
            i - 1
        } else if wraps {
            n - 1
        } else {
            0
        };
        let next = if i + 1 < n {
            i + 1
        } else if wraps {
            0
        } else {
            n - 1
        };
        [prev as usize, i as usize, next as usize]
    };
    let cols = near(x, w, opts.wrap != Wrap::Clamp);
    let rows = near(y, h, opts.wrap == Wrap::Repeat);
    let at =
        |dx: i64, dy: i64| -> f64 { heights[rows[(dy + 1) as usize] * w as usize + cols[(dx + 1) as usize]] as f64 };
    // −(Sobel Y): the row below minus the row above (+y towards row 0 for a
    // height rising downwards); −(Sobel X): the left column minus the right.
    let dy = (at(-1, 1) - at(-1, -1)) + 2.0 * (at(0, 1) - at(0, -1)) + (at(1, 1) - at(1, -1));
    let dx = (at(-1, -1) - at(1, -1)) + 2.0 * (at(-1, 0) - at(1, 0)) + (at(-1, 1) - at(1, 1));
    let dz = 8.0 / opts.white_height as f64;
    let len = (dx * dx + dy * dy + dz * dz).sqrt();
    let n = [dx / len, dy / len, dz / len];
    let mut hh = at(0, 0);
    if opts.low_pass {
        let mut s = 0.0;
        for j in -1..=1 {
            for i in -1..=1 {
                s += at(i, j);
            }
        }
        hh = s / 9.0;
    }
    if opts.scale_height_by_nz {
        hh *= n[2];
    }
    (n, hh)
}

/// One texel of the normal map, as G3D packs it.
fn texel(heights: &[f32], w: u32, h: u32, x: u32, y: u32, opts: &NormalMapOptions) -> [u8; 4] {
    let (n, hh) = sobel_normal(heights, w, h, x, y, opts);
    let byte = |v: f64| iround(v * 127.5 + 127.5).clamp(0, 255) as u8;
    [
        byte(n[0]),
        byte(n[1]),
        byte(n[2]),
        iround(hh * 255.0).clamp(0, 255) as u8,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map_of(w: u32, h: u32, f: impl Fn(u32, u32) -> u8) -> Vec<f32> {
        let bytes: Vec<u8> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| f(x, y))
            .collect();
        heights_of_bytes(&bytes)
    }

    fn rgba(t: [u8; 4]) -> [u8; 3] {
        [t[0], t[1], t[2]]
    }

    /// dents.md §2.5, KAT 9: G3D's bytes.
    #[test]
    fn flat_and_ramps_give_g3ds_bytes() {
        let o = NormalMapOptions::default();
        let n = NormalMap::of(&map_of(8, 8, |_, _| 128), 8, 8, &o);
        assert_eq!(n.get(3, 3), [128, 128, 255, 128]);
        let n = NormalMap::of(&map_of(16, 8, |x, _| x as u8), 16, 8, &o);
        assert_eq!(rgba(n.get(5, 4)), [124, 128, 255]);
        let n = NormalMap::of(&map_of(16, 8, |x, _| 10 * x as u8), 16, 8, &o);
        assert_eq!(n.get(5, 4), [89, 128, 249, 50]);
        let v = n.normal(5, 4);
        assert!((v[0] + 0.299340).abs() < 0.01 && v[1].abs() < 0.01 && (v[2] - 0.954146).abs() < 0.01);
        let n = NormalMap::of(&map_of(8, 16, |_, y| 10 * y as u8), 8, 16, &o);
        assert_eq!(rgba(n.get(4, 5)), [128, 166, 249], "+y points towards row 0");
    }

    #[test]
    fn a_spike_gives_g3ds_bytes_around_it() {
        let o = NormalMapOptions::default();
        let hs = map_of(8, 8, |x, y| if (x, y) == (4, 4) { 255 } else { 0 });
        let n = NormalMap::of(&hs, 8, 8, &o);
        assert_eq!(rgba(n.get(4, 4)), [128, 128, 255]);
        assert_eq!(rgba(n.get(3, 4)), [13, 128, 185], "left");
        assert_eq!(rgba(n.get(5, 4)), [242, 128, 185], "right");
        assert_eq!(rgba(n.get(4, 3)), [128, 242, 185], "above");
        assert_eq!(rgba(n.get(4, 5)), [128, 13, 185], "below");
        assert_eq!(rgba(n.get(3, 3)), [54, 201, 201], "up-left");
        assert_eq!(rgba(n.get(5, 5)), [201, 54, 201], "down-right");
        let lp = NormalMap::of(&hs, 8, 8, &NormalMapOptions { low_pass: true, ..o });
        assert_eq!(lp.get(4, 4)[3], 28);
    }

    #[test]
    fn borders_wrap_and_scaling_by_nz_leaves_a_flat_map() {
        let o = NormalMapOptions::default();
        let n = NormalMap::of(&map_of(8, 8, |x, _| 10 * x as u8), 8, 8, &o);
        assert_eq!(rgba(n.get(0, 3)), [215, 128, 220]);
        assert_eq!(n.get(7, 3), [215, 128, 220, 70]);
        let s = NormalMapOptions {
            scale_height_by_nz: true,
            ..o
        };
        assert_eq!(NormalMap::of(&map_of(8, 8, |_, _| 128), 8, 8, &s).get(2, 2)[3], 128);
        // Clamped borders see no jump at the edge.
        let c = NormalMapOptions { wrap: Wrap::Clamp, ..o };
        let n = NormalMap::of(&map_of(8, 8, |x, _| 10 * x as u8), 8, 8, &c);
        assert_eq!(rgba(n.get(3, 3)), [89, 128, 249]);
        assert!(n.get(0, 3)[0] > 89, "half the slope at a clamped edge");
    }

    /// A white height of 4 texels halves the slopes: the 10-per-texel ramp
    /// then tilts as the 5-per-texel one does with 8.
    #[test]
    fn the_white_height_scales_the_slopes() {
        let w4 = NormalMapOptions {
            white_height: 4.0,
            ..Default::default()
        };
        let a = NormalMap::of(&map_of(16, 8, |x, _| 10 * x as u8), 16, 8, &w4);
        let b = NormalMap::of(&map_of(16, 8, |x, _| 5 * x as u8), 16, 8, &NormalMapOptions::default());
        assert_eq!(rgba(a.get(5, 4)), rgba(b.get(5, 4)));
    }

    fn random_map(w: u32, h: u32, seed: u64) -> Vec<f32> {
        let mut s = seed;
        (0..w * h)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (s >> 56) as u8 as f32 / 255.0
            })
            .collect()
    }

    fn changed_texels(a: &NormalMap, b: &NormalMap) -> Vec<(u32, u32)> {
        (0..a.height)
            .flat_map(|y| (0..a.width).map(move |x| (x, y)))
            .filter(|&(x, y)| a.get(x, y) != b.get(x, y))
            .collect()
    }

    /// KAT 10.
    #[test]
    fn a_changed_block_changes_exactly_its_ring_padded_rectangle() {
        let o = NormalMapOptions::default();
        let mut hs = random_map(16, 16, 7);
        let before = NormalMap::of(&hs, 16, 16, &o);
        for y in 5..9 {
            for x in 6..10 {
                hs[y * 16 + x] = 0.0;
            }
        }
        let after = NormalMap::of(&hs, 16, 16, &o);
        let ch = changed_texels(&before, &after);
        assert!(ch.iter().all(|&(x, y)| (5..=10).contains(&x) && (4..=9).contains(&y)));
        assert!(ch.len() > 30, "{} of the 36 changed", ch.len());
        let mut part = before.clone();
        let n = part.update(&hs, &o, Rect::new(6, 5, 10, 9));
        assert_eq!(n, 36);
        assert_eq!(part, after);
        // The thesis's update of the block alone leaves stale normals.
        let mut thesis = before.clone();
        thesis.compute_rect(&hs, &o, Rect::new(6, 5, 10, 9));
        assert_ne!(thesis, after);
    }

    #[test]
    fn a_corner_texel_changes_its_nine_wrapped_neighbours() {
        let o = NormalMapOptions::default();
        let mut hs = map_of(16, 16, |_, _| 100);
        let before = NormalMap::of(&hs, 16, 16, &o);
        hs[0] = 1.0;
        let after = NormalMap::of(&hs, 16, 16, &o);
        let mut ch = changed_texels(&before, &after);
        ch.sort();
        // The texel (its height byte) and its eight wrapped neighbours.
        let mut want = vec![
            (0, 0),
            (0, 1),
            (0, 15),
            (1, 0),
            (1, 1),
            (1, 15),
            (15, 0),
            (15, 1),
            (15, 15),
        ];
        want.sort();
        assert_eq!(ch, want);
        let mut part = before.clone();
        assert_eq!(part.update(&hs, &o, Rect::texel(0, 0)), 9);
        assert_eq!(part, after);
    }

    proptest::proptest! {
        /// A recompute of the changed rectangle grown by one equals the full
        /// recompute, on every map and rectangle, every border mode.
        #[test]
        fn a_partial_update_equals_a_full_recompute(
            seed in 0u64..1000, w in 3u32..20, h in 3u32..20,
            x0 in 0u32..20, y0 in 0u32..20, cw in 1u32..8, ch in 1u32..8, mode in 0usize..3,
        ) {
            let wrap = [Wrap::Repeat, Wrap::Clamp, Wrap::Columns][mode];
            let o = NormalMapOptions { wrap, ..Default::default() };
            let mut hs = random_map(w, h, seed);
            let mut part = NormalMap::of(&hs, w, h, &o);
            let r = Rect { x0: x0 % w, y0: y0 % h, x1: (x0 % w + cw).min(w), y1: (y0 % h + ch).min(h) };
            let fresh = random_map(w, h, seed + 1);
            for y in r.y0..r.y1 {
                for x in r.x0..r.x1 {
                    let i = (y * w + x) as usize;
                    hs[i] = fresh[i];
                }
            }
            part.update(&hs, &o, r);
            proptest::prop_assert_eq!(part, NormalMap::of(&hs, w, h, &o));
        }
    }
}
