//! Objects whose distance is exactly a plane's or a sphere's, recognised
//! numerically (whatever text produced them), so that rays can intersect
//! them in closed form instead of marching towards them.
//!
//! A plane's distance is n·p + h with |n| = 1: its gradient is the same
//! everywhere. A sphere's is |p − c| − r: at any point p, c = p − (d + r)∇d,
//! so two points fix c and r. A candidate is accepted only if it matches the
//! object's distance at 64 scattered points to 1e-9 (relative).

use isoray_shape::{GradientMode, Shape};

/// A closed-form shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Analytic {
    /// Points p with n·p + h = 0 (n a unit vector, the distance n·p + h).
    Plane {
        /// Unit normal.
        n: [f64; 3],
        /// Offset.
        h: f64,
    },
    /// Points at distance r from c.
    Sphere {
        /// Centre.
        c: [f64; 3],
        /// Radius.
        r: f64,
    },
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn len(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Scattered test points in a box of half-size 4 around the origin.
fn probes() -> Vec<[f64; 3]> {
    let mut seed = 0x1234_5678_9abc_def0u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 8.0 - 4.0
    };
    (0..64).map(|_| [next(), next(), next()]).collect()
}

impl Analytic {
    /// The signed distance at p.
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        match *self {
            Analytic::Plane { n, h } => dot(n, p) + h,
            Analytic::Sphere { c, r } => len(sub(p, c)) - r,
        }
    }

    /// Points on the surface and a little off it on both sides: the probes
    /// moved onto it (a plane), or directions from the centre (a sphere).
    fn near_points(&self, probes: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut out = Vec::new();
        for (i, &q) in probes.iter().enumerate() {
            let off = [0.0, 0.05, -0.05, 0.3, -0.3][i % 5];
            match *self {
                Analytic::Plane { n, h } => {
                    let t = dot(n, q) + h - off;
                    out.push([q[0] - t * n[0], q[1] - t * n[1], q[2] - t * n[2]]);
                }
                Analytic::Sphere { c, r } => {
                    let u = sub(q, c);
                    let l = len(u);
                    if l > 0.0 {
                        let s = (r + off * r) / l;
                        out.push([c[0] + s * u[0], c[1] + s * u[1], c[2] + s * u[2]]);
                    }
                }
            }
        }
        // And all around a sphere, not only on the side the probes see it
        // from: a capsule far from the probes is its near cap's sphere
        // from there.
        if let Analytic::Sphere { c, r } = *self {
            for x in -1..=1 {
                for y in -1..=1 {
                    for z in -1..=1 {
                        let u = [x as f64, y as f64, z as f64];
                        let l = len(u);
                        if l == 0.0 {
                            continue;
                        }
                        for f in [0.5, 1.0, 1.05, 1.5] {
                            let s = f * r / l;
                            out.push([c[0] + s * u[0], c[1] + s * u[1], c[2] + s * u[2]]);
                        }
                    }
                }
            }
        }
        out
    }

    /// Recognises a plane or a sphere, with the inputs `vars`.
    pub fn recognise(shape: &Shape, vars: &[f64]) -> Option<Analytic> {
        // A tape that is exactly a sphere's operations is that sphere, its
        // centre and radius read from it exactly.
        if let Some((c, r)) = isoray_shape::sphere_form(shape.tape()).filter(|&(_, r)| r > 0.0) {
            return Some(Analytic::Sphere { c, r });
        }
        let pts = probes();
        // One evaluator for the couple of hundred points.
        let mut eval = isoray_shape::PointEvaluator::<f64>::new(shape.tape());
        let mut d = |p: [f64; 3]| eval.eval(vars, p[0], p[1], p[2]);
        let (d0, d1) = (d(pts[0]), d(pts[1]));
        // Equal at the probes, and on and near the candidate's own surface:
        // a shape clipped by a sphere, max(f, sphere(p, r)), is that
        // sphere's distance at every probe far from it, not at its surface.
        let mut matches = |a: &Analytic| {
            let near = a.near_points(&pts);
            pts.iter().chain(&near).all(|&p| {
                let (d, e) = (d(p), a.distance(p));
                d.is_finite() && (d - e).abs() <= 1e-9 * (1.0 + e.abs())
            })
        };
        let g0 = shape.gradient_with(vars, pts[0], GradientMode::Dual);
        if !d0.is_finite() || !g0.iter().all(|x| x.is_finite()) {
            return None;
        }
        // Plane: n = ∇d, h = d − n·p.
        if (len(g0) - 1.0).abs() < 1e-9 {
            let plane = Analytic::Plane {
                n: g0,
                h: d0 - dot(g0, pts[0]),
            };
            if matches(&plane) {
                return Some(plane);
            }
        }
        // Sphere: c = p − (d + r)∇d; with a second point, |p₁ − c| = d₁ + r.
        let p1 = pts[1];
        // |p₁ − p₀ + (d₀ + r) g₀| = d₁ + r: a quadratic in s = d₀ + r.
        let w = sub(p1, pts[0]);
        let k = d1 - d0; // d₁ + r = s + k
                         // |w|² + 2s w·g₀ + s² = s² + 2sk + k²  →  s = (k² − |w|²) / (2(w·g₀ − k))
        let den = 2.0 * (dot(w, g0) - k);
        if den.abs() > 1e-12 {
            let s = (k * k - dot(w, w)) / den;
            let r = s - d0;
            if r > 0.0 && r.is_finite() {
                let c = [pts[0][0] - s * g0[0], pts[0][1] - s * g0[1], pts[0][2] - s * g0[2]];
                let sphere = Analytic::Sphere { c, r };
                if matches(&sphere) {
                    return Some(sphere);
                }
            }
        }
        None
    }

    /// The ray parameters t > 0 where o + t·d (d a unit vector) meets the
    /// surface, nearest first (at most two).
    pub fn intersect(&self, o: [f32; 3], d: [f32; 3]) -> [f32; 2] {
        let inf = f32::INFINITY;
        match *self {
            Analytic::Plane { n, h } => {
                let n = n.map(|x| x as f32);
                let den = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
                let num = n[0] * o[0] + n[1] * o[1] + n[2] * o[2] + h as f32;
                let t = -num / den;
                [if t > 0.0 && t.is_finite() { t } else { inf }, inf]
            }
            Analytic::Sphere { c, r } => {
                let oc = [o[0] - c[0] as f32, o[1] - c[1] as f32, o[2] - c[2] as f32];
                let b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
                let cc = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - (r * r) as f32;
                let disc = b * b - cc;
                if disc < 0.0 {
                    return [inf, inf];
                }
                let q = disc.sqrt();
                let (t0, t1) = (-b - q, -b + q);
                match (t0 > 0.0, t1 > 0.0) {
                    (true, _) => [t0, t1],
                    (false, true) => [t1, inf],
                    _ => [inf, inf],
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use isoray_shape::{compile, Library};

    fn rec(text: &str) -> Option<Analytic> {
        Analytic::recognise(&compile(&Library::new(), text).unwrap(), &[])
    }

    #[test]
    fn recognises_planes_and_spheres_whatever_the_text() {
        assert_eq!(
            rec("plane(p, vec3(0.0, 1.0, 0.0), 0.5)"),
            Some(Analytic::Plane {
                n: [0.0, 1.0, 0.0],
                h: 0.5
            })
        );
        match rec("sphere(p - vec3(1.0, 2.0, -0.5), 0.75)") {
            Some(Analytic::Sphere { c, r }) => {
                assert!((c[0] - 1.0).abs() < 1e-9 && (c[1] - 2.0).abs() < 1e-9 && (c[2] + 0.5).abs() < 1e-9);
                assert!((r - 0.75).abs() < 1e-9);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            rec("length(p + vec3(0.0, 0.0, 3.0)) - 2.0"),
            Some(Analytic::Sphere { .. })
        ));
        assert_eq!(rec("torus(p, 1.0, 0.3)"), None);
        assert_eq!(rec("box(p, vec3(1.0))"), None);
        assert_eq!(rec("sphere(p, 1.0) * 0.5"), None); // a bound, not the distance
        assert_eq!(rec("p.y - 0.1 * sin(p.x)"), None);
        // (Shapes clipped by a ball: tests/surfaces.rs, the algebraic gallery.)
        // Still a sphere where the clip never matters.
        assert!(matches!(
            rec("max(sphere(p, 1.0), sphere(p, 1.5))"),
            Some(Analytic::Sphere { .. })
        ));
        // A capsule far from the probes is, from them, its near cap's
        // sphere; all around, it is not (the character example's limbs).
        assert_eq!(rec("capsule(p - vec3(0.9, 5.3, -0.4), 0.72, 0.16)"), None);
        assert_eq!(rec("capsule(p - vec3(0.0, -9.0, 0.0), 0.5, 0.2)"), None);
        assert!(matches!(
            rec("sphere(p - vec3(0.9, 5.3, -0.4), 0.16)"),
            Some(Analytic::Sphere { .. })
        ));
        // A sphere's own tape is read, not fitted: exact however far the
        // centre (a ground made of a huge ball is a common idiom, where
        // fitting from probes near the origin loses digits).
        for (text, c, r) in [
            ("sphere(p - vec3(0.0, -1000.0, 0.0), 999.0)", [0.0, -1000.0, 0.0], 999.0),
            ("sphere(p - vec3(3.0e6, 1.0, -2.0), 0.5)", [3.0e6, 1.0, -2.0], 0.5),
        ] {
            assert_eq!(rec(text), Some(Analytic::Sphere { c, r }), "{text}");
        }
        // Placed by inputs (not constants), it is still found by fitting.
        let placed = compile(&Library::new(), "sphere(p - vec3(t, 0.5, 0.0), 0.25)").unwrap();
        match Analytic::recognise(&placed, &[1.5]) {
            Some(Analytic::Sphere { c, r }) => {
                assert!((c[0] - 1.5).abs() < 1e-9 && (c[1] - 0.5).abs() < 1e-9 && c[2].abs() < 1e-9);
                assert!((r - 0.25).abs() < 1e-9);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn intersections_are_exact() {
        let s = Analytic::Sphere {
            c: [0.0, 0.0, 0.0],
            r: 1.0,
        };
        assert_eq!(s.intersect([0.0, 0.0, 5.0], [0.0, 0.0, -1.0]), [4.0, 6.0]);
        assert_eq!(s.intersect([0.0, 0.0, 0.0], [0.0, 0.0, -1.0])[0], 1.0);
        assert_eq!(s.intersect([0.0, 2.0, 5.0], [0.0, 0.0, -1.0])[0], f32::INFINITY);
        let p = Analytic::Plane {
            n: [0.0, 1.0, 0.0],
            h: 0.0,
        };
        assert_eq!(p.intersect([0.0, 2.0, 0.0], [0.0, -1.0, 0.0])[0], 2.0);
        assert_eq!(p.intersect([0.0, 2.0, 0.0], [0.0, 1.0, 0.0])[0], f32::INFINITY);
    }
}
