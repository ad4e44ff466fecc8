//! Writing frame sequences: numbered PNG files from a `%04d` pattern, an
//! animated GIF, an animated PNG (APNG), or an MP4 through `ffmpeg` when it
//! is on the PATH. GIF, APNG and MP4 are written to a temporary file beside
//! the target and renamed over it when the last frame is in, so a failed or
//! cancelled run leaves an old file as it was.
//!
//! ```
//! use isoray_render::sequence::{frame_path, SequenceKind};
//! assert_eq!(frame_path("out/f_%04d.png", 7).to_str(), Some("out/f_0007.png"));
//! assert_eq!(SequenceKind::of(std::path::Path::new("a.gif")), Ok(SequenceKind::Gif));
//! ```

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use isoray_job::file::TempFile;
use isoray_shade::srgb::to_srgb8;

use crate::output::{write_png, OutputError};

/// What a sequence's output path asks for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SequenceKind {
    /// One PNG per frame, named by a pattern with `%d` or `%0Nd`.
    Pattern(String),
    /// An animated GIF (256 colours per frame).
    Gif,
    /// An animated PNG: lossless, 8-bit sRGB like the stills.
    Apng,
    /// An H.264 MP4 encoded by `ffmpeg`.
    Mp4,
}

impl SequenceKind {
    /// The kind `path` asks for: a pattern when it holds `%d` or `%0Nd`,
    /// otherwise by its extension (`.gif`, `.apng`, `.mp4`).
    pub fn of(path: &Path) -> Result<SequenceKind, String> {
        let text = path.to_string_lossy();
        if pattern_at(&text).is_some() {
            if !text.to_lowercase().ends_with(".png") {
                return Err(format!(
                    "`{text}`: numbered frames are PNG files: end the pattern in .png"
                ));
            }
            return Ok(SequenceKind::Pattern(text.into_owned()));
        }
        match path.extension().map(|e| e.to_string_lossy().to_lowercase()).as_deref() {
            Some("gif") => Ok(SequenceKind::Gif),
            Some("apng") => Ok(SequenceKind::Apng),
            Some("mp4") => Ok(SequenceKind::Mp4),
            _ => Err(format!(
                "`{text}`: frames go to a pattern with %04d (such as out/frame_%04d.png), a .gif, an .apng or an .mp4"
            )),
        }
    }
}

/// The byte range of the first `%d` or `%0Nd` in `text`, and N (0 for `%d`).
fn pattern_at(text: &str) -> Option<(std::ops::Range<usize>, usize)> {
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let mut j = i + 1;
            while j < bytes.len() && bytes[j].is_ascii_digit() {
                j += 1;
            }
            if j < bytes.len() && bytes[j] == b'd' {
                let width = text[i + 1..j].parse().unwrap_or(0);
                return Some((i..j + 1, width));
            }
        }
        i += 1;
    }
    None
}

/// The path of frame `n` under `pattern` (`%04d` → `0007`); the pattern
/// itself when it has no `%d`.
pub fn frame_path(pattern: &str, n: u64) -> PathBuf {
    match pattern_at(pattern) {
        Some((range, width)) => PathBuf::from(format!(
            "{}{n:0width$}{}",
            &pattern[..range.start],
            &pattern[range.end..]
        )),
        None => PathBuf::from(pattern),
    }
}

/// Writes the frames of a sequence in order.
pub struct SequenceWriter {
    target: PathBuf,
    width: u32,
    height: u32,
    sink: Sink,
}

enum Sink {
    Pattern(String),
    Gif(
        TempFile,
        Box<image::codecs::gif::GifEncoder<Shared>>,
        Shared,
        image::Delay,
    ),
    Apng(TempFile, Box<png::Writer<BufWriter<std::fs::File>>>),
    Mp4(TempFile, Child),
}

impl SequenceWriter {
    /// Starts a sequence of `frames` frames of `width`×`height` at `fps`
    /// frames per second, written to `path` (see [`SequenceKind::of`]).
    pub fn create(path: &Path, width: u32, height: u32, fps: f64, frames: u64) -> Result<SequenceWriter, OutputError> {
        let fail = |message: String| OutputError::Write {
            path: path.display().to_string(),
            message,
        };
        if width == 0 || height == 0 || !(fps.is_finite() && fps > 0.0) || frames == 0 {
            return Err(fail(format!(
                "a sequence needs frames of a positive size at a positive rate ({frames} frames of {width}x{height} at {fps} fps)"
            )));
        }
        let kind = SequenceKind::of(path).map_err(fail)?;
        let temp = || {
            if path.is_dir() {
                return Err(fail("it is a directory".into()));
            }
            TempFile::beside(path).map_err(|e| fail(e.to_string()))
        };
        let sink = match kind {
            SequenceKind::Pattern(p) => Sink::Pattern(p),
            SequenceKind::Gif => {
                let (tmp, file) = temp()?;
                let shared = Shared(std::sync::Arc::new(std::sync::Mutex::new(BufWriter::new(file))));
                let mut enc = image::codecs::gif::GifEncoder::new_with_speed(shared.clone(), 10);
                enc.set_repeat(image::codecs::gif::Repeat::Infinite)
                    .map_err(|e| fail(e.to_string()))?;
                // GIF delays are in hundredths of a second.
                let cs = (100.0 / fps).round().clamp(1.0, 65535.0) as u32;
                Sink::Gif(
                    tmp,
                    Box::new(enc),
                    shared,
                    image::Delay::from_numer_denom_ms(cs * 10, 1),
                )
            }
            SequenceKind::Apng => {
                let (tmp, file) = temp()?;
                let mut enc = png::Encoder::new(BufWriter::new(file), width, height);
                enc.set_color(png::ColorType::Rgb);
                enc.set_depth(png::BitDepth::Eight);
                let count = u32::try_from(frames).map_err(|_| fail("too many frames for an APNG".into()))?;
                enc.set_animated(count, 0).map_err(|e| fail(e.to_string()))?;
                let (num, den) = frame_delay(fps);
                enc.set_frame_delay(num, den).map_err(|e| fail(e.to_string()))?;
                let w = enc.write_header().map_err(|e| fail(e.to_string()))?;
                Sink::Apng(tmp, Box::new(w))
            }
            SequenceKind::Mp4 => {
                let (tmp, file) = temp()?;
                drop(file);
                let child = Command::new("ffmpeg")
                    .args(["-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s"])
                    .arg(format!("{width}x{height}"))
                    .arg("-framerate")
                    .arg(format!("{fps}"))
                    .args(["-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
                    .args(["-c:v", "libx264", "-pix_fmt", "yuv420p", "-f", "mp4"])
                    .arg(tmp.path())
                    .stdin(Stdio::piped())
                    .stdout(Stdio::null())
                    .stderr(Stdio::piped())
                    .spawn()
                    .map_err(|e| {
                        fail(if e.kind() == std::io::ErrorKind::NotFound {
                            "writing .mp4 needs `ffmpeg` on the PATH (apt-get install ffmpeg); or write numbered PNGs with %04d, a .gif or an .apng".into()
                        } else {
                            format!("cannot start ffmpeg: {e}")
                        })
                    })?;
                Sink::Mp4(tmp, child)
            }
        };
        Ok(SequenceWriter {
            target: path.to_path_buf(),
            width,
            height,
            sink,
        })
    }

    /// The path frame `n` is written to (the sequence's file unless numbered).
    pub fn path_of(&self, n: u64) -> PathBuf {
        match &self.sink {
            Sink::Pattern(p) => frame_path(p, n),
            _ => self.target.clone(),
        }
    }

    /// Adds frame `n` (linear RGB, row by row).
    pub fn push(&mut self, n: u64, rgb: &[[f32; 3]]) -> Result<(), OutputError> {
        let fail = |message: String| OutputError::Write {
            path: self.target.display().to_string(),
            message,
        };
        if rgb.len() != self.width as usize * self.height as usize {
            return Err(fail(format!(
                "{} pixels given for a {}x{} frame",
                rgb.len(),
                self.width,
                self.height
            )));
        }
        match &mut self.sink {
            Sink::Pattern(p) => write_png(&frame_path(p, n), self.width, self.height, rgb)?,
            Sink::Gif(_, enc, _, delay) => {
                let mut rgba = Vec::with_capacity(rgb.len() * 4);
                for px in to_srgb8(rgb).chunks_exact(3) {
                    rgba.extend_from_slice(&[px[0], px[1], px[2], 255]);
                }
                let img = image::RgbaImage::from_raw(self.width, self.height, rgba)
                    .ok_or_else(|| fail("frame size mismatch".into()))?;
                enc.encode_frame(image::Frame::from_parts(img, 0, 0, *delay))
                    .map_err(|e| fail(e.to_string()))?;
            }
            Sink::Apng(_, w) => w.write_image_data(&to_srgb8(rgb)).map_err(|e| fail(e.to_string()))?,
            Sink::Mp4(_, child) => {
                let stdin = child
                    .stdin
                    .as_mut()
                    .ok_or_else(|| fail("ffmpeg's input is closed".into()))?;
                stdin
                    .write_all(&to_srgb8(rgb))
                    .map_err(|e| fail(format!("ffmpeg stopped reading frames: {e}")))?;
            }
        }
        Ok(())
    }

    /// Closes the sequence: the GIF, APNG or MP4 is renamed into place.
    pub fn finish(self) -> Result<(), OutputError> {
        let fail = |message: String| OutputError::Write {
            path: self.target.display().to_string(),
            message,
        };
        match self.sink {
            Sink::Pattern(_) => Ok(()),
            Sink::Gif(tmp, enc, mut shared, _) => {
                // The encoder writes the GIF's trailer when dropped.
                drop(enc);
                shared.flush().map_err(|e| fail(e.to_string()))?;
                drop(shared);
                tmp.commit().map_err(|e| fail(e.to_string()))
            }
            Sink::Apng(tmp, w) => {
                w.finish().map_err(|e| fail(e.to_string()))?;
                tmp.commit().map_err(|e| fail(e.to_string()))
            }
            Sink::Mp4(tmp, mut child) => {
                drop(child.stdin.take());
                let out = child.wait_with_output().map_err(|e| fail(format!("ffmpeg: {e}")))?;
                if !out.status.success() {
                    let msg = String::from_utf8_lossy(&out.stderr);
                    return Err(fail(format!("ffmpeg failed ({}): {}", out.status, msg.trim())));
                }
                tmp.commit().map_err(|e| fail(e.to_string()))
            }
        }
    }
}

/// A file the GIF encoder writes into and the writer flushes once the
/// encoder is gone (so a failed flush is an error, not lost in a drop).
#[derive(Clone)]
struct Shared(std::sync::Arc<std::sync::Mutex<BufWriter<std::fs::File>>>);

impl Write for Shared {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().map_err(|_| std::io::Error::other("poisoned"))?.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.lock().map_err(|_| std::io::Error::other("poisoned"))?.flush()
    }
}

/// An APNG frame delay num/den seconds for `fps` (exact for whole rates
/// up to 65535 and for rates with a few decimals, such as 29.97).
fn frame_delay(fps: f64) -> (u16, u16) {
    if fps.fract() == 0.0 && fps <= 65535.0 {
        return (1, fps as u16);
    }
    for scale in [10.0, 100.0, 1000.0] {
        let den = fps * scale;
        if den.fract().abs() < 1e-9 && den <= 65535.0 && scale <= 65535.0 {
            return (scale as u16, den as u16);
        }
    }
    (((1000.0 / fps).round().clamp(1.0, 65535.0)) as u16, 1000)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_number_frames_with_their_width() {
        assert_eq!(frame_path("f%04d.png", 12), PathBuf::from("f0012.png"));
        assert_eq!(frame_path("f%d.png", 12), PathBuf::from("f12.png"));
        assert_eq!(frame_path("f%02d.png", 1234), PathBuf::from("f1234.png"));
        assert!(SequenceKind::of(Path::new("f%04d.exr")).is_err());
        assert!(SequenceKind::of(Path::new("movie.avi")).is_err());
        assert_eq!(SequenceKind::of(Path::new("x.APNG")), Ok(SequenceKind::Apng));
    }

    #[test]
    fn frame_delays_are_exact_for_common_rates() {
        assert_eq!(frame_delay(24.0), (1, 24));
        assert_eq!(frame_delay(29.97), (100, 2997));
        assert_eq!(frame_delay(12.5), (10, 125));
    }
}
