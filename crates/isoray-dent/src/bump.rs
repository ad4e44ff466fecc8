//! Blinn's bump mapping as the thesis derives it (§2.3.2, after Vince;
//! `dents.md` §1.8 with its errata corrected): on a surface P(u, v) with
//! N = P_u × P_v, a height F(u, v) moves the normal to
//! N' = N + λ·[F_u (N × P_v) − F_v (N × P_u)] / ‖N‖, the tilt being
//! atan(‖F_v P_u − F_u P_v‖ / ‖N‖) for λ = 1.

use crate::impulse::V3;
use crate::vec::{cross, length as norm};

/// N' = N + λ·[F_u (N × P_v) − F_v (N × P_u)] / ‖N‖ (unnormalised), with
/// N = P_u × P_v.
pub fn perturbed_normal(pu: V3, pv: V3, fu: f64, fv: f64, lambda: f64) -> V3 {
    let n = cross(pu, pv);
    let l = norm(n);
    let a = cross(n, pv);
    let b = cross(n, pu);
    std::array::from_fn(|i| n[i] + lambda * (fu * a[i] - fv * b[i]) / l)
}

/// The angle, in degrees, between N = P_u × P_v and the perturbed normal.
pub fn tilt_degrees(pu: V3, pv: V3, fu: f64, fv: f64, lambda: f64) -> f64 {
    let n = cross(pu, pv);
    let p = perturbed_normal(pu, pv, fu, fv, lambda);
    let c = (n[0] * p[0] + n[1] * p[1] + n[2] * p[2]) / (norm(n) * norm(p));
    c.clamp(-1.0, 1.0).acos().to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// dents.md §2.5, KAT 11: the cylinder (cos u, v, −sin u) at u = v = 0
    /// with F = 200 and neighbours 205 (u) and 210 (v), corrected angles.
    #[test]
    fn the_blinn_cylinder_gives_the_corrected_values() {
        let (pu, pv) = ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0]);
        assert_eq!(cross(pu, pv), [1.0, 0.0, 0.0]);
        let (fu, fv) = (205.0 - 200.0, 210.0 - 200.0);
        for (lambda, want, len, angle) in [
            (1.0, [1.0, -10.0, 5.0], 11.224972, 84.889),
            (0.1, [1.0, -1.0, 0.5], 1.5, 48.190),
            (0.01, [1.0, -0.1, 0.05], 1.006231, 6.379),
        ] {
            let n = perturbed_normal(pu, pv, fu, fv, lambda);
            for i in 0..3 {
                assert!((n[i] - want[i]).abs() < 1e-12, "λ {lambda}: {n:?}");
            }
            assert!((norm(n) - len).abs() < 1e-6);
            assert!((tilt_degrees(pu, pv, fu, fv, lambda) - angle).abs() < 1e-3);
        }
        // The thesis's 9.01° is acos(1/1.0125), 1.0125 being ‖N'‖² of λ = 0.01.
        assert!((tilt_degrees(pu, pv, fu, fv, 0.01) - 9.01).abs() > 2.0);
    }
}
