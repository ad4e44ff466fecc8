//! Gröbner bases over word-size prime fields by Faugère's F4 (1999): the
//! S-pairs of lowest degree are reduced together as the rows of one
//! Macaulay matrix built by symbolic preprocessing, reduced by its known
//! pivots with a dense accumulator, and echelonized; its rows with new
//! leading monomials are reduced by each other (reduced row echelon form
//! among them, as msolve does: sparser elements, smaller later matrices —
//! eco-11 modulo 65521 went from 1.27 s to 0.80 s) and join the basis.
//! Pairs are installed with Gebauer and Möller's criteria (the product
//! criterion, the chain criterion in its M, F and B_k forms), as in
//! [`crate::groebner`].
//!
//! Monomials live in a hash table and rows refer to them by index, so the
//! matrix's columns are sorted once per round and a row is a list of column
//! numbers and `u32` residues. The table's hash is additive (a weighted sum
//! of the exponents), so a product's hash is the sum of its factors'. The
//! accumulator keeps residues below p² and reduces them modulo p only when
//! it reaches their column (delayed reduction); a divisibility mask per
//! monomial screens the search for reducers.
//!
//! A run can record its *trace* (Traverso's Gröbner trace carried over to
//! F4): per matrix, as numbers only, the pivot rows that were used and the
//! rows that gave new elements, each with its columns. Replaying it modulo
//! another prime reduces only those rows, with no monomial arithmetic,
//! hashing or sorting, and checks that every result leads where the
//! trace's did and has no term outside the trace's support. The multi-modular
//! method over Q ([`crate::modular_f4`]) learns it modulo a random prime.
//!
//! Pairs are selected by the degree of their lcm for graded orders and by
//! sugar otherwise (lex and block orders, where lcm degrees mislead).
//! Setting the environment variable `F4_DEBUG` prints every matrix's size
//! and reduction time on standard error.
//!
//! ```
//! use isoray_algebra::{f4::f4_modp, parse_poly, Fp, GroebnerOptions, MonomialOrder, Poly, Ring};
//!
//! let ring = Ring::new(&["x", "y"], MonomialOrder::DegRevLex);
//! let modp = |s: &str| {
//!     let f = parse_poly(&ring, s).unwrap();
//!     let terms = f.terms().iter().map(|(m, c)| (m.clone(), Fp::from_rat(c, 101).unwrap())).collect();
//!     Poly::from_terms(&ring, terms)
//! };
//! let (basis, _) = f4_modp(&ring, &[modp("x^2 + y^2 - 1"), modp("x - y")], &GroebnerOptions::default()).unwrap();
//! let text: Vec<String> = basis.iter().map(|p| p.display(&ring)).collect();
//! assert_eq!(text, ["x + 100*y", "y^2 + 50"]); // x = y, y² = 1/2 = −50 (mod 101)
//! ```

use std::cmp::Ordering;
use std::rc::Rc;
use std::time::Instant;

use rustc_hash::FxHashSet;

use crate::coeff::Fp;
use crate::groebner::{check_budget, GroebnerError, GroebnerOptions, Stats};
use crate::monomial::{Monomial, MonomialOrder};
use crate::poly::{Poly, Ring};

/// Coefficients modulo p, shared.
pub(crate) type Coefs = Rc<[u32]>;

/// A reduced basis element: its place among the interreduction's rows,
/// monomials (decreasing) and coefficients.
type Element = (usize, Vec<Monomial>, Coefs);

/// No pivot in this column.
const NONE: u32 = u32::MAX;

/// A divisibility mask: for each variable (up to 64 / n bits each) whether
/// its exponent reaches 1, 2, 4, 8. If a divides b, mask(a) ⊆ mask(b).
fn mask_of(m: &Monomial) -> u64 {
    let n = m.nvars().max(1);
    let bits = (64 / n).clamp(1, 4);
    let mut k = 0u64;
    for (i, &e) in m.exps().iter().enumerate() {
        for b in 0..bits {
            if e >= 1 << b {
                k |= 1 << ((i * bits + b) % 64);
            }
        }
    }
    k
}

/// The monomials met so far, by index: their exponents (flat, `n` per
/// monomial, for hashing and products without allocation), masks, and the
/// [`Monomial`] (for the order and the output). An open-addressing hash
/// table maps exponents to indices.
struct Table {
    n: usize,
    /// Σ weights[i]·e[i] is a monomial's hash: additive, so a product's
    /// hash is the sum of its factors' (no rehashing in symbolic
    /// preprocessing).
    weights: Vec<u64>,
    exps: Vec<u16>,
    hashes: Vec<u64>,
    masks: Vec<u64>,
    monos: Vec<Monomial>,
    /// Index + 1 of the monomial in each slot (0: empty); a power of two long.
    slots: Vec<u32>,
    /// Scratch exponents of a product.
    scratch: Vec<u16>,
}

/// The weight of variable `i` in the additive hash: odd, pseudo-random.
fn hash_weight(i: usize) -> u64 {
    let mut x = (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    x ^= x >> 31;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    (x ^ (x >> 29)) | 1
}

/// Σ weights[i]·e[i] (wrapping).
fn weighted_hash(weights: &[u64], e: &[u16]) -> u64 {
    e.iter()
        .zip(weights)
        .fold(0u64, |h, (&x, &w)| h.wrapping_add(w.wrapping_mul(x as u64)))
}

/// The table slot of a hash (its high bits folded into the low ones).
fn slot_of(h: u64, mask: usize) -> usize {
    (h ^ (h >> 32) ^ (h >> 47)) as usize & mask
}

impl Table {
    fn new(n: usize) -> Table {
        Table {
            n,
            weights: (0..n).map(hash_weight).collect(),
            exps: Vec::new(),
            hashes: Vec::new(),
            masks: Vec::new(),
            monos: Vec::new(),
            slots: vec![0; 1024],
            scratch: vec![0; n],
        }
    }

    fn len(&self) -> usize {
        self.monos.len()
    }

    /// The hash of exponents `e`.
    fn hash(&self, e: &[u16]) -> u64 {
        weighted_hash(&self.weights, e)
    }

    /// The index of the exponents in `self.scratch` (whose hash is `h`),
    /// added if new.
    fn id_of_scratch(&mut self, h: u64) -> u32 {
        let mask = self.slots.len() - 1;
        let mut i = slot_of(h, mask);
        let n = self.n;
        loop {
            let s = self.slots[i];
            if s == 0 {
                break;
            }
            let k = (s - 1) as usize;
            if self.hashes[k] == h
                && self.exps[k * n..(k + 1) * n]
                    .iter()
                    .zip(&self.scratch)
                    .all(|(a, b)| a == b)
            {
                return k as u32;
            }
            i = (i + 1) & mask;
        }
        let k = self.monos.len() as u32;
        self.slots[i] = k + 1;
        self.exps.extend_from_slice(&self.scratch);
        self.hashes.push(h);
        let m = Monomial::new(&self.scratch);
        self.masks.push(mask_of(&m));
        self.monos.push(m);
        if 2 * self.monos.len() > self.slots.len() {
            self.grow();
        }
        k
    }

    fn grow(&mut self) {
        let size = self.slots.len() * 2;
        let mut slots = vec![0u32; size];
        for (k, &h) in self.hashes.iter().enumerate() {
            let mut i = slot_of(h, size - 1);
            while slots[i] != 0 {
                i = (i + 1) & (size - 1);
            }
            slots[i] = k as u32 + 1;
        }
        self.slots = slots;
    }

    fn id(&mut self, m: &Monomial) -> u32 {
        self.scratch.copy_from_slice(m.exps());
        let h = self.hash(m.exps());
        self.id_of_scratch(h)
    }

    /// The index of monomial k times the monomial of exponents `m` and hash `hm`.
    fn mul(&mut self, k: u32, m: &[u16], hm: u64) -> u32 {
        let base = k as usize * self.n;
        let src = &self.exps[base..base + self.n];
        let mut saturated = false;
        for ((d, &a), &b) in self.scratch.iter_mut().zip(src).zip(m) {
            let (v, o) = a.overflowing_add(b);
            *d = if o { u16::MAX } else { v };
            saturated |= o;
        }
        let h = if saturated {
            weighted_hash(&self.weights, &self.scratch)
        } else {
            self.hashes[k as usize].wrapping_add(hm)
        };
        self.id_of_scratch(h)
    }
}

/// A polynomial: its monomials (table indices) from the leading one down, and
/// their coefficients in 0..p.
#[derive(Clone, Debug)]
struct Row {
    mons: Vec<u32>,
    /// Shared by the multiples of one element (reducers stream only their
    /// column numbers from memory; the coefficients stay in cache).
    coefs: Rc<[u32]>,
    /// The polynomial the coefficients belong to: an input's index, or the
    /// number given to a new element (as a trace refers to it).
    src: u32,
}

/// A row of a matrix: increasing column numbers (decreasing monomials).
#[derive(Clone)]
struct MatRow {
    cols: Rc<[u32]>,
    coefs: Rc<[u32]>,
    src: u32,
}

/// A critical pair: basis elements i < j and the lcm of their leading monomials.
#[derive(Clone, Debug)]
struct Pair {
    i: usize,
    j: usize,
    lcm: Monomial,
    /// The selection degree: the lcm's degree for graded orders, else
    /// the sugar (Giovini et al.).
    deg: u32,
}

/// a⁻¹ mod p for a prime p (a^(p−2)), p < 2³².
pub(crate) fn inv_mod(a: u64, p: u64) -> u64 {
    let (mut base, mut e, mut acc) = (a % p, p - 2, 1u64);
    while e > 0 {
        if e & 1 == 1 {
            acc = acc * base % p;
        }
        base = base * base % p;
        e >>= 1;
    }
    acc
}

/// What an F4 run learned, to be replayed modulo other primes: the
/// supports of the inputs, and every reduction it made that mattered, as
/// numbers only: per matrix its columns, the pivot rows that were used
/// (which polynomial, on which columns) and the rows that gave new
/// elements, with the columns their results occupy. A replay builds no
/// monomial, hashes nothing and skips the rows that reduced to zero.
#[derive(Debug, Clone, Default)]
pub struct F4Trace {
    /// Per input (by its index), its monomials from the leading one down.
    inputs: Vec<Vec<Monomial>>,
    steps: Vec<Step>,
    /// The reduced basis: per element (increasing leading monomial) the row
    /// of the last step it is and the monomials of its columns.
    outputs: Vec<(usize, Vec<Monomial>)>,
}

/// A recorded row: polynomial `src` on columns `cols`.
#[derive(Debug, Clone)]
struct RecRow {
    src: u32,
    cols: Rc<[u32]>,
}

/// One recorded matrix.
#[derive(Debug, Clone, Default)]
struct Step {
    ncols: usize,
    pivots: Vec<RecRow>,
    /// Rows reduced in turn, each with the columns of its result; with
    /// `keep_lead` false each result is the next new polynomial and a pivot.
    reduce: Vec<(RecRow, Rc<[u32]>)>,
    keep_lead: bool,
}

impl F4Trace {
    /// Matrices recorded.
    pub fn rounds(&self) -> usize {
        self.steps.len()
    }

    /// The reduced basis's monomials, per element by increasing leading
    /// monomial, from the leading one down.
    pub fn output_monomials(&self) -> impl Iterator<Item = &[Monomial]> {
        self.outputs.iter().map(|(_, m)| m.as_slice())
    }

    /// Row entries (pivots and reduced rows) a replay streams.
    pub fn entries(&self) -> usize {
        self.steps
            .iter()
            .map(|s| {
                s.pivots.iter().map(|r| r.cols.len()).sum::<usize>()
                    + s.reduce.iter().map(|r| r.0.cols.len()).sum::<usize>()
            })
            .sum()
    }
}

/// A replay met other leading monomials than its trace (an unlucky prime,
/// or a prime where a coefficient the trace relies on vanishes).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TraceMismatch;

/// The state of an F4 run.
struct F4<'r> {
    ring: &'r Ring,
    p: u64,
    opts: &'r GroebnerOptions,
    start: Instant,
    stats: Stats,
    table: Table,
    basis: Vec<Row>,
    /// Leading monomial of each basis element, and its mask.
    lead: Vec<Monomial>,
    lead_mask: Vec<u64>,
    /// Whether an element is still in the basis (not made redundant).
    alive: Vec<bool>,
    /// Sugar degree of each element.
    sugar: Vec<u32>,
    /// Whether the order refines the total degree (pairs are then selected
    /// by the degree of their lcm, else by sugar).
    graded: bool,
    pairs: Vec<Pair>,
    /// The number the next new element gets (after the inputs' indices).
    next_id: u32,
    /// The matrices recorded, when learning a trace.
    rec: Option<Vec<Step>>,
    /// `F4_DEBUG` is set: print every matrix's statistics.
    debug: bool,
}

impl<'r> F4<'r> {
    fn new(ring: &'r Ring, p: u64, opts: &'r GroebnerOptions) -> F4<'r> {
        F4 {
            ring,
            p,
            opts,
            start: Instant::now(),
            stats: Stats::default(),
            table: Table::new(ring.nvars()),
            basis: Vec::new(),
            lead: Vec::new(),
            lead_mask: Vec::new(),
            alive: Vec::new(),
            sugar: Vec::new(),
            graded: matches!(ring.order(), MonomialOrder::DegLex | MonomialOrder::DegRevLex),
            pairs: Vec::new(),
            next_id: 0,
            rec: None,
            debug: std::env::var_os("F4_DEBUG").is_some(),
        }
    }

    fn cmp(&self, a: u32, b: u32) -> Ordering {
        self.ring
            .cmp(&self.table.monos[a as usize], &self.table.monos[b as usize])
    }

    fn check(&self) -> Result<(), GroebnerError> {
        check_budget(&self.opts.budget, self.start, &self.stats)
    }

    /// Row of m·g for basis element g.
    fn multiple(&mut self, m: &Monomial, g: usize) -> Row {
        if m.is_one() {
            return self.basis[g].clone();
        }
        let hm = self.table.hash(m.exps());
        let mut mons = Vec::with_capacity(self.basis[g].mons.len());
        for k in 0..self.basis[g].mons.len() {
            mons.push(self.table.mul(self.basis[g].mons[k], m.exps(), hm));
        }
        Row {
            mons,
            coefs: self.basis[g].coefs.clone(),
            src: self.basis[g].src,
        }
    }

    /// The new pairs of element h with the alive elements, pruned by the
    /// chain criterion (M: another new pair's lcm properly divides this
    /// one's; F: one pair per lcm) and the product criterion; the old pairs
    /// that lm(h) makes redundant (B_k) are dropped.
    fn update_pairs(&mut self, h: usize, lh: &Monomial, sugar: u32) {
        // (element, lcm, the lcm's divisibility mask).
        let cand: Vec<(usize, Monomial, u64)> = (0..h)
            .filter(|&g| self.alive[g])
            .map(|g| {
                let l = self.lead[g].lcm(lh);
                let m = mask_of(&l);
                (g, l, m)
            })
            .collect();
        self.stats.pairs_created += cand.len() as u64;
        let criteria = self.opts.criteria;
        // The lcms of the coprime pairs (criterion F below).
        let coprime_lcms: FxHashSet<&Monomial> = if criteria.chain && criteria.product {
            cand.iter()
                .filter(|(g, _, _)| self.lead[*g].coprime(lh))
                .map(|(_, l, _)| l)
                .collect()
        } else {
            FxHashSet::default()
        };
        let mut kept = 0;
        for (k, (g, l, m)) in cand.iter().enumerate() {
            // The masks reject most candidates before the exponents are compared.
            let dominated = criteria.chain
                && cand.iter().enumerate().any(|(k2, (_, l2, m2))| {
                    k2 != k && m2 & !m == 0 && l2.degree() <= l.degree() && l2.divides(l) && (k2 < k || l2 != l)
                });
            let coprime = criteria.product && self.lead[*g].coprime(lh);
            // A pair whose lcm equals a coprime pair's lcm goes with it (F).
            let same_as_coprime = !coprime && coprime_lcms.contains(l);
            if coprime {
                self.stats.removed_product += 1;
            } else if dominated || same_as_coprime {
                self.stats.removed_chain += 1;
            } else {
                let d = l.degree();
                let deg = if self.graded {
                    d
                } else {
                    (self.sugar[*g] + d - self.lead[*g].degree()).max(sugar + d - lh.degree())
                };
                self.pairs.push(Pair {
                    i: *g,
                    j: h,
                    lcm: l.clone(),
                    deg,
                });
                kept += 1;
            }
        }
        let lead = &self.lead;
        let before = self.pairs.len() - kept;
        let mut k = 0;
        let mut removed = 0;
        self.pairs.retain(|q| {
            k += 1;
            let drop = criteria.chain
                && k <= before
                && lh.divides(&q.lcm)
                && lead[q.i].lcm(lh) != q.lcm
                && lead[q.j].lcm(lh) != q.lcm;
            removed += u64::from(drop);
            !drop
        });
        self.stats.removed_chain += removed;
    }

    /// Adds `row` (monic, nonzero, its leading monomial divisible by no
    /// alive element's) to the basis, with its pairs if `pairs`; elements
    /// whose leading monomial it divides are no longer alive (their pairs
    /// with it are made first, as Gebauer and Möller's UPDATE does).
    fn insert(&mut self, row: Row, sugar: u32, pairs: bool) {
        let h = self.basis.len();
        let lh = self.table.monos[row.mons[0] as usize].clone();
        let mh = self.table.masks[row.mons[0] as usize];
        if pairs {
            self.update_pairs(h, &lh, sugar);
        }
        for g in 0..h {
            if self.alive[g] && mh & !self.lead_mask[g] == 0 && lh.divides(&self.lead[g]) {
                self.alive[g] = false;
            }
        }
        self.basis.push(row);
        self.lead.push(lh);
        self.lead_mask.push(mh);
        self.alive.push(true);
        self.sugar.push(sugar);
    }

    /// An alive element whose leading monomial divides monomial `m`.
    fn divisor(&self, m: u32) -> Option<usize> {
        let mm = self.table.masks[m as usize];
        let mono = &self.table.monos[m as usize];
        (0..self.basis.len()).find(|&g| self.alive[g] && self.lead_mask[g] & !mm == 0 && self.lead[g].divides(mono))
    }

    /// Symbolic preprocessing: for every monomial of `rows` (with `leads`
    /// false, but their leading ones) and of the reducers found, a reducer
    /// row (a multiple of an alive element with that leading monomial).
    fn preprocess(&mut self, rows: &[Row], leads: bool) -> Result<Vec<Row>, GroebnerError> {
        let skip = usize::from(!leads);
        let mut done: FxHashSet<u32> = FxHashSet::default();
        if !leads {
            done.extend(rows.iter().map(|r| r.mons[0]));
        }
        let mut todo: Vec<u32> = rows.iter().flat_map(|r| r.mons[skip..].iter().copied()).collect();
        let mut reducers = Vec::new();
        let mut seen = 0u32;
        while let Some(m) = todo.pop() {
            if !done.insert(m) {
                continue;
            }
            seen = seen.wrapping_add(1);
            if seen % 4096 == 0 {
                self.check()?;
            }
            if let Some(g) = self.divisor(m) {
                let q = self.lead[g].quotient(&self.table.monos[m as usize]).expect("divides");
                let r = self.multiple(&q, g);
                todo.extend(r.mons[1..].iter().copied());
                reducers.push(r);
            }
        }
        Ok(reducers)
    }

    /// The columns of `rows` (all their monomials) in descending order, and
    /// the column of each table index (`NONE` for monomials not in them).
    fn columns<'a>(&self, rows: impl Iterator<Item = &'a Row>) -> (Vec<u32>, Vec<u32>) {
        let mut col_of = vec![NONE; self.table.len()];
        let mut cols = Vec::new();
        for r in rows {
            for &m in &r.mons {
                if col_of[m as usize] == NONE {
                    col_of[m as usize] = 0;
                    cols.push(m);
                }
            }
        }
        cols.sort_unstable_by(|&a, &b| self.cmp(b, a));
        for (c, &m) in cols.iter().enumerate() {
            col_of[m as usize] = c as u32;
        }
        (cols, col_of)
    }

    /// `row` in column numbers, made monic.
    fn to_matrix(&self, row: Row, col_of: &[u32]) -> MatRow {
        let cols = row.mons.iter().map(|&m| col_of[m as usize]).collect();
        let mut coefs = row.coefs;
        if coefs[0] != 1 {
            let inv = inv_mod(coefs[0] as u64, self.p);
            coefs = coefs.iter().map(|&c| (c as u64 * inv % self.p) as u32).collect();
        }
        MatRow {
            cols,
            coefs,
            src: row.src,
        }
    }

    /// Makes `rows` pivots of their leading columns (where there is none yet).
    fn install(&self, rows: Vec<Row>, col_of: &[u32], piv: &mut [u32], store: &mut Vec<MatRow>) {
        for r in rows {
            let m = self.to_matrix(r, col_of);
            let c = m.cols[0] as usize;
            if piv[c] == NONE {
                piv[c] = store.len() as u32;
                store.push(m);
            }
        }
    }

    /// Reduces `row` by the pivots (`piv[c]`: the index in `store` of the
    /// monic row whose leading column is c) in the dense accumulator `acc`
    /// (zero on entry): returns the columns left nonzero, increasing, their
    /// values (below p) left in `acc`. With `keep_lead` the row's leading
    /// term stays and only its tail is reduced. `used` collects the pivots
    /// used.
    fn reduce_row(
        &mut self,
        acc: &mut [u64],
        row: &MatRow,
        piv: &[u32],
        store: &[MatRow],
        keep_lead: bool,
        mut used: Option<&mut Vec<u32>>,
    ) -> Vec<u32> {
        let p = self.p;
        let p2 = p * p;
        // How many products (p − 1)² fit on top of a value below p² in a u64.
        let headroom = (u64::MAX - p2) / ((p - 1) * (p - 1)).max(1);
        let ncols = acc.len();
        for (&c, &v) in row.cols.iter().zip(row.coefs.iter()) {
            acc[c as usize] = v as u64;
        }
        let first = row.cols[0] as usize;
        let mut pending = 0u64;
        let mut nz: Vec<u32> = Vec::new();
        if keep_lead {
            nz.push(first as u32);
        }
        for c in first + usize::from(keep_lead)..ncols {
            let a = acc[c];
            if a == 0 {
                continue;
            }
            let v = a % p;
            if v == 0 {
                acc[c] = 0;
                continue;
            }
            let k = piv[c];
            if k == NONE {
                acc[c] = v;
                nz.push(c as u32);
                continue;
            }
            if let Some(u) = used.as_deref_mut() {
                u.push(k);
            }
            // acc −= v·pivot (monic: its leading term cancels column c).
            acc[c] = 0;
            let f = p - v;
            let pr = &store[k as usize];
            let (cols, coefs) = (&pr.cols[1..], &pr.coefs[1..]);
            if headroom >= 16 {
                // Small p: add products unreduced, and bring the row
                // below p before `headroom` of them could overflow.
                for (&cc, &pc) in cols.iter().zip(coefs) {
                    // SAFETY: every column of a row is below ncols = acc.len().
                    unsafe { *acc.get_unchecked_mut(cc as usize) += f * pc as u64 };
                }
                pending += 1;
                if pending + 1 >= headroom {
                    for a in &mut acc[c + 1..] {
                        *a %= p;
                    }
                    pending = 0;
                }
            } else {
                for (&cc, &pc) in cols.iter().zip(coefs) {
                    // SAFETY: as above.
                    let a = unsafe { acc.get_unchecked_mut(cc as usize) };
                    let x = *a + f * pc as u64;
                    *a = if x >= p2 { x - p2 } else { x };
                }
            }
            self.stats.reduction_steps += 1;
        }
        nz
    }

    /// Reduces `rows` by the pivots with [`F4::reduce_row`]. With
    /// `keep_lead` false a nonzero result, monic, becomes the pivot of its
    /// leading column (so later rows are reduced by it too) and a new
    /// polynomial; with `keep_lead` true the rows' leading terms stay and
    /// only their tails are reduced (interreduction). Returns each row's
    /// result (its index in `store`, None for a row that reduced to zero);
    /// when learning a trace, records the matrix (`store[..fixed]` were its
    /// pivots before the rows came).
    fn echelon(
        &mut self,
        ncols: usize,
        piv: &mut [u32],
        store: &mut Vec<MatRow>,
        rows: Vec<MatRow>,
        keep_lead: bool,
    ) -> Result<Vec<Option<u32>>, GroebnerError> {
        let p = self.p;
        let fixed = store.len();
        let learning = self.rec.is_some();
        let mut acc = vec![0u64; ncols];
        let mut out = Vec::with_capacity(rows.len());
        let mut need = vec![false; if learning { fixed } else { 0 }];
        let mut reduced = Vec::new();
        let mut used = Vec::new();
        for (n, row) in rows.into_iter().enumerate() {
            if n % 64 == 63 {
                self.check()?;
            }
            used.clear();
            let nz = self.reduce_row(&mut acc, &row, piv, store, keep_lead, learning.then_some(&mut used));
            if nz.is_empty() {
                self.stats.zero_reductions += 1;
                out.push(None);
                continue;
            }
            let inv = if keep_lead { 1 } else { inv_mod(acc[nz[0] as usize], p) };
            let coefs = nz
                .iter()
                .map(|&c| {
                    let v = std::mem::take(&mut acc[c as usize]);
                    (v * inv % p) as u32
                })
                .collect();
            let lead = nz[0];
            let k = store.len() as u32;
            let src = if keep_lead {
                row.src
            } else {
                self.next_id += 1;
                self.next_id - 1
            };
            let cols: Rc<[u32]> = nz.into();
            if learning {
                for &u in &used {
                    if (u as usize) < fixed {
                        need[u as usize] = true;
                    }
                }
                reduced.push((
                    RecRow {
                        src: row.src,
                        cols: row.cols.clone(),
                    },
                    cols.clone(),
                ));
            }
            store.push(MatRow { cols, coefs, src });
            if !keep_lead {
                piv[lead as usize] = k;
            }
            out.push(Some(k));
        }
        if let Some(rec) = &mut self.rec {
            rec.push(Step {
                ncols,
                pivots: (0..fixed)
                    .filter(|&k| need[k])
                    .map(|k| RecRow {
                        src: store[k].src,
                        cols: store[k].cols.clone(),
                    })
                    .collect(),
                reduce: reduced,
                keep_lead,
            });
        }
        Ok(out)
    }

    /// One matrix: the pair rows `rows` and their reducers. Returns the
    /// new elements' rows, largest leading monomial first.
    fn matrix(&mut self, rows: Vec<Row>) -> Result<Vec<Row>, GroebnerError> {
        let reducers = self.preprocess(&rows, false)?;
        let (order, col_of) = self.columns(rows.iter().chain(&reducers));
        let mut piv = vec![NONE; order.len()];
        let mut store: Vec<MatRow> = Vec::with_capacity(reducers.len() + rows.len());
        self.install(reducers, &col_of, &mut piv, &mut store);
        let mut todo = Vec::new();
        for r in rows {
            let m = self.to_matrix(r, &col_of);
            let c = m.cols[0] as usize;
            if piv[c] == NONE {
                piv[c] = store.len() as u32;
                store.push(m);
            } else {
                todo.push(m);
            }
        }
        let t0 = Instant::now();
        let (nred, ntodo, steps0) = (store.len(), todo.len(), self.stats.reduction_steps);
        let results = self.echelon(order.len(), &mut piv, &mut store, todo, false)?;
        // Back-substitution, as msolve does: each new row's tail reduced by
        // the other new rows (a left-to-right pass meets every new leading
        // column, so the order does not matter), for sparser new elements
        // and smaller matrices later. Recorded as a step keeping the leads.
        let fresh: Vec<u32> = results.into_iter().flatten().collect();
        let results: Vec<Option<u32>> = if fresh.len() > 1 {
            let rows = fresh.iter().map(|&k| store[k as usize].clone()).collect();
            self.echelon(order.len(), &mut piv, &mut store, rows, true)?
        } else {
            fresh.into_iter().map(Some).collect()
        };
        if self.debug {
            let nnz: usize = store[..nred].iter().map(|r| r.cols.len()).sum();
            eprintln!(
                "matrix {} pivots ({} nnz) + {} rows x {} cols: {} steps, {} new, {:.1} ms",
                nred,
                nnz,
                ntodo,
                order.len(),
                self.stats.reduction_steps - steps0,
                results.iter().flatten().count(),
                t0.elapsed().as_secs_f64() * 1e3
            );
        }
        let mut new: Vec<Row> = results
            .into_iter()
            .flatten()
            .map(|s| {
                let m = &store[s as usize];
                Row {
                    mons: m.cols.iter().map(|&c| order[c as usize]).collect(),
                    coefs: m.coefs.clone(),
                    src: m.src,
                }
            })
            .collect();
        // Largest leading monomial first: a new element whose leading
        // monomial another one's divides then leaves the basis when that
        // one comes in (after their pair is made).
        new.sort_by(|a, b| self.cmp(b.mons[0], a.mons[0]));
        Ok(new)
    }

    /// The inputs, each reduced by the elements before it.
    fn add_inputs(&mut self, rows: Vec<Row>, pairs: bool) -> Result<(), GroebnerError> {
        for row in rows {
            let sugar = row
                .mons
                .iter()
                .map(|&m| self.table.monos[m as usize].degree())
                .max()
                .unwrap_or(0);
            let reducers = self.preprocess(std::slice::from_ref(&row), true)?;
            let (order, col_of) = self.columns(std::iter::once(&row).chain(&reducers));
            let mut piv = vec![NONE; order.len()];
            let mut store = Vec::new();
            self.install(reducers, &col_of, &mut piv, &mut store);
            let row = MatRow {
                cols: row.mons.iter().map(|&m| col_of[m as usize]).collect(),
                coefs: row.coefs,
                src: row.src,
            };
            if let Some(Some(s)) = self.echelon(order.len(), &mut piv, &mut store, vec![row], false)?.pop() {
                let m = &store[s as usize];
                let r = Row {
                    mons: m.cols.iter().map(|&c| order[c as usize]).collect(),
                    coefs: m.coefs.clone(),
                    src: m.src,
                };
                self.insert(r, sugar, pairs);
            }
        }
        Ok(())
    }

    fn report(&self, done: u64) {
        if let Some(p) = &self.opts.progress {
            p.update(done, done + self.pairs.len() as u64);
        }
    }

    /// The main loop: pairs of lowest degree, a matrix each time.
    fn run(&mut self) -> Result<(), GroebnerError> {
        let mut done = 0u64;
        self.report(done);
        while !self.pairs.is_empty() {
            self.check()?;
            let d = self.pairs.iter().map(|q| q.deg).min().expect("pairs");
            let (now, later): (Vec<Pair>, Vec<Pair>) = self.pairs.drain(..).partition(|q| q.deg == d);
            self.pairs = later;
            self.stats.pairs_reduced += now.len() as u64;
            // Both halves of each pair; one row per (element, multiplier).
            let mut seen = FxHashSet::default();
            let mut rows = Vec::new();
            for q in &now {
                for g in [q.i, q.j] {
                    let m = self.lead[g].quotient(&q.lcm).expect("lcm");
                    if seen.insert((g, m.clone())) {
                        rows.push(self.multiple(&m, g));
                    }
                }
            }
            for r in self.matrix(rows)? {
                self.check()?;
                self.insert(r, d, true);
            }
            done += now.len() as u64;
            self.report(done);
        }
        Ok(())
    }

    /// The reduced basis: the alive elements, each tail reduced by the
    /// others in one matrix; per element (by increasing leading monomial)
    /// its place among the matrix's reduced rows, its monomials and its
    /// coefficients.
    fn reduced(&mut self) -> Result<Vec<Element>, GroebnerError> {
        let alive: Vec<Row> = (0..self.basis.len())
            .filter(|&g| self.alive[g])
            .map(|g| self.basis[g].clone())
            .collect();
        let reducers = self.preprocess(&alive, false)?;
        let (order, col_of) = self.columns(alive.iter().chain(&reducers));
        let mut piv = vec![NONE; order.len()];
        let mut store = Vec::new();
        let mut rows = Vec::new();
        for r in alive {
            let m = self.to_matrix(r, &col_of);
            piv[m.cols[0] as usize] = store.len() as u32;
            rows.push(m.clone());
            store.push(m);
        }
        self.install(reducers, &col_of, &mut piv, &mut store);
        let done = self.echelon(order.len(), &mut piv, &mut store, rows, true)?;
        let mut out: Vec<Element> = done
            .into_iter()
            .enumerate()
            .map(|(k, s)| {
                let m = &store[s.expect("a basis element keeps its leading term") as usize];
                let monos = m
                    .cols
                    .iter()
                    .map(|&c| self.table.monos[order[c as usize] as usize].clone())
                    .collect();
                (k, monos, m.coefs.clone())
            })
            .collect();
        out.sort_by(|a, b| self.ring.cmp(&a.1[0], &b.1[0]));
        Ok(out)
    }

    /// The inputs as rows, by increasing leading monomial.
    fn input_rows(&mut self, polys: &[Poly<Fp>]) -> Vec<Row> {
        let mut rows: Vec<Row> = Vec::new();
        self.next_id = polys.len() as u32;
        for (i, f) in polys.iter().enumerate() {
            let mut terms: Vec<(Monomial, u32)> = f
                .terms()
                .iter()
                .filter(|(_, c)| c.value() != 0)
                .map(|(m, c)| (m.clone(), c.value() as u32))
                .collect();
            if terms.is_empty() {
                continue;
            }
            terms.sort_by(|a, b| self.ring.cmp(&b.0, &a.0));
            let mons = terms.iter().map(|(m, _)| self.table.id(m)).collect();
            rows.push(Row {
                mons,
                coefs: terms.iter().map(|(_, c)| *c).collect(),
                src: i as u32,
            });
        }
        rows.sort_by(|a, b| self.cmp(a.mons[0], b.mons[0]));
        rows
    }

    /// The reduced basis, with the counters; records the outputs into
    /// `trace` when learning.
    fn finish(&mut self, trace: Option<&mut F4Trace>) -> Result<FpBasis, GroebnerError> {
        let n = self.alive.iter().filter(|a| **a).count() as u64;
        if let Some(p) = &self.opts.progress {
            p.stage("f4: interreduction");
            p.update(0, n);
        }
        let elems = self.reduced()?;
        if let Some(p) = &self.opts.progress {
            p.update(n, n);
        }
        let basis = elems
            .iter()
            .map(|(_, monos, coefs)| to_poly(monos, coefs, self.p))
            .collect::<Vec<_>>();
        if let Some(t) = trace {
            t.steps = self.rec.take().unwrap_or_default();
            t.outputs = elems.into_iter().map(|(k, monos, _)| (k, monos)).collect();
        }
        self.stats.basis_size = basis.len();
        self.stats.time = self.start.elapsed();
        Ok((basis, self.stats))
    }
}

/// The polynomial of coefficients `coefs` (zeros skipped) on `monos`.
fn to_poly(monos: &[Monomial], coefs: &[u32], p: u64) -> Poly<Fp> {
    Poly::from_sorted(
        monos
            .iter()
            .zip(coefs)
            .filter(|(_, &v)| v != 0)
            .map(|(m, &v)| (m.clone(), Fp::new(v as i64, p)))
            .collect(),
    )
}

/// A reduced basis over GF(p) and the counters of its computation.
pub type FpBasis = (Vec<Poly<Fp>>, Stats);

/// The modulus of `polys`' coefficients (None when they are all zero).
fn modulus(polys: &[Poly<Fp>]) -> Option<u64> {
    let p = polys.iter().flat_map(|f| f.terms()).map(|(_, c)| c.modulus()).next()?;
    assert!(p < 1 << 31, "F4 here works modulo primes below 2³¹");
    Some(p)
}

/// The reduced Gröbner basis of `polys` over GF(p) (p < 2³¹) by F4: monic
/// elements by increasing leading monomial, with the run's counters
/// (`pairs_reduced` counts pairs, `reduction_steps` row eliminations,
/// `zero_reductions` rows that reduced to zero). The budget, interrupt and
/// progress of `opts` apply (stages `f4` and `f4: interreduction`).
pub fn f4_modp(
    ring: &Ring,
    polys: &[Poly<Fp>],
    opts: &GroebnerOptions,
) -> Result<(Vec<Poly<Fp>>, Stats), GroebnerError> {
    f4_learn(ring, polys, opts, None)
}

/// [`f4_modp`], recording the run's trace into `trace`.
pub fn f4_learn(
    ring: &Ring,
    polys: &[Poly<Fp>],
    opts: &GroebnerOptions,
    mut trace: Option<&mut F4Trace>,
) -> Result<(Vec<Poly<Fp>>, Stats), GroebnerError> {
    if let Some(t) = trace.as_deref_mut() {
        *t = F4Trace {
            inputs: polys
                .iter()
                .map(|f| {
                    f.terms()
                        .iter()
                        .filter(|(_, c)| c.value() != 0)
                        .map(|(m, _)| m.clone())
                        .collect()
                })
                .collect(),
            ..F4Trace::default()
        };
    }
    let Some(p) = modulus(polys) else {
        return Ok((Vec::new(), Stats::default()));
    };
    let mut f4 = F4::new(ring, p, opts);
    if trace.is_some() {
        f4.rec = Some(Vec::new());
    }
    if let Some(pr) = &opts.progress {
        pr.stage("f4");
    }
    let rows = f4.input_rows(polys);
    f4.add_inputs(rows, true)?;
    f4.run()?;
    f4.finish(trace)
}

/// Replays `trace` (learned by [`f4_learn`] on the same inputs modulo another
/// prime) modulo the prime of `polys`: the reduced basis, or
/// `Ok(Err(TraceMismatch))` when the reductions come out otherwise (a
/// leading term vanishes, or a term appears where the trace has none: the
/// caller then runs [`f4_modp`] or drops the prime). Its result is a
/// Gröbner basis only if the trace's run was one for this prime too, which
/// the multi-modular method's verification settles.
pub fn f4_replay(
    ring: &Ring,
    polys: &[Poly<Fp>],
    trace: &F4Trace,
    opts: &GroebnerOptions,
) -> Result<Result<FpBasis, TraceMismatch>, GroebnerError> {
    let p = modulus(polys).unwrap_or(2);
    Ok(f4_replay_coefs(ring, polys, trace, opts)?.map(|(coefs, stats)| {
        let basis = trace
            .outputs
            .iter()
            .zip(&coefs)
            .map(|((_, monos), c)| to_poly(monos, c, p))
            .collect();
        (basis, stats)
    }))
}

/// [`f4_replay`]'s basis as coefficients on the monomials of
/// [`F4Trace::output_monomials`] (zeros kept).
pub(crate) fn f4_replay_coefs(
    ring: &Ring,
    polys: &[Poly<Fp>],
    trace: &F4Trace,
    opts: &GroebnerOptions,
) -> Result<Result<(Vec<Coefs>, Stats), TraceMismatch>, GroebnerError> {
    let Some(p) = modulus(polys) else {
        return Ok(Err(TraceMismatch));
    };
    if polys.len() != trace.inputs.len() {
        return Ok(Err(TraceMismatch));
    }
    let mut f4 = F4::new(ring, p, opts);
    if let Some(pr) = &opts.progress {
        pr.stage("f4 replay");
        pr.update(0, trace.steps.len() as u64);
    }
    // The coefficients of every polynomial, on the trace's supports.
    let mut vals: Vec<Rc<[u32]>> = Vec::with_capacity(polys.len());
    for (f, support) in polys.iter().zip(&trace.inputs) {
        match align(ring, f, support) {
            Some(v) => vals.push(v),
            None => return Ok(Err(TraceMismatch)),
        }
    }
    let mut last = Vec::new();
    for (k, step) in trace.steps.iter().enumerate() {
        f4.check()?;
        let mut piv = vec![NONE; step.ncols];
        let mut store = Vec::with_capacity(step.pivots.len() + step.reduce.len());
        for r in &step.pivots {
            if vals[r.src as usize][0] == 0 {
                return Ok(Err(TraceMismatch));
            }
            piv[r.cols[0] as usize] = store.len() as u32;
            store.push(MatRow {
                cols: r.cols.clone(),
                coefs: vals[r.src as usize].clone(),
                src: r.src,
            });
        }
        let mut acc = vec![0u64; step.ncols];
        last.clear();
        for (r, support) in &step.reduce {
            let row = MatRow {
                cols: r.cols.clone(),
                coefs: vals[r.src as usize].clone(),
                src: r.src,
            };
            let nz = f4.reduce_row(&mut acc, &row, &piv, &store, step.keep_lead, None);
            // The result must lead where the trace's did, and have no term
            // outside the trace's support.
            if nz.first() != support.first() {
                return Ok(Err(TraceMismatch));
            }
            let mut it = support.iter().peekable();
            for &c in &nz {
                while it.next_if(|&&s| s < c).is_some() {}
                if it.next_if_eq(&&c).is_none() {
                    return Ok(Err(TraceMismatch));
                }
            }
            let inv = if step.keep_lead {
                1
            } else {
                inv_mod(acc[nz[0] as usize], p)
            };
            let coefs: Rc<[u32]> = support
                .iter()
                .map(|&c| (std::mem::take(&mut acc[c as usize]) * inv % p) as u32)
                .collect();
            if step.keep_lead {
                // The polynomial's new version (later steps refer to it).
                vals[r.src as usize] = coefs.clone();
                last.push(coefs);
            } else {
                piv[support[0] as usize] = store.len() as u32;
                store.push(MatRow {
                    cols: support.clone(),
                    coefs: coefs.clone(),
                    src: vals.len() as u32,
                });
                vals.push(coefs);
            }
        }
        if let Some(pr) = &opts.progress {
            pr.update(k as u64 + 1, trace.steps.len() as u64);
        }
    }
    let basis: Vec<Rc<[u32]>> = trace.outputs.iter().map(|(k, _)| last[*k].clone()).collect();
    f4.stats.basis_size = basis.len();
    f4.stats.time = f4.start.elapsed();
    Ok(Ok((basis, f4.stats)))
}

/// The coefficients of `f` on `support` (its monomials, decreasing), None
/// if `f` has a term outside it.
fn align(ring: &Ring, f: &Poly<Fp>, support: &[Monomial]) -> Option<Rc<[u32]>> {
    let mut out = vec![0u32; support.len()];
    let mut k = 0;
    for (m, c) in f.terms().iter().filter(|(_, c)| c.value() != 0) {
        while k < support.len() && ring.cmp(&support[k], m) == Ordering::Greater {
            k += 1;
        }
        if k == support.len() || support[k] != *m {
            return None;
        }
        out[k] = c.value() as u32;
        k += 1;
    }
    Some(out.into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groebner::groebner_in;
    use crate::monomial::MonomialOrder;

    fn modp(ring: &Ring, polys: &[Poly<crate::coeff::Rat>], p: u64) -> Vec<Poly<Fp>> {
        polys
            .iter()
            .map(|f| {
                Poly::from_terms(
                    ring,
                    f.terms()
                        .iter()
                        .filter_map(|(m, c)| Fp::from_rat(c, p).map(|c| (m.clone(), c)))
                        .filter(|(_, c)| c.value() != 0)
                        .collect(),
                )
            })
            .collect()
    }

    /// F4 and Buchberger give the same reduced basis, term for term,
    /// modulo 65521: katsura-5 and cyclic-5 in grevlex, katsura-3 in lex
    /// and in an elimination (block) order.
    #[test]
    fn f4_agrees_with_buchberger() {
        let p = 65521;
        let (k5, k5p) = crate::systems::katsura(5);
        let (c5, c5p) = crate::systems::cyclic(5);
        let (k3, k3p) = crate::systems::katsura(3);
        let lex = k3.with_order(MonomialOrder::Lex);
        let block = k3.with_order(MonomialOrder::Block(vec![2, 2]));
        let cases = [
            (k5.clone(), k5p.clone()),
            (c5.clone(), c5p.clone()),
            (lex.clone(), k3p.iter().map(|f| f.reorder(&lex)).collect()),
            (block.clone(), k3p.iter().map(|f| f.reorder(&block)).collect()),
        ];
        for (ring, polys) in cases {
            let fs = modp(&ring, &polys, p);
            let want = groebner_in(&ring, &fs, &GroebnerOptions::default()).unwrap().0;
            let have = f4_modp(&ring, &fs, &GroebnerOptions::default()).unwrap().0;
            let show = |b: &[Poly<Fp>]| b.iter().map(|f| f.display(&ring)).collect::<Vec<_>>();
            assert_eq!(show(&have), show(&want), "{:?}", ring.order());
        }
        // The unit ideal and an empty input.
        let (r, _) = crate::systems::katsura(2);
        let one = modp(
            &r,
            &[
                crate::parse::parse_poly(&r, "x0^2-1").unwrap(),
                crate::parse::parse_poly(&r, "x0").unwrap(),
            ],
            p,
        );
        let b = f4_modp(&r, &one, &GroebnerOptions::default()).unwrap().0;
        assert_eq!(b.len(), 1);
        assert!(b[0].is_constant());
        assert!(f4_modp(&r, &[], &GroebnerOptions::default()).unwrap().0.is_empty());
    }
}
