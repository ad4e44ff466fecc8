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

/// The options of `isoray dent`, as parsed.
pub(crate) struct DentArgs<'a> {
    pub scene: &'a crate::SceneArgs,
    pub object: &'a str,
    pub at: &'a [f64],
    pub normal: &'a [f64],
    pub depth: Option<f64>,
    pub impulse: Option<f64>,
    pub impactor: Option<&'a str>,
    pub radius: f64,
    pub imprint: &'a str,
    pub quiet: bool,
}

fn vec3_arg(v: &[f64], flag: &str) -> Result<[f64; 3], Failure> {
    match v {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(usage(format!("{flag}: expected three numbers X,Y,Z"))),
    }
}

/// Runs `isoray dent`: one impact on a dentable object, its maps read from
/// and written back to the `--maps` folder.
pub(crate) fn cmd_dent(a: &DentArgs) -> Result<(), Failure> {
    use isoray_dent::imprint::{ImprintMethod, Sphere};
    let Some(dir) = a.scene.maps() else {
        return Err(usage(
            "isoray dent needs --maps DIR: the folder its maps are read from and written to".into(),
        ));
    };
    std::fs::create_dir_all(dir).map_err(|e| io_failure(format!("{}: {e}", dir.display())))?;
    let scene = a.scene.load(&[])?;
    let names = || {
        scene
            .objects
            .iter()
            .filter_map(|o| o.name.clone())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let find = |name: &str| {
        scene.object_named(name).ok_or_else(|| {
            usage(format!(
                "`{}` has no object named `{name}` (named objects: {})",
                a.scene.path().display(),
                names()
            ))
        })
    };
    let i = find(a.object)?;
    let obj = &scene.objects[i];
    if obj.physics.dents == isoray_scene::DentMode::None {
        return Err(usage(format!(
            "object `{}` is not dentable: give it dents = \"bump\" and a dent_map = {{ size, range, uv, extent }}",
            a.object
        )));
    }
    let at = vec3_arg(a.at, "--at")?;
    let n = vec3_arg(a.normal, "--normal")?;
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len == 0.0 {
        return Err(usage(
            "--normal: expected a nonzero direction (from the object towards the impactor)".into(),
        ));
    }
    let n = n.map(|c| c / len);
    let material = &scene.materials[obj.material];
    let depth = match (a.depth, a.impulse) {
        (Some(d), None) if d >= 0.0 && d.is_finite() => d,
        (None, Some(j)) if j >= 0.0 && j.is_finite() => {
            isoray_dent::impulse::dent_depth(material.thickness, material.dent_compliance, j, material.restitution)
        }
        (Some(_), Some(_)) => return Err(usage("give --depth or --impulse, not both".into())),
        (None, None) => {
            return Err(usage(
                "give the dent's --depth D (scene units) or the impact's --impulse J (N·s)".into(),
            ))
        }
        _ => return Err(usage("--depth and --impulse take a number ≥ 0".into())),
    };
    let mut maps = obj
        .physics
        .current_maps()
        .map_err(|e| usage(format!("`object.{i}.dent_map`: {e}")))?;
    let place = scene.placement(i);
    let s = place.scale;
    let inputs = &scene.inputs;
    let a_world = |p: [f64; 3]| obj.shape.eval_with(inputs, p);
    let a_local = |q: [f64; 3]| a_world(place.to_world(q)) / s;
    // The impactor in the world, pushed `depth` along −n from its contact pose.
    let push = |p: [f64; 3]| [p[0] + n[0] * depth, p[1] + n[1] * depth, p[2] + n[2] * depth];
    let ball_centre = std::array::from_fn(|k| at[k] + n[k] * (a.radius - depth));
    let b_world: Box<dyn Fn([f64; 3]) -> f64> = match a.impactor {
        None => {
            if !(a.radius > 0.0 && a.radius.is_finite()) {
                return Err(usage("--radius: expected a positive number of scene units".into()));
            }
            let r = a.radius;
            Box::new(move |p: [f64; 3]| {
                let d: [f64; 3] = std::array::from_fn(|k| p[k] - ball_centre[k]);
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - r
            })
        }
        Some(name) => {
            let j = find(name)?;
            if j == i {
                return Err(usage(format!(
                    "`{name}` cannot strike itself: name another object as --impactor"
                )));
            }
            let shape = scene.objects[j].shape.clone();
            let inputs = inputs.clone();
            Box::new(move |p: [f64; 3]| shape.eval_with(&inputs, push(p)))
        }
    };
    let b_local = |q: [f64; 3]| b_world(place.to_world(q)) / s;
    // The impactor's reach around the contact: a ball, or the object's
    // extent from the pushed contact point along 26 directions.
    let reach_world = match a.impactor {
        None => Sphere {
            centre: ball_centre,
            radius: a.radius,
        },
        Some(_) => {
            let start = [
                at[0] - n[0] * depth * 0.5,
                at[1] - n[1] * depth * 0.5,
                at[2] - n[2] * depth * 0.5,
            ];
            let cap = 4.0 * obj.physics.dent_map.extent * s;
            isoray_dent::imprint::reach_of(&|p: [f64; 3]| b_world(p), start, cap, depth)
        }
    };
    let reach = Sphere {
        centre: place.to_local(reach_world.centre),
        radius: reach_world.radius / s,
    };
    let Some(method) = ImprintMethod::from_name(a.imprint) else {
        return Err(usage(format!(
            "--imprint {}: expected {}",
            a.imprint,
            ImprintMethod::NAMES
        )));
    };
    let pixel = obj.physics.dent_map.extent / maps.height.width() as f64;
    let started = std::time::Instant::now();
    let out = maps.imprint(
        method,
        &a_local,
        &b_local,
        place.to_local(at),
        place.dir_to_local(n),
        reach,
        pixel,
    );
    let imprint_ms = started.elapsed().as_secs_f64() * 1e3;
    let started = std::time::Instant::now();
    let normals = maps.update_normals();
    let normal_ms = started.elapsed().as_secs_f64() * 1e3;
    maps.write(dir, a.object).map_err(|e| io_failure(e.to_string()))?;
    if !a.quiet {
        let (h, nm) = isoray_dent::DentMaps::paths(dir, a.object);
        eprintln!(
            "dent of {depth:.6} on `{}` ({} imprint): {} texels lowered, deepest {:.6}, {} normals recomputed; {imprint_ms:.2} ms imprint, {normal_ms:.2} ms normals",
            a.object,
            a.imprint,
            out.lowered,
            out.deepest * s,
            normals
        );
        if maps.height.saturated() > 0 {
            eprintln!(
                "warning: {} texels reached the bottom of the map's range ({} scene units): raise dent_map.range",
                maps.height.saturated(),
                maps.height.range * 0.5 * s
            );
        }
        eprintln!("wrote {} and {}", h.display(), nm.display());
    }
    Ok(())
}
