//! Particle migration: particles to the patch (and rank) holding their
//! cell, records delivered to patches in a rank-independent order, and
//! patches moved between ranks by the load balance.

use super::{Departure, Level};
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::particles::{Packed, Particles};
use crate::records::{Length, Routed};

impl Level {
    /// Moves every particle to the patch (and rank) holding its cell, and
    /// returns the owned particles whose cell is in no patch of the level,
    /// packed (copies that leave the level are dropped: they are recreated
    /// when the levels synchronise). With `leaving`, local patch `pi`'s
    /// particles outside the slot range `leaving[pi]` (`None`: all of them)
    /// are known to be in the patch and are not looked at (the last pass of
    /// a step notes that range, [`kernel::PassStats::leaving`]). Collective.
    pub fn migrate(
        &mut self,
        comm: &Comm,
        leaving: Option<&[Option<(usize, usize)>]>,
    ) -> Result<Vec<(Departure, Packed)>> {
        let t0 = std::time::Instant::now();
        let r = self.migrate_inner(comm, leaving);
        self.stats.migrate += t0.elapsed().as_secs_f64();
        r
    }

    fn migrate_inner(
        &mut self,
        comm: &Comm,
        leaving: Option<&[Option<(usize, usize)>]>,
    ) -> Result<Vec<(Departure, Packed)>> {
        let nr = comm.size() as usize;
        let mut send: Vec<Vec<u8>> = vec![Vec::new(); nr];
        let mut departures = Vec::new();
        let mut moving = Vec::new();
        for pi in 0..self.local.len() {
            moving.clear();
            let lp = &self.local[pi];
            let scan = match leaving {
                None => 0..lp.parts.len(),
                Some(l) => match l[pi] {
                    None => continue,
                    Some((a, b)) => a..(b + 1).min(lp.parts.len()),
                },
            };
            for i in scan {
                let c = self.cell_of(lp.parts.x[i], lp.parts.y[i]);
                if !lp.cells.contains_cell(c[0], c[1]) {
                    moving.push(i);
                }
            }
            if moving.is_empty() {
                continue;
            }
            // The grid's prepared P2G counted the particles that leave.
            self.local[pi].prepared = None;
            for &i in &moving {
                let parts = &self.local[pi].parts;
                if self.pack_for(parts, i, &mut send) {
                    self.crossings += 1;
                } else if parts.copy[i] == crate::particles::OWNED {
                    let d = Departure {
                        id: parts.id[i],
                        x: parts.x[i],
                        y: parts.y[i],
                    };
                    departures.push((d, parts.packed(i)));
                }
            }
            let mut mv = moving.iter().copied().peekable();
            self.local[pi].parts.retain(|i| {
                if mv.peek() == Some(&i) {
                    mv.next();
                    false
                } else {
                    true
                }
            });
        }
        self.deliver_to_neighbours(comm, send)?;
        Ok(departures)
    }

    /// This rank's part of a migration in which it sends nothing (after a
    /// failure it keeps its particles as they are): the exchange with the
    /// neighbours that [`Level::migrate`] makes, with empty messages.
    pub(super) fn migrate_nothing(&mut self, comm: &Comm) -> Result<()> {
        let send = vec![Vec::new(); comm.size() as usize];
        self.deliver_to_neighbours(comm, send)
    }

    /// Ranks owning a patch that overlaps one of this rank's patches.
    fn peers(&self, me: i32) -> Vec<i32> {
        let mut v: Vec<i32> = self
            .local
            .iter()
            .flat_map(|p| p.nbrs.iter().map(|&(q, _)| self.owner[q]))
            .filter(|&r| r != me)
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// As [`Level::deliver`], for records that go to this rank's patches or
    /// to neighbouring patches only (a step moves a particle less than a
    /// cell): point-to-point with the neighbour ranks, sizes first.
    fn deliver_to_neighbours(&mut self, comm: &Comm, mut send: Vec<Vec<u8>>) -> Result<()> {
        let me = comm.rank();
        let peers = self.peers(me);
        // A record for a rank that is no neighbour cannot be sent (the
        // exchange is with the neighbours only): it is an error, returned
        // after the exchange so that the other ranks are not left waiting
        // in it (the caller agrees on it).
        let mut err = None;
        if let Some(r) = (0..send.len()).find(|&r| {
            r as i32 != me && !send[r].is_empty() && peers.binary_search(&(r as i32)).is_err()
        }) {
            err = Some(Error::new(
                Status::Internal,
                format!("a particle of level {} moved from a patch of rank {me} to rank {r}, which owns no neighbouring patch", self.l),
            ));
            for (q, b) in send.iter_mut().enumerate() {
                if q as i32 != me && peers.binary_search(&(q as i32)).is_err() {
                    b.clear();
                }
            }
        }
        let lens: Vec<[u8; 8]> = peers
            .iter()
            .map(|&r| Length::write(send[r as usize].len()))
            .collect();
        let size_msgs: Vec<(i32, &[u8])> =
            peers.iter().zip(&lens).map(|(&r, l)| (r, &l[..])).collect();
        let size_recv: Vec<(i32, usize)> = peers.iter().map(|&r| (r, Length::BYTES)).collect();
        let got = comm.exchange_with(&size_msgs, &size_recv, 18)?;
        let data_msgs: Vec<(i32, &[u8])> = peers
            .iter()
            .map(|&r| (r, send[r as usize].as_slice()))
            .collect();
        let data_recv: Vec<(i32, usize)> = peers
            .iter()
            .zip(&got)
            .map(|(&r, b)| (r, Length::read(b)))
            .collect();
        self.stats.bytes_sent += data_msgs
            .iter()
            .map(|m| (m.1.len() + Length::BYTES) as u64)
            .sum::<u64>();
        let mut bufs = comm.exchange_with(&data_msgs, &data_recv, 19)?;
        drop(data_msgs);
        bufs.push(std::mem::take(&mut send[me as usize]));
        self.push_records(&bufs)?;
        err.map_or(Ok(()), Err)
    }

    /// Appends the records ([`Routed`]) of `bufs` to their patches, each
    /// patch's arrivals sorted by global id.
    fn push_records(&mut self, bufs: &[Vec<u8>]) -> Result<()> {
        // (dest patch, id, buffer, offset of the record)
        let mut arr: Vec<(usize, u64, usize, usize)> = Vec::new();
        for (bi, b) in bufs.iter().enumerate() {
            for (n, (q, p)) in Routed::all(b).enumerate() {
                arr.push((q, p.id(), bi, n * Routed::BYTES));
            }
        }
        arr.sort_unstable();
        // One bulk append per destination patch.
        let mut at = 0;
        while at < arr.len() {
            let q = arr[at].0;
            let end = at + arr[at..].partition_point(|e| e.0 == q);
            let p = self.local_mut(q).ok_or_else(|| {
                Error::new(
                    Status::Internal,
                    format!("a particle was sent to patch {q}, which this rank does not own"),
                )
            })?;
            p.prepared = None;
            p.parts.extend_packed(
                arr[at..end]
                    .iter()
                    .map(|&(_, _, bi, off)| Routed::read(&bufs[bi][off..]).1),
            );
            at = end;
        }
        Ok(())
    }

    /// Delivers particles to the patches that own them (collective):
    /// `send[r]` holds records ([`Routed`]) for
    /// patches of rank `r`. Each patch appends its arrivals sorted by
    /// global id, so the order does not depend on where they came from.
    /// This rank's own records are read where they are (not copied through
    /// MPI); `send` is left as it was.
    pub fn deliver(&mut self, comm: &Comm, send: &mut [Vec<u8>]) -> Result<()> {
        if !comm.any(send.iter().any(|b| !b.is_empty()))? {
            return Ok(());
        }
        let me = comm.rank() as usize;
        self.stats.bytes_sent += send
            .iter()
            .enumerate()
            .filter(|&(r, _)| r != me)
            .map(|(_, b)| b.len() as u64)
            .sum::<u64>();
        let mut bufs = [Vec::new(), std::mem::take(&mut send[me])];
        let r = match comm.alltoallv_bytes(send) {
            Ok((recv, _)) => {
                bufs[0] = recv;
                self.push_records(&bufs)
            }
            Err(e) => Err(e),
        };
        send[me] = std::mem::take(&mut bufs[1]);
        r
    }

    /// Appends the record ([`Routed`]) of particle `i` of `parts` for the
    /// patch holding its cell to the buffer of the patch's owner; returns
    /// false when no patch of the level holds the cell.
    pub fn pack_for(&self, parts: &Particles, i: usize, send: &mut [Vec<u8>]) -> bool {
        let c = self.cell_of(parts.x[i], parts.y[i]);
        match self.find_patch(c) {
            Some(q) => {
                Routed::write(&mut send[self.owner[q] as usize], q, &parts.packed(i));
                true
            }
            None => false,
        }
    }

    /// Re-assigns patches to ranks by particle count (greedy, deterministic)
    /// and moves whole patches to their new owners (collective).
    pub fn rebalance(&mut self, comm: &Comm) -> Result<()> {
        let np = self.patches.len();
        let mut counts = vec![0u64; np];
        for p in &self.local {
            counts[p.k] = p.parts.len() as u64;
        }
        comm.sum_u64(&mut counts)?;
        // Empty patches weigh 1 so that they spread over the ranks too.
        for c in counts.iter_mut() {
            *c = (*c).max(1);
        }
        let owner = crate::balance::balance(&counts, comm.size() as usize);
        if owner == self.owner {
            return Ok(());
        }
        let nr = comm.size() as usize;
        let me = comm.rank();
        let mut send: Vec<Vec<u8>> = vec![Vec::new(); nr];
        let mut keep = Vec::new();
        for p in std::mem::take(&mut self.local) {
            let r = owner[p.k];
            if r == me {
                keep.push(p);
                continue;
            }
            let buf = &mut send[r as usize];
            for i in 0..p.parts.len() {
                Routed::write(buf, p.k, &p.parts.packed(i));
            }
        }
        self.owner = owner;
        self.local = (0..np)
            .filter(|&k| self.owner[k] == me)
            .map(|k| match keep.iter().position(|p| p.k == k) {
                Some(i) => keep.swap_remove(i),
                None => self.new_local(k),
            })
            .collect();
        self.local.sort_by_key(|p| p.k);
        let (recv, _) = comm.alltoallv_bytes(&send)?;
        // A moved patch arrives from one rank, in its (canonical) order.
        for (q, p) in Routed::all(&recv) {
            self.local_mut(q)
                .expect("moved patches go to their new owner")
                .parts
                .push_packed(p);
        }
        Ok(())
    }
}
