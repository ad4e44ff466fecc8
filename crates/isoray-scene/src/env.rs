//! Environment maps: what rays that leave the scene see, as a background and
//! in reflections and refractions.
//!
//! An equirectangular map covers all directions: column u ∈ [0, 1) is the
//! longitude φ = 2π(u − ½) measured from −z towards +x, row v ∈ [0, 1] the
//! polar angle θ = πv from +y, so the direction (sin θ sin φ, cos θ,
//! −sin θ cos φ) is at (u, v); the centre of the image is straight ahead
//! (−z) and its top row straight up. A cube map has six square faces named
//! by the axis they face (px, nx, py, ny, pz, nz), in the usual layout of
//! OpenGL cube maps. `rotation` turns the environment about +y
//! (right-handed, degrees); `intensity` scales it. Images are linear RGB:
//! Radiance `.hdr` and OpenEXR `.exr` as stored, 8-bit `.png` decoded from sRGB.

use std::path::Path;
use std::sync::Arc;

/// A linear RGB image.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major pixels, top row first.
    pub pixels: Vec<[f32; 3]>,
}

impl RgbImage {
    /// Bilinear lookup at (u, v) ∈ [0, 1]², pixel centres at (i + ½)/w;
    /// u wraps around, v is clamped.
    pub fn bilinear(&self, u: f32, v: f32) -> [f32; 3] {
        let (w, h) = (self.width as f32, self.height as f32);
        let x = u * w - 0.5;
        let y = (v * h - 0.5).clamp(0.0, h - 1.0);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let wrap = |i: f32| (i as i64).rem_euclid(self.width as i64) as usize;
        let row = |j: f32| (j as usize).min(self.height as usize - 1);
        let px = |i: f32, j: f32| self.pixels[row(j) * self.width as usize + wrap(i)];
        let (a, b, c, d) = (px(x0, y0), px(x0 + 1.0, y0), px(x0, y0 + 1.0), px(x0 + 1.0, y0 + 1.0));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }
}

/// The picture of an environment.
#[derive(Debug, Clone, PartialEq)]
pub enum EnvMap {
    /// One equirectangular image.
    Equirect(Arc<RgbImage>),
    /// Six square faces: +x, −x, +y, −y, +z, −z.
    Cube(Arc<[RgbImage; 6]>),
    /// A sky gradient: `horizon` at y = 0, blending linearly in the height y
    /// of the direction to `zenith` straight up and to `nadir` straight down.
    Gradient {
        /// Straight up.
        zenith: [f32; 3],
        /// At the horizon.
        horizon: [f32; 3],
        /// Straight down.
        nadir: [f32; 3],
    },
}

/// The environment of a scene (`[environment]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Environment {
    /// The picture.
    pub map: EnvMap,
    /// Turn about +y, degrees.
    pub rotation: f64,
    /// Multiplies the picture.
    pub intensity: f64,
}

/// The (u, v) of a unit direction in an equirectangular map (see the module documentation).
pub fn equirect_uv(d: [f32; 3]) -> (f32, f32) {
    let u = 0.5 + d[0].atan2(-d[2]) / std::f32::consts::TAU;
    let v = d[1].clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
    (u, v)
}

/// The unit direction at (u, v) of an equirectangular map.
pub fn equirect_direction(u: f64, v: f64) -> [f64; 3] {
    let phi = (u - 0.5) * std::f64::consts::TAU;
    let theta = v * std::f64::consts::PI;
    [theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos()]
}

/// The cube face (0..6: +x, −x, +y, −y, +z, −z) and (u, v) of a direction
/// (OpenGL cube-map convention).
pub fn cube_uv(d: [f32; 3]) -> (usize, f32, f32) {
    let [x, y, z] = d;
    let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
    let (face, sc, tc, ma) = if ax >= ay && ax >= az {
        if x > 0.0 {
            (0, -z, -y, ax)
        } else {
            (1, z, -y, ax)
        }
    } else if ay >= az {
        if y > 0.0 {
            (2, x, z, ay)
        } else {
            (3, x, -z, ay)
        }
    } else if z > 0.0 {
        (4, x, -y, az)
    } else {
        (5, -x, -y, az)
    };
    let ma = ma.max(1e-30);
    (face, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0))
}

impl Environment {
    /// The light arriving from unit direction `d` (towards the environment).
    pub fn radiance(&self, d: [f32; 3]) -> [f32; 3] {
        // Turning the environment by +r is looking it up at the direction turned by −r.
        let (s, c) = (-(self.rotation as f32).to_radians()).sin_cos();
        let d = [c * d[0] + s * d[2], d[1], -s * d[0] + c * d[2]];
        let k = self.intensity as f32;
        let rgb = match &self.map {
            EnvMap::Equirect(img) => {
                let (u, v) = equirect_uv(d);
                img.bilinear(u, v)
            }
            EnvMap::Cube(faces) => {
                let (f, u, v) = cube_uv(d);
                faces[f].bilinear(u.clamp(0.0, 1.0), v)
            }
            EnvMap::Gradient { zenith, horizon, nadir } => {
                let (to, w) = if d[1] >= 0.0 { (zenith, d[1]) } else { (nadir, -d[1]) };
                let w = w.clamp(0.0, 1.0);
                std::array::from_fn(|k| horizon[k] + (to[k] - horizon[k]) * w)
            }
        };
        rgb.map(|x| x * k)
    }
}

/// sRGB to linear.
fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Reads an image as linear RGB: `.hdr` and `.exr` as stored, `.png` from sRGB.
pub fn read_image(path: &Path) -> Result<RgbImage, String> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "exr" => {
            let img = exr::prelude::read_first_rgba_layer_from_file(
                path,
                |res, _| {
                    let (w, h) = (res.width(), res.height());
                    (w, vec![[0.0f32; 3]; w * h])
                },
                |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                    px[pos.y() * *w + pos.x()] = [r, g, b];
                },
            )
            .map_err(|e| e.to_string())?;
            let size = img.layer_data.size;
            Ok(RgbImage {
                width: size.width() as u32,
                height: size.height() as u32,
                pixels: img.layer_data.channel_data.pixels.1,
            })
        }
        "hdr" | "png" => {
            let dynamic = image::open(path).map_err(|e| e.to_string())?;
            let (w, h) = (dynamic.width(), dynamic.height());
            let pixels = if ext == "hdr" {
                dynamic.to_rgb32f().pixels().map(|p| p.0).collect()
            } else {
                dynamic.to_rgb8().pixels().map(|p| p.0.map(srgb_to_linear)).collect()
            };
            Ok(RgbImage {
                width: w,
                height: h,
                pixels,
            })
        }
        _ => Err(format!(
            "unsupported image format `.{ext}`: expected .hdr, .exr or .png"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equirect_directions_round_trip() {
        for (u, v) in [(0.5, 0.5), (0.75, 0.5), (0.25, 0.3), (0.1, 0.9)] {
            let d = equirect_direction(u, v);
            let (u2, v2) = equirect_uv(d.map(|x| x as f32));
            assert!(
                (u2 as f64 - u).abs() < 1e-5 && (v2 as f64 - v).abs() < 1e-5,
                "{u} {v}: {u2} {v2}"
            );
        }
        // The centre is straight ahead (−z); a quarter turn right is +x; the top row is up.
        let ahead = equirect_direction(0.5, 0.5);
        assert!((ahead[2] + 1.0).abs() < 1e-12);
        assert!((equirect_direction(0.75, 0.5)[0] - 1.0).abs() < 1e-12);
        assert!((equirect_direction(0.3, 0.0)[1] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn gradient_sky_blends_by_height() {
        let env = Environment {
            map: EnvMap::Gradient {
                zenith: [0.0, 0.0, 1.0],
                horizon: [1.0, 1.0, 1.0],
                nadir: [0.0, 0.0, 0.0],
            },
            rotation: 45.0,
            intensity: 1.0,
        };
        assert_eq!(env.radiance([0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
        assert_eq!(env.radiance([1.0, 0.0, 0.0]), [1.0, 1.0, 1.0]);
        assert_eq!(env.radiance([0.0, -1.0, 0.0]), [0.0, 0.0, 0.0]);
        let half = env.radiance([0.0, 0.5, 0.866]);
        assert!((half[0] - 0.5).abs() < 1e-6 && (half[2] - 1.0).abs() < 1e-6, "{half:?}");
    }

    #[test]
    fn cube_faces_follow_the_axes() {
        assert_eq!(cube_uv([1.0, 0.0, 0.0]), (0, 0.5, 0.5));
        assert_eq!(cube_uv([0.0, -1.0, 0.0]).0, 3);
        assert_eq!(cube_uv([0.0, 0.0, -1.0]), (5, 0.5, 0.5));
        // +x face: −z is to the right (u grows), +y up (v shrinks).
        let (_, u, v) = cube_uv([1.0, 0.5, -0.5]);
        assert!(u > 0.5 && v < 0.5);
    }

    #[test]
    fn rotation_turns_the_environment() {
        // A map that is bright only straight ahead (−z).
        let mut img = RgbImage {
            width: 8,
            height: 4,
            pixels: vec![[0.0; 3]; 32],
        };
        for j in 1..3 {
            img.pixels[j * 8 + 3] = [1.0; 3];
            img.pixels[j * 8 + 4] = [1.0; 3];
        }
        let mut env = Environment {
            map: EnvMap::Equirect(Arc::new(img)),
            rotation: 0.0,
            intensity: 2.0,
        };
        assert!(env.radiance([0.0, 0.0, -1.0])[0] > 1.9);
        assert!(env.radiance([-1.0, 0.0, 0.0])[0] < 0.1);
        // Turned 90° about +y (counter-clockwise seen from above), "ahead" moves to −x.
        env.rotation = 90.0;
        assert!(
            env.radiance([-1.0, 0.0, 0.0])[0] > 1.9,
            "{:?}",
            env.radiance([-1.0, 0.0, 0.0])
        );
        assert!(env.radiance([0.0, 0.0, -1.0])[0] < 0.1);
    }
}
