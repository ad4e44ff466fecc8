//! Implicit and parametric surfaces: what isoray derives for them.
//!
//! An implicit surface whose equation is a polynomial is traced through the
//! Taylor-root bound of its square-free part ([`crate::algebraic`]); any other
//! equation through the first-order estimate f / |∇f|. A rational
//! parametric surface is implicitized (Gröbner elimination, falling back to
//! interpolation), the equation is checked numerically against points of
//! the parametrization, and the result is traced like an implicit surface.
//! Every analysis is computed once per surface and parameter values and
//! cached by the [`Library`].

use std::time::{Duration, Instant};

use isoray_algebra::auto::{implicitize_auto, AutoOptions};
use isoray_algebra::parse::to_rational;
use isoray_algebra::{MonomialOrder, Poly, Rat, RatFunc, Ring};
use num_traits::One;

use crate::algebraic::{dense_terms, eval_with_scale, squarefree_part, taylor_size, xyz_ring};
use crate::diag::{Diagnostic, SourceId};
use crate::ir::{Builder, Node, Tape};
use crate::lipschitz::Field;
use crate::lower::{Library, Surface, SurfaceMode};
use crate::syntax::Program;
use crate::types::Value;

/// Which distance bound an implicit or parametric surface is traced with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BoundMethod {
    /// The Taylor-root bound for polynomial equations, else first order.
    #[default]
    Auto,
    /// The guaranteed Taylor-root bound (an error when the equation is not a polynomial).
    Taylor,
    /// The Lipschitz bound of the field over a ball, by interval arithmetic
    /// on the exact gradient (any equation; slower than Taylor).
    Lipschitz,
    /// The first-order estimate f / |∇f| (fast, not a bound everywhere).
    FirstOrder,
}

impl BoundMethod {
    /// The names accepted in scene files.
    pub const NAMES: &'static [&'static str] = &["auto", "taylor", "lipschitz", "first-order"];

    /// Parses a name of [`BoundMethod::NAMES`].
    pub fn parse(s: &str) -> Option<BoundMethod> {
        match s {
            "auto" => Some(BoundMethod::Auto),
            "taylor" => Some(BoundMethod::Taylor),
            "lipschitz" => Some(BoundMethod::Lipschitz),
            "first-order" => Some(BoundMethod::FirstOrder),
            _ => None,
        }
    }
}

/// How an implicit or parametric surface is traced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceOptions {
    /// The bound.
    pub bound: BoundMethod,
    /// The traced distance is divided by this (≥ 1 makes steps shorter).
    pub lipschitz_factor: f64,
    /// Parametric surfaces: keep only points with a real preimage in the domain.
    pub image_only: bool,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        SurfaceOptions {
            bound: BoundMethod::Auto,
            lipschitz_factor: 1.0,
            image_only: false,
        }
    }
}

/// The coordinate functions of a parametric surface.
#[derive(Debug, Clone)]
pub struct ParametricDef {
    /// x(s, t), y(s, t), z(s, t).
    pub coords: [Program; 3],
    /// Where each coordinate's text came from.
    pub sources: [SourceId; 3],
    /// The parameter domain: [s_min, s_max], [t_min, t_max].
    pub domain: [[f64; 2]; 2],
}

/// The parameter domain used when a parametric surface gives none.
pub const DEFAULT_DOMAIN: [[f64; 2]; 2] = [[-1.0, 1.0], [-1.0, 1.0]];

/// A polynomial equation traced through the Taylor-root bound.
#[derive(Debug, Clone)]
pub struct Equation {
    /// The traced polynomial in Q[x, y, z] (square-free).
    pub poly: Poly<Rat>,
    /// The degree of the equation as written (or implicitized).
    pub original_degree: i64,
    /// True when a repeated factor was removed.
    pub reduced: bool,
    /// True when the equation was a rational function and its numerator is traced.
    pub numerator: bool,
    /// How many Taylor coefficient polynomials the Taylor-root bound
    /// evaluates, or why that bound is not used for this equation.
    pub taylor_terms: Result<usize, String>,
}

/// How a parametric surface was implicitized and checked.
#[derive(Debug, Clone)]
pub struct Implicitization {
    /// "groebner", "interpolation" or "resultant": the method that
    /// `isoray_algebra::auto` chose by its cost estimate.
    pub method: &'static str,
    /// Points of the parametrization checked against the equation.
    pub checked_points: usize,
    /// The largest relative residual found there.
    pub max_residual: f64,
}

/// What isoray derived for an implicit or parametric surface.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// The polynomial equation, or why there is none (the surface is then
    /// traced by f / |∇f|, or, parametric, cannot be traced).
    pub equation: Result<Equation, String>,
    /// The rational coordinate functions in Q[s, t] (parametric surfaces).
    pub parametrization: Option<[RatFunc; 3]>,
    /// The implicitization (parametric surfaces).
    pub implicitization: Option<Implicitization>,
    /// The equation as a field with its gradient, for the Lipschitz bound
    /// (None for parametric surfaces that have no equation).
    pub field: Option<Field>,
    /// Named phases and their durations.
    pub timings: Vec<(&'static str, Duration)>,
}

/// The highest degree traced by the Taylor-root bound (its size grows as n³).
pub const MAX_TAYLOR_DEGREE: i64 = 16;

/// The most terms, over all Taylor coefficient polynomials, that the
/// Taylor-root bound evaluates; larger equations use the Lipschitz bound.
pub const MAX_TAYLOR_TERMS: usize = 20_000;

/// Relative residual above which an implicit equation fails its check.
pub const VERIFY_TOLERANCE: f64 = 1e-7;

/// Time given to the implicitization (`isoray_algebra::auto` chooses the
/// method by its cost estimate).
const IMPLICITIZATION_TIME: Duration = Duration::from_secs(125);

/// Time given to the square-free part.
const SQUAREFREE_TIME: Duration = Duration::from_secs(2);

/// Analyzes a surface with constant parameters (see the module documentation).
pub(crate) fn analyze(lib: &Library, s: &Surface, params: &[Value]) -> Result<Analysis, Diagnostic> {
    match s.mode {
        SurfaceMode::Parametric => analyze_parametric(lib, s, params),
        _ => analyze_implicit(lib, s, params),
    }
}

fn equation_from(
    poly: Poly<Rat>,
    numerator: bool,
    timings: &mut Vec<(&'static str, Duration)>,
) -> Result<Equation, String> {
    let ring = xyz_ring();
    let original_degree = poly.degree();
    let t = Instant::now();
    let sf = squarefree_part(&ring, &poly, SQUAREFREE_TIME);
    timings.push(("square-free part", t.elapsed()));
    let degree = sf.poly.degree();
    let taylor_terms = if degree > MAX_TAYLOR_DEGREE {
        Err(format!(
            "its degree {degree} is above {MAX_TAYLOR_DEGREE}, the largest traced by the Taylor-root bound"
        ))
    } else if sf.poly.len() * dense_terms(degree) > 4 * MAX_TAYLOR_TERMS {
        // A quick upper bound on the expansion's size (terms × derivatives).
        Err(format!(
            "its {} terms of degree {degree} make a Taylor expansion too costly to evaluate at every step",
            sf.poly.len()
        ))
    } else {
        let t = Instant::now();
        let (polys, total_terms) = taylor_size(&ring, &sf.poly);
        timings.push(("Taylor coefficients", t.elapsed()));
        if total_terms > MAX_TAYLOR_TERMS {
            Err(format!(
                "its Taylor expansion has {total_terms} terms, more than {MAX_TAYLOR_TERMS} (too costly to evaluate at every step)"
            ))
        } else {
            Ok(polys)
        }
    };
    Ok(Equation {
        poly: sf.poly,
        original_degree,
        reduced: sf.reduced,
        numerator,
        taylor_terms,
    })
}

fn analyze_implicit(lib: &Library, s: &Surface, params: &[Value]) -> Result<Analysis, Diagnostic> {
    let mut timings = Vec::new();
    let t = Instant::now();
    let mut b = Builder::new();
    let f = lib.lower_raw(&mut b, s, params)?;
    let ring = xyz_ring();
    let rf = crate::algebraic::to_rational(&b, f, [Some(0), Some(1), Some(2)], &ring);
    timings.push(("conversion to a polynomial", t.elapsed()));
    let field = Some(Field::new(b, f));
    let equation = match rf {
        Err(op) => Err(format!("its equation uses {op}, so it is not a polynomial")),
        Ok(rf) => {
            let numerator = !rf.den.is_constant();
            let poly = if numerator {
                rf.num
            } else {
                let c = rf.den.lc().cloned().unwrap_or_else(Rat::one);
                rf.num.scale(&(Rat::one() / c))
            };
            equation_from(poly, numerator, &mut timings)
        }
    };
    Ok(Analysis {
        equation,
        parametrization: None,
        implicitization: None,
        field,
        timings,
    })
}

/// The ring Q[s, t] of parametrizations.
pub fn st_ring() -> Ring {
    Ring::new(&["s", "t"], MonomialOrder::DegRevLex)
}

/// Evaluates rational coordinate functions at (s, t); None near a pole.
pub fn eval_parametrization(coords: &[RatFunc; 3], st: [f64; 2]) -> Option<[f64; 3]> {
    let mut out = [0.0; 3];
    for (o, c) in out.iter_mut().zip(coords) {
        let (n, _) = eval_with_scale(&c.num, &st);
        let (d, ds) = eval_with_scale(&c.den, &st);
        if d.abs() <= 1e-9 * ds.max(1e-300) || !d.is_finite() {
            return None;
        }
        *o = n / d;
    }
    out.iter().all(|v| v.is_finite()).then_some(out)
}

fn analyze_parametric(lib: &Library, s: &Surface, params: &[Value]) -> Result<Analysis, Diagnostic> {
    let def = s.parametric.as_ref().expect("a parametric surface");
    let mut timings = Vec::new();
    let t = Instant::now();
    let mut b = Builder::new();
    let nodes = lib.lower_coords(&mut b, s, params)?;
    let ring = st_ring();
    let mut coords = Vec::new();
    for (i, &n) in nodes.iter().enumerate() {
        match crate::algebraic::to_rational(&b, n, [Some(0), Some(1), None], &ring) {
            Ok(rf) => coords.push(rf),
            Err(op) => {
                return Ok(Analysis {
                    equation: Err(format!(
                    "coordinate `{}` uses {op}, so the parametrization is not rational and has no implicit equation",
                    ["x", "y", "z"][i]
                )),
                    parametrization: None,
                    implicitization: None,
                    field: None,
                    timings,
                })
            }
        }
    }
    let coords: [RatFunc; 3] = coords.try_into().expect("three coordinates");
    timings.push(("conversion to rational functions", t.elapsed()));

    let fail = |msg: String| {
        Diagnostic::new(def.sources[0], def.coords[0].body.span, msg)
            .with_label("in this parametrization")
            .with_note(format!("surface `{}`", s.name))
    };
    let texts: Vec<String> = coords
        .iter()
        .map(|c| format!("({})/({})", c.num.display(&ring), c.den.display(&ring)))
        .collect();
    let texts: Vec<&str> = texts.iter().map(String::as_str).collect();
    let t = Instant::now();
    // Progress of the implicitization, its stages named after the surface.
    let progress = lib.progress().map(|p| {
        let named: std::sync::Arc<dyn isoray_job::Progress + Send> = std::sync::Arc::new(Named {
            prefix: format!("surface `{}`: ", s.name),
            inner: p.clone(),
        });
        named
    });
    let result = implicitize_auto(
        &texts,
        &["s", "t"],
        &AutoOptions {
            time: Some(IMPLICITIZATION_TIME),
            interrupt: lib.cancel_token().cloned(),
            progress,
        },
    );
    let method = result.as_ref().map_or("auto", |a| a.method.as_str());
    let result = result.map(|a| a.implicit);
    timings.push(("implicitization", t.elapsed()));
    let imp = result.map_err(|e| fail(format!("surface `{}` could not be implicitized: {e}", s.name)))?;
    let poly = to_rational(&imp.poly);
    // The implicit ring is (x, y, z) grevlex, the same as xyz_ring.

    let t = Instant::now();
    let (checked, worst) = verify(&coords, &poly, def.domain);
    timings.push(("numerical check", t.elapsed()));
    if let Some((st, xyz, res)) = worst.filter(|w| w.2 > VERIFY_TOLERANCE) {
        return Err(fail(format!(
            "the implicit equation of surface `{}` fails its check: the point (s, t) = ({}, {}) maps to ({:.6}, {:.6}, {:.6}), \
             where {} = 0 is off by {:.2e} (relative), above the tolerance {:.0e}",
            s.name,
            st[0],
            st[1],
            xyz[0],
            xyz[1],
            xyz[2],
            poly.display(&xyz_ring()),
            res,
            VERIFY_TOLERANCE
        )));
    }
    if checked == 0 {
        return Err(fail(format!(
            "surface `{}`: no point of the domain could be evaluated (every sample is at a pole)",
            s.name
        )));
    }
    let mut fb = Builder::new();
    let at = [fb.x(), fb.y(), fb.z()];
    let f = crate::algebraic::build_equation(&mut fb, &poly, at);
    let field = Some(Field::new(fb, f));
    let equation = equation_from(poly, false, &mut timings);
    Ok(Analysis {
        equation,
        field,
        parametrization: Some(coords),
        implicitization: Some(Implicitization {
            method,
            checked_points: checked,
            max_residual: worst.map(|w| w.2).unwrap_or(0.0),
        }),
        timings,
    })
}

/// Sample points of the parameter domain: a grid (shifted off the centre of
/// symmetric domains, where parametrizations are often singular) and
/// pseudo-random points.
fn domain_samples(domain: [[f64; 2]; 2], grid: usize, random: usize) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    let lerp = |r: [f64; 2], u: f64| r[0] + (r[1] - r[0]) * u;
    for i in 0..grid {
        for j in 0..grid {
            let u = (i as f64 + 0.57) / grid as f64;
            let v = (j as f64 + 0.61) / grid as f64;
            out.push([lerp(domain[0], u), lerp(domain[1], v)]);
        }
    }
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..random {
        let (u, v) = (next(), next());
        out.push([lerp(domain[0], u), lerp(domain[1], v)]);
    }
    out
}

/// A checked point: (s, t), (x, y, z) and the relative residual there.
pub type Residual = ([f64; 2], [f64; 3], f64);

/// Checks that points of the parametrization satisfy the equation. Returns
/// the number of points checked and the worst one: ((s, t), (x, y, z), residual).
pub fn verify(coords: &[RatFunc; 3], poly: &Poly<Rat>, domain: [[f64; 2]; 2]) -> (usize, Option<Residual>) {
    let mut checked = 0;
    let mut worst: Option<Residual> = None;
    for st in domain_samples(domain, 12, 200) {
        let Some(xyz) = eval_parametrization(coords, st) else {
            continue;
        };
        let (v, scale) = eval_with_scale(poly, &xyz);
        if !scale.is_finite() || scale == 0.0 {
            continue;
        }
        checked += 1;
        let res = v.abs() / scale;
        if worst.is_none_or(|w| res > w.2) {
            worst = Some((st, xyz, res));
        }
    }
    (checked, worst)
}

/// Samples per side of the grid that seeds the preimage search.
const PREIMAGE_GRID: usize = 6;

/// Gauss–Newton steps of the preimage search.
const NEWTON_STEPS: usize = 5;

/// The field of `image_only`: max(|closure|, ρ − τ), where ρ is the distance
/// from p to the nearest image point found by Gauss–Newton from the nearest
/// grid sample (clamped to the domain), and τ a small fraction of the image's
/// size. Its zero set is the part of the implicit surface with a real
/// preimage in the domain. Far outside a bounding sphere of the image the
/// field is the distance to that sphere, and the tape skips the rest.
pub fn image_only_field(
    b: &mut Builder,
    coords: &[RatFunc; 3],
    domain: [[f64; 2]; 2],
    p: [Node; 3],
    closure: Node,
) -> Node {
    let ring = st_ring();
    // Seed: the nearest of a grid of image points.
    let samples: Vec<([f64; 2], [f64; 3])> = domain_samples(domain, PREIMAGE_GRID, 0)
        .into_iter()
        .filter_map(|st| eval_parametrization(coords, st).map(|x| (st, x)))
        .collect();
    let Some(first) = samples.first() else {
        return closure;
    };
    let (mut lo, mut hi) = (first.1, first.1);
    for (_, x) in &samples {
        for i in 0..3 {
            lo[i] = lo[i].min(x[i]);
            hi[i] = hi[i].max(x[i]);
        }
    }
    let extent = ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
    let tau = 1e-3 * extent.max(1e-6);
    let dist2 = |b: &mut Builder, x: [f64; 3]| {
        let mut acc = b.constant(0.0);
        for i in 0..3 {
            let d = b.add_c(p[i], -x[i]);
            let sq = b.square(d);
            acc = b.add(acc, sq);
        }
        acc
    };
    let mut best = dist2(b, first.1);
    let mut s = b.constant(first.0[0]);
    let mut t = b.constant(first.0[1]);
    for (st, x) in &samples[1..] {
        let d = dist2(b, *x);
        let closer = b.sub(best, d);
        best = b.min(best, d);
        let (cs, ct) = (b.constant(st[0]), b.constant(st[1]));
        s = b.select(closer, cs, s);
        t = b.select(closer, ct, t);
    }
    // Derivatives of the coordinates.
    let parts: Vec<[Poly<Rat>; 4]> = coords
        .iter()
        .map(|c| {
            [
                c.num.clone(),
                c.den.clone(),
                c.num.derivative(&ring, 0),
                c.num.derivative(&ring, 1),
            ]
        })
        .collect();
    let dens: Vec<[Poly<Rat>; 2]> = coords
        .iter()
        .map(|c| [c.den.derivative(&ring, 0), c.den.derivative(&ring, 1)])
        .collect();
    let to_st = |p: &Poly<Rat>| -> Poly<Rat> {
        // Embed Q[s, t] into the (x, y, z) slots the DAG builder reads: s ↦ x, t ↦ y.
        Poly::from_terms(
            &xyz_ring(),
            p.terms()
                .iter()
                .map(|(m, c)| (isoray_algebra::Monomial::new(&[m.exp(0), m.exp(1), 0]), c.clone()))
                .collect(),
        )
    };
    let eval =
        |b: &mut Builder, p: &Poly<Rat>, s: Node, t: Node| crate::algebraic::build_equation(b, &to_st(p), [s, t, s]);
    let tiny = b.constant(1e-30);
    let point_and_jacobian = |b: &mut Builder, s: Node, t: Node| {
        let mut x = [s; 3];
        let mut xs = [s; 3];
        let mut xt = [s; 3];
        for i in 0..3 {
            let n = eval(b, &parts[i][0], s, t);
            let d = eval(b, &parts[i][1], s, t);
            let ns = eval(b, &parts[i][2], s, t);
            let nt = eval(b, &parts[i][3], s, t);
            let ds = eval(b, &dens[i][0], s, t);
            let dt = eval(b, &dens[i][1], s, t);
            x[i] = b.div(n, d);
            // (N/D)' = (N' − (N/D)·D') / D
            let a = b.mul(x[i], ds);
            let a = b.sub(ns, a);
            xs[i] = b.div(a, d);
            let c = b.mul(x[i], dt);
            let c = b.sub(nt, c);
            xt[i] = b.div(c, d);
        }
        (x, xs, xt)
    };
    let dot = |b: &mut Builder, u: [Node; 3], v: [Node; 3]| {
        let mut acc = b.mul(u[0], v[0]);
        for i in 1..3 {
            let m = b.mul(u[i], v[i]);
            acc = b.add(acc, m);
        }
        acc
    };
    for _ in 0..NEWTON_STEPS {
        let (x, xs, xt) = point_and_jacobian(b, s, t);
        let r: [Node; 3] = std::array::from_fn(|i| b.sub(x[i], p[i]));
        let aa = dot(b, xs, xs);
        let cc = dot(b, xt, xt);
        let ac = dot(b, xs, xt);
        let ar = dot(b, xs, r);
        let cr = dot(b, xt, r);
        // Levenberg damping keeps the 2×2 system solvable at singular points.
        let tr = b.add(aa, cc);
        let damp = b.mul_c(tr, 1e-9);
        let damp = b.max(damp, tiny);
        let aa = b.add(aa, damp);
        let cc = b.add(cc, damp);
        let ac2 = b.square(ac);
        let det = b.mul(aa, cc);
        let det = b.sub(det, ac2);
        let det = b.max(det, tiny);
        let u1 = b.mul(cc, ar);
        let u2 = b.mul(ac, cr);
        let num_s = b.sub(u1, u2);
        let v1 = b.mul(aa, cr);
        let v2 = b.mul(ac, ar);
        let num_t = b.sub(v1, v2);
        let ds = b.div(num_s, det);
        let dt = b.div(num_t, det);
        let s1 = b.sub(s, ds);
        let t1 = b.sub(t, dt);
        let (s0, s_hi, t0, t_hi) = (
            b.constant(domain[0][0]),
            b.constant(domain[0][1]),
            b.constant(domain[1][0]),
            b.constant(domain[1][1]),
        );
        s = b.clamp(s1, s0, s_hi);
        t = b.clamp(t1, t0, t_hi);
    }
    let (x, _, _) = point_and_jacobian(b, s, t);
    let r: [Node; 3] = std::array::from_fn(|i| b.sub(x[i], p[i]));
    let rho2 = dot(b, r, r);
    let rho = b.sqrt(rho2);
    let gap = b.add_c(rho, -tau);
    let unsigned = b.abs(closure);
    let field = b.max(unsigned, gap);
    // A bounding sphere of the image (from a finer sampling, with a margin):
    // farther than half its radius outside it, the distance to the sphere is
    // the bound, and the preimage search is skipped.
    let fine: Vec<[f64; 3]> = domain_samples(domain, 32, 0)
        .into_iter()
        .chain(samples.iter().map(|s| s.0))
        .filter_map(|st| eval_parametrization(coords, st))
        .collect();
    let centre: [f64; 3] = std::array::from_fn(|i| 0.5 * (lo[i] + hi[i]));
    let radius = fine
        .iter()
        .map(|x| ((x[0] - centre[0]).powi(2) + (x[1] - centre[1]).powi(2) + (x[2] - centre[2]).powi(2)).sqrt())
        .fold(0.0f64, f64::max);
    let radius = radius * 1.2 + tau + 1e-6;
    let mut d2 = b.constant(0.0);
    for i in 0..3 {
        let d = b.add_c(p[i], -centre[i]);
        let sq = b.square(d);
        d2 = b.add(d2, sq);
    }
    let dist = b.sqrt(d2);
    let outside = b.add_c(dist, -radius);
    let far = b.add_c(outside, -0.5 * radius);
    b.lazy_select(far, outside, field)
}

const LIPSCHITZ_TEXT: &str =
    "Lipschitz bound: |f(p)| / sup |grad f| over a ball around p, by interval arithmetic on the exact gradient";

/// Renders an analysis as the lines `isoray surface` prints.
pub fn describe(name: &str, s: &Surface, a: &Analysis) -> String {
    let mut out = String::new();
    let mode = match s.mode {
        SurfaceMode::Sdf => "sdf",
        SurfaceMode::Implicit => "implicit",
        SurfaceMode::Parametric => "parametric",
    };
    out.push_str(&format!("surface:   {name} ({mode})\n"));
    if let Some(c) = &a.parametrization {
        let ring = st_ring();
        for (i, f) in c.iter().enumerate() {
            let text = if f.den.is_constant() && f.den.lc().is_some_and(|c| c.is_one()) {
                f.num.display(&ring)
            } else {
                format!("({}) / ({})", f.num.display(&ring), f.den.display(&ring))
            };
            out.push_str(&format!("{}(s,t):    {text}\n", ["x", "y", "z"][i]));
        }
    }
    match &a.equation {
        Ok(eq) => {
            let ring = xyz_ring();
            out.push_str(&format!("equation:  {} = 0\n", eq.poly.display(&ring)));
            out.push_str(&format!("degree:    {}", eq.poly.degree()));
            if eq.reduced {
                out.push_str(&format!(
                    " (square-free part of a degree-{} equation)",
                    eq.original_degree
                ));
            }
            if eq.numerator {
                out.push_str(" (numerator of a rational equation)");
            }
            out.push('\n');
            let factor = s.options.lipschitz_factor;
            let bound = match (s.options.bound, &eq.taylor_terms) {
                (BoundMethod::FirstOrder, _) => {
                    "first-order estimate f / |grad f| (exact symbolic gradient)".to_string()
                }
                (BoundMethod::Lipschitz, _) => LIPSCHITZ_TEXT.to_string(),
                (_, Ok(n)) => format!(
                    "Taylor-root bound: smallest root of |f(p)| = sum_k M_k d^k, {n} Taylor coefficient polynomials"
                ),
                (_, Err(why)) => format!("{LIPSCHITZ_TEXT} (no Taylor-root bound: {why})"),
            };
            out.push_str(&format!("bound:     {bound}"));
            if factor != 1.0 {
                out.push_str(&format!(", divided by lipschitz_factor = {factor}"));
            }
            out.push('\n');
            if s.options.image_only {
                out.push_str(
                    "image:     only points with a real preimage in the domain (Gauss-Newton from the nearest point of a 6x6 grid)\n",
                );
            }
        }
        Err(why) => {
            out.push_str(&format!("equation:  none: {why}\n"));
            let bound = if s.mode == SurfaceMode::Parametric {
                "none: this surface cannot be sphere-traced"
            } else if s.options.bound == BoundMethod::FirstOrder {
                "first-order estimate f / |grad f| (exact symbolic gradient)"
            } else {
                LIPSCHITZ_TEXT
            };
            out.push_str(&format!("bound:     {bound}\n"));
        }
    }
    if let (Some(i), Some(def)) = (&a.implicitization, s.parametric.as_ref()) {
        out.push_str(&format!(
            "check:     {} points of s in [{}, {}], t in [{}, {}] satisfy the equation (largest relative residual {:.1e})\n",
            i.checked_points, def.domain[0][0], def.domain[0][1], def.domain[1][0], def.domain[1][1], i.max_residual
        ));
        out.push_str(&format!("method:    {}\n", i.method));
    }
    for (what, d) in &a.timings {
        out.push_str(&format!("time:      {what}: {:.3} ms\n", d.as_secs_f64() * 1e3));
    }
    out
}

/// The coordinate functions of a parametric surface compiled for
/// evaluation, as returned by [`Library::parametric_coords`]: what the mesh
/// pipeline tessellates.
///
/// Each tape computes one coordinate with s read from the X input and t from
/// the Y input; the Z input is unused. Evaluating them with a
/// [`PointEvaluator`](crate::PointEvaluator) over [`Dual`](crate::Dual)
/// numbers, seeding s with the derivative `[1, 0, 0]` and t with
/// `[0, 1, 0]`, gives ∂/∂s and ∂/∂t exactly.
#[derive(Debug, Clone)]
pub struct ParametricCoords {
    /// The surface's name.
    pub name: String,
    /// x(s, t), y(s, t), z(s, t).
    pub coords: [Tape; 3],
    /// The parameter domain: [s_min, s_max], [t_min, t_max].
    pub domain: [[f64; 2]; 2],
}

impl ParametricCoords {
    /// The point (x, y, z) at (s, t) (allocates evaluators: for a few points only).
    pub fn point(&self, s: f64, t: f64) -> [f64; 3] {
        self.coords
            .each_ref()
            .map(|tape| crate::PointEvaluator::<f64>::new(tape).eval(&[], s, t, 0.0))
    }

    /// The point at (s, t) and its exact partial derivatives ∂/∂s and ∂/∂t
    /// (by dual numbers; allocates evaluators: for a few points only).
    pub fn point_and_derivatives(&self, s: f64, t: f64) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let (mut p, mut ds, mut dt) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        for (k, tape) in self.coords.iter().enumerate() {
            let v = crate::PointEvaluator::<crate::Dual>::new(tape).eval(
                &[],
                crate::Dual {
                    v: s,
                    d: [1.0, 0.0, 0.0],
                },
                crate::Dual {
                    v: t,
                    d: [0.0, 1.0, 0.0],
                },
                crate::Dual { v: 0.0, d: [0.0; 3] },
            );
            p[k] = v.v;
            ds[k] = v.d[0];
            dt[k] = v.d[1];
        }
        (p, ds, dt)
    }
}

/// A progress reporter whose stage names get a prefix (the surface's name).
struct Named {
    prefix: String,
    inner: std::sync::Arc<dyn isoray_job::Progress + Send>,
}

impl isoray_job::Progress for Named {
    fn update(&self, done: u64, total: u64) {
        self.inner.update(done, total)
    }
    fn stage(&self, name: &str) {
        self.inner.stage(&format!("{}{name}", self.prefix))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use isoray_algebra::parse_rational;

    fn rf(text: &str) -> RatFunc {
        parse_rational(&st_ring(), text).unwrap()
    }

    #[test]
    fn a_wrong_equation_fails_the_check() {
        let sphere = [
            rf("2*s/(s^2+t^2+1)"),
            rf("2*t/(s^2+t^2+1)"),
            rf("(s^2+t^2-1)/(s^2+t^2+1)"),
        ];
        let ring = xyz_ring();
        let right = isoray_algebra::parse_poly(&ring, "x^2 + y^2 + z^2 - 1").unwrap();
        let wrong = isoray_algebra::parse_poly(&ring, "x^2 + y^2 + z^2 - 1001/1000").unwrap();
        let (n, worst) = verify(&sphere, &right, [[-3.0, 3.0], [-3.0, 3.0]]);
        assert!(n > 300 && worst.unwrap().2 < 1e-12);
        let (_, worst) = verify(&sphere, &wrong, [[-3.0, 3.0], [-3.0, 3.0]]);
        assert!(worst.unwrap().2 > VERIFY_TOLERANCE);
    }

    #[test]
    fn bound_names_parse() {
        for n in BoundMethod::NAMES {
            assert!(BoundMethod::parse(n).is_some());
        }
        assert_eq!(BoundMethod::parse("exact"), None);
    }

    #[test]
    fn parametric_coords_evaluate_a_sphere_with_exact_derivatives() {
        let mut lib = Library::new();
        lib.add_parametric_surface(
            "ball",
            vec![("r".to_string(), Value::Float(2.0))],
            [
                ("r * cos(t) * cos(s)", 0),
                ("r * cos(t) * sin(s)", 1),
                ("r * sin(t)", 2),
            ],
            [[0.0, 2.0 * std::f64::consts::PI], [-1.5, 1.5]],
            SurfaceOptions::default(),
        )
        .unwrap();
        let c = lib.parametric_coords("ball", None).unwrap();
        assert_eq!(c.name, "ball");
        assert_eq!(c.domain, [[0.0, 2.0 * std::f64::consts::PI], [-1.5, 1.5]]);
        let (s, t) = (0.7, 0.3);
        let (p, ds, dt) = c.point_and_derivatives(s, t);
        let want = [2.0 * t.cos() * s.cos(), 2.0 * t.cos() * s.sin(), 2.0 * t.sin()];
        let want_ds = [-2.0 * t.cos() * s.sin(), 2.0 * t.cos() * s.cos(), 0.0];
        let want_dt = [-2.0 * t.sin() * s.cos(), -2.0 * t.sin() * s.sin(), 2.0 * t.cos()];
        for k in 0..3 {
            assert!((p[k] - want[k]).abs() < 1e-14);
            assert!((ds[k] - want_ds[k]).abs() < 1e-14);
            assert!((dt[k] - want_dt[k]).abs() < 1e-14);
        }
        assert_eq!(c.point(s, t), p);
        // Explicit parameters replace the defaults.
        let c3 = lib.parametric_coords("ball", Some(&[Value::Float(3.0)])).unwrap();
        assert!((c3.point(s, t)[2] - 3.0 * t.sin()).abs() < 1e-14);

        // Errors: unknown names, non-parametric surfaces, bad parameters.
        let e = lib.parametric_coords("bal", None).unwrap_err();
        assert!(e.message.contains("unknown surface `bal`"), "{e:?}");
        assert!(e.notes.iter().any(|n| n.contains("`ball`")), "{e:?}");
        lib.add_surface("blob", vec![], "length(p) - 1.0", 3).unwrap();
        let e = lib.parametric_coords("blob", None).unwrap_err();
        assert!(e.message.contains("not parametric"), "{e:?}");
        let e = lib
            .parametric_coords("ball", Some(&[Value::Float(1.0), Value::Float(2.0)]))
            .unwrap_err();
        assert!(e.message.contains("takes 1 parameter"), "{e:?}");
        let e = lib
            .parametric_coords("ball", Some(&[Value::Vec2([1.0, 2.0])]))
            .unwrap_err();
        assert!(e.message.contains("parameter `r`"), "{e:?}");
    }
}
