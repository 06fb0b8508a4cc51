//! Four `f64`s operated on together: a node's `[vx, vy, v0x, v0y]` or
//! `[px, py, fx, fy]` (see [`super::grid::Node4`]), gathered and scattered
//! with one load or store per node.
//!
//! The vector width is a type parameter ([`Simd4`]) rather than left to
//! the compiler's auto-vectorizer: written as plain array loops, the
//! AVX-512 build turned some of these small computations into gather and
//! scatter instructions across nodes and ran slower than the baseline
//! build (about 100 against 86 ns per particle-step on the comparison
//! scene, 55 for the AVX2 build). [`Avx`] is one 256-bit register, [`Sse2`] two 128-bit
//! ones (the x86-64 baseline), [`Scalar`] four `f64`s elsewhere. Every
//! operation is the IEEE operation on each lane (no fused multiply-add),
//! so all three give the same bits.

/// An implementation of 4-lane `f64` arithmetic.
pub(crate) trait Simd4: Copy + 'static {
    /// The register (or registers) holding four lanes.
    type V: Copy;
    /// All lanes zero.
    fn zero() -> Self::V;
    /// All lanes `v`.
    fn splat(v: f64) -> Self::V;
    /// The four values of `a`.
    fn load(a: &[f64; 4]) -> Self::V;
    /// Lanes `[a, b, c, d]` from scalars (in registers: no round trip
    /// through memory, which would stall the vector load).
    fn new(a: f64, b: f64, c: f64, d: f64) -> Self::V;
    /// Lane by lane.
    fn to_array(v: Self::V) -> [f64; 4];
    /// Lane by lane `a + b`.
    fn add(a: Self::V, b: Self::V) -> Self::V;
    /// Lane by lane `a - b`.
    fn sub(a: Self::V, b: Self::V) -> Self::V;
    /// Lane by lane `a * b`.
    fn mul(a: Self::V, b: Self::V) -> Self::V;
}

/// Four lanes of `f64` in the representation of `I`.
pub(crate) struct F4<I: Simd4>(I::V);

impl<I: Simd4> Clone for F4<I> {
    #[inline(always)]
    fn clone(&self) -> Self {
        *self
    }
}

impl<I: Simd4> Copy for F4<I> {}

impl<I: Simd4> F4<I> {
    /// All lanes zero.
    #[inline(always)]
    pub(crate) fn zero() -> Self {
        F4(I::zero())
    }
    /// All lanes `v`.
    #[inline(always)]
    pub(crate) fn splat(v: f64) -> Self {
        F4(I::splat(v))
    }
    /// The four values of `a`.
    #[inline(always)]
    pub(crate) fn load(a: &[f64; 4]) -> Self {
        F4(I::load(a))
    }
    /// Lanes `[a, b, c, d]`.
    #[inline(always)]
    pub(crate) fn new(a: f64, b: f64, c: f64, d: f64) -> Self {
        F4(I::new(a, b, c, d))
    }
    /// The lanes as an array.
    #[inline(always)]
    pub(crate) fn to_array(self) -> [f64; 4] {
        I::to_array(self.0)
    }
    /// Lane by lane sum.
    #[inline(always)]
    pub(crate) fn add(self, o: Self) -> Self {
        F4(I::add(self.0, o.0))
    }
    /// Lane by lane difference.
    #[inline(always)]
    pub(crate) fn sub(self, o: Self) -> Self {
        F4(I::sub(self.0, o.0))
    }
    /// Lane by lane product.
    #[inline(always)]
    pub(crate) fn mul(self, o: Self) -> Self {
        F4(I::mul(self.0, o.0))
    }
}

/// Plain arrays (any target).
#[derive(Clone, Copy)]
#[allow(dead_code)] // Only the non-x86 build runs the loops with it.
pub(crate) struct Scalar;

#[allow(clippy::needless_range_loop)]
impl Simd4 for Scalar {
    type V = [f64; 4];
    #[inline(always)]
    fn zero() -> [f64; 4] {
        [0.0; 4]
    }
    #[inline(always)]
    fn splat(v: f64) -> [f64; 4] {
        [v; 4]
    }
    #[inline(always)]
    fn load(a: &[f64; 4]) -> [f64; 4] {
        *a
    }
    #[inline(always)]
    fn new(a: f64, b: f64, c: f64, d: f64) -> [f64; 4] {
        [a, b, c, d]
    }
    #[inline(always)]
    fn to_array(v: [f64; 4]) -> [f64; 4] {
        v
    }
    #[inline(always)]
    fn add(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        std::array::from_fn(|i| a[i] + b[i])
    }
    #[inline(always)]
    fn sub(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        std::array::from_fn(|i| a[i] - b[i])
    }
    #[inline(always)]
    fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        std::array::from_fn(|i| a[i] * b[i])
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::Simd4;
    use std::arch::x86_64::*;

    /// Two SSE2 registers (the x86-64 baseline: always available).
    #[derive(Clone, Copy)]
    pub(crate) struct Sse2;

    // SAFETY (every `unsafe` block of this impl): SSE2 is part of every
    // x86-64 target, and the loads and stores touch the given arrays only.
    #[allow(unused_unsafe)]
    impl Simd4 for Sse2 {
        type V = [__m128d; 2];
        #[inline(always)]
        fn zero() -> Self::V {
            unsafe { [_mm_setzero_pd(); 2] }
        }
        #[inline(always)]
        fn splat(v: f64) -> Self::V {
            unsafe { [_mm_set1_pd(v); 2] }
        }
        #[inline(always)]
        fn load(a: &[f64; 4]) -> Self::V {
            unsafe { [_mm_loadu_pd(a.as_ptr()), _mm_loadu_pd(a.as_ptr().add(2))] }
        }
        #[inline(always)]
        fn new(a: f64, b: f64, c: f64, d: f64) -> Self::V {
            unsafe { [_mm_set_pd(b, a), _mm_set_pd(d, c)] }
        }
        #[inline(always)]
        fn to_array(v: Self::V) -> [f64; 4] {
            let mut r = [0.0; 4];
            unsafe {
                _mm_storeu_pd(r.as_mut_ptr(), v[0]);
                _mm_storeu_pd(r.as_mut_ptr().add(2), v[1]);
            }
            r
        }
        #[inline(always)]
        fn add(a: Self::V, b: Self::V) -> Self::V {
            unsafe { [_mm_add_pd(a[0], b[0]), _mm_add_pd(a[1], b[1])] }
        }
        #[inline(always)]
        fn sub(a: Self::V, b: Self::V) -> Self::V {
            unsafe { [_mm_sub_pd(a[0], b[0]), _mm_sub_pd(a[1], b[1])] }
        }
        #[inline(always)]
        fn mul(a: Self::V, b: Self::V) -> Self::V {
            unsafe { [_mm_mul_pd(a[0], b[0]), _mm_mul_pd(a[1], b[1])] }
        }
    }

    /// One AVX register. Only for code compiled with AVX enabled and run on
    /// a CPU that has it: the AVX2 and AVX-512 copies that
    /// [`crate::kernel::isa::multiversion`] makes and chooses at run time
    /// (nothing else names this type).
    #[derive(Clone, Copy)]
    pub(crate) struct Avx;

    // SAFETY (every `unsafe` block of this impl): AVX is available where
    // this type is used (see the type's notes), and the loads and stores
    // touch the given arrays only.
    impl Simd4 for Avx {
        type V = __m256d;
        #[inline(always)]
        fn zero() -> __m256d {
            unsafe { _mm256_setzero_pd() }
        }
        #[inline(always)]
        fn splat(v: f64) -> __m256d {
            unsafe { _mm256_set1_pd(v) }
        }
        #[inline(always)]
        fn load(a: &[f64; 4]) -> __m256d {
            unsafe { _mm256_loadu_pd(a.as_ptr()) }
        }
        #[inline(always)]
        fn new(a: f64, b: f64, c: f64, d: f64) -> __m256d {
            unsafe { _mm256_set_pd(d, c, b, a) }
        }
        #[inline(always)]
        fn to_array(v: __m256d) -> [f64; 4] {
            let mut r = [0.0; 4];
            unsafe { _mm256_storeu_pd(r.as_mut_ptr(), v) };
            r
        }
        #[inline(always)]
        fn add(a: __m256d, b: __m256d) -> __m256d {
            unsafe { _mm256_add_pd(a, b) }
        }
        #[inline(always)]
        fn sub(a: __m256d, b: __m256d) -> __m256d {
            unsafe { _mm256_sub_pd(a, b) }
        }
        #[inline(always)]
        fn mul(a: __m256d, b: __m256d) -> __m256d {
            unsafe { _mm256_mul_pd(a, b) }
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use x86::{Avx, Sse2};

/// The representation of the baseline build of the particle loops.
#[cfg(target_arch = "x86_64")]
pub(crate) type Base = Sse2;
/// The representation of the baseline build of the particle loops.
#[cfg(not(target_arch = "x86_64"))]
pub(crate) type Base = Scalar;

#[cfg(test)]
mod tests {
    use super::*;

    fn check<I: Simd4>() {
        let a = [0.1, 1.0 / 3.0, -2.5e-300, 7.0e300];
        let b = [3.0, -0.0, 1e-310, 0.5];
        let (x, y) = (F4::<I>::load(&a), F4::<I>::load(&b));
        let s = x.add(y).mul(F4::splat(b[1] + 0.7)).sub(x);
        let z = F4::<I>::zero().add(F4::splat(2.0)).to_array();
        assert_eq!(F4::<I>::new(a[0], a[1], a[2], a[3]).to_array(), a);
        let r = s.to_array();
        for i in 0..4 {
            assert_eq!(
                r[i].to_bits(),
                ((a[i] + b[i]) * (b[1] + 0.7) - a[i]).to_bits()
            );
            assert_eq!(z[i], 2.0);
        }
    }

    #[test]
    fn lanes_follow_ieee_scalar_operations() {
        check::<Scalar>();
        check::<Base>();
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // The test binary is not built with AVX, so the AVX
            // representation runs here through calls that are not inlined;
            // still the same operations.
            check::<Avx>();
        }
    }
}
