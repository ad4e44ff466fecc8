//! The wavefront sphere tracer: rays are traced in packets, and every step
//! evaluates the distance of all still-active rays with one batch call, so the
//! shape tape runs over structure-of-arrays blocks (the hot path).

use isoray_scene::{March, RenderSettings, ShadowMode, StepLimit};
use isoray_shape::{BatchEvaluator, GradientMode, Tape};

use crate::prune::{prunable, Pruner};

/// A distance field ready to evaluate in a frame: a batch evaluator of its
/// tape and the frame's runtime inputs (the time and the parameters), and,
/// when made by [`Field::pruned`], the tapes simplified for the regions of
/// space the evaluations reach (see [`crate::prune`]).
#[derive(Debug)]
pub struct Field<'s> {
    eval: BatchEvaluator<'s, f32>,
    vars: &'s [f64],
    prune: Option<Box<Pruner<'s>>>,
}

impl<'s> Field<'s> {
    /// The field of `tape` with the inputs `vars`: every evaluation runs
    /// the full tape.
    pub fn new(tape: &'s Tape, vars: &'s [f64]) -> Self {
        Field {
            eval: BatchEvaluator::new(tape),
            vars,
            prune: None,
        }
    }

    /// The field of `tape` with the inputs `vars`, each evaluation inside
    /// the cube of half-size `half` around `center` running the tape
    /// simplified for a region around it (the same values, bit for bit);
    /// as [`Field::new`] when the tape has nothing to simplify.
    pub fn pruned(tape: &'s Tape, vars: &'s [f64], center: [f64; 3], half: f64) -> Self {
        let ok = can_prune(tape, center, half);
        Field {
            eval: BatchEvaluator::new(tape),
            vars,
            prune: ok.then(|| Box::new(Pruner::new(tape, vars, center, half))),
        }
    }

    /// [`Field::pruned`] for a field that is the fold of the objects'
    /// `objects` tapes by smooth union of width `k` (0: min), in order (and
    /// `spheres`: the sphere each object's distance is, when it is): its
    /// regions specialised object by object ([`isoray_shape::fold`]), which
    /// is several times cheaper than simplifying the tape; as
    /// [`Field::pruned`] when the fold's program does not give `tape`'s
    /// values bit for bit at sample points of the cube of half-size
    /// `probe.1` around `probe.0` (where the objects are).
    #[allow(clippy::too_many_arguments)]
    pub fn pruned_fold(
        tape: &'s Tape,
        objects: &[&'s Tape],
        spheres: &[Option<([f64; 3], f64)>],
        k: f64,
        vars: &'s [f64],
        center: [f64; 3],
        half: f64,
        probe: ([f64; 3], f64),
    ) -> Self {
        let ok = can_prune(tape, center, half);
        let fold = ok
            .then(|| isoray_shape::fold::Fold::new(objects, spheres, k, vars, tape, probe.0, probe.1))
            .flatten();
        Field {
            eval: BatchEvaluator::new(tape),
            vars,
            prune: ok.then(|| Box::new(Pruner::with_fold(tape, vars, center, half, fold))),
        }
    }

    /// Whether its regions are specialised object by object (see
    /// [`Field::pruned_fold`]).
    pub fn by_objects(&self) -> bool {
        self.prune.as_ref().is_some_and(|p| p.by_objects())
    }

    /// Tape instructions run by pruned evaluations so far, summed over
    /// points (None when not pruned).
    pub fn instructions_run(&self) -> Option<u64> {
        self.prune.as_ref().map(|p| p.instrs_run)
    }

    /// Distances at the points into `out`.
    pub fn eval(&mut self, xs: &[f32], ys: &[f32], zs: &[f32], out: &mut [f32]) {
        match &mut self.prune {
            Some(p) => p.eval(&mut self.eval, self.vars, xs, ys, zs, out),
            None => self.eval.eval(self.vars, xs, ys, zs, out),
        }
    }

    /// Gradients at the points (see [`BatchEvaluator::gradients`]).
    #[allow(clippy::too_many_arguments)]
    pub fn gradients(
        &mut self,
        xs: &[f32],
        ys: &[f32],
        zs: &[f32],
        mode: GradientMode,
        gx: &mut [f32],
        gy: &mut [f32],
        gz: &mut [f32],
    ) {
        match &mut self.prune {
            Some(p) => p.gradients(&mut self.eval, self.vars, xs, ys, zs, mode, gx, gy, gz),
            None => self.eval.gradients(self.vars, xs, ys, zs, mode, gx, gy, gz),
        }
    }
}

/// Whether `tape` is worth pruning over the cube of half-size `half`
/// around `center` (a finite, non-empty one).
fn can_prune(tape: &Tape, center: [f64; 3], half: f64) -> bool {
    prunable(tape) && half.is_finite() && half > 0.0 && center.iter().all(|c| c.is_finite())
}

/// Scratch buffers reused across packets (no allocation per ray).
#[derive(Debug, Default)]
pub struct Scratch {
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    ds: Vec<f32>,
    active: Vec<u32>,
    next: Vec<u32>,
    /// The previous distance of each ray of the packet (overshoot detection).
    last: Vec<f32>,
    /// Steps that landed clearly inside a surface after a positive distance:
    /// the field overstepped, so it is not a distance bound there.
    pub overshoots: u64,
    /// The largest overshoot factor seen: (d_before + |d_after|) / d_before,
    /// about the factor the step was too long by.
    pub worst_overshoot: f32,
}

impl Scratch {
    /// Gathers the points o + t·d of the active rays and evaluates the
    /// distance there into `self.ds`. Returns the number of evaluations.
    fn eval_active(&mut self, eval: &mut Field, rays: &Rays, t: impl Fn(usize) -> f32) -> u64 {
        let m = self.active.len();
        for v in [&mut self.xs, &mut self.ys, &mut self.zs, &mut self.ds] {
            v.resize(m, 0.0);
        }
        for (k, &i) in self.active.iter().enumerate() {
            let i = i as usize;
            let ti = t(i);
            self.xs[k] = rays.ox[i] + rays.dx[i] * ti;
            self.ys[k] = rays.oy[i] + rays.dy[i] * ti;
            self.zs[k] = rays.oz[i] + rays.dz[i] * ti;
        }
        eval.eval(&self.xs[..m], &self.ys[..m], &self.zs[..m], &mut self.ds[..m]);
        m as u64
    }
}

/// A packet of rays (structure of arrays).
#[derive(Debug, Default, Clone)]
pub struct Rays {
    /// Origins.
    pub ox: Vec<f32>,
    /// Origins.
    pub oy: Vec<f32>,
    /// Origins.
    pub oz: Vec<f32>,
    /// Unit directions.
    pub dx: Vec<f32>,
    /// Unit directions.
    pub dy: Vec<f32>,
    /// Unit directions.
    pub dz: Vec<f32>,
}

impl Rays {
    /// Number of rays.
    pub fn len(&self) -> usize {
        self.ox.len()
    }
    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.ox.is_empty()
    }
    /// Removes all rays, keeping capacity.
    pub fn clear(&mut self) {
        for v in [
            &mut self.ox,
            &mut self.oy,
            &mut self.oz,
            &mut self.dx,
            &mut self.dy,
            &mut self.dz,
        ] {
            v.clear();
        }
    }
    /// The origin of ray `i`.
    pub fn origin(&self, i: usize) -> [f32; 3] {
        [self.ox[i], self.oy[i], self.oz[i]]
    }
    /// The direction of ray `i`.
    pub fn direction(&self, i: usize) -> [f32; 3] {
        [self.dx[i], self.dy[i], self.dz[i]]
    }
    /// Adds a ray.
    pub fn push(&mut self, o: [f32; 3], d: [f32; 3]) {
        self.ox.push(o[0]);
        self.oy.push(o[1]);
        self.oz.push(o[2]);
        self.dx.push(d[0]);
        self.dy.push(d[1]);
        self.dz.push(d[2]);
    }
}

/// The result of tracing one ray.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Hit {
    /// Distance along the ray; +inf on a miss.
    pub t: f32,
    /// Steps taken.
    pub steps: u32,
}

/// Sphere-traces every ray of the packet. Returns the number of distance evaluations.
pub fn sphere_trace(
    eval: &mut Field,
    rays: &Rays,
    s: &RenderSettings,
    scratch: &mut Scratch,
    hits: &mut Vec<Hit>,
) -> u64 {
    sphere_trace_capped(eval, rays, s, scratch, hits, None, None)
}

/// Sphere-traces every ray of the packet, ray i stopping at `caps[i]` (a
/// surface found in closed form there: the ray hits it unless the march
/// finds one before), and beyond `far[i]` marching no more (no surface of
/// the field lies beyond: see [`crate::reach`]), a miss unless a cap
/// lies ahead. Returns the number of distance evaluations.
pub fn sphere_trace_capped(
    eval: &mut Field,
    rays: &Rays,
    s: &RenderSettings,
    scratch: &mut Scratch,
    hits: &mut Vec<Hit>,
    caps: Option<&[f32]>,
    far: Option<&[f32]>,
) -> u64 {
    let n = rays.len();
    hits.clear();
    hits.resize(n, Hit { t: 0.0, steps: 0 });
    let eps = s.hit_epsilon as f32;
    let tmax = s.max_distance as f32;
    let scale = s.step_scale as f32;
    let fixed = s.march == March::Fixed;
    let fixed_step = s.fixed_step as f32;
    let mut evals = 0u64;
    let cap_of = |i: usize| caps.map_or(f32::INFINITY, |c| c[i]);
    // Past the field's last surface: the cap's hit, or a miss.
    let beyond = |i: usize| {
        let cap = cap_of(i);
        if cap <= tmax {
            (cap - 0.5 * eps).max(0.0)
        } else {
            f32::INFINITY
        }
    };
    scratch.active.clear();
    for i in 0..n {
        if far.is_some_and(|f| f[i] < 0.0) {
            hits[i].t = beyond(i);
        } else {
            scratch.active.push(i as u32);
        }
    }
    scratch.last.clear();
    scratch.last.resize(n, f32::NAN);
    // Rays from one point (a camera's primary rays) take their first step
    // from one distance: evaluated once, the same number for each.
    let shared_start = scratch.active.split_first().and_then(|(&first, rest)| {
        let o = rays.origin(first as usize);
        rest.iter().all(|&i| rays.origin(i as usize) == o).then_some(o)
    });
    let mut step = 0;
    while !scratch.active.is_empty() {
        match shared_start.filter(|_| step == 0) {
            Some(o) => {
                let mut d = [0.0f32];
                eval.eval(&[o[0]], &[o[1]], &[o[2]], &mut d);
                scratch.ds.clear();
                scratch.ds.resize(scratch.active.len(), d[0]);
                evals += 1;
            }
            None => evals += scratch.eval_active(eval, rays, |i| hits[i].t),
        }
        step += 1;
        scratch.next.clear();
        for (k, &i) in scratch.active.iter().enumerate() {
            let h = &mut hits[i as usize];
            let d = scratch.ds[k];
            h.steps = step;
            let threshold = if s.relative_epsilon { eps * h.t } else { eps };
            if d < threshold {
                // A bound never steps from outside to clearly inside (fixed
                // steps do, by design).
                let before = scratch.last[i as usize];
                if !fixed && before > 0.0 && d < -threshold.max(eps) * 4.0 {
                    scratch.overshoots += 1;
                    let factor = (before * scale + (-d)) / before;
                    scratch.worst_overshoot = scratch.worst_overshoot.max(factor);
                }
                continue; // hit at h.t
            }
            scratch.last[i as usize] = d;
            if d.is_nan() {
                h.t = f32::INFINITY; // undefined field: treat as a miss
                continue;
            }
            h.t += if fixed { fixed_step } else { d * scale };
            let cap = cap_of(i as usize);
            if h.t >= cap && cap <= tmax {
                // The closed-form surface comes first; stop just outside it,
                // as a marched hit would (within the hit epsilon).
                h.t = (cap - 0.5 * eps).max(0.0);
            } else if far.is_some_and(|f| h.t > f[i as usize]) {
                h.t = beyond(i as usize);
            } else if h.t > tmax {
                h.t = f32::INFINITY;
            } else if step < s.max_steps {
                scratch.next.push(i);
            } else if s.on_step_limit == StepLimit::Miss {
                h.t = f32::INFINITY;
            }
            // Otherwise out of steps while still inside the range: a hit (the
            // ray is grazing a surface), as most sphere tracers do.
        }
        std::mem::swap(&mut scratch.active, &mut scratch.next);
    }
    evals
}

/// The distance below which a shadow ray meets an occluder:
/// `shadow_epsilon`, or `hit_epsilon` when that is 0.
pub fn shadow_epsilon(s: &RenderSettings) -> f32 {
    (if s.shadow_epsilon > 0.0 {
        s.shadow_epsilon
    } else {
        s.hit_epsilon
    }) as f32
}

/// Marches shadow rays from surface points towards lights and returns the
/// visibility (0 = shadowed, 1 = lit) of each. `size` is the light's penumbra
/// size and `tmax` the distance to the light (per ray). Returns evaluations.
#[allow(clippy::too_many_arguments)]
pub fn shadow_march(
    eval: &mut Field,
    rays: &Rays,
    tmax: &[f32],
    mode: ShadowMode,
    size: f32,
    s: &RenderSettings,
    scratch: &mut Scratch,
    vis: &mut Vec<f32>,
) -> u64 {
    let n = rays.len();
    vis.clear();
    vis.resize(n, 1.0);
    if mode == ShadowMode::None || n == 0 {
        return 0;
    }
    let eps = shadow_epsilon(s);
    let start = s.shadow_start as f32;
    let min_step = (0.5 * start).max(eps);
    let mut t = vec![start; n];
    // Aaltonen's estimate: the previous step's distance.
    let mut ph = vec![1e20f32; if mode == ShadowMode::Aaltonen { n } else { 0 }];
    let mut evals = 0u64;
    scratch.active.clear();
    scratch
        .active
        .extend((0..n as u32).filter(|&i| start < tmax[i as usize]));
    let mut step = 0;
    while !scratch.active.is_empty() && step < s.shadow_max_steps {
        evals += scratch.eval_active(eval, rays, |i| t[i]);
        step += 1;
        scratch.next.clear();
        for (k, &i) in scratch.active.iter().enumerate() {
            let i = i as usize;
            let d = scratch.ds[k];
            let ti = t[i];
            let keep = match mode {
                ShadowMode::Hard => {
                    if d < eps {
                        vis[i] = 0.0;
                        false
                    } else {
                        t[i] += d;
                        true
                    }
                }
                ShadowMode::Soft => {
                    if d < eps {
                        vis[i] = 0.0;
                        false
                    } else {
                        vis[i] = vis[i].min(d / (size * ti));
                        t[i] += d;
                        true
                    }
                }
                ShadowMode::Improved => {
                    // Tolerates slight penetration: the estimate may go down to -1
                    // and is remapped smoothly at the end.
                    vis[i] = vis[i].min(d / (size * ti));
                    t[i] += d.max(min_step);
                    vis[i] > -1.0
                }
                ShadowMode::Aaltonen => {
                    if d < eps {
                        vis[i] = 0.0;
                        false
                    } else {
                        // The closest approach between this sphere and the
                        // previous one: y along the ray, dd across it.
                        let y = d * d / (2.0 * ph[i]);
                        let dd = (d * d - y * y).max(0.0).sqrt();
                        let est = dd / (size * (ti - y).max(0.0));
                        if !est.is_nan() {
                            vis[i] = vis[i].min(est);
                        }
                        ph[i] = d;
                        t[i] += d;
                        true
                    }
                }
                ShadowMode::None => false,
            };
            if keep && t[i] < tmax[i] {
                scratch.next.push(i as u32);
            }
        }
        std::mem::swap(&mut scratch.active, &mut scratch.next);
    }
    match mode {
        ShadowMode::Soft | ShadowMode::Aaltonen => vis.iter_mut().for_each(|v| *v = v.clamp(0.0, 1.0)),
        ShadowMode::Improved => vis.iter_mut().for_each(|v| {
            let r = v.clamp(-1.0, 1.0);
            *v = 0.25 * (1.0 + r) * (1.0 + r) * (2.0 - r);
        }),
        _ => {}
    }
    evals
}
