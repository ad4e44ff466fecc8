//! Writing images: PNG (8-bit sRGB, encoded by [`isoray_shade::srgb`]) and
//! OpenEXR AOVs, always atomically: the data goes to a temporary file beside
//! the target, which is renamed over it only when complete, so a failed
//! write leaves any old file intact.

use std::path::Path;

use exr::prelude::*;
use isoray_shade::srgb::to_srgb8;

/// An output failure.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// Writing the file failed.
    #[error("cannot write `{path}`: {message}")]
    Write {
        /// The target.
        path: String,
        /// What went wrong.
        message: String,
    },
}

/// Writes through [`isoray_job::file::replace_atomically`], naming the target in errors.
fn atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> std::result::Result<(), String>,
) -> std::result::Result<(), OutputError> {
    let fail = |message: String| OutputError::Write {
        path: path.display().to_string(),
        message,
    };
    if path.is_dir() {
        return Err(fail("it is a directory".into()));
    }
    isoray_job::file::replace_atomically(path, |tmp| write(tmp).map_err(std::io::Error::other))
        .map_err(|e| fail(e.to_string()))
}

/// Writes `text` to `path` atomically: a failed write leaves an existing file intact.
pub fn write_text(path: &Path, text: &str) -> std::result::Result<(), OutputError> {
    atomically(path, |tmp| std::fs::write(tmp, text).map_err(|e| e.to_string()))
}

/// Writes linear RGB as an 8-bit sRGB PNG.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[[f32; 3]]) -> std::result::Result<(), OutputError> {
    write_png_srgb8(path, width, height, &to_srgb8(rgb))
}

/// Writes 8-bit sRGB bytes (r, g, b per pixel, row by row) as a PNG: the
/// same file [`write_png`] writes for the linear colours they encode.
pub fn write_png_srgb8(path: &Path, width: u32, height: u32, bytes: &[u8]) -> std::result::Result<(), OutputError> {
    atomically(path, |tmp| {
        if bytes.len() != width as usize * height as usize * 3 {
            return Err(format!("{} pixels given for a {width}x{height} image", bytes.len() / 3));
        }
        image::save_buffer_with_format(
            tmp,
            bytes,
            width,
            height,
            image::ColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| e.to_string())
    })
}

/// Writes one 32-bit float channel named `name` (e.g. `Z`).
pub fn write_exr_channel(
    path: &Path,
    width: u32,
    height: u32,
    name: &str,
    data: &[f32],
) -> std::result::Result<(), OutputError> {
    let channel = AnyChannel::new(name, FlatSamples::F32(data.to_vec()));
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(vec![channel])),
    );
    let image = Image::from_layer(layer);
    atomically(path, |tmp| image.write().to_file(tmp).map_err(|e| e.to_string()))
}

/// Writes three 32-bit float channels R, G, B.
pub fn write_exr_rgb(path: &Path, width: u32, height: u32, data: &[[f32; 3]]) -> std::result::Result<(), OutputError> {
    let w = width as usize;
    atomically(path, |tmp| {
        write_rgb_file(tmp, w, height as usize, |x, y| {
            let c = data[y * w + x];
            (c[0], c[1], c[2])
        })
        .map_err(|e| e.to_string())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_write_keeps_old_file() {
        let dir = std::env::temp_dir().join(format!("isoray-out-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("a.png");
        write_png(&target, 1, 1, &[[1.0, 0.0, 0.0]]).unwrap();
        let before = std::fs::read(&target).unwrap();
        // A wrong-sized buffer makes the encoder fail: the old file must survive.
        assert!(write_png(&target, 2, 2, &[[0.0; 3]]).is_err());
        assert_eq!(std::fs::read(&target).unwrap(), before);
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
            .collect();
        assert!(leftovers.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
