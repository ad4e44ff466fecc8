//! Implicitization of rational surfaces by resultants (the thesis's second
//! method, §1.7), with base-point detection.
//!
//! For x = X₁/W₁, y = X₂/W₂, z = X₃/W₃ in the parameters (s, t) the
//! *auxiliary system* is Fᵢ = Xᵢ − xᵢ·Wᵢ (i = 1, 2, 3): three polynomials in
//! (s, t) whose coefficients are affine in x, y, z. A point (x, y, z) lies on
//! the (closure of the) surface exactly when the system has a common root, so
//! the resultant that eliminates s and t vanishes on the surface. Each
//! coordinate keeps its own denominator: bringing them to a common
//! denominator W = W₁W₂W₃ would add a base point wherever two different
//! denominators vanish together, and the resultant would vanish identically;
//! when the denominators agree the two systems are the same.
//!
//! The resultant used is Dixon's, in the formulation of Kapur, Saxena and
//! Yang: the Dixon polynomial
//!
//! ```text
//! δ(s, t, α, β) = det | F₁(s, t)  F₂(s, t)  F₃(s, t) |
//!                     | F₁(α, t)  F₂(α, t)  F₃(α, t) |  / ((s − α)(t − β))
//!                     | F₁(α, β)  F₂(α, β)  F₃(α, β) |
//! ```
//!
//! is written as (monomials in s, t)·D·(monomials in α, β), and the
//! determinant of a maximal nonsingular minor of the *Dixon matrix* D (a
//! matrix of polynomials in x, y, z) is a *projection operator*: a nonzero
//! multiple of the implicit equation. When the parametrization has base
//! points (also at infinity, as the stereographic sphere has at (1 : ±i : 0))
//! the projection operator carries *extraneous factors*, and it is a power of
//! the implicit equation when the parametrization is not proper.
//!
//! The implicit polynomial F is separated from them as follows. Everything
//! runs modulo primes below 2³¹, with the projection operators as black boxes
//! (numerical determinants of the chosen minors):
//!
//! 1. A projection operator is kept only if it vanishes at random points of
//!    the surface (else the minor chosen does not contain F).
//! 2. On a line ℓ of direction (1, a, b), each kept operator restricts to a
//!    univariate polynomial; the square-free part of their gcd is F on ℓ
//!    times the extraneous factors the operators share. The roots of
//!    extraneous factors known in advance are removed (`known_extraneous`:
//!    where the numerators and denominators of two coordinates vanish at a
//!    point b, every resultant has a factor W(b)·x − X(b) in the third). What
//!    remains has degree d.
//! 3. Certificate: if no nonzero polynomial of degree d − 1 vanishes at
//!    enough random points of the surface (a linear system of full column
//!    rank modulo p; a polynomial over Q vanishing on the surface would give
//!    a nonzero kernel vector), then deg F ≥ d, so the gcd is F on ℓ. Up to
//!    400 monomials this is checked on the surface itself; beyond, on its
//!    section by a random plane (monomials in x and y only; points from the
//!    roots in GF(p) of the plane's equation along parameter lines), which
//!    could wrongly pass only if the plane's linear form divided a lower-degree
//!    equation modulo p (probability below d/p²). If the certificate fails,
//!    another operator is added: the coordinates mixed by a random invertible
//!    matrix (over their common denominator), s and t exchanged, a random
//!    projective change of the parameter plane (which moves the line at
//!    infinity), and both changes at once. Past 1330 monomials of the plane
//!    section (d > 51) no certificate is computed and three operators are used.
//! 4. F is interpolated from its restrictions to a grid of (d + 1)² parallel
//!    lines, modulo enough primes for the Chinese remainder theorem and
//!    rational reconstruction, and verified exactly: F(x(s, t), y(s, t),
//!    z(s, t))·ΠWᵢ^eᵢ vanishes on a grid one larger than its bidegree.
//!
//! Base points: a parameter value where every numerator and denominator
//! vanishes is a common root of the auxiliary system for every (x, y, z), so
//! the auxiliary resultant is identically zero (thesis Def. 1.53, Thm 1.14).
//! Such affine base points are found by a Gröbner basis of the numerators and
//! denominators (after each coordinate's common factors are cancelled) and
//! reported as [`ImplicitError::BasePoints`]. Other base points (of the map
//! (s, t) ↦ (X : Y : Z : W) to projective space, at infinity among them) only
//! contribute extraneous factors, which steps 2 and 3 remove; when they
//! cannot (the certificate keeps failing), the base points of that map are
//! reported as [`ImplicitError::BasePoints`] too.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use isoray_job::{CancelToken, Progress};
use num_integer::Integer;
use num_traits::{One, ToPrimitive, Zero};
use rayon::prelude::*;

use crate::coeff::{to_zint, Int, Rat, ZInt};
use crate::f4::inv_mod;
use crate::groebner::{groebner, Algorithm, Budget, GroebnerOptions, Stats};
use crate::implicit::{coordinate_names, parse_parametrization, Implicit, ImplicitError};
use crate::modular::Reconstructor;
use crate::monomial::{Monomial, MonomialOrder};
use crate::parse::{to_primitive_integer, to_rational, RatFunc};
use crate::poly::{Poly, Ring};
use crate::resultant::homogenize;

/// Options of [`implicitize_resultant`].
#[derive(Clone, Default)]
pub struct ResultantOptions {
    /// Wall-clock limit ([`ImplicitError::TimeLimit`] when exceeded).
    pub time: Option<Duration>,
    /// Cancelled to stop ([`ImplicitError::Cancelled`]); checked between
    /// steps: per projection operator, per line of the grid, per block of
    /// the verification grid.
    pub interrupt: Option<CancelToken>,
    /// Told how far the computation got (none by default): a stage
    /// `resultant: dixon matrices` (operators built of those that may be
    /// tried), a stage `resultant: certificate` per degree certified, a stage
    /// `resultant: lines (prime K)` per prime (lines of the grid done), and a
    /// stage `resultant: verification` (points of the exact check done).
    pub progress: Option<Arc<dyn Progress + Send>>,
}

impl std::fmt::Debug for ResultantOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ResultantOptions")
            .field("time", &self.time)
            .field("interrupt", &self.interrupt)
            .field("progress", &self.progress.is_some())
            .finish()
    }
}

/// Budget, cancellation and progress.
struct Guard<'a> {
    start: Instant,
    opts: &'a ResultantOptions,
}

impl Guard<'_> {
    fn check(&self) -> Result<(), ImplicitError> {
        if self.opts.interrupt.as_ref().is_some_and(CancelToken::is_cancelled) {
            return Err(ImplicitError::Cancelled);
        }
        if let Some(t) = self.opts.time {
            if self.start.elapsed() > t {
                return Err(ImplicitError::TimeLimit { limit: t.as_secs_f64() });
            }
        }
        Ok(())
    }

    fn stage(&self, name: &str) {
        if let Some(p) = &self.opts.progress {
            p.stage(name);
        }
    }

    fn update(&self, done: usize, total: usize) {
        if let Some(p) = &self.opts.progress {
            p.update(done as u64, total as u64);
        }
    }

    /// Gröbner options with what is left of the budget.
    fn groebner_options(&self) -> GroebnerOptions {
        GroebnerOptions {
            algorithm: Algorithm::Buchberger,
            budget: Budget {
                time: self.opts.time.map(|t| t.saturating_sub(self.start.elapsed())),
                interrupt: self.opts.interrupt.clone(),
                ..Default::default()
            },
            ..Default::default()
        }
    }
}

// ---------------------------------------------------------------------------
// The Dixon matrix.

/// The Dixon matrix of three polynomials in two variables (s, t) with
/// polynomial coefficients: δ(s, t, α, β) = Σ s^rows[i] · entries[i][j] · α^cols[j].
#[derive(Debug, Clone, PartialEq)]
pub struct DixonMatrix {
    /// The row monomials: exponents of (s, t), increasing.
    pub rows: Vec<[u16; 2]>,
    /// The column monomials: exponents of (α, β), increasing.
    pub cols: Vec<[u16; 2]>,
    /// The entries, polynomials in the coefficient ring.
    pub entries: Vec<Vec<Poly<Rat>>>,
}

/// A row monomial (exponents of s, t) and a column monomial (of α, β).
type DixonCell = ([u16; 2], [u16; 2]);

/// (p(v) − p(w)) / (v − w) for p without w: each term c·v^k·m becomes
/// c·m·Σ_{j<k} v^j w^(k−1−j).
fn divided_difference(ring: &Ring, p: &Poly<Rat>, v: usize, w: usize) -> Poly<Rat> {
    let mut terms = Vec::new();
    for (m, c) in p.terms() {
        let k = m.exp(v);
        for j in 0..k {
            let mut e = m.exps().to_vec();
            e[v] = j;
            e[w] += k - 1 - j;
            terms.push((Monomial::new(&e), c.clone()));
        }
    }
    Poly::from_terms(ring, terms)
}

/// The Dixon matrix (Kapur–Saxena–Yang) of `polys`, three polynomials in a
/// ring whose first two variables are the ones eliminated (s, t) and whose
/// other variables are those of `coeff_ring`, in the same order.
///
/// The Dixon polynomial det[Fᵢ(s, t); Fᵢ(α, t); Fᵢ(α, β)] / ((s − α)(t − β))
/// is computed as det[(Fᵢ(s, t) − Fᵢ(α, t))/(s − α); (Fᵢ(α, t) − Fᵢ(α, β))/(t − β); Fᵢ(α, β)].
/// For the auxiliary system of thesis Ex. 1.3 (s + t − x, s − y, t − z) it is
/// the 1 × 1 matrix [−x + y + z].
pub fn dixon_matrix(ring: &Ring, polys: &[Poly<Rat>; 3], coeff_ring: &Ring) -> DixonMatrix {
    dixon_matrix_checked(ring, polys, coeff_ring, &|| Ok(())).expect("no check fails")
}

/// [`dixon_matrix`], calling `check` between the products (so that a
/// large Dixon polynomial can be cancelled or stopped by a time limit).
fn dixon_matrix_checked(
    ring: &Ring,
    polys: &[Poly<Rat>; 3],
    coeff_ring: &Ring,
    check: &dyn Fn() -> Result<(), ImplicitError>,
) -> Result<DixonMatrix, ImplicitError> {
    let k = coeff_ring.nvars();
    debug_assert_eq!(ring.nvars(), k + 2);
    let mut names: Vec<String> = vec!["s".into(), "t".into(), "α".into(), "β".into()];
    names.extend(coeff_ring.vars().iter().cloned());
    let work = Ring::new(&names, MonomialOrder::DegRevLex);
    let coeff_map: Vec<usize> = (0..k).map(|i| 4 + i).collect();
    let map = |s: usize, t: usize| {
        let mut m = vec![s, t];
        m.extend(&coeff_map);
        m
    };
    let (st, at, ab) = (map(0, 1), map(2, 1), map(2, 3));
    let rows: [Vec<Poly<Rat>>; 3] = [
        polys
            .iter()
            .map(|f| divided_difference(&work, &f.embed(&work, &st), 0, 2))
            .collect(),
        polys
            .iter()
            .map(|f| divided_difference(&work, &f.embed(&work, &at), 1, 3))
            .collect(),
        polys.iter().map(|f| f.embed(&work, &ab)).collect(),
    ];
    let m = |i: usize, j: usize| &rows[i][j];
    let minor = |a: usize, b: usize| -> Result<Poly<Rat>, ImplicitError> {
        check()?;
        Ok(m(1, a).mul(&work, m(2, b)).sub(&work, &m(1, b).mul(&work, m(2, a))))
    };
    let (m12, m02, m01) = (minor(1, 2)?, minor(0, 2)?, minor(0, 1)?);
    check()?;
    let delta = m(0, 0)
        .mul(&work, &m12)
        .sub(&work, &m(0, 1).mul(&work, &m02))
        .add(&work, &m(0, 2).mul(&work, &m01));
    check()?;
    let mut cells: BTreeMap<DixonCell, Vec<(Monomial, Rat)>> = BTreeMap::new();
    for (mono, c) in delta.terms() {
        let e = mono.exps();
        cells
            .entry(([e[0], e[1]], [e[2], e[3]]))
            .or_default()
            .push((Monomial::new(&e[4..]), c.clone()));
    }
    let mut row_keys: Vec<[u16; 2]> = cells.keys().map(|k| k.0).collect();
    row_keys.sort();
    row_keys.dedup();
    let mut col_keys: Vec<[u16; 2]> = cells.keys().map(|k| k.1).collect();
    col_keys.sort();
    col_keys.dedup();
    let mut entries = vec![vec![Poly::zero(); col_keys.len()]; row_keys.len()];
    for ((r, c), terms) in cells {
        let i = row_keys.binary_search(&r).expect("a row key");
        let j = col_keys.binary_search(&c).expect("a column key");
        entries[i][j] = Poly::from_terms(coeff_ring, terms);
    }
    Ok(DixonMatrix {
        rows: row_keys,
        cols: col_keys,
        entries,
    })
}

/// The auxiliary system Fᵢ = Xᵢ − xᵢ·Wᵢ in the ring (s, t, x, y, z).
fn auxiliary_system(funcs: &[RatFunc]) -> (Ring, [Poly<Rat>; 3]) {
    let ring = Ring::new(&["s", "t", "x", "y", "z"], MonomialOrder::DegRevLex);
    let one = Rat::one();
    let f = |i: usize| {
        let xi = Poly::monomial(Monomial::var(5, 2 + i, 1), one.clone());
        funcs[i]
            .num
            .embed(&ring, &[0, 1])
            .sub(&ring, &funcs[i].den.embed(&ring, &[0, 1]).mul(&ring, &xi))
    };
    let polys = [f(0), f(1), f(2)];
    (ring, polys)
}

// ---------------------------------------------------------------------------
// Arithmetic modulo a prime p < 2^31 (products of two residues fit in 64 bits).

fn powm(mut b: u64, mut e: u64, p: u64) -> u64 {
    let mut r = 1 % p;
    b %= p;
    while e > 0 {
        if e & 1 == 1 {
            r = r * b % p;
        }
        b = b * b % p;
        e >>= 1;
    }
    r
}

/// c modulo p, None when p divides its denominator.
fn rat_mod(c: &Rat, p: u64) -> Option<u64> {
    crate::coeff::Fp::from_rat(c, p).map(|v| v.value())
}

/// A deterministic xorshift generator.
struct Rng(u64);

impl Rng {
    fn below(&mut self, m: u64) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0 % m
    }

    /// `n` distinct residues mod p.
    fn distinct(&mut self, n: usize, p: u64) -> Vec<u64> {
        let mut out: Vec<u64> = Vec::with_capacity(n);
        while out.len() < n {
            let v = self.below(p);
            if !out.contains(&v) {
                out.push(v);
            }
        }
        out
    }
}

/// The determinant of an n × n matrix mod p (row-major), by elimination.
fn det_mod(a: &mut [u64], n: usize, p: u64) -> u64 {
    let mut det = 1u64;
    for c in 0..n {
        let Some(r) = (c..n).find(|&r| a[r * n + c] != 0) else {
            return 0;
        };
        if r != c {
            for k in 0..n {
                a.swap(r * n + k, c * n + k);
            }
            det = (p - det) % p;
        }
        let piv = a[c * n + c];
        det = det * piv % p;
        let inv = inv_mod(piv, p);
        for r in c + 1..n {
            let f = a[r * n + c] * inv % p;
            if f != 0 {
                for k in c + 1..n {
                    a[r * n + k] = (a[r * n + k] + p - f * a[c * n + k] % p) % p;
                }
            }
        }
    }
    det
}

/// The pivot columns of a row echelon form of a rows × cols matrix mod p.
fn pivot_columns(mut a: Vec<u64>, rows: usize, cols: usize, p: u64) -> Vec<usize> {
    let mut pivots = Vec::new();
    let mut row = 0;
    for c in 0..cols {
        if row == rows {
            break;
        }
        let Some(r) = (row..rows).find(|&r| a[r * cols + c] != 0) else {
            continue;
        };
        if r != row {
            for k in 0..cols {
                a.swap(r * cols + k, row * cols + k);
            }
        }
        let inv = inv_mod(a[row * cols + c], p);
        let (top, rest) = a.split_at_mut((row + 1) * cols);
        let prow = &top[row * cols..];
        rest.par_chunks_mut(cols).for_each(|other| {
            let f = other[c] * inv % p;
            if f != 0 {
                for k in c..cols {
                    other[k] = (other[k] + p - f * prow[k] % p) % p;
                }
            }
        });
        pivots.push(c);
        row += 1;
    }
    pivots
}

/// Univariate polynomials mod p: coefficients, lowest first, no trailing zeros.
type UPoly = Vec<u64>;

fn trim(mut a: UPoly) -> UPoly {
    while a.last() == Some(&0) {
        a.pop();
    }
    a
}

fn monic(a: UPoly, p: u64) -> UPoly {
    let a = trim(a);
    match a.last() {
        None => a,
        Some(&lc) => {
            let inv = inv_mod(lc, p);
            a.into_iter().map(|c| c * inv % p).collect()
        }
    }
}

/// a mod b (b nonzero, trimmed).
fn urem(a: &[u64], b: &[u64], p: u64) -> UPoly {
    let mut r = trim(a.to_vec());
    let db = b.len() - 1;
    let inv = inv_mod(b[db], p);
    while r.len() > db {
        let dr = r.len() - 1;
        let f = r[dr] * inv % p;
        for (k, &bk) in b.iter().enumerate() {
            let i = dr - db + k;
            r[i] = (r[i] + p - f * bk % p) % p;
        }
        r = trim(r);
    }
    r
}

/// The exact quotient a / b (b nonzero, trimmed).
fn udiv(a: &[u64], b: &[u64], p: u64) -> UPoly {
    let mut r = trim(a.to_vec());
    let db = b.len() - 1;
    if r.len() <= db {
        return Vec::new();
    }
    let inv = inv_mod(b[db], p);
    let mut q = vec![0u64; r.len() - db];
    while r.len() > db {
        let dr = r.len() - 1;
        let f = r[dr] * inv % p;
        q[dr - db] = f;
        for (k, &bk) in b.iter().enumerate() {
            let i = dr - db + k;
            r[i] = (r[i] + p - f * bk % p) % p;
        }
        r.pop();
        while r.len() > db && r.last() == Some(&0) {
            r.pop();
        }
    }
    trim(q)
}

/// The monic gcd (empty for gcd(0, 0)).
fn ugcd(a: &[u64], b: &[u64], p: u64) -> UPoly {
    let (mut a, mut b) = (trim(a.to_vec()), trim(b.to_vec()));
    while !b.is_empty() {
        let r = urem(&a, &b, p);
        a = b;
        b = r;
    }
    monic(a, p)
}

fn deriv(a: &[u64], p: u64) -> UPoly {
    trim(
        a.iter()
            .enumerate()
            .skip(1)
            .map(|(k, &c)| (k as u64 % p) * c % p)
            .collect(),
    )
}

/// The monic square-free part (p larger than the degree).
fn squarefree_part(a: &[u64], p: u64) -> UPoly {
    let a = monic(a.to_vec(), p);
    let g = ugcd(&a, &deriv(&a, p), p);
    if g.len() <= 1 {
        a
    } else {
        monic(udiv(&a, &g, p), p)
    }
}

fn umul(a: &[u64], b: &[u64], p: u64) -> UPoly {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let mut out = vec![0u64; a.len() + b.len() - 1];
    for (i, &x) in a.iter().enumerate() {
        if x != 0 {
            for (j, &y) in b.iter().enumerate() {
                out[i + j] = (out[i + j] + x * y % p) % p;
            }
        }
    }
    trim(out)
}

/// (t + shift)^e mod m (m monic of degree ≥ 1).
fn power_mod(shift: u64, mut e: u64, m: &[u64], p: u64) -> UPoly {
    let mut base = urem(&[shift % p, 1], m, p);
    let mut acc = urem(&[1], m, p);
    while e > 0 {
        if e & 1 == 1 {
            acc = urem(&umul(&acc, &base, p), m, p);
        }
        base = urem(&umul(&base, &base, p), m, p);
        e >>= 1;
    }
    acc
}

/// The roots in GF(p) of g (p odd), by gcd with t^p − t and Cantor–Zassenhaus splitting.
fn roots_mod(g: &[u64], p: u64, rng: &mut Rng) -> Vec<u64> {
    let g = monic(g.to_vec(), p);
    if g.len() <= 1 {
        return Vec::new();
    }
    let mut tp = power_mod(0, p, &g, p);
    tp.resize(tp.len().max(2), 0);
    tp[1] = (tp[1] + p - 1) % p;
    let r = ugcd(&g, &trim(tp), p);
    let mut out = Vec::new();
    let mut stack = vec![r];
    while let Some(r) = stack.pop() {
        match r.len() {
            0 | 1 => {}
            2 => out.push((p - r[0]) % p),
            _ => loop {
                let mut w = power_mod(rng.below(p), (p - 1) / 2, &r, p);
                if w.is_empty() {
                    continue;
                }
                w[0] = (w[0] + p - 1) % p;
                let g1 = ugcd(&r, &trim(w), p);
                if g1.len() > 1 && g1.len() < r.len() {
                    stack.push(udiv(&r, &g1, p));
                    stack.push(g1);
                    break;
                }
            },
        }
    }
    out
}

/// Interpolation at fixed distinct points, by Newton's divided differences.
struct Interpolator {
    xs: Vec<u64>,
    /// inv[j][i] = 1 / (xs[i] − xs[i − j]) for i ≥ j ≥ 1.
    inv: Vec<Vec<u64>>,
    p: u64,
}

impl Interpolator {
    fn new(xs: Vec<u64>, p: u64) -> Self {
        let n = xs.len();
        let mut inv = vec![Vec::new(); n];
        for (j, row) in inv.iter_mut().enumerate().skip(1) {
            *row = (0..n)
                .map(|i| {
                    if i >= j {
                        inv_mod((xs[i] + p - xs[i - j]) % p, p)
                    } else {
                        0
                    }
                })
                .collect();
        }
        Interpolator { xs, inv, p }
    }

    /// The polynomial of degree < n through (xs[i], ys[i]), coefficients lowest first (untrimmed).
    fn apply(&self, ys: &[u64]) -> UPoly {
        let (n, p) = (self.xs.len(), self.p);
        let mut c = ys.to_vec();
        for j in 1..n {
            for i in (j..n).rev() {
                c[i] = (c[i] + p - c[i - 1]) % p * self.inv[j][i] % p;
            }
        }
        let mut poly = vec![0u64; n];
        poly[0] = c[n - 1];
        for i in (0..n - 1).rev() {
            let r = self.xs[i];
            let deg = n - 2 - i; // degree of poly before multiplying by (x − r)
            for k in (1..=deg + 1).rev() {
                poly[k] = (poly[k - 1] + p - poly[k] * r % p) % p;
            }
            poly[0] = (p - poly[0] * r % p) % p;
            poly[0] = (poly[0] + c[i]) % p;
        }
        poly
    }
}

// ---------------------------------------------------------------------------
// The parametrization modulo p.

/// A polynomial in (s, t) mod p.
type Poly2Mod = Vec<(usize, usize, u64)>;

fn poly2_mod(f: &Poly<Rat>, p: u64) -> Option<Poly2Mod> {
    f.terms()
        .iter()
        .map(|(m, c)| Some((m.exp(0) as usize, m.exp(1) as usize, rat_mod(c, p)?)))
        .collect()
}

fn eval2(f: &Poly2Mod, s: u64, t: u64, p: u64) -> u64 {
    f.iter().fold(0, |acc, &(i, j, c)| {
        (acc + c * powm(s, i as u64, p) % p * powm(t, j as u64, p)) % p
    })
}

/// The coordinates, and their partial derivatives' numerators, mod p.
struct ParamMod {
    p: u64,
    num: Vec<Poly2Mod>,
    den: Vec<Poly2Mod>,
    /// ∂/∂s and ∂/∂t of num and den.
    dnum: Vec<[Poly2Mod; 2]>,
    dden: Vec<[Poly2Mod; 2]>,
}

impl ParamMod {
    fn new(funcs: &[RatFunc], p: u64) -> Option<ParamMod> {
        let ring = Ring::new(&["s", "t"], MonomialOrder::DegRevLex);
        let mut pm = ParamMod {
            p,
            num: Vec::new(),
            den: Vec::new(),
            dnum: Vec::new(),
            dden: Vec::new(),
        };
        for f in funcs {
            pm.num.push(poly2_mod(&f.num, p)?);
            pm.den.push(poly2_mod(&f.den, p)?);
            let d = |g: &Poly<Rat>, v| poly2_mod(&g.derivative(&ring, v), p);
            pm.dnum.push([d(&f.num, 0)?, d(&f.num, 1)?]);
            pm.dden.push([d(&f.den, 0)?, d(&f.den, 1)?]);
        }
        Some(pm)
    }

    /// φ(s, t), unless a denominator vanishes there.
    fn at(&self, s: u64, t: u64) -> Option<[u64; 3]> {
        let p = self.p;
        let mut out = [0u64; 3];
        for (i, o) in out.iter_mut().enumerate() {
            let w = eval2(&self.den[i], s, t, p);
            if w == 0 {
                return None;
            }
            *o = eval2(&self.num[i], s, t, p) * inv_mod(w, p) % p;
        }
        Some(out)
    }

    /// A random point of the surface.
    fn random_point(&self, rng: &mut Rng) -> [u64; 3] {
        loop {
            let (s, t) = (rng.below(self.p), rng.below(self.p));
            if let Some(pt) = self.at(s, t) {
                return pt;
            }
        }
    }

    /// Whether the Jacobian matrix of φ has rank 2 at a random point.
    fn jacobian_rank_two(&self, rng: &mut Rng) -> bool {
        let p = self.p;
        for _ in 0..3 {
            let (s, t) = (rng.below(p), rng.below(p));
            let mut rows = Vec::new();
            for i in 0..3 {
                let (n, w) = (eval2(&self.num[i], s, t, p), eval2(&self.den[i], s, t, p));
                if w == 0 {
                    break;
                }
                // (n'w − nw') (the common factor 1/w² does not change the rank).
                let d = |v: usize| {
                    let a = eval2(&self.dnum[i][v], s, t, p) * w % p;
                    let b = n * eval2(&self.dden[i][v], s, t, p) % p;
                    (a + p - b) % p
                };
                rows.push([d(0), d(1)]);
            }
            if rows.len() < 3 {
                continue;
            }
            for (a, b) in [(0, 1), (0, 2), (1, 2)] {
                if (rows[a][0] * rows[b][1] % p + p - rows[a][1] * rows[b][0] % p) % p != 0 {
                    return true;
                }
            }
        }
        false
    }
}

// ---------------------------------------------------------------------------
// Projection operators: maximal nonsingular minors of Dixon matrices.

/// A square minor of a Dixon matrix, entries in Q[x, y, z].
struct Minor {
    entries: Vec<Vec<Poly<Rat>>>,
    /// A bound on the total degree of its determinant.
    degree: usize,
    /// The coordinates the entries are written in are `transform`·(x, y, z).
    transform: [[i64; 3]; 3],
}

/// A minor modulo p, evaluated numerically.
struct ModMinor {
    n: usize,
    transform: [[u64; 3]; 3],
    entries: Vec<Vec<([usize; 3], u64)>>,
    max_exp: [usize; 3],
    degree: usize,
    p: u64,
}

impl ModMinor {
    fn new(m: &Minor, p: u64) -> Option<ModMinor> {
        let n = m.entries.len();
        let cols = m.entries.first().map_or(0, Vec::len);
        let mut entries = Vec::with_capacity(n * cols);
        let mut max_exp = [0usize; 3];
        for row in &m.entries {
            for e in row {
                let mut terms = Vec::with_capacity(e.len());
                for (mono, c) in e.terms() {
                    let ex = [mono.exp(0) as usize, mono.exp(1) as usize, mono.exp(2) as usize];
                    for v in 0..3 {
                        max_exp[v] = max_exp[v].max(ex[v]);
                    }
                    terms.push((ex, rat_mod(c, p)?));
                }
                entries.push(terms);
            }
        }
        let mut transform = [[0u64; 3]; 3];
        for (i, row) in m.transform.iter().enumerate() {
            for (j, &v) in row.iter().enumerate() {
                transform[i][j] = v.rem_euclid(p as i64) as u64;
            }
        }
        Some(ModMinor {
            n,
            transform,
            entries,
            max_exp,
            degree: m.degree,
            p,
        })
    }

    /// The determinant at (x, y, z) (at transform·(x, y, z) in the entries' coordinates).
    fn det_at(&self, pt: [u64; 3]) -> u64 {
        let p = self.p;
        let a = &self.transform;
        let pt: [u64; 3] =
            std::array::from_fn(|i| (a[i][0] * pt[0] % p + a[i][1] * pt[1] % p + a[i][2] * pt[2] % p) % p);
        let mut a = self.values_at(pt);
        det_mod(&mut a, self.n, p)
    }

    /// The entries at (x, y, z) in the entries' own coordinates, row-major.
    fn values_at(&self, pt: [u64; 3]) -> Vec<u64> {
        let p = self.p;
        let pows: Vec<Vec<u64>> = (0..3)
            .map(|v| {
                let mut w = vec![1u64; self.max_exp[v] + 1];
                for e in 1..w.len() {
                    w[e] = w[e - 1] * pt[v] % p;
                }
                w
            })
            .collect();
        self.entries
            .iter()
            .map(|terms| {
                terms.iter().fold(0u64, |acc, (e, c)| {
                    (acc + c * pows[0][e[0]] % p * pows[1][e[1]] % p * pows[2][e[2]]) % p
                })
            })
            .collect()
    }
}

/// Chooses a maximal nonsingular minor of the Dixon matrix: the pivot rows
/// and columns of its value at a random point mod p. `None` when the matrix
/// is zero there (or a coefficient's denominator vanishes mod p).
fn select_minor(dm: &DixonMatrix, transform: [[i64; 3]; 3], p: u64, rng: &mut Rng) -> Option<Minor> {
    let (r, c) = (dm.rows.len(), dm.cols.len());
    if r == 0 || c == 0 {
        return None;
    }
    let full = Minor {
        entries: dm.entries.clone(),
        degree: 0,
        transform: IDENTITY,
    };
    let m = ModMinor::new(&full, p)?;
    let pt = [rng.below(p), rng.below(p), rng.below(p)];
    let vals = m.values_at(pt);
    let cols = pivot_columns(vals.clone(), r, c, p);
    if cols.is_empty() {
        return None;
    }
    let mut transposed = vec![0u64; r * c];
    for i in 0..r {
        for j in 0..c {
            transposed[j * r + i] = vals[i * c + j];
        }
    }
    let rows = pivot_columns(transposed, c, r, p);
    let entries: Vec<Vec<Poly<Rat>>> = rows
        .iter()
        .map(|&i| cols.iter().map(|&j| dm.entries[i][j].clone()).collect())
        .collect();
    let deg = |e: &Poly<Rat>| e.degree().max(0) as usize;
    let by_rows: usize = entries.iter().map(|row| row.iter().map(deg).max().unwrap_or(0)).sum();
    let by_cols: usize = (0..cols.len())
        .map(|j| entries.iter().map(|row| deg(&row[j])).max().unwrap_or(0))
        .sum();
    Some(Minor {
        entries,
        degree: by_rows.min(by_cols),
        transform,
    })
}

/// A random invertible 3 × 3 integer matrix with entries in −r..=r.
fn random_matrix(rng: &mut Rng, r: u64) -> [[i64; 3]; 3] {
    loop {
        let mut m = [[0i64; 3]; 3];
        for row in m.iter_mut() {
            for v in row.iter_mut() {
                *v = rng.below(2 * r + 1) as i64 - r as i64;
            }
        }
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        if det != 0 {
            return m;
        }
    }
}

const IDENTITY: [[i64; 3]; 3] = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];

/// The parametrization composed with a projective transformation of the
/// parameter plane, (s, t) ↦ (L₁/L₃, L₂/L₃) for the rows of `l`.
fn reparametrize(funcs: &[RatFunc], l: &[[i64; 3]; 3]) -> Vec<RatFunc> {
    let p2 = Ring::new(&["s", "t"], MonomialOrder::DegRevLex);
    let h = Ring::new(&["s", "t", "u"], MonomialOrder::DegRevLex);
    let lin = |r: &[i64; 3]| {
        Poly::from_terms(
            &h,
            vec![
                (Monomial::new(&[1, 0, 0]), Rat::from_integer(Int::from(r[0]))),
                (Monomial::new(&[0, 1, 0]), Rat::from_integer(Int::from(r[1]))),
                (Monomial::new(&[0, 0, 0]), Rat::from_integer(Int::from(r[2]))),
            ],
        )
    };
    let values = [Some(lin(&l[0])), Some(lin(&l[1])), Some(lin(&l[2]))];
    let back = |g: Poly<Rat>| {
        Poly::from_terms(
            &p2,
            g.terms()
                .iter()
                .map(|(m, c)| (Monomial::new(&m.exps()[..2]), c.clone()))
                .collect(),
        )
    };
    funcs
        .iter()
        .map(|f| {
            let n = f.num.degree().max(f.den.degree()).max(0) as u32;
            let tr = |g: &Poly<Rat>| {
                let gh = homogenize(&h, &g.embed(&h, &[0, 1]), &[0, 1], 2, Some(n));
                back(gh.substitute(&h, &values))
            };
            RatFunc {
                num: tr(&f.num),
                den: tr(&f.den),
            }
        })
        .collect()
}

/// The lcm W of the denominators and the cofactors W/Wᵢ.
fn common_denominator(funcs: &[RatFunc], guard: &Guard) -> Result<(Poly<Rat>, Vec<Poly<Rat>>), ImplicitError> {
    let ring = Ring::new(&["s", "t"], MonomialOrder::DegRevLex);
    let opts = guard.groebner_options();
    let mut w = Poly::constant(&ring, Rat::one());
    for f in funcs {
        let g = crate::gcd::gcd(&ring, &w, &f.den, &opts)?;
        let q = crate::gcd::exact_div(&ring, &f.den, &g).expect("the gcd divides");
        w = w.mul(&ring, &q);
    }
    let cofactors = funcs
        .iter()
        .map(|f| crate::gcd::exact_div(&ring, &w, &f.den).expect("the lcm is a multiple"))
        .collect();
    Ok((w, cofactors))
}

/// The coordinates A·(x, y, z) over the common denominator.
fn mix_coordinates(funcs: &[RatFunc], a: &[[i64; 3]; 3], guard: &Guard) -> Result<Vec<RatFunc>, ImplicitError> {
    let ring = Ring::new(&["s", "t"], MonomialOrder::DegRevLex);
    let (w, cof) = common_denominator(funcs, guard)?;
    let nums: Vec<Poly<Rat>> = funcs.iter().zip(&cof).map(|(f, c)| f.num.mul(&ring, c)).collect();
    Ok(a.iter()
        .map(|row| {
            let mut num = Poly::zero();
            for (j, &c) in row.iter().enumerate() {
                num = num.add(&ring, &nums[j].scale(&Rat::from_integer(Int::from(c))));
            }
            RatFunc { num, den: w.clone() }
        })
        .collect())
}

/// The variants of the auxiliary system tried in turn: the parametrization
/// itself; its coordinates mixed by a random invertible matrix A (then the
/// operator's zero set is A times the surface's, and its extraneous factors
/// move differently); s and t exchanged; a random projective change of the
/// parameter plane, alone and with mixed coordinates. Returns the
/// parametrization and A.
fn variant(funcs: &[RatFunc], k: usize, guard: &Guard) -> Result<(Vec<RatFunc>, [[i64; 3]; 3]), ImplicitError> {
    let p2 = Ring::new(&["s", "t"], MonomialOrder::DegRevLex);
    let mut rng = Rng(0x517C_C1B7_2722_0A95 ^ (k as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    Ok(match k {
        0 => (funcs.to_vec(), IDENTITY),
        1 | 2 => {
            let a = random_matrix(&mut rng, 3);
            (mix_coordinates(funcs, &a, guard)?, a)
        }
        3 => (
            funcs
                .iter()
                .map(|f| RatFunc {
                    num: f.num.embed(&p2, &[1, 0]),
                    den: f.den.embed(&p2, &[1, 0]),
                })
                .collect(),
            IDENTITY,
        ),
        4 => (reparametrize(funcs, &random_matrix(&mut rng, 4)), IDENTITY),
        _ => {
            let a = random_matrix(&mut rng, 3);
            let l = random_matrix(&mut rng, 4);
            (mix_coordinates(&reparametrize(funcs, &l), &a, guard)?, a)
        }
    })
}

/// The work of a Dixon polynomial, estimated: the product of the term counts
/// of the three polynomials, times the degrees that the divided differences
/// spread them over.
fn dixon_work(polys: &[Poly<Rat>; 3]) -> usize {
    polys
        .iter()
        .map(|f| f.len() * (1 + f.degree_in(0).max(0) as usize).max(1 + f.degree_in(1).max(0) as usize))
        .product()
}

/// [`dixon_work`] of the auxiliary system of a parametrization of a surface.
pub(crate) fn dixon_work_of(funcs: &[RatFunc]) -> usize {
    dixon_work(&auxiliary_system(funcs).1)
}

/// Variants beyond the first whose Dixon polynomial would cost more are skipped.
const MAX_DIXON_WORK: usize = 4_000_000;

/// The first Dixon polynomial is not computed past this work (minutes).
const MAX_FIRST_DIXON_WORK: usize = 400_000_000;

/// How many parametrization variants may be tried.
const VARIANTS: usize = 6;
/// The largest number of monomials in x, y, z for which the degree
/// certificate is computed on the surface (exact); beyond, it is computed on
/// a plane section, in x and y.
const EXACT_CERTIFICATE_COLUMNS: usize = 400;
/// The largest number of monomials in x, y for the plane-section certificate.
const PLANE_CERTIFICATE_COLUMNS: usize = 1330;

/// Whether the degree certificate for degree d (no equation of degree d − 1) is computed.
fn certifiable(d: usize) -> bool {
    d <= 1 || d * (d + 1) / 2 <= PLANE_CERTIFICATE_COLUMNS
}

/// Exponent vectors of the monomials in x, y, z of total degree ≤ d.
fn monomials3(d: usize) -> Vec<[usize; 3]> {
    let mut out = Vec::new();
    for i in 0..=d {
        for j in 0..=d - i {
            for k in 0..=d - i - j {
                out.push([i, j, k]);
            }
        }
    }
    out
}

fn binomial_count(d: usize) -> usize {
    (d + 1) * (d + 2) * (d + 3) / 6
}

/// True when no nonzero polynomial of degree ≤ e vanishes at random points
/// of the surface mod p (then none vanishes on it over Q).
fn no_equation_of_degree(pm: &ParamMod, e: usize, rng: &mut Rng) -> bool {
    let p = pm.p;
    let mons = monomials3(e);
    let n = mons.len();
    let k = n + 4;
    let mut a = Vec::with_capacity(k * n);
    for _ in 0..k {
        let pt = pm.random_point(rng);
        let pows: Vec<Vec<u64>> = pt
            .iter()
            .map(|&v| {
                let mut w = vec![1u64; e + 1];
                for i in 1..=e {
                    w[i] = w[i - 1] * v % p;
                }
                w
            })
            .collect();
        a.extend(
            mons.iter()
                .map(|m| pows[0][m[0]] * pows[1][m[1]] % p * pows[2][m[2]] % p),
        );
    }
    pivot_columns(a, k, n, p).len() == n
}

/// True when no nonzero polynomial of degree ≤ e vanishes on the plane
/// section of the surface by a random plane z = h₀ + h₁x + h₂y (mod p): then
/// none of degree ≤ e vanishes on the surface either, unless the plane's
/// linear form divides that polynomial modulo p (probability below e/p²).
/// The section's points are found as the roots in GF(p) of the plane's
/// equation on random lines s = s₀ of the parameter plane.
fn no_equation_on_plane_section(pm: &ParamMod, e: usize, rng: &mut Rng) -> bool {
    let p = pm.p;
    let n = (e + 1) * (e + 2) / 2;
    let k = n + 4;
    let h = [rng.below(p), rng.below(p), rng.below(p)];
    let tdeg: usize = (0..3)
        .map(|i| {
            let d = |f: &Poly2Mod| f.iter().map(|&(_, j, _)| j).max().unwrap_or(0);
            d(&pm.num[i]).max(d(&pm.den[i]))
        })
        .sum();
    let it = Interpolator::new((0..=tdeg as u64).collect(), p);
    let mut points: Vec<[u64; 2]> = Vec::with_capacity(k);
    let mut attempts = 0;
    while points.len() < k {
        attempts += 1;
        if attempts > 50 * k + 100 {
            return false;
        }
        let s0 = rng.below(p);
        // g(t) = N_z W_x W_y − h₀ W_x W_y W_z − h₁ N_x W_y W_z − h₂ N_y W_x W_z at s = s₀.
        let vals: Vec<u64> = it
            .xs
            .iter()
            .map(|&t| {
                let nv: Vec<u64> = (0..3).map(|i| eval2(&pm.num[i], s0, t, p)).collect();
                let wv: Vec<u64> = (0..3).map(|i| eval2(&pm.den[i], s0, t, p)).collect();
                let all = wv[0] * wv[1] % p * wv[2] % p;
                let a = nv[2] * wv[0] % p * wv[1] % p;
                let b = h[0] * all % p;
                let c = h[1] * nv[0] % p * wv[1] % p * wv[2] % p;
                let d = h[2] * nv[1] % p * wv[0] % p * wv[2] % p;
                (a + 3 * p - b - c - d) % p
            })
            .collect();
        let g = trim(it.apply(&vals));
        for t0 in roots_mod(&g, p, rng) {
            if let Some(pt) = pm.at(s0, t0) {
                if !points.iter().any(|q| q[0] == pt[0] && q[1] == pt[1]) {
                    points.push([pt[0], pt[1]]);
                }
            }
        }
    }
    let mut a = Vec::with_capacity(k * n);
    for pt in points.iter().take(k) {
        for i in 0..=e {
            let xi = powm(pt[0], i as u64, p);
            for j in 0..=e - i {
                a.push(xi * powm(pt[1], j as u64, p) % p);
            }
        }
    }
    pivot_columns(a, k, n, p).len() == n
}

/// The projection operators modulo p, with the known extraneous factors.
struct Operators {
    minors: Vec<ModMinor>,
    interps: Vec<Interpolator>,
    /// Univariate polynomials in x, y, z (coefficients lowest first) known to
    /// divide extraneous factors (see [`known_extraneous`]).
    known: [UPoly; 3],
    p: u64,
}

impl Operators {
    fn new(minors: &[Minor], known: &[Option<Poly<Rat>>; 3], p: u64) -> Option<Operators> {
        let minors: Vec<ModMinor> = minors.iter().map(|m| ModMinor::new(m, p)).collect::<Option<_>>()?;
        let interps = minors
            .iter()
            .map(|m| Interpolator::new((0..=m.degree as u64).collect(), p))
            .collect();
        let mut k: [UPoly; 3] = Default::default();
        for (v, e) in known.iter().enumerate() {
            if let Some(e) = e {
                let mut c = vec![0u64; e.degree().max(0) as usize + 1];
                for (m, r) in e.terms() {
                    c[m.degree() as usize] = rat_mod(r, p)?;
                }
                k[v] = trim(c);
            }
        }
        Some(Operators {
            minors,
            interps,
            known: k,
            p,
        })
    }

    /// On the line (ξ, y0 + aξ, z0 + bξ): the square-free part of the gcd of
    /// the operators, without the roots of the known extraneous factors,
    /// monic; `None` when an operator vanishes on the line.
    fn line(&self, dir: [u64; 2], y0: u64, z0: u64) -> Option<UPoly> {
        let p = self.p;
        let mut g: Option<UPoly> = None;
        for (m, it) in self.minors.iter().zip(&self.interps) {
            let ys: Vec<u64> = it
                .xs
                .iter()
                .map(|&xi| m.det_at([xi, (y0 + dir[0] * xi) % p, (z0 + dir[1] * xi) % p]))
                .collect();
            let q = trim(it.apply(&ys));
            if q.is_empty() {
                return None;
            }
            g = Some(match g {
                None => q,
                Some(g) => ugcd(&g, &q, p),
            });
        }
        let mut g = squarefree_part(&g?, p);
        // The known factors restricted to the line: e(c + kξ) by Horner.
        for (e, c, k) in [
            (&self.known[0], 0, 1),
            (&self.known[1], y0, dir[0]),
            (&self.known[2], z0, dir[1]),
        ] {
            if e.len() <= 1 {
                continue;
            }
            let mut r: UPoly = Vec::new();
            for &coef in e.iter().rev() {
                r = umul(&r, &[c % p, k % p], p);
                if r.is_empty() {
                    r = vec![coef];
                } else {
                    r[0] = (r[0] + coef) % p;
                }
                r = trim(r);
            }
            let common = ugcd(&g, &r, p);
            if common.len() > 1 {
                g = monic(udiv(&g, &common, p), p);
            }
        }
        Some(g)
    }

    /// The degree of [`Operators::line`] on random lines of direction `dir` (the median of three).
    fn line_degree(&self, dir: [u64; 2], rng: &mut Rng) -> usize {
        let p = self.p;
        let mut ds: Vec<usize> = (0..3)
            .map(|_| {
                self.line(dir, rng.below(p), rng.below(p))
                    .map_or(0, |g| g.len().saturating_sub(1))
            })
            .collect();
        ds.sort();
        ds[1]
    }
}

/// Extraneous factors known in advance: where the numerators and
/// denominators of two coordinates (say y and z) vanish together at a point
/// b, the auxiliary system has the common root b whenever x = x(b), so every
/// resultant has the factor W₁(b)·x − X₁(b). Returns, per coordinate, the
/// univariate polynomial with those roots (the generator of
/// ⟨X₂, W₂, X₃, W₃, W₁x − X₁⟩ ∩ Q[x]), or `None`. A constant coordinate
/// gets none (its plane is the surface).
fn known_extraneous(funcs: &[RatFunc], guard: &Guard) -> Result<[Option<Poly<Rat>>; 3], ImplicitError> {
    let ring = Ring::new(&["s", "t", "v"], MonomialOrder::Lex);
    let opts = guard.groebner_options();
    let mut out: [Option<Poly<Rat>>; 3] = Default::default();
    for (i, slot) in out.iter_mut().enumerate() {
        let f = &funcs[i];
        if f.num.is_constant() && f.den.is_constant() {
            continue;
        }
        let lift = |p: &Poly<Rat>| p.embed(&ring, &[0, 1]);
        let mut gens: Vec<Poly<Rat>> = (0..3)
            .filter(|&j| j != i)
            .flat_map(|j| [lift(&funcs[j].num), lift(&funcs[j].den)])
            .filter(|g| !g.is_zero())
            .collect();
        if gens.iter().any(|g| g.is_constant()) {
            continue;
        }
        let v = Poly::monomial(Monomial::var(3, 2, 1), Rat::one());
        gens.push(lift(&f.den).mul(&ring, &v).sub(&ring, &lift(&f.num)));
        let basis = groebner(&ring, &gens, &opts)?.basis;
        if let Some(e) = basis
            .iter()
            .find(|g| !g.uses_var(0) && !g.uses_var(1) && !g.is_constant())
        {
            *slot = Some(e.clone());
        }
    }
    Ok(out)
}

/// What the first prime decided.
struct Plan {
    minors: Vec<Minor>,
    known: [Option<Poly<Rat>>; 3],
    degree: usize,
    direction: [u64; 2],
}

/// The error for extraneous factors that could not be removed: the base
/// points of the map to projective space behind them, if there are any.
fn separation_failure(funcs: &[RatFunc], params: &[&str], guard: &Guard, why: String) -> ImplicitError {
    match map_base_points(funcs, params, guard) {
        Ok(Some(points)) => ImplicitError::BasePoints { points },
        Ok(None) => ImplicitError::Resultant(why),
        Err(e) => e,
    }
}

fn make_plan(funcs: &[RatFunc], params: &[&str], p: u64, rng: &mut Rng, guard: &Guard) -> Result<Plan, ImplicitError> {
    let pm = ParamMod::new(funcs, p).ok_or_else(|| ImplicitError::Resultant("unlucky prime".into()))?;
    if !pm.jacobian_rank_two(rng) {
        return Err(ImplicitError::Resultant(
            "the parametrization does not describe a surface (its Jacobian matrix has rank below 2), so there is no implicit equation".into(),
        ));
    }
    let known = known_extraneous(funcs, guard)?;
    let coeff_ring = Ring::new(&["x", "y", "z"], MonomialOrder::DegRevLex);
    let mut active: Vec<Minor> = Vec::new();
    let mut degree: Option<usize> = None;
    let mut certified = false;
    let mut tried_containing = 0;
    for k in 0..VARIANTS {
        guard.check()?;
        guard.stage("resultant: dixon matrices");
        guard.update(k, VARIANTS);
        let (vf, transform) = variant(funcs, k, guard)?;
        let (ring, polys) = auxiliary_system(&vf);
        let work = dixon_work(&polys);
        if k == 0 && work > MAX_FIRST_DIXON_WORK {
            return Err(ImplicitError::Resultant(format!(
                "the Dixon polynomial is too large (estimated work {work}, limit {MAX_FIRST_DIXON_WORK}); try --method interpolation or groebner"
            )));
        }
        if k > 0 && work > MAX_DIXON_WORK {
            guard.update(k + 1, VARIANTS);
            continue;
        }
        let dm = dixon_matrix_checked(&ring, &polys, &coeff_ring, &|| guard.check())?;
        guard.update(k + 1, VARIANTS);
        let Some(minor) = select_minor(&dm, transform, p, rng) else {
            continue;
        };
        let Some(mm) = ModMinor::new(&minor, p) else { continue };
        // Keep only operators that vanish on the surface.
        if (0..3).any(|_| mm.det_at(pm.random_point(rng)) != 0) {
            continue;
        }
        tried_containing += 1;
        active.push(minor);
        let Some(ops) = Operators::new(&active, &known, p) else {
            active.pop();
            continue;
        };
        let dir = [rng.below(p), rng.below(p)];
        let d = ops.line_degree(dir, rng);
        if d == 0 || degree.is_some_and(|old| d >= old) {
            // No better than without it.
            active.pop();
            continue;
        }
        degree = Some(d);
        if certifiable(d) {
            guard.stage("resultant: certificate");
            guard.update(0, 1);
            certified = d == 1
                || if binomial_count(d - 1) <= EXACT_CERTIFICATE_COLUMNS {
                    no_equation_of_degree(&pm, d - 1, rng)
                } else {
                    no_equation_on_plane_section(&pm, d - 1, rng)
                };
            guard.update(1, 1);
            if certified {
                break;
            }
        } else if active.len() >= 3 {
            break;
        }
    }
    let Some(degree) = degree else {
        let why = if tried_containing == 0 {
            "no maximal minor of the Dixon matrix vanishes on the surface (the Kapur–Saxena–Yang condition fails); try --method groebner".into()
        } else {
            "the projection operators give no equation; try --method groebner".into()
        };
        return Err(separation_failure(funcs, params, guard, why));
    };
    if !certified && certifiable(degree) {
        let why = format!(
            "could not separate the implicit equation from the extraneous factors of the resultant (their common part has degree {degree}); try --method groebner"
        );
        return Err(separation_failure(funcs, params, guard, why));
    }
    // A small direction along which the equation keeps its degree.
    let ops = Operators::new(&active, &known, p).ok_or_else(|| ImplicitError::Resultant("unlucky prime".into()))?;
    let mut pairs: Vec<[u64; 2]> = (1..=8u64).flat_map(|a| (1..=8u64).map(move |b| [a, b])).collect();
    pairs.sort_by_key(|d| (d[0] + d[1], d[0]));
    let direction = pairs
        .into_iter()
        .find(|&dir| ops.line_degree(dir, rng) == degree)
        .ok_or_else(|| ImplicitError::Resultant("no direction of full degree found".into()))?;
    Ok(Plan {
        minors: active,
        known,
        degree,
        direction,
    })
}

/// F mod p, densely: `out[(i·(d+1) + j)·(d+1) + k]` is the coefficient of
/// x^i y^j z^k, normalized so that F(x, y + ax, z + bx) is monic in x.
/// `None` for an unlucky prime.
fn modular_image(
    plan: &Plan,
    p: u64,
    rng: &mut Rng,
    guard: &Guard,
    label: usize,
) -> Result<Option<Vec<u64>>, ImplicitError> {
    let Some(ops) = Operators::new(&plan.minors, &plan.known, p) else {
        return Ok(None);
    };
    let d = plan.degree;
    let n = d + 1;
    let dir = [plan.direction[0] % p, plan.direction[1] % p];
    let ys = rng.distinct(n, p);
    let zs = rng.distinct(n, p);
    // vals[i][j] = the line through (0, ys[i], zs[j]).
    let mut vals: Vec<Vec<UPoly>> = Vec::with_capacity(n);
    guard.stage(&format!("resultant: lines (prime {label})"));
    guard.update(0, n * n);
    for (i, &y0) in ys.iter().enumerate() {
        guard.check()?;
        let row: Vec<Option<UPoly>> = zs.par_iter().map(|&z0| ops.line(dir, y0, z0)).collect();
        let mut out = Vec::with_capacity(n);
        for g in row {
            match g {
                Some(g) if g.len() == d + 1 => out.push(g),
                _ => return Ok(None),
            }
        }
        vals.push(out);
        guard.update((i + 1) * n, n * n);
    }
    // Interpolate each coefficient c_k(y, z), k < d, over the grid.
    let iy = Interpolator::new(ys, p);
    let iz = Interpolator::new(zs, p);
    let idx = |i: usize, j: usize, k: usize| (i * n + j) * n + k;
    // hat[k][u][v]: coefficient of x^k y^u z^v in F(x, y + ax, z + bx) / lc.
    let mut hat = vec![0u64; n * n * n];
    hat[idx(d, 0, 0)] = 1;
    for k in 0..d {
        let in_z: Vec<UPoly> = (0..n)
            .map(|i| iz.apply(&(0..n).map(|j| vals[i][j][k]).collect::<Vec<_>>()))
            .collect();
        for v in 0..n {
            let in_y = iy.apply(&(0..n).map(|i| in_z[i][v]).collect::<Vec<_>>());
            for (u, &c) in in_y.iter().enumerate() {
                if c != 0 {
                    if k + u + v > d {
                        return Ok(None);
                    }
                    hat[idx(k, u, v)] = c;
                }
            }
        }
    }
    // Undo the shear: F(x, y, z) = hat(x, y − ax, z − bx).
    let mut binom = vec![vec![0u64; n]; n];
    for a in 0..n {
        binom[a][0] = 1;
        for b in 1..=a {
            binom[a][b] = (binom[a - 1][b - 1] + if b < a { binom[a - 1][b] } else { 0 }) % p;
        }
    }
    let pw = |base: u64| {
        let mut w = vec![1u64; n];
        for e in 1..n {
            w[e] = w[e - 1] * base % p;
        }
        w
    };
    let (na, nb) = (pw((p - dir[0]) % p), pw((p - dir[1]) % p));
    let mut out = vec![0u64; n * n * n];
    for k in 0..n {
        for u in 0..n - k {
            for v in 0..n - k - u {
                let c = hat[idx(k, u, v)];
                if c == 0 {
                    continue;
                }
                for i in 0..=u {
                    let cu = c * binom[u][i] % p * na[u - i] % p;
                    for j in 0..=v {
                        let cv = cu * binom[v][j] % p * nb[v - j] % p;
                        let e = idx(k + (u - i) + (v - j), i, j);
                        out[e] = (out[e] + cv) % p;
                    }
                }
            }
        }
    }
    Ok(Some(out))
}

/// Exact check that F vanishes on the parametrization: G = F(φ)·Π W_g^e_g
/// (one factor per distinct denominator) is a polynomial in (s, t) of
/// degree ≤ D_s, D_t; it is zero iff it vanishes on a (D_s + 1) × (D_t + 1)
/// grid of integers.
fn vanishes_on(f: &Poly<Int>, funcs: &[RatFunc], guard: &Guard) -> Result<bool, ImplicitError> {
    // Distinct denominators and the coordinates sharing each.
    let mut groups: Vec<(usize, Vec<usize>)> = Vec::new();
    for (i, g) in funcs.iter().enumerate() {
        match groups.iter_mut().find(|(r, _)| funcs[*r].den == g.den) {
            Some((_, members)) => members.push(i),
            None => groups.push((i, vec![i])),
        }
    }
    let exps: Vec<u64> = groups
        .iter()
        .map(|(_, members)| {
            f.terms()
                .iter()
                .map(|(m, _)| members.iter().map(|&i| m.exp(i) as u64).sum::<u64>())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let bound = |v: usize| -> u64 {
        groups
            .iter()
            .zip(&exps)
            .map(|((r, members), &e)| {
                let w = funcs[*r].den.degree_in(v).max(0) as u64;
                let nmax = members
                    .iter()
                    .map(|&i| funcs[i].num.degree_in(v).max(0) as u64)
                    .max()
                    .unwrap_or(0);
                e * nmax.max(w)
            })
            .sum()
    };
    let (ds, dt) = (bound(0), bound(1));
    let total = (ds + 1) * (dt + 1);
    if total > 4_000_000 {
        return Err(ImplicitError::Resultant(format!(
            "the exact check would need {total} grid points; try --method interpolation"
        )));
    }
    // Integer numerators and denominators: each coordinate scaled by the lcm of its coefficients' denominators.
    type Terms = Vec<(usize, usize, ZInt)>;
    let scale = |g: &RatFunc| {
        let mut l = Int::one();
        for (_, c) in g.num.terms().iter().chain(g.den.terms()) {
            l = l.lcm(c.denom());
        }
        let conv = |q: &Poly<Rat>| -> Terms {
            q.terms()
                .iter()
                .map(|(m, c)| {
                    let v = (c * Rat::from_integer(l.clone())).to_integer();
                    (m.exp(0) as usize, m.exp(1) as usize, to_zint(&v))
                })
                .collect()
        };
        (conv(&g.num), conv(&g.den))
    };
    let scaled: Vec<(Terms, Terms)> = funcs.iter().map(scale).collect();
    let fz: Vec<([usize; 3], ZInt)> = f
        .terms()
        .iter()
        .map(|(m, c)| ([m.exp(0) as usize, m.exp(1) as usize, m.exp(2) as usize], to_zint(c)))
        .collect();
    let eval = |q: &Terms, s: &ZInt, t: &ZInt| -> ZInt {
        q.iter()
            .fold(ZInt::ZERO, |acc, (i, j, c)| acc + c * s.pow(*i) * t.pow(*j))
    };
    let powers = |v: ZInt, e: usize| {
        let mut w = vec![ZInt::ONE; e + 1];
        for k in 1..=e {
            w[k] = &w[k - 1] * &v;
        }
        w
    };
    let group_of: Vec<usize> = (0..funcs.len())
        .map(|i| groups.iter().position(|(_, m)| m.contains(&i)).expect("grouped"))
        .collect();
    let offset_s = ZInt::from((ds / 2) as i64);
    let offset_t = ZInt::from((dt / 2) as i64);
    let vanishes = |flat: u64| {
        let s = ZInt::from((flat % (ds + 1)) as i64) - &offset_s;
        let t = ZInt::from((flat / (ds + 1)) as i64) - &offset_t;
        let dmax = exps.iter().copied().max().unwrap_or(0) as usize;
        let nums: Vec<Vec<ZInt>> = scaled.iter().map(|(n, _)| powers(eval(n, &s, &t), dmax)).collect();
        let dens: Vec<Vec<ZInt>> = groups
            .iter()
            .map(|(r, _)| powers(eval(&scaled[*r].1, &s, &t), dmax))
            .collect();
        let mut acc = ZInt::ZERO;
        for (e, c) in &fz {
            let mut term = c.clone();
            let mut used = vec![0usize; groups.len()];
            for i in 0..3 {
                term *= &nums[i][e[i]];
                used[group_of[i]] += e[i];
            }
            for (g, &u) in used.iter().enumerate() {
                term *= &dens[g][exps[g] as usize - u];
            }
            acc += term;
        }
        acc == ZInt::ZERO
    };
    guard.stage("resultant: verification");
    guard.update(0, total as usize);
    const BLOCK: u64 = 1024;
    let mut lo = 0;
    while lo < total {
        guard.check()?;
        let hi = (lo + BLOCK).min(total);
        if !(lo..hi).into_par_iter().all(vanishes) {
            return Ok(false);
        }
        lo = hi;
        guard.update(lo as usize, total as usize);
    }
    Ok(true)
}

/// Cancels the common factor of each coordinate's numerator and denominator.
fn reduce_fractions(funcs: Vec<RatFunc>, params: &[&str], guard: &Guard) -> Result<Vec<RatFunc>, ImplicitError> {
    let ring = Ring::new(params, MonomialOrder::DegRevLex);
    let mut out = Vec::with_capacity(funcs.len());
    for f in funcs {
        if f.num.is_constant() || f.den.is_constant() {
            out.push(f);
            continue;
        }
        let g = crate::gcd::gcd(&ring, &f.num, &f.den, &guard.groebner_options())?;
        if g.is_constant() {
            out.push(f);
            continue;
        }
        let num = crate::gcd::exact_div(&ring, &f.num, &g).expect("the gcd divides the numerator");
        let den = crate::gcd::exact_div(&ring, &f.den, &g).expect("the gcd divides the denominator");
        out.push(RatFunc { num, den });
    }
    Ok(out)
}

/// The affine base points of a parametrization: the common zeros of every
/// numerator and denominator (in the parameters `params`), described as
/// text, or `None` when there are none. There the auxiliary system
/// Xᵢ − xᵢWᵢ has a common root for every (x, y, z), so its resultant is
/// identically zero. Each coordinate should be in lowest terms (a common
/// factor of one coordinate's numerator and denominator is a whole curve of
/// such zeros).
pub fn affine_base_points(funcs: &[RatFunc], params: &[&str]) -> Result<Option<String>, ImplicitError> {
    let gens: Vec<Poly<Rat>> = funcs.iter().flat_map(|f| [f.num.clone(), f.den.clone()]).collect();
    common_zeros(
        &gens,
        params,
        &GroebnerOptions {
            algorithm: Algorithm::Buchberger,
            ..Default::default()
        },
    )
}

/// The base points of the map (s, t) ↦ (X : Y : Z : W) to projective space,
/// W the lcm of the denominators and Xᵢ = xᵢ·W: the common zeros of X, Y, Z
/// and W. They include the points of [`affine_base_points`], and also points
/// where only some coordinates' numerators and denominators vanish (where
/// two different denominators vanish together, too).
fn map_base_points(funcs: &[RatFunc], params: &[&str], guard: &Guard) -> Result<Option<String>, ImplicitError> {
    let ring = Ring::new(params, MonomialOrder::DegRevLex);
    let (w, cofactors) = common_denominator(funcs, guard)?;
    let mut gens = vec![w];
    gens.extend(funcs.iter().zip(&cofactors).map(|(f, c)| f.num.mul(&ring, c)));
    common_zeros(&gens, params, &guard.groebner_options())
}

/// The common zeros of `gens`, described, or `None` when there are none.
fn common_zeros(gens: &[Poly<Rat>], params: &[&str], opts: &GroebnerOptions) -> Result<Option<String>, ImplicitError> {
    let np = params.len();
    let ring = Ring::new(params, MonomialOrder::Lex);
    let gens: Vec<Poly<Rat>> = gens.iter().map(|p| p.reorder(&ring)).filter(|p| !p.is_zero()).collect();
    if gens.is_empty() || gens.iter().any(|p| p.is_constant()) {
        return Ok(None);
    }
    let basis = groebner(&ring, &gens, opts)?.basis;
    if basis.iter().any(|p| p.is_constant()) {
        return Ok(None);
    }
    // A single rational point: a basis {x_i − c_i}.
    let mut point: Vec<Option<Rat>> = vec![None; np];
    for g in &basis {
        if let [(m, c1), rest @ ..] = g.terms() {
            if m.degree() == 1 && rest.len() <= 1 && rest.iter().all(|(m, _)| m.is_one()) {
                let v = (0..np).find(|&v| m.exp(v) == 1).expect("a variable");
                let c0 = rest.first().map_or_else(Rat::zero, |(_, c)| c.clone());
                point[v] = Some(-c0 / c1.clone());
            }
        }
    }
    if basis.len() == np && point.iter().all(Option::is_some) {
        let values: Vec<String> = point.iter().map(|c| c.as_ref().expect("checked").to_string()).collect();
        return Ok(Some(format!("({}) = ({})", params.join(", "), values.join(", "))));
    }
    let eqs: Vec<String> = basis.iter().map(|g| format!("{} = 0", g.display(&ring))).collect();
    let text = eqs.join(", ");
    if text.chars().count() <= 240 {
        return Ok(Some(format!("the common zeros of {text}")));
    }
    let first: String = eqs[0].chars().take(100).collect();
    Ok(Some(format!(
        "the common zeros of {} equations, the first {first}…",
        eqs.len()
    )))
}

/// Implicitizes a rational parametrization by resultants: surfaces (three
/// coordinates in two parameters) by the Dixon resultant as the module
/// documentation describes, plane curves (two coordinates in one parameter)
/// by the Sylvester resultant ([`crate::resultant::resultant`]) of the
/// coordinates in lowest terms, made square-free.
///
/// The result is normalized as [`crate::implicit::implicitize_groebner`]
/// normalizes its generator: a primitive integer polynomial in (x, y[, z])
/// with a positive leading coefficient in grevlex, so the two methods'
/// answers compare with `==`. Errors: those of parsing, base points
/// ([`ImplicitError::BasePoints`]), a parametrization whose image is not a
/// surface or whose extraneous factors could not be separated
/// ([`ImplicitError::Resultant`]), the time limit and cancellation.
pub fn implicitize_resultant(
    coords: &[&str],
    params: &[&str],
    opts: &ResultantOptions,
) -> Result<Implicit, ImplicitError> {
    let guard = Guard {
        start: Instant::now(),
        opts,
    };
    let funcs = parse_parametrization(coords, params)?;
    let funcs = reduce_fractions(funcs, params, &guard)?;
    let gens: Vec<Poly<Rat>> = funcs.iter().flat_map(|f| [f.num.clone(), f.den.clone()]).collect();
    if let Some(points) = common_zeros(&gens, params, &guard.groebner_options())? {
        return Err(ImplicitError::BasePoints { points });
    }
    let names = coordinate_names(coords.len());
    let out_ring = Ring::new(names, MonomialOrder::DegRevLex);
    let poly = if coords.len() == 2 {
        curve(&funcs, &out_ring, &guard)?
    } else {
        surface(&funcs, params, &out_ring, &guard)?
    };
    Ok(Implicit {
        ring: out_ring,
        poly,
        stats: Stats {
            time: guard.start.elapsed(),
            ..Default::default()
        },
    })
}

/// Plane curves: Res_t(W₁x − X₁, W₂y − X₂), square-free.
fn curve(funcs: &[RatFunc], out_ring: &Ring, guard: &Guard) -> Result<Poly<Int>, ImplicitError> {
    let ring = Ring::new(&["t", "x", "y"], MonomialOrder::DegRevLex);
    let one = Rat::one();
    let f = |i: usize| {
        let v = Poly::monomial(Monomial::var(3, 1 + i, 1), one.clone());
        funcs[i]
            .den
            .embed(&ring, &[0])
            .mul(&ring, &v)
            .sub(&ring, &funcs[i].num.embed(&ring, &[0]))
    };
    let r = crate::resultant::resultant(&ring, &f(0), &f(1), 0);
    guard.check()?;
    let projected = Poly::from_terms(
        out_ring,
        r.terms()
            .iter()
            .map(|(m, c)| (Monomial::new(&m.exps()[1..]), c.clone()))
            .collect(),
    );
    if projected.is_zero() {
        return Err(ImplicitError::BasePoints {
            points: "a common zero of the numerators and denominators".into(),
        });
    }
    if projected.is_constant() {
        return Err(ImplicitError::Resultant(
            "the parametrization does not describe a curve (it is constant)".into(),
        ));
    }
    let p = to_rational(&to_primitive_integer(out_ring, &projected));
    let sf = crate::gcd::squarefree(out_ring, &p, &guard.groebner_options())?;
    Ok(to_primitive_integer(out_ring, &sf))
}

/// Surfaces: see the module documentation.
fn surface(funcs: &[RatFunc], params: &[&str], out_ring: &Ring, guard: &Guard) -> Result<Poly<Int>, ImplicitError> {
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);
    let mut primes = crate::modular_f4::primes();
    // The plan, on the first prime for which the parametrization reduces.
    let (plan, p0) = loop {
        let p = primes.next().expect("primes");
        if ParamMod::new(funcs, p).is_some() {
            break (make_plan(funcs, params, p, &mut rng, guard)?, p);
        }
    };
    let d = plan.degree;
    let n = d + 1;
    let mons: Vec<[usize; 3]> = {
        let mut m = monomials3(d);
        let key = |e: &[usize; 3]| Monomial::new(&[e[0] as u16, e[1] as u16, e[2] as u16]);
        m.sort_by(|a, b| out_ring.cmp(&key(b), &key(a)));
        m
    };
    let at = |e: &[usize; 3]| (e[0] * n + e[1]) * n + e[2];
    let mut lead: Option<usize> = None; // index in mons of the normalizing coefficient
    let mut residues: Vec<Int> = Vec::new();
    let mut modulus = Int::one();
    let mut previous: Option<Vec<Rat>> = None;
    let mut unlucky = 0;
    let mut used = 0;
    let mut next = Some(p0);
    loop {
        guard.check()?;
        if unlucky > 8 {
            return Err(ImplicitError::Resultant(
                "too many unlucky primes; try --method groebner".into(),
            ));
        }
        if used > 200 {
            return Err(ImplicitError::Resultant(
                "the coefficients did not settle after 200 primes; try --method groebner".into(),
            ));
        }
        let p = match next.take() {
            Some(p) => p,
            None => primes.next().expect("primes"),
        };
        let Some(image) = modular_image(&plan, p, &mut rng, guard, used + 1)? else {
            unlucky += 1;
            continue;
        };
        let l = *lead.get_or_insert_with(|| mons.iter().position(|e| image[at(e)] != 0).unwrap_or(0));
        let lc = image[at(&mons[l])];
        if lc == 0 {
            unlucky += 1;
            continue;
        }
        let inv = inv_mod(lc, p);
        let vals: Vec<u64> = mons.iter().map(|e| image[at(e)] * inv % p).collect();
        used += 1;
        // Chinese remaindering.
        if residues.is_empty() {
            residues = vals.iter().map(|&v| Int::from(v)).collect();
            modulus = Int::from(p);
        } else {
            let pm = Int::from(p);
            let minv = inv_mod((&modulus % &pm).to_u64().expect("below p"), p);
            for (r, &v) in residues.iter_mut().zip(&vals) {
                let rp = (&*r % &pm).to_u64().expect("below p");
                let t = (v + p - rp) % p * minv % p;
                *r += &modulus * Int::from(t);
            }
            modulus *= pm;
        }
        let rec = Reconstructor::new(&modulus);
        let lifted: Option<Vec<Rat>> = residues
            .iter()
            .map(|a| {
                if a.is_zero() {
                    Some(Rat::zero())
                } else {
                    rec.reconstruct(a)
                }
            })
            .collect();
        let Some(lifted) = lifted else { continue };
        if previous.as_ref() != Some(&lifted) {
            previous = Some(lifted);
            continue;
        }
        let fq = Poly::from_terms(
            out_ring,
            mons.iter()
                .zip(&lifted)
                .filter(|(_, c)| !c.is_zero())
                .map(|(e, c)| (Monomial::new(&[e[0] as u16, e[1] as u16, e[2] as u16]), c.clone()))
                .collect(),
        );
        let f = to_primitive_integer(out_ring, &fq);
        if vanishes_on(&f, funcs, guard)? {
            return Ok(f);
        }
        if used > 60 {
            return Err(ImplicitError::Resultant(
                "the interpolated equation does not vanish on the surface; try --method groebner".into(),
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::implicit::implicitize_groebner;
    use crate::parse::parse_poly;

    fn res(x: &str, y: &str, z: &str) -> Result<Implicit, ImplicitError> {
        implicitize_resultant(&[x, y, z], &["s", "t"], &ResultantOptions::default())
    }

    fn groebner_answer(x: &str, y: &str, z: &str) -> Poly<Int> {
        implicitize_groebner(&[x, y, z], &["s", "t"], &GroebnerOptions::default())
            .unwrap_or_else(|e| panic!("{e}"))
            .poly
    }

    #[test]
    fn example_1_3_dixon_matrix_and_plane() {
        // Thesis Ex. 1.3: x = s + t, y = s, z = t. The Dixon matrix of the
        // auxiliary system is the 1 × 1 matrix [−x + y + z] (the determinant
        // det [[−x, 1, 1], [−y, 1, 0], [−z, 0, 1]]).
        let ring = Ring::new(&["s", "t", "x", "y", "z"], MonomialOrder::DegRevLex);
        let coeffs = Ring::new(&["x", "y", "z"], MonomialOrder::DegRevLex);
        let p = |s: &str| parse_poly(&ring, s).unwrap();
        let dm = dixon_matrix(&ring, &[p("s + t - x"), p("s - y"), p("t - z")], &coeffs);
        assert_eq!(dm.entries, vec![vec![parse_poly(&coeffs, "-x + y + z").unwrap()]]);
        // The implicit equation: x − y − z (positive leading coefficient), as Gröbner gives it.
        let a = res("s+t", "s", "t").unwrap();
        assert_eq!(a.display(), "x - y - z");
        assert_eq!(a.poly, groebner_answer("s+t", "s", "t"));
    }

    #[test]
    fn dixon_matrix_of_a_generic_bilinear_system_is_2_by_2() {
        // Three bilinear polynomials (bidegree (1, 1)): the Dixon matrix is 2mn × 2mn = 2 × 2.
        let ring = Ring::new(&["s", "t", "x", "y", "z"], MonomialOrder::DegRevLex);
        let coeffs = Ring::new(&["x", "y", "z"], MonomialOrder::DegRevLex);
        let p = |s: &str| parse_poly(&ring, s).unwrap();
        let dm = dixon_matrix(&ring, &[p("s - x"), p("t - y"), p("s*t - z")], &coeffs);
        assert_eq!((dm.rows.len(), dm.cols.len()), (2, 2));
        let det = crate::resultant::determinant(&coeffs, dm.entries.clone());
        let xyz = parse_poly(&coeffs, "x*y - z").unwrap();
        assert!(det == xyz || det == xyz.neg(), "{}", det.display(&coeffs));
    }

    #[test]
    fn sphere_by_stereographic_projection() {
        // Its Dixon determinant is −64(z − 1)(x² + y² + z² − 1): the plane z = 1 is extraneous.
        let (x, y, z) = ("2s/(s^2+t^2+1)", "2t/(s^2+t^2+1)", "(s^2+t^2-1)/(s^2+t^2+1)");
        let a = res(x, y, z).unwrap();
        assert_eq!(a.display(), "x^2 + y^2 + z^2 - 1");
        assert_eq!(a.poly, groebner_answer(x, y, z));
    }

    #[test]
    fn cone_cylinder_and_polynomial_patches() {
        let cases = [
            // A cone: x² + y² = z², polynomial and rational (the rational one has the
            // base points (0, ±i) of its map to projective space: the first projection
            // operator has the extraneous factor y²z², removed by a second one with mixed
            // coordinates).
            ("s*(1-t^2)", "s*2t", "s*(1+t^2)", "x^2 + y^2 - z^2"),
            ("s*(1-t^2)/(1+t^2)", "s*2t/(1+t^2)", "s", "x^2 + y^2 - z^2"),
            // A cylinder: x² + y² = 1.
            ("(1-t^2)/(1+t^2)", "2t/(1+t^2)", "s", "x^2 + y^2 - 1"),
            // A hyperbolic paraboloid, a saddle, and the thesis's "ellipsoid" (a paraboloid).
            ("s", "t", "s*t", "x*y - z"),
            ("s", "t", "s^2+t^2", "x^2 + y^2 - z"),
        ];
        for (x, y, z, want) in cases {
            let a = res(x, y, z).unwrap_or_else(|e| panic!("{x}, {y}, {z}: {e}"));
            let g = groebner_answer(x, y, z);
            assert_eq!(a.poly, g, "{x}, {y}, {z}: {} vs {}", a.display(), g.display(&a.ring));
            let want = to_primitive_integer(&a.ring, &parse_poly(&a.ring, want).unwrap());
            assert_eq!(a.poly, want, "{x}, {y}, {z}");
        }
    }

    #[test]
    fn distinct_denominators_match_groebner() {
        let (x, y, z) = ("(s+t^2)/(t+1)", "(s^2-t)/(s+2)", "(s*t)/(s-t+1)");
        let a = res(x, y, z).unwrap();
        // Cross-check: the answer vanishes on the parametrization and equals Gröbner's
        // elimination (computed by interpolation when elimination is slow is checked in
        // `interp`; here elimination itself).
        assert_eq!(a.poly, groebner_answer(x, y, z));
        assert!(a.poly.degree() > 2);
    }

    #[test]
    fn improper_parametrization_gives_the_reduced_equation() {
        // x = s², y = t², z = s² + t² covers the plane z = x + y four times.
        let a = res("s^2", "t^2", "s^2+t^2").unwrap();
        assert_eq!(a.display(), "x + y - z");
        let (x, y, z) = ("s^2", "s*t", "t^2");
        let a = res(x, y, z).unwrap();
        assert_eq!(a.poly, groebner_answer(x, y, z));
    }

    #[test]
    fn base_points_are_reported() {
        // Every numerator and denominator vanishes at (s, t) = (0, 0).
        let e = res("s/(s^2+t^2)", "t/(s^2+t^2)", "(s*t)/(s^2+t^2)").unwrap_err();
        match &e {
            ImplicitError::BasePoints { points } => assert_eq!(points, "(s, t) = (0, 0)"),
            other => panic!("{other}"),
        }
        assert!(e.to_string().contains("base points") && e.to_string().contains("--method groebner"));
        // And at (1, −2), where every numerator and denominator vanishes.
        let e = res("(s-1)/(s+t+1)", "(t+2)/(s+t+1)", "(s-1)*(t+2)/(s^2+t+1)").unwrap_err();
        assert!(
            matches!(&e, ImplicitError::BasePoints { points } if points == "(s, t) = (1, -2)"),
            "{e}"
        );
    }

    #[test]
    fn known_extraneous_factors_are_removed() {
        // x and y depend on s/t only, and both their numerators and denominators vanish at
        // (0, 0): there the auxiliary system has the common root (0, 0) whenever z = 1, so
        // every resultant has the extraneous factor z − 1 (mixing the coordinates moves it
        // along, as the base point stays). It is found in advance and divided out.
        let (x, y, z) = ("3s/(2t+s)", "-3t/(t-s)", "(3+t)/(3+t-2s)");
        let a = res(x, y, z).unwrap();
        assert_eq!(a.poly, groebner_answer(x, y, z));
        assert_eq!(a.poly.degree(), 2);
        let funcs = parse_parametrization(&[x, y, z], &["s", "t"]).unwrap();
        let guard = Guard {
            start: Instant::now(),
            opts: &ResultantOptions::default(),
        };
        let known = known_extraneous(&funcs, &guard).unwrap();
        let v = Ring::new(&["s", "t", "v"], MonomialOrder::Lex);
        assert_eq!(known[0], None);
        assert_eq!(known[1], None);
        assert_eq!(known[2].as_ref().map(|e| e.display(&v)), Some("v - 1".to_string()));
    }

    #[test]
    fn no_surface_and_cancellation() {
        let e = res("s+t", "s+t", "(s+t)^2").unwrap_err();
        assert!(
            matches!(e, ImplicitError::Resultant(ref m) if m.contains("surface")),
            "{e}"
        );
        let token = CancelToken::new();
        token.cancel();
        let opts = ResultantOptions {
            interrupt: Some(token),
            ..Default::default()
        };
        let e = implicitize_resultant(&["s", "t", "s*t"], &["s", "t"], &opts).unwrap_err();
        assert_eq!(e, ImplicitError::Cancelled);
        let e = implicitize_resultant(&["s", "t"], &["s", "t"], &opts).unwrap_err();
        assert!(matches!(e, ImplicitError::WrongParameterCount { .. }), "{e}");
    }

    #[test]
    fn random_parametrizations_match_groebner() {
        // Fixed-seed random coordinates (numerators of degree ≤ 2, denominators of degree ≤ 1,
        // distinct): the resultant method either reports base points or gives exactly
        // elimination's answer.
        let mut rng = Rng(12345);
        let poly = |deg: u64, rng: &mut Rng| {
            let mut terms = Vec::new();
            for i in 0..=deg {
                for j in 0..=deg - i {
                    let c = rng.below(7) as i64 - 3;
                    if c != 0 && rng.below(3) != 0 {
                        terms.push(format!("{c}*s^{i}*t^{j}"));
                    }
                }
            }
            if terms.is_empty() {
                "1".to_string()
            } else {
                terms.join(" + ")
            }
        };
        let mut solved = 0;
        for case in 0..12 {
            let c: Vec<String> = (0..3)
                .map(|_| format!("({})/({})", poly(1 + case % 2, &mut rng), poly(1, &mut rng)))
                .collect();
            let (x, y, z) = (c[0].as_str(), c[1].as_str(), c[2].as_str());
            match res(x, y, z) {
                Ok(a) => {
                    // Elimination with a budget (some of these take it minutes); past it, the
                    // interpolation method, whose answer is verified exactly over Q.
                    let quick = GroebnerOptions {
                        budget: Budget {
                            time: Some(Duration::from_secs(2)),
                            ..Default::default()
                        },
                        ..Default::default()
                    };
                    let want = match implicitize_groebner(&[x, y, z], &["s", "t"], &quick) {
                        Ok(g) => g.poly,
                        Err(ImplicitError::Groebner(_)) => {
                            crate::interp::implicitize_interpolation(&[x, y, z], &["s", "t"], &Default::default())
                                .unwrap()
                                .poly
                        }
                        Err(e) => panic!("{x}, {y}, {z}: {e}"),
                    };
                    assert_eq!(a.poly, want, "{x}, {y}, {z}");
                    solved += 1;
                }
                Err(ImplicitError::BasePoints { .. }) => {}
                // Not a surface: elimination finds no principal ideal either.
                Err(ImplicitError::Resultant(m)) if m.contains("not describe a surface") => {
                    let g = implicitize_groebner(&[x, y, z], &["s", "t"], &GroebnerOptions::default());
                    assert!(matches!(g, Err(ImplicitError::NotPrincipal { .. })), "{x}, {y}, {z}");
                }
                Err(e) => panic!("{x}, {y}, {z}: {e}"),
            }
        }
        assert!(solved >= 9, "{solved} of 12");
    }

    #[test]
    fn plane_curves() {
        let opts = ResultantOptions::default();
        for (x, y) in [("(1-t^2)/(1+t^2)", "2t/(1+t^2)"), ("t^2", "t^3"), ("t^2", "t^4")] {
            let a = implicitize_resultant(&[x, y], &["t"], &opts).unwrap();
            let g = implicitize_groebner(&[x, y], &["t"], &GroebnerOptions::default()).unwrap();
            assert_eq!(a.poly, g.poly, "{x}, {y}");
        }
    }

    #[test]
    fn progress_is_reported() {
        let recorder = Arc::new(crate::testing::Recorder::default());
        let opts = ResultantOptions {
            progress: Some(recorder.clone()),
            ..Default::default()
        };
        let a = implicitize_resultant(
            &["2s/(s^2+t^2+1)", "2t/(s^2+t^2+1)", "(s^2+t^2-1)/(s^2+t^2+1)"],
            &["s", "t"],
            &opts,
        )
        .unwrap();
        assert_eq!(a.display(), "x^2 + y^2 + z^2 - 1");
        let stages = recorder.check(|name| name.starts_with("resultant: lines") || name.ends_with("verification"));
        assert!(stages.iter().any(|(n, _)| n == "resultant: certificate"), "{stages:?}");
        assert!(stages.iter().any(|(n, _)| n == "resultant: verification"), "{stages:?}");
    }

    #[test]
    fn univariate_helpers() {
        let p = 1_000_003;
        // (x − 1)²(x + 2) → square-free part (x − 1)(x + 2) = x² + x − 2.
        let a = vec![2, p - 3, 0, 1];
        assert_eq!(squarefree_part(&a, p), vec![p - 2, 1, 1]);
        let it = Interpolator::new(vec![0, 1, 2, 3], p);
        // 3x³ − x + 5 at 0..3.
        let f = |x: u64| (3 * x * x * x + 5 + p - x) % p;
        assert_eq!(trim(it.apply(&[f(0), f(1), f(2), f(3)])), vec![5, p - 1, 0, 3]);
        assert_eq!(ugcd(&[p - 1, 0, 1], &[p - 1, 1], p), vec![p - 1, 1]);
        let mut m = vec![2, 1, 1, 3];
        assert_eq!(det_mod(&mut m, 2, p), 5);
        // Roots mod p = 1000003 (≡ 3 mod 4, so t² + 1 has none) of (t − 1)(t − 5)(t² + 1)(t + 2)².
        let mut rng = Rng(7);
        let g = umul(
            &umul(&umul(&[p - 1, 1], &[p - 5, 1], p), &[1, 0, 1], p),
            &umul(&[2, 1], &[2, 1], p),
            p,
        );
        let mut r = roots_mod(&g, p, &mut rng);
        r.sort();
        assert_eq!(r, vec![1, 5, p - 2]);
    }

    #[test]
    fn degree_certificates() {
        // The sphere lies on no plane but on a quadric: both certificates say so.
        let funcs = parse_parametrization(
            &["2s/(s^2+t^2+1)", "2t/(s^2+t^2+1)", "(s^2+t^2-1)/(s^2+t^2+1)"],
            &["s", "t"],
        )
        .unwrap();
        let pm = ParamMod::new(&funcs, 2_147_483_647).unwrap();
        let mut rng = Rng(99);
        assert!(no_equation_of_degree(&pm, 1, &mut rng));
        assert!(!no_equation_of_degree(&pm, 2, &mut rng));
        assert!(no_equation_on_plane_section(&pm, 1, &mut rng));
        assert!(!no_equation_on_plane_section(&pm, 2, &mut rng));
    }
}
