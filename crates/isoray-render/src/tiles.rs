//! One still split across processes: band I of N is a horizontal band of
//! rows, rendered alone ([`band`] gives its rows) and written as a PNG that
//! says in a text chunk where it belongs; [`merge`] checks that a set of
//! bands makes one whole image and writes it, byte for byte the PNG a
//! single render would have written.
//!
//! ```
//! use isoray_render::tiles::band;
//! // 10 rows in 3 bands: 0..3, 3..6, 6..10.
//! assert_eq!(band(10, 0, 3), 0..3);
//! assert_eq!(band(10, 2, 3), 6..10);
//! ```

use std::path::Path;

use crate::output::{write_png_srgb8, OutputError};

/// The PNG text key that marks a band.
pub const TILE_KEY: &str = "isoray-tile";

/// The rows of band `index` of `count` in an image `height` rows high:
/// contiguous, in order, covering every row once.
pub fn band(height: u32, index: u32, count: u32) -> std::ops::Range<u32> {
    let at = |i: u32| (u64::from(height) * u64::from(i) / u64::from(count.max(1))) as u32;
    at(index)..at(index + 1)
}

/// Where a band belongs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileInfo {
    /// Which band (from 0).
    pub index: u32,
    /// How many bands the image was split into.
    pub count: u32,
    /// The whole image's width.
    pub width: u32,
    /// The whole image's height.
    pub height: u32,
}

impl TileInfo {
    fn text(&self) -> String {
        format!(
            "index={} count={} width={} height={}",
            self.index, self.count, self.width, self.height
        )
    }

    fn parse(text: &str) -> Option<TileInfo> {
        let mut v = [None; 4];
        for part in text.split_whitespace() {
            let (k, x) = part.split_once('=')?;
            let slot = ["index", "count", "width", "height"].iter().position(|n| *n == k)?;
            v[slot] = Some(x.parse().ok()?);
        }
        let info = TileInfo {
            index: v[0]?,
            count: v[1]?,
            width: v[2]?,
            height: v[3]?,
        };
        (info.count > 0 && info.index < info.count).then_some(info)
    }
}

/// Writes band `info.index` (its rows of 8-bit sRGB, `rgb8`) as a PNG
/// marked with where it belongs.
pub fn write_band(path: &Path, info: TileInfo, rgb8: &[u8]) -> Result<(), OutputError> {
    let rows = band(info.height, info.index, info.count);
    let fail = |message: String| OutputError::Write {
        path: path.display().to_string(),
        message,
    };
    if rgb8.len() != info.width as usize * rows.len() * 3 {
        return Err(fail(format!(
            "{} bytes given for {} rows of {}",
            rgb8.len(),
            rows.len(),
            info.width
        )));
    }
    isoray_job::file::replace_atomically(path, |tmp| {
        let file = std::fs::File::create(tmp)?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), info.width, rows.len() as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.add_text_chunk(TILE_KEY.into(), info.text())
            .map_err(std::io::Error::other)?;
        let mut w = enc.write_header().map_err(std::io::Error::other)?;
        w.write_image_data(rgb8).map_err(std::io::Error::other)?;
        w.finish().map_err(std::io::Error::other)
    })
    .map_err(|e| fail(e.to_string()))
}

/// Why bands do not merge.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// A band could not be read, or is not a band.
    #[error("`{path}`: {message}")]
    Band {
        /// The file.
        path: String,
        /// What is wrong with it.
        message: String,
    },
    /// The bands do not make one image.
    #[error("{0}")]
    Set(String),
    /// Writing the merged image failed.
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// Reads one band: where it belongs and its bytes.
fn read_band(path: &Path) -> Result<(TileInfo, Vec<u8>), MergeError> {
    let fail = |message: String| MergeError::Band {
        path: path.display().to_string(),
        message,
    };
    let file = std::fs::File::open(path).map_err(|e| fail(format!("cannot read it: {e}")))?;
    let mut dec = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .map_err(|e| fail(format!("not a PNG: {e}")))?;
    let info = dec
        .info()
        .uncompressed_latin1_text
        .iter()
        .find(|t| t.keyword == TILE_KEY)
        .and_then(|t| TileInfo::parse(&t.text))
        .ok_or_else(|| fail("not a band of `isoray render --tile I/N` (no isoray-tile text)".into()))?;
    let (w, h) = (dec.info().width, dec.info().height);
    let (ct, depth) = (dec.info().color_type, dec.info().bit_depth);
    if ct != png::ColorType::Rgb || depth != png::BitDepth::Eight {
        return Err(fail(format!("expected 8-bit RGB, found {ct:?} {depth:?}")));
    }
    let rows = band(info.height, info.index, info.count);
    if w != info.width || h as usize != rows.len() {
        return Err(fail(format!(
            "band {} of {} of a {}x{} image should be {}x{}, found {w}x{h}",
            info.index,
            info.count,
            info.width,
            info.height,
            info.width,
            rows.len()
        )));
    }
    let mut buf = vec![
        0;
        dec.output_buffer_size()
            .ok_or_else(|| fail("the image is too large".into()))?
    ];
    dec.next_frame(&mut buf)
        .map_err(|e| fail(format!("cannot decode it: {e}")))?;
    buf.truncate(w as usize * h as usize * 3);
    Ok((info, buf))
}

/// Assembles bands into the whole image at `out`: every band of one split
/// of one image, each once. Returns the image's size.
pub fn merge(bands: &[&Path], out: &Path) -> Result<(u32, u32), MergeError> {
    let mut read: Vec<(TileInfo, Vec<u8>, &Path)> = Vec::new();
    for p in bands {
        let (info, bytes) = read_band(p)?;
        read.push((info, bytes, p));
    }
    let Some(first) = read.first().map(|r| r.0) else {
        return Err(MergeError::Set("no bands to merge".into()));
    };
    let mut have: Vec<Option<&Path>> = vec![None; first.count as usize];
    for (info, _, p) in &read {
        if (info.count, info.width, info.height) != (first.count, first.width, first.height) {
            return Err(MergeError::Set(format!(
                "`{}` is band {} of {} of a {}x{} image, but `{}` is of {} bands of a {}x{} image",
                p.display(),
                info.index,
                info.count,
                info.width,
                info.height,
                read[0].2.display(),
                first.count,
                first.width,
                first.height
            )));
        }
        if let Some(other) = have[info.index as usize] {
            return Err(MergeError::Set(format!(
                "band {} is given twice: `{}` and `{}`",
                info.index,
                other.display(),
                p.display()
            )));
        }
        have[info.index as usize] = Some(p);
    }
    let missing: Vec<String> = (0..first.count)
        .filter(|i| have[*i as usize].is_none())
        .map(|i| i.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(MergeError::Set(format!(
            "band(s) {} of {} are missing",
            missing.join(", "),
            first.count
        )));
    }
    read.sort_by_key(|r| r.0.index);
    let whole: Vec<u8> = read.into_iter().flat_map(|r| r.1).collect();
    write_png_srgb8(out, first.width, first.height, &whole)?;
    Ok((first.width, first.height))
}
