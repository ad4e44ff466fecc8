//! The (s, t) mapping of a parametric surface X(s, t): u and v are s and t
//! scaled to [0, 1] over the domain, one-to-one wherever X is (the
//! thesis's precondition, §1.9, holds by construction for a surface that
//! does not cross itself). X is sampled once on a grid; a point's (u, v) is
//! its nearest sample refined by Gauss–Newton on the grid's bilinear
//! patches, found through a spatial hash, so shading a hit costs a few
//! dozen operations and never evaluates X.

use std::collections::HashMap;
use std::sync::Arc;

use crate::impulse::V3;
use crate::vec::{add, cross, dot, length, scale, sub};

/// A parametric surface sampled for its (s, t) mapping; cheap to clone.
#[derive(Clone)]
pub struct ParametricUv(Arc<Grid>);

struct Grid {
    name: String,
    /// Samples per side.
    n: usize,
    /// X at (u, v) = (i, j) / (n − 1), row-major in j.
    pts: Vec<V3>,
    /// Side of the spatial hash's cells.
    cell: f64,
    /// Sample indices per cell.
    hash: HashMap<[i64; 3], Vec<u32>>,
    /// The mean length of the u and v lines.
    span: f64,
}

impl std::fmt::Debug for ParametricUv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ParametricUv({:?}, {} samples a side)", self.0.name, self.0.n)
    }
}

impl PartialEq for ParametricUv {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl ParametricUv {
    /// Samples `x(u, v)` (u, v in [0, 1]) on an n × n grid. An error where
    /// a sample is undefined (a pole of a rational parametrisation) or the
    /// surface has no extent.
    pub fn new(name: &str, n: usize, mut x: impl FnMut(f64, f64) -> Option<V3>) -> Result<ParametricUv, String> {
        let n = n.max(2);
        let mut pts = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                let (u, v) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
                let p = x(u, v)
                    .filter(|p| p.iter().all(|c| c.is_finite()))
                    .ok_or_else(|| format!("the parametric surface `{name}` is undefined at (u, v) = ({u}, {v})"))?;
                pts.push(p);
            }
        }
        let at = |i: usize, j: usize| pts[j * n + i];
        let (mut longest, mut total_u, mut total_v) = (0.0f64, 0.0, 0.0);
        for j in 0..n {
            for i in 0..n {
                if i + 1 < n {
                    let l = length(sub(at(i + 1, j), at(i, j)));
                    longest = longest.max(l);
                    total_u += l;
                }
                if j + 1 < n {
                    let l = length(sub(at(i, j + 1), at(i, j)));
                    longest = longest.max(l);
                    total_v += l;
                }
            }
        }
        if longest.is_nan() || longest <= 0.0 {
            return Err(format!("the parametric surface `{name}` has no extent"));
        }
        let cell = longest;
        let mut hash: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (k, p) in pts.iter().enumerate() {
            hash.entry(p.map(|c| (c / cell).floor() as i64))
                .or_default()
                .push(k as u32);
        }
        let span = 0.5 * (total_u + total_v) / n as f64;
        Ok(ParametricUv(Arc::new(Grid {
            name: name.to_string(),
            n,
            pts,
            cell,
            hash,
            span,
        })))
    }

    /// The grid: samples per side n, and X at (u, v) = (i, j)/(n − 1),
    /// row-major in j (a mesh of the surface, for colliders).
    pub fn grid(&self) -> (usize, &[V3]) {
        (self.0.n, &self.0.pts)
    }

    /// The surface's name.
    pub fn name(&self) -> &str {
        &self.0.name
    }

    /// The mean length of its u and v lines (scene units).
    pub fn span(&self) -> f64 {
        self.0.span
    }

    /// The grid's bilinear surface at (u, v) and its partials ∂/∂u, ∂/∂v.
    pub fn point(&self, u: f64, v: f64) -> (V3, V3, V3) {
        let g = &*self.0;
        let m = (g.n - 1) as f64;
        let (fu, fv) = (u.clamp(0.0, 1.0) * m, v.clamp(0.0, 1.0) * m);
        let (i, j) = ((fu.floor() as usize).min(g.n - 2), (fv.floor() as usize).min(g.n - 2));
        let (a, b) = (fu - i as f64, fv - j as f64);
        let at = |i: usize, j: usize| g.pts[j * g.n + i];
        let (p00, p10, p01, p11) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
        let lerp = |x: V3, y: V3, t: f64| add(scale(x, 1.0 - t), scale(y, t));
        let p = lerp(lerp(p00, p10, a), lerp(p01, p11, a), b);
        let du = scale(lerp(sub(p10, p00), sub(p11, p01), b), m);
        let dv = scale(lerp(sub(p01, p00), sub(p11, p10), a), m);
        (p, du, dv)
    }

    /// The (u, v) of the surface point nearest q, when q is within half a
    /// grid cell of the surface (plus 1/1000 of its span); None elsewhere.
    pub fn invert(&self, q: V3) -> Option<[f64; 2]> {
        let g = &*self.0;
        let key = q.map(|c| (c / g.cell).floor() as i64);
        let mut best: Option<(f64, u32)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = g.hash.get(&[key[0] + dx, key[1] + dy, key[2] + dz]) else {
                        continue;
                    };
                    for &k in list {
                        let d = sub(g.pts[k as usize], q);
                        let d2 = dot(d, d);
                        if best.is_none_or(|(b, _)| d2 < b) {
                            best = Some((d2, k));
                        }
                    }
                }
            }
        }
        let (_, k) = best?;
        let m = (g.n - 1) as f64;
        let mut uv = [(k as usize % g.n) as f64 / m, (k as usize / g.n) as f64 / m];
        for _ in 0..12 {
            let (p, du, dv) = self.point(uv[0], uv[1]);
            let r = sub(p, q);
            // Gauss–Newton on |X(u, v) − q|²: (JᵀJ) δ = −Jᵀ r.
            let (a, b, c) = (dot(du, du), dot(du, dv), dot(dv, dv));
            let (e, f) = (-dot(du, r), -dot(dv, r));
            let det = a * c - b * b;
            if det.is_nan() || det.abs() <= 1e-300 {
                break;
            }
            let (x, y) = ((e * c - b * f) / det, (a * f - b * e) / det);
            // At most a cell per step.
            let lim = 1.0 / m;
            uv = [
                (uv[0] + x.clamp(-lim, lim)).clamp(0.0, 1.0),
                (uv[1] + y.clamp(-lim, lim)).clamp(0.0, 1.0),
            ];
            if x.abs() < 1e-12 && y.abs() < 1e-12 {
                break;
            }
        }
        let (p, _, _) = self.point(uv[0], uv[1]);
        (length(sub(p, q)) <= 0.5 * g.cell + 1e-3 * g.span).then_some(uv)
    }

    /// The unit normal ∂X/∂u × ∂X/∂v at (u, v) (zero where degenerate).
    pub fn normal(&self, u: f64, v: f64) -> V3 {
        let (_, du, dv) = self.point(u, v);
        let n = cross(du, dv);
        let l = length(n);
        if l > 0.0 {
            scale(n, 1.0 / l)
        } else {
            [0.0; 3]
        }
    }

    /// The (u, v) box of the samples within `radius` of `centre`, grown by
    /// a cell; None when no sample is that near.
    pub fn uv_box_near(&self, centre: V3, radius: f64) -> Option<[f64; 4]> {
        let g = &*self.0;
        let m = (g.n - 1) as f64;
        let mut out: Option<[f64; 4]> = None;
        let r = radius + g.cell;
        for (k, p) in g.pts.iter().enumerate() {
            let d = sub(*p, centre);
            if dot(d, d) > r * r {
                continue;
            }
            let (u, v) = ((k % g.n) as f64 / m, (k / g.n) as f64 / m);
            out = Some(match out {
                None => [u, v, u, v],
                Some(b) => [b[0].min(u), b[1].min(v), b[2].max(u), b[3].max(v)],
            });
        }
        out.map(|b| {
            [
                (b[0] - 1.0 / m).max(0.0),
                (b[1] - 1.0 / m).max(0.0),
                (b[2] + 1.0 / m).min(1.0),
                (b[3] + 1.0 / m).min(1.0),
            ]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A saddle z = (s² − t²)/4 over [−1, 1]²: points on it invert to their
    /// own (u, v); points off it by more than a cell do not.
    #[test]
    fn saddle_points_invert_to_their_parameters() {
        let x = |u: f64, v: f64| {
            let (s, t) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            Some([s, t, 0.25 * (s * s - t * t)])
        };
        let m = ParametricUv::new("saddle", 129, x).unwrap();
        for (u, v) in [(0.5, 0.5), (0.1, 0.9), (0.73, 0.21), (0.0, 1.0), (0.999, 0.5)] {
            let p = x(u, v).unwrap();
            let uv = m.invert(p).unwrap();
            assert!((uv[0] - u).abs() < 2e-4 && (uv[1] - v).abs() < 2e-4, "{u}, {v}: {uv:?}");
            // The normal is the saddle's: (−s/2, t/2, 1), normalised.
            let (s, t) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            let want = [-0.5 * s, 0.5 * t, 1.0];
            let l = length(want);
            let n = m.normal(uv[0], uv[1]);
            assert!(dot(n, want) / l > 0.9999, "{n:?}");
        }
        assert_eq!(m.invert([0.2, 0.3, 1.0]), None);
        assert_eq!(m.invert([5.0, 0.0, 0.0]), None);
        let b = m.uv_box_near([0.0, 0.0, 0.0], 0.2).unwrap();
        assert!(b[0] < 0.4 && b[2] > 0.6 && b[0] > 0.3 && b[2] < 0.7, "{b:?}");
        assert!(ParametricUv::new("pole", 9, |u, _| (u < 0.5).then_some([u, 0.0, 0.0])).is_err());
    }
}
