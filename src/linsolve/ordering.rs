//! Reverse Cuthill–McKee ordering of the free-set submatrix `A_FF`, so that
//! its envelope (and the cost of the envelope Cholesky in `cholesky.rs`) is
//! small whatever order the caller numbered the contact particles in.
//!
//! Cuthill–McKee is a breadth-first numbering of the matrix graph (the
//! unvisited neighbours of each node in increasing degree), started from a
//! pseudo-peripheral node (George & Liu's heuristic: repeat the search from
//! a minimum-degree node of the last level while the eccentricity grows);
//! reversing it keeps the bandwidth and shrinks the envelope. Every step is
//! deterministic (ties broken by index), so all ranks compute the same order
//! from the same replicated matrix.

use super::{SymCsr, NOT_FREE};

/// Scratch and result of an ordering (buffers grow, never shrink).
#[derive(Clone, Debug, Default)]
pub(crate) struct Rcm {
    /// `perm[new] = local`: the local index (position in the free set) of
    /// the unknown numbered `new`.
    pub perm: Vec<u32>,
    /// `inv[local] = new`.
    pub inv: Vec<u32>,
    deg: Vec<u32>,
    visited: Vec<bool>,
    stamp: Vec<u32>,
    level: Vec<u32>,
    next: Vec<u32>,
    nbrs: Vec<u32>,
}

impl Rcm {
    /// Neighbours (local indices, self excluded) of local node `k`.
    fn neighbours(a: &SymCsr, free: &[u32], pos: &[u32], k: usize, out: &mut Vec<u32>) {
        out.clear();
        let gi = free[k] as usize;
        for &j in &a.cols[a.row_ptr[gi]..a.row_ptr[gi + 1]] {
            let p = pos[j as usize];
            if p != NOT_FREE && p as usize != k {
                out.push(p);
            }
        }
    }

    /// Breadth-first levels from `root` over the nodes not yet numbered;
    /// returns the number of levels and leaves the last level in
    /// `self.level`.
    fn levels(&mut self, a: &SymCsr, free: &[u32], pos: &[u32], root: u32, mark: u32) -> usize {
        self.level.clear();
        self.level.push(root);
        self.stamp[root as usize] = mark;
        let mut depth = 1;
        let mut nbrs = std::mem::take(&mut self.nbrs);
        loop {
            self.next.clear();
            for &u in &self.level {
                Self::neighbours(a, free, pos, u as usize, &mut nbrs);
                for &v in &nbrs {
                    if !self.visited[v as usize] && self.stamp[v as usize] != mark {
                        self.stamp[v as usize] = mark;
                        self.next.push(v);
                    }
                }
            }
            if self.next.is_empty() {
                break;
            }
            std::mem::swap(&mut self.level, &mut self.next);
            depth += 1;
        }
        self.nbrs = nbrs;
        depth
    }

    /// Computes the ordering of the `m = free.len()` free unknowns.
    pub fn order(&mut self, a: &SymCsr, free: &[u32], pos: &[u32]) {
        let m = free.len();
        self.perm.clear();
        self.inv.clear();
        self.inv.resize(m, 0);
        self.deg.clear();
        let mut nbrs = std::mem::take(&mut self.nbrs);
        for k in 0..m {
            Self::neighbours(a, free, pos, k, &mut nbrs);
            self.deg.push(nbrs.len() as u32);
        }
        self.visited.clear();
        self.visited.resize(m, false);
        self.stamp.clear();
        self.stamp.resize(m, 0);
        self.nbrs = nbrs;
        let mut mark = 0u32;
        let mut scan = 0usize;
        while self.perm.len() < m {
            // Start of the next component: its minimum-degree node, refined
            // toward a pseudo-peripheral one.
            while self.visited[scan] {
                scan += 1;
            }
            let mut root = scan as u32;
            for k in scan..m {
                if !self.visited[k] && self.deg[k] < self.deg[root as usize] {
                    root = k as u32;
                }
            }
            mark += 1;
            let mut ecc = self.levels(a, free, pos, root, mark);
            for _ in 0..4 {
                let cand = *self
                    .level
                    .iter()
                    .min_by_key(|&&v| (self.deg[v as usize], v))
                    .expect("the last level is not empty");
                mark += 1;
                let e = self.levels(a, free, pos, cand, mark);
                if e > ecc {
                    ecc = e;
                    root = cand;
                } else {
                    break;
                }
            }
            // Cuthill–McKee from root.
            let start = self.perm.len();
            self.perm.push(root);
            self.visited[root as usize] = true;
            let mut head = start;
            let mut nbrs = std::mem::take(&mut self.nbrs);
            while head < self.perm.len() {
                let u = self.perm[head] as usize;
                head += 1;
                Self::neighbours(a, free, pos, u, &mut nbrs);
                nbrs.retain(|&v| !self.visited[v as usize]);
                nbrs.sort_unstable_by_key(|&v| (self.deg[v as usize], v));
                nbrs.dedup();
                for &v in &nbrs {
                    self.visited[v as usize] = true;
                    self.perm.push(v);
                }
            }
            self.nbrs = nbrs;
        }
        self.perm.reverse();
        for (new, &k) in self.perm.iter().enumerate() {
            self.inv[k as usize] = new as u32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path graph numbered in a scrambled order gets a band of width 1
    /// back: every row's first neighbour (in the new numbering) is at most
    /// one column left of the diagonal, and the result is a permutation.
    #[test]
    fn rcm_recovers_a_path_from_a_scrambled_numbering() {
        let n = 50;
        // Position along the path of unknown g: (g * 17) mod 50 (17 and 50
        // are coprime, so this is a permutation).
        let place: Vec<usize> = (0..n).map(|g| (g * 17) % n).collect();
        let mut at = vec![0; n];
        for (g, &p) in place.iter().enumerate() {
            at[p] = g;
        }
        let mut t = Vec::new();
        for p in 0..n {
            t.push((at[p], at[p], 2.0));
            if p + 1 < n {
                t.push((at[p], at[p + 1], -1.0));
                t.push((at[p + 1], at[p], -1.0));
            }
        }
        let a = SymCsr::from_triplets(n, &t);
        let free: Vec<u32> = (0..n as u32).collect();
        let pos: Vec<u32> = (0..n as u32).collect();
        let mut rcm = Rcm::default();
        rcm.order(&a, &free, &pos);
        let mut seen = vec![false; n];
        for &k in &rcm.perm {
            assert!(!seen[k as usize]);
            seen[k as usize] = true;
        }
        let mut bandwidth = 0;
        for g in 0..n {
            for k in a.row_ptr[g]..a.row_ptr[g + 1] {
                let j = a.cols[k] as usize;
                bandwidth = bandwidth.max((rcm.inv[g] as i64 - rcm.inv[j] as i64).unsigned_abs());
            }
        }
        assert_eq!(bandwidth, 1);
    }

    /// Only the free unknowns are ordered; disconnected pieces (two paths)
    /// are both numbered, each as a band.
    #[test]
    fn rcm_orders_a_subset_with_two_components() {
        let n = 10;
        let mut t = Vec::new();
        for i in 0..n {
            t.push((i, i, 2.0));
            if i + 1 < n {
                t.push((i, i + 1, -1.0));
                t.push((i + 1, i, -1.0));
            }
        }
        let a = SymCsr::from_triplets(n, &t);
        // Unknown 4 is not free: 0..4 and 5..10 are separate paths.
        let free: Vec<u32> = (0..n as u32).filter(|&i| i != 4).collect();
        let mut pos = vec![NOT_FREE; n];
        for (k, &g) in free.iter().enumerate() {
            pos[g as usize] = k as u32;
        }
        let mut rcm = Rcm::default();
        rcm.order(&a, &free, &pos);
        assert_eq!(rcm.perm.len(), 9);
        for (k, &g) in free.iter().enumerate() {
            for j in [g.wrapping_sub(1), g + 1] {
                if j < n as u32 && pos[j as usize] != NOT_FREE {
                    let d = rcm.inv[k] as i64 - rcm.inv[pos[j as usize] as usize] as i64;
                    assert_eq!(d.abs(), 1, "neighbours {g} and {j} not adjacent");
                }
            }
        }
    }
}
