//! `isoray normalmap`: the thesis's height-to-normal converter on its own
//! (isoray-dent's `normalmap`), byte-compatible with its G3D code.

use std::path::Path;

use isoray_dent::heightmap::Rect;
use isoray_dent::normalmap::{heights_of_bytes, NormalMap, NormalMapOptions, Wrap};

use crate::{io_failure, usage, Failure};

/// The options of `isoray normalmap`, as parsed.
pub(crate) struct NormalmapArgs<'a> {
    pub input: &'a Path,
    pub output: &'a Path,
    pub white_height: f32,
    pub wrap: &'a str,
    pub low_pass: bool,
    pub scale_height_by_nz: bool,
    pub rect: Option<&'a str>,
    pub quiet: bool,
}

/// Reads the height PNG: an 8-bit grey image (of an RGB one, the first
/// channel, as G3D reads it); a 16-bit one as value / 65535.
fn read_heights(path: &Path) -> Result<(Vec<f32>, u32, u32), Failure> {
    let img = image::open(path).map_err(|e| match e {
        image::ImageError::IoError(e) => io_failure(format!("{}: {e}", path.display())),
        e => usage(format!("{}: {e}; expected a PNG height map", path.display())),
    })?;
    let (w, h) = (img.width(), img.height());
    let heights = match &img {
        image::DynamicImage::ImageLuma8(g) => heights_of_bytes(g.as_raw()),
        image::DynamicImage::ImageLumaA8(_)
        | image::DynamicImage::ImageRgb8(_)
        | image::DynamicImage::ImageRgba8(_) => {
            let rgba = img.to_rgba8();
            heights_of_bytes(&rgba.pixels().map(|p| p.0[0]).collect::<Vec<u8>>())
        }
        image::DynamicImage::ImageLuma16(_) | image::DynamicImage::ImageLumaA16(_) => {
            img.to_luma16().pixels().map(|p| p.0[0] as f32 / 65535.0).collect()
        }
        other => {
            return Err(usage(format!(
                "{}: a {:?} image; expected an 8-bit grey height map (or 16-bit grey, or RGB whose red is the height)",
                path.display(),
                other.color()
            )))
        }
    };
    Ok((heights, w, h))
}

/// `X0,Y0,X1,Y1` (half-open) inside a `w` × `h` map.
fn parse_rect(text: &str, w: u32, h: u32) -> Result<Rect, Failure> {
    let v: Vec<u32> = text
        .split(',')
        .map(|s| s.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|e| {
            usage(format!(
                "--rect {text}: {e}; expected X0,Y0,X1,Y1 (texels, X1 and Y1 excluded)"
            ))
        })?;
    let [x0, y0, x1, y1] = v[..] else {
        return Err(usage(format!("--rect {text}: expected four numbers X0,Y0,X1,Y1")));
    };
    if x0 >= x1 || y0 >= y1 || x1 > w || y1 > h {
        return Err(usage(format!(
            "--rect {text}: expected 0 <= X0 < X1 <= {w} and 0 <= Y0 < Y1 <= {h} (the map is {w}x{h})"
        )));
    }
    Ok(Rect { x0, y0, x1, y1 })
}

/// Runs `isoray normalmap`.
pub(crate) fn cmd_normalmap(a: &NormalmapArgs) -> Result<(), Failure> {
    let wrap = match a.wrap {
        "repeat" => Wrap::Repeat,
        "clamp" => Wrap::Clamp,
        other => return Err(usage(format!("--wrap {other}: expected repeat or clamp"))),
    };
    if !(a.white_height.is_finite() && a.white_height > 0.0) {
        return Err(usage(format!(
            "--white-height {}: expected a positive number of texels",
            a.white_height
        )));
    }
    let opts = NormalMapOptions {
        white_height: a.white_height,
        wrap,
        low_pass: a.low_pass,
        scale_height_by_nz: a.scale_height_by_nz,
    };
    let (heights, w, h) = read_heights(a.input)?;
    let out = match a.rect {
        None => NormalMap::of(&heights, w, h, &opts),
        Some(text) => {
            // The thesis's fragment: the rectangle alone, its lookups taken
            // over the whole map.
            let r = parse_rect(text, w, h)?;
            let mut whole = NormalMap::flat(w, h);
            whole.compute_rect(&heights, &opts, r);
            let (fw, fh) = (r.x1 - r.x0, r.y1 - r.y0);
            let texels = (0..fh)
                .flat_map(|y| (0..fw).map(move |x| (x, y)))
                .map(|(x, y)| whole.get(r.x0 + x, r.y0 + y))
                .collect();
            NormalMap::from_texels(fw, fh, texels)
        }
    };
    out.write_png(a.output).map_err(|e| io_failure(e.to_string()))?;
    if !a.quiet {
        eprintln!(
            "{}: {}x{} normal map (RGB normal, A height; white height {} texels, {} borders)",
            a.output.display(),
            out.width(),
            out.height(),
            a.white_height,
            a.wrap
        );
    }
    Ok(())
}
