//! The weights of one particle on both axes at once: the x and y 1D
//! weights are the same function of `(xi, li)`, so they are evaluated side
//! by side in the two lanes of an [`F2`], with every branch of the scalar
//! functions ([`Shape1D::eval_f`]) replaced by a lane select of the same
//! expressions. The results are bit for bit those of the scalar functions
//! (checked by the tests below), at about half the instructions.

use super::simd::F2;
use crate::shape::{GimpShape, MpmShape, Shape1D};

/// 1D weights of one particle on both axes: lane 0 is x, lane 1 is y.
#[derive(Clone, Copy)]
pub(crate) struct W2 {
    /// First stencil node (`floor(xi + 1/2) - 1`), as a float.
    pub(crate) base: F2,
    /// Weights of nodes `base, base+1, base+2`.
    pub(crate) w: [F2; 3],
    /// Their slopes in cell units.
    pub(crate) g: [F2; 3],
}

/// A 1D weight function evaluated on both axes at once.
pub(crate) trait Shape2: Shape1D {
    /// Weights at positions `xi` and half-lengths `li` (cell units; lane 0
    /// x, lane 1 y).
    fn eval2(xi: F2, li: F2) -> W2;
}

/// See [`crate::shape`]'s `base_of`: the same operations per lane.
#[inline(always)]
fn base_of2(xi: F2) -> F2 {
    const ROUND_MAGIC: f64 = 6755399441055744.0;
    let one = F2::splat(1.0);
    let m = F2::splat(ROUND_MAGIC);
    let v = xi.add(F2::splat(0.5));
    let t = v.add(m).sub(m);
    // `t - 1` where `t > v`, `t - 0 = t` elsewhere.
    t.sub(t.gt(v).and(one)).sub(one)
}

impl Shape2 for MpmShape {
    #[inline(always)]
    fn eval2(xi: F2, _li: F2) -> W2 {
        let (one, zero) = (F2::splat(1.0), F2::zero());
        let b = base_of2(xi);
        let d0 = xi.sub(b);
        let left = d0.lt(one);
        let f = left.select(d0, d0.sub(one));
        let omf = one.sub(f);
        W2 {
            base: b,
            w: [
                left.select(omf, zero),
                left.select(f, omf),
                left.select(zero, f),
            ],
            g: [
                left.select(one.neg(), zero),
                left.select(one, one.neg()),
                left.select(zero, one),
            ],
        }
    }
}

impl Shape2 for GimpShape {
    #[inline(always)]
    fn eval2(xi: F2, li: F2) -> W2 {
        let (one, zero, half) = (F2::splat(1.0), F2::zero(), F2::splat(0.5));
        // clamp(li, 0, 1/2): NaN and -0.0 kept, as `f64::clamp`
        let l = zero.max_sse(half.min_sse(li));
        let b = base_of2(xi);
        let d0 = xi.sub(b);
        let d1 = d0.sub(one);
        let e2 = F2::splat(2.0).sub(d0);
        let h2 = half.div(l);
        let lin = one.sub(l);
        let onel = one.add(l);
        let outer = |e: F2| -> (F2, F2) {
            let r = onel.sub(e).mul(h2).max_sse(zero);
            let is_lin = e.le(lin);
            (
                is_lin.select(one.sub(e), r.mul(r).mul(l)),
                is_lin.select(one, r),
            )
        };
        let (w0, s0) = outer(d0);
        let (w2, s2) = outer(e2);
        let a1 = d1.abs();
        let inner = a1.lt(l);
        let w1 = inner.select(one.sub(d1.mul(d1).add(l.mul(l)).mul(h2)), one.sub(a1));
        let sign = d1.gt(zero).select(one.neg(), one);
        let g1 = inner.select(F2::splat(-2.0).mul(d1).mul(h2), sign);
        W2 {
            base: b,
            w: [w0, w1, w2],
            g: [s0.neg(), g1, s2],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn probes() -> Vec<f64> {
        let mut v = Vec::new();
        let mut s = 0x2545F4914F6CDD1Du64;
        for _ in 0..3000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            v.push(-4.0 + 12.0 * (s >> 11) as f64 / (1u64 << 53) as f64);
        }
        for k in -3..6 {
            for f in [0.0, 0.25, 0.5, 0.75, 0.125, 0.375] {
                let x = k as f64 + f;
                v.extend([x, x - 1e-15, x + 1e-15, -x]);
            }
        }
        v.extend([-0.0, 1e-300, -1e-300, 1e6 + 0.5]);
        v
    }

    fn check<S: Shape2>() {
        let sizes = [0.0, -0.0, 1e-9, 0.125, 0.25, 0.3, 0.5, 0.7, -0.1];
        let pr = probes();
        for (i, &x) in pr.iter().enumerate() {
            let y = pr[(i * 7 + 3) % pr.len()];
            for (k, &lx) in sizes.iter().enumerate() {
                let ly = sizes[(k + 4) % sizes.len()];
                let v = S::eval2(F2::new(x, y), F2::new(lx, ly));
                for (lane, (p, l)) in [(x, lx), (y, ly)].into_iter().enumerate() {
                    let s = S::eval_f(p, l);
                    let get = |f: F2| if lane == 0 { f.lo() } else { f.hi() };
                    assert_eq!(get(v.base).to_bits(), s.base.to_bits(), "base at {p}");
                    for a in 0..3 {
                        assert_eq!(
                            get(v.w[a]).to_bits(),
                            s.w[a].to_bits(),
                            "w{a} at xi = {p}, li = {l}"
                        );
                        assert_eq!(
                            get(v.g[a]).to_bits(),
                            s.g[a].to_bits(),
                            "g{a} at xi = {p}, li = {l}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn pair_evaluation_matches_the_scalar_functions_bit_for_bit() {
        check::<GimpShape>();
        check::<MpmShape>();
    }
}
