//! The natural logarithm as branch-free arithmetic, so that a loop over
//! particles that takes `ln J` (the Neo-Hookean stress and wave speed) is
//! compiled to vector instructions instead of one library call per
//! particle.
//!
//! Method (the classical argument reduction and minimax fit used by most C
//! libraries since 4.3BSD): `x = 2^k m` with `m` in `[√2/2, √2)`, `f = m − 1`,
//! `s = f / (2 + f)`, and
//! `ln m = f − f²/2 + s (f²/2 + R(s²))`, from `ln m = ln((1+s)/(1−s)) =
//! 2s + s R(s²)` with `R(z) = Σ_{n≥1} 2zⁿ/(2n+1)` replaced by its degree-7
//! minimax polynomial (error below 2^-58 on the reduced range);
//! `ln x = k ln2_hi − ((f²/2 − (s (f²/2 + R) + k ln2_lo)) − f)` with `ln 2`
//! split so that `k ln2_hi` is exact. The error is below one unit in the
//! last place (checked against `f64::ln` in the tests).
//!
//! Special values as `f64::ln`: `ln(0) = −∞`, `ln(x < 0) = NaN`,
//! `ln(+∞) = +∞`, `ln(NaN) = NaN`; subnormal inputs are scaled first.

// The constants are written with 19 significant digits (more than a double
// holds); each rounds to the intended double.
#![allow(clippy::excessive_precision)]

/// Coefficients of `R(z) = z (L1 + z² (L3 + z² (L5 + z² L7))) + z² (L2 +
/// z² (L4 + z² L6))`, `z = s²`.
const L1: f64 = 6.666666666666735130e-01;
const L2: f64 = 3.999999999940941908e-01;
const L3: f64 = 2.857142874366239149e-01;
const L4: f64 = 2.222219843214978396e-01;
const L5: f64 = 1.818357216161805012e-01;
const L6: f64 = 1.531383769920937332e-01;
const L7: f64 = 1.479819860511658591e-01;
/// High part of `ln 2` (its last 32 bits are zero, so `k · LN2_HI` is exact
/// for `|k| < 2^32`).
const LN2_HI: f64 = 6.93147180369123816490e-01;
/// `ln 2 − LN2_HI`.
const LN2_LO: f64 = 1.90821492927058770002e-10;

/// Natural logarithm of `x`, within one unit in the last place; branch-free
/// (every special case is a select), so loops over it vectorize.
#[inline(always)]
pub fn ln(x: f64) -> f64 {
    // Subnormal: scale by 2^54 and correct the exponent.
    let sub = x < f64::MIN_POSITIVE;
    let xs = if sub { x * 18014398509481984.0 } else { x };
    let bits = xs.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i64 - 1023 - if sub { 54 } else { 0 };
    // Mantissa in [1, 2), halved when above √2 (exact).
    let m1 = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    let big = m1 > std::f64::consts::SQRT_2;
    let m = if big { 0.5 * m1 } else { m1 };
    let k = (e + if big { 1 } else { 0 }) as f64;
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let r = z * (L1 + w * (L3 + w * (L5 + w * L7))) + w * (L2 + w * (L4 + w * L6));
    let hfsq = 0.5 * f * f;
    let v = k * LN2_HI - ((hfsq - (s * (hfsq + r) + k * LN2_LO)) - f);
    // x = +inf or NaN: x itself (inf, NaN); x = 0: -inf; x < 0: NaN.
    let special = x.is_nan() || x == f64::INFINITY;
    let v = if special { x + x } else { v };
    let v = if x == 0.0 { f64::NEG_INFINITY } else { v };
    if x < 0.0 {
        f64::NAN
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::ln;

    fn ulps(a: f64, b: f64) -> u64 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    #[test]
    fn within_one_ulp_of_the_library_logarithm() {
        let mut s = 0x2545F4914F6CDD1Du64;
        let mut worst = 0;
        for i in 0..2_000_000u64 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            // Spread over the whole range, and densely around 1 (J near 1).
            let x = if i % 2 == 0 {
                f64::from_bits(s >> 1) // any positive double (incl. subnormal)
            } else {
                1.0 + ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.6
            };
            if !x.is_finite() {
                continue;
            }
            worst = worst.max(ulps(ln(x), x.ln()));
        }
        assert!(worst <= 1, "largest difference {worst} ulp");
        for x in [
            1.0,
            2.0,
            0.5,
            std::f64::consts::E,
            1.0 + 1e-15,
            1.0 - 1e-16,
            5e-324,
        ] {
            assert!(ulps(ln(x), x.ln()) <= 1, "ln({x})");
        }
        assert_eq!(ln(1.0), 0.0);
    }

    #[test]
    fn special_values_as_the_library() {
        assert_eq!(ln(0.0), f64::NEG_INFINITY);
        assert_eq!(ln(-0.0), f64::NEG_INFINITY);
        assert!(ln(-1.0).is_nan());
        assert!(ln(f64::NEG_INFINITY).is_nan());
        assert!(ln(f64::NAN).is_nan());
        assert_eq!(ln(f64::INFINITY), f64::INFINITY);
    }
}
