//! Imprints against the analytic dent (dents.md §2.5, KATs 12 and 13): a
//! ball of radius r pressed into a plane to depth d leaves the spherical
//! cap δ(ρ) = d − r + sqrt(r² − ρ²) within ρ ≤ sqrt(2rd − d²). The texel
//! method writes it exactly at every tilt of the impact; the thesis's ortho
//! method measures along the impact direction, too deep by about 1/cos θ,
//! and its N·N_C fix brings the depth back.

use isoray_dent::field::March;
use isoray_dent::imprint::{imprint_ortho, imprint_texel, OrthoOptions, Sphere};
use isoray_dent::uv::UvMapping;
use isoray_dent::HeightMap;

const R: f64 = 0.5;
const D: f64 = 0.05;
const K: f64 = 0.2;
const N: u32 = 256;

fn plane(p: [f64; 3]) -> f64 {
    p[1]
}

fn ball(p: [f64; 3]) -> f64 {
    let c = [0.0, R - D, 0.0];
    ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt() - R
}

fn mapping() -> UvMapping {
    UvMapping::named("planar-xz", [-1.0, -1.0, -1.0], [1.0, 0.0, 1.0]).unwrap()
}

/// The analytic dent depth at texel (x, y).
fn exact(x: u32, y: u32) -> f64 {
    let s = 2.0 / N as f64;
    let (px, pz) = (-1.0 + (x as f64 + 0.5) * s, -1.0 + (y as f64 + 0.5) * s);
    let rho = (px * px + pz * pz).sqrt();
    if rho * rho <= 2.0 * R * D - D * D {
        D - R + (R * R - rho * rho).sqrt()
    } else {
        0.0
    }
}

/// (max |δ − δ_exact|, deepest δ) over the map.
fn errors(map: &HeightMap) -> (f64, f64) {
    let mut worst: f64 = 0.0;
    let mut deepest: f64 = 0.0;
    for y in 0..N {
        for x in 0..N {
            let d = -map.displacement(x, y);
            worst = worst.max((d - exact(x, y)).abs());
            deepest = deepest.max(d);
        }
    }
    (worst, deepest)
}

fn reach() -> Sphere {
    Sphere {
        centre: [0.0, R - D, 0.0],
        radius: R,
    }
}

#[test]
fn kat_12_the_texel_method_writes_the_spherical_cap() {
    let mut map = HeightMap::new(N, N, K);
    let out = imprint_texel(&mut map, &mapping(), &plane, &ball, reach(), March::default());
    let (worst, deepest) = errors(&map);
    assert!(worst < 1e-5, "max error {worst}");
    assert!((deepest - D).abs() < 1e-3, "{deepest}");
    // The dent's radius: 0.217945; texels just beyond are untouched.
    assert!((2.0f64 * R * D - D * D).sqrt() - 0.217945 < 1e-6);
    let rect = out.rect.unwrap();
    let span = (rect.x1 - rect.x0) as f64 * 2.0 / N as f64;
    assert!((span - 2.0 * 0.217945).abs() < 3.0 * 2.0 / N as f64, "{span} {rect:?}");
    // δ(0.1) = 0.039898; the texel whose centre is at ρ = 0.0977 holds δ there.
    assert!((D - R + (R * R - 0.01f64).sqrt() - 0.039898).abs() < 1e-6);
    let want = exact(140, N / 2);
    assert!((-map.displacement(140, N / 2) - want).abs() < 1e-6 && (want - 0.039898).abs() < 1e-3);
    // The same impact again changes nothing (the deepest wins).
    let again = imprint_texel(&mut map, &mapping(), &plane, &ball, reach(), March::default());
    assert_eq!(again.lowered, 0);
}

/// The ortho method at a tilt θ of the impact direction from the plane's
/// normal (the ball's pose, hence the exact dent, the same).
fn ortho(theta_deg: f64, project: bool) -> (f64, f64) {
    let t = theta_deg.to_radians();
    let n_c = [t.sin(), t.cos(), 0.0];
    let mut map = HeightMap::new(N, N, K);
    imprint_ortho(
        &mut map,
        &mapping(),
        &plane,
        &ball,
        [0.0, 0.0, 0.0],
        n_c,
        reach(),
        0.5 * 2.0 / N as f64,
        OrthoOptions {
            project_on_normal: project,
        },
        March::default(),
    );
    errors(&map)
}

#[test]
fn kat_13_the_ortho_method_errs_by_the_tilt_and_the_fix_brings_the_depth_back() {
    let (e0, d0) = ortho(0.0, false);
    assert!(e0 < 2e-3 && (d0 - D).abs() < 1e-3, "0°: error {e0}, deepest {d0}");
    for theta in [15.0f64, 30.0, 45.0, 60.0] {
        let (e, deepest) = ortho(theta, false);
        let (ef, fixed) = ortho(theta, true);
        let cos = theta.to_radians().cos();
        eprintln!(
            "{theta}°: ortho error {e:.5} deepest {deepest:.5} (d/cos θ {:.5}); with N·N_C error {ef:.5} deepest {fixed:.5}",
            D / cos
        );
        // Measured along N_C, the centre is d/cos θ deep: too deep by that factor.
        assert!((deepest - D / cos).abs() < 2e-4 * D / cos + 1e-4, "{theta}°: {deepest}");
        assert!(e > 0.9 * D * (1.0 / cos - 1.0), "{theta}°: error {e}");
        // The fix gives the depth back, not the shape (the texels are still
        // addressed along the tilted rays).
        assert!((fixed - D).abs() < 1e-4, "{theta}°: {fixed}");
        assert!(ef < e && ef > 1e-3, "{theta}°: {ef} vs {e}");
        // The texel method does not depend on the impact's direction at all.
        let mut map = HeightMap::new(N, N, K);
        imprint_texel(&mut map, &mapping(), &plane, &ball, reach(), March::default());
        assert!(errors(&map).0 < 1e-5);
    }
}

/// The overlap bound of a dent cut into geometry holds the whole spherical
/// cap (its rim at ρ = sqrt(2rd − d²)), tightly, whatever the impact's tilt.
#[test]
fn the_overlap_bound_holds_the_cap_at_any_tilt() {
    use isoray_dent::imprint::overlap_bound;
    let rho = (2.0 * R * D - D * D).sqrt();
    for tilt in [0.0f64, 20.0, 45.0, 70.0] {
        // The plane and the ball turned together about z: the cap turns too.
        let (s, c) = tilt.to_radians().sin_cos();
        let back = |p: [f64; 3]| [c * p[0] + s * p[1], -s * p[0] + c * p[1], p[2]];
        let a = move |p: [f64; 3]| plane(back(p));
        let b = move |p: [f64; 3]| ball(back(p));
        let n = [-s, c, 0.0];
        let bound = overlap_bound(&a, &b, [0.0; 3], n, D, 4.0, 0.0).expect("the line is inside both");
        let centre = [0.5 * D * s, -0.5 * D * c, 0.0];
        assert!((0..3).all(|i| (bound.centre[i] - centre[i]).abs() < 1e-12));
        // Every point of the cap (its rim and its bottom) is inside.
        let far = (rho * rho + 0.25 * D * D).sqrt();
        assert!(bound.radius >= far, "tilt {tilt}: {} < {far}", bound.radius);
        assert!(
            bound.radius <= 1.25 * far + 1e-6,
            "tilt {tilt}: {} too loose",
            bound.radius
        );
    }
    // A start outside the overlap gives no bound.
    assert!(overlap_bound(&plane, &ball, [0.0, 0.5, 0.0], [0.0, 1.0, 0.0], D, 4.0, 0.0).is_none());
}
