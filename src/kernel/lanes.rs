//! A block's particle fields as fixed-size lane arrays.
//!
//! The particle loops update a block of [`LANES`] consecutive particles in
//! straight loops over the lanes, which the compiler turns into vector
//! instructions across the particles. These helpers move one field of the
//! block between the particle arrays and a `[f64; LANES]` (one vector load
//! or store for a full block; the last, partial block is padded with
//! zeros, whose lanes are never written back), and fold a lane condition
//! into a bit mask (one vector compare), so that the rare per-particle
//! notes (a particle off the grid, an inverted one) cost one test per
//! block.

// Lane loops index several arrays by the lane on purpose: that is the
// form the compiler turns into vector instructions.
#![allow(clippy::needless_range_loop)]

use super::block::LANES;

/// The values of `src` (at most [`LANES`] of them), zero-padded.
#[inline(always)]
pub(crate) fn load(src: &[f64]) -> [f64; LANES] {
    match src.first_chunk::<LANES>() {
        // A full block: a fixed-size copy (no library call).
        Some(full) => *full,
        None => {
            let mut a = [0.0; LANES];
            let n = src.len().min(LANES);
            a[..n].copy_from_slice(&src[..n]);
            a
        }
    }
}

/// Writes the first `dst.len()` (at most [`LANES`]) lanes of `v` to `dst`.
#[inline(always)]
pub(crate) fn store(dst: &mut [f64], v: &[f64; LANES]) {
    match dst.first_chunk_mut::<LANES>() {
        Some(full) => *full = *v,
        None => {
            let n = dst.len().min(LANES);
            dst[..n].copy_from_slice(&v[..n]);
        }
    }
}

/// Bit `l` set where `b[l]`.
#[inline(always)]
pub(crate) fn mask(b: &[bool; LANES]) -> u32 {
    let mut m = 0u32;
    for l in 0..LANES {
        m |= (b[l] as u32) << l;
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_and_partial_blocks_round_trip() {
        let src: Vec<f64> = (0..LANES + 3).map(|i| i as f64 + 0.5).collect();
        let full = load(&src[..LANES]);
        assert_eq!(&full[..], &src[..LANES]);
        let part = load(&src[LANES..]);
        assert_eq!(&part[..3], &src[LANES..]);
        assert!(part[3..].iter().all(|&v| v == 0.0));
        let mut dst = vec![-1.0; LANES + 3];
        store(&mut dst[..LANES], &full);
        store(&mut dst[LANES..], &part);
        assert_eq!(dst, src);
        let mut b = [false; LANES];
        assert_eq!(mask(&b), 0);
        b[0] = true;
        b[LANES - 1] = true;
        assert_eq!(mask(&b), 1 | 1 << (LANES - 1));
    }
}
