//! Gröbner bases over word-size prime fields by Faugère's F4 (1999): the
//! S-pairs of lowest degree are reduced together as the rows of one
//! Macaulay matrix built by symbolic preprocessing, reduced by its known
//! pivots with a dense accumulator, and echelonized; its rows with new
//! leading monomials join the basis. Pairs are installed with Gebauer and
//! Möller's criteria (the product criterion, the chain criterion in its
//! M, F and B_k forms), as in [`crate::groebner`].
//!
//! Monomials live in a hash table and rows refer to them by index, so the
//! matrix's columns are sorted once per round; coefficients are `u32`
//! residues with arithmetic in `u64`.
//!
//! This is the first stage of issue 18 (the engine over GF(p); multi-modular
//! lifting over Q and the trace come next). It returns the reduced basis,
//! monic, by increasing leading monomial, as [`crate::groebner_in`] does.

use std::cmp::Ordering;
use std::collections::HashMap;

use crate::coeff::Fp;
use crate::monomial::Monomial;
use crate::poly::{Poly, Ring};

/// The monomials met so far, by index.
struct Table {
    monos: Vec<Monomial>,
    index: HashMap<Monomial, u32>,
}

impl Table {
    fn new() -> Table {
        Table {
            monos: Vec::new(),
            index: HashMap::new(),
        }
    }
    fn id(&mut self, m: Monomial) -> u32 {
        if let Some(&k) = self.index.get(&m) {
            return k;
        }
        let k = self.monos.len() as u32;
        self.monos.push(m.clone());
        self.index.insert(m, k);
        k
    }
}

/// A polynomial: its monomials (table indices) from the leading one down, and
/// their coefficients in 0..p.
#[derive(Clone, Debug)]
struct Row {
    mons: Vec<u32>,
    coefs: Vec<u32>,
}

/// A critical pair: basis elements i < j and the lcm of their leading monomials.
#[derive(Clone, Debug)]
struct Pair {
    i: usize,
    j: usize,
    lcm: Monomial,
}

fn inv_mod(a: u64, p: u64) -> u64 {
    // a^(p−2) mod p.
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

/// The state of an F4 run.
struct F4<'r> {
    ring: &'r Ring,
    p: u64,
    table: Table,
    basis: Vec<Row>,
    /// Leading monomial of each basis element.
    lead: Vec<Monomial>,
    /// Whether an element is still in the basis (not made redundant).
    alive: Vec<bool>,
    pairs: Vec<Pair>,
}

impl<'r> F4<'r> {
    fn cmp(&self, a: u32, b: u32) -> Ordering {
        self.ring
            .cmp(&self.table.monos[a as usize], &self.table.monos[b as usize])
    }

    /// Row of m·g for basis element g.
    fn multiple(&mut self, m: &Monomial, g: usize) -> Row {
        let mons = self.basis[g]
            .mons
            .clone()
            .into_iter()
            .map(|k| {
                let prod = self.table.monos[k as usize].mul(m);
                self.table.id(prod)
            })
            .collect();
        Row {
            mons,
            coefs: self.basis[g].coefs.clone(),
        }
    }

    /// Adds `row` (monic, nonzero) to the basis and updates the pairs by
    /// Gebauer and Möller's criteria.
    fn insert(&mut self, row: Row) {
        let h = self.basis.len();
        let lh = self.table.monos[row.mons[0] as usize].clone();
        // New pairs (h, g), pruned by the chain criterion among themselves
        // (keep a pair unless another new pair's lcm properly divides its
        // lcm), then by the product criterion.
        let cand: Vec<(usize, Monomial)> = (0..h)
            .filter(|&g| self.alive[g])
            .map(|g| (g, self.lead[g].lcm(&lh)))
            .collect();
        let mut keep: Vec<(usize, Monomial)> = Vec::new();
        for (k, (g, l)) in cand.iter().enumerate() {
            let coprime = self.lead[*g].coprime(&lh);
            let dominated = cand
                .iter()
                .enumerate()
                .any(|(k2, (_, l2))| k2 != k && l2.divides(l) && (l2 != l || k2 < k));
            if coprime || !dominated {
                keep.push((*g, l.clone()));
            }
        }
        let new_pairs: Vec<Pair> = keep
            .into_iter()
            .filter(|(g, _)| !self.lead[*g].coprime(&lh))
            .map(|(g, l)| Pair { i: g, j: h, lcm: l })
            .collect();
        // Old pairs (i, j) go when lm(h) divides their lcm strictly inside
        // (B_k: lcm(i, h) and lcm(j, h) both differ from lcm(i, j)).
        let lead = &self.lead;
        self.pairs
            .retain(|q| !(lh.divides(&q.lcm) && lead[q.i].lcm(&lh) != q.lcm && lead[q.j].lcm(&lh) != q.lcm));
        self.pairs.extend(new_pairs);
        // Elements whose leading monomial lm(h) divides are redundant.
        for g in 0..h {
            if self.alive[g] && lh.divides(&self.lead[g]) {
                self.alive[g] = false;
            }
        }
        self.basis.push(row);
        self.lead.push(lh);
        self.alive.push(true);
    }

    /// Symbolic preprocessing: the rows `rows` and, for every monomial in
    /// them divisible by a leading monomial of the basis, a reducer row
    /// (a multiple of a basis element with that leading monomial); returns
    /// the reducers.
    /// With `leads` false the rows' own leading monomials get no reducer
    /// (they are the matrix's new pivots or known to be irreducible).
    fn preprocess(&mut self, rows: &[Row], leads: bool) -> Vec<Row> {
        let skip = usize::from(!leads);
        let mut done: std::collections::HashSet<u32> = std::collections::HashSet::new();
        if !leads {
            done.extend(rows.iter().map(|r| r.mons[0]));
        }
        let mut todo: Vec<u32> = rows.iter().flat_map(|r| r.mons[skip..].iter().copied()).collect();
        let mut reducers = Vec::new();
        while let Some(m) = todo.pop() {
            if !done.insert(m) {
                continue;
            }
            let mono = self.table.monos[m as usize].clone();
            // The first alive element whose leading monomial divides m.
            let found = (0..self.basis.len()).find(|&g| self.alive[g] && self.lead[g].divides(&mono));
            if let Some(g) = found {
                let q = self.lead[g].quotient(&mono).expect("divides");
                let r = self.multiple(&q, g);
                todo.extend(r.mons[1..].iter().copied());
                reducers.push(r);
            }
        }
        reducers
    }

    /// Reduces `rows` by the pivots (`pivots[c]`: the row whose leading
    /// monomial is column c) and by each other (echelon form): returns the
    /// nonzero results, monic, each with a leading monomial no pivot has.
    /// Columns are the table indices in `order` (descending monomials).
    fn reduce(&self, order: &[u32], pivots: &mut HashMap<u32, Row>, rows: Vec<Row>) -> Vec<Row> {
        let p = self.p;
        let col_of: HashMap<u32, usize> = order.iter().enumerate().map(|(c, &m)| (m, c)).collect();
        let mut acc = vec![0u64; order.len()];
        let mut out = Vec::new();
        for row in rows {
            for (&m, &c) in row.mons.iter().zip(&row.coefs) {
                acc[col_of[&m]] = c as u64;
            }
            let first = col_of[&row.mons[0]];
            let mut lead: Option<usize> = None;
            for c in first..order.len() {
                let v = acc[c] % p;
                acc[c] = v;
                if v == 0 {
                    continue;
                }
                match pivots.get(&order[c]) {
                    Some(piv) => {
                        // acc −= v·piv (piv is monic: its leading term cancels).
                        let f = p - v;
                        for (&m, &pc) in piv.mons.iter().zip(&piv.coefs) {
                            let k = col_of[&m];
                            acc[k] = (acc[k] + f * pc as u64) % p;
                        }
                    }
                    None => {
                        if lead.is_none() {
                            lead = Some(c);
                        }
                    }
                }
            }
            if let Some(l) = lead {
                let inv = inv_mod(acc[l], p);
                let mut r = Row {
                    mons: Vec::new(),
                    coefs: Vec::new(),
                };
                for (c, a) in acc.iter_mut().enumerate().skip(l) {
                    if *a != 0 {
                        r.mons.push(order[c]);
                        r.coefs.push((*a * inv % p) as u32);
                        *a = 0;
                    }
                }
                pivots.insert(order[l], r.clone());
                out.push(r);
            }
        }
        out
    }

    /// The full normal form of `row` by the basis, monic, or `None` if it is 0.
    fn normal_form(&mut self, row: Row) -> Option<Row> {
        let reducers = self.preprocess(std::slice::from_ref(&row), true);
        let all: Vec<&Row> = std::iter::once(&row).chain(&reducers).collect();
        let order = self.columns(&all);
        let mut pivots = self.pivots(reducers);
        self.reduce(&order, &mut pivots, vec![row]).pop()
    }

    /// The rows made monic, keyed by leading monomial (the first row with a
    /// given leading monomial wins).
    fn pivots(&self, rows: Vec<Row>) -> HashMap<u32, Row> {
        let mut pivots = HashMap::new();
        for r in rows {
            let inv = inv_mod(r.coefs[0] as u64, self.p);
            let coefs = r.coefs.iter().map(|&c| (c as u64 * inv % self.p) as u32).collect();
            pivots.entry(r.mons[0]).or_insert(Row { mons: r.mons, coefs });
        }
        pivots
    }

    /// The columns of `rows` (all their monomials), in descending order.
    fn columns(&self, rows: &[&Row]) -> Vec<u32> {
        let mut cols: Vec<u32> = rows.iter().flat_map(|r| r.mons.iter().copied()).collect();
        cols.sort_unstable();
        cols.dedup();
        cols.sort_by(|&a, &b| self.cmp(b, a));
        cols
    }

    fn run(&mut self) {
        while !self.pairs.is_empty() {
            // The pairs of lowest degree.
            let d = self.pairs.iter().map(|q| q.lcm.degree()).min().expect("pairs");
            let (now, later): (Vec<Pair>, Vec<Pair>) = self.pairs.drain(..).partition(|q| q.lcm.degree() == d);
            self.pairs = later;
            // Both halves of each pair; one row per (multiplier, element).
            let mut seen = std::collections::HashSet::new();
            let mut rows = Vec::new();
            for q in &now {
                for g in [q.i, q.j] {
                    let m = self.lead[g].quotient(&q.lcm).expect("lcm");
                    if seen.insert((g, m.clone())) {
                        rows.push(self.multiple(&m, g));
                    }
                }
            }
            let reducers = self.preprocess(&rows, false);
            let all: Vec<&Row> = rows.iter().chain(&reducers).collect();
            let order = self.columns(&all);
            // A pivot per leading column: reducers first, then pair rows.
            let mut pivots: HashMap<u32, Row> = HashMap::new();
            let mut rest = Vec::new();
            for r in reducers.into_iter().chain(rows) {
                if let std::collections::hash_map::Entry::Vacant(e) = pivots.entry(r.mons[0]) {
                    let inv = inv_mod(r.coefs[0] as u64, self.p);
                    let coefs = r.coefs.iter().map(|&c| (c as u64 * inv % self.p) as u32).collect();
                    e.insert(Row { mons: r.mons, coefs });
                } else {
                    rest.push(r);
                }
            }
            let new = self.reduce(&order, &mut pivots, rest);
            for r in new {
                self.insert(r);
            }
        }
    }

    /// The reduced basis: the alive elements, each tail reduced by the others.
    fn reduced(mut self) -> Vec<Row> {
        let alive: Vec<usize> = (0..self.basis.len()).filter(|&g| self.alive[g]).collect();
        let mut out = Vec::new();
        for &g in &alive {
            let row = self.basis[g].clone();
            // Reducers for the tail (never g itself: its leading monomial is not in its tail).
            if row.mons.len() == 1 {
                out.push(row);
                continue;
            }
            let reducers = self.preprocess(std::slice::from_ref(&row), false);
            let all: Vec<&Row> = std::iter::once(&row).chain(&reducers).collect();
            let order = self.columns(&all);
            let mut pivots = self.pivots(reducers);
            let mut reduced = self.reduce(&order, &mut pivots, vec![row]);
            out.push(reduced.pop().expect("a basis element does not reduce to zero"));
        }
        out
    }
}

/// The reduced Gröbner basis of `polys` over GF(p) (p < 2³¹) by F4: monic
/// elements by increasing leading monomial.
pub fn f4_modp(ring: &Ring, polys: &[Poly<Fp>]) -> Vec<Poly<Fp>> {
    let Some(p) = polys.iter().flat_map(|f| f.terms()).map(|(_, c)| c.modulus()).next() else {
        return Vec::new();
    };
    assert!(p < 1 << 31, "F4 here works modulo primes below 2³¹");
    let mut f4 = F4 {
        ring,
        p,
        table: Table::new(),
        basis: Vec::new(),
        lead: Vec::new(),
        alive: Vec::new(),
        pairs: Vec::new(),
    };
    // The inputs, inter-reduced by one matrix so that they enter with
    // distinct leading monomials.
    let mut rows: Vec<Row> = Vec::new();
    for f in polys {
        let mut terms: Vec<(Monomial, u64)> = f
            .terms()
            .iter()
            .map(|(m, c)| (m.clone(), c.value()))
            .filter(|(_, c)| *c != 0)
            .collect();
        if terms.is_empty() {
            continue;
        }
        terms.sort_by(|a, b| ring.cmp(&b.0, &a.0));
        let mons = terms.iter().map(|(m, _)| f4.table.id(m.clone())).collect();
        rows.push(Row {
            mons,
            coefs: terms.iter().map(|(_, c)| *c as u32).collect(),
        });
    }
    // The inputs by increasing leading monomial, each reduced by the basis
    // so far, so that no element's leading monomial divides another's.
    rows.sort_by(|a, b| f4.cmp(a.mons[0], b.mons[0]));
    for row in rows {
        if let Some(r) = f4.normal_form(row) {
            f4.insert(r);
        }
    }
    f4.run();
    let ring_p = p;
    let table_monos = f4.table.monos.clone();
    let mut out: Vec<Poly<Fp>> = f4
        .reduced()
        .into_iter()
        .map(|r| {
            Poly::from_sorted(
                r.mons
                    .iter()
                    .zip(&r.coefs)
                    .map(|(&m, &c)| (table_monos[m as usize].clone(), Fp::new(c as i64, ring_p)))
                    .collect(),
            )
        })
        .collect();
    out.sort_by(|a, b| ring.cmp(a.lm().expect("nonzero"), b.lm().expect("nonzero")));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groebner::{groebner_in, GroebnerOptions};
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
            let have = f4_modp(&ring, &fs);
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
        let b = f4_modp(&r, &one);
        assert_eq!(b.len(), 1);
        assert!(b[0].is_constant());
        assert!(f4_modp(&r, &[]).is_empty());
    }
}
