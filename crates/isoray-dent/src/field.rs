//! Signed distance fields as the imprints see them: a body is a function
//! from a point to its signed distance (negative inside), in the
//! coordinates the caller chooses (the struck body's own, usually).

use crate::impulse::V3;
use crate::vec::{along, normalize};

/// A signed distance (or a distance bound: |d| no more than the true
/// distance), negative inside.
pub trait Field {
    /// The signed distance at `p`.
    fn distance(&self, p: V3) -> f64;

    /// The unit outward normal at `p`: the tetrahedral difference of step
    /// `h` (four evaluations: Σ kᵢ·d(p + h·kᵢ) over the corners kᵢ of a
    /// tetrahedron).
    fn normal(&self, p: V3, h: f64) -> V3 {
        let mut g = [0.0; 3];
        for k in [[1.0, -1.0, -1.0], [-1.0, -1.0, 1.0], [-1.0, 1.0, -1.0], [1.0, 1.0, 1.0]] {
            let d = self.distance([p[0] + h * k[0], p[1] + h * k[1], p[2] + h * k[2]]);
            for i in 0..3 {
                g[i] += k[i] * d;
            }
        }
        normalize(g)
    }
}

impl<F: Fn(V3) -> f64> Field for F {
    fn distance(&self, p: V3) -> f64 {
        self(p)
    }
}

/// How far and how finely the marches go.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct March {
    /// A hit or an exit is within this distance of the surface.
    pub epsilon: f64,
    /// Steps at most.
    pub max_steps: u32,
}

impl Default for March {
    fn default() -> Self {
        March {
            epsilon: 1e-7,
            max_steps: 4096,
        }
    }
}

/// The first t in [0, tmax] where o + t·d (d a unit vector) reaches the
/// surface of `f` from outside, by sphere tracing; None if it does not.
pub fn first_hit(f: &dyn Field, o: V3, d: V3, tmax: f64, m: March) -> Option<f64> {
    let mut t = 0.0;
    for _ in 0..m.max_steps {
        let dist = f.distance(along(o, d, t));
        if dist < m.epsilon {
            return Some(t);
        }
        t += dist;
        if t > tmax {
            return None;
        }
    }
    None
}

/// From a point o inside `f`, the t where o + t·d (d a unit vector)
/// leaves it. Inside, |distance| is a safe step (the ball of that radius
/// lies inside); each step tries the secant of the last two distances
/// instead where that goes farther (at most 8 safe steps: a thin part of
/// the body could otherwise be jumped over), which keeps a grazing exit
/// from crawling; once a point outside is found, the Illinois method pins
/// the exit down between the last points inside and outside. 0 when o is
/// outside already; `tmax` when the line is still inside there.
pub fn exit(f: &dyn Field, o: V3, d: V3, tmax: f64, m: March) -> f64 {
    let at = |t: f64| f.distance(along(o, d, t));
    let (mut t0, mut f0) = (0.0, at(0.0));
    if f0 >= 0.0 {
        return 0.0;
    }
    let (mut t1, mut f1) = ((-f0).min(tmax), 0.0);
    f1 = if t1 > 0.0 { at(t1) } else { f1 };
    let mut steps = 0;
    while f1 < 0.0 {
        steps += 1;
        if t1 >= tmax || steps > m.max_steps {
            return tmax;
        }
        let safe = (-f1).max(m.epsilon);
        let slope = (f1 - f0) / (t1 - t0);
        let secant = if slope > 0.0 { -f1 / slope } else { safe };
        let next = (t1 + secant.clamp(safe, 8.0 * safe)).min(tmax);
        (t0, f0) = (t1, f1);
        t1 = next;
        f1 = at(t1);
    }
    // Illinois between (t0 inside, t1 outside).
    let (mut lo, mut flo, mut hi, mut fhi) = (t0, f0, t1, f1);
    let mut side = 0;
    for _ in 0..100 {
        if hi - lo <= 1e-3 * m.epsilon {
            break;
        }
        let t = (lo * fhi - hi * flo) / (fhi - flo);
        let t = if t > lo && t < hi { t } else { 0.5 * (lo + hi) };
        let ft = at(t);
        if ft.abs() <= 1e-3 * m.epsilon {
            return t;
        }
        if ft < 0.0 {
            (lo, flo) = (t, ft);
            if side == -1 {
                fhi *= 0.5;
            }
            side = -1;
        } else {
            (hi, fhi) = (t, ft);
            if side == 1 {
                flo *= 0.5;
            }
            side = 1;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marches_find_a_spheres_surface_from_outside_and_inside() {
        let ball = |p: V3| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0;
        let t = first_hit(&ball, [0.0, 0.0, 5.0], [0.0, 0.0, -1.0], 10.0, March::default()).unwrap();
        assert!((t - 4.0).abs() < 1e-6);
        assert!(first_hit(&ball, [0.0, 2.0, 5.0], [0.0, 0.0, -1.0], 10.0, March::default()).is_none());
        let e = exit(&ball, [0.0, 0.0, 0.5], [0.0, 0.0, -1.0], 10.0, March::default());
        assert!((e - 1.5).abs() < 1e-6);
        let n = ball.normal([0.6, 0.8, 0.0], 1e-5);
        assert!((n[0] - 0.6).abs() < 1e-6 && (n[1] - 0.8).abs() < 1e-6);
    }
}
