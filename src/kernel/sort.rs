//! Particle order: the stencil key that groups particles sharing a 3×3
//! stencil ([`stencil_order`]), and the counting sort by that key
//! ([`sort_by_stencil`]) that lets P2G sum runs of particles locally.

use super::Grid;
use crate::particles::Particles;
use crate::shape::{GimpShape, Shape1D};

/// A sort key per particle that groups particles sharing a 3×3 stencil:
/// the storage index of the stencil's first node (`round(x/h) - 1` per axis,
/// row-major), or `u64::MAX` for a particle off the grid. P2G sums the
/// contributions of consecutive particles with the same key locally and adds
/// them to the grid once, so sorting particles by this key now and then (a
/// counting sort over `grid.len()` keys) makes P2G several times cheaper.
/// The key does not depend on the particle size, so it is the same for
/// MPM, uGIMP and cpGIMP.
pub fn stencil_order(grid: &Grid, parts: &Particles, keys: &mut Vec<u64>) {
    let inv_h = 1.0 / grid.h;
    let [ox, oy] = grid.origin;
    let [lox, loy] = grid.lo;
    let [nx, ny] = grid.n;
    keys.clear();
    keys.extend((0..parts.len()).map(|p| {
        let bx = GimpShape::eval((parts.x[p] - ox) * inv_h, 0.0).base - lox;
        let by = GimpShape::eval((parts.y[p] - oy) * inv_h, 0.0).base - loy;
        if bx < 0 || by < 0 || bx + 2 >= nx as i64 || by + 2 >= ny as i64 {
            u64::MAX
        } else {
            by as u64 * nx as u64 + bx as u64
        }
    }));
}

/// Reusable buffers of [`sort_by_stencil`].
#[derive(Clone, Debug, Default)]
pub struct SortScratch {
    keys: Vec<u64>,
    start: Vec<usize>,
    perm: Vec<usize>,
}

/// Reorders the particles by the stencil key of [`stencil_order`] (a
/// counting sort over the grid's nodes), particles with equal keys by id, so
/// that the order depends only on the positions and ids, not on the order
/// before. P2G and G2P then visit the grid in storage order, and P2G's local
/// sums see runs of ~ppc particles. Returns the permutation applied (new
/// slot `k` holds old slot `perm[k]`), empty when the particles were
/// already in order (nothing moved). Changing the order changes the order of
/// P2G's sums, hence their round-off: sort at a fixed schedule to keep runs
/// reproducible.
pub fn sort_by_stencil<'a>(
    grid: &Grid,
    parts: &mut Particles,
    scratch: &'a mut SortScratch,
) -> &'a [usize] {
    let SortScratch { keys, start, perm } = scratch;
    stencil_order(grid, parts, keys);
    let nb = grid.len() + 1; // last bucket: particles off the grid
    let bucket = |k: u64| (k as usize).min(nb - 1);
    start.clear();
    start.resize(nb + 1, 0);
    for &k in keys.iter() {
        start[bucket(k) + 1] += 1;
    }
    for b in 0..nb {
        start[b + 1] += start[b];
    }
    perm.clear();
    perm.resize(parts.len(), 0);
    // `start[b]` walks through bucket b while it is filled, in slot order.
    for (p, &k) in keys.iter().enumerate() {
        let b = bucket(k);
        perm[start[b]] = p;
        start[b] += 1;
    }
    // Within a bucket (now ending at `start[b]`), order by id: buckets hold
    // ~ppc particles, so an insertion sort; the off-grid bucket may be
    // larger and is sorted with the library sort.
    let id = &parts.id;
    let mut lo = 0;
    for &hi in &start[..nb] {
        let run = &mut perm[lo..hi];
        if run.len() > 16 {
            run.sort_unstable_by_key(|&p| id[p]);
        } else {
            for i in 1..run.len() {
                let mut j = i;
                while j > 0 && id[run[j - 1]] > id[run[j]] {
                    run.swap(j - 1, j);
                    j -= 1;
                }
            }
        }
        lo = hi;
    }
    if perm.iter().enumerate().all(|(k, &p)| k == p) {
        perm.clear();
    } else {
        parts.permute(perm);
    }
    perm
}
