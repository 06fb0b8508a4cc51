//! The nodal sums over nodes that several patches store (see the module
//! notes of [`crate::level`]).

use super::{node_box, node_index, overlap_nodes, Fields, Level};
use crate::comm::Comm;
use crate::error::Result;
use crate::geom::IBox;
use crate::records::NodalSums;

impl Level {
    /// Sums the selected nodal accumulators over every node shared by
    /// several patches (collective). Every copy of a node ends with the sum
    /// of all patches' partial values in increasing patch index.
    pub fn exchange(&mut self, comm: &Comm, fields: Fields) -> Result<()> {
        let t0 = std::time::Instant::now();
        let r = self.exchange_inner(comm, fields);
        self.stats.exchange += t0.elapsed().as_secs_f64();
        r
    }

    fn exchange_inner(&mut self, comm: &Comm, fields: Fields) -> Result<()> {
        let fl = fields.list();
        let me = comm.rank();
        // One buffer per peer rank (and one for this rank). Every pair of
        // overlapping patches sends, zeros for a patch without particles,
        // so both sides know every message size from the layout alone and
        // the exchange is point-to-point with the neighbours only.
        let mut send: Vec<(i32, Vec<u8>)> = Vec::new();
        for p in &self.local {
            for &(q, ov) in &p.nbrs {
                let r = self.owner[q];
                let at = match send.iter().position(|e| e.0 == r) {
                    Some(i) => i,
                    None => {
                        send.push((r, Vec::new()));
                        send.len() - 1
                    }
                };
                let buf = &mut send[at].1;
                NodalSums::begin(buf, q, p.k);
                for &f in fl {
                    for j in ov.lo[1]..ov.hi[1] {
                        for i in ov.lo[0]..ov.hi[0] {
                            let v = p
                                .grid
                                .as_ref()
                                .map_or(0.0, |g| g.acc(f, node_index(g, i, j)));
                            NodalSums::push(buf, v);
                        }
                    }
                }
            }
        }
        if send.is_empty() {
            return Ok(());
        }
        send.sort_by_key(|e| e.0);
        let remote: Vec<(i32, &[u8])> = send
            .iter()
            .filter(|e| e.0 != me)
            .map(|e| (e.0, e.1.as_slice()))
            .collect();
        let sizes: Vec<(i32, usize)> = remote.iter().map(|e| (e.0, e.1.len())).collect();
        self.stats.bytes_sent += sizes.iter().map(|e| e.1 as u64).sum::<u64>();
        let mut bufs = comm.exchange_with(&remote, &sizes, 17)?;
        drop(remote);
        if let Some(own) = send.into_iter().find(|e| e.0 == me) {
            bufs.push(own.1);
        }
        // Index the partials by destination patch: (dest, src, buffer, offset).
        let mut incoming: Vec<(usize, usize, usize, usize)> = Vec::new();
        for (bi, recv) in bufs.iter().enumerate() {
            let mut at = 0;
            while at < recv.len() {
                let (q, src) = NodalSums::header(recv, at);
                let ov = node_box(&self.patches[q]).intersect(&node_box(&self.patches[src]));
                incoming.push((q, src, bi, at + NodalSums::HEADER));
                at += NodalSums::HEADER + 8 * fl.len() * ov.num_cells() as usize;
            }
        }
        incoming.sort_unstable();
        let patches = &self.patches;
        let scratch = &mut self.scratch;
        for p in &mut self.local {
            let Some(g) = &mut p.grid else { continue };
            if fields == Fields::Dilatation && g.dil.len() != g.len() {
                // Its allocation failed: the step fails (and is undone)
                // after the exchange, which this rank still takes part in.
                continue;
            }
            let lo = incoming.partition_point(|e| e.0 < p.k);
            let hi = incoming.partition_point(|e| e.0 <= p.k);
            let mine = &incoming[lo..hi];
            if mine.is_empty() {
                continue;
            }
            let own_box = node_box(&p.cells);
            // Every copy of a shared node sums its contributions in
            // increasing patch index with the own one in its place, from 0:
            // `(0 + Σ_{src < k} v) + own + Σ_{src > k} v`. Only the nodes of
            // the overlaps change, so only they are visited (a node in
            // several overlaps, a corner, more than once: the passes that
            // can see it twice assign values that do not change between the
            // visits). `lower` and `sum` are scratch over the grid's nodes,
            // written before they are read.
            let (lo, nx) = (g.lo, g.n[0]);
            let ovs: Vec<(usize, IBox, usize, usize)> = mine
                .iter()
                .map(|&(_, src, bi, off)| {
                    (src, own_box.intersect(&node_box(&patches[src])), bi, off)
                })
                .collect();
            let n = g.len();
            if scratch.len() < 2 * n {
                scratch.resize(2 * n, 0.0);
            }
            let (lower, sum) = scratch.split_at_mut(n);
            for (fi, &f) in fl.iter().enumerate() {
                let add = |acc: &mut [f64], &(_, ov, bi, off): &(usize, IBox, usize, usize)| {
                    let base = off + 8 * fi * ov.num_cells() as usize;
                    overlap_nodes(lo, nx, &ov, |k, r| {
                        acc[k] += NodalSums::value(&bufs[bi], base, r);
                    });
                };
                for o in &ovs {
                    overlap_nodes(lo, nx, &o.1, |k, _| lower[k] = 0.0);
                }
                for o in ovs.iter().filter(|o| o.0 < p.k) {
                    add(lower, o);
                }
                for o in &ovs {
                    overlap_nodes(lo, nx, &o.1, |k, _| sum[k] = lower[k] + g.acc(f, k));
                }
                for o in ovs.iter().filter(|o| o.0 > p.k) {
                    add(sum, o);
                }
                for o in &ovs {
                    overlap_nodes(lo, nx, &o.1, |k, _| g.set_acc(f, k, sum[k]));
                }
            }
        }
        Ok(())
    }
}
