//! Tapes specialised to regions of space (fidget's tape simplification,
//! for the sphere tracer).
//!
//! A field's domain (a cube around the camera that every ray stays in) is
//! an octree built lazily, as points reach it: each cell holds its
//! parent's tape simplified for the cell's box
//! ([`isoray_shape::simplify::Simplifier`]: the branches of `min`, `max`
//! and selects that cannot win anywhere in the box dropped, with all that
//! only they needed). A point is evaluated with the tape of the deepest
//! cell that holds it, which gives the same value as the full tape there,
//! bit for bit, so images do not change; a batch of points is grouped by
//! cell, each group one batch call of its short tape. Cells stop dividing
//! at [`MAX_DEPTH`] or once their tape is [`SHORT`] instructions long.
//!
//! Every evaluation in a region reuses the work done for it, whatever the
//! ray: primary, shadow, reflected and refracted rays, ambient-occlusion
//! samples and normals. The tree belongs to one worker thread and lives
//! for a frame.
//!
//! A tape with no `min`, `max` or select has nothing to simplify and is
//! never pruned, nor is a tape shorter than [`MIN_TAPE`].
//!
//! The scene's own distance is the fold of its objects' distances; for it
//! the cells are specialised object by object instead
//! ([`isoray_shape::fold`], [`crate::trace::Field::pruned_fold`]): each
//! cell keeps the objects that can change the fold in its box, from
//! interval bounds of each object's short tape, and runs them as one
//! program — the same values, several times cheaper to make a cell for,
//! so cells are made sooner ([`FOLD_PATIENCE`]), and a sphere and its
//! smooth union are one operation there, so leaves hold more objects
//! ([`FOLD_SHORT`]).

use isoray_shape::fold::{Fold, FoldCell};
use isoray_shape::interval::{Choice, Interval, IntervalEvaluator};
use isoray_shape::ir::{BinOp, Instr};
use isoray_shape::simplify::Simplifier;
use isoray_shape::{BatchEvaluator, GradientMode, Tape};

/// Levels of cells below the domain cube, at most.
pub const MAX_DEPTH: u8 = 10;

/// Cells whose tape is at most this long are not divided further.
pub const SHORT: usize = 24;

/// [`SHORT`] for a fold specialised object by object, whose programs run
/// a recognised sphere and its smooth union as one operation: leaves of up
/// to about a hundred spheres (300 and 1,000 spheres 10–12 % faster than
/// with 24; 1,000 tori or boxes, bounded by interval arithmetic, alike).
pub const FOLD_SHORT: usize = 100;

/// No cell (a child not made yet).
const NONE: u32 = u32::MAX;

/// The full tape (a cell where nothing simplifies).
const FULL: u32 = u32::MAX;

/// The children of a leaf (a cell never divided).
const LEAF: u32 = u32::MAX - 1;

/// What finding a point's cell reads of each cell on the way down: its
/// box and children, one cache line (the rest is in [`Cell`]).
#[derive(Debug, Clone)]
#[repr(C, align(64))]
struct Node {
    /// Its box: centre and half-size.
    c: [f64; 3],
    h: f64,
    /// The eight children (x, y, z bits of the index: the upper half
    /// along that axis), [`NONE`] until made; all [`LEAF`] for a leaf.
    kids: [u32; 8],
}

/// A cell of the octree (its [`Node`] is at the same index).
#[derive(Debug, Clone)]
struct Cell {
    /// Index into `tapes`, or [`FULL`].
    tape: u32,
    /// Per child not made yet, the points this cell evaluated for want of
    /// it (see [`PATIENCE`]).
    visits: [u32; 8],
    /// The cell it divides ([`NONE`] for the root).
    parent: u32,
    /// Its level below the domain cube (0: the root).
    depth: u8,
}

/// Groups of fewer points than this go to the parent cell when its tape
/// is at most twice as long: the batch evaluator's cost per instruction
/// hardly depends on the number of points below its block size, so one
/// group of 8 points beats four of 2.
pub const MIN_GROUP: usize = 8;

/// A child is made once its parent has evaluated this many points that
/// fall in it: making one (interval evaluation and simplification of the
/// parent's tape) costs about as much as evaluating that tape at dozens
/// of points in small groups, so cells that few points reach are not worth
/// it. (On the 1,000-sphere scene of `bench/tracer.sh`, 16 was 1.4× slower
/// than 64; 256 and 1000 were within the machine's noise of it.)
pub const PATIENCE: u32 = 64;

/// [`PATIENCE`] for a fold specialised object by object, whose cells cost
/// a fraction as much (1,000 spheres: 16 and 32 alike, 8 and 64 4 % slower).
pub const FOLD_PATIENCE: u32 = 24;

/// The cube of half-size `h` around `c` as intervals, padded for the
/// rounding of f32 points near its faces.
pub(crate) fn padded_cell(c: [f64; 3], h: f64) -> [Interval; 3] {
    let pad = 1e-5 * h + 1e-6 * c.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    std::array::from_fn(|k| Interval::new(c[k] - h - pad, c[k] + h + pad))
}

/// The lazily built octree of one field (see the module docs).
#[derive(Debug)]
pub(crate) struct Pruner<'s> {
    tape: &'s Tape,
    intervals: IntervalEvaluator<'s>,
    choices: Vec<Choice>,
    simplifier: Simplifier,
    /// The octree, root first (its box the domain cube).
    cells: Vec<Cell>,
    nodes: Vec<Node>,
    tapes: Vec<Tape>,
    /// When the field is a fold of objects specialised object by object
    /// ([`isoray_shape::fold`]): the fold and its cells (index 0 the whole
    /// fold, which [`FULL`] then names); `tapes` stays empty.
    fold: Option<(Fold<'s>, Vec<FoldCell>)>,
    /// Scratch: (cell << 32 | point) keys, and gathered points.
    keys: Vec<u64>,
    gather: [Vec<f32>; 7],
    /// Scratch: a fold's finite-difference stencil points.
    stencil: [Vec<f32>; 4],
    /// Tape instructions run, summed over points (for tests and stats).
    pub(crate) instrs_run: u64,
}

/// Tapes shorter than this are not pruned: looking up cells and grouping
/// points costs more than the instructions it saves (the gallery's 357
/// instructions ran 5 % slower pruned, the showcase's 127 and the optics
/// scene's 28 up to 1.5× slower).
pub const MIN_TAPE: usize = 500;

/// True when the tape is long enough to prune ([`MIN_TAPE`]) and has
/// something the simplifier can drop.
pub(crate) fn prunable(tape: &Tape) -> bool {
    if tape.len() < MIN_TAPE {
        return false;
    }
    let choosable = |i: &Instr| {
        matches!(
            i,
            Instr::Binary {
                op: BinOp::Min | BinOp::Max,
                ..
            } | Instr::Select { .. }
        )
    };
    let skips = tape.instrs().iter().any(|i| matches!(i, Instr::Skip { .. }));
    !skips && tape.instrs().iter().any(choosable)
}

impl<'s> Pruner<'s> {
    /// The octree of `tape` (with the inputs `vars`) over the cube of
    /// half-size `half` around `center`.
    pub(crate) fn new(tape: &'s Tape, vars: &[f64], center: [f64; 3], half: f64) -> Self {
        Self::with_fold(tape, vars, center, half, None)
    }

    /// [`Self::new`], specialising the cells object by object when `fold`
    /// (the field as a fold of objects, checked against `tape`) is given.
    pub(crate) fn with_fold(tape: &'s Tape, vars: &[f64], center: [f64; 3], half: f64, fold: Option<Fold<'s>>) -> Self {
        let fold = fold.map(|f| {
            let whole = f.whole();
            (f, vec![whole])
        });
        let mut p = Pruner {
            tape,
            intervals: IntervalEvaluator::new(tape, vars),
            choices: Vec::new(),
            simplifier: Simplifier::default(),
            cells: Vec::new(),
            nodes: Vec::new(),
            tapes: Vec::new(),
            fold,
            keys: Vec::new(),
            gather: Default::default(),
            stencil: Default::default(),
            instrs_run: 0,
        };
        p.make_cell(FULL, NONE, center, half, 0);
        p
    }

    /// The tape index of a cell ([`FULL`] for [`NONE`], outside the domain).
    fn cell_tape(&self, cell: u32) -> u32 {
        if cell == NONE {
            FULL
        } else {
            self.cells[cell as usize].tape
        }
    }

    fn tape_of(&self, t: u32) -> &Tape {
        if t == FULL {
            self.tape
        } else {
            &self.tapes[t as usize]
        }
    }

    /// Whether cells are specialised object by object.
    pub(crate) fn by_objects(&self) -> bool {
        self.fold.is_some()
    }

    /// Instructions per point of the tape or fold cell `t`.
    fn len_of(&self, t: u32) -> usize {
        match &self.fold {
            Some((_, cells)) => cells[fold_index(t)].len(),
            None => self.tape_of(t).len(),
        }
    }

    /// Makes a cell of the given box and depth below `above` (a child of
    /// it, or the root), its tape simplified from `parent`'s; returns its
    /// index.
    fn make_cell(&mut self, parent: u32, above: u32, c: [f64; 3], h: f64, depth: u8) -> u32 {
        let bx = padded_cell(c, h);
        let tape = match &mut self.fold {
            Some((fold, cells)) => match fold.specialise(&cells[fold_index(parent)], bx) {
                Some(cell) => {
                    cells.push(cell);
                    cells.len() as u32 - 1
                }
                None => parent,
            },
            None => {
                let parent_tape = if parent == FULL {
                    self.tape
                } else {
                    &self.tapes[parent as usize]
                };
                self.intervals.eval(parent_tape, bx, Some(&mut self.choices));
                match self.simplifier.simplify(parent_tape, &self.choices) {
                    Some(t) if t.len() < parent_tape.len() => {
                        self.tapes.push(t);
                        self.tapes.len() as u32 - 1
                    }
                    _ => parent,
                }
            }
        };
        let short = if self.fold.is_some() { FOLD_SHORT } else { SHORT };
        let leaf = depth >= MAX_DEPTH || self.len_of(tape) <= short;
        self.cells.push(Cell {
            tape,
            visits: [0; 8],
            parent: above,
            depth,
        });
        let kids = [if leaf { LEAF } else { NONE }; 8];
        self.nodes.push(Node { c, h, kids });
        self.cells.len() as u32 - 1
    }

    /// Evaluates the points with the tape or fold cell `t`.
    #[allow(clippy::too_many_arguments)]
    fn run(
        &mut self,
        eval: &mut BatchEvaluator<'s, f32>,
        vars: &[f64],
        t: u32,
        xs: &[f32],
        ys: &[f32],
        zs: &[f32],
        out: &mut [f32],
    ) {
        self.instrs_run += (xs.len() * self.len_of(t)) as u64;
        match &mut self.fold {
            Some((fold, cells)) => fold.eval(&cells[fold_index(t)], xs, ys, zs, out),
            None => eval.eval_variant(self.tape_of(t), vars, xs, ys, zs, out),
        }
    }

    /// The deepest cell holding the cube of half-size `margin` around `p`
    /// (made as needed); [`NONE`] when `p` is outside the domain (the
    /// root's tape holds only inside it).
    ///
    /// The descent starts at `hint` (the previous point's cell: points come
    /// in runs along rays), or the nearest cell above it, that the cube
    /// around `p` lies strictly inside: the cells above that one lead to
    /// it, and no plane that divides them passes within `margin` of `p`.
    fn cell_of(&mut self, p: [f32; 3], margin: f64, hint: u32) -> u32 {
        let p = p.map(|x| x as f64);
        let within = |c: [f64; 3], h: f64| (0..3).all(|k| (p[k] - c[k]).abs() + margin < h);
        // Up from the hint to the first cell that holds the cube: points
        // mostly move on to a neighbouring cell, a level or two away.
        let mut cell = if hint == NONE { 0 } else { hint };
        while cell != 0 {
            let n = &self.nodes[cell as usize];
            if within(n.c, n.h) {
                break;
            }
            cell = self.cells[cell as usize].parent;
        }
        let (mut c, mut h) = (self.nodes[cell as usize].c, self.nodes[cell as usize].h);
        if cell == 0 {
            let inside = |k: usize| (p[k] - c[k]).abs() + margin <= h;
            if !(inside(0) && inside(1) && inside(2)) {
                return NONE;
            }
        }
        let mut depth = self.cells[cell as usize].depth;
        loop {
            let kids = &self.nodes[cell as usize].kids;
            if kids[0] == LEAF {
                return cell;
            }
            let h2 = 0.5 * h;
            let mut i = 0;
            let mut cc = c;
            for k in 0..3 {
                // Inside the child only if the whole margin is.
                let off = p[k] - c[k];
                if off.abs() < margin {
                    return cell;
                }
                if off >= 0.0 {
                    i |= 1 << k;
                    cc[k] += h2;
                } else {
                    cc[k] -= h2;
                }
            }
            depth += 1;
            let mut kid = kids[i];
            if kid == NONE {
                let v = &mut self.cells[cell as usize].visits[i];
                let patience = if self.fold.is_some() { FOLD_PATIENCE } else { PATIENCE };
                if *v < patience {
                    *v += 1;
                    return cell;
                }
                let parent = self.cells[cell as usize].tape;
                kid = self.make_cell(parent, cell, cc, h2, depth);
                self.nodes[cell as usize].kids[i] = kid;
            }
            (cell, c, h) = (kid, cc, h2);
        }
    }

    /// Groups the points by the cell whose tape evaluates them (within
    /// `margin` of the point): `self.keys`, sorted. Returns the cell when
    /// they all share one.
    fn group(&mut self, xs: &[f32], ys: &[f32], zs: &[f32], margin: f64) -> Option<u32> {
        self.keys.clear();
        let mut same = true;
        let mut first = NONE;
        let mut hint = NONE;
        for i in 0..xs.len() {
            let c = self.cell_of([xs[i], ys[i], zs[i]], margin, hint);
            hint = c;
            if i == 0 {
                first = c;
            }
            same &= c == first;
            self.keys.push(((c as u64) << 32) | i as u64);
        }
        if same {
            return Some(first);
        }
        self.keys.sort_unstable();
        // Small groups move up to their parent cell (a few levels at most).
        for _ in 0..4 {
            let mut moved = false;
            for (start, end, cell) in self.runs() {
                if end - start >= MIN_GROUP || cell == NONE {
                    continue;
                }
                let parent = self.cells[cell as usize].parent;
                let len = |c: u32| self.len_of(self.cell_tape(c));
                if parent != NONE && len(parent) <= 2 * len(cell) {
                    for k in &mut self.keys[start..end] {
                        *k = ((parent as u64) << 32) | (*k & 0xffff_ffff);
                    }
                    moved = true;
                }
            }
            if !moved {
                break;
            }
            self.keys.sort_unstable();
        }
        None
    }

    /// The runs of `self.keys` (after [`Self::group`]): (start, end, cell).
    fn runs(&self) -> Vec<(usize, usize, u32)> {
        let mut runs = Vec::new();
        let m = self.keys.len();
        let mut start = 0;
        while start < m {
            let cell = self.keys[start] >> 32;
            let mut end = start + 1;
            while end < m && self.keys[end] >> 32 == cell {
                end += 1;
            }
            runs.push((start, end, cell as u32));
            start = end;
        }
        runs
    }

    /// Copies the points of keys `run` (after [`Self::group`]) from `src`
    /// into `dst`, in key order.
    fn gather_points(&self, run: std::ops::Range<usize>, src: [&[f32]; 3], dst: [&mut Vec<f32>; 3]) {
        for (s, d) in src.into_iter().zip(dst) {
            d.clear();
            d.extend(self.keys[run.clone()].iter().map(|&k| s[(k & 0xffff_ffff) as usize]));
        }
    }

    /// Evaluates the points (xs, ys, zs) into `out`, each with the tape of
    /// its cell.
    pub(crate) fn eval(
        &mut self,
        eval: &mut BatchEvaluator<'s, f32>,
        vars: &[f64],
        xs: &[f32],
        ys: &[f32],
        zs: &[f32],
        out: &mut [f32],
    ) {
        let m = xs.len().min(ys.len()).min(zs.len()).min(out.len());
        if m == 0 {
            return;
        }
        if let Some(cell) = self.group(&xs[..m], &ys[..m], &zs[..m], 0.0) {
            let t = self.cell_tape(cell);
            self.run(eval, vars, t, &xs[..m], &ys[..m], &zs[..m], &mut out[..m]);
            return;
        }
        let mut g = std::mem::take(&mut self.gather);
        for (start, end, cell) in self.runs() {
            let t = self.cell_tape(cell);
            let [gx, gy, gz, gd, ..] = &mut g;
            self.gather_points(start..end, [xs, ys, zs], [gx, gy, gz]);
            gd.resize(end - start, 0.0);
            self.run(eval, vars, t, gx, gy, gz, &mut gd[..end - start]);
            for (j, &k) in self.keys[start..end].iter().enumerate() {
                out[(k & 0xffff_ffff) as usize] = gd[j];
            }
        }
        self.gather = g;
    }

    /// Gradients (see [`BatchEvaluator::gradients`]) at the points, each
    /// with the tape of a cell holding its whole finite-difference stencil
    /// (dual numbers run the full tape).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn gradients(
        &mut self,
        eval: &mut BatchEvaluator<'s, f32>,
        vars: &[f64],
        xs: &[f32],
        ys: &[f32],
        zs: &[f32],
        mode: GradientMode,
        gx: &mut [f32],
        gy: &mut [f32],
        gz: &mut [f32],
    ) {
        let m = xs.len().min(ys.len()).min(zs.len());
        if m == 0 {
            return;
        }
        let h = mode.step();
        if mode == GradientMode::Dual || !h.is_finite() {
            eval.gradients(vars, xs, ys, zs, mode, gx, gy, gz);
            return;
        }
        // The stencil's offsets are at most h along each axis.
        let margin = 1.01 * h.abs() + 1e-6;
        if let Some(cell) = self.group(&xs[..m], &ys[..m], &zs[..m], margin) {
            let t = self.cell_tape(cell);
            self.gradients_of(eval, vars, t, [xs, ys, zs], mode, [gx, gy, gz]);
            return;
        }
        let mut g = std::mem::take(&mut self.gather);
        for (start, end, cell) in self.runs() {
            let t = self.cell_tape(cell);
            let [px, py, pz, ox, oy, oz, _] = &mut g;
            self.gather_points(start..end, [xs, ys, zs], [px, py, pz]);
            for v in [&mut *ox, &mut *oy, &mut *oz] {
                v.clear();
                v.resize(end - start, 0.0);
            }
            self.gradients_of(eval, vars, t, [px, py, pz], mode, [ox, oy, oz]);
            for (j, &k) in self.keys[start..end].iter().enumerate() {
                let i = (k & 0xffff_ffff) as usize;
                (gx[i], gy[i], gz[i]) = (ox[j], oy[j], oz[j]);
            }
        }
        self.gather = g;
    }

    /// Finite-difference gradients at the points `p` with the tape or fold
    /// cell `t` (valid over the whole stencil): for a fold, the batch
    /// evaluator's stencil over the fold's values, so the same numbers.
    fn gradients_of(
        &mut self,
        eval: &mut BatchEvaluator<'s, f32>,
        vars: &[f64],
        t: u32,
        p: [&[f32]; 3],
        mode: GradientMode,
        g: [&mut [f32]; 3],
    ) {
        let at = fold_index(t);
        let Some((fold, cells)) = &mut self.fold else {
            let [gx, gy, gz] = g;
            let tape = self.tape_of(t);
            eval.gradients_variant(Some(tape), vars, p[0], p[1], p[2], mode, gx, gy, gz);
            return;
        };
        let cell = &cells[at];
        isoray_shape::eval::finite_differences(mode, p, g, &mut self.stencil, |x, y, z, f| fold.eval(cell, x, y, z, f));
    }
}

/// The index in a fold's cells of the tape index `t` ([`FULL`]: the
/// whole fold, cell 0).
fn fold_index(t: u32) -> usize {
    if t == FULL {
        0
    } else {
        t as usize
    }
}

#[cfg(test)]
mod tests {
    use crate::trace::Field;

    /// A scene of `n` spheres joined by a smooth union (as
    /// bench/tracer/spheres.sh writes, smaller).
    fn spheres(n: usize, size: (u32, u32)) -> String {
        let mut s = format!(
            "[camera]\nposition = [0.0, 3.0, 14.0]\ntarget = [0.0, 0.0, 0.0]\n[render]\nwidth = {}\nheight = {}\nblend = 0.15\n[[light]]\ndirection = [-0.6, 1.0, 0.8]\n",
            size.0, size.1
        );
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed * 16807 % 2147483647;
            -4.0 + 8.0 * seed as f64 / 2147483647.0
        };
        for _ in 0..n {
            let c = [rnd(), rnd(), rnd()];
            s += &format!(
                "[[object]]\nshape = \"sphere(p - vec3({:.4}, {:.4}, {:.4}), 0.3)\"\n",
                c[0], c[1], c[2]
            );
        }
        s
    }

    /// Compares `pruned` with `full` bit for bit, values and gradients
    /// (`mode`), over `rounds` batches of `n` points: every other batch
    /// clustered (radius `near`, as a packet's rays are) around a random
    /// point of the cube [-4, 4]³, the others spread (radius `far`) around
    /// the origin. Returns the number of points.
    fn compare_fields(
        pruned: &mut Field,
        full: &mut Field,
        rounds: usize,
        n: usize,
        (near, far): (f32, f32),
        mode: isoray_shape::GradientMode,
        what: &str,
    ) -> usize {
        let mut seed = 7u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f32 / (1u64 << 53) as f32
        };
        for round in 0..rounds {
            let (c, r) = if round % 2 == 0 {
                ([rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0], near)
            } else {
                ([0.0; 3], far)
            };
            let p: Vec<[f32; 3]> = (0..n)
                .map(|_| std::array::from_fn(|k| c[k] + (rnd() * 2.0 - 1.0) * r))
                .collect();
            let [xs, ys, zs]: [Vec<f32>; 3] = std::array::from_fn(|k| p.iter().map(|q| q[k]).collect());
            let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
            pruned.eval(&xs, &ys, &zs, &mut a);
            full.eval(&xs, &ys, &zs, &mut b);
            for i in 0..n {
                assert_eq!(a[i].to_bits(), b[i].to_bits(), "{what}: at {:?}", p[i]);
            }
            let mut ga = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
            let mut gb = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
            {
                let [x, y, z] = &mut ga;
                pruned.gradients(&xs, &ys, &zs, mode, x, y, z);
            }
            {
                let [x, y, z] = &mut gb;
                full.gradients(&xs, &ys, &zs, mode, x, y, z);
            }
            for k in 0..3 {
                for i in 0..n {
                    assert_eq!(ga[k][i].to_bits(), gb[k][i].to_bits(), "{what}: gradient at {:?}", p[i]);
                }
            }
        }
        rounds * n
    }

    /// Pruned evaluations equal the full tape's bit for bit, inside the
    /// domain and out, in batches spread over many cells, and run far fewer
    /// instructions.
    #[test]
    fn pruned_field_equals_the_full_tape() {
        let scene = isoray_scene::load_str(&spheres(60, (8, 8)), "spheres.toml", &[]).unwrap();
        let tape = scene.shape.tape();
        assert!(super::prunable(tape), "{} instructions", tape.len());
        let mut pruned = Field::pruned(tape, &scene.inputs, [0.0, 0.0, 0.0], 6.0);
        let mut full = Field::new(tape, &scene.inputs);
        let mode = isoray_shape::GradientMode::Tetrahedron(1e-3);
        let points = compare_fields(&mut pruned, &mut full, 60, 2000, (0.3, 7.0), mode, "tape");
        let run = pruned.instructions_run().unwrap();
        let whole = (points * tape.len()) as u64;
        assert!(run * 10 < whole * 7, "{run} instructions run, {whole} unpruned");
    }

    /// A scene of `n` objects of several kinds (spheres, boxes, tori,
    /// placed and rotated), joined with `blend`.
    fn mixed(n: usize, blend: f64) -> String {
        let mut s =
            format!("[camera]\nposition = [0.0, 3.0, 14.0]\n[render]\nwidth = 8\nheight = 8\nblend = {blend}\n");
        let mut seed = 777u64;
        let mut rnd = || {
            seed = seed * 16807 % 2147483647;
            seed as f64 / 2147483647.0
        };
        for i in 0..n {
            let c = [rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0];
            let shape = match i % 3 {
                0 => "sphere(p, 0.3)",
                1 => "box(p, vec3(0.25, 0.15, 0.3))",
                _ => "torus(p, 0.3, 0.1)",
            };
            s += &format!(
                "[[object]]\nshape = \"{shape}\"\nposition = [{:.4}, {:.4}, {:.4}]\nrotation = [{:.1}, {:.1}, 0.0]\n",
                c[0],
                c[1],
                c[2],
                rnd() * 90.0,
                rnd() * 90.0
            );
        }
        s
    }

    /// Regions specialised object by object give the full tape's values
    /// and gradients bit for bit, for smooth unions and plain ones, with
    /// the spheres bounded by their tapes or in closed form, and run far
    /// fewer instructions.
    #[test]
    fn fold_cells_equal_the_full_tape() {
        for (blend, closed) in [(0.2, false), (0.0, false), (0.2, true)] {
            let scene = isoray_scene::load_str(&mixed(45, blend), "mixed.toml", &[]).unwrap();
            let tape = scene.shape.tape();
            assert!(super::prunable(tape), "{} instructions", tape.len());
            let tapes: Vec<&isoray_shape::Tape> = scene.objects.iter().map(|o| o.shape.tape()).collect();
            // The spheres bounded in closed form, the others by their tapes.
            let spheres: Vec<Option<([f64; 3], f64)>> = scene
                .objects
                .iter()
                .map(|o| match o.closed_form(&scene.inputs) {
                    Some(isoray_scene::analytic::Analytic::Sphere { c, r }) if closed => Some((c, r)),
                    _ => None,
                })
                .collect();
            assert_eq!(spheres.iter().flatten().count(), if closed { 15 } else { 0 });
            let mut folded = Field::pruned_fold(
                tape,
                &tapes,
                &spheres,
                blend,
                &scene.inputs,
                [0.0; 3],
                8.0,
                ([0.0; 3], 4.5),
            );
            assert!(folded.by_objects(), "blend {blend}: the fold was refused");
            let mut full = Field::new(tape, &scene.inputs);
            let mode = isoray_shape::GradientMode::Central(1e-3);
            let what = format!("blend {blend}, spheres in closed form {closed}");
            let points = compare_fields(&mut folded, &mut full, 80, 1000, (0.2, 7.5), mode, &what);
            let run = folded.instructions_run().unwrap();
            let whole = (points * tape.len()) as u64;
            assert!(
                run * 10 < whole * 7,
                "blend {blend}: {run} instructions run, {whole} unpruned"
            );
        }
    }

    /// Objects in another order than the scene's fold are not its fold:
    /// the check at sample points refuses them, and the field simplifies
    /// the tape instead (the same values).
    #[test]
    fn a_fold_of_other_objects_is_refused() {
        let scene = isoray_scene::load_str(&mixed(45, 0.2), "mixed.toml", &[]).unwrap();
        let tape = scene.shape.tape();
        let mut tapes: Vec<&isoray_shape::Tape> = scene.objects.iter().map(|o| o.shape.tape()).collect();
        tapes.reverse();
        let f = Field::pruned_fold(tape, &tapes, &[], 0.2, &scene.inputs, [0.0; 3], 8.0, ([0.0; 3], 4.5));
        assert!(!f.by_objects());
        assert!(f.instructions_run().is_some(), "still pruned, by tape");
    }

    /// A render with `render.prune` on is byte for byte the render with it
    /// off: tapes simplified per region, rays stopped past the surface's
    /// reach, and shadow rays past the penumbra's (soft, improved and hard
    /// shadows).
    #[test]
    fn pruning_leaves_the_image_unchanged() {
        let text = spheres(60, (48, 32));
        let opts = crate::RenderOptions {
            aovs: true,
            ..Default::default()
        };
        for shadows in ["soft", "improved", "hard"] {
            let mode = format!("render.shadows=\"{shadows}\"");
            let on = isoray_scene::load_str(&text, "spheres.toml", std::slice::from_ref(&mode)).unwrap();
            let off = isoray_scene::load_str(&text, "spheres.toml", &[mode, "render.prune=false".into()]).unwrap();
            assert!(super::super::penumbra(&on).is_some());
            let (a, _) = crate::render(&on, &opts);
            let (b, _) = crate::render(&off, &opts);
            assert!(a == b, "{shadows} shadows: pruned and unpruned images differ");
            let hit = a.depth.as_ref().unwrap().iter().filter(|d| d.is_finite()).count();
            assert!(hit > 100, "only {hit} pixels hit");
        }
    }
}
