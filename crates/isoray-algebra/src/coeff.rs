//! Coefficient domains: the integers Z (for fraction-free computation), the
//! rationals Q, and prime fields GF(p) for word-size primes.
//!
//! The arithmetic sits behind the small [`Coeff`] trait so that the bignum
//! crate can change; all big-integer use goes through the [`Int`] alias.

use std::fmt::{Debug, Display};

use num_integer::Integer as _;
use num_traits::{One, Signed, ToPrimitive, Zero};

/// The arbitrary-precision integer type.
pub type Int = num_bigint::BigInt;
/// Rational numbers over [`Int`].
pub type Rat = num_rational::BigRational;

/// Coefficients of polynomials. Constructors take an existing element
/// (`*_like`) so that elements of GF(p) can carry their modulus.
pub trait Coeff: Clone + PartialEq + Eq + Debug + Display + Send + Sync + 'static {
    /// 0 in the same domain as `self`.
    fn zero_like(&self) -> Self;
    /// 1 in the same domain as `self`.
    fn one_like(&self) -> Self;
    /// An integer in the same domain as `self`.
    fn int_like(&self, v: i64) -> Self;
    /// True for 0.
    fn is_zero(&self) -> bool;
    /// True for 1.
    fn is_one(&self) -> bool;
    /// self + o
    fn add(&self, o: &Self) -> Self;
    /// self − o
    fn sub(&self, o: &Self) -> Self;
    /// self · o
    fn mul(&self, o: &Self) -> Self;
    /// −self
    fn neg(&self) -> Self;
    /// True when the printed form starts with a minus sign.
    fn is_negative(&self) -> bool;
    /// Size in bits of the magnitude (0 where that means nothing, as in GF(p)).
    fn bit_len(&self) -> usize {
        0
    }
}

/// Domains that Buchberger's algorithm runs over: fields, and Z in
/// fraction-free form.
pub trait Domain: Coeff {
    /// True for Z: coefficients grow during reduction and contents are removed.
    const FRACTION_FREE: bool = false;
    /// Multipliers (a, b), a ≠ 0, with a·c = b·d: reducing a term with
    /// coefficient c by a leading coefficient d computes a·f − b·m·g.
    fn cancel(c: &Self, d: &Self) -> (Self, Self);
    /// Normalises a polynomial's coefficients in place (leading first): monic
    /// over a field, primitive with a positive leading coefficient over Z.
    fn normalize(coeffs: &mut [Self]);
}

/// Fields: every nonzero element has an inverse.
pub trait Field: Coeff {
    /// 1 / self. Undefined for 0 (returns 0).
    fn inv(&self) -> Self;
    /// self / o.
    fn div(&self, o: &Self) -> Self {
        self.mul(&o.inv())
    }
}

/// The ring operations of [`Coeff`] for types whose references implement the
/// arithmetic operators (the big integers and rationals).
macro_rules! operator_arithmetic {
    () => {
        fn add(&self, o: &Self) -> Self {
            self + o
        }
        fn sub(&self, o: &Self) -> Self {
            self - o
        }
        fn mul(&self, o: &Self) -> Self {
            self * o
        }
        fn neg(&self) -> Self {
            -self
        }
    };
}

impl Coeff for Int {
    fn zero_like(&self) -> Self {
        Int::zero()
    }
    fn one_like(&self) -> Self {
        Int::one()
    }
    fn int_like(&self, v: i64) -> Self {
        Int::from(v)
    }
    fn is_zero(&self) -> bool {
        Zero::is_zero(self)
    }
    fn is_one(&self) -> bool {
        One::is_one(self)
    }
    operator_arithmetic!();
    fn is_negative(&self) -> bool {
        Signed::is_negative(self)
    }
}

impl Domain for Int {
    const FRACTION_FREE: bool = true;
    fn cancel(c: &Self, d: &Self) -> (Self, Self) {
        let g = c.gcd(d);
        let (mut a, mut b) = (d / &g, c / &g);
        if Signed::is_negative(&a) {
            a = -a;
            b = -b;
        }
        (a, b)
    }
    fn normalize(coeffs: &mut [Self]) {
        let Some(first) = coeffs.first() else { return };
        let mut g = Int::zero();
        for c in coeffs.iter() {
            g = g.gcd(c);
            if One::is_one(&g) {
                break;
            }
        }
        let neg = Signed::is_negative(first);
        if One::is_one(&g) && !neg {
            return;
        }
        if neg {
            g = -g;
        }
        for c in coeffs.iter_mut() {
            *c = &*c / &g;
        }
    }
}

impl Coeff for Rat {
    fn zero_like(&self) -> Self {
        Rat::zero()
    }
    fn one_like(&self) -> Self {
        Rat::one()
    }
    fn int_like(&self, v: i64) -> Self {
        Rat::from_integer(Int::from(v))
    }
    fn is_zero(&self) -> bool {
        Zero::is_zero(self)
    }
    fn is_one(&self) -> bool {
        One::is_one(self)
    }
    operator_arithmetic!();
    fn is_negative(&self) -> bool {
        Signed::is_negative(self)
    }
}

impl Field for Rat {
    fn inv(&self) -> Self {
        if Zero::is_zero(self) {
            Rat::zero()
        } else {
            self.recip()
        }
    }
}

impl Domain for Rat {
    fn cancel(c: &Self, d: &Self) -> (Self, Self) {
        if One::is_one(d) {
            return (Rat::one(), c.clone());
        }
        (Rat::one(), c / d)
    }
    fn normalize(coeffs: &mut [Self]) {
        let Some(first) = coeffs.first() else { return };
        if One::is_one(first) {
            return;
        }
        let inv = first.recip();
        for c in coeffs.iter_mut() {
            *c = &*c * &inv;
        }
    }
}

/// An element of GF(p) for a prime p < 2⁶³, carrying its modulus.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Fp {
    v: u64,
    p: u64,
}

impl Fp {
    /// v mod p.
    pub fn new(v: i64, p: u64) -> Fp {
        Fp {
            v: (v as i128).rem_euclid(p as i128) as u64,
            p,
        }
    }
    /// The representative in 0..p.
    pub fn value(&self) -> u64 {
        self.v
    }
    /// The modulus.
    pub fn modulus(&self) -> u64 {
        self.p
    }
    /// The image of a rational number, if its denominator is invertible mod p.
    pub fn from_rat(r: &Rat, p: u64) -> Option<Fp> {
        let pm = Int::from(p);
        let n = r.numer().mod_floor(&pm).to_u64()?;
        let d = r.denom().mod_floor(&pm).to_u64()?;
        if d == 0 {
            return None;
        }
        Some(Fp { v: n, p }.mul(&Fp { v: d, p }.inv()))
    }
    fn pow(&self, mut e: u64) -> Fp {
        let mut base = *self;
        let mut acc = Fp {
            v: 1 % self.p.max(1),
            p: self.p,
        };
        while e > 0 {
            if e & 1 == 1 {
                acc = acc.mul(&base);
            }
            base = base.mul(&base);
            e >>= 1;
        }
        acc
    }
}

impl Debug for Fp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} (mod {})", self.v, self.p)
    }
}

impl Display for Fp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.v)
    }
}

impl Coeff for Fp {
    fn zero_like(&self) -> Self {
        Fp { v: 0, p: self.p }
    }
    fn one_like(&self) -> Self {
        Fp { v: 1, p: self.p }
    }
    fn int_like(&self, v: i64) -> Self {
        Fp::new(v, self.p)
    }
    fn is_zero(&self) -> bool {
        self.v == 0
    }
    fn is_one(&self) -> bool {
        self.v == 1
    }
    fn add(&self, o: &Self) -> Self {
        // Both below p < 2^63: the sum fits in u64.
        let s = self.v + o.v;
        Fp {
            v: if s >= self.p { s - self.p } else { s },
            p: self.p,
        }
    }
    fn sub(&self, o: &Self) -> Self {
        Fp {
            v: if self.v >= o.v {
                self.v - o.v
            } else {
                self.v + (self.p - o.v)
            },
            p: self.p,
        }
    }
    fn mul(&self, o: &Self) -> Self {
        // Word-size primes below 2^32 multiply in u64; larger ones in u128.
        let v = if self.p <= 1 << 32 {
            (self.v * o.v) % self.p
        } else {
            ((self.v as u128 * o.v as u128) % self.p as u128) as u64
        };
        Fp { v, p: self.p }
    }
    fn neg(&self) -> Self {
        Fp {
            v: if self.v == 0 { 0 } else { self.p - self.v },
            p: self.p,
        }
    }
    fn is_negative(&self) -> bool {
        false
    }
}

impl Field for Fp {
    fn inv(&self) -> Self {
        // Fermat: a^(p-2).
        if self.v == 0 {
            return *self;
        }
        self.pow(self.p - 2)
    }
}

impl Domain for Fp {
    fn cancel(c: &Self, d: &Self) -> (Self, Self) {
        // Basis elements are monic: no inversion needed then.
        if d.is_one() {
            return (c.one_like(), *c);
        }
        (c.one_like(), c.div(d))
    }
    fn normalize(coeffs: &mut [Self]) {
        let Some(first) = coeffs.first() else { return };
        if first.is_one() {
            return;
        }
        let inv = first.inv();
        for c in coeffs.iter_mut() {
            *c = c.mul(&inv);
        }
    }
}

/// True when `p` is prime (deterministic Miller–Rabin for 64-bit integers).
pub fn is_prime(p: u64) -> bool {
    if p < 2 {
        return false;
    }
    for q in [2u64, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37] {
        if p % q == 0 {
            return p == q;
        }
    }
    let (mut d, mut s) = (p - 1, 0);
    while d % 2 == 0 {
        d /= 2;
        s += 1;
    }
    let mulmod = |a: u64, b: u64| ((a as u128 * b as u128) % p as u128) as u64;
    let powmod = |mut b: u64, mut e: u64| {
        let mut r = 1u64;
        while e > 0 {
            if e & 1 == 1 {
                r = mulmod(r, b);
            }
            b = mulmod(b, b);
            e >>= 1;
        }
        r
    };
    'witness: for a in [2u64, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37] {
        let mut x = powmod(a, d);
        if x == 1 || x == p - 1 {
            continue;
        }
        for _ in 1..s {
            x = mulmod(x, x);
            if x == p - 1 {
                continue 'witness;
            }
        }
        return false;
    }
    true
}

/// The fast integer type of the fraction-free Gröbner engine (dashu's
/// `IBig`, chosen by measurement: see `bench/bignum/RESULTS.md`; values up to
/// 128 bits live inline without allocation).
pub type ZInt = dashu_int::IBig;

impl Coeff for ZInt {
    fn zero_like(&self) -> Self {
        ZInt::ZERO
    }
    fn one_like(&self) -> Self {
        ZInt::ONE
    }
    fn int_like(&self, v: i64) -> Self {
        ZInt::from(v)
    }
    fn is_zero(&self) -> bool {
        ZInt::is_zero(self)
    }
    fn is_one(&self) -> bool {
        ZInt::is_one(self)
    }
    operator_arithmetic!();
    fn is_negative(&self) -> bool {
        self < &ZInt::ZERO
    }
    fn bit_len(&self) -> usize {
        use dashu_base::{BitTest, UnsignedAbs};
        self.unsigned_abs().bit_len()
    }
}

impl Domain for ZInt {
    const FRACTION_FREE: bool = true;
    fn cancel(c: &Self, d: &Self) -> (Self, Self) {
        use dashu_base::Gcd;
        let g = ZInt::from(c.gcd(d));
        let (mut a, mut b) = (d / &g, c / &g);
        if a < ZInt::ZERO {
            a = -a;
            b = -b;
        }
        (a, b)
    }
    fn normalize(coeffs: &mut [Self]) {
        use dashu_base::Gcd;
        let Some(first) = coeffs.first() else { return };
        let neg = first < &ZInt::ZERO;
        let mut g = dashu_int::UBig::ZERO;
        for c in coeffs.iter() {
            g = (&g).gcd(c);
            if g.is_one() {
                break;
            }
        }
        if g.is_one() && !neg {
            return;
        }
        let mut g = ZInt::from(g);
        if neg {
            g = -g;
        }
        for c in coeffs.iter_mut() {
            *c = &*c / &g;
        }
    }
}

/// Converts between the two integer types (at the boundaries of the engine).
pub fn to_zint(x: &Int) -> ZInt {
    let (sign, bytes) = x.to_bytes_le();
    let mag = ZInt::from(dashu_int::UBig::from_le_bytes(&bytes));
    if sign == num_bigint::Sign::Minus {
        -mag
    } else {
        mag
    }
}

/// Converts a [`ZInt`] back to [`Int`].
pub fn from_zint(x: &ZInt) -> Int {
    let neg = x < &ZInt::ZERO;
    let mag = dashu_int::UBig::try_from(if neg { -x } else { x.clone() }).unwrap_or(dashu_int::UBig::ZERO);
    let n = Int::from_bytes_le(num_bigint::Sign::Plus, &mag.to_le_bytes());
    if neg {
        -n
    } else {
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prime_field() {
        let p = 1_000_000_007;
        let a = Fp::new(-3, p);
        assert_eq!(a.value(), p - 3);
        assert!(a.mul(&a.inv()).is_one());
        let r = Rat::new(Int::from(1), Int::from(3));
        let t = Fp::from_rat(&r, p).unwrap();
        assert!(t.mul(&Fp::new(3, p)).is_one());
        assert!(Fp::from_rat(&Rat::new(Int::from(1), Int::from(7)), 7).is_none());
        assert!(is_prime(p) && is_prime(2) && is_prime(9_223_372_036_854_775_783) && !is_prime(1) && !is_prime(561));
    }

    #[test]
    fn fraction_free_cancel() {
        let (a, b) = Int::cancel(&Int::from(6), &Int::from(-4));
        // a*6 = b*(-4) with a > 0 and no common factor.
        assert_eq!((a.clone(), b.clone()), (Int::from(2), Int::from(-3)));
        let mut cs = vec![Int::from(-4), Int::from(6), Int::from(10)];
        Int::normalize(&mut cs);
        assert_eq!(cs, vec![Int::from(2), Int::from(-3), Int::from(-5)]);
    }
}
