//! The standard algebraic test surfaces render without holes or skipped
//! thin parts: the depth of every pixel is compared with an independent
//! reference, a fine march of the polynomial itself (f64, steps of 1/500 of
//! the scene's size, bisection at the first sign change).

use isoray_algebra::{parse_poly, MonomialOrder, Poly, Rat, Ring};
use isoray_render::camera::RayCamera;
use isoray_render::{render, RenderOptions};
use isoray_shape::algebraic::eval_with_scale;

const W: u32 = 64;
const H: u32 = 48;

struct Case {
    name: &'static str,
    equation: String,
    /// Radius of the clipping ball (the surface inside it is shown), or None.
    clip: Option<f64>,
    /// Camera distance from the origin.
    distance: f64,
}

fn first_crossing(f: &Poly<Rat>, o: [f64; 3], d: [f64; 3], clip: Option<f64>, tmax: f64) -> Option<f64> {
    let at = |t: f64| [o[0] + d[0] * t, o[1] + d[1] * t, o[2] + d[2] * t];
    let inside = |p: [f64; 3]| clip.is_none_or(|r| p[0] * p[0] + p[1] * p[1] + p[2] * p[2] < r * r);
    let step = tmax / 5000.0;
    let mut prev: Option<(f64, f64)> = None;
    let mut t = 0.0;
    while t < tmax {
        let p = at(t);
        if inside(p) {
            let v = eval_with_scale(f, &p).0;
            if let Some((t0, v0)) = prev {
                if v0 == 0.0 {
                    return Some(t0);
                }
                if v0.signum() != v.signum() {
                    let (mut a, mut b) = (t0, t);
                    for _ in 0..60 {
                        let m = 0.5 * (a + b);
                        if eval_with_scale(f, &at(m)).0.signum() == v0.signum() {
                            a = m;
                        } else {
                            b = m;
                        }
                    }
                    return Some(a);
                }
            }
            prev = Some((t, v));
        } else {
            prev = None;
        }
        t += step;
    }
    None
}

fn check(case: &Case) {
    let ring = Ring::new(&["x", "y", "z"], MonomialOrder::DegRevLex);
    let f = parse_poly(&ring, &case.equation).unwrap_or_else(|e| panic!("{}: {e}", case.name));
    let shape = match case.clip {
        Some(r) => format!("max(abs(s(p)), sphere(p, {r:?}))"),
        None => "s(p)".to_string(),
    };
    let text = format!(
        "[camera]\nposition = [{:?}, {:?}, {:?}]\ntarget = [0.0, 0.0, 0.0]\nfov = 40.0\n\
         [render]\nwidth = {W}\nheight = {H}\nmax_steps = 512\n[[light]]\ndirection = [1.0, 1.0, 1.0]\n\
         [surface.s]\nimplicit = \"{}\"\n[[object]]\nshape = \"{shape}\"\n",
        case.distance * 0.3,
        case.distance * 0.4,
        case.distance * 0.866,
        case.equation
    );
    let scene = isoray_scene::load_str(&text, "t.toml", &[]).unwrap_or_else(|e| panic!("{}: {e}", case.name));
    let (img, _) = render(
        &scene,
        &RenderOptions {
            aovs: true,
            ..RenderOptions::default()
        },
    );
    let depth = img.depth.unwrap();
    let cam = RayCamera::new(&scene.camera, W, H);
    let o = cam.origin().to_array();
    let tmax = 2.0 * case.distance;
    let reference: Vec<Option<f64>> = (0..H)
        .flat_map(|j| (0..W).map(move |i| (i, j)))
        .map(|(i, j)| {
            let d = cam.direction(i as f64 + 0.5, j as f64 + 0.5).to_array();
            first_crossing(&f, o, d, case.clip, tmax)
        })
        .collect();
    let tol = 0.01 * case.distance;
    let (mut hits, mut edge_misses, mut holes) = (0, 0, Vec::new());
    for j in 0..H {
        for i in 0..W {
            let k = (j * W + i) as usize;
            let Some(t) = reference[k] else { continue };
            hits += 1;
            let got = depth[k] as f64;
            if (got - t).abs() <= tol {
                continue;
            }
            // A pixel whose four neighbours all hit at about the same depth is
            // inside the surface's silhouette: a miss there is a hole.
            let interior = [(-1i32, 0i32), (1, 0), (0, -1), (0, 1)].iter().all(|(di, dj)| {
                let (a, b) = (i as i32 + di, j as i32 + dj);
                a >= 0
                    && b >= 0
                    && a < W as i32
                    && b < H as i32
                    && reference[(b as u32 * W + a as u32) as usize].is_some_and(|u| (u - t).abs() < 5.0 * tol)
            });
            if interior {
                holes.push((i, j, got, t));
            } else {
                edge_misses += 1;
            }
        }
    }
    assert!(hits > 150, "{}: only {hits} pixels show the surface", case.name);
    assert!(
        holes.is_empty(),
        "{}: holes at (pixel, rendered depth, reference): {holes:?}",
        case.name
    );
    assert!(
        edge_misses * 100 <= hits * 3,
        "{}: {edge_misses} of {hits} silhouette pixels differ",
        case.name
    );
}

#[test]
fn sphere_torus_tangle_cube() {
    for case in [
        Case {
            name: "unit sphere",
            equation: "x^2 + y^2 + z^2 - 1".into(),
            clip: None,
            distance: 4.0,
        },
        Case {
            name: "quartic torus",
            equation: "(x^2 + y^2 + z^2 + 1 - 0.16)^2 - 4*(x^2 + z^2)".into(),
            clip: None,
            distance: 4.5,
        },
        Case {
            name: "tangle cube",
            equation: "x^4 - 5*x^2 + y^4 - 5*y^2 + z^4 - 5*z^2 + 10".into(),
            clip: None,
            distance: 8.0,
        },
    ] {
        check(&case);
    }
}

#[test]
fn barth_kummer_clebsch_roman() {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let (p2, c) = (phi * phi, 1.0 + 2.0 * phi);
    let mu2 = 1.69f64;
    let lambda = (3.0 * mu2 - 1.0) / (3.0 - mu2);
    let r2 = 2f64.sqrt();
    for case in [
        Case {
            name: "Barth sextic",
            equation: format!(
                "4*({p2:?}*x^2 - y^2)*({p2:?}*y^2 - z^2)*({p2:?}*z^2 - x^2) - {c:?}*(x^2 + y^2 + z^2 - 1)^2"
            ),
            clip: Some(1.8),
            distance: 6.0,
        },
        Case {
            name: "Kummer quartic",
            equation: format!(
                "(x^2 + y^2 + z^2 - {mu2:?})^2 - {lambda:?}*(1 - z - {r2:?}*x)*(1 - z + {r2:?}*x)*(1 + z + {r2:?}*y)*(1 + z - {r2:?}*y)"
            ),
            clip: Some(2.5),
            distance: 8.0,
        },
        Case {
            name: "Clebsch cubic",
            equation: "81*(x^3 + y^3 + z^3) - 189*(x^2*y + x^2*z + y^2*x + y^2*z + z^2*x + z^2*y) + 54*x*y*z + 126*(x*y + x*z + y*z) - 9*(x^2 + y^2 + z^2) - 9*(x + y + z) + 1".into(),
            clip: Some(1.0),
            distance: 3.5,
        },
        Case {
            name: "Roman surface",
            equation: "x^2*y^2 + y^2*z^2 + z^2*x^2 - x*y*z".into(),
            clip: None,
            distance: 2.0,
        },
    ] {
        check(&case);
    }
}
