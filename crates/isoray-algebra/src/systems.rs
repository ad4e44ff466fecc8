//! Standard benchmark systems: katsura-n and cyclic-n.

use crate::coeff::{Int, Rat};
use crate::monomial::{Monomial, MonomialOrder};
use crate::poly::{Poly, Ring};

fn var(n: usize, i: usize) -> Poly<Rat> {
    Poly::monomial(Monomial::var(n, i, 1), Rat::from_integer(Int::from(1)))
}

/// cyclic-n in x1..xn (grevlex): Σᵢ Πⱼ<k x_{i+j mod n} for k = 1..n−1, and x1⋯xn − 1.
pub fn cyclic(n: usize) -> (Ring, Vec<Poly<Rat>>) {
    let names: Vec<String> = (1..=n).map(|i| format!("x{i}")).collect();
    let ring = Ring::new(&names, MonomialOrder::DegRevLex);
    let mut out = Vec::new();
    for k in 1..n {
        let mut sum = Poly::zero();
        for i in 0..n {
            let mut prod = Poly::constant(&ring, Rat::from_integer(Int::from(1)));
            for j in 0..k {
                prod = prod.mul(&ring, &var(n, (i + j) % n));
            }
            sum = sum.add(&ring, &prod);
        }
        out.push(sum);
    }
    let mut prod = Poly::constant(&ring, Rat::from_integer(Int::from(1)));
    for i in 0..n {
        prod = prod.mul(&ring, &var(n, i));
    }
    out.push(prod.sub(&ring, &Poly::constant(&ring, Rat::from_integer(Int::from(1)))));
    (ring, out)
}

/// katsura-n in x0..xn (grevlex): with u_l = x_|l| for |l| ≤ n and 0 otherwise,
/// Σ_l u_l u_{m−l} − u_m for m = 0..n−1, and u_0 + 2 Σ_{l≥1} u_l − 1.
pub fn katsura(n: usize) -> (Ring, Vec<Poly<Rat>>) {
    let names: Vec<String> = (0..=n).map(|i| format!("x{i}")).collect();
    let nv = n + 1;
    let ring = Ring::new(&names, MonomialOrder::DegRevLex);
    let u = |l: i64| -> Option<Poly<Rat>> {
        let a = l.unsigned_abs() as usize;
        (a <= n).then(|| var(nv, a))
    };
    let mut out = Vec::new();
    for m in 0..n as i64 {
        let mut sum = Poly::zero();
        for l in -(n as i64)..=(n as i64) {
            if let (Some(a), Some(b)) = (u(l), u(m - l)) {
                sum = sum.add(&ring, &a.mul(&ring, &b));
            }
        }
        out.push(sum.sub(&ring, &u(m).expect("m <= n")));
    }
    let mut lin = var(nv, 0);
    for l in 1..=n {
        lin = lin.add(&ring, &var(nv, l).scale(&Rat::from_integer(Int::from(2))));
    }
    out.push(lin.sub(&ring, &Poly::constant(&ring, Rat::from_integer(Int::from(1)))));
    (ring, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_systems() {
        let (r, c) = cyclic(3);
        let t: Vec<String> = c.iter().map(|p| p.display(&r)).collect();
        assert_eq!(t, ["x1 + x2 + x3", "x1*x2 + x1*x3 + x2*x3", "x1*x2*x3 - 1"]);
        let (r, k) = katsura(2);
        let t: Vec<String> = k.iter().map(|p| p.display(&r)).collect();
        assert_eq!(
            t,
            [
                "x0^2 + 2*x1^2 + 2*x2^2 - x0",
                "2*x0*x1 + 2*x1*x2 - x1",
                "x0 + 2*x1 + 2*x2 - 1"
            ]
        );
    }
}
