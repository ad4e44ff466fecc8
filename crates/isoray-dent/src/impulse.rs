//! The impact model of the thesis (§2.2.1; `dents.md` §1.3): whether an
//! impact leaves a permanent dent, and how deep.
//!
//! The impulse is Guendelman, Bridson and Fedkiw's linear one, evaluated
//! as if the impact were perfectly elastic (ε = 1, a bracket of 2), from
//! the velocities before contact; the yield impulse of a body of
//! restitution ε is Y = 1/(1 − ε) − 1 = ε/(1 − ε) (infinite at ε = 1: a
//! perfectly elastic body never dents); the dent is the body's thickness
//! t times its compliance κ times the impulse beyond the yield:
//! t·κ·max(0, |j| − Y). The thesis equates a pressure with an impulse,
//! so κ is a tuning constant, per N·s.

/// A vector of three components.
pub type V3 = [f64; 3];

use crate::vec::dot;

/// The yield impulse Y = ε/(1 − ε) of restitution ε (clamped to [0, 1]):
/// 0 at ε = 0 (every impact dents), infinite at ε = 1 (none does).
pub fn yield_impulse(restitution: f64) -> f64 {
    let e = restitution.clamp(0.0, 1.0);
    if e >= 1.0 {
        f64::INFINITY
    } else {
        e / (1.0 - e)
    }
}

/// The impulse on body B of an impact along the unit normal `n` (from A
/// towards B), with the bracket 1 + ε: −n·(1 + ε)·(n·(v_B − v_A)) /
/// (1/m_A + 1/m_B). Inverse masses of 0 are fixed bodies. Zero when both
/// are fixed.
pub fn impulse(n: V3, v_a: V3, v_b: V3, inv_mass_a: f64, inv_mass_b: f64, restitution: f64) -> V3 {
    let inv = inv_mass_a + inv_mass_b;
    if inv <= 0.0 {
        return [0.0; 3];
    }
    let rel = [v_b[0] - v_a[0], v_b[1] - v_a[1], v_b[2] - v_a[2]];
    let s = -(1.0 + restitution) * dot(n, rel) / inv;
    [n[0] * s, n[1] * s, n[2] * s]
}

/// [`impulse`] with ε = 1: the thesis's j_{ε=1}, whatever the materials.
pub fn elastic_impulse(n: V3, v_a: V3, v_b: V3, inv_mass_a: f64, inv_mass_b: f64) -> V3 {
    impulse(n, v_a, v_b, inv_mass_a, inv_mass_b, 1.0)
}

/// Whether the bodies close along `n` (from A to B): n·(v_B − v_A) < 0.
/// Only approaching contacts dent; separating and resting ones do not.
pub fn approaching(n: V3, v_a: V3, v_b: V3) -> bool {
    dot(n, [v_b[0] - v_a[0], v_b[1] - v_a[1], v_b[2] - v_a[2]]) < 0.0
}

/// The permanent dent depth t·κ·max(0, |j| − Y(ε)) of a body of thickness
/// `t`, compliance `kappa` and restitution ε struck with an impulse of
/// magnitude `j`: 0 below the yield impulse and for ε = 1.
pub fn dent_depth(t: f64, kappa: f64, j: f64, restitution: f64) -> f64 {
    let over = j - yield_impulse(restitution);
    if over > 0.0 {
        t * kappa * over
    } else {
        0.0
    }
}

/// The slowest closing speed at which a body of mass m (inverse `inv_mass`)
/// striking a fixed one with restitution ε dents it: 2·v·m > Y, so
/// v = Y/(2m). Infinite at ε = 1.
pub fn threshold_speed(inv_mass: f64, restitution: f64) -> f64 {
    yield_impulse(restitution) * inv_mass / 2.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1.0)
    }

    /// dents.md §2.5, KAT 1.
    #[test]
    fn yield_impulses_are_the_theses_values() {
        for (e, y) in [(0.0, 0.0), (0.2, 0.25), (0.5, 1.0), (0.75, 3.0), (0.8, 4.0), (0.9, 9.0)] {
            assert!(close(yield_impulse(e), y, 1e-12), "Y({e}) = {}", yield_impulse(e));
            // The thesis's form 1/(1 − ε) − 1.
            assert!(close(1.0 / (1.0 - e) - 1.0, y, 1e-12));
        }
        assert_eq!(yield_impulse(1.0), f64::INFINITY);
        assert_eq!(dent_depth(1.0, 1.0, 1e300, 1.0), 0.0);
    }

    /// KAT 2.
    #[test]
    fn impulses_are_the_theses_values() {
        let n = [0.0, 1.0, 0.0];
        assert_eq!(
            elastic_impulse(n, [0.0; 3], [0.0, -2.0, 0.0], 0.0, 1.0),
            [0.0, 4.0, 0.0]
        );
        assert_eq!(
            impulse(n, [0.0; 3], [0.0, -2.0, 0.0], 0.0, 1.0, 0.5f64.min(0.8)),
            [0.0, 3.0, 0.0]
        );
        // Two free 1 kg bodies closing at 2 m/s.
        let j = elastic_impulse(n, [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], 1.0, 1.0);
        assert!(close(dot(j, j).sqrt(), 2.0, 1e-12));
        // Separating: the formula flips sign, and the guard says no dent.
        assert_eq!(
            elastic_impulse(n, [0.0; 3], [0.0, 2.0, 0.0], 0.0, 1.0),
            [0.0, -4.0, 0.0]
        );
        assert!(!approaching(n, [0.0; 3], [0.0, 2.0, 0.0]));
        assert!(approaching(n, [0.0; 3], [0.0, -2.0, 0.0]));
        assert!(!approaching(n, [0.0; 3], [1.0, 0.0, 0.0]), "sliding is not approaching");
    }

    /// KAT 3: a 1 kg ball on a fixed plane dents it above 0.5 m/s with ε = 0.5
    /// (a drop of 0.0127421 m at g = 9.81) and above 2 m/s with ε = 0.8.
    #[test]
    fn thresholds_are_the_theses_values() {
        let g = 9.81;
        for (e, v, h) in [(0.5, 0.5, 0.0127421), (0.8, 2.0, 0.203874)] {
            let t = threshold_speed(1.0, e);
            assert!(close(t, v, 1e-12));
            assert!(close(t * t / (2.0 * g), h, 1e-5));
            let j = |v: f64| {
                dot(
                    elastic_impulse([0.0, 1.0, 0.0], [0.0; 3], [0.0, -v, 0.0], 0.0, 1.0),
                    [0.0, 1.0, 0.0],
                )
            };
            assert_eq!(dent_depth(1.0, 1.0, j(v * 0.999), e), 0.0);
            assert!(dent_depth(1.0, 1.0, j(v * 1.001), e) > 0.0);
        }
    }

    /// KAT 4.
    #[test]
    fn dent_depths_are_the_theses_values() {
        assert!(close(dent_depth(0.1, 0.01, 4.0, 0.5), 0.003, 1e-12));
        assert_eq!(dent_depth(0.1, 0.01, 1.0, 0.5), 0.0);
    }
}
