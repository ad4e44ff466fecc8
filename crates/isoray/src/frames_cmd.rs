//! `isoray render --frames A..B` (an animation, optionally one shard of it)
//! and `isoray render --tile I/N` (one band of rows of a still), and
//! `isoray merge` of the bands.

use std::path::{Path, PathBuf};
use std::time::Instant;

use isoray_render::sequence::{frame_path, SequenceKind, SequenceWriter};
use isoray_render::{output, tiles};
use isoray_scene::Scene;

use crate::{io_failure, usage, Backend, Failure, HowToRender, Outputs, Rendered, SceneArgs};

/// Frames `first..=last` (`last` None: to the end of the animation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct FrameRange {
    pub(crate) first: u64,
    pub(crate) last: Option<u64>,
}

/// Parses `A..B` (both included) or `A..` (to the end).
pub(crate) fn parse_frames(s: &str) -> Result<FrameRange, String> {
    let bad = || format!("expected frames A..B (both included) or A.. (to the end of the animation), found `{s}`");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let first = a.trim().parse::<u64>().map_err(|_| bad())?;
    let last = match b.trim() {
        "" => None,
        b => {
            let last = b.parse::<u64>().map_err(|_| bad())?;
            if last < first {
                return Err(format!("frames `{s}`: the last frame comes before the first"));
            }
            Some(last)
        }
    };
    Ok(FrameRange { first, last })
}

/// Part I of N (I from 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Part {
    pub(crate) index: u32,
    pub(crate) count: u32,
}

/// Parses `I/N` with 0 ≤ I < N.
pub(crate) fn parse_part(s: &str) -> Result<Part, String> {
    let bad = || format!("expected I/N with 0 <= I < N (the part, counted from 0, of N), found `{s}`");
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (index, count) = (
        i.trim().parse::<u32>().map_err(|_| bad())?,
        n.trim().parse::<u32>().map_err(|_| bad())?,
    );
    if count == 0 || index >= count {
        return Err(bad());
    }
    Ok(Part { index, count })
}

/// Parses a time in seconds: a number, or a fraction `N/D` (such as `7/24`,
/// the time of frame 7 at 24 frames per second, computed as 7.0 / 24.0).
pub(crate) fn parse_time(s: &str) -> Result<f64, String> {
    let bad = || format!("expected a finite time in seconds, like 1.5 or 7/24, found `{s}`");
    let t = match s.split_once('/') {
        Some((n, d)) => {
            let (n, d) = (
                n.trim().parse::<f64>().map_err(|_| bad())?,
                d.trim().parse::<f64>().map_err(|_| bad())?,
            );
            if d == 0.0 {
                return Err(bad());
            }
            n / d
        }
        None => s.trim().parse::<f64>().map_err(|_| bad())?,
    };
    if !t.is_finite() {
        return Err(bad());
    }
    Ok(t)
}

/// The frames of `range` that part `shard` renders: the range split into
/// `count` contiguous parts as evenly as whole frames allow.
pub(crate) fn shard_frames(first: u64, last: u64, shard: Part) -> std::ops::Range<u64> {
    let n = last - first + 1;
    let at = |i: u32| first + n * u64::from(i) / u64::from(shard.count);
    // An empty part (more parts than frames) is an empty range.
    at(shard.index)..at(shard.index + 1)
}

/// The renderer a run keeps for all its frames.
pub(crate) enum Engine {
    Cpu,
    #[cfg(feature = "gpu")]
    Gpu(Box<crate::gpu_cmd::GpuSession>),
}

impl Engine {
    pub(crate) fn new(how: &HowToRender) -> Result<Engine, Failure> {
        match how.backend {
            Backend::Cpu => Ok(Engine::Cpu),
            #[cfg(feature = "gpu")]
            Backend::Gpu => Ok(Engine::Gpu(Box::new(crate::gpu_cmd::GpuSession::new()?))),
            #[cfg(not(feature = "gpu"))]
            Backend::Gpu => Err(crate::no_gpu()),
        }
    }

    /// Renders one image (`quiet`: no progress bar of its own).
    pub(crate) fn render(
        &mut self,
        scene: &Scene,
        aovs: bool,
        how: &HowToRender,
        quiet: bool,
    ) -> Result<Rendered, Failure> {
        match self {
            Engine::Cpu => crate::render_cpu(scene, aovs, how.threads, quiet),
            #[cfg(feature = "gpu")]
            Engine::Gpu(s) => {
                let how = HowToRender { quiet, ..*how };
                s.render(scene, aovs, &how)
            }
        }
    }
}

/// A progress bar over frames, on a terminal.
pub(crate) fn frame_bar(total: u64, quiet: bool) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    if quiet || !std::io::stderr().is_terminal() {
        return None;
    }
    let b = indicatif::ProgressBar::new(total);
    b.set_style(
        indicatif::ProgressStyle::with_template("{spinner} frames [{bar:40}] {pos}/{len} ({per_sec}), eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    Some(b)
}

/// `isoray render SCENE --frames A..B [--shard I/N] -o OUT`.
pub(crate) fn render_frames(
    input: &SceneArgs,
    overrides: &[String],
    outputs: &Outputs,
    how: &HowToRender,
    range: FrameRange,
    shard: Option<Part>,
) -> Result<(), Failure> {
    if input.time.is_some() {
        return Err(usage(
            "--frames renders each frame n at t = n / fps: leave out --time".into(),
        ));
    }
    let kind = SequenceKind::of(outputs.png).map_err(usage)?;
    if shard.is_some() && !matches!(kind, SequenceKind::Pattern(_)) {
        return Err(usage(format!(
            "--shard writes its own frames: give a numbered pattern such as out/frame_%04d.png, not `{}`",
            outputs.png.display()
        )));
    }
    let aov_paths: Vec<(&Path, &str)> = [
        (outputs.depth, "depth"),
        (outputs.normals, "normals"),
        (outputs.albedo, "albedo"),
    ]
    .into_iter()
    .filter_map(|(p, n)| p.map(|p| (p, n)))
    .collect();
    for (p, name) in &aov_paths {
        let text = p.to_string_lossy();
        if frame_path(&text, 0) == *p || !text.to_lowercase().ends_with(".exr") {
            return Err(usage(format!(
                "--{name} with --frames needs a numbered EXR pattern such as {name}_%04d.exr, found `{text}`"
            )));
        }
    }
    let mut scene = input.load(overrides)?;
    let Some(anim) = scene.animation else {
        return Err(usage(format!(
            "`{}` has no [animation] table: add one with fps and duration, e.g.\n\n[animation]\nfps = 24\nduration = 2.0",
            input.path().display()
        )));
    };
    let last = match range.last {
        Some(l) => l,
        None => {
            let end = anim.frame_count() - 1;
            if range.first > end {
                return Err(usage(format!(
                    "frame {} is past the animation's last frame {end} ({} s at {} fps)",
                    range.first, anim.duration, anim.fps
                )));
            }
            end
        }
    };
    let frames = match shard {
        Some(part) => shard_frames(range.first, last, part),
        None => range.first..last + 1,
    };
    if frames.is_empty() {
        if !how.quiet {
            eprintln!(
                "nothing to render: this shard's part of frames {}..{last} is empty",
                range.first
            );
        }
        return Ok(());
    }
    let count = frames.end - frames.start;
    let (w, h) = (scene.render.width, scene.render.height);
    let mut engine = Engine::new(how)?;
    let mut writer =
        SequenceWriter::create(outputs.png, w, h, anim.fps, count).map_err(|e| io_failure(e.to_string()))?;
    let bar = frame_bar(count, how.quiet);
    let start = Instant::now();
    let mut backend = String::new();
    let aovs = !aov_paths.is_empty();
    for n in frames.clone() {
        scene.set_time(anim.time_of(n))?;
        let r = engine.render(&scene, aovs, how, true)?;
        backend = r.backend;
        writer.push(n, &r.image.color).map_err(|e| io_failure(e.to_string()))?;
        write_aovs(outputs, n, &r.image)?;
        if let Some(b) = &bar {
            b.inc(1);
        }
    }
    let (first, last) = (writer.path_of(frames.start), writer.path_of(frames.end - 1));
    writer.finish().map_err(|e| io_failure(e.to_string()))?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if !how.quiet {
        let secs = start.elapsed().as_secs_f64().max(1e-9);
        let shown = if first == last {
            first.display().to_string()
        } else {
            format!("{} … {}", first.display(), last.display())
        };
        eprintln!(
            "rendered {count} frame{} ({}..{}) of {w}x{h} on {backend} in {secs:.2} s: {:.2} frames/s -> {shown}",
            if count == 1 { "" } else { "s" },
            frames.start,
            frames.end - 1,
            count as f64 / secs
        );
    }
    Ok(())
}

/// Writes frame `n`'s AOVs to their numbered patterns.
fn write_aovs(outputs: &Outputs, n: u64, image: &isoray_render::RenderedImage) -> Result<(), Failure> {
    let writer_path = |pattern: &Path, n: u64| frame_path(&pattern.to_string_lossy(), n);
    let (w, h) = (image.width, image.height);
    let io = |r: Result<(), output::OutputError>| r.map_err(|e| io_failure(e.to_string()));
    if let (Some(p), Some(d)) = (outputs.depth, &image.depth) {
        io(output::write_exr_channel(&writer_path(p, n), w, h, "Z", d))?;
    }
    if let (Some(p), Some(v)) = (outputs.normals, &image.normals) {
        io(output::write_exr_rgb(&writer_path(p, n), w, h, v))?;
    }
    if let (Some(p), Some(v)) = (outputs.albedo, &image.albedo) {
        io(output::write_exr_rgb(&writer_path(p, n), w, h, v))?;
    }
    Ok(())
}

/// `isoray render SCENE --tile I/N -o BAND.png`: band I of N of the still.
pub(crate) fn render_tile(
    input: &SceneArgs,
    overrides: &[String],
    outputs: &Outputs,
    how: &HowToRender,
    part: Part,
) -> Result<(), Failure> {
    if outputs.depth.is_some() || outputs.normals.is_some() || outputs.albedo.is_some() {
        return Err(usage(
            "--tile writes the colour image only: leave out --depth, --normals and --albedo".into(),
        ));
    }
    let ext = outputs.png.extension().map(|e| e.to_string_lossy().to_lowercase());
    if ext.as_deref() != Some("png") {
        return Err(usage(format!(
            "a band is a PNG: `{}` must end in .png",
            outputs.png.display()
        )));
    }
    let scene = input.load(overrides)?;
    let (w, h) = (scene.render.width, scene.render.height);
    let rows = tiles::band(h, part.index, part.count);
    let start = Instant::now();
    let (image, backend) = match how.backend {
        Backend::Cpu => {
            let region = isoray_render::Region {
                x0: 0,
                y0: rows.start,
                width: w,
                height: rows.len() as u32,
            };
            let r = crate::render_region_cpu(&scene, region, how.threads, how.quiet)?;
            (r.image, r.backend)
        }
        // The GPU renders the whole frame; the band is cut from it.
        Backend::Gpu => {
            let r = Engine::new(how)?.render(&scene, false, how, how.quiet)?;
            (r.image, r.backend)
        }
    };
    let lo = rows.start as usize * w as usize;
    let hi = rows.end as usize * w as usize;
    let bytes = isoray_shade::srgb::to_srgb8(&image.color[lo..hi]);
    let info = tiles::TileInfo {
        index: part.index,
        count: part.count,
        width: w,
        height: h,
    };
    tiles::write_band(outputs.png, info, &bytes).map_err(|e| io_failure(e.to_string()))?;
    if !how.quiet {
        eprintln!(
            "rendered band {} of {} (rows {}..{} of {w}x{h}) on {backend} in {:.2} s -> {}",
            part.index,
            part.count,
            rows.start,
            rows.end,
            start.elapsed().as_secs_f64(),
            outputs.png.display()
        );
    }
    Ok(())
}

/// `isoray merge BAND… -o OUT.png`.
pub(crate) fn cmd_merge(bands: &[PathBuf], out: &Path, quiet: bool) -> Result<(), Failure> {
    let ext = out.extension().map(|e| e.to_string_lossy().to_lowercase());
    if ext.as_deref() != Some("png") {
        return Err(usage(format!(
            "the merged image is a PNG: `{}` must end in .png",
            out.display()
        )));
    }
    let paths: Vec<&Path> = bands.iter().map(|p| p.as_path()).collect();
    let (w, h) = tiles::merge(&paths, out).map_err(|e| match e {
        tiles::MergeError::Output(e) => io_failure(e.to_string()),
        other => usage(other.to_string()),
    })?;
    if !quiet {
        eprintln!("merged {} bands into {w}x{h} -> {}", bands.len(), out.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_split_a_range_into_contiguous_parts_that_cover_it_once() {
        for (first, last, n) in [(0u64, 47u64, 4u32), (3, 10, 3), (0, 2, 5), (5, 5, 1)] {
            let mut all = vec![];
            for i in 0..n {
                all.extend(shard_frames(first, last, Part { index: i, count: n }));
            }
            assert_eq!(all, (first..=last).collect::<Vec<_>>(), "{first}..{last} in {n}");
        }
        assert_eq!(shard_frames(0, 47, Part { index: 1, count: 4 }), 12..24);
    }

    #[test]
    fn frame_ranges_times_and_parts_parse_or_say_what_was_expected() {
        assert_eq!(
            parse_frames("2..5"),
            Ok(FrameRange {
                first: 2,
                last: Some(5)
            })
        );
        assert_eq!(parse_frames("7.."), Ok(FrameRange { first: 7, last: None }));
        assert!(parse_frames("5..2").unwrap_err().contains("before the first"));
        assert!(parse_frames("a..b").is_err());
        assert_eq!(parse_part("1/4"), Ok(Part { index: 1, count: 4 }));
        assert!(parse_part("4/4").is_err());
        assert_eq!(parse_time("7/24"), Ok(7.0 / 24.0));
        assert_eq!(parse_time("-1.5"), Ok(-1.5));
        assert!(parse_time("1/0").is_err());
    }
}
