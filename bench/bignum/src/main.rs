//! Micro-benchmark of arbitrary-precision integer crates for a fraction-free Buchberger engine.
//!
//! Every backend gets the same operands (random odd integers of exactly `bits` bits with random
//! signs, fixed seed) as hexadecimal strings, parses them with its own API, and is timed on:
//!
//! * `mul`      `a * b`                       (both by reference, fresh result)
//! * `add`      `a + b`
//! * `divexact` `(a*b) / b`, the product precomputed, with the crate's exact-division API when it
//!              has one (num-bigint has none: plain truncating `/`)
//! * `div`      the same quotient through the plain truncating `/` operator
//! * `gcd`      `gcd(a, b)`
//! * `fused`    `c1*a - c2*b` with the crate's best idiomatic form (see `fused` in each module)
//! * `clone`    `a.clone()` (plus the drop)
//! * `to_dec` / `parse_dec`: decimal printing and parsing (I/O, informative only)
//!
//! Results are dropped inside the timed loop, so allocation and free are part of every number.
//! Each value is the best of 3 rounds of the median over 5 batches of at least 20 ms each of the
//! benchmark thread's CPU time (`--wall` for wall-clock time instead).
//! The results of every backend are cross-checked (decimal strings) before timing.
//!
//! Usage: `cargo run --release [-- --quick] [--wall] [--sizes 64,256]`

#![cfg_attr(
    not(any(feature = "num", feature = "dashu", feature = "malachite", feature = "rug")),
    allow(unused)
)]

use std::hint::black_box;
use std::time::Instant;

const POOL: usize = 64;

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Op {
    Mul,
    Add,
    DivExact,
    Div,
    Gcd,
    Fused,
    Clone,
    ToDec,
    ParseDec,
}

const OPS: [Op; 9] = [
    Op::Mul,
    Op::Add,
    Op::DivExact,
    Op::Div,
    Op::Gcd,
    Op::Fused,
    Op::Clone,
    Op::ToDec,
    Op::ParseDec,
];

impl Op {
    fn name(self) -> &'static str {
        match self {
            Op::Mul => "mul a*b",
            Op::Add => "add a+b",
            Op::DivExact => "exact div (a*b)/b",
            Op::Div => "plain div (a*b)/b",
            Op::Gcd => "gcd(a,b)",
            Op::Fused => "c1*a - c2*b",
            Op::Clone => "clone",
            Op::ToDec => "to decimal string",
            Op::ParseDec => "parse decimal string",
        }
    }
}

/// Operands as strings: each backend parses them itself.
struct Operands {
    a: Vec<String>,
    b: Vec<String>,
    c1: Vec<String>,
    c2: Vec<String>,
}

struct SplitMix64(u64);
impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

/// A random odd integer of exactly `bits` bits (bits a multiple of 64), random sign, in hex.
fn random_hex(rng: &mut SplitMix64, bits: usize) -> String {
    let limbs = bits / 64;
    let mut words: Vec<u64> = (0..limbs).map(|_| rng.next()).collect();
    words[0] |= 1;
    words[limbs - 1] |= 1 << 63;
    let mut s = String::new();
    if rng.next() & 1 == 1 {
        s.push('-');
    }
    for w in words.iter().rev() {
        s.push_str(&format!("{w:016x}"));
    }
    s
}

fn operands(bits: usize) -> Operands {
    let mut rng = SplitMix64(0x5EED_0000 + bits as u64);
    let mut gen = || (0..crate::POOL).map(|_| random_hex(&mut rng, bits)).collect::<Vec<_>>();
    Operands { a: gen(), b: gen(), c1: gen(), c2: gen() }
}

struct Timer {
    batch_ns: u128,
    batches: usize,
    wall: bool,
}

/// Nanoseconds of CPU time consumed by the calling thread.
fn thread_cpu_ns() -> u128 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: valid pointer to a timespec; CLOCK_THREAD_CPUTIME_ID is supported on Linux.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0);
    ts.tv_sec as u128 * 1_000_000_000 + ts.tv_nsec as u128
}

impl Timer {
    fn now(&self) -> (Instant, u128) {
        (Instant::now(), if self.wall { 0 } else { thread_cpu_ns() })
    }
    fn since(&self, start: (Instant, u128)) -> u128 {
        if self.wall {
            start.0.elapsed().as_nanos()
        } else {
            thread_cpu_ns() - start.1
        }
    }

    /// Median ns per call of `f(i)` (i cycles through the operand pool).
    fn time<R>(&self, mut f: impl FnMut(usize) -> R) -> f64 {
        // Calibrate: grow the iteration count until one batch takes at least batch_ns.
        let mut iters: usize = POOL;
        loop {
            let t = self.now();
            for k in 0..iters {
                black_box(f(black_box(k % POOL)));
            }
            let el = self.since(t);
            if el >= self.batch_ns {
                break;
            }
            iters = if el == 0 {
                iters * 16
            } else {
                (iters as u128 * self.batch_ns * 12 / 10 / el) as usize + POOL
            };
        }
        let mut per: Vec<f64> = (0..self.batches)
            .map(|_| {
                let t = self.now();
                for k in 0..iters {
                    black_box(f(black_box(k % POOL)));
                }
                self.since(t) as f64 / iters as f64
            })
            .collect();
        per.sort_by(|x, y| x.partial_cmp(y).unwrap());
        per[per.len() / 2]
    }
}

/// One backend: parse the operands, self-check, and time each op.
trait Backend {
    const NAME: &'static str;
    /// Decimal strings of [a*b, a+b, divexact, div, gcd, fused, clone] for pool index 0..crate::POOL,
    /// for the cross-check.
    fn check(ops: &Operands) -> Vec<String>;
    fn bench(ops: &Operands, t: &Timer) -> Vec<(Op, f64)>;
}

macro_rules! common_bench {
    ($T:ty, $ops:expr, $t:expr, parse_hex = $parse_hex:expr, parse_dec = $parse_dec:expr,
     mul = $mul:expr, add = $add:expr, divexact = $dx:expr, div = $div:expr, gcd = $gcd:expr,
     fused = $fused:expr, to_dec = $to_dec:expr) => {{
        let ops: &crate::Operands = $ops;
        let t: &crate::Timer = $t;
        let parse_hex: fn(&str) -> $T = $parse_hex;
        let parse_dec: fn(&str) -> $T = $parse_dec;
        let a: Vec<$T> = ops.a.iter().map(|s| parse_hex(s)).collect();
        let b: Vec<$T> = ops.b.iter().map(|s| parse_hex(s)).collect();
        let c1: Vec<$T> = ops.c1.iter().map(|s| parse_hex(s)).collect();
        let c2: Vec<$T> = ops.c2.iter().map(|s| parse_hex(s)).collect();
        let p: Vec<$T> = (0..crate::POOL).map(|i| $mul(&a[i], &b[i])).collect();
        let dec: Vec<String> = a.iter().map(|x| $to_dec(x)).collect();
        let mut out = Vec::new();
        out.push((crate::Op::Mul, t.time(|i| $mul(&a[i], &b[i]))));
        out.push((crate::Op::Add, t.time(|i| $add(&a[i], &b[i]))));
        out.push((crate::Op::DivExact, t.time(|i| $dx(&p[i], &b[i]))));
        out.push((crate::Op::Div, t.time(|i| $div(&p[i], &b[i]))));
        out.push((crate::Op::Gcd, t.time(|i| $gcd(&a[i], &b[i]))));
        out.push((crate::Op::Fused, t.time(|i| $fused(&c1[i], &a[i], &c2[i], &b[i]))));
        out.push((crate::Op::Clone, t.time(|i| a[i].clone())));
        out.push((crate::Op::ToDec, t.time(|i| $to_dec(&a[i]))));
        out.push((crate::Op::ParseDec, t.time(|i| parse_dec(&dec[i]))));
        out
    }};
}

macro_rules! common_check {
    ($T:ty, $ops:expr, parse_hex = $parse_hex:expr, parse_dec = $parse_dec:expr,
     mul = $mul:expr, add = $add:expr, divexact = $dx:expr, div = $div:expr, gcd = $gcd:expr,
     fused = $fused:expr, to_dec = $to_dec:expr) => {{
        let ops: &crate::Operands = $ops;
        let parse_hex: fn(&str) -> $T = $parse_hex;
        let parse_dec: fn(&str) -> $T = $parse_dec;
        let mut v = Vec::new();
        for i in 0..crate::POOL {
            let a = parse_hex(&ops.a[i]);
            let b = parse_hex(&ops.b[i]);
            let c1 = parse_hex(&ops.c1[i]);
            let c2 = parse_hex(&ops.c2[i]);
            let p = $mul(&a, &b);
            v.push($to_dec(&p));
            v.push($to_dec(&$add(&a, &b)));
            let q = $dx(&p, &b);
            v.push(format!("{}", $to_dec(&q) == $to_dec(&a)));
            v.push($to_dec(&$div(&p, &b)));
            v.push(format!("{}", $gcd(&a, &b)));
            v.push($to_dec(&$fused(&c1, &a, &c2, &b)));
            v.push($to_dec(&a.clone()));
            let back = parse_dec(&$to_dec(&a));
            v.push(format!("{}", $to_dec(&back) == $to_dec(&a)));
        }
        v
    }};
}

/// The same closures for `check` and `bench`.
macro_rules! backend {
    ($name:ident, $label:expr, $T:ty, $($k:ident = $e:expr),* $(,)?) => {
        pub struct $name;
        impl crate::Backend for $name {
            const NAME: &'static str = $label;
            fn check(ops: &crate::Operands) -> Vec<String> {
                crate::common_check!($T, ops, $($k = $e),*)
            }
            fn bench(ops: &crate::Operands, t: &crate::Timer) -> Vec<(crate::Op, f64)> {
                crate::common_bench!($T, ops, t, $($k = $e),*)
            }
        }
    };
}
pub(crate) use {backend, common_bench, common_check};

#[cfg(feature = "num")]
mod num_backend {
    use num_bigint::BigInt;
    use num_integer::Integer;
    use num_traits::{Num, ToPrimitive};

    /// Ergonomics probe (compiled, run once): i64 round trip, decimal parse/print.
    pub fn probe() {
        let x = BigInt::from(-42i64);
        assert_eq!(x.to_i64(), Some(-42));
        let y: BigInt = "-123456789012345678901234567890".parse().unwrap();
        assert_eq!(y.to_string(), "-123456789012345678901234567890");
        assert_eq!(y.to_i64(), None);
    }

    crate::backend!(NumBackend, "num-bigint", BigInt,
        parse_hex = |s| BigInt::from_str_radix(s, 16).unwrap(),
        parse_dec = |s| s.parse::<BigInt>().unwrap(),
        mul = |a: &BigInt, b: &BigInt| a * b,
        add = |a: &BigInt, b: &BigInt| a + b,
        // No exact-division API: truncating division.
        divexact = |p: &BigInt, b: &BigInt| p / b,
        div = |p: &BigInt, b: &BigInt| p / b,
        gcd = |a: &BigInt, b: &BigInt| a.gcd(b),
        fused = |c1: &BigInt, a: &BigInt, c2: &BigInt, b: &BigInt| c1 * a - c2 * b,
        to_dec = |x: &BigInt| x.to_string(),
    );
}

#[cfg(feature = "dashu")]
mod dashu_backend {
    use dashu_int::ops::Gcd;
    use dashu_int::IBig;
    use dashu_base::ring::DivExact;

    pub fn probe() {
        let x = IBig::from(-42i64);
        assert_eq!(i64::try_from(&x), Ok(-42));
        let y: IBig = "-123456789012345678901234567890".parse().unwrap();
        assert_eq!(y.to_string(), "-123456789012345678901234567890");
        assert!(i64::try_from(&y).is_err());
    }

    crate::backend!(Dashu, "dashu-int", IBig,
        parse_hex = |s| IBig::from_str_radix(s, 16).unwrap(),
        parse_dec = |s| s.parse::<IBig>().unwrap(),
        mul = |a: &IBig, b: &IBig| a * b,
        add = |a: &IBig, b: &IBig| a + b,
        // DivExact (num-modular's trait) takes the divisor by value (and `&IBig` dividends are cloned
        // inside), so a by-reference call costs two clones.
        divexact = |p: &IBig, b: &IBig| p.div_exact(b.clone(), &()).unwrap(),
        div = |p: &IBig, b: &IBig| p / b,
        gcd = |a: &IBig, b: &IBig| a.gcd(b),
        fused = |c1: &IBig, a: &IBig, c2: &IBig, b: &IBig| c1 * a - c2 * b,
        to_dec = |x: &IBig| x.to_string(),
    );
}

#[cfg(feature = "malachite")]
mod malachite_backend {
    use malachite_base::num::arithmetic::traits::{DivExact, Gcd, MulSubMul};
    use malachite_base::num::conversion::traits::FromStringBase;
    use malachite_nz::integer::Integer;

    pub fn probe() {
        let x = Integer::from(-42i64);
        assert_eq!(i64::try_from(&x), Ok(-42));
        let y: Integer = "-123456789012345678901234567890".parse().unwrap();
        assert_eq!(y.to_string(), "-123456789012345678901234567890");
        assert!(i64::try_from(&y).is_err());
    }

    crate::backend!(Malachite, "malachite-nz", Integer,
        parse_hex = |s| Integer::from_string_base(16, s).unwrap(),
        parse_dec = |s| s.parse::<Integer>().unwrap(),
        mul = |a: &Integer, b: &Integer| a * b,
        add = |a: &Integer, b: &Integer| a + b,
        divexact = |p: &Integer, b: &Integer| p.div_exact(b),
        div = |p: &Integer, b: &Integer| p / b,
        gcd = |a: &Integer, b: &Integer| a.gcd(b),
        // malachite's fused x*y - z*w.
        fused = |c1: &Integer, a: &Integer, c2: &Integer, b: &Integer| c1.mul_sub_mul(a, c2, b),
        to_dec = |x: &Integer| x.to_string(),
    );

    // The plain-operator form of the fused op, for comparison.
    crate::backend!(MalachiteOps, "malachite-nz (c1*a - c2*b via ops)", Integer,
        parse_hex = |s| Integer::from_string_base(16, s).unwrap(),
        parse_dec = |s| s.parse::<Integer>().unwrap(),
        mul = |a: &Integer, b: &Integer| a * b,
        add = |a: &Integer, b: &Integer| a + b,
        divexact = |p: &Integer, b: &Integer| p.div_exact(b),
        div = |p: &Integer, b: &Integer| p / b,
        gcd = |a: &Integer, b: &Integer| a.gcd(b),
        fused = |c1: &Integer, a: &Integer, c2: &Integer, b: &Integer| c1 * a - c2 * b,
        to_dec = |x: &Integer| x.to_string(),
    );
}

#[cfg(feature = "rug")]
mod rug_backend {
    use rug::Integer;

    pub fn probe() {
        let x = Integer::from(-42i64);
        assert_eq!(x.to_i64(), Some(-42));
        let y: Integer = "-123456789012345678901234567890".parse().unwrap();
        assert_eq!(y.to_string(), "-123456789012345678901234567890");
        assert_eq!(y.to_i64(), None);
    }

    crate::backend!(Rug, "rug (GMP)", Integer,
        parse_hex = |s| Integer::from_str_radix(s, 16).unwrap(),
        parse_dec = |s| s.parse::<Integer>().unwrap(),
        mul = |a: &Integer, b: &Integer| Integer::from(a * b),
        add = |a: &Integer, b: &Integer| Integer::from(a + b),
        divexact = |p: &Integer, b: &Integer| Integer::from(p.div_exact_ref(b)),
        div = |p: &Integer, b: &Integer| Integer::from(p / b),
        gcd = |a: &Integer, b: &Integer| Integer::from(a.gcd_ref(b)),
        // mpz_mul then mpz_submul into the same buffer.
        fused = |c1: &Integer, a: &Integer, c2: &Integer, b: &Integer| {
            let mut r = Integer::from(c1 * a);
            r -= c2 * b;
            r
        },
        to_dec = |x: &Integer| x.to_string(),
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let mut sizes = vec![64usize, 256, 1024, 4096];
    if let Some(pos) = args.iter().position(|a| a == "--sizes") {
        sizes = args[pos + 1].split(',').map(|s| s.parse().expect("sizes")).collect();
    }
    // Thread CPU time by default (robust on a shared machine); --wall for wall-clock time.
    let wall = args.iter().any(|a| a == "--wall");
    let (timer, rounds) = if quick {
        (Timer { batch_ns: 5_000_000, batches: 3, wall }, 1)
    } else {
        (Timer { batch_ns: 20_000_000, batches: 5, wall }, 3)
    };

    type CheckFn = fn(&Operands) -> Vec<String>;
    type BenchFn = fn(&Operands, &Timer) -> Vec<(Op, f64)>;
    let mut backends: Vec<(&str, CheckFn, BenchFn)> = Vec::new();
    macro_rules! reg {
        ($B:ty, $probe:path) => {{
            $probe();
            backends.push((<$B as Backend>::NAME, <$B>::check, <$B>::bench));
        }};
    }
    #[cfg(feature = "num")]
    reg!(num_backend::NumBackend, num_backend::probe);
    #[cfg(feature = "dashu")]
    reg!(dashu_backend::Dashu, dashu_backend::probe);
    #[cfg(feature = "malachite")]
    reg!(malachite_backend::Malachite, malachite_backend::probe);
    #[cfg(feature = "rug")]
    reg!(rug_backend::Rug, rug_backend::probe);
    #[cfg(feature = "malachite")]
    reg!(malachite_backend::MalachiteOps, malachite_backend::probe);
    assert!(!backends.is_empty(), "enable at least one backend feature");

    // Cross-check every backend against the first on every size.
    for &bits in &sizes {
        let ops = operands(bits);
        let reference = (backends[0].1)(&ops);
        assert!(reference.iter().all(|s| s != "false"), "{} self-check failed", backends[0].0);
        for (name, check, _) in &backends[1..] {
            let got = check(&ops);
            assert_eq!(got, reference, "{name} disagrees with {} at {bits} bits", backends[0].0);
        }
    }
    eprintln!("cross-check ok: {} backends agree on all ops and sizes", backends.len());

    // results[size][backend] = Vec<(Op, ns)>: the minimum over `rounds` full rounds of each
    // round's median, so a burst of load from other processes spoils at most one round of a cell.
    let mut results: Vec<Vec<Vec<(Op, f64)>>> = Vec::new();
    for round in 0..rounds {
        for (si, &bits) in sizes.iter().enumerate() {
            let ops = operands(bits);
            if round == 0 {
                results.push(Vec::new());
            }
            for (bi, (name, _, bench)) in backends.iter().enumerate() {
                eprintln!("round {}/{rounds}: timing {name} at {bits} bits ...", round + 1);
                let r = bench(&ops, &timer);
                if round == 0 {
                    results[si].push(r);
                } else {
                    for (cell, (_, v)) in results[si][bi].iter_mut().zip(r) {
                        cell.1 = cell.1.min(v);
                    }
                }
            }
        }
    }

    println!(
        "ns per operation ({} time; best of {} rounds of the median of {} batches of >= {} ms; \
         results dropped inside the loop)\n",
        if timer.wall { "wall-clock" } else { "thread CPU" },
        rounds,
        timer.batches,
        timer.batch_ns / 1_000_000
    );
    print!("| op | bits |");
    for (name, _, _) in &backends {
        print!(" {name} |");
    }
    println!();
    print!("|---|---:|");
    for _ in &backends {
        print!("---:|");
    }
    println!();
    for op in OPS {
        for (si, &bits) in sizes.iter().enumerate() {
            let vals: Vec<f64> = results[si]
                .iter()
                .map(|r| r.iter().find(|(o, _)| *o == op).unwrap().1)
                .collect();
            // Best among the main backends (the "via ops" column is a malachite variant).
            let best = vals
                .iter()
                .zip(&backends)
                .filter(|(_, (name, _, _))| !name.contains("via ops"))
                .map(|(v, _)| *v)
                .fold(f64::INFINITY, f64::min);
            print!("| {} | {bits} |", op.name());
            for v in &vals {
                let cell = fmt_ns(*v);
                if *v == best {
                    print!(" **{cell}** |");
                } else {
                    print!(" {cell} |");
                }
            }
            println!();
        }
    }
}

fn fmt_ns(v: f64) -> String {
    if v < 10.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.0}")
    }
}
