//! The quadratic error function of dual contouring: the point that best
//! fits a set of tangent planes, solved by a truncated eigen-decomposition so
//! that flat and ridge-like sets of planes fall back towards their mass point
//! instead of shooting off along the unconstrained directions.

/// Accumulates planes n·(x − p) = 0 and solves for the best point.
#[derive(Debug, Clone, Default)]
pub(crate) struct Qef {
    /// AᵀA (symmetric; upper triangle xx, xy, xz, yy, yz, zz).
    ata: [f64; 6],
    /// Aᵀb.
    atb: [f64; 3],
    /// Sum of the points, and how many.
    mass: [f64; 3],
    count: usize,
}

impl Qef {
    /// Adds the plane through `p` with unit normal `n`.
    pub(crate) fn add(&mut self, p: [f64; 3], n: [f64; 3]) {
        let d = n[0] * p[0] + n[1] * p[1] + n[2] * p[2];
        self.ata[0] += n[0] * n[0];
        self.ata[1] += n[0] * n[1];
        self.ata[2] += n[0] * n[2];
        self.ata[3] += n[1] * n[1];
        self.ata[4] += n[1] * n[2];
        self.ata[5] += n[2] * n[2];
        for ((atb, mass), (nk, pk)) in self.atb.iter_mut().zip(&mut self.mass).zip(n.iter().zip(&p)) {
            *atb += nk * d;
            *mass += pk;
        }
        self.count += 1;
    }

    /// Adds a point to the mass point only (no plane: its normal is unknown).
    pub(crate) fn add_point(&mut self, p: [f64; 3]) {
        for (m, pk) in self.mass.iter_mut().zip(p) {
            *m += pk;
        }
        self.count += 1;
    }

    /// The mass point (average of the plane points).
    pub(crate) fn mass_point(&self) -> [f64; 3] {
        let c = self.count.max(1) as f64;
        self.mass.map(|m| m / c)
    }

    /// The minimiser of Σ (nᵢ·(x − pᵢ))² nearest the mass point, with
    /// eigenvalues below `truncation` × the largest treated as zero.
    pub(crate) fn solve(&self, truncation: f64) -> [f64; 3] {
        let c = self.mass_point();
        let a = [
            [self.ata[0], self.ata[1], self.ata[2]],
            [self.ata[1], self.ata[3], self.ata[4]],
            [self.ata[2], self.ata[4], self.ata[5]],
        ];
        // Right-hand side relative to the mass point: Aᵀb − AᵀA c.
        let mut r = [0.0; 3];
        for i in 0..3 {
            r[i] = self.atb[i] - (a[i][0] * c[0] + a[i][1] * c[1] + a[i][2] * c[2]);
        }
        let (vals, vecs) = symmetric_eigen(a);
        let max = vals.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
        let mut x = c;
        if max <= 0.0 {
            return x;
        }
        for k in 0..3 {
            if vals[k].abs() <= truncation * max {
                continue;
            }
            let v = [vecs[0][k], vecs[1][k], vecs[2][k]];
            let proj = (v[0] * r[0] + v[1] * r[1] + v[2] * r[2]) / vals[k];
            for i in 0..3 {
                x[i] += proj * v[i];
            }
        }
        x
    }
}

/// Eigenvalues and eigenvectors (as columns) of a symmetric 3×3 matrix by
/// cyclic Jacobi rotations.
pub(crate) fn symmetric_eigen(mut a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..32 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= 1e-30 * diag.max(1e-300) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q].abs() < 1e-300 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J with the rotation in the (p, q) plane.
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * rp[k] - s * rq[k];
                a[q][k] = s * rp[k] + c * rq[k];
            }
            for row in v.iter_mut() {
                let (vkp, vkq) = (row[p], row[q]);
                row[p] = c * vkp - s * vkq;
                row[q] = s * vkp + c * vkq;
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigen_decomposition_reconstructs_the_matrix() {
        let m = [[4.0, 1.0, -2.0], [1.0, 2.0, 0.5], [-2.0, 0.5, 3.0]];
        let (vals, v) = symmetric_eigen(m);
        for i in 0..3 {
            for j in 0..3 {
                let r: f64 = (0..3).map(|k| v[i][k] * vals[k] * v[j][k]).sum();
                assert!((r - m[i][j]).abs() < 1e-12, "{i} {j}: {r} vs {}", m[i][j]);
            }
        }
        // Trace is preserved.
        assert!((vals.iter().sum::<f64>() - 9.0).abs() < 1e-12);
    }

    #[test]
    fn three_planes_meet_at_the_corner() {
        let mut q = Qef::default();
        let corner = [0.3, -0.2, 0.7];
        q.add([0.3, 0.0, 0.5], [1.0, 0.0, 0.0]);
        q.add([0.1, -0.2, 0.6], [0.0, 1.0, 0.0]);
        q.add([0.0, 0.1, 0.7], [0.0, 0.0, 1.0]);
        let x = q.solve(0.01);
        for k in 0..3 {
            assert!((x[k] - corner[k]).abs() < 1e-12, "{x:?}");
        }
    }

    #[test]
    fn two_planes_give_the_edge_point_nearest_the_mass_point() {
        let mut q = Qef::default();
        // The edge x = 1, y = 2 along z; points around z = 0.5 on average.
        q.add([1.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
        q.add([0.0, 2.0, 1.0], [0.0, 1.0, 0.0]);
        let x = q.solve(0.01);
        assert!((x[0] - 1.0).abs() < 1e-12 && (x[1] - 2.0).abs() < 1e-12);
        assert!((x[2] - 0.5).abs() < 1e-12, "{x:?}");
    }

    #[test]
    fn one_plane_projects_the_mass_point() {
        let mut q = Qef::default();
        let n = [0.6, 0.8, 0.0];
        q.add([1.0, 0.0, 0.0], n);
        q.add([0.2, 0.6, 1.0], n);
        let x = q.solve(0.01);
        // On the plane 0.6x + 0.8y = 0.6.
        assert!((0.6 * x[0] + 0.8 * x[1] - 0.6).abs() < 1e-12);
        assert!((x[2] - 0.5).abs() < 1e-12);
    }
}
