//! The box a field's surface lies in, from interval bounds of its tape.
//!
//! A ray that has left this box, heading away, meets no surface again: it
//! can stop marching there, a miss, instead of stepping on to the far
//! limit through empty space (where the field is the most expensive to
//! evaluate: far from every object, the nearest one is decided by many).
//!
//! The box is found in a cube (the domain every traced point lies in) by
//! six best-first searches, one per face, over an octree of that cube
//! shared between them: the search for, say, the largest x opens cells
//! in order of their largest x, drops each whose interval bound shows
//! the field at least `above` everywhere in it (no surface: no point
//! there is a hit), and stops at the first cell that may hold surface at
//! the finest level. Each cell bounds its parent's tape simplified for
//! it ([`Simplifier`]), so the deep levels run short tapes.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use isoray_shape::interval::{Choice, IntervalEvaluator};
use isoray_shape::simplify::Simplifier;
use isoray_shape::Tape;

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The least corner.
    pub lo: [f64; 3],
    /// The greatest corner.
    pub hi: [f64; 3],
}

impl Aabb {
    /// True when the point lies in the box (faces included).
    pub fn contains(&self, p: [f64; 3]) -> bool {
        (0..3).all(|k| self.lo[k] <= p[k] && p[k] <= self.hi[k])
    }

    /// The parameter range [t0, t1] of the ray o + t·d inside the box
    /// (slabs; t0 > t1 when the ray's line misses it).
    pub fn ray_range(&self, o: [f64; 3], d: [f64; 3]) -> (f64, f64) {
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for k in 0..3 {
            if d[k] == 0.0 {
                if o[k] < self.lo[k] || o[k] > self.hi[k] {
                    return (f64::INFINITY, f64::NEG_INFINITY);
                }
                continue;
            }
            let inv = 1.0 / d[k];
            let (a, b) = ((self.lo[k] - o[k]) * inv, (self.hi[k] - o[k]) * inv);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0, t1)
    }
}

/// No child made yet.
const NONE: u32 = u32::MAX;

/// A cell of the shared octree.
#[derive(Debug, Clone)]
struct Cell {
    c: [f64; 3],
    h: f64,
    depth: u8,
    /// The tape it is bounded with (its parent's, simplified for the
    /// parent): an index into `tapes`, or [`NONE`] for the full tape.
    tape: u32,
    /// None until bounded; then whether it may hold surface.
    maybe: Option<bool>,
    /// The tape its children are bounded with (set when bounded).
    kids_tape: u32,
    kids: [u32; 8],
}

/// An entry of a search's queue: how far out a cell reaches, its depth
/// and the cell; the furthest first, and of those the deepest (so that a
/// surface reaching the domain's face, such as a plane, is found by one
/// descent rather than a sweep of the face).
#[derive(Debug, PartialEq)]
struct Entry(f64, u8, u32);

impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0
            .total_cmp(&other.0)
            .then(self.1.cmp(&other.1))
            .then(other.2.cmp(&self.2))
    }
}

struct Search<'t> {
    tape: &'t Tape,
    intervals: IntervalEvaluator<'t>,
    choices: Vec<Choice>,
    simplifier: Simplifier,
    tapes: Vec<Tape>,
    cells: Vec<Cell>,
    above: f64,
    max_depth: u8,
    /// Interval instructions left to run.
    budget: i64,
    /// Whether a search stopped at its cap (its answer a looser bound).
    capped: bool,
}

impl Search<'_> {
    /// The box from the six searches, each spending at most `cap`.
    fn six(&mut self, cap: i64) -> Option<Aabb> {
        let mut b = Aabb {
            lo: [0.0; 3],
            hi: [0.0; 3],
        };
        for k in 0..3 {
            b.hi[k] = self.extreme(k, 1.0, cap)?;
            b.lo[k] = -self.extreme(k, -1.0, cap)?;
        }
        Some(b)
    }
}

impl Search<'_> {
    fn tape(&self, t: u32) -> &Tape {
        if t == NONE {
            self.tape
        } else {
            &self.tapes[t as usize]
        }
    }

    /// Whether cell `i` may hold a point where the field is below `above`.
    fn maybe(&mut self, i: u32) -> bool {
        if let Some(m) = self.cells[i as usize].maybe {
            return m;
        }
        let Cell { c, h, tape, depth, .. } = self.cells[i as usize];
        let bx = crate::prune::padded_cell(c, h);
        let t = if tape == NONE {
            self.tape
        } else {
            &self.tapes[tape as usize]
        };
        self.budget -= t.len() as i64 + 1;
        let v = self.intervals.eval(t, bx, Some(&mut self.choices));
        // Clear of `above` whatever the f32 evaluation's rounding.
        let clear = v.lo > self.above + 1e-5 * (v.lo.abs() + self.above.abs()) + 1e-6;
        let mut kids_tape = tape;
        if !clear && depth < self.max_depth {
            if let Some(s) = self.simplifier.simplify(t, &self.choices) {
                if s.len() < self.tape(tape).len() {
                    self.tapes.push(s);
                    kids_tape = self.tapes.len() as u32 - 1;
                }
            }
        }
        let cell = &mut self.cells[i as usize];
        cell.maybe = Some(!clear);
        cell.kids_tape = kids_tape;
        !clear
    }

    /// The children of cell `i` (made on first use).
    fn kids(&mut self, i: u32) -> [u32; 8] {
        let cell = self.cells[i as usize].clone();
        if cell.kids[0] != NONE {
            return cell.kids;
        }
        let h = 0.5 * cell.h;
        let kids = std::array::from_fn(|j| {
            let c = std::array::from_fn(|k| cell.c[k] + if j >> k & 1 == 1 { h } else { -h });
            self.cells.push(Cell {
                c,
                h,
                depth: cell.depth + 1,
                tape: cell.kids_tape,
                maybe: None,
                kids_tape: NONE,
                kids: [NONE; 8],
            });
            self.cells.len() as u32 - 1
        });
        self.cells[i as usize].kids = kids;
        kids
    }

    /// The greatest s·x_axis over the cells at the finest level that may
    /// hold surface (s = ±1); None when no cell may. Spends at most `cap`
    /// of the budget; past that (or the budget), the furthest cell not
    /// ruled out, and `self.capped` is set.
    fn extreme(&mut self, axis: usize, s: f64, cap: i64) -> Option<f64> {
        let entry = |c: &Cell, i: u32| Entry(s * c.c[axis] + c.h, c.depth, i);
        let stop = self.budget.saturating_sub(cap).max(0);
        let mut queue = BinaryHeap::new();
        queue.push(entry(&self.cells[0], 0));
        while let Some(Entry(r, depth, i)) = queue.pop() {
            if self.budget <= stop {
                // Nothing queued reaches further than this cell.
                self.capped = true;
                return Some(r);
            }
            if !self.maybe(i) {
                continue;
            }
            if depth >= self.max_depth {
                return Some(r);
            }
            for k in self.kids(i) {
                queue.push(entry(&self.cells[k as usize], k));
            }
        }
        None
    }
}

/// The box, within the cube of half-size `half` around `center`, holding
/// every point of the cube where `tape` (with the inputs `vars`) may be
/// `above` or less, to within the cube's size / 2^`max_depth`; None when
/// no point of the cube is. The searches run at most `budget` interval
/// instructions in all: past that, each answers with the furthest cell it
/// has not ruled out, a looser box but still a true one.
///
/// They run in two rounds. In the first each face gets 1/48 of the budget;
/// when one runs short and the box is still more than half the cube (the
/// bounds are too loose to rule out much of it, as for a twisted box or
/// a plane), that box is the answer and the rest of the budget is not
/// spent. Otherwise the six searches go on in turn with what is left; the
/// cells the first round bounded are not bounded again, so the answer is
/// the one a single round with the whole budget gives.
pub fn surface_box(
    tape: &Tape,
    vars: &[f64],
    center: [f64; 3],
    half: f64,
    above: f64,
    max_depth: u8,
    budget: i64,
) -> Option<Aabb> {
    let mut search = Search {
        tape,
        intervals: IntervalEvaluator::new(tape, vars),
        choices: Vec::new(),
        simplifier: Simplifier::default(),
        tapes: Vec::new(),
        cells: vec![Cell {
            c: center,
            h: half,
            depth: 0,
            tape: NONE,
            maybe: None,
            kids_tape: NONE,
            kids: [NONE; 8],
        }],
        above,
        max_depth,
        budget,
        capped: false,
    };
    let first = search.six(budget / 48)?;
    if !search.capped {
        return Some(first);
    }
    let volume = |b: &Aabb| (0..3).map(|k| (b.hi[k] - b.lo[k]).max(0.0)).product::<f64>();
    if volume(&first) > 0.5 * (2.0 * half).powi(3) {
        return Some(first);
    }
    search.six(i64::MAX)
}

/// What rays can reach of a field's surface inside a domain cube (every
/// point rays trace lies in it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    domain: Aabb,
    /// The box of the surface (see [`surface_box`]); None: no surface.
    surface: Option<Aabb>,
}

/// Levels of the octree [`Reach::new`] searches: the box is exact to
/// 1/1024 of the domain.
pub const REACH_DEPTH: u8 = 9;

impl Reach {
    /// The reach of `tape`'s surface, the points where it is `above` or
    /// less (the hit threshold), inside the cube of half-size `half`
    /// around `center`, for a render of `rays` primary rays: the search
    /// runs about 1/64 of the instructions one step of every ray would
    /// (at least 65,536, about 2 ms; at most 64 million, about 1 s).
    pub fn new(tape: &Tape, vars: &[f64], center: [f64; 3], half: f64, above: f64, rays: u64) -> Reach {
        let budget = (rays.saturating_mul(tape.len() as u64) / 64).clamp(1 << 16, 1 << 26) as i64;
        Reach {
            domain: Aabb {
                lo: center.map(|c| c - half),
                hi: center.map(|c| c + half),
            },
            surface: surface_box(tape, vars, center, half, above, REACH_DEPTH, budget),
        }
    }

    /// The reach of a union of spheres (centre, radius), or of their smooth
    /// union of width `k` folded in any order, inside the cube of
    /// half-size `half` around `center`: where the field is `above` or
    /// less, in closed form.
    ///
    /// A fold of quadratic smooth unions is never below the least of its
    /// operands minus k: su(a, b) ≥ min(a, b) − k/4, and once the fold is
    /// x below an operand m, adding any b ≥ m leaves it at least
    /// m − x − (k − x)²/(4k) ≥ m − k for 0 ≤ x ≤ k. So the surface lies in
    /// the union of the balls of radius r + `above` + k, whose box this is
    /// (padded for the f32 evaluation of the field). None when a centre
    /// or radius is not finite.
    pub fn of_spheres(spheres: &[([f64; 3], f64)], k: f64, center: [f64; 3], half: f64, above: f64) -> Option<Reach> {
        let domain = Aabb {
            lo: center.map(|c| c - half),
            hi: center.map(|c| c + half),
        };
        let mut b: Option<Aabb> = None;
        for &(c, r) in spheres {
            if !(r.is_finite() && c.iter().all(|x| x.is_finite())) {
                return None;
            }
            let size = c.iter().fold(r.abs() + above.abs() + k.abs(), |m, x| m.max(x.abs()));
            let reach = r + above + k.max(0.0) + 1e-4 * (1.0 + size);
            if reach < 0.0 {
                continue;
            }
            let lo = c.map(|x| x - reach);
            let hi = c.map(|x| x + reach);
            b = Some(match b {
                None => Aabb { lo, hi },
                Some(b) => Aabb {
                    lo: std::array::from_fn(|i| b.lo[i].min(lo[i])),
                    hi: std::array::from_fn(|i| b.hi[i].max(hi[i])),
                },
            });
        }
        // Within the domain, as the searches' boxes are.
        let surface = b.and_then(|b| {
            let lo: [f64; 3] = std::array::from_fn(|i| b.lo[i].max(domain.lo[i]));
            let hi: [f64; 3] = std::array::from_fn(|i| b.hi[i].min(domain.hi[i]));
            (0..3).all(|i| lo[i] <= hi[i]).then_some(Aabb { lo, hi })
        });
        Some(Reach { domain, surface })
    }

    /// The box of the surface; None when the domain holds none.
    pub fn surface(&self) -> Option<Aabb> {
        self.surface
    }

    /// The domain it was searched in, and the box of the surface in it
    /// (None: no surface there).
    pub fn boxes(&self) -> (Aabb, Option<Aabb>) {
        (self.domain, self.surface)
    }

    /// The parameter beyond which the ray o + t·d, 0 ≤ t ≤ `tmax`, meets
    /// no surface: negative when it meets none at all, +∞ when that is not
    /// known (the ray leaves the domain).
    pub fn far(&self, o: [f32; 3], d: [f32; 3], tmax: f32) -> f32 {
        let o = o.map(f64::from);
        let d = d.map(f64::from);
        let end: [f64; 3] = std::array::from_fn(|k| o[k] + d[k] * tmax as f64);
        if !tmax.is_finite() || !self.domain.contains(o) || !self.domain.contains(end) {
            return f32::INFINITY;
        }
        let Some(b) = self.surface else {
            return -1.0;
        };
        let (t0, t1) = b.ray_range(o, d);
        if t0 > t1 || t1 < 0.0 {
            -1.0
        } else {
            (t1 + 1e-5 * (1.0 + t1)) as f32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use isoray_shape::{compile, Library};

    /// The box of a sphere and of a smooth union of two, to within a cell.
    #[test]
    fn boxes_of_spheres() {
        let lib = Library::new();
        let sh = compile(&lib, "sphere(p - vec3(1.0, -2.0, 0.5), 0.5)").unwrap();
        let b = surface_box(sh.tape(), &[], [0.0; 3], 16.0, 1e-3, 9, 1 << 20).unwrap();
        let cell = 2.0 * 16.0 / 512.0;
        let want_lo = [0.5, -2.5, 0.0];
        let want_hi = [1.5, -1.5, 1.0];
        for k in 0..3 {
            assert!(b.lo[k] <= want_lo[k] && b.lo[k] > want_lo[k] - 2.0 * cell, "{b:?}");
            assert!(b.hi[k] >= want_hi[k] && b.hi[k] < want_hi[k] + 2.0 * cell, "{b:?}");
        }
        // Nothing below -1 anywhere: no box.
        assert!(surface_box(sh.tape(), &[], [0.0; 3], 16.0, -1.0, 9, 1 << 20).is_none());
    }

    /// A smooth union of spheres, some of them stacked on one centre (the
    /// blends compound there, down to min − k), never reaches below the
    /// threshold outside the closed-form box, and the box is the union of
    /// the balls grown by no more than k.
    #[test]
    fn sphere_folds_lie_in_their_balls_box() {
        let lib = Library::new();
        let mut seed = 11u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % 1_000_000) as f64 / 1_000_000.0
        };
        let k = 0.5;
        let mut spheres: Vec<([f64; 3], f64)> = (0..12)
            .map(|_| (std::array::from_fn(|_| rnd() * 4.0 - 2.0), 0.1 + 0.3 * rnd()))
            .collect();
        for _ in 0..6 {
            spheres.push(([1.5, -1.5, 1.5], 0.2));
        }
        let one = |(c, r): &([f64; 3], f64)| format!("sphere(p - vec3({:.6}, {:.6}, {:.6}), {r:.6})", c[0], c[1], c[2]);
        let src = spheres[1..].iter().fold(one(&spheres[0]), |acc, s| {
            format!("smooth_union({acc}, {}, {k})", one(s))
        });
        let sh = compile(&lib, &src).unwrap();
        let above = 1e-3;
        let reach = Reach::of_spheres(&spheres, k, [0.0; 3], 8.0, above).unwrap();
        let b = reach.surface().unwrap();
        let mut eval = isoray_shape::PointEvaluator::<f32>::new(sh.tape());
        let mut inside = 0;
        for _ in 0..200_000 {
            let p: [f64; 3] = std::array::from_fn(|_| rnd() * 6.0 - 3.0);
            if eval.eval(&[], p[0] as f32, p[1] as f32, p[2] as f32) as f64 <= above {
                inside += 1;
                assert!(b.contains(p), "{p:?} outside {b:?}");
            }
        }
        assert!(inside > 1000, "{inside} points sampled inside");
        // At most k (and the padding) beyond the balls themselves.
        for i in 0..3 {
            let lo = spheres.iter().map(|(c, r)| c[i] - r).fold(f64::INFINITY, f64::min);
            let hi = spheres.iter().map(|(c, r)| c[i] + r).fold(f64::NEG_INFINITY, f64::max);
            assert!(b.lo[i] >= lo - k - 0.01 && b.hi[i] <= hi + k + 0.01, "{b:?}");
        }
        // The fold's own bound: min − k at the stacked centre's rim.
        let q = [1.5f32 + 0.2, -1.5, 1.5];
        let v = eval.eval(&[], q[0], q[1], q[2]);
        let v = v as f64;
        assert!(v < -0.2 * k && v >= -k - 1e-6, "{v}");
    }

    /// A field whose interval bounds rule out little (a twist: sines of
    /// wide ranges) still gets a true box: every sampled point where it is
    /// below the threshold lies inside, whichever round answered.
    #[test]
    fn loose_bounds_still_give_a_true_box() {
        let lib = Library::new();
        let src = "box(vec3(p.x * cos(2.0 * p.y) - p.z * sin(2.0 * p.y), p.y, p.x * sin(2.0 * p.y) + p.z * cos(2.0 * p.y)) - vec3(3.0, 1.0, -2.0), vec3(0.6, 1.5, 0.3))";
        let sh = compile(&lib, src).unwrap();
        let mut eval = isoray_shape::PointEvaluator::<f64>::new(sh.tape());
        for budget in [1 << 12, 1 << 16, 1 << 20] {
            let b = surface_box(sh.tape(), &[], [0.0; 3], 16.0, 1e-3, 9, budget).unwrap();
            let mut inside = 0;
            for i in 0..40_000u32 {
                let f = |k: u32| {
                    ((i.wrapping_mul(2654435761).wrapping_add(k * 40503) % 10_000) as f64 / 10_000.0) * 12.0 - 6.0
                };
                let p = [f(1), f(2), f(3)];
                if eval.eval(&[], p[0], p[1], p[2]) <= 1e-3 {
                    inside += 1;
                    assert!(b.contains(p), "budget {budget}: {p:?} outside {b:?}");
                }
            }
            assert!(inside > 100, "{inside} points sampled inside");
        }
    }

    #[test]
    fn ray_ranges() {
        let b = Aabb {
            lo: [-1.0; 3],
            hi: [1.0; 3],
        };
        assert_eq!(b.ray_range([-3.0, 0.0, 0.0], [1.0, 0.0, 0.0]), (2.0, 4.0));
        let (t0, t1) = b.ray_range([-3.0, 2.0, 0.0], [1.0, 0.0, 0.0]);
        assert!(t0 > t1);
    }
}
