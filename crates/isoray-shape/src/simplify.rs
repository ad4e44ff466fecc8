//! Tape simplification over a region: the branches of `min`, `max` and
//! selects that cannot win anywhere in a box are dropped, and so is every
//! instruction only they needed.
//!
//! Interval evaluation over the box ([`crate::interval::eval_interval_choices`])
//! tells, per `min` and `max`, whether one operand's interval lies strictly
//! on the winning side of the other's; then that operand *is* the value at
//! every point of the box, so the instruction becomes a copy of it
//! (`max(a, a)`, exact for every a, NaN included) and a backward liveness
//! pass drops what no longer feeds the output. The simplified tape computes
//! the same value as the full one at every point of the box; renderers
//! reuse it for every evaluation inside the box (fidget's tape
//! simplification, on isoray's tapes).

use crate::interval::Choice;
use crate::ir::{BinOp, Instr, Tape, UnOp};

/// The tape specialised to the region `choices` were recorded over (one
/// per instruction, from [`crate::interval::eval_interval_choices`]), or
/// `None` when nothing can be dropped or the tape has lazy regions (whose
/// `Skip` lengths this pass does not rewrite).
///
/// Three passes: the branches that cannot win are dropped (the
/// instruction becomes a copy of the winner) with everything only they
/// needed; copies are then forwarded (readers read the copied slot, and a
/// copy is written only where that slot is about to be overwritten), and
/// the arithmetic a dropped branch leaves on a constant zero is folded
/// where it is exact for every value (x − 0, 0², 0·c and 0/c for a
/// positive constant c: a smooth union's correction term far from the
/// blend); a last pass drops what became dead.
pub fn simplify(tape: &Tape, choices: &[Choice]) -> Option<Tape> {
    Simplifier::default().simplify(tape, choices)
}

/// [`simplify`] with working memory kept between calls (renderers simplify
/// thousands of times a frame).
#[derive(Debug, Clone, Default)]
pub struct Simplifier {
    /// Per slot: read later (backward passes).
    live: Vec<bool>,
    /// Per slot: the last reader of its next definition (backward pass).
    pending: Vec<Option<usize>>,
    /// Per instruction: the last reader of its result.
    last: Vec<Option<usize>>,
    /// Per slot: the slot holding its value.
    alias: Vec<u32>,
    /// Per aliased slot: its last reader.
    until: Vec<usize>,
    /// Slots aliased to each slot, as doubly linked lists (`NONE` ends).
    head: Vec<u32>,
    next: Vec<u32>,
    prev: Vec<u32>,
    /// Per slot: its value when it is known to be a constant.
    value: Vec<Option<f64>>,
    a: Vec<Instr>,
    b: Vec<Instr>,
}

const NONE: u32 = u32::MAX;

/// A copy of slot `x` into `out`.
fn copy(out: u32, x: u32) -> Instr {
    Instr::Binary {
        op: BinOp::Max,
        out,
        a: x,
        b: x,
    }
}

/// The slots an instruction reads.
fn reads(ins: &Instr) -> impl Iterator<Item = u32> {
    let (v, n): ([u32; 3], usize) = match *ins {
        Instr::Unary { a, .. } => ([a, 0, 0], 1),
        Instr::Binary { a, b, .. } => ([a, b, 0], 2),
        Instr::Select { c, a, b, .. } => ([c, a, b], 3),
        Instr::Skip { c, .. } => ([c, 0, 0], 1),
    };
    v.into_iter().take(n)
}

/// The slot an instruction writes.
fn writes(ins: &Instr) -> Option<u32> {
    match *ins {
        Instr::Unary { out, .. } | Instr::Binary { out, .. } | Instr::Select { out, .. } => Some(out),
        Instr::Skip { .. } => None,
    }
}

/// The instruction with its operands read through `alias`.
fn resolve(alias: &[u32], ins: Instr) -> Instr {
    let r = |s: u32| alias[s as usize];
    match ins {
        Instr::Unary { op, out, a } => Instr::Unary { op, out, a: r(a) },
        Instr::Binary { op, out, a, b } => Instr::Binary {
            op,
            out,
            a: r(a),
            b: r(b),
        },
        Instr::Select { out, c, a, b } => Instr::Select {
            out,
            c: r(c),
            a: r(a),
            b: r(b),
        },
        skip => skip,
    }
}

/// The operand slot an instruction merely passes on, if it does: copies,
/// and the folds exact for every value (x − 0, 0², 0·c and 0/c for a
/// positive finite constant c), given the known constant `value`s.
fn passes_on(value: &[Option<f64>], ins: Instr) -> Option<u32> {
    let zero = |s: u32| value[s as usize].is_some_and(|v| v.to_bits() == 0);
    let positive = |s: u32| value[s as usize].is_some_and(|v| v.is_finite() && v > 0.0);
    match ins {
        Instr::Binary {
            op: BinOp::Min | BinOp::Max,
            a,
            b,
            ..
        } if a == b => Some(a),
        Instr::Select { a, b, .. } if a == b => Some(a),
        Instr::Unary {
            op: UnOp::Square, a, ..
        } if zero(a) => Some(a),
        Instr::Binary {
            op: BinOp::Mul, a, b, ..
        } if zero(a) && positive(b) => Some(a),
        Instr::Binary {
            op: BinOp::Mul, a, b, ..
        } if zero(b) && positive(a) => Some(b),
        Instr::Binary {
            op: BinOp::Div, a, b, ..
        } if zero(a) && positive(b) => Some(a),
        Instr::Binary {
            op: BinOp::Sub, a, b, ..
        } if zero(b) => Some(a),
        _ => None,
    }
}

impl Simplifier {
    /// See [`simplify`].
    pub fn simplify(&mut self, tape: &Tape, choices: &[Choice]) -> Option<Tape> {
        let instrs = tape.instrs();
        if choices.len() != instrs.len()
            || !choices.iter().any(|c| *c != Choice::Both)
            || instrs.iter().any(|i| matches!(i, Instr::Skip { .. }))
        {
            return None;
        }
        self.drop_branches(tape, choices);
        self.forward_copies(tape);
        Some(tape.with_instrs(self.drop_dead(tape)))
    }

    /// Backwards: min, max and selects with a choice become copies of the
    /// winner; instructions nothing live reads are dropped. Into `self.a`.
    fn drop_branches(&mut self, tape: &Tape, choices: &[Choice]) {
        let live = &mut self.live;
        live.clear();
        live.resize(tape.slots(), false);
        live[tape.output()] = true;
        let kept = &mut self.a;
        kept.clear();
        for (ins, &choice) in tape.instrs().iter().zip(choices).rev() {
            let Some(out) = writes(ins) else { continue };
            if !std::mem::take(&mut live[out as usize]) {
                continue;
            }
            let only = match (*ins, choice) {
                (
                    Instr::Binary {
                        op: BinOp::Min | BinOp::Max,
                        a,
                        ..
                    },
                    Choice::Left,
                ) => Some(a),
                (
                    Instr::Binary {
                        op: BinOp::Min | BinOp::Max,
                        b,
                        ..
                    },
                    Choice::Right,
                ) => Some(b),
                (Instr::Select { a, .. }, Choice::Left) => Some(a),
                (Instr::Select { b, .. }, Choice::Right) => Some(b),
                _ => None,
            };
            match only {
                Some(x) => {
                    live[x as usize] = true;
                    kept.push(copy(out, x));
                }
                None => {
                    for r in reads(ins) {
                        live[r as usize] = true;
                    }
                    kept.push(*ins);
                }
            }
        }
        kept.reverse();
    }

    /// For each instruction of `self.a`, the position of the last
    /// instruction that reads its result (before the slot is written
    /// again): `usize::MAX` for the output's last definition, `None` when
    /// nothing reads it. Into `self.last`.
    fn last_reads(&mut self, tape: &Tape) {
        let pending = &mut self.pending;
        pending.clear();
        pending.resize(tape.slots(), None);
        pending[tape.output()] = Some(usize::MAX);
        self.last.clear();
        self.last.resize(self.a.len(), None);
        for (j, ins) in self.a.iter().enumerate().rev() {
            if let Some(w) = writes(ins) {
                self.last[j] = pending[w as usize].take();
            }
            for r in reads(ins) {
                pending[r as usize].get_or_insert(j);
            }
        }
    }

    /// Unlinks slot `a` from the list of the slot it is aliased to.
    fn unlink(&mut self, a: u32) {
        let t = self.alias[a as usize];
        let (p, n) = (self.prev[a as usize], self.next[a as usize]);
        if p == NONE {
            self.head[t as usize] = n;
        } else {
            self.next[p as usize] = n;
        }
        if n != NONE {
            self.prev[n as usize] = p;
        }
        self.alias[a as usize] = a;
    }

    /// Forwards over `self.a` into `self.b`: copies (and exact folds to an
    /// operand) become aliases, so readers read the source slot; an alias
    /// is written out as a copy only when its source slot is about to be
    /// overwritten while the alias is still read, or at the end for the
    /// output.
    fn forward_copies(&mut self, tape: &Tape) {
        self.last_reads(tape);
        let n = tape.slots();
        self.alias.clear();
        self.alias.extend(0..n as u32);
        self.until.clear();
        self.until.resize(n, 0);
        for v in [&mut self.head, &mut self.next, &mut self.prev] {
            v.clear();
            v.resize(n, NONE);
        }
        self.value.clear();
        self.value.resize(n, None);
        for &(k, v) in tape.constants() {
            self.value[k as usize] = Some(v);
        }
        self.b.clear();
        for j in 0..self.a.len() {
            let ins = self.a[j];
            let Some(w) = writes(&ins) else {
                self.b.push(ins);
                continue;
            };
            let Some(reader) = self.last[j] else { continue };
            // A copy of the value w already holds (through an alias) leaves w as it is.
            if passes_on(&self.value, resolve(&self.alias, ins)) == Some(w) {
                if self.alias[w as usize] != w {
                    self.unlink(w);
                }
                continue;
            }
            // Slots whose value lives in w and that are still read keep it:
            // write them out first.
            let mut a = self.head[w as usize];
            while a != NONE {
                let after = self.next[a as usize];
                self.unlink(a);
                if self.until[a as usize] >= j {
                    self.b.push(copy(a, w));
                }
                a = after;
            }
            // w is redefined: it no longer aliases anything.
            if self.alias[w as usize] != w {
                self.unlink(w);
            }
            let ins = resolve(&self.alias, ins);
            match passes_on(&self.value, ins) {
                Some(t) => {
                    debug_assert!(t != w);
                    self.alias[w as usize] = t;
                    self.until[w as usize] = reader;
                    let h = self.head[t as usize];
                    self.next[w as usize] = h;
                    self.prev[w as usize] = NONE;
                    if h != NONE {
                        self.prev[h as usize] = w;
                    }
                    self.head[t as usize] = w;
                    self.value[w as usize] = self.value[t as usize];
                }
                None => {
                    self.value[w as usize] = None;
                    self.b.push(ins);
                }
            }
        }
        let o = tape.output();
        if self.alias[o] != o as u32 {
            self.b.push(copy(o as u32, self.alias[o]));
        }
    }

    /// Backwards over `self.b`: drops instructions whose result nothing
    /// live reads.
    fn drop_dead(&mut self, tape: &Tape) -> Vec<Instr> {
        let live = &mut self.live;
        live.clear();
        live.resize(tape.slots(), false);
        live[tape.output()] = true;
        let mut kept: Vec<Instr> = Vec::with_capacity(self.b.len());
        for ins in self.b.iter().rev() {
            let Some(out) = writes(ins) else { continue };
            if std::mem::take(&mut live[out as usize]) {
                for r in reads(ins) {
                    live[r as usize] = true;
                }
                kept.push(*ins);
            }
        }
        kept.reverse();
        kept
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interval::{eval_interval_choices, Interval};
    use crate::{compile, Library, PointEvaluator};

    /// On random boxes of CSG shapes (plain and smooth unions, selects),
    /// the simplified tape is shorter where a branch cannot win and equals
    /// the full tape at random points inside.
    #[test]
    fn simplified_tapes_agree_inside_their_box() {
        let shapes = [
            "union(sphere(p - vec3(1.0, 0.0, 0.0), 0.5), box(p + vec3(1.0, 0.0, 0.0), 0.4), torus(p - vec3(0.0, 1.5, 0.0), 0.6, 0.2))",
            "smooth_union(smooth_union(sphere(p - vec3(1.0, 0.0, 0.0), 0.5), box(p + vec3(1.0, 0.0, 0.0), 0.4), 0.3), torus(p - vec3(0.0, 1.5, 0.0), 0.6, 0.2), 0.2)",
            "min(sphere(p, 0.5) + 0.2 * step(0.3, p.x), max(box(p - vec3(0.0, 1.0, 0.0), 0.3), -sphere(p - vec3(0.0, 1.2, 0.0), 0.2)))",
        ];
        let mut seed = 3u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % 100_000) as f64 / 100_000.0
        };
        for src in shapes {
            let sh = compile(&Library::new(), src).unwrap();
            let tape = sh.tape();
            let mut full = PointEvaluator::<f64>::new(tape);
            let mut fullf = PointEvaluator::<f32>::new(tape);
            let mut shorter = 0;
            for _ in 0..300 {
                let c: [f64; 3] = std::array::from_fn(|_| rnd() * 4.0 - 2.0);
                let h = rnd() * 0.5;
                let b: [Interval; 3] = std::array::from_fn(|k| Interval::new(c[k] - h, c[k] + h));
                let mut choices = Vec::new();
                eval_interval_choices(tape, &[], b, Some(&mut choices));
                let Some(t) = simplify(tape, &choices) else { continue };
                if t.len() < tape.len() {
                    shorter += 1;
                }
                let mut e = PointEvaluator::<f64>::new(&t);
                let mut ef = PointEvaluator::<f32>::new(&t);
                for _ in 0..20 {
                    let p: [f64; 3] = std::array::from_fn(|k| c[k] + (rnd() * 2.0 - 1.0) * h);
                    assert_eq!(
                        e.eval(&[], p[0], p[1], p[2]).to_bits(),
                        full.eval(&[], p[0], p[1], p[2]).to_bits(),
                        "{src}: at {p:?} in the box around {c:?} ± {h}"
                    );
                    let q = p.map(|x| x as f32);
                    assert_eq!(
                        ef.eval(&[], q[0], q[1], q[2]).to_bits(),
                        fullf.eval(&[], q[0], q[1], q[2]).to_bits(),
                        "{src} (f32): at {p:?} in the box around {c:?} ± {h}"
                    );
                }
            }
            assert!(shorter > 75, "{src}: only {shorter} of 300 boxes simplified");
        }
    }

    /// Far from a smooth union's blend, its correction term folds away:
    /// the simplified tape of a box near one of two far-apart blended
    /// spheres is as short as that sphere alone (plus a copy at most).
    #[test]
    fn smooth_union_far_from_the_blend_is_one_operand() {
        let lib = Library::new();
        let both = compile(
            &lib,
            "smooth_union(sphere(p - vec3(3.0, 0.0, 0.0), 0.5), sphere(p + vec3(3.0, 0.0, 0.0), 0.5), 0.2)",
        )
        .unwrap();
        let one = compile(&lib, "sphere(p - vec3(3.0, 0.0, 0.0), 0.5)").unwrap();
        let b = [
            Interval::new(2.5, 3.5),
            Interval::new(-0.5, 0.5),
            Interval::new(-0.5, 0.5),
        ];
        let mut choices = Vec::new();
        eval_interval_choices(both.tape(), &[], b, Some(&mut choices));
        let t = simplify(both.tape(), &choices).unwrap();
        assert!(
            t.len() <= one.tape().len() + 1,
            "{} > {} + 1: {:?}",
            t.len(),
            one.tape().len(),
            t.instrs()
        );
    }
}
