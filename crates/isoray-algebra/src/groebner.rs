//! Gröbner bases by Buchberger's algorithm.
//!
//! * Pair selection by the sugar strategy (Giovini, Mora, Niesi, Robbiano,
//!   Traverso 1991) or the normal strategy.
//! * Pairs are installed with Gebauer and Möller's criteria (Becker and
//!   Weispfenning, *Gröbner Bases*, algorithm UPDATE): the chain criterion in
//!   its M, F and B_k forms, and the product criterion.
//! * Over Q the computation is fraction-free: polynomials are kept primitive
//!   with integer coefficients, and reduction computes a·f − b·m·g.
//! * The output is the reduced basis: minimal, interreduced, normalised (monic
//!   over a field), sorted by increasing leading monomial.

use std::borrow::Cow;
use std::sync::Arc;
use std::time::{Duration, Instant};

use isoray_job::Progress;
use num_traits::One;

use crate::coeff::{from_zint, to_zint, Coeff, Domain, Rat, ZInt};
use crate::monomial::Monomial;
use crate::parse::{to_primitive_integer, to_rational};
use crate::poly::{Poly, Ring};

/// Pair selection strategy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Strategy {
    /// Smallest sugar degree first, ties by smallest lcm (the default).
    #[default]
    Sugar,
    /// Smallest lcm first.
    Normal,
}

/// Limits on a computation. The default is unlimited.
#[derive(Debug, Clone, Default)]
pub struct Budget {
    /// Wall-clock limit.
    pub time: Option<Duration>,
    /// Limit on reduction steps (a measure of work independent of the machine).
    pub steps: Option<u64>,
    /// Cancelled (from another thread or a signal handler) to stop.
    pub interrupt: Option<isoray_job::CancelToken>,
}

/// Options of [`groebner`].
#[derive(Clone, Default)]
pub struct GroebnerOptions {
    /// Pair selection.
    pub strategy: Strategy,
    /// Limits.
    pub budget: Budget,
    /// The engine: F4 (multi-modular over Q) or Buchberger.
    pub algorithm: Algorithm,
    /// How bases over Q are computed by Buchberger's algorithm.
    pub method: Method,
    /// How F4's multi-modular result over Q is checked.
    pub verify: crate::modular_f4::Verify,
    /// Which criteria discard S-pairs (both by default; switching them off
    /// changes the work, never the basis).
    pub criteria: Criteria,
    /// Told how far the computation got (none by default):
    ///
    /// * each Buchberger run is a stage `groebner`: `done` is the S-pairs
    ///   reduced, `total` those and the S-pairs waiting (it grows as new
    ///   basis elements bring pairs);
    /// * then a stage `interreduction`: elements reduced of the basis size;
    /// * the multi-modular method adds, per prime, `replay` (steps of the
    ///   first prime's trace replayed, of its length) and `verification`
    ///   (pairs and inputs checked, of those to check), and prefixes the
    ///   stage names by `modular, prime K: `.
    ///
    /// `done` never decreases within a stage and equals `total` when a stage
    /// completes (a verification that fails, and the fraction-free attempt
    /// that [`Method::Auto`] abandons for the multi-modular method, stop
    /// short).
    pub progress: Option<Arc<dyn Progress + Send>>,
}

/// The criteria that discard S-pairs before they are reduced (Buchberger's
/// first and second criteria in Gebauer and Möller's installation), for
/// both engines. The thesis's ablation switches them off
/// (`isoray groebner --no-criteria`, `--no-chain-criterion`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Criteria {
    /// Drop pairs whose leading monomials are coprime (first criterion).
    pub product: bool,
    /// The chain criterion: Gebauer–Möller's M, F and B_k.
    pub chain: bool,
}

impl Default for Criteria {
    fn default() -> Criteria {
        Criteria {
            product: true,
            chain: true,
        }
    }
}

impl Criteria {
    /// No criterion: every pair is reduced.
    pub const NONE: Criteria = Criteria {
        product: false,
        chain: false,
    };
}

impl std::fmt::Debug for GroebnerOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GroebnerOptions")
            .field("strategy", &self.strategy)
            .field("budget", &self.budget)
            .field("algorithm", &self.algorithm)
            .field("method", &self.method)
            .field("verify", &self.verify)
            .field("criteria", &self.criteria)
            .field("progress", &self.progress.is_some())
            .finish()
    }
}

/// A [`Progress`] that forwards to another with every stage name prefixed.
struct Prefixed {
    prefix: String,
    inner: Arc<dyn Progress + Send>,
}

impl Progress for Prefixed {
    fn update(&self, done: u64, total: u64) {
        self.inner.update(done, total);
    }
    fn stage(&self, name: &str) {
        self.inner.stage(&format!("{}{name}", self.prefix));
    }
}

/// `progress` with every stage name prefixed by `prefix()` (`None` stays `None`).
pub(crate) fn prefixed_progress(
    progress: &Option<Arc<dyn Progress + Send>>,
    prefix: impl FnOnce() -> String,
) -> Option<Arc<dyn Progress + Send>> {
    progress.as_ref().map(|inner| {
        Arc::new(Prefixed {
            prefix: prefix(),
            inner: inner.clone(),
        }) as Arc<dyn Progress + Send>
    })
}

/// `opts` whose progress stages are prefixed by `prefix()`; borrowed unchanged without progress.
pub(crate) fn with_stage_prefix(opts: &GroebnerOptions, prefix: impl FnOnce() -> String) -> Cow<'_, GroebnerOptions> {
    match &opts.progress {
        None => Cow::Borrowed(opts),
        Some(_) => Cow::Owned(GroebnerOptions {
            progress: prefixed_progress(&opts.progress, prefix),
            ..opts.clone()
        }),
    }
}

/// Which engine [`groebner`] runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Algorithm {
    /// Faugère's F4 ([`crate::f4`]); over Q multi-modular with a learned
    /// trace ([`crate::modular_f4`]), checked as [`GroebnerOptions::verify`] says.
    #[default]
    F4,
    /// Buchberger's algorithm with the sugar strategy, the reference
    /// engine; over Q as [`GroebnerOptions::method`] says.
    Buchberger,
}

/// How [`groebner`] computes a basis over Q with [`Algorithm::Buchberger`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Fraction-free, switching to multi-modular when intermediate
    /// coefficients grow large.
    #[default]
    Auto,
    /// Fraction-free Buchberger over Z.
    FractionFree,
    /// Multi-modular with verification over Q ([`crate::modular`]).
    Modular,
}

/// Counters of a run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// S-pairs created.
    pub pairs_created: u64,
    /// Pairs removed by the product criterion (coprime leading monomials).
    pub removed_product: u64,
    /// Pairs removed by the chain criterion (M and F among new pairs, B_k among old ones).
    pub removed_chain: u64,
    /// S-polynomials reduced.
    pub pairs_reduced: u64,
    /// Of those, the ones that reduced to zero.
    pub zero_reductions: u64,
    /// Single reduction steps a·f − b·m·g.
    pub reduction_steps: u64,
    /// Size of the reduced basis.
    pub basis_size: usize,
    /// Wall-clock time.
    pub time: Duration,
}

impl Stats {
    /// Adds the work counters of `o` (pairs, reductions), not its basis size or time.
    pub fn add_work(&mut self, o: &Stats) {
        self.pairs_created += o.pairs_created;
        self.removed_product += o.removed_product;
        self.removed_chain += o.removed_chain;
        self.pairs_reduced += o.pairs_reduced;
        self.zero_reductions += o.zero_reductions;
        self.reduction_steps += o.reduction_steps;
    }
}

impl std::fmt::Display for Stats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "pairs created: {}\npairs removed by the product criterion: {}\npairs removed by the chain criterion: {}\npairs reduced: {}\nreductions to zero: {}\nreduction steps: {}\nbasis size: {}\ntime: {:.6} s",
            self.pairs_created,
            self.removed_product,
            self.removed_chain,
            self.pairs_reduced,
            self.zero_reductions,
            self.reduction_steps,
            self.basis_size,
            self.time.as_secs_f64()
        )
    }
}

/// Why a computation stopped early.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GroebnerError {
    /// The time budget ran out.
    #[error("time limit of {limit:.1} s exceeded after {} reduction steps", stats.reduction_steps)]
    Timeout {
        /// The limit in seconds.
        limit: f64,
        /// Work done until then.
        stats: Stats,
    },
    /// The step budget ran out.
    #[error("work limit of {limit} reduction steps exceeded")]
    WorkLimit {
        /// The limit.
        limit: u64,
        /// Work done until then.
        stats: Stats,
    },
    /// Intermediate coefficients grew past the bound of [`Method::Auto`]'s
    /// fraction-free attempt (internal: Auto then switches methods).
    #[error("coefficients grew to {bits} bits")]
    CoefficientGrowth {
        /// The size reached.
        bits: u64,
    },
    /// The interrupt flag was set.
    #[error("interrupted after {} reduction steps", stats.reduction_steps)]
    Interrupted {
        /// Work done until then.
        stats: Stats,
    },
}

/// A reduced Gröbner basis over Q and the statistics of its computation.
#[derive(Debug, Clone)]
pub struct GroebnerResult {
    /// The reduced basis: monic, sorted by increasing leading monomial.
    pub basis: Vec<Poly<Rat>>,
    /// Counters.
    pub stats: Stats,
}

/// The reduced Gröbner basis over Q of the ideal generated by `polys`: by
/// multi-modular F4 (the default), or by Buchberger's algorithm with the
/// method `opts.method` (by default the faster of fraction-free and modular).
pub fn groebner(ring: &Ring, polys: &[Poly<Rat>], opts: &GroebnerOptions) -> Result<GroebnerResult, GroebnerError> {
    if opts.algorithm == Algorithm::F4 {
        return crate::modular_f4::groebner_f4_rational(ring, polys, opts, opts.verify)
            .map(|(basis, stats)| GroebnerResult { basis, stats });
    }
    match opts.method {
        Method::FractionFree => groebner_fraction_free(ring, polys, opts),
        Method::Modular => {
            crate::modular::groebner_modular(ring, polys, opts).map(|(basis, stats)| GroebnerResult { basis, stats })
        }
        Method::Auto => auto(ring, polys, opts),
    }
}

/// Fraction-free first; if intermediate coefficients grow past a bound
/// (max(256, 4 × the inputs' largest coefficient) bits) the computation
/// switches to the multi-modular method, whose cost does not depend on them.
fn auto(ring: &Ring, polys: &[Poly<Rat>], opts: &GroebnerOptions) -> Result<GroebnerResult, GroebnerError> {
    let start = Instant::now();
    let ints = primitive_inputs(ring, polys);
    let input_bits = ints
        .iter()
        .flat_map(|p| p.terms().iter().map(|t| Coeff::bit_len(&t.1)))
        .max()
        .unwrap_or(0) as u64;
    let limit = GrowthLimit(256.max(4 * input_bits));
    match groebner_in_limited(ring, &ints, opts, Some(limit)) {
        Ok((basis, stats)) => Ok(GroebnerResult {
            basis: monic_rationals(ring, &basis),
            stats,
        }),
        Err(GroebnerError::CoefficientGrowth { .. }) => {
            crate::modular::groebner_modular(ring, polys, opts).map(|(basis, stats)| GroebnerResult {
                basis,
                // The time includes the abandoned fraction-free attempt.
                stats: Stats {
                    time: start.elapsed(),
                    ..stats
                },
            })
        }
        Err(e) => Err(e),
    }
}

fn primitive_inputs(ring: &Ring, polys: &[Poly<Rat>]) -> Vec<Poly<ZInt>> {
    polys
        .iter()
        .map(|p| to_primitive_integer(ring, &p.reorder(ring)).map_coeffs(ring, to_zint))
        .collect()
}

fn monic_rationals(ring: &Ring, basis: &[Poly<ZInt>]) -> Vec<Poly<Rat>> {
    basis
        .iter()
        .map(|p| {
            let q = to_rational(&p.map_coeffs(ring, from_zint));
            let lc = q.lc().cloned().unwrap_or_else(Rat::one);
            q.scale(&lc.recip())
        })
        .collect()
}

/// Abort a fraction-free run when a new element has a coefficient of more bits than this.
#[derive(Debug, Clone, Copy)]
struct GrowthLimit(u64);

/// The reduced Gröbner basis over Q, computed fraction-free over Z.
pub fn groebner_fraction_free(
    ring: &Ring,
    polys: &[Poly<Rat>],
    opts: &GroebnerOptions,
) -> Result<GroebnerResult, GroebnerError> {
    let (basis, stats) = groebner_in(ring, &primitive_inputs(ring, polys), opts)?;
    Ok(GroebnerResult {
        basis: monic_rationals(ring, &basis),
        stats,
    })
}

/// Stops a computation that began at `start` when `budget` is spent
/// (time, steps, interrupt), with the work `stats` done until then.
pub(crate) fn check_budget(b: &Budget, start: Instant, stats: &Stats) -> Result<(), GroebnerError> {
    let snapshot = || Stats {
        time: start.elapsed(),
        ..*stats
    };
    if let Some(t) = b.time {
        if start.elapsed() > t {
            return Err(GroebnerError::Timeout {
                limit: t.as_secs_f64(),
                stats: snapshot(),
            });
        }
    }
    if let Some(n) = b.steps {
        if stats.reduction_steps > n {
            return Err(GroebnerError::WorkLimit {
                limit: n,
                stats: snapshot(),
            });
        }
    }
    if let Some(token) = &b.interrupt {
        if token.is_cancelled() {
            return Err(GroebnerError::Interrupted { stats: snapshot() });
        }
    }
    Ok(())
}

/// The reduced Gröbner basis over any [`Domain`] (Z fraction-free, Q, GF(p)):
/// elements normalised by [`Domain::normalize`].
pub fn groebner_in<D: Domain>(
    ring: &Ring,
    polys: &[Poly<D>],
    opts: &GroebnerOptions,
) -> Result<(Vec<Poly<D>>, Stats), GroebnerError> {
    groebner_traced(ring, polys, opts).map(|(b, s, _)| (b, s))
}

/// A basis with the statistics of its computation.
pub type Basis<D> = (Vec<Poly<D>>, Stats);

/// The useful work of a Buchberger run: the S-pairs (by element index) that
/// gave new basis elements, in order, and the leading monomial each gave.
/// Replaying it modulo another prime skips every reduction to zero
/// (Traverso's Gröbner trace).
#[derive(Debug, Clone, Default)]
pub struct Trace {
    inputs: Vec<Monomial>,
    steps: Vec<(usize, usize, Monomial)>,
}

/// Inputs, normalised, nonzero, in the order a run inserts them.
fn prepared_inputs<D: Domain>(ring: &Ring, polys: &[Poly<D>]) -> Vec<Poly<D>> {
    let mut inputs: Vec<Poly<D>> = polys
        .iter()
        .filter(|p| !p.is_zero())
        .map(|p| p.reorder(ring).normalized())
        .collect();
    // Small leading monomials first: fewer pairs survive the criteria.
    inputs.sort_by(|a, b| ring.cmp(a.lm().expect("nonzero"), b.lm().expect("nonzero")));
    inputs
}

/// [`groebner_in`], also returning the run's [`Trace`].
pub fn groebner_traced<D: Domain>(
    ring: &Ring,
    polys: &[Poly<D>],
    opts: &GroebnerOptions,
) -> Result<(Vec<Poly<D>>, Stats, Trace), GroebnerError> {
    run(ring, polys, opts, None)
}

fn groebner_in_limited<D: Domain>(
    ring: &Ring,
    polys: &[Poly<D>],
    opts: &GroebnerOptions,
    limit: Option<GrowthLimit>,
) -> Result<(Vec<Poly<D>>, Stats), GroebnerError> {
    run(ring, polys, opts, limit).map(|(b, s, _)| (b, s))
}

fn run<D: Domain>(
    ring: &Ring,
    polys: &[Poly<D>],
    opts: &GroebnerOptions,
    limit: Option<GrowthLimit>,
) -> Result<(Vec<Poly<D>>, Stats, Trace), GroebnerError> {
    let mut st = State::new(ring, opts);
    let mut trace = Trace::default();
    st.stage("groebner");
    // The inputs enter as they are (Buchberger's algorithm as stated; the
    // criteria take care of what they share).
    for h in prepared_inputs(ring, polys) {
        let sugar = h.degree() as u32;
        trace.inputs.push(h.lm().expect("nonzero").clone());
        st.update(h, sugar);
    }
    st.report_pairs(0, 0);
    while let Some(pair) = st.select() {
        st.check()?;
        let s = st.spoly(&pair);
        st.stats.pairs_reduced += 1;
        let h = st.reduce_full(&s, None)?;
        if h.is_zero() {
            st.stats.zero_reductions += 1;
            st.report_pairs(st.stats.pairs_reduced, 0);
            continue;
        }
        let h = h.normalized();
        if let Some(GrowthLimit(bits)) = limit {
            let grown = h.terms().iter().map(|t| t.1.bit_len()).max().unwrap_or(0) as u64;
            if grown > bits {
                return Err(GroebnerError::CoefficientGrowth { bits: grown });
            }
        }
        trace.steps.push((pair.i, pair.j, h.lm().expect("nonzero").clone()));
        st.update(h, pair.sugar);
        st.report_pairs(st.stats.pairs_reduced, 0);
    }
    let basis = st.interreduce()?;
    st.stats.basis_size = basis.len();
    st.stats.time = st.start.elapsed();
    Ok((basis, st.stats, trace))
}

/// Replays a [`Trace`] on the same inputs over another domain (another prime).
/// Returns `None` when the run diverges from the trace (an unlucky prime);
/// the caller then computes normally.
pub fn groebner_replay<D: Domain>(
    ring: &Ring,
    polys: &[Poly<D>],
    trace: &Trace,
    opts: &GroebnerOptions,
) -> Result<Option<Basis<D>>, GroebnerError> {
    let mut st = State::new(ring, opts);
    let inputs = prepared_inputs(ring, polys);
    let mut k = 0;
    for h in inputs {
        if trace.inputs.get(k) != h.lm() {
            return Ok(None);
        }
        k += 1;
        st.insert(h);
    }
    if k != trace.inputs.len() {
        return Ok(None);
    }
    st.stage("replay");
    let steps = trace.steps.len() as u64;
    st.report(0, steps);
    for (n, (i, j, lm)) in trace.steps.iter().enumerate() {
        st.check()?;
        let (Some(a), Some(b)) = (st.polys.get(*i), st.polys.get(*j)) else {
            return Ok(None);
        };
        let lcm = a.poly.lm().expect("nonzero").lcm(b.poly.lm().expect("nonzero"));
        let s = st.spoly(&Pair {
            i: *i,
            j: *j,
            lcm,
            sugar: 0,
        });
        st.stats.pairs_reduced += 1;
        let h = st.reduce_full(&s, None)?;
        if h.is_zero() {
            return Ok(None);
        }
        let h = h.normalized();
        if h.lm() != Some(lm) {
            return Ok(None);
        }
        st.insert(h);
        st.report(n as u64 + 1, steps);
    }
    let basis = st.interreduce()?;
    st.stats.basis_size = basis.len();
    st.stats.time = st.start.elapsed();
    Ok(Some((basis, st.stats)))
}

struct Pair {
    i: usize,
    j: usize,
    lcm: Monomial,
    sugar: u32,
}

struct Element<D> {
    poly: Poly<D>,
    sugar: u32,
    mask: u64,
}

struct State<'a, D> {
    ring: &'a Ring,
    opts: &'a GroebnerOptions,
    polys: Vec<Element<D>>,
    basis: Vec<usize>,
    pairs: Vec<Pair>,
    stats: Stats,
    start: Instant,
}

/// Bit i set when variable i (mod 64) occurs: a fast test that rules out divisibility.
fn mask(m: &Monomial) -> u64 {
    m.exps()
        .iter()
        .enumerate()
        .filter(|(_, &e)| e > 0)
        .fold(0u64, |acc, (i, _)| acc | (1 << (i % 64)))
}

impl<'a, D: Domain> State<'a, D> {
    fn new(ring: &'a Ring, opts: &'a GroebnerOptions) -> Self {
        State {
            ring,
            opts,
            polys: Vec::new(),
            basis: Vec::new(),
            pairs: Vec::new(),
            stats: Stats::default(),
            start: Instant::now(),
        }
    }

    fn check(&mut self) -> Result<(), GroebnerError> {
        check_budget(&self.opts.budget, self.start, &self.stats)
    }

    fn lm(&self, k: usize) -> &Monomial {
        self.polys[k].poly.lm().expect("basis elements are nonzero")
    }

    /// Tells the options' progress (if any) that stage `name` begins.
    fn stage(&self, name: &str) {
        if let Some(p) = &self.opts.progress {
            p.stage(name);
        }
    }

    /// Tells the options' progress (if any) `done` of `total`.
    fn report(&self, done: u64, total: u64) {
        if let Some(p) = &self.opts.progress {
            p.update(done, total);
        }
    }

    /// Reports `done` pairs of `done` + the pairs waiting + `more` (units still to come).
    fn report_pairs(&self, done: u64, more: u64) {
        if let Some(p) = &self.opts.progress {
            p.update(done, done + self.pairs.len() as u64 + more);
        }
    }

    /// Chooses and removes the next pair.
    fn select(&mut self) -> Option<Pair> {
        if self.pairs.is_empty() {
            return None;
        }
        let ring = self.ring;
        let mut best = 0;
        for k in 1..self.pairs.len() {
            let (a, b) = (&self.pairs[k], &self.pairs[best]);
            let better = match self.opts.strategy {
                Strategy::Sugar => a.sugar < b.sugar || (a.sugar == b.sugar && ring.cmp(&a.lcm, &b.lcm).is_lt()),
                Strategy::Normal => ring.cmp(&a.lcm, &b.lcm).is_lt(),
            };
            if better {
                best = k;
            }
        }
        Some(self.pairs.swap_remove(best))
    }

    fn spoly(&self, p: &Pair) -> Poly<D> {
        let (f, g) = (&self.polys[p.i].poly, &self.polys[p.j].poly);
        let (lf, lg) = (f.lc().expect("nonzero"), g.lc().expect("nonzero"));
        let (a, b) = D::cancel(lf, lg);
        let mf = self.lm(p.i).quotient(&p.lcm).expect("lcm is a multiple");
        let mg = self.lm(p.j).quotient(&p.lcm).expect("lcm is a multiple");
        let fa = f.mul_term(&mf, &a);
        let gb = g.mul_term(&mg, &b);
        fa.sub(self.ring, &gb)
    }

    /// Fully reduces f modulo the current basis (all elements except `skip`).
    /// (Top reduction only, with tails left for the final interreduction, was
    /// measured 2–16× slower on katsura and cyclic.)
    fn reduce_full(&mut self, f: &Poly<D>, skip: Option<usize>) -> Result<Poly<D>, GroebnerError> {
        let ring = self.ring;
        // p is kept in increasing order, so that its leading term is at the end.
        let mut p: Vec<(Monomial, D)> = f.terms().iter().rev().cloned().collect();
        let mut rem: Vec<(Monomial, D)> = Vec::new();
        let mut steps_since_check = 0u32;
        while let Some((lm, lc)) = p.last() {
            let lmask = mask(lm);
            let divisor = self.basis.iter().copied().filter(|&k| Some(k) != skip).find(|&k| {
                let e = &self.polys[k];
                e.mask & !lmask == 0 && e.poly.lm().is_some_and(|g| g.divides(lm))
            });
            let Some(k) = divisor else {
                rem.push(p.pop().expect("nonempty"));
                continue;
            };
            let g = &self.polys[k].poly;
            let (a, b) = D::cancel(lc, g.lc().expect("nonzero"));
            let q = g.lm().expect("nonzero").quotient(lm).expect("divides");
            let minus_b = b.neg();
            p.pop(); // the leading terms cancel
            if !a.is_one() {
                for t in p.iter_mut() {
                    t.1 = t.1.mul(&a);
                }
                for t in rem.iter_mut() {
                    t.1 = t.1.mul(&a);
                }
            }
            let tail = g.terms()[1..].iter().rev().map(|(m, c)| (m.mul(&q), c.mul(&minus_b)));
            p = merge_ascending(ring, p, tail);
            self.stats.reduction_steps += 1;
            steps_since_check += 1;
            if steps_since_check >= 64 {
                steps_since_check = 0;
                if D::FRACTION_FREE {
                    // Keep coefficients small during long reductions.
                    let mut all: Vec<D> = rem.iter().chain(p.iter()).map(|t| t.1.clone()).collect();
                    if !all.is_empty() {
                        let first = all[0].clone();
                        D::normalize(&mut all);
                        if all[0] != first {
                            let (r2, p2) = all.split_at(rem.len());
                            for (t, c) in rem.iter_mut().zip(r2) {
                                t.1 = c.clone();
                            }
                            for (t, c) in p.iter_mut().zip(p2) {
                                t.1 = c.clone();
                            }
                        }
                    }
                }
                self.check()?;
            }
        }
        Ok(Poly::from_sorted(rem))
    }

    /// Adds a basis element without creating pairs (for trace replays).
    fn insert(&mut self, h: Poly<D>) {
        let hm = h.lm().expect("nonzero").clone();
        let new = self.polys.len();
        self.polys.push(Element {
            mask: mask(&hm),
            poly: h,
            sugar: 0,
        });
        let polys = &self.polys;
        self.basis
            .retain(|&g| !hm.divides(polys[g].poly.lm().expect("nonzero")));
        self.basis.push(new);
    }

    /// Gebauer–Möller installation of a new basis element.
    fn update(&mut self, h: Poly<D>, sugar: u32) {
        let hm = h.lm().expect("nonzero").clone();
        let new = self.polys.len();
        self.polys.push(Element {
            mask: mask(&hm),
            poly: h,
            sugar,
        });
        // New pairs (g, h) for g in the basis.
        let mut cands: Vec<(usize, Monomial, bool)> = self
            .basis
            .iter()
            .map(|&g| {
                let gm = self.lm(g);
                (g, gm.lcm(&hm), gm.coprime(&hm))
            })
            .collect();
        self.stats.pairs_created += cands.len() as u64;
        // Criterion M and F: drop a pair whose lcm is a multiple of another new pair's lcm
        // (for equal lcms keep the last; coprime pairs are kept here so they can remove others).
        let criteria = self.opts.criteria;
        let mut keep: Vec<(usize, Monomial, bool)> = Vec::new();
        while let Some((g1, l1, coprime)) = cands.pop() {
            let dominated = criteria.chain
                && (cands.iter().any(|(_, l2, _)| l2.divides(&l1)) || keep.iter().any(|(_, l2, _)| l2.divides(&l1)));
            if coprime || !dominated {
                keep.push((g1, l1, coprime));
            } else {
                self.stats.removed_chain += 1;
            }
        }
        // Product criterion.
        let before = keep.len();
        if criteria.product {
            keep.retain(|(_, _, coprime)| !coprime);
        }
        self.stats.removed_product += (before - keep.len()) as u64;
        // Criterion B_k on the old pairs.
        let old = std::mem::take(&mut self.pairs);
        for p in old {
            let (li, lj) = (self.lm(p.i).lcm(&hm), self.lm(p.j).lcm(&hm));
            if criteria.chain && hm.divides(&p.lcm) && li != p.lcm && lj != p.lcm {
                self.stats.removed_chain += 1;
            } else {
                self.pairs.push(p);
            }
        }
        for (g, lcm, _) in keep {
            let sg = self.polys[g].sugar + lcm.degree() - self.lm(g).degree();
            let sh = sugar + lcm.degree() - hm.degree();
            self.pairs.push(Pair {
                i: g,
                j: new,
                sugar: sg.max(sh),
                lcm,
            });
        }
        // Basis elements whose leading monomial is a multiple of lm(h) are
        // no longer needed for new pairs (the chain criterion's reason).
        if criteria.chain {
            let polys = &self.polys;
            self.basis
                .retain(|&g| !hm.divides(polys[g].poly.lm().expect("nonzero")));
        }
        self.basis.push(new);
    }

    /// The reduced basis from the current (minimal) one.
    fn interreduce(&mut self) -> Result<Vec<Poly<D>>, GroebnerError> {
        let ring = self.ring;
        // A minimal basis first (without the chain criterion the basis
        // keeps elements whose leading monomial another one's divides; of
        // equal leading monomials the latest stays).
        let lm = |k: usize| self.polys[k].poly.lm().expect("nonzero");
        let ids: Vec<usize> = self
            .basis
            .iter()
            .enumerate()
            .filter(|&(a, &g)| {
                !self
                    .basis
                    .iter()
                    .enumerate()
                    .any(|(b, &h)| b != a && lm(h).divides(lm(g)) && (lm(h) != lm(g) || b > a))
            })
            .map(|(_, &g)| g)
            .collect();
        self.basis = ids.clone();
        let mut out = Vec::with_capacity(ids.len());
        self.stage("interreduction");
        self.report(0, ids.len() as u64);
        for &k in &ids {
            let f = self.polys[k].poly.clone();
            let r = self.reduce_full(&f, Some(k))?;
            out.push((k, r.normalized()));
            self.report(out.len() as u64, ids.len() as u64);
        }
        for (k, p) in &out {
            self.polys[*k].poly = p.clone();
        }
        let mut basis: Vec<Poly<D>> = out.into_iter().map(|(_, p)| p).collect();
        basis.sort_by(|a, b| ring.cmp(a.lm().expect("nonzero"), b.lm().expect("nonzero")));
        Ok(basis)
    }
}

/// True when `basis` is a Gröbner basis whose ideal contains every input:
/// every S-pair kept by the Gebauer–Möller criteria, and every input, reduces
/// to zero. (Used to verify lifted modular results.)
pub fn check_groebner_basis<D: Domain>(
    ring: &Ring,
    basis: &[Poly<D>],
    inputs: &[Poly<D>],
    opts: &GroebnerOptions,
) -> Result<bool, GroebnerError> {
    // With the criteria whatever the caller's options say (the minimality
    // test below relies on the chain criterion's pruning).
    let opts = GroebnerOptions {
        criteria: Criteria::default(),
        ..opts.clone()
    };
    let mut st = State::new(ring, &opts);
    for g in basis {
        if g.is_zero() {
            continue;
        }
        st.update(g.reorder(ring), g.degree() as u32);
    }
    if st.basis.len() != basis.iter().filter(|g| !g.is_zero()).count() {
        return Ok(false); // not minimal: some leading monomial divides another
    }
    // Progress: the pairs, then the inputs.
    st.stage("verification");
    let n_inputs = inputs.len() as u64;
    let mut done = 0;
    st.report_pairs(done, n_inputs);
    while let Some(pair) = st.select() {
        st.check()?;
        let s = st.spoly(&pair);
        if !st.reduce_full(&s, None)?.is_zero() {
            return Ok(false);
        }
        done += 1;
        st.report_pairs(done, n_inputs);
    }
    for (k, f) in inputs.iter().enumerate() {
        if !st.reduce_full(&f.reorder(ring), None)?.is_zero() {
            return Ok(false);
        }
        st.report(done + k as u64 + 1, done + n_inputs);
    }
    Ok(true)
}

/// Merges two increasing term lists, adding coefficients of equal monomials.
fn merge_ascending<D: Domain>(
    ring: &Ring,
    p: Vec<(Monomial, D)>,
    q: impl Iterator<Item = (Monomial, D)>,
) -> Vec<(Monomial, D)> {
    let mut out = Vec::with_capacity(p.len() + 8);
    let mut p = p.into_iter().peekable();
    let mut q = q.peekable();
    loop {
        let ord = match (p.peek(), q.peek()) {
            (Some(a), Some(b)) => ring.cmp(&a.0, &b.0),
            (Some(_), None) => {
                out.extend(p);
                break;
            }
            (None, Some(_)) => {
                out.extend(q);
                break;
            }
            (None, None) => break,
        };
        match ord {
            std::cmp::Ordering::Less => out.push(p.next().expect("peeked")),
            std::cmp::Ordering::Greater => out.push(q.next().expect("peeked")),
            std::cmp::Ordering::Equal => {
                let (m, c) = p.next().expect("peeked");
                let (_, d) = q.next().expect("peeked");
                let s = c.add(&d);
                if !s.is_zero() {
                    out.push((m, s));
                }
            }
        }
    }
    out
}

/// The normal form of f modulo a Gröbner basis over Q (the remainder of
/// division; zero exactly when f is in the ideal).
pub fn normal_form(ring: &Ring, f: &Poly<Rat>, basis: &[Poly<Rat>]) -> Poly<Rat> {
    crate::poly::divide(ring, &f.reorder(ring), basis).1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::monomial::MonomialOrder;
    use crate::parse::parse_poly;

    fn gb(vars: &[&str], order: MonomialOrder, input: &[&str]) -> Vec<String> {
        let ring = Ring::new(vars, order);
        let polys: Vec<_> = input.iter().map(|s| parse_poly(&ring, s).unwrap()).collect();
        let r = groebner(&ring, &polys, &GroebnerOptions::default()).unwrap();
        r.basis.iter().map(|p| p.display(&ring)).collect()
    }

    #[test]
    fn textbook_bases() {
        // Cox–Little–O'Shea §2.7 Example 1: <x^3 - 2xy, x^2 y - 2y^2 + x> in grlex x > y
        // has the reduced basis {x^2, xy, y^2 - x/2}.
        assert_eq!(
            gb(
                &["x", "y"],
                MonomialOrder::DegLex,
                &["x^3 - 2*x*y", "x^2*y - 2*y^2 + x"]
            ),
            ["y^2 - 1/2*x", "x*y", "x^2"]
        );
        // The example: <x - s - t, y - s, z - t> in lex s > t > x > y > z.
        assert_eq!(
            gb(
                &["s", "t", "x", "y", "z"],
                MonomialOrder::Lex,
                &["x - s - t", "y - s", "z - t"]
            ),
            ["x - y - z", "t - z", "s - y"]
        );
        // The twisted cubic (CLO §2.8): <y - x^2, z - x^3> in lex y > z > x... here x > y > z.
        assert_eq!(
            gb(&["x", "y", "z"], MonomialOrder::Lex, &["y - x^2", "z - x^3"]),
            ["y^3 - z^2", "x*z - y^2", "x*y - z", "x^2 - y"]
        );
        // The unit ideal.
        assert_eq!(
            gb(&["x", "y"], MonomialOrder::DegRevLex, &["x*y - 1", "x", "y^2"]),
            ["1"]
        );
    }

    /// Large coefficients: several primes, so replays of the first prime's trace.
    fn big_system() -> (Ring, Vec<Poly<Rat>>) {
        let ring = Ring::new(&["x", "y", "z"], MonomialOrder::DegRevLex);
        let polys = [
            "12345678901*x^2 + 98765432101*y*z - 1",
            "x*y - 31415926535*z^2 + 2",
            "x + 27182818284*y + z - 3",
        ]
        .iter()
        .map(|s| parse_poly(&ring, s).unwrap())
        .collect::<Vec<_>>();
        (ring, polys)
    }

    #[test]
    fn progress_counts_pairs_and_changes_nothing() {
        use crate::testing::Recorder;
        // Large coefficients need several primes (replays of the first prime's trace).
        let big = big_system();
        for (k, (ring, polys)) in [crate::systems::katsura(4), crate::systems::cyclic(4), big]
            .into_iter()
            .enumerate()
        {
            for method in [Method::FractionFree, Method::Modular, Method::Auto] {
                let plain = GroebnerOptions {
                    method,
                    algorithm: Algorithm::Buchberger,
                    ..Default::default()
                };
                let expected = groebner(&ring, &polys, &plain).unwrap();
                let recorder = Arc::new(Recorder::default());
                let watched = GroebnerOptions {
                    progress: Some(recorder.clone()),
                    ..plain.clone()
                };
                let r = groebner(&ring, &polys, &watched).unwrap();
                assert_eq!(r.basis, expected.basis, "{method:?}");
                assert_eq!(
                    Stats {
                        time: Duration::ZERO,
                        ..r.stats
                    },
                    Stats {
                        time: Duration::ZERO,
                        ..expected.stats
                    },
                    "{method:?}"
                );
                // Only a verification that fails (an unlucky lift) and the
                // fraction-free attempt that Auto abandons stop short.
                let abandoned = |name: &str| method == Method::Auto && name == "groebner";
                let stages = recorder.check(|name| !(name.ends_with("verification") || abandoned(name)));
                let names: Vec<&str> = stages.iter().map(|(n, _)| n.as_str()).collect();
                match method {
                    Method::FractionFree => {
                        assert_eq!(names, ["groebner", "interreduction"]);
                        // Every pair reduced was counted.
                        assert_eq!(stages[0].1.last().unwrap().0, r.stats.pairs_reduced);
                    }
                    Method::Modular => {
                        assert_eq!(names[0], "modular, prime 1: groebner");
                        assert!(names.iter().all(|n| n.starts_with("modular, prime ")), "{names:?}");
                        if k == 2 {
                            assert!(names.iter().any(|n| n.ends_with(": replay")), "{names:?}");
                        }
                        let last = stages.last().unwrap();
                        assert!(last.0.ends_with(": verification"), "{names:?}");
                        let (d, t) = *last.1.last().unwrap();
                        assert_eq!(d, t, "the accepted verification checked everything");
                    }
                    Method::Auto => assert_eq!(names[0], "groebner"),
                }
            }
        }
        // F4: a learning run modulo a random prime (its basis is the
        // check), then a replay per lifting prime; the reported stages are
        // complete and the basis is the same as without progress.
        for (ring, polys) in [crate::systems::katsura(4), big_system()] {
            let plain = GroebnerOptions::default();
            let expected = groebner(&ring, &polys, &plain).unwrap();
            let recorder = Arc::new(Recorder::default());
            let watched = GroebnerOptions {
                progress: Some(recorder.clone()),
                ..plain
            };
            assert_eq!(groebner(&ring, &polys, &watched).unwrap().basis, expected.basis);
            let stages = recorder.check(|_| true);
            let names: Vec<&str> = stages.iter().map(|(n, _)| n.as_str()).collect();
            assert_eq!(
                names[..2],
                ["modular, learning: f4", "modular, learning: f4: interreduction"]
            );
            assert!(
                names[2..]
                    .iter()
                    .all(|n| n.starts_with("modular, prime ") || n.starts_with("verification: f4")),
                "{names:?}"
            );
            assert_eq!(names[2], "modular, prime 1: f4 replay", "{names:?}");
            assert!(names.last().unwrap().ends_with(": f4 replay"), "{names:?}");
        }
        // The job crate's Counter ends at done == total.
        let (ring, polys) = crate::systems::katsura(3);
        let counter = Arc::new(isoray_job::Counter::default());
        let opts = GroebnerOptions {
            algorithm: Algorithm::Buchberger,
            method: Method::FractionFree,
            progress: Some(counter.clone()),
            ..Default::default()
        };
        let r = groebner(&ring, &polys, &opts).unwrap();
        assert_eq!(
            (counter.done(), counter.total()),
            (r.basis.len() as u64, r.basis.len() as u64)
        );
    }

    /// The thesis's Example 1.3 (x = s + t, y = s, z = t in lex
    /// s > t > x > y > z) and its counts. Sage's toy Buchberger (ordered
    /// pairs, both ways round, no criterion) meets 8 reductions to zero;
    /// with unordered pairs and no criterion (`--no-criteria`) six S-pairs
    /// are reduced (one gives x − y − z, five vanish); with the criteria a
    /// single pair is reduced and the five coprime ones are discarded. Both
    /// engines, the same basis every time.
    #[test]
    fn example_1_3_counts_with_and_without_criteria() {
        let ring = Ring::new(&["s", "t", "x", "y", "z"], MonomialOrder::Lex);
        let f: Vec<Poly<Rat>> = ["x - s - t", "y - s", "z - t"]
            .iter()
            .map(|t| crate::parse_poly(&ring, t).unwrap())
            .collect();
        // Sage's toy_buchberger.buchberger: G grows, B holds ordered pairs,
        // the pair of smallest lcm goes first.
        let mut g = f.clone();
        let mut b: Vec<(usize, usize)> = (0..3)
            .flat_map(|i| (0..3).filter(move |&j| j != i).map(move |j| (i, j)))
            .collect();
        let mut zeros = 0;
        let lcm = |g: &[Poly<Rat>], (i, j): (usize, usize)| g[i].lm().unwrap().lcm(g[j].lm().unwrap());
        while !b.is_empty() {
            // Sage's select: the pair of smallest lcm.
            let k = (0..b.len())
                .min_by(|&p, &q| ring.cmp(&lcm(&g, b[p]), &lcm(&g, b[q])))
                .unwrap();
            let (i, j) = b.remove(k);
            let (fi, fj) = (&g[i], &g[j]);
            let l = lcm(&g, (i, j));
            let si = fi.mul_term(&fi.lm().unwrap().quotient(&l).unwrap(), &fi.lc().unwrap().recip());
            let sj = fj.mul_term(&fj.lm().unwrap().quotient(&l).unwrap(), &fj.lc().unwrap().recip());
            let (_, h) = crate::poly::divide(&ring, &si.sub(&ring, &sj), &g);
            if h.is_zero() {
                zeros += 1;
            } else {
                b.extend((0..g.len()).map(|k| (k, g.len())));
                g.push(h);
            }
        }
        assert_eq!(zeros, 8);
        let want = ["s - y", "t - z", "x - y - z"];
        for algorithm in [Algorithm::Buchberger, Algorithm::F4] {
            // Buchberger takes the inputs as given: without criteria the six
            // pairs of f1, f2, f3 and x − y − z; with them only (f1, f2),
            // four coprime pairs discarded (f1 leaves the basis when f2,
            // of the same leading monomial, comes in). F4 reduces the
            // inputs first (f1 becomes x − y − z): three coprime pairs.
            let (none, with) = match algorithm {
                Algorithm::Buchberger => ((6, 5, 0), (1, 0, 4)),
                Algorithm::F4 => ((3, 3, 0), (0, 0, 3)),
            };
            for (criteria, (reduced, vanished, product)) in [(Criteria::NONE, none), (Criteria::default(), with)] {
                let opts = GroebnerOptions {
                    algorithm,
                    method: Method::FractionFree,
                    criteria,
                    ..Default::default()
                };
                let (basis, st) = if algorithm == Algorithm::F4 {
                    // Counted modulo a prime: F4's run over Q adds the
                    // replays' and the check's work.
                    let fp: Vec<Poly<crate::Fp>> = f
                        .iter()
                        .map(|p| p.map_coeffs(&ring, |c| crate::Fp::from_rat(c, 32003).unwrap()))
                        .collect();
                    let (b, st) = crate::f4::f4_modp(&ring, &fp, &opts).unwrap();
                    (b.iter().map(|p| p.display(&ring)).collect::<Vec<_>>(), st)
                } else {
                    let r = groebner(&ring, &f, &opts).unwrap();
                    (r.basis.iter().map(|p| p.display(&ring)).collect(), r.stats)
                };
                let mut basis = basis;
                basis.sort();
                let want: Vec<String> = if algorithm == Algorithm::F4 {
                    ["s + 32002*y", "t + 32002*z", "x + 32002*y + 32002*z"]
                        .map(String::from)
                        .to_vec()
                } else {
                    want.map(String::from).to_vec()
                };
                assert_eq!(basis, want, "{algorithm:?} {criteria:?}");
                assert_eq!(
                    (
                        st.pairs_reduced,
                        st.zero_reductions,
                        st.removed_product,
                        st.removed_chain
                    ),
                    (reduced, vanished, product, 0),
                    "{algorithm:?} {criteria:?}"
                );
            }
        }
    }

    /// Switching criteria off changes the work, never the basis: katsura-4
    /// and cyclic-4 over Q, every combination, both engines; the pairs
    /// reduced only grow as criteria go.
    #[test]
    fn criteria_off_gives_the_same_basis() {
        for (ring, polys) in [crate::systems::katsura(4), crate::systems::cyclic(4)] {
            for algorithm in [Algorithm::Buchberger, Algorithm::F4] {
                let run = |criteria| {
                    let opts = GroebnerOptions {
                        algorithm,
                        method: Method::FractionFree,
                        criteria,
                        ..Default::default()
                    };
                    groebner(&ring, &polys, &opts).unwrap()
                };
                let all = run(Criteria::default());
                let mut last = all.stats.pairs_reduced;
                for criteria in [
                    Criteria {
                        product: true,
                        chain: false,
                    },
                    Criteria {
                        product: false,
                        chain: true,
                    },
                    Criteria::NONE,
                ] {
                    let r = run(criteria);
                    assert_eq!(r.basis, all.basis, "{algorithm:?} {criteria:?}");
                    assert!(
                        r.stats.pairs_reduced >= all.stats.pairs_reduced,
                        "{algorithm:?} {criteria:?}"
                    );
                    if criteria == Criteria::NONE {
                        assert!(r.stats.pairs_reduced > last, "{algorithm:?}");
                        assert_eq!((r.stats.removed_product, r.stats.removed_chain), (0, 0));
                    }
                    last = last.max(r.stats.pairs_reduced);
                }
            }
        }
    }

    #[test]
    fn budget_stops_work() {
        let ring = Ring::new(&["x", "y", "z", "t"], MonomialOrder::DegRevLex);
        let polys: Vec<_> = [
            "x^5 + y^4 + z^3 - 1",
            "x^3 + y^3 + z^2 - 1",
            "x^2*t + y*z - 3",
            "x*y*z*t - 2",
        ]
        .iter()
        .map(|s| parse_poly(&ring, s).unwrap())
        .collect();
        let opts = GroebnerOptions {
            budget: Budget {
                steps: Some(10),
                ..Default::default()
            },
            ..Default::default()
        };
        assert!(matches!(
            groebner(&ring, &polys, &opts),
            Err(GroebnerError::WorkLimit { .. })
        ));
        let token = isoray_job::CancelToken::new();
        token.cancel();
        let opts = GroebnerOptions {
            budget: Budget {
                interrupt: Some(token),
                ..Default::default()
            },
            ..Default::default()
        };
        assert!(matches!(
            groebner(&ring, &polys, &opts),
            Err(GroebnerError::Interrupted { .. })
        ));
    }
}
