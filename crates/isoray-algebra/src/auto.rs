//! `implicitize --method auto`: choosing the implicitization method by an
//! estimate of its cost.
//!
//! The three methods scale differently with the degree D of the implicit
//! equation, which none of them knows in advance (the Bézout bound n² of a
//! parametrization of degree n overestimates it by the base points: the
//! random degree-3 cases of the implicitization bench have n² = 25 and
//! D = 8 to 12). So D is measured first, modulo a prime, in milliseconds:
//!
//! * a generic line meets the surface in D points, each the image of
//!   deg φ parameter values, where deg φ is the degree of the map (1 for a
//!   proper parametrization). The parameter values are the common zeros of
//!   two (for a plane curve, one) affine forms in the coordinates, written
//!   over the product Q of the denominators, away from Q = 0 (a variable w
//!   with 1 − wQ): their number is the dimension of the quotient ring, read
//!   off the leading monomials of a Gröbner basis modulo p;
//! * the fiber of a random parameter point, counted the same way, is deg φ.
//!
//! Then, with N(d) the number of monomials of degree ≤ d in the coordinates,
//! the estimates (seconds on the 2-core machine of `docs/BENCHMARKS.md`,
//! fitted to the implicitization bench and the bicubic patch) are
//!
//! * interpolation (told D): `INTERPOLATION · N(D)³`, a dense nullspace
//!   modulo a few primes; only for D ≤ its largest degree, 24;
//! * resultant: `RESULTANT · D⁵` (restrictions to (D + 1)² lines of
//!   determinants of a Dixon minor) plus the Dixon polynomial's work; only
//!   without affine base points (common zeros of every numerator and
//!   denominator, which make the resultant vanish), tested modulo p too;
//! * elimination (F4 in an elimination order): `ELIMINATION · N(D)³`, the
//!   most expensive in every measured case, but the only method that needs
//!   neither a degree nor the absence of base points.
//!
//! The methods are tried from the cheapest estimate up. Each but the last
//! gets a time box of `OVERRUN` × its estimate (at least `MIN_BOX`), so an
//! estimate that is badly off costs a bounded multiple of it; a method that
//! fails for its own reasons (base points, a nullspace that is not
//! one-dimensional) hands over to the next at once. When D cannot be
//! measured (the map is degenerate, or every trial prime is unlucky), the
//! order is resultant, elimination, interpolation with boxes of `MIN_BOX`.

use std::sync::Arc;
use std::time::{Duration, Instant};

use isoray_job::{CancelToken, Progress};

use crate::coeff::{Coeff, Field, Fp, Rat};
use crate::f4::f4_modp;
use crate::fglm::standard_monomials;
use crate::groebner::{Budget, GroebnerError, GroebnerOptions};
use crate::implicit::{implicitize_groebner, parse_parametrization, Implicit, ImplicitError};
use crate::interp::{implicitize_interpolation, InterpolationOptions};
use crate::monomial::{Monomial, MonomialOrder};
use crate::parse::RatFunc;
use crate::poly::{Poly, Ring};
use crate::surface_resultant::{implicitize_resultant, ResultantOptions};

/// An implicitization method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Gröbner elimination ([`implicitize_groebner`]).
    Groebner,
    /// Interpolation ([`implicitize_interpolation`]).
    Interpolation,
    /// Resultants ([`implicitize_resultant`]).
    Resultant,
}

impl Method {
    /// The method's name on the command line (`--method`).
    pub fn as_str(self) -> &'static str {
        match self {
            Method::Groebner => "groebner",
            Method::Interpolation => "interpolation",
            Method::Resultant => "resultant",
        }
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Seconds per N(D)³ of interpolation told the degree.
const INTERPOLATION: f64 = 3e-9;
/// Seconds per D⁵ of the resultant's modular images.
const RESULTANT: f64 = 1e-6;
/// Seconds per unit of estimated Dixon work (see `surface_resultant::dixon_work`).
const DIXON: f64 = 1e-7;
/// Seconds per N(D)³ of elimination.
const ELIMINATION: f64 = 8e-8;
/// A method may run this many times its estimate before the next one is tried.
const OVERRUN: f64 = 4.0;
/// The smallest time box.
const MIN_BOX: Duration = Duration::from_secs(1);

/// What the cost estimate measured and decided.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// The degree of the implicit equation, measured modulo a prime (`None`
    /// when it could not be).
    pub degree: Option<u32>,
    /// The degree of the map (parameter values per point of the image).
    pub map_degree: Option<u32>,
    /// Whether the numerators and denominators have common zeros (modulo p).
    pub base_points: bool,
    /// The methods in the order they are tried, with their estimated seconds.
    pub plan: Vec<(Method, Option<f64>)>,
}

impl std::fmt::Display for Estimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.degree, self.map_degree) {
            (Some(d), Some(m)) => write!(f, "implicit degree {d} (map degree {m}, measured modulo a prime)")?,
            _ => write!(f, "implicit degree not measured")?,
        }
        if self.base_points {
            write!(f, ", base points")?;
        }
        write!(f, "; estimates:")?;
        for (i, (m, c)) in self.plan.iter().enumerate() {
            let sep = if i == 0 { " " } else { ", " };
            match c {
                Some(c) => write!(f, "{sep}{m} {c:.3} s")?,
                None => write!(f, "{sep}{m} ?")?,
            }
        }
        Ok(())
    }
}

/// Options of [`implicitize_auto`].
#[derive(Clone, Default)]
pub struct AutoOptions {
    /// Wall-clock limit for everything.
    pub time: Option<Duration>,
    /// Cancelled to stop.
    pub interrupt: Option<CancelToken>,
    /// Told the stages: `auto: estimate`, then the chosen methods' own.
    pub progress: Option<Arc<dyn Progress + Send>>,
}

/// The outcome of [`implicitize_auto`]: the equation, the method that
/// found it and the estimate that chose it.
#[derive(Debug, Clone)]
pub struct AutoImplicit {
    /// The implicit equation.
    pub implicit: Implicit,
    /// The method that found it.
    pub method: Method,
    /// The estimate.
    pub estimate: Estimate,
}

/// Implicitizes with the cheapest method by the estimate described in the
/// module documentation, falling back to the next on failure or overrun.
///
/// ```
/// use isoray_algebra::auto::{implicitize_auto, AutoOptions};
///
/// let r = implicitize_auto(
///     &["2*s/(s^2+t^2+1)", "2*t/(s^2+t^2+1)", "(s^2+t^2-1)/(s^2+t^2+1)"],
///     &["s", "t"],
///     &AutoOptions::default(),
/// )
/// .unwrap();
/// assert_eq!(r.implicit.display(), "x^2 + y^2 + z^2 - 1");
/// assert_eq!(r.estimate.degree, Some(2));
/// ```
pub fn implicitize_auto(coords: &[&str], params: &[&str], opts: &AutoOptions) -> Result<AutoImplicit, ImplicitError> {
    let start = Instant::now();
    let funcs = parse_parametrization(coords, params)?;
    if let Some(p) = &opts.progress {
        p.stage("auto: estimate");
        p.update(0, 1);
    }
    let estimate = estimate(&funcs, params.len());
    if let Some(p) = &opts.progress {
        p.update(1, 1);
    }
    follow(coords, params, estimate, start, opts)
}

/// Tries the methods of `estimate.plan` in turn (see the module documentation).
fn follow(
    coords: &[&str],
    params: &[&str],
    estimate: Estimate,
    start: Instant,
    opts: &AutoOptions,
) -> Result<AutoImplicit, ImplicitError> {
    let mut last: Option<ImplicitError> = None;
    let n = estimate.plan.len();
    for (i, &(method, cost)) in estimate.plan.iter().enumerate() {
        if opts.interrupt.as_ref().is_some_and(|c| c.is_cancelled()) {
            return Err(ImplicitError::Cancelled);
        }
        let left = opts.time.map(|t| t.saturating_sub(start.elapsed()));
        if left.is_some_and(|l| l.is_zero()) {
            break;
        }
        let boxed = if i + 1 < n {
            let b = cost.map_or(MIN_BOX, |c| Duration::from_secs_f64(c * OVERRUN).max(MIN_BOX));
            Some(left.map_or(b, |l| l.min(b)))
        } else {
            left
        };
        let r = run(method, coords, params, boxed, estimate.degree, opts);
        match r {
            Ok(implicit) => {
                return Ok(AutoImplicit {
                    implicit,
                    method,
                    estimate,
                })
            }
            Err(e) if fatal(&e) => return Err(e),
            Err(e) => last = Some(e),
        }
    }
    let out_of_time = opts.time.filter(|&t| start.elapsed() >= t);
    Err(match (last, out_of_time) {
        (_, Some(t)) => ImplicitError::TimeLimit { limit: t.as_secs_f64() },
        (Some(e), None) => e,
        (None, None) => ImplicitError::Interpolation("no method applies".into()),
    })
}

/// Errors that no other method can avoid: bad input and cancellation.
fn fatal(e: &ImplicitError) -> bool {
    matches!(
        e,
        ImplicitError::Parse { .. }
            | ImplicitError::ZeroDenominator { .. }
            | ImplicitError::UsesCoordinate { .. }
            | ImplicitError::WrongParameterCount { .. }
            | ImplicitError::Cancelled
            | ImplicitError::Groebner(GroebnerError::Interrupted { .. })
    )
}

fn run(
    method: Method,
    coords: &[&str],
    params: &[&str],
    time: Option<Duration>,
    degree: Option<u32>,
    opts: &AutoOptions,
) -> Result<Implicit, ImplicitError> {
    match method {
        Method::Groebner => implicitize_groebner(
            coords,
            params,
            &GroebnerOptions {
                budget: Budget {
                    time,
                    interrupt: opts.interrupt.clone(),
                    ..Default::default()
                },
                progress: opts.progress.clone(),
                ..Default::default()
            },
        ),
        Method::Interpolation => implicitize_interpolation(
            coords,
            params,
            &InterpolationOptions {
                time,
                interrupt: opts.interrupt.clone(),
                progress: opts.progress.clone(),
                degree_hint: degree,
                ..Default::default()
            },
        ),
        Method::Resultant => implicitize_resultant(
            coords,
            params,
            &ResultantOptions {
                time,
                interrupt: opts.interrupt.clone(),
                progress: opts.progress.clone(),
            },
        ),
    }
}

/// N(d): monomials of degree ≤ d in `nc` variables.
fn monomial_count(nc: usize, d: u32) -> f64 {
    (1..=nc).map(|i| (d as f64 + i as f64) / i as f64).product()
}

/// Measures the degree and base points modulo a prime and orders the methods.
pub fn estimate(funcs: &[RatFunc], np: usize) -> Estimate {
    let nc = funcs.len();
    let measured = crate::modular_f4::primes()
        .skip(40)
        .take(3)
        .find_map(|p| Measure::new(funcs, np, p).and_then(|m| m.run()));
    let (degree, map_degree, base_points) = match measured {
        Some((d, m, b)) => (Some(d), Some(m), b),
        None => (None, None, false),
    };
    let dixon = if nc == 3 {
        crate::surface_resultant::dixon_work_of(funcs) as f64 * DIXON
    } else {
        0.0
    };
    let mut plan: Vec<(Method, Option<f64>)> = Vec::new();
    match degree {
        Some(d) => {
            let n3 = monomial_count(nc, d).powi(3);
            if !base_points {
                let modular = if nc == 3 {
                    RESULTANT * f64::from(d).powi(5)
                } else {
                    RESULTANT * f64::from(d).powi(3)
                };
                plan.push((Method::Resultant, Some(dixon + modular)));
            }
            if d <= InterpolationOptions::default().max_degree {
                plan.push((Method::Interpolation, Some(INTERPOLATION * n3)));
            }
            plan.push((Method::Groebner, Some(ELIMINATION * n3)));
            plan.sort_by(|a, b| a.1.partial_cmp(&b.1).expect("finite estimates"));
        }
        None => {
            plan.push((Method::Resultant, None));
            plan.push((Method::Groebner, None));
            plan.push((Method::Interpolation, None));
        }
    }
    Estimate {
        degree,
        map_degree,
        base_points,
        plan,
    }
}

/// The parametrization modulo p, in the ring (parameters, w).
struct Measure {
    ring: Ring,
    p: u64,
    np: usize,
    nums: Vec<Poly<Fp>>,
    dens: Vec<Poly<Fp>>,
    /// The product of the denominators.
    den_product: Poly<Fp>,
    rng: u64,
}

/// Options of the small Gröbner bases of the measurement: half a second each.
fn quick() -> GroebnerOptions {
    GroebnerOptions {
        budget: Budget {
            time: Some(Duration::from_millis(500)),
            ..Default::default()
        },
        ..Default::default()
    }
}

impl Measure {
    fn new(funcs: &[RatFunc], np: usize, p: u64) -> Option<Measure> {
        let mut names: Vec<String> = (0..np).map(|i| format!("t{i}")).collect();
        names.push("w".into());
        let ring = Ring::new(&names, MonomialOrder::DegRevLex);
        let map: Vec<usize> = (0..np).collect();
        let reduce = |f: &Poly<Rat>| -> Option<Poly<Fp>> {
            let terms: Option<Vec<(Monomial, Fp)>> = f
                .embed(&ring, &map)
                .terms()
                .iter()
                .map(|(m, c)| Fp::from_rat(c, p).map(|v| (m.clone(), v)))
                .collect();
            let g = Poly::from_terms(&ring, terms?);
            // The reduction must keep the degree (else p is unlucky).
            (g.degree() == f.degree()).then_some(g)
        };
        let mut nums = Vec::new();
        let mut dens = Vec::new();
        for f in funcs {
            nums.push(if f.num.is_zero() { Poly::zero() } else { reduce(&f.num)? });
            dens.push(reduce(&f.den)?);
        }
        let den_product = dens
            .iter()
            .fold(Poly::constant(&ring, Fp::new(1, p)), |q, d| q.mul(&ring, d));
        Some(Measure {
            ring,
            p,
            np,
            nums,
            dens,
            den_product,
            rng: 0x9E37_79B9_7F4A_7C15 ^ p,
        })
    }

    fn random(&mut self) -> Fp {
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        Fp::new((self.rng % (self.p - 1)) as i64 + 1, self.p)
    }

    fn constant(&self, c: Fp) -> Poly<Fp> {
        Poly::constant(&self.ring, c)
    }

    /// The number of common zeros of `eqs` where no denominator vanishes,
    /// or `None` when there are infinitely many (or too many to count).
    fn count(&self, eqs: &[Poly<Fp>]) -> Option<u32> {
        let ring = &self.ring;
        let w = Poly::monomial(Monomial::var(self.np + 1, self.np, 1), Fp::new(1, self.p));
        let mut gens: Vec<Poly<Fp>> = eqs.iter().filter(|e| !e.is_zero()).cloned().collect();
        gens.push(
            self.constant(Fp::new(1, self.p))
                .sub(ring, &self.den_product.mul(ring, &w)),
        );
        let (basis, _) = f4_modp(ring, &gens, &quick()).ok()?;
        if basis.iter().any(|g| g.is_constant()) {
            return Some(0);
        }
        let std = standard_monomials(ring, &basis, 100_000).ok()?;
        u32::try_from(std.len()).ok()
    }

    /// Evaluates a polynomial at a point of the parameters.
    fn eval(&self, f: &Poly<Fp>, at: &[Fp]) -> Fp {
        let mut sum = Fp::new(0, self.p);
        for (m, c) in f.terms() {
            let mut t = *c;
            for (i, a) in at.iter().enumerate() {
                for _ in 0..m.exp(i) {
                    t = t.mul(a);
                }
            }
            sum = sum.add(&t);
        }
        sum
    }

    /// (implicit degree, map degree, base points).
    fn run(mut self) -> Option<(u32, u32, bool)> {
        let ring = self.ring.clone();
        let nc = self.nums.len();
        // Base points: common zeros of every numerator and denominator.
        let gens: Vec<Poly<Fp>> = self
            .nums
            .iter()
            .chain(&self.dens)
            .filter(|g| !g.is_zero())
            .cloned()
            .collect();
        let base_points = gens.iter().all(|g| !g.is_constant()) && {
            let (basis, _) = f4_modp(&ring, &gens, &quick()).ok()?;
            !basis.iter().any(|g| g.is_constant())
        };
        // The fiber of a random parameter point.
        let point = loop {
            let pt: Vec<Fp> = (0..self.np).map(|_| self.random()).collect();
            if self.dens.iter().all(|d| self.eval(d, &pt).value() != 0) {
                break pt;
            }
        };
        let fiber: Vec<Poly<Fp>> = (0..nc)
            .map(|i| {
                let c = self
                    .eval(&self.nums[i], &point)
                    .mul(&self.eval(&self.dens[i], &point).inv());
                self.nums[i].sub(&ring, &self.dens[i].scale(&c))
            })
            .collect();
        let map_degree = self.count(&fiber)?;
        if map_degree == 0 {
            return None;
        }
        // The section by np random hyperplanes, over the product of the
        // denominators: Σ aᵢ·numᵢ·Π_{j≠i} denⱼ + e·Π denⱼ.
        let cleared: Vec<Poly<Fp>> = (0..nc)
            .map(|i| {
                self.dens
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .fold(self.nums[i].clone(), |t, (_, d)| t.mul(&ring, d))
            })
            .collect();
        let mut section = Vec::new();
        for _ in 0..self.np {
            let mut eq = Poly::zero();
            for c in &cleared {
                let a = self.random();
                eq = eq.add(&ring, &c.scale(&a));
            }
            let e = self.random();
            section.push(eq.add(&ring, &self.den_product.scale(&e)));
        }
        let points = self.count(&section)?;
        if points == 0 || points % map_degree != 0 {
            return None;
        }
        Some((points / map_degree, map_degree, base_points))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measured(coords: &[&str], params: &[&str]) -> Estimate {
        estimate(&parse_parametrization(coords, params).unwrap(), params.len())
    }

    #[test]
    fn degrees_of_known_surfaces() {
        // The stereographic sphere: degree 2, proper, base points at infinity only.
        let e = measured(
            &["2*s/(s^2+t^2+1)", "2*t/(s^2+t^2+1)", "(s^2+t^2-1)/(s^2+t^2+1)"],
            &["s", "t"],
        );
        assert_eq!((e.degree, e.map_degree, e.base_points), (Some(2), Some(1), false));
        // A paraboloid parametrized twice over: (s², t, s⁴ + t²) covers each point twice.
        let e = measured(&["s^2", "t", "s^4+t^2"], &["s", "t"]);
        assert_eq!((e.degree, e.map_degree), (Some(2), Some(2)));
        // Random-9 of the implicitization bench: Bézout bound 25, degree 8.
        let e = measured(
            &[
                "(-2*s^2*t-2)/(-1*s-3)",
                "(-2*s^3-1*s^2*t)/(-2*s+1)",
                "(-1*s^3+1*s*t^2)/(2*t+2)",
            ],
            &["s", "t"],
        );
        assert_eq!(e.degree, Some(8));
        // The plane curve (t², t³): the cuspidal cubic.
        let e = measured(&["t^2", "t^3"], &["t"]);
        assert_eq!((e.degree, e.map_degree), (Some(3), Some(1)));
    }

    #[test]
    fn base_points_are_seen() {
        // Every numerator (s, t, st) and the denominator s + t vanish at s = t = 0.
        let e = measured(&["s/(s+t)", "t/(s+t)", "(s*t)/(s+t)"], &["s", "t"]);
        assert!(e.base_points, "{e}");
        assert!(e.plan.iter().all(|(m, _)| *m != Method::Resultant), "{e}");
    }

    #[test]
    fn a_failing_method_hands_over_to_the_next() {
        // Affine base point at s = t = 0: the resultant vanishes identically.
        let coords = ["s/(s^2+t^2)", "t/(s^2+t^2)", "s*t/(s^2+t^2)"];
        let mut e = measured(&coords, &["s", "t"]);
        assert!(e.base_points);
        e.plan = vec![(Method::Resultant, Some(0.0)), (Method::Interpolation, Some(0.0))];
        let r = follow(&coords, &["s", "t"], e, Instant::now(), &AutoOptions::default()).unwrap();
        assert_eq!(r.method, Method::Interpolation);
        let g = implicitize_groebner(&coords, &["s", "t"], &GroebnerOptions::default()).unwrap();
        assert_eq!(r.implicit.display(), g.display());
        // Bad input stops at once.
        let e = Estimate {
            degree: None,
            map_degree: None,
            base_points: false,
            plan: vec![(Method::Resultant, None), (Method::Groebner, None)],
        };
        let r = follow(
            &["s+", "t", "s"],
            &["s", "t"],
            e,
            Instant::now(),
            &AutoOptions::default(),
        );
        assert!(matches!(r, Err(ImplicitError::Parse { .. })), "{r:?}");
    }

    #[test]
    fn the_plan_follows_the_estimates() {
        let e = measured(
            &["2*s/(s^2+t^2+1)", "2*t/(s^2+t^2+1)", "(s^2+t^2-1)/(s^2+t^2+1)"],
            &["s", "t"],
        );
        let costs: Vec<f64> = e.plan.iter().map(|(_, c)| c.unwrap()).collect();
        assert!(costs.windows(2).all(|w| w[0] <= w[1]), "{e}");
        assert_eq!(e.plan.len(), 3);
    }
}
