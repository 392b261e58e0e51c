//! Exact arithmetic on single-precision inputs, for the arbiter.
//!
//! Every finite `f32` is an integer multiple of `2^-149` (the smallest
//! subnormal), so [`fixed`] maps it exactly to a [`BigInt`] in those units.
//! Differences, cross and dot products of such integers are exact, so every
//! quantity of a ray/triangle test (edge volumes, `t` as a fraction) is
//! computed without rounding. A sphere's hit distance is a root of a quadratic
//! and is kept exactly as `(p + q sqrt(d)) / m` ([`ExactT`]); comparisons of
//! such numbers reduce to signs of `a + b sqrt(d)` decided by squaring.

use std::cmp::Ordering;

use num_bigint::{BigInt, Sign};
use num_traits::{Signed, ToPrimitive, Zero};

/// A 3-vector of exact integers (units of `2^-149`).
pub type BigVec = [BigInt; 3];

/// The exact value of `x` in units of `2^-149` (`x` finite).
pub fn fixed(x: f32) -> BigInt {
    debug_assert!(x.is_finite());
    let bits = x.to_bits();
    let exp = ((bits >> 23) & 0xff) as usize;
    let frac = bits & 0x7f_ffff;
    // Normal: (2^23 + frac) 2^(exp - 150) = (2^23 + frac) 2^(exp - 1) units; subnormal: frac units.
    let v = if exp == 0 { BigInt::from(frac) } else { BigInt::from(frac | 0x80_0000) << (exp - 1) };
    if bits >> 31 == 1 { -v } else { v }
}

/// [`fixed`] of each component.
pub fn fixed3(v: glam::Vec3) -> BigVec {
    [fixed(v.x), fixed(v.y), fixed(v.z)]
}

/// `a - b`.
pub fn sub(a: &BigVec, b: &BigVec) -> BigVec {
    [&a[0] - &b[0], &a[1] - &b[1], &a[2] - &b[2]]
}

/// `a x b`.
pub fn cross(a: &BigVec, b: &BigVec) -> BigVec {
    [&a[1] * &b[2] - &a[2] * &b[1], &a[2] * &b[0] - &a[0] * &b[2], &a[0] * &b[1] - &a[1] * &b[0]]
}

/// `a . b`.
pub fn dot(a: &BigVec, b: &BigVec) -> BigInt {
    &a[0] * &b[0] + &a[1] * &b[1] + &a[2] * &b[2]
}

/// The sign of `x` as -1, 0 or 1.
pub fn sign(x: &BigInt) -> i32 {
    match x.sign() {
        Sign::Minus => -1,
        Sign::NoSign => 0,
        Sign::Plus => 1,
    }
}

fn ord(s: i32) -> Ordering {
    s.cmp(&0)
}

/// Sign of `p + q sqrt(d)`, `d >= 0`.
fn sign_sqrt1(p: &BigInt, q: &BigInt, d: &BigInt) -> i32 {
    let a = sign(p);
    let b = if d.is_zero() { 0 } else { sign(q) };
    if b == 0 || a == b {
        return if a == 0 { b } else { a };
    }
    if a == 0 {
        return b;
    }
    // Opposite signs: the larger magnitude wins.
    match (p * p).cmp(&(q * q * d)) {
        Ordering::Greater => a,
        Ordering::Less => b,
        Ordering::Equal => 0,
    }
}

/// Sign of `p + q sqrt(d1) + r sqrt(d2)`, `d1, d2 >= 0`.
fn sign_sqrt2(p: &BigInt, q: &BigInt, d1: &BigInt, r: &BigInt, d2: &BigInt) -> i32 {
    let s1 = sign_sqrt1(p, q, d1);
    let s2 = if d2.is_zero() { 0 } else { sign(r) };
    if s2 == 0 || s1 == s2 {
        return s1;
    }
    if s1 == 0 {
        return s2;
    }
    // |p + q sqrt(d1)|^2 - r^2 d2 = (p^2 + q^2 d1 - r^2 d2) + 2 p q sqrt(d1).
    let g = sign_sqrt1(&(p * p + q * q * d1 - r * r * d2), &(BigInt::from(2) * p * q), d1);
    match g {
        1 => s1,
        -1 => s2,
        _ => 0,
    }
}

/// `n / d` rounded to `f64` (relative error below `2^-62` before the final
/// rounding), without overflowing for huge integers.
pub fn ratio_f64(n: &BigInt, d: &BigInt) -> f64 {
    if d.is_zero() {
        return if n.is_zero() { f64::NAN } else { f64::INFINITY * sign(n) as f64 * sign(d).max(1) as f64 };
    }
    if n.is_zero() {
        return 0.0;
    }
    let e = n.bits() as i64 - d.bits() as i64;
    let q = if e <= 64 { (n << (64 - e) as usize) / d } else { n / (d << (e - 64) as usize) };
    let m = q.to_f64().unwrap_or(f64::NAN);
    // 2^(e - 64) in two steps so neither factor overflows for |e| up to ~2000.
    let k = (e - 64) as i32;
    m * 2f64.powi(k / 2) * 2f64.powi(k - k / 2)
}

/// `x 2^(-149 units)` rounded to `f64`: the value of a product of `units`
/// [`fixed`] numbers.
pub fn scaled_f64(x: &BigInt, units: usize) -> f64 {
    ratio_f64(x, &(BigInt::from(1) << (149 * units)))
}

/// An exact hit distance `(p + q sqrt(d)) / m` with `m > 0`, `d >= 0`
/// (`q = 0` for a triangle's rational `t`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExactT {
    /// Rational part numerator.
    pub p: BigInt,
    /// Coefficient of the square root (0 for rationals, +-1 for sphere roots).
    pub q: BigInt,
    /// Radicand.
    pub d: BigInt,
    /// Positive denominator.
    pub m: BigInt,
}

impl ExactT {
    /// The rational `n / den` (`den != 0`).
    pub fn rational(n: BigInt, den: BigInt) -> Self {
        let (p, m) = if den.is_negative() { (-n, -den) } else { (n, den) };
        Self { p, q: BigInt::zero(), d: BigInt::zero(), m }
    }

    /// The exact value of a finite `f32`.
    pub fn from_f32(x: f32) -> Self {
        Self::rational(fixed(x), fixed(1.0))
    }

    /// Exact comparison.
    pub fn cmp_exact(&self, o: &ExactT) -> Ordering {
        // sign(p1 m2 + q1 m2 sqrt(d1) - p2 m1 - q2 m1 sqrt(d2)).
        let p = &self.p * &o.m - &o.p * &self.m;
        ord(sign_sqrt2(&p, &(&self.q * &o.m), &self.d, &(-(&o.q * &self.m)), &o.d))
    }

    /// Exact comparison with an `f32` (infinities allowed).
    pub fn cmp_f32(&self, x: f32) -> Ordering {
        if x == f32::INFINITY {
            Ordering::Less
        } else if x == f32::NEG_INFINITY {
            Ordering::Greater
        } else {
            self.cmp_exact(&Self::from_f32(x))
        }
    }

    /// `self - o` rounded to `f64`: exact before the rounding when both are
    /// rational, else the difference of the two values rounded to `f64`
    /// (absolute error about `2^-53 (|self| + |o|)`). For margins and
    /// reports; the sign is [`Self::cmp_exact`]'s.
    pub fn diff_f64(&self, o: &ExactT) -> f64 {
        if self.q.is_zero() && o.q.is_zero() {
            ratio_f64(&(&self.p * &o.m - &o.p * &self.m), &(&self.m * &o.m))
        } else {
            self.to_f64() - o.to_f64()
        }
    }

    /// The value rounded to `f64` (for margins and reports, never for decisions).
    pub fn to_f64(&self) -> f64 {
        if self.q.is_zero() || self.d.is_zero() {
            return ratio_f64(&self.p, &self.m);
        }
        // floor(sqrt(d 4^k)) / 2^k with d 4^k of at least 128 bits: exact to 2^-64 relative.
        let k = (130u64.saturating_sub(self.d.bits()) / 2) as usize;
        let root = (&self.d << (2 * k)).sqrt();
        ratio_f64(&((&self.p << k) + &self.q * root), &(&self.m << k))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_is_exact_for_normal_and_subnormal_values() {
        assert_eq!(fixed(1.0), BigInt::from(1) << 149usize);
        assert_eq!(fixed(-0.5), -(BigInt::from(1) << 148usize));
        assert_eq!(fixed(f32::from_bits(1)), BigInt::from(1));
        assert_eq!(fixed(f32::MAX), BigInt::from(0xff_ffffu32) << (254 - 1usize));
        for x in [3.25f32, -1e-30, 7e37, 0.1] {
            assert_eq!(ratio_f64(&fixed(x), &fixed(1.0)), x as f64);
        }
    }

    #[test]
    fn square_root_comparisons_are_exact() {
        let i = |v: i64| BigInt::from(v);
        // (1 + sqrt 2) / 1 vs (3 - sqrt 0.25 * 4 = 2): 2.414 > 2.
        let a = ExactT { p: i(1), q: i(1), d: i(2), m: i(1) };
        let b = ExactT::rational(i(2), i(1));
        assert_eq!(a.cmp_exact(&b), Ordering::Greater);
        // sqrt(2) + sqrt(3) vs sqrt(10): 3.146 vs 3.162.
        let c = ExactT { p: i(0), q: i(1), d: i(2), m: i(1) };
        let s3 = ExactT { p: i(0), q: i(-1), d: i(3), m: i(1) };
        let d = ExactT { p: i(0), q: i(1), d: i(10), m: i(1) };
        // c - d vs -sqrt(3) ... compare sqrt2 - sqrt10 with -sqrt3 via (p=0,q=1,d=2) - (q=1,d=10).
        assert_eq!(sign_sqrt2(&i(0), &i(1), &i(2), &i(-1), &i(10)), -1);
        assert_eq!(c.cmp_exact(&d), Ordering::Less);
        assert_eq!(s3.cmp_exact(&ExactT { p: i(-173205), q: i(0), d: i(0), m: i(100000) }), Ordering::Less);
        // Equal values in different forms: sqrt(8)/2 == sqrt(2).
        let e = ExactT { p: i(0), q: i(1), d: i(8), m: i(2) };
        assert_eq!(e.cmp_exact(&c), Ordering::Equal);
        assert!((a.to_f64() - 2.414213562373095).abs() < 1e-12);
    }
}
