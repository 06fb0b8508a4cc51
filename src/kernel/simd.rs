//! A pair of `f64`s operated on together: the x and y components of a
//! nodal or particle vector, in one SSE2 register on x86-64 (SSE2 is part of
//! the x86-64 baseline, so no feature detection is needed) and as a plain
//! array elsewhere. Every operation is the IEEE operation on each lane, so
//! both builds give the same bits.

#[cfg(target_arch = "x86_64")]
mod imp {
    use std::arch::x86_64::*;

    /// Two lanes `(lo, hi)`.
    #[derive(Clone, Copy)]
    #[repr(transparent)]
    pub(crate) struct F2(__m128d);

    // SAFETY (every `unsafe` block below): SSE2 is enabled on every x86-64
    // target, and the loads read the given (in-bounds) references.
    #[allow(unused_unsafe)]
    impl F2 {
        #[inline(always)]
        pub(crate) fn new(lo: f64, hi: f64) -> F2 {
            F2(unsafe { _mm_set_pd(hi, lo) })
        }
        #[inline(always)]
        pub(crate) fn splat(v: f64) -> F2 {
            F2(unsafe { _mm_set1_pd(v) })
        }
        #[inline(always)]
        pub(crate) fn zero() -> F2 {
            F2(unsafe { _mm_setzero_pd() })
        }
        /// `(*lo, *hi)` from two separate places (two loads, no shuffle).
        #[inline(always)]
        pub(crate) fn load2(lo: &f64, hi: &f64) -> F2 {
            unsafe { F2(_mm_loadh_pd(_mm_load_sd(lo), hi)) }
        }
        #[inline(always)]
        pub(crate) fn lo(self) -> f64 {
            unsafe { _mm_cvtsd_f64(self.0) }
        }
        #[inline(always)]
        pub(crate) fn hi(self) -> f64 {
            unsafe { _mm_cvtsd_f64(_mm_unpackhi_pd(self.0, self.0)) }
        }
        #[inline(always)]
        pub(crate) fn add(self, o: F2) -> F2 {
            F2(unsafe { _mm_add_pd(self.0, o.0) })
        }
        #[inline(always)]
        pub(crate) fn sub(self, o: F2) -> F2 {
            F2(unsafe { _mm_sub_pd(self.0, o.0) })
        }
        #[inline(always)]
        pub(crate) fn mul(self, o: F2) -> F2 {
            F2(unsafe { _mm_mul_pd(self.0, o.0) })
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod imp {
    /// Two lanes `(lo, hi)`.
    #[derive(Clone, Copy)]
    pub(crate) struct F2([f64; 2]);

    impl F2 {
        #[inline(always)]
        pub(crate) fn new(lo: f64, hi: f64) -> F2 {
            F2([lo, hi])
        }
        #[inline(always)]
        pub(crate) fn splat(v: f64) -> F2 {
            F2([v, v])
        }
        #[inline(always)]
        pub(crate) fn zero() -> F2 {
            F2([0.0, 0.0])
        }
        #[inline(always)]
        pub(crate) fn load2(lo: &f64, hi: &f64) -> F2 {
            F2([*lo, *hi])
        }
        #[inline(always)]
        pub(crate) fn lo(self) -> f64 {
            self.0[0]
        }
        #[inline(always)]
        pub(crate) fn hi(self) -> f64 {
            self.0[1]
        }
        #[inline(always)]
        pub(crate) fn add(self, o: F2) -> F2 {
            F2([self.0[0] + o.0[0], self.0[1] + o.0[1]])
        }
        #[inline(always)]
        pub(crate) fn sub(self, o: F2) -> F2 {
            F2([self.0[0] - o.0[0], self.0[1] - o.0[1]])
        }
        #[inline(always)]
        pub(crate) fn mul(self, o: F2) -> F2 {
            F2([self.0[0] * o.0[0], self.0[1] * o.0[1]])
        }
    }
}

pub(crate) use imp::F2;

#[cfg(test)]
mod tests {
    use super::F2;

    #[test]
    fn lanes_follow_ieee_scalar_operations() {
        let (a, b, c, d) = (0.1, 1.0 / 3.0, -2.5e-300, 7.0e300);
        let x = F2::new(a, b);
        let y = F2::load2(&c, &d);
        assert_eq!((x.lo(), x.hi()), (a, b));
        let s = x.add(y).mul(F2::splat(b)).sub(F2::new(d, c));
        assert_eq!(s.lo().to_bits(), ((a + c) * b - d).to_bits());
        assert_eq!(s.hi().to_bits(), ((b + d) * b - c).to_bits());
        assert_eq!(F2::zero().add(x).hi(), b);
    }
}
