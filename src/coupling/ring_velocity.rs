//! The coarse level's nodal velocities prescribed on a refined level's
//! ghost-ring nodes (see the notes of [`crate::coupling`], "The ghost ring
//! moves with the coarse level").
//!
//! After each step of a coarse level (USL: after its grid update and
//! contact phase; MUSL: after its re-map) the coarse grids' nodal mass and
//! velocities at the step's start and end are saved, at the coarse nodes
//! the finer level's ghost ring needs, and sent to the ranks owning the
//! fine patches that need them ([`RingLevel::capture`],
//! [`RingLevel::exchange`]). In each of the fine level's two substeps,
//! after its grid update (and contact phase), and after MUSL's re-map,
//! every fine node that touches a cell inside the domain but outside the
//! fine level's own region `R` (the nodes on `R`'s edge and all the ghost
//! ring's nodes) gets the coarse velocity interpolated with the coarse
//! linear hats over the coarse stencil nodes that carry mass (weights
//! renormalised; a node whose stencil has no mass is left alone), linear in
//! time between the coarse step's start and end velocities at the
//! fractions `1/4 -> 3/4` (first substep) and `3/4 -> 5/4` (second) of the
//! coarse step ([`RingLevel::prescribe`]).
//!
//! Every coarse node is taken from one coarse patch: the lowest-index
//! patch whose grid holds the node and exists (a patch without particles
//! has no grid). After the level's nodal sums every grid holding a node
//! holds the same values there, so the choice only makes the result
//! independent of the number of ranks and of which rank owns which patch.
//! What is sent, and in which order, follows from the layout alone
//! (computed when the layout changes, [`RingLevel::update`]); a coarse
//! patch without a grid sends a marker, so the message sizes are fixed.

use super::layout::{grid_nodes, in_any};
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::geom::IBox;
use crate::kernel::grid::{mf, vl, Node4};
use crate::kernel::{apply_bc, GridPhase, Scheme, StepParams};
use crate::level::{GridHook, Level, LocalPatch};

/// MPI tag of the exchange of the saved coarse velocities.
const TAG_RING_VELOCITY: i32 = 24;

/// Values saved per coarse node: the mass, the velocity at the coarse
/// step's start (x, y) and at its end (x, y).
const NV: usize = 5;

/// The mass sent for a coarse node of a patch that has no grid (masses are
/// never negative): the receiver takes the node from another patch.
const NO_GRID: f64 = -1.0;

/// The time fractions of the coarse step at which a fine substep starts,
/// for the first and the second substep; each ends half a coarse step
/// later. Shifted by a quarter from the substeps' own `0 -> 1/2` and `1/2
/// -> 1`: the scheme's grid velocities sit at the half steps of the
/// staggering (the coarse `v0` and `v` at `t - dt/2` and `t + dt/2`), so
/// the fine substeps' are at a quarter of a coarse step from their ends,
/// and the ring moves over a coarse step by exactly `dt v_end`, as the
/// coarse level does. The unshifted fractions failed the vibrating plate's
/// accuracy test (`test_levels_accuracy`) in the experiment that found the
/// prescription.
const FRACTIONS: [f64; 2] = [0.25, 0.75];

/// A fine node the ring prescribes: its storage index on its patch's grid
/// and its coarse stencil (up to four nodes, as slots of the patch's
/// table of coarse nodes, with their linear-hat weights).
#[derive(Clone, Copy, Debug)]
struct Prescribed {
    /// Storage index on the fine patch's grid.
    idx: u32,
    /// Number of stencil nodes (1, 2 or 4).
    n: u8,
    /// Slots in [`FinePatch::coarse`].
    slot: [u32; 4],
    /// Weights (1, 1/2 or 1/4 each).
    w: [f64; 4],
}

/// What one local fine patch needs: its prescribed nodes, the coarse nodes
/// their stencils read and the coarse values saved there.
#[derive(Default)]
struct FinePatch {
    /// The fine patch's index in its level.
    k: usize,
    /// The coarse nodes the stencils read (sorted by row, then column).
    coarse: Vec<[i64; 2]>,
    /// Per coarse node: mass, start and end velocity ([`NV`]) of the last
    /// coarse step.
    vals: Vec<[f64; NV]>,
    /// Per coarse node: the coarse patch its values came from (`usize::MAX`
    /// when none yet this coarse step).
    from: Vec<usize>,
    /// The prescribed nodes.
    nodes: Vec<Prescribed>,
}

/// One (coarse patch, fine patch) pair the values travel along: the fine
/// patch's coarse nodes on the coarse patch's grid.
#[derive(Default)]
struct Route {
    /// The coarse patch.
    q: usize,
    /// The fine patch's position in this rank's [`RingLevel::fine`] (when
    /// this rank owns it).
    f: usize,
    /// The rank that owns the fine patch (sender side) or the coarse patch
    /// (receiver side).
    rank: i32,
    /// Storage indices of the nodes on the coarse patch's grid (sender
    /// side), in the order of the fine patch's coarse nodes.
    grid: Vec<u32>,
    /// Slots in the fine patch's [`FinePatch::coarse`] (receiver side),
    /// in the same order.
    slots: Vec<u32>,
}

/// The layout a [`RingLevel`]'s plan was made for: coarse patches and
/// owners, fine patches and owners, fine own boxes, fine domain, rank.
type RingKey = (
    Vec<IBox>,
    Vec<i32>,
    Vec<IBox>,
    Vec<i32>,
    Vec<IBox>,
    IBox,
    i32,
);

/// The prescription on one refined level: the plan (which fine nodes, which
/// coarse nodes, who sends what to whom), made when the layout changes,
/// and the coarse values of the last coarse step.
#[derive(Default)]
pub(super) struct RingLevel {
    /// The layout the plan was made for.
    key: Option<RingKey>,
    /// This rank's fine patches with prescribed nodes, in the order of the
    /// fine level's local patches (every local patch has an entry).
    fine: Vec<FinePatch>,
    /// Per local coarse patch (in the coarse level's local order): the
    /// routes to fine patches, in increasing fine patch index.
    out: Vec<Vec<Route>>,
    /// Routes arriving from other ranks, in the order each sender packs
    /// them (increasing coarse patch, then fine patch), grouped by rank in
    /// increasing rank.
    inc: Vec<Route>,
    /// Outgoing messages (rank, bytes), in increasing rank; the bytes are
    /// rewritten at every capture.
    send: Vec<(i32, Vec<u8>)>,
    /// Expected incoming message sizes (rank, bytes), in increasing rank.
    recv: Vec<(i32, usize)>,
    /// The time fractions of the coarse step of the coming fine substep.
    a: [f64; 2],
}

/// The coarse stencil of fine node `(i, j)` (fine cells halving coarse
/// ones): up to two coarse indices and weights per axis, in increasing
/// index.
fn axis_stencil(i: i64) -> ([i64; 2], [f64; 2], usize) {
    if i.rem_euclid(2) == 0 {
        ([i.div_euclid(2), 0], [1.0, 0.0], 1)
    } else {
        (
            [(i - 1).div_euclid(2), (i + 1).div_euclid(2)],
            [0.5, 0.5],
            2,
        )
    }
}

/// Whether fine node `(i, j)` touches a cell inside `domain` but outside
/// the own boxes `owned`: a node of the ghost ring or of `R`'s edge
/// (not one inside `R`, on a domain face `R` reaches, or outside the
/// domain).
fn on_ring(owned: &[IBox], domain: &IBox, i: i64, j: i64) -> bool {
    [[i - 1, j - 1], [i, j - 1], [i - 1, j], [i, j]]
        .iter()
        .any(|&c| domain.contains_cell(c[0], c[1]) && !in_any(owned, c))
}

/// The prescribed nodes of fine patch `cells` and the coarse nodes their
/// stencils read (sorted by row, then column).
fn fine_patch_plan(cells: &IBox, fine: &Level) -> (Vec<Prescribed>, Vec<[i64; 2]>) {
    let nb = grid_nodes(cells);
    let n0 = nb.shape()[0];
    let mut raw: Vec<(u32, u8, [[i64; 2]; 4], [f64; 4])> = Vec::new();
    for j in nb.lo[1]..nb.hi[1] {
        for i in nb.lo[0]..nb.hi[0] {
            if !on_ring(&fine.owned, &fine.domain, i, j) {
                continue;
            }
            let (ci, wi, ni) = axis_stencil(i);
            let (cj, wj, nj) = axis_stencil(j);
            let mut c = [[0i64; 2]; 4];
            let mut w = [0.0; 4];
            let mut n = 0;
            // Column index outer, row index inner (the order of the sums).
            for a in 0..ni {
                for b in 0..nj {
                    c[n] = [ci[a], cj[b]];
                    w[n] = wi[a] * wj[b];
                    n += 1;
                }
            }
            let idx = (j - nb.lo[1]) * n0 + (i - nb.lo[0]);
            raw.push((idx as u32, n as u8, c, w));
        }
    }
    let mut coarse: Vec<[i64; 2]> = raw
        .iter()
        .flat_map(|r| r.2[..r.1 as usize].iter().copied())
        .collect();
    coarse.sort_unstable_by_key(|c| (c[1], c[0]));
    coarse.dedup();
    let slot = |c: [i64; 2]| {
        coarse
            .binary_search_by_key(&(c[1], c[0]), |e| (e[1], e[0]))
            .expect("every stencil node is listed") as u32
    };
    let nodes = raw
        .iter()
        .map(|&(idx, n, c, w)| {
            let mut s = [0u32; 4];
            for (t, cc) in s.iter_mut().zip(&c[..n as usize]) {
                *t = slot(*cc);
            }
            Prescribed { idx, n, slot: s, w }
        })
        .collect();
    (nodes, coarse)
}

/// The positions in `coarse` (a fine patch's coarse nodes) of the nodes on
/// the grid of coarse patch `qcells`, and their storage indices there.
fn on_coarse_grid(coarse: &[[i64; 2]], qcells: &IBox) -> (Vec<u32>, Vec<u32>) {
    let nb = grid_nodes(qcells);
    let n0 = nb.shape()[0];
    let mut slots = Vec::new();
    let mut grid = Vec::new();
    for (s, c) in coarse.iter().enumerate() {
        if nb.contains_cell(c[0], c[1]) {
            slots.push(s as u32);
            grid.push(((c[1] - nb.lo[1]) * n0 + (c[0] - nb.lo[0])) as u32);
        }
    }
    (slots, grid)
}

impl RingLevel {
    /// Makes the plan for the pair (`coarse`, `fine` = the next finer level)
    /// on rank `me` when their layout changed (never, in a simulation after
    /// its first step): which fine nodes each local fine patch prescribes,
    /// the coarse nodes their stencils read, and the routes the coarse
    /// values take from the coarse patches' owners.
    pub(super) fn update(&mut self, coarse: &Level, fine: &Level, me: i32) {
        let same = self.key.as_ref().is_some_and(|(cp, co, fp, fo, ow, d, r)| {
            *cp == coarse.patches
                && *co == coarse.owner
                && *fp == fine.patches
                && *fo == fine.owner
                && *ow == fine.owned
                && *d == fine.domain
                && *r == me
        });
        if same {
            return;
        }
        self.key = Some((
            coarse.patches.clone(),
            coarse.owner.clone(),
            fine.patches.clone(),
            fine.owner.clone(),
            fine.owned.clone(),
            fine.domain,
            me,
        ));
        // Every fine patch's coarse nodes (all ranks: a sender needs those
        // of the fine patches its coarse patches serve); local ones keep
        // their prescribed nodes.
        let mut all: Vec<Vec<[i64; 2]>> = Vec::with_capacity(fine.patches.len());
        let mut local_pos = vec![usize::MAX; fine.patches.len()];
        self.fine.clear();
        for (k, cells) in fine.patches.iter().enumerate() {
            let (nodes, cn) = fine_patch_plan(cells, fine);
            if fine.owner[k] == me {
                local_pos[k] = self.fine.len();
                self.fine.push(FinePatch {
                    k,
                    vals: vec![[NO_GRID, 0.0, 0.0, 0.0, 0.0]; cn.len()],
                    from: vec![usize::MAX; cn.len()],
                    coarse: cn.clone(),
                    nodes,
                });
            }
            all.push(cn);
        }
        // The routes: every (coarse patch, fine patch) pair whose grids
        // share a needed coarse node, with one end on this rank.
        self.out.clear();
        self.inc.clear();
        let local_coarse: Vec<usize> = (0..coarse.patches.len())
            .filter(|&q| coarse.owner[q] == me)
            .collect();
        for &q in &local_coarse {
            let mut routes = Vec::new();
            for (k, cn) in all.iter().enumerate() {
                if cn.is_empty() {
                    continue;
                }
                let (slots, grid) = on_coarse_grid(cn, &coarse.patches[q]);
                if grid.is_empty() {
                    continue;
                }
                routes.push(Route {
                    q,
                    f: local_pos[k],
                    rank: fine.owner[k],
                    grid,
                    slots,
                });
            }
            self.out.push(routes);
        }
        for q in 0..coarse.patches.len() {
            if coarse.owner[q] == me {
                continue;
            }
            for (pos, fp) in self.fine.iter().enumerate() {
                if fp.coarse.is_empty() {
                    continue;
                }
                let (slots, _) = on_coarse_grid(&fp.coarse, &coarse.patches[q]);
                if slots.is_empty() {
                    continue;
                }
                self.inc.push(Route {
                    q,
                    f: pos,
                    rank: coarse.owner[q],
                    grid: Vec::new(),
                    slots,
                });
            }
        }
        // Grouped by sending rank; within a rank in the sender's packing
        // order (coarse patch, then fine patch: already so).
        self.inc.sort_by_key(|r| (r.rank, r.q, self.fine[r.f].k));
        self.send.clear();
        for routes in &self.out {
            for r in routes.iter().filter(|r| r.rank != me) {
                if let Err(s) = self.send.binary_search_by_key(&r.rank, |e| e.0) {
                    self.send.insert(s, (r.rank, Vec::new()));
                }
            }
        }
        self.recv.clear();
        for r in &self.inc {
            match self.recv.last_mut() {
                Some(e) if e.0 == r.rank => e.1 += 8 * NV * r.slots.len(),
                _ => self.recv.push((r.rank, 8 * NV * r.slots.len())),
            }
        }
    }

    /// Sets the time fractions of the coarse step for the coming substep of
    /// the fine level (the second of the two when `second`; see
    /// [`FRACTIONS`]).
    pub(super) fn set_substep(&mut self, second: bool) {
        let a0 = FRACTIONS[usize::from(second)];
        self.a = [a0, a0 + 0.5];
    }

    /// Saves the coarse values this plan routes from the coarse level's
    /// local patches `local` (after its step of `dt`): into the local fine
    /// patches' tables, and into the messages to other ranks. A patch
    /// without a grid contributes [`NO_GRID`] markers.
    fn capture(&mut self, local: &[LocalPatch], dt: f64, me: i32) {
        for fp in &mut self.fine {
            fp.from.fill(usize::MAX);
            fp.vals.fill([NO_GRID, 0.0, 0.0, 0.0, 0.0]);
        }
        for (_, b) in &mut self.send {
            b.clear();
        }
        let RingLevel {
            fine, out, send, ..
        } = self;
        for (p, routes) in local.iter().zip(out.iter()) {
            let g = p.grid.as_ref();
            for r in routes {
                debug_assert_eq!(r.q, p.k);
                let value = |idx: u32| -> [f64; NV] {
                    let Some(g) = g else {
                        return [NO_GRID, 0.0, 0.0, 0.0, 0.0];
                    };
                    let k = idx as usize;
                    let m = g.mass[k];
                    if m > 0.0 && (1.0 / m).is_finite() {
                        let v = g.vel[k].0;
                        let f = g.mom_force[k].0;
                        let e = [v[vl::VX], v[vl::VY]];
                        [
                            m,
                            e[0] - dt * f[mf::FX] / m,
                            e[1] - dt * f[mf::FY] / m,
                            e[0],
                            e[1],
                        ]
                    } else {
                        [m, 0.0, 0.0, 0.0, 0.0]
                    }
                };
                if r.rank == me {
                    let fp = &mut fine[r.f];
                    for (&idx, &s) in r.grid.iter().zip(&r.slots) {
                        take(fp, s as usize, r.q, value(idx));
                    }
                } else {
                    let s = send
                        .binary_search_by_key(&r.rank, |e| e.0)
                        .expect("every remote route has a message");
                    let buf = &mut send[s].1;
                    for &idx in &r.grid {
                        for v in value(idx) {
                            buf.extend_from_slice(&v.to_ne_bytes());
                        }
                    }
                }
            }
        }
    }

    /// Sends the captured coarse values to the ranks owning the fine
    /// patches that need them and takes what arrives (point-to-point with
    /// the ranks the plan names; every rank calls it after every coarse
    /// step the fine level's substeps follow).
    pub(super) fn exchange(&mut self, comm: &Comm) -> Result<()> {
        if self.send.is_empty() && self.recv.is_empty() {
            return Ok(());
        }
        let sends: Vec<(i32, &[u8])> = self.send.iter().map(|e| (e.0, e.1.as_slice())).collect();
        let bufs = comm.exchange_with(&sends, &self.recv, TAG_RING_VELOCITY)?;
        let mut r = 0;
        for (bi, (rank, size)) in self.recv.iter().enumerate() {
            let buf = &bufs[bi];
            let mut at = 0;
            while r < self.inc.len() && self.inc[r].rank == *rank {
                let route = &self.inc[r];
                let fp = &mut self.fine[route.f];
                for &s in &route.slots {
                    let mut v = [0.0; NV];
                    for x in &mut v {
                        let mut b = [0u8; 8];
                        b.copy_from_slice(&buf[at..at + 8]);
                        *x = f64::from_ne_bytes(b);
                        at += 8;
                    }
                    take(fp, s as usize, route.q, v);
                }
                r += 1;
            }
            if at != *size {
                return Err(Error::new(
                    Status::Internal,
                    format!(
                        "ring velocities from rank {rank}: {size} bytes arrived, {at} expected"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Prescribes the saved coarse velocities on the ring nodes of the
    /// fine level's local patches `local` (see the module notes) in a
    /// substep of `prm` at `phase`: after the grid update, `v` and `v0` at
    /// the substep's end and start, the momentum `m v0` and the force `m (v
    /// - v0)/dt` to match; after MUSL's re-map, `v0` and the momentum at
    /// the substep's end. The face conditions are applied again on every
    /// patch with a prescribed node.
    fn prescribe(&self, local: &mut [LocalPatch], prm: &StepParams, phase: GridPhase) {
        let dt = prm.dt;
        let [a0, a1] = self.a;
        for (p, fp) in local.iter_mut().zip(&self.fine) {
            debug_assert_eq!(p.k, fp.k);
            let Some(grid) = p.grid.as_mut() else {
                continue;
            };
            if fp.nodes.is_empty() {
                continue;
            }
            for pn in &fp.nodes {
                let (mut w, mut va, mut vb) = (0.0, [0.0; 2], [0.0; 2]);
                for t in 0..pn.n as usize {
                    let c = &fp.vals[pn.slot[t] as usize];
                    if !(c[0] > 0.0) {
                        continue;
                    }
                    let ww = pn.w[t];
                    w += ww;
                    for d in 0..2 {
                        let (vs, ve) = (c[1 + d], c[3 + d]);
                        va[d] += ww * (vs + a0 * (ve - vs));
                        vb[d] += ww * (vs + a1 * (ve - vs));
                    }
                }
                if !(w > 0.0) {
                    continue;
                }
                let (va, vb) = ([va[0] / w, va[1] / w], [vb[0] / w, vb[1] / w]);
                let idx = pn.idx as usize;
                let m = grid.mass[idx];
                match phase {
                    GridPhase::Updated => {
                        grid.vel[idx] = Node4([vb[0], vb[1], va[0], va[1]]);
                        let pf = &mut grid.mom_force[idx].0;
                        pf[mf::PX] = m * va[0];
                        pf[mf::PY] = m * va[1];
                        pf[mf::FX] = m * (vb[0] - va[0]) / dt;
                        pf[mf::FY] = m * (vb[1] - va[1]) / dt;
                    }
                    GridPhase::Remapped => {
                        let vel = &mut grid.vel[idx].0;
                        vel[vl::V0X] = vb[0];
                        vel[vl::V0Y] = vb[1];
                        let pf = &mut grid.mom_force[idx].0;
                        pf[mf::PX] = m * vb[0];
                        pf[mf::PY] = m * vb[1];
                    }
                }
            }
            apply_bc(grid, &prm.boundary);
        }
    }
}

/// Takes coarse values `v` from coarse patch `q` for slot `s` of `fp` when
/// `q` has a grid there and no lower-index patch's values were taken.
#[inline]
fn take(fp: &mut FinePatch, s: usize, q: usize, v: [f64; NV]) {
    if v[0] != NO_GRID && q < fp.from[s] {
        fp.from[s] = q;
        fp.vals[s] = v;
    }
}

/// The prescription on every refined level of a hierarchy (indexed by the
/// fine level; entry 0 unused). Holds no state between steps that a step
/// does not recompute first: a clone is empty.
#[derive(Default)]
pub(super) struct RingVelocities {
    /// Per fine level.
    pub(super) levels: Vec<RingLevel>,
}

impl Clone for RingVelocities {
    fn clone(&self) -> Self {
        RingVelocities::default()
    }
}

impl std::fmt::Debug for RingVelocities {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("RingVelocities")
    }
}

/// The grid hook of one level's step (see [`GridHook`]): prescribes the
/// ring of the level (a refined one) and saves the coarse values the next
/// finer level needs.
pub(super) struct RingHook<'a> {
    /// The level's own prescription (refined levels).
    pub(super) prescribe: Option<&'a RingLevel>,
    /// The next finer level's prescription, whose coarse values this
    /// level's step saves.
    pub(super) capture: Option<&'a mut RingLevel>,
    /// This rank.
    pub(super) me: i32,
}

impl GridHook for RingHook<'_> {
    fn grid_hook(&mut self, local: &mut [LocalPatch], prm: &StepParams, phase: GridPhase) {
        if let Some(r) = self.prescribe {
            r.prescribe(local, prm, phase);
        }
        // The values the particles read at the end of the step: after the
        // grid update (USL), after the re-map (MUSL; `v` and the forces
        // are the update's).
        let last = match prm.scheme {
            Scheme::Usl => phase == GridPhase::Updated,
            Scheme::Musl => phase == GridPhase::Remapped,
            Scheme::Usf => false,
        };
        if last {
            if let Some(c) = self.capture.as_deref_mut() {
                c.capture(local, prm.dt, self.me);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fine_nodes_read_the_coarse_hats_of_the_nodes_around_them() {
        // Even indices sit on a coarse node, odd ones halfway between two.
        assert_eq!(axis_stencil(4), ([2, 0], [1.0, 0.0], 1));
        assert_eq!(axis_stencil(5), ([2, 3], [0.5, 0.5], 2));
        assert_eq!(axis_stencil(-1), ([-1, 0], [0.5, 0.5], 2));
        assert_eq!(axis_stencil(-2), ([-1, 0], [1.0, 0.0], 1));
    }

    #[test]
    fn the_ring_is_the_nodes_touching_a_domain_cell_outside_the_region() {
        let domain = IBox::new([0, 0], [16, 16]);
        let owned = [IBox::new([4, 4], [12, 12])];
        // R's corner and edge, the ring, the domain's corner.
        for n in [[4, 4], [8, 4], [12, 8], [3, 8], [0, 0], [16, 16]] {
            assert!(on_ring(&owned, &domain, n[0], n[1]), "{n:?}");
        }
        // Inside R, and beyond the domain.
        for n in [[5, 5], [11, 11], [-1, 5], [17, 3]] {
            assert!(!on_ring(&owned, &domain, n[0], n[1]), "{n:?}");
        }
        // A region reaching the domain's left face: its nodes on the face
        // are not ring nodes (no cell outside R inside the domain).
        let owned = [IBox::new([0, 4], [12, 12])];
        assert!(!on_ring(&owned, &domain, 0, 8));
        assert!(on_ring(&owned, &domain, 0, 4));
    }

    #[test]
    fn a_coarse_node_comes_from_the_lowest_patch_with_a_grid() {
        let mut fp = FinePatch {
            k: 0,
            coarse: vec![[0, 0]],
            vals: vec![[NO_GRID, 0.0, 0.0, 0.0, 0.0]],
            from: vec![usize::MAX],
            nodes: Vec::new(),
        };
        // Any arrival order gives the values of patch 2, the lowest with a
        // grid (patch 1 has none).
        take(&mut fp, 0, 5, [1.0, 5.0, 5.0, 5.0, 5.0]);
        take(&mut fp, 0, 1, [NO_GRID, 0.0, 0.0, 0.0, 0.0]);
        take(&mut fp, 0, 2, [1.0, 2.0, 2.0, 2.0, 2.0]);
        take(&mut fp, 0, 3, [1.0, 3.0, 3.0, 3.0, 3.0]);
        assert_eq!(fp.from[0], 2);
        assert_eq!(fp.vals[0], [1.0, 2.0, 2.0, 2.0, 2.0]);
    }

    #[test]
    fn the_substeps_sit_a_quarter_of_a_coarse_step_late() {
        let mut r = RingLevel::default();
        r.set_substep(false);
        assert_eq!(r.a, [0.25, 0.75]);
        r.set_substep(true);
        assert_eq!(r.a, [0.75, 1.25]);
    }
}
