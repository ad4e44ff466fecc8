//! Imprints: where a struck body A is pressed by an impactor B, lower A's
//! height map by how deep B reaches into A's surface. Everything here is in
//! A's own coordinates (the caller maps B and the contact there).
//!
//! Two methods:
//!
//! - [`imprint_texel`] (isoray's default): for each texel near the impact,
//!   the surface point P₀ it stands for (the mapping's line to A's
//!   surface) and A's normal N there; where the current (dented) surface
//!   point lies inside B, march along −N until B is left: the dent there
//!   is deepened to that point. Depth is measured along the true surface
//!   normal, each texel once: no framing, no direction error.
//! - [`imprint_ortho`] (the thesis's, §2.4.1–2.4.2, for comparison): an
//!   orthographic camera on the contact looking along −N_C, one ray per
//!   pixel; A's front surface (offset by its current dent along the view
//!   axis) and B's back surface beyond it give ΔD; the texel the pixel
//!   addresses is lowered by ΔD (measured along N_C: the thesis's
//!   acknowledged direction error, or ΔD·(N·N_C) with
//!   `project_on_normal`, its suggested fix). Where several pixels address
//!   one texel the deepest wins ([`HeightMap::lower_min`]).

use crate::field::{exit, first_hit, Field, March};
use crate::heightmap::{HeightMap, Rect};
use crate::impulse::V3;
use crate::uv::UvMapping;
use crate::vec::{along, cross, dot, length, normalize, scale, sub};

/// How an impact's depth is measured (`--imprint`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ImprintMethod {
    /// Along the struck surface's normal, texel by texel (isoray's): [`imprint_texel`].
    #[default]
    Texel,
    /// The thesis's orthographic depth passes along the impact: [`imprint_ortho`].
    Ortho,
    /// Those, scaled by N·N_C.
    OrthoProjected,
}

impl ImprintMethod {
    /// The names of the methods, as `--imprint` takes them.
    pub const NAMES: &'static str =
        "texel (along the surface normal), ortho (the thesis's) or ortho-projected (the thesis's with its N·N_C fix)";

    /// The method named `texel`, `ortho` or `ortho-projected`.
    pub fn from_name(name: &str) -> Option<ImprintMethod> {
        match name {
            "texel" => Some(ImprintMethod::Texel),
            "ortho" => Some(ImprintMethod::Ortho),
            "ortho-projected" => Some(ImprintMethod::OrthoProjected),
            _ => None,
        }
    }
}

/// A bounding sphere (of the impactor at its pushed pose).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Its centre.
    pub centre: V3,
    /// Its radius.
    pub radius: f64,
}

/// What an imprint did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Imprint {
    /// Texels (or pixels, for the ortho method) examined.
    pub examined: u64,
    /// Texels lowered.
    pub lowered: u64,
    /// The rectangle of lowered texels (None: nothing changed).
    pub rect: Option<Rect>,
    /// The deepest dent written, in A's units.
    pub deepest: f64,
}

impl Imprint {
    fn record(&mut self, x: u32, y: u32, depth: f64) {
        self.lowered += 1;
        let r = Rect::texel(x, y);
        self.rect = Some(self.rect.map_or(r, |d| d.union(r)));
        self.deepest = self.deepest.max(depth);
    }
}

/// The rectangles of texels whose surface points may lie within `reach`
/// (a superset; two where a spherical map's columns wrap around).
pub fn texels_near(mapping: &UvMapping, w: u32, h: u32, reach: Sphere) -> Vec<Rect> {
    let all = vec![Rect::new(0, 0, w, h)];
    let texel_range = |lo: f64, hi: f64, n: u32| -> (u32, u32) {
        let a = (lo * n as f64).floor().max(0.0) as u32;
        let b = ((hi * n as f64).ceil().max(0.0) as u32).min(n);
        (a.min(n), b)
    };
    match *mapping {
        UvMapping::Planar { .. } => {
            // The sphere's shadow on the picture: its centre's uv ± its radius.
            let (Some(extent), Some(c)) = (planar_extent(mapping), mapping.planar_uv(reach.centre)) else {
                return all;
            };
            let (du, dv) = (reach.radius / extent[0], reach.radius / extent[1]);
            let (x0, x1) = texel_range(c[0] - du, c[0] + du, w);
            let (y0, y1) = texel_range(c[1] - dv, c[1] + dv, h);
            vec![Rect::new(x0, y0, x1, y1)]
        }
        UvMapping::Parametric(ref m) => match m.uv_box_near(reach.centre, reach.radius) {
            None => Vec::new(),
            Some(b) => {
                let (x0, x1) = texel_range(b[0], b[2], w);
                let (y0, y1) = texel_range(b[1], b[3], h);
                vec![Rect::new(x0, y0, x1, y1)]
            }
        },
        UvMapping::Spherical { .. } => {
            let dist = length(reach.centre);
            if dist <= reach.radius {
                return all;
            }
            let alpha = (reach.radius / dist).asin();
            let theta = (reach.centre[1] / dist).clamp(-1.0, 1.0).acos();
            let pi = std::f64::consts::PI;
            let (y0, y1) = texel_range((theta - alpha) / pi, (theta + alpha) / pi, h);
            if theta - alpha <= 0.0 || theta + alpha >= pi {
                return vec![Rect::new(0, y0, w, y1)];
            }
            let dphi = (alpha.sin() / theta.sin()).clamp(-1.0, 1.0).asin();
            let u = mapping.uv(reach.centre).map_or(0.0, |uv| uv[0]);
            let span = dphi / std::f64::consts::TAU;
            let first = ((u - span) * w as f64).floor() as i64;
            let last = ((u + span) * w as f64).ceil() as i64;
            let w64 = w as i64;
            if last - first >= w64 {
                vec![Rect::new(0, y0, w, y1)]
            } else if first < 0 {
                vec![
                    Rect::new(0, y0, last as u32, y1),
                    Rect::new((first + w64) as u32, y0, w, y1),
                ]
            } else if last > w64 {
                vec![
                    Rect::new(first as u32, y0, w, y1),
                    Rect::new(0, y0, (last - w64) as u32, y1),
                ]
            } else {
                vec![Rect::new(first as u32, y0, last as u32, y1)]
            }
        }
    }
}

/// A bounding sphere of the part of impactor `b` near a contact: from
/// `start` (a point inside `b`, near the contact), the farthest of its
/// exits along 26 directions (capped at `cap`), plus `margin`. Exact for a
/// ball whose centre is `start`; a generous bound for convex impactors
/// seen from inside.
pub fn reach_of(b: &dyn Field, start: V3, cap: f64, margin: f64) -> Sphere {
    let mut r: f64 = 0.0;
    for dx in -1..=1 {
        for dy in -1..=1 {
            for dz in -1..=1 {
                if (dx, dy, dz) == (0, 0, 0) {
                    continue;
                }
                let d = normalize([dx as f64, dy as f64, dz as f64]);
                r = r.max(exit(b, start, d, cap, March::default()));
            }
        }
    }
    Sphere {
        centre: start,
        radius: r + margin,
    }
}

/// A bounding sphere of the overlap of `a` and `b` (where both are
/// negative) at a contact, for a dent cut into geometry: `b` overlaps `a`
/// by `depth` below `contact` along −`n` (`n` points from `a` towards
/// `b`). The overlap is probed from the points of that line inside both
/// (2 %, 25 %, 50 %, 75 % and 98 % of the depth down, and −50 %, 150 %,
/// −200 % and 300 % for a contact point off the surfaces), each along 82 directions (16
/// across `n` at each of the elevations 0°, ±30° and ±60°, and ±`n`), to
/// its exit (capped at `cap`); the sphere is centred half way down and
/// reaches the farthest exit, grown by a quarter (for what falls between
/// the directions) and `margin`. A shallow cap is widest at the top, which
/// the first point sees. None when no probe point is inside both.
pub fn overlap_bound(
    a: &dyn Field,
    b: &dyn Field,
    contact: V3,
    n: V3,
    depth: f64,
    cap: f64,
    margin: f64,
) -> Option<Sphere> {
    let both = |p: V3| a.distance(p).max(b.distance(p));
    let n = normalize(n);
    let helper = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let t = normalize(cross(n, helper));
    let u = cross(n, t);
    let mut dirs = vec![n, scale(n, -1.0)];
    for e in [-60.0f64, -30.0, 0.0, 30.0, 60.0] {
        let (se, ce) = e.to_radians().sin_cos();
        for k in 0..16 {
            let (sa, ca) = (k as f64 * std::f64::consts::PI / 8.0).sin_cos();
            dirs.push(std::array::from_fn(|i| ce * (ca * t[i] + sa * u[i]) + se * n[i]));
        }
    }
    let centre = along(contact, n, -0.5 * depth);
    let mut r: Option<f64> = None;
    // Points above and below the expected overlap too: a contact point
    // off the surfaces by more than the depth still finds it.
    for f in [0.02, 0.25, 0.5, 0.75, 0.98, -0.5, 1.5, -2.0, 3.0] {
        let start = along(contact, n, -f * depth);
        if both(start) >= 0.0 {
            continue;
        }
        for &d in &dirs {
            let e = along(start, d, exit(&both, start, d, cap, March::default()));
            let reach = length(sub(e, centre));
            r = Some(r.map_or(reach, |r: f64| r.max(reach)));
        }
    }
    r.map(|r| Sphere {
        centre,
        radius: 1.25 * r + margin,
    })
}

/// The side of the smallest blocks of texels the texel imprint skips at once.
const BLOCK: u32 = 8;

/// The picture's width and height (scene units) of a planar mapping.
fn planar_extent(m: &UvMapping) -> Option<[f64; 2]> {
    match *m {
        UvMapping::Planar { min, max, .. } => Some([max[0] - min[0], max[1] - min[1]]),
        _ => None,
    }
}

/// The surface point of texel (x, y).
fn texel_surface(map: &HeightMap, mapping: &UvMapping, a: &dyn Field, x: u32, y: u32, m: March) -> Option<V3> {
    let (u, v) = (
        (x as f64 + 0.5) / map.width() as f64,
        (y as f64 + 0.5) / map.height() as f64,
    );
    let (o, d) = mapping.line(u, v);
    let reach = 2.0 * length(o).max(1.0) + 4.0 * map.range;
    let t = first_hit(a, o, d, reach, m)?;
    Some(along(o, d, t))
}

/// A step for normals: a tenth of a texel's size in scene units, at least 1e-6.
fn normal_step(map: &HeightMap, mapping: &UvMapping) -> f64 {
    let texel = match planar_extent(mapping) {
        Some(e) => (e[0] / map.width() as f64).min(e[1] / map.height() as f64),
        None => 1.0 / map.height() as f64,
    };
    (0.1 * texel).max(1e-6)
}

/// The texel method: see the module's documentation. `reach` bounds the
/// impactor `b` at its pushed pose.
pub fn imprint_texel(
    map: &mut HeightMap,
    mapping: &UvMapping,
    a: &dyn Field,
    b: &dyn Field,
    reach: Sphere,
    m: March,
) -> Imprint {
    let mut out = Imprint::default();
    let step = normal_step(map, mapping);
    for rect in texels_near(mapping, map.width(), map.height(), reach) {
        // A quadtree over the candidates: blocks B cannot reach are
        // skipped whole, the rest split down to BLOCK × BLOCK texels.
        let mut stack = vec![rect];
        while let Some(block) = stack.pop() {
            if block.is_empty() {
                continue;
            }
            if !block_may_be_reached(map, mapping, a, b, block, m) {
                out.examined += block.area();
                continue;
            }
            let (w, h) = (block.x1 - block.x0, block.y1 - block.y0);
            if w > BLOCK || h > BLOCK {
                let (mx, my) = (block.x0 + w.div_ceil(2), block.y0 + h.div_ceil(2));
                stack.push(Rect::new(block.x0, block.y0, mx, my));
                stack.push(Rect::new(mx, block.y0, block.x1, my));
                stack.push(Rect::new(block.x0, my, mx, block.y1));
                stack.push(Rect::new(mx, my, block.x1, block.y1));
                continue;
            }
            for y in block.y0..block.y1 {
                for x in block.x0..block.x1 {
                    out.examined += 1;
                    imprint_one(map, mapping, a, b, (x, y), step, reach, m, &mut out);
                }
            }
        }
    }
    out
}

/// Whether B may reach a surface point of `block`: B (1-Lipschitz) at the
/// block's middle texel against the block's radius (its corners' surface
/// points, and a texel's diagonal more) and its deepest dent.
fn block_may_be_reached(
    map: &HeightMap,
    mapping: &UvMapping,
    a: &dyn Field,
    b: &dyn Field,
    block: Rect,
    m: March,
) -> bool {
    let mid = (block.x0 + block.x1) / 2;
    let mid_y = (block.y0 + block.y1) / 2;
    let Some(centre) = texel_surface(map, mapping, a, mid, mid_y, m) else {
        return true;
    };
    let mut radius: f64 = 0.0;
    for (x, y) in [
        (block.x0, block.y0),
        (block.x1 - 1, block.y0),
        (block.x0, block.y1 - 1),
        (block.x1 - 1, block.y1 - 1),
    ] {
        match texel_surface(map, mapping, a, x, y, m) {
            Some(p) => radius = radius.max(length(sub(p, centre))),
            None => return true,
        }
    }
    // The corners' distances, plus the corner texels' own reach (half a
    // texel each way, as far as a corner is from its neighbour).
    let side = (block.x1 - block.x0).min(block.y1 - block.y0).max(1);
    radius *= 1.0 + 2.0 / side as f64;
    let deepest = map.deepest();
    b.distance(centre) < radius + deepest + m.epsilon
}

/// The texel method at one texel.
#[allow(clippy::too_many_arguments)]
fn imprint_one(
    map: &mut HeightMap,
    mapping: &UvMapping,
    a: &dyn Field,
    b: &dyn Field,
    (x, y): (u32, u32),
    step: f64,
    reach: Sphere,
    m: March,
    out: &mut Imprint,
) {
    let Some(p0) = texel_surface(map, mapping, a, x, y, m) else {
        return;
    };
    let current = -map.displacement(x, y);
    // B is 1-Lipschitz: farther from p0 than the dent is deep, it cannot
    // reach the dented surface point (no normal needed to know).
    if b.distance(p0) >= current.abs() - m.epsilon {
        return;
    }
    // Outward on the mapped side: against the texel's line into the
    // surface (a parametric sheet's field may point either way).
    let mut n = a.normal(p0, step);
    let (_, into) = mapping.line(
        (x as f64 + 0.5) / map.width() as f64,
        (y as f64 + 0.5) / map.height() as f64,
    );
    if dot(n, into) > 0.0 {
        n = scale(n, -1.0);
    }
    let q = along(p0, n, -current);
    if b.distance(q) >= -m.epsilon {
        return;
    }
    let deeper = exit(b, q, scale(n, -1.0), 2.0 * reach.radius, m);
    let depth = current + deeper;
    if map.lower_min(x, y, map.value_of(-depth)) {
        out.record(x, y, depth);
    }
}

/// Options of the thesis's ortho imprint.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OrthoOptions {
    /// Scale ΔD by N·N_C (the thesis's suggested fix of its direction error).
    pub project_on_normal: bool,
}

/// The ortho camera's up vector for a view along `look` (Anexo 7): +y,
/// or +x when |y·look| > 0.9 (within 25.84° of the y axis).
pub fn ortho_up(look: V3) -> V3 {
    if dot([0.0, 1.0, 0.0], normalize(look)).abs() > 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    }
}

/// The thesis's ortho imprint: a camera at the contact `contact` looking
/// along −`n_c` (`n_c` from A towards B), its square viewport fitted to
/// `reach` (the smaller body's bounds), one ray per pixel of side `pixel`.
#[allow(clippy::too_many_arguments)]
pub fn imprint_ortho(
    map: &mut HeightMap,
    mapping: &UvMapping,
    a: &dyn Field,
    b: &dyn Field,
    contact: V3,
    n_c: V3,
    reach: Sphere,
    pixel: f64,
    opts: OrthoOptions,
    m: March,
) -> Imprint {
    let mut out = Imprint::default();
    let n_c = normalize(n_c);
    let look = scale(n_c, -1.0);
    let right = normalize(cross(look, ortho_up(look)));
    let up = cross(right, look);
    // The camera plane beyond B, centred on the reach's projection.
    let back = dot(sub(reach.centre, contact), n_c).max(0.0) + 2.0 * reach.radius + 1e-3;
    let centre = along(contact, n_c, back);
    let side = sub(reach.centre, contact);
    let centre = along(along(centre, right, dot(side, right)), up, dot(side, up));
    let n = ((2.0 * reach.radius / pixel).ceil() as i64).max(1);
    let tmax = back + 4.0 * reach.radius + 4.0 * map.range;
    // Every pixel sees the map as it was before this impact (the thesis
    // draws the old bump map, then composites the new heights).
    let before = map.clone();
    let step = normal_step(map, mapping);
    for j in 0..n {
        for i in 0..n {
            out.examined += 1;
            let sx = (i as f64 + 0.5) * pixel - reach.radius;
            let sy = (j as f64 + 0.5) * pixel - reach.radius;
            let o = along(along(centre, right, sx), up, sy);
            let Some(ta) = first_hit(a, o, look, tmax, m) else {
                continue;
            };
            let hit = along(o, look, ta);
            let Some(uv) = mapping.uv(hit) else { continue };
            let x = ((uv[0] * map.width() as f64) as u32).min(map.width() - 1);
            let y = ((uv[1] * map.height() as f64) as u32).min(map.height() - 1);
            let current = -before.displacement(x, y);
            // A's front surface moved back by its dent along the view axis.
            let da = ta + current;
            let at = along(o, look, da);
            if b.distance(at) >= -m.epsilon {
                continue;
            }
            let mut delta = exit(b, at, look, 2.0 * reach.radius, m);
            if opts.project_on_normal {
                delta *= dot(a.normal(hit, step), n_c).abs();
            }
            let depth = current + delta;
            if map.lower_min(x, y, map.value_of(-depth)) {
                out.record(x, y, depth);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// dents.md §2.5, KAT 7: the up vector switches at 25.84° from +y.
    #[test]
    fn the_ortho_up_vector_falls_back_to_x_near_the_y_axis() {
        assert_eq!(ortho_up([0.0, -1.0, 0.0]), [1.0, 0.0, 0.0]);
        assert_eq!(ortho_up([0.0, 0.0, -1.0]), [0.0, 1.0, 0.0]);
        let tilt = |deg: f64| [deg.to_radians().sin(), -deg.to_radians().cos(), 0.0];
        assert_eq!(ortho_up(tilt(25.0)), [1.0, 0.0, 0.0]);
        assert_eq!(ortho_up(tilt(26.0)), [0.0, 1.0, 0.0]);
    }
}
