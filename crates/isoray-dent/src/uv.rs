//! How a dentable body's surface is laid out on its height map: the uv
//! mapping, in the body's own coordinates.
//!
//! Dents need a one-to-one mapping (the thesis, §2.3.1: "a cada texel …
//! una única ubicación en la superficie"): a texel written by one impact
//! must not show up elsewhere on the surface. Each mapping here says where
//! it is one-to-one:
//!
//! - [`UvMapping::Planar`] projects along one axis, from its + side: it maps
//!   the first surface seen from that side (a plane, a terrain, the top of
//!   a box: any height field over the other two axes), one-to-one there;
//!   the far side is not mapped.
//! - [`UvMapping::Spherical`] maps the direction from the body's origin
//!   (longitude, colatitude): one-to-one for a body star-shaped about its
//!   origin (a sphere, an ellipsoid, a box, any convex body around it);
//!   columns wrap around, rows stop at the poles.
//!
//! - [`UvMapping::Parametric`] is a parametric surface's own (s, t),
//!   scaled to [0, 1] over its domain: one-to-one wherever the surface does
//!   not cross itself; the side its ∂X/∂s × ∂X/∂t points to is mapped.
//!
//! Triplanar mapping (three planar projections blended by the normal) is
//! not one-to-one: opposite faces share texels and the blend mixes three of
//! them; it is refused for dents.
//!
//! A texel's tangent frame for normal mapping: T along the columns (+u), B
//! towards row 0 (−v), N out of the surface, as the normal maps store them.

use crate::impulse::V3;
use crate::vec::{cross, dot, normalize, scale, sub};

/// A uv mapping: see the module's documentation.
#[derive(Debug, Clone, PartialEq)]
pub enum UvMapping {
    /// Projection along axis `axis` (0 x, 1 y, 2 z) from its + side, over
    /// the rectangle `min`..`max` of the picture seen from there: columns
    /// go along −z, +x, +x and rows along −y, +z, −y for the x, y and z
    /// axes (so T × B is the axis: row 0 is the top of the view, with +y
    /// up, or −z up looking down y).
    Planar {
        /// The axis projected along.
        axis: usize,
        /// The rectangle's lower corner.
        min: [f64; 2],
        /// The rectangle's upper corner.
        max: [f64; 2],
        /// Where the projection lines start on the axis (beyond the body).
        from: f64,
    },
    /// Longitude and colatitude about the origin: u = atan2(x, z)/2π + ½,
    /// v = acos(y/|p|)/π (row 0 at +y); lines start at radius `from`.
    Spherical {
        /// Where the projection lines start (beyond the body).
        from: f64,
    },
    /// A parametric surface's (s, t), scaled to [0, 1] over its domain
    /// (see [`crate::param`]); lines start just off the surface along its
    /// normal.
    Parametric(crate::param::ParametricUv),
}

/// The picture's column and row directions when looking along −`axis`:
/// (coordinate, sign) each, with column × (−row) = +axis.
fn picture(axis: usize) -> ((usize, f64), (usize, f64)) {
    match axis {
        0 => ((2, -1.0), (1, -1.0)),
        1 => ((0, 1.0), (2, 1.0)),
        _ => ((0, 1.0), (1, -1.0)),
    }
}

impl UvMapping {
    /// The mapping named `name` (`planar-xy`, `planar-xz`, `planar-yz`,
    /// `spherical`) for a body inside the box `lo`..`hi`; `planar-xy`
    /// projects along z, `planar-xz` along y, `planar-yz` along x.
    pub fn named(name: &str, lo: V3, hi: V3) -> Result<UvMapping, String> {
        let planar = |axis: usize| {
            let ((a, sa), (b, sb)) = picture(axis);
            let span = |i: usize, s: f64| {
                let (x, y) = (s * lo[i], s * hi[i]);
                (x.min(y), x.max(y))
            };
            let (ua, ub) = span(a, sa);
            let (va, vb) = span(b, sb);
            UvMapping::Planar {
                axis,
                min: [ua, va],
                max: [ub, vb],
                from: hi[axis] + 1e-3 * (1.0 + (hi[axis] - lo[axis]).abs()),
            }
        };
        match name {
            "planar-yz" => Ok(planar(0)),
            "planar-xz" => Ok(planar(1)),
            "planar-xy" => Ok(planar(2)),
            "spherical" => {
                let r = (0..3)
                    .map(|i| lo[i].abs().max(hi[i].abs()))
                    .map(|c| c * c)
                    .sum::<f64>()
                    .sqrt();
                Ok(UvMapping::Spherical { from: 1.001 * r + 1e-3 })
            }
            "triplanar" => Err(
                "triplanar is not one-to-one (opposite faces share texels, and the blend mixes three): \
                 use spherical for a closed body around its origin, or planar-xy, planar-xz or planar-yz \
                 for a height field"
                    .into(),
            ),
            other => Err(format!(
                "unknown uv mapping `{other}`: expected planar-xy, planar-xz, planar-yz, spherical or parametric"
            )),
        }
    }

    /// Whether the surface point q of normal n is on the mapped side: a
    /// planar map's points face its + side, a spherical map's face away
    /// from the origin. (A planar map's far side would otherwise show the
    /// near side's dents.)
    pub fn faces(&self, q: V3, n: V3) -> bool {
        match *self {
            UvMapping::Planar { axis, .. } => n[axis] > 0.0,
            UvMapping::Spherical { .. } => dot(n, q) > 0.0,
            // Either side of a sheet: its field's normal may point either
            // way; `side` says which the map's dents face.
            UvMapping::Parametric(ref m) => m.invert(q).is_some() && dot(n, n) > 0.0,
        }
    }

    /// +1 when `n` at q points to the side the map's dents are seen from
    /// (always, but for a parametric sheet: the side of ∂X/∂s × ∂X/∂t),
    /// −1 on the other side of a sheet.
    pub fn side(&self, q: V3, n: V3) -> f64 {
        match self {
            UvMapping::Parametric(m) => match m.invert(q) {
                Some(uv) if dot(n, m.normal(uv[0], uv[1])) < 0.0 => -1.0,
                _ => 1.0,
            },
            _ => 1.0,
        }
    }

    /// Whether columns wrap around (the spherical longitude).
    pub fn wraps_columns(&self) -> bool {
        matches!(self, UvMapping::Spherical { .. })
    }

    /// The line (start, unit direction) whose first surface point is the
    /// one at (u, v).
    pub fn line(&self, u: f64, v: f64) -> (V3, V3) {
        match *self {
            UvMapping::Planar { axis, min, max, from } => {
                let ((a, sa), (b, sb)) = picture(axis);
                let mut o = [0.0; 3];
                o[a] = sa * (min[0] + u * (max[0] - min[0]));
                o[b] = sb * (min[1] + v * (max[1] - min[1]));
                o[axis] = from;
                let mut d = [0.0; 3];
                d[axis] = -1.0;
                (o, d)
            }
            UvMapping::Parametric(ref m) => {
                let (p, _, _) = m.point(u, v);
                let n = m.normal(u, v);
                (crate::vec::add(p, scale(n, 1e-3 * m.span())), scale(n, -1.0))
            }
            UvMapping::Spherical { from } => {
                let dir = sphere_dir(u, v);
                (scale(dir, from), scale(dir, -1.0))
            }
        }
    }

    /// The (u, v) of a surface point p (None outside a planar rectangle).
    pub fn uv(&self, p: V3) -> Option<[f64; 2]> {
        match *self {
            UvMapping::Planar { .. } => {
                let [u, v] = self.planar_uv(p)?;
                ((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v)).then_some([u, v])
            }
            UvMapping::Parametric(ref m) => m.invert(p),
            UvMapping::Spherical { .. } => {
                let r = dot(p, p).sqrt();
                if r == 0.0 {
                    return None;
                }
                let u = p[0].atan2(p[2]) / std::f64::consts::TAU + 0.5;
                let v = (p[1] / r).clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
                Some([u.rem_euclid(1.0), v])
            }
        }
    }

    /// A planar mapping's (u, v) of any point p, outside [0, 1] beyond its
    /// rectangle; None for other mappings.
    pub fn planar_uv(&self, p: V3) -> Option<[f64; 2]> {
        let UvMapping::Planar { axis, min, max, .. } = *self else {
            return None;
        };
        let ((a, sa), (b, sb)) = picture(axis);
        Some([
            (sa * p[a] - min[0]) / (max[0] - min[0]),
            (sb * p[b] - min[1]) / (max[1] - min[1]),
        ])
    }

    /// The tangent frame (T along +u, B towards row 0) at surface point p
    /// of normal n: the mapping's directions projected on the tangent plane.
    pub fn frame(&self, p: V3, n: V3) -> (V3, V3) {
        let (du, dv) = match *self {
            UvMapping::Planar { axis, .. } => {
                let ((a, sa), (b, sb)) = picture(axis);
                let mut du = [0.0; 3];
                du[a] = sa;
                let mut dv = [0.0; 3];
                dv[b] = sb;
                (du, dv)
            }
            UvMapping::Parametric(ref m) => match m.invert(p) {
                Some(uv) => {
                    let (_, du, dv) = m.point(uv[0], uv[1]);
                    (du, dv)
                }
                None => ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            },
            UvMapping::Spherical { .. } => {
                // East (growing longitude) and south (growing colatitude).
                let east = [p[2], 0.0, -p[0]];
                let r = dot(p, p).sqrt().max(1e-300);
                let dir = scale(p, 1.0 / r);
                let south = cross(normalize(east), dir);
                (east, south)
            }
        };
        let tangent = |d: V3| normalize(sub(d, scale(n, dot(d, n))));
        let t = tangent(du);
        let mut b = scale(tangent(dv), -1.0);
        if dot(b, b) == 0.0 {
            b = cross(n, t);
        }
        (t, b)
    }
}

/// The unit direction of longitude-colatitude (u, v).
fn sphere_dir(u: f64, v: f64) -> V3 {
    let phi = (u - 0.5) * std::f64::consts::TAU;
    let theta = v * std::f64::consts::PI;
    [theta.sin() * phi.sin(), theta.cos(), theta.sin() * phi.cos()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planar_and_spherical_uvs_invert_their_lines() {
        let lo = [-2.0, -1.0, -3.0];
        let hi = [2.0, 0.0, 3.0];
        for name in ["planar-xz", "planar-xy", "planar-yz", "spherical"] {
            let m = UvMapping::named(name, lo, hi).unwrap();
            for (u, v) in [(0.25, 0.5), (0.9, 0.1), (0.5, 0.75)] {
                let (o, d) = m.line(u, v);
                // A point on the line, past the start.
                let p = [o[0] + 0.3 * d[0], o[1] + 0.3 * d[1], o[2] + 0.3 * d[2]];
                let uv = m.uv(p).unwrap();
                assert!((uv[0] - u).abs() < 1e-12 && (uv[1] - v).abs() < 1e-12, "{name}: {uv:?}");
            }
        }
    }

    #[test]
    fn planar_frames_are_right_handed_about_their_axis() {
        for (name, axis) in [("planar-yz", 0), ("planar-xz", 1), ("planar-xy", 2)] {
            let m = UvMapping::named(name, [-1.0; 3], [1.0; 3]).unwrap();
            let mut n = [0.0; 3];
            n[axis] = 1.0;
            let (t, b) = m.frame([0.0; 3], n);
            assert_eq!(cross(t, b), n, "{name}");
        }
    }

    #[test]
    fn frames_are_right_handed_with_b_towards_row_0() {
        let m = UvMapping::named("planar-xz", [-1.0; 3], [1.0; 3]).unwrap();
        let (t, b) = m.frame([0.0, 1.0, 0.0], [0.0, 1.0, 0.0]);
        assert_eq!(t, [1.0, 0.0, 0.0]);
        assert_eq!(b, [0.0, 0.0, -1.0]);
        assert_eq!(cross(t, b), [0.0, 1.0, 0.0]);
        let s = UvMapping::named("spherical", [-1.0; 3], [1.0; 3]).unwrap();
        let p = normalize([0.3, 0.4, 0.8]);
        let (t, b) = s.frame(p, p);
        let n = cross(t, b);
        assert!((dot(n, p) - 1.0).abs() < 1e-9, "{n:?}");
        // B points north (towards +y, row 0).
        assert!(b[1] > 0.0);
        // T follows growing u.
        let uv0 = s.uv(p).unwrap()[0];
        let uv1 = s.uv(crate::vec::along(p, t, 1e-4)).unwrap()[0];
        assert!(uv1 > uv0);
    }

    #[test]
    fn triplanar_and_unknown_mappings_are_refused_with_reasons() {
        let e = UvMapping::named("triplanar", [-1.0; 3], [1.0; 3]).unwrap_err();
        assert!(e.contains("not one-to-one"), "{e}");
        let e = UvMapping::named("cylindrical", [-1.0; 3], [1.0; 3]).unwrap_err();
        assert!(e.contains("expected planar-xy"), "{e}");
    }
}
