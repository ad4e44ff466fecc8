//! Tape simplification over a region: the branches of `min` and `max` that
//! cannot win anywhere in a box are dropped, and so is every instruction
//! only they needed.
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
use crate::ir::{BinOp, Instr, Tape};

/// The tape specialised to the region `choices` were recorded over (one
/// per instruction, from [`crate::interval::eval_interval_choices`]), or
/// `None` when nothing can be dropped or the tape has lazy regions (whose
/// `Skip` lengths this pass does not rewrite).
pub fn simplify(tape: &Tape, choices: &[Choice]) -> Option<Tape> {
    let instrs = tape.instrs();
    if choices.len() != instrs.len()
        || !choices.iter().any(|c| *c != Choice::Both)
        || instrs.iter().any(|i| matches!(i, Instr::Skip { .. }))
    {
        return None;
    }
    let mut live = vec![false; tape.slots()];
    live[tape.output()] = true;
    let mut kept: Vec<Instr> = Vec::with_capacity(instrs.len());
    for (ins, &choice) in instrs.iter().zip(choices).rev() {
        match *ins {
            Instr::Unary { out, a, .. } => {
                if std::mem::take(&mut live[out as usize]) {
                    live[a as usize] = true;
                    kept.push(*ins);
                }
            }
            Instr::Binary { op, out, a, b } => {
                if !std::mem::take(&mut live[out as usize]) {
                    continue;
                }
                let only = match (op, choice) {
                    (BinOp::Min | BinOp::Max, Choice::Left) => Some(a),
                    (BinOp::Min | BinOp::Max, Choice::Right) => Some(b),
                    _ => None,
                };
                match only {
                    Some(x) => {
                        live[x as usize] = true;
                        kept.push(Instr::Binary {
                            op: BinOp::Max,
                            out,
                            a: x,
                            b: x,
                        });
                    }
                    None => {
                        live[a as usize] = true;
                        live[b as usize] = true;
                        kept.push(*ins);
                    }
                }
            }
            Instr::Select { out, c, a, b } => {
                if std::mem::take(&mut live[out as usize]) {
                    live[c as usize] = true;
                    live[a as usize] = true;
                    live[b as usize] = true;
                    kept.push(*ins);
                }
            }
            Instr::Skip { .. } => unreachable!("checked above"),
        }
    }
    kept.reverse();
    Some(tape.with_instrs(kept))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interval::{eval_interval_choices, Interval};
    use crate::{compile, Library, PointEvaluator};

    /// On random boxes of a CSG shape, the simplified tape is shorter where
    /// a branch cannot win and equals the full tape at random points inside.
    #[test]
    fn simplified_tapes_agree_inside_their_box() {
        let sh = compile(
            &Library::new(),
            "union(sphere(p - vec3(1.0, 0.0, 0.0), 0.5), box(p + vec3(1.0, 0.0, 0.0), 0.4), torus(p - vec3(0.0, 1.5, 0.0), 0.6, 0.2))",
        )
        .unwrap();
        let tape = sh.tape();
        let mut full = PointEvaluator::<f64>::new(tape);
        let mut seed = 3u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % 100_000) as f64 / 100_000.0
        };
        let mut shorter = 0;
        for _ in 0..200 {
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
            for _ in 0..20 {
                let p: [f64; 3] = std::array::from_fn(|k| c[k] + (rnd() * 2.0 - 1.0) * h);
                assert_eq!(
                    e.eval(&[], p[0], p[1], p[2]).to_bits(),
                    full.eval(&[], p[0], p[1], p[2]).to_bits(),
                    "at {p:?} in the box around {c:?} ± {h}"
                );
            }
        }
        assert!(shorter > 50, "only {shorter} of 200 boxes simplified");
    }
}
