//! One level of patches over MPI ranks: each rank advances the patches it
//! owns with the kernel phases, and the ranks agree on every shared node.
//!
//! **Ghosts: a sum of nodal data over shared nodes** (not ghost particles).
//! Each patch maps only its own particles onto a grid over its cells grown
//! by [`GHOST`] cell; after each P2G phase, every node that several patches
//! store gets the sum of their partial values, added in increasing patch
//! index so that every copy of a node holds bitwise the same number. We chose
//! this over the paper's ghost particles because it is exact after every
//! phase (the paper's outer ghost layers go stale each step, so it needs 4
//! ghost cells and extra copies), it sends a 3-node-wide strip of nodal
//! values instead of a ring of particles several cells wide (MUSL's two
//! mappings would need a ring of about 6 cells to stay exact), and patches
//! without particles need no grid and send nothing.
//!
//! **Canonical particle order.** A patch keeps its particles in an order that
//! does not depend on the number of ranks: particles that stay keep their
//! order, arrivals (from any patch, local or remote) are appended sorted by
//! global id. With a fixed patch layout the result is therefore bitwise the
//! same on any number of ranks; a different patch layout changes only the
//! association of nodal sums (round-off).
//!
//! **Leaving the level.** After each step every particle goes to the patch
//! (and rank) holding its cell. A particle whose cell is in no patch of the
//! level is handed back to the caller: on the coarsest level that means it
//! left the domain; on a finer level it moves to a coarser level.

use crate::comm::Comm;
use crate::contact::resolve::{LevelGeometry, PatchRef};
use crate::contact::LevelStepContact;
use crate::error::{Error, Result, Status};
use crate::geom::IBox;
pub use crate::kernel::Fields;
use crate::kernel::{
    self, DomainFace, FaceBc, Grid, PatchBoundary, PatchMut, Patches, Pipeline, Prepared,
    StepParams,
};
use crate::material::MatParams;
use crate::particles::Particles;

/// Ghost cells around a patch's grid: one, so every particle of the patch's
/// cells has its 3-node stencil on the grid.
pub const GHOST: i64 = 1;

/// A patch owned by this rank.
///
/// `Clone` is written out so that `clone_from` copies the particles and the
/// grid into the arrays `self` already has (see [`Level`]).
#[derive(Debug)]
pub struct LocalPatch {
    /// Index of the patch in the level's patch list.
    pub k: usize,
    /// The patch's cells.
    pub cells: IBox,
    /// The particles whose cell lies in the patch.
    pub parts: Particles,
    /// The grid (allocated while the patch holds particles).
    pub grid: Option<Grid>,
    /// What the grid holds ahead of the next step (see
    /// [`kernel::Prepared`]); forgotten whenever the particles change
    /// outside a step ([`Level::unprepare`]).
    prepared: Option<Prepared>,
    /// Other patches whose node boxes overlap this one's, with the overlap
    /// (node indices, half-open), in increasing patch index.
    nbrs: Vec<(usize, IBox)>,
}

/// A particle that left the level during a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Departure {
    /// Global id.
    pub id: u64,
    /// Position when it left.
    pub x: f64,
    /// Position when it left.
    pub y: f64,
}

/// One level of patches and the particles this rank owns on it.
///
/// `Clone` is written out: `clone` copies every field as a derived one
/// would, and `clone_from` copies field by field into the storage `self`
/// already has (the patches' particle arrays and grids, through
/// [`Particles`]' and [`Grid`]'s own `clone_from`), so that a copy taken
/// over and over — the snapshot [`crate::sim::Simulation::step`] returns to
/// — allocates nothing once its buffers are big enough. Either way the
/// result equals the source field by field.
#[derive(Debug)]
pub struct Level {
    /// Level index (0 = coarsest).
    pub l: usize,
    /// Cell size.
    pub h: f64,
    /// Domain origin (node `(0, 0)` of every level).
    pub origin: [f64; 2],
    /// The domain as a box of this level's cells.
    pub domain: IBox,
    /// The boxes the level computes on (its own boxes plus the ghost ring
    /// of copied particles for a refined level), disjoint.
    pub boxes: Vec<IBox>,
    /// The level's own boxes: the region whose particles it owns.
    pub owned: Vec<IBox>,
    /// Patch size the boxes were tiled with.
    pub patch_size: [i64; 2],
    /// All patches of the level (the same on every rank).
    pub patches: Vec<IBox>,
    /// Owner rank of each patch.
    pub owner: Vec<i32>,
    /// The patches this rank owns, in increasing patch index.
    pub local: Vec<LocalPatch>,
    /// Face conditions (left, right, bottom, top) of the domain.
    pub bc: [FaceBc; 4],
    /// Particles this rank moved from one of its patches to another patch
    /// of the level (any rank), since creation.
    pub crossings: u64,
    /// Time and traffic of this rank on the level, since creation.
    pub stats: LevelStats,
    /// Reused buffer for the ordered nodal sums: written before it is read
    /// within one exchange, so it is no state (a clone starts it empty and
    /// `clone_from` keeps its own).
    scratch: Vec<f64>,
    /// `min h / (c + |v|)` over this rank's particles of the level as the
    /// last pass of the last successful step left them (infinite without
    /// particles): bit for bit [`Level::local_dt_cfl1`] of the state right
    /// after that step (see [`kernel::PassStats::dt_cfl1`]), so a caller
    /// whose particles nothing else has touched since need not recompute it.
    pub step_dt_cfl1: f64,
}

/// Where a rank's time on a level goes, and what it sends.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LevelStats {
    /// Seconds in the kernel phases (P2G, grid update, G2P).
    pub compute: f64,
    /// Seconds in nodal-sum exchanges (packing, MPI, ordered sums; includes
    /// waiting for slower ranks).
    pub exchange: f64,
    /// Seconds in particle migration (including its MPI exchange).
    pub migrate: f64,
    /// Seconds synchronising this level with the next finer one (level
    /// changes and the copies that couple the two levels; see
    /// [`crate::coupling::Coupler::sync`]).
    pub coupling: f64,
    /// Bytes this rank sent to other ranks (nodal sums and particles).
    pub bytes_sent: u64,
    /// Steps taken.
    pub steps: u64,
}

impl Clone for LocalPatch {
    fn clone(&self) -> Self {
        let LocalPatch {
            k,
            cells,
            parts,
            grid,
            prepared,
            nbrs,
        } = self;
        LocalPatch {
            k: *k,
            cells: *cells,
            parts: parts.clone(),
            grid: grid.clone(),
            prepared: *prepared,
            nbrs: nbrs.clone(),
        }
    }

    fn clone_from(&mut self, src: &Self) {
        // Every field named (no `..`): a new field must be added here.
        let LocalPatch {
            k,
            cells,
            parts,
            grid,
            prepared,
            nbrs,
        } = self;
        *k = src.k;
        *cells = src.cells;
        parts.clone_from(&src.parts);
        // `Option::clone_from` copies into a grid `self` has when the source
        // has one too (and drops or clones it otherwise).
        grid.clone_from(&src.grid);
        *prepared = src.prepared;
        nbrs.clone_from(&src.nbrs);
    }
}

impl Clone for Level {
    fn clone(&self) -> Self {
        let Level {
            l,
            h,
            origin,
            domain,
            boxes,
            owned,
            patch_size,
            patches,
            owner,
            local,
            bc,
            crossings,
            stats,
            // No state (written before it is read): not copied or compared.
            scratch: _,
            step_dt_cfl1,
        } = self;
        Level {
            l: *l,
            h: *h,
            origin: *origin,
            domain: *domain,
            boxes: boxes.clone(),
            owned: owned.clone(),
            patch_size: *patch_size,
            patches: patches.clone(),
            owner: owner.clone(),
            local: local.clone(),
            bc: *bc,
            crossings: *crossings,
            stats: *stats,
            scratch: Vec::new(),
            step_dt_cfl1: *step_dt_cfl1,
        }
    }

    fn clone_from(&mut self, src: &Self) {
        // Every field named (no `..`): a new field must be added here.
        let Level {
            l,
            h,
            origin,
            domain,
            boxes,
            owned,
            patch_size,
            patches,
            owner,
            local,
            bc,
            crossings,
            stats,
            // No state (written before it is read): not copied or compared.
            scratch: _,
            step_dt_cfl1,
        } = self;
        *l = src.l;
        *h = src.h;
        *origin = src.origin;
        *domain = src.domain;
        boxes.clone_from(&src.boxes);
        owned.clone_from(&src.owned);
        *patch_size = src.patch_size;
        patches.clone_from(&src.patches);
        owner.clone_from(&src.owner);
        // `Vec::clone_from` calls `LocalPatch::clone_from` on the patches
        // both have, drops the extra ones and clones the missing ones.
        local.clone_from(&src.local);
        *bc = src.bc;
        *crossings = src.crossings;
        *stats = src.stats;
        *step_dt_cfl1 = src.step_dt_cfl1;
    }
}

/// The nodes a patch's grid stores, as a half-open box of node indices.
fn node_box(cells: &IBox) -> IBox {
    IBox::new(
        [cells.lo[0] - GHOST, cells.lo[1] - GHOST],
        [cells.hi[0] + GHOST + 1, cells.hi[1] + GHOST + 1],
    )
}

/// Local storage index of node `(i, j)` in `g`.
fn node_index(g: &Grid, i: i64, j: i64) -> usize {
    (j - g.lo[1]) as usize * g.n[0] + (i - g.lo[0]) as usize
}

/// Calls `f(node, r)` for the nodes of `ov` on a grid whose first node is
/// `lo` and whose rows have `nx` nodes, `r` counting them in the order the
/// exchange packs them (rows of increasing `j`, `i` inner).
fn overlap_nodes(lo: [i64; 2], nx: usize, ov: &IBox, mut f: impl FnMut(usize, usize)) {
    let mut r = 0;
    for j in ov.lo[1]..ov.hi[1] {
        let row = (j - lo[1]) as usize * nx;
        for i in ov.lo[0]..ov.hi[0] {
            f(row + (i - lo[0]) as usize, r);
            r += 1;
        }
    }
}

fn read_u64(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"))
}

impl Level {
    /// A level from its layout; `owner` gives each patch's rank.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        l: usize,
        h: f64,
        origin: [f64; 2],
        domain: IBox,
        boxes: Vec<IBox>,
        owned: Vec<IBox>,
        patch_size: [i64; 2],
        owner: Vec<i32>,
        rank: i32,
    ) -> Level {
        let patches: Vec<IBox> = boxes.iter().flat_map(|b| b.tile(patch_size)).collect();
        assert_eq!(patches.len(), owner.len(), "one owner per patch");
        let mut lv = Level {
            l,
            h,
            origin,
            domain,
            boxes,
            owned,
            patch_size,
            patches,
            owner,
            local: Vec::new(),
            bc: [FaceBc::Free; 4],
            crossings: 0,
            stats: LevelStats::default(),
            scratch: Vec::new(),
            step_dt_cfl1: f64::INFINITY,
        };
        lv.local = (0..lv.patches.len())
            .filter(|&k| lv.owner[k] == rank)
            .map(|k| lv.new_local(k))
            .collect();
        lv
    }

    fn new_local(&self, k: usize) -> LocalPatch {
        let nb = node_box(&self.patches[k]);
        let nbrs = (0..self.patches.len())
            .filter(|&q| q != k)
            .filter_map(|q| {
                let ov = nb.intersect(&node_box(&self.patches[q]));
                (!ov.is_empty()).then_some((q, ov))
            })
            .collect();
        LocalPatch {
            k,
            cells: self.patches[k],
            parts: Particles::new(),
            grid: None,
            prepared: None,
            nbrs,
        }
    }

    /// The patch holding cell `c`, if any (O(number of boxes)).
    pub fn find_patch(&self, c: [i64; 2]) -> Option<usize> {
        let mut offset = 0;
        for b in &self.boxes {
            let s = b.shape();
            let nt = [
                (s[0] + self.patch_size[0] - 1) / self.patch_size[0],
                (s[1] + self.patch_size[1] - 1) / self.patch_size[1],
            ];
            if b.contains_cell(c[0], c[1]) {
                let ti = (c[0] - b.lo[0]) / self.patch_size[0];
                let tj = (c[1] - b.lo[1]) / self.patch_size[1];
                return Some(offset + (tj * nt[0] + ti) as usize);
            }
            offset += (nt[0] * nt[1]) as usize;
        }
        None
    }

    /// True when cell `c` lies in the level's own region.
    pub fn owns_cell(&self, c: [i64; 2]) -> bool {
        self.owned.iter().any(|b| b.contains_cell(c[0], c[1]))
    }

    /// The cell of this level holding a point (not clamped to the domain).
    pub fn cell_of(&self, x: f64, y: f64) -> [i64; 2] {
        [
            ((x - self.origin[0]) / self.h).floor() as i64,
            ((y - self.origin[1]) / self.h).floor() as i64,
        ]
    }

    /// The local patch with index `k`, if this rank owns it.
    pub fn local_mut(&mut self, k: usize) -> Option<&mut LocalPatch> {
        self.local
            .binary_search_by_key(&k, |p| p.k)
            .ok()
            .map(move |i| &mut self.local[i])
    }

    /// Number of particles this rank holds on the level.
    pub fn num_local_particles(&self) -> usize {
        self.local.iter().map(|p| p.parts.len()).sum()
    }

    /// Number of particles this rank owns on the level (copies excluded).
    pub fn num_owned_particles(&self) -> usize {
        self.particle_sets()
            .map(|p| {
                p.copy
                    .iter()
                    .filter(|&&c| c == crate::particles::OWNED)
                    .count()
            })
            .sum()
    }

    /// Visits every local particle set (in patch order).
    pub fn particle_sets(&self) -> impl Iterator<Item = &Particles> {
        self.local.iter().map(|p| &p.parts)
    }

    /// The patch-side conditions: every domain face, with its node index on
    /// this level (the kernel constrains only the nodes a grid stores).
    fn boundary(&self) -> PatchBoundary {
        let d = &self.domain;
        let nodes = [d.lo[0], d.hi[0], d.lo[1], d.hi[1]];
        let mut b = PatchBoundary::default();
        for (s, &node) in nodes.iter().enumerate() {
            b.faces[s] = Some(DomainFace {
                node,
                bc: self.bc[s],
            });
        }
        b
    }

    /// Makes sure every local patch with particles has a grid, and frees the
    /// grids of empty patches.
    fn ensure_grids(&mut self) -> Result<()> {
        for p in &mut self.local {
            if p.parts.is_empty() {
                p.grid = None;
                p.prepared = None;
            } else if p.grid.is_none() {
                p.prepared = None;
                p.grid = Some(Grid::from_ibox(self.origin, self.h, &p.cells, GHOST)?);
            }
        }
        Ok(())
    }

    /// Forgets the next step's first P2G that the last step's last pass
    /// left on the grids (see [`kernel::Pipeline`]): whoever changes the
    /// level's particles, their loads or the grids outside a step calls it
    /// (the level's own migration forgets it on the patches it changes).
    pub fn unprepare(&mut self) {
        for p in &mut self.local {
            p.prepared = None;
        }
    }

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
                buf.extend_from_slice(&(q as u64).to_le_bytes());
                buf.extend_from_slice(&(p.k as u64).to_le_bytes());
                for &f in fl {
                    for j in ov.lo[1]..ov.hi[1] {
                        for i in ov.lo[0]..ov.hi[0] {
                            let v = p
                                .grid
                                .as_ref()
                                .map_or(0.0, |g| g.acc(f, node_index(g, i, j)));
                            buf.extend_from_slice(&v.to_le_bytes());
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
                let q = read_u64(recv, at) as usize;
                let src = read_u64(recv, at + 8) as usize;
                let ov = node_box(&self.patches[q]).intersect(&node_box(&self.patches[src]));
                incoming.push((q, src, bi, at + 16));
                at += 16 + 8 * fl.len() * ov.num_cells() as usize;
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
                        acc[k] += f64::from_bits(read_u64(&bufs[bi], base + 8 * r));
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

    /// `min h / (c + |v|)` over this rank's particles of the level.
    pub fn local_dt_cfl1(&self, mats: &[MatParams]) -> f64 {
        self.particle_sets()
            .map(|p| kernel::stable_dt_cfl1(p, mats, self.h))
            .fold(f64::INFINITY, f64::min)
    }

    /// Advances the level by one step of `prm.dt` (collective): the one
    /// step, [`kernel::step_patches`], on the local patches, with the nodal
    /// sums over shared nodes ([`Level::exchange`]) and the contact phase
    /// (with `contact`, see [`crate::contact::resolve`]) between its
    /// phases, then particle migration, which looks only at the particles
    /// the last pass noted as possibly leaving their patch
    /// ([`kernel::PassStats::leaving`]). With `next_load_factor`, the last
    /// pass also scatters the next step's first P2G (loads at that factor)
    /// on every patch, and the next step skips it on the patches whose
    /// particles nothing changed (bit for bit the same result; see
    /// [`kernel::Pipeline`]); pass it only when nothing reads the grids'
    /// accumulators between the steps. With `skip_last`, the last pass
    /// leaves the copies with that copy flag as they are (in whole blocks,
    /// see [`kernel::Pipeline::skip_last`]): pass it only for copies that
    /// are replaced before anything reads them after this step. Returns the
    /// owned particles that left the level (see [`Level::migrate`]). On an
    /// error every rank fails (the state is that reached by the step).
    pub fn step(
        &mut self,
        comm: &Comm,
        mats: &[MatParams],
        prm: &StepParams,
        contact: Option<LevelStepContact>,
        next_load_factor: Option<f64>,
        skip_last: Option<f64>,
    ) -> Result<Vec<(Departure, Vec<u8>)>> {
        let t0 = std::time::Instant::now();
        let before = self.stats;
        let r = self.step_inner(comm, mats, prm, contact, next_load_factor, skip_last);
        let other = (self.stats.exchange - before.exchange) + (self.stats.migrate - before.migrate);
        self.stats.compute += t0.elapsed().as_secs_f64() - other;
        self.stats.steps += 1;
        r
    }

    /// The contact phase (see [`crate::contact::resolve`]) on the local
    /// patches' grids after their grid update.
    fn contact_phase(
        &mut self,
        comm: &Comm,
        prm: &StepParams,
        c: &mut LevelStepContact,
    ) -> Result<()> {
        let h = self.h;
        let o = self.origin;
        let mut extent = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for b in &self.patches {
            extent[0] = extent[0].min(o[0] + b.lo[0] as f64 * h);
            extent[1] = extent[1].min(o[1] + b.lo[1] as f64 * h);
            extent[2] = extent[2].max(o[0] + b.hi[0] as f64 * h);
            extent[3] = extent[3].max(o[1] + b.hi[1] as f64 * h);
        }
        let geo = LevelGeometry {
            l: self.l,
            h,
            origin: o,
            extent,
            boundary: prm.boundary,
            shape: prm.shape,
            mass_tol: prm.mass_tol,
            dt: prm.dt,
            t_end: c.t_end,
            thickness: c.thickness,
            catch_up: if c.out.last_dt > 0.0 {
                (prm.dt / c.out.last_dt).min(1.0)
            } else {
                1.0
            },
        };
        let mut refs: Vec<PatchRef> = self
            .local
            .iter_mut()
            .filter_map(|p| {
                p.grid.as_mut().map(|g| PatchRef {
                    parts: &p.parts,
                    grid: g,
                })
            })
            .collect();
        crate::contact::resolve::resolve(
            &mut refs,
            &geo,
            comm,
            c.indenters,
            c.opts,
            c.solver,
            c.out,
        )
    }

    fn step_inner(
        &mut self,
        comm: &Comm,
        mats: &[MatParams],
        prm: &StepParams,
        contact: Option<LevelStepContact>,
        next_load_factor: Option<f64>,
        skip_last: Option<f64>,
    ) -> Result<Vec<(Departure, Vec<u8>)>> {
        let mut prm = *prm;
        prm.boundary = self.boundary();
        let mut first_err: Option<Error> = None;
        let note = |r: Result<()>, e: &mut Option<Error>| {
            if let Err(x) = r {
                e.get_or_insert(x);
            }
        };
        // A grid this rank cannot allocate fails the step on every rank
        // (agreed below), not this rank alone before the exchanges.
        note(self.ensure_grids(), &mut first_err);
        let pipe = Pipeline {
            next_load_factor,
            fuse: true,
            skip_last,
        };
        let mut set = LevelPatches {
            lv: self,
            comm,
            contact,
        };
        let out = kernel::step_patches(&mut set, mats, &prm, pipe, None)?;
        if let Some(e) = out.first_err {
            first_err.get_or_insert(e);
        }
        let mut stats = out.stats;
        // Non-finite or inverted particles (checked before migration, so the
        // message names a particle this rank holds, with its level and
        // patch). Particles off a patch's grid are not a problem here:
        // migration moves them. A rank that failed migrates nothing (a
        // broken particle is never sent anywhere) but still takes part in
        // the migration's exchange, so no rank waits for it there; the ranks
        // agree at the end (one reduction per level step, as without the
        // failure).
        let l = self.l;
        for (p, st) in self.local.iter().zip(&mut stats) {
            st.first_outside = None;
            note(
                st.to_result(&p.parts).map_err(|e| {
                    Error::new(e.status, format!("{} (level {l}, patch {})", e.msg, p.k))
                }),
                &mut first_err,
            );
        }
        let departures = if first_err.is_some() {
            self.migrate_nothing(comm).map(|()| Vec::new())
        } else {
            // The last pass moved the particles and noted the slots that
            // may have left their patch: migration looks at those only.
            let leaving: Vec<_> = stats.iter().map(|s| s.leaving).collect();
            self.migrate(comm, Some(&leaving))
        };
        let departures = match departures {
            Ok(d) => d,
            Err(e) => {
                first_err.get_or_insert(e);
                Vec::new()
            }
        };
        note(self.ensure_grids(), &mut first_err);
        if first_err.is_some() {
            self.unprepare();
        }
        agreed(comm, &mut first_err)?;
        self.step_dt_cfl1 = stats
            .iter()
            .map(|s| s.dt_cfl1)
            .fold(f64::INFINITY, f64::min);
        Ok(departures)
    }

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
    ) -> Result<Vec<(Departure, Vec<u8>)>> {
        let t0 = std::time::Instant::now();
        let r = self.migrate_inner(comm, leaving);
        self.stats.migrate += t0.elapsed().as_secs_f64();
        r
    }

    fn migrate_inner(
        &mut self,
        comm: &Comm,
        leaving: Option<&[Option<(usize, usize)>]>,
    ) -> Result<Vec<(Departure, Vec<u8>)>> {
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
                    let mut b = Vec::with_capacity(Particles::PACKED_BYTES);
                    parts.pack(i, &mut b);
                    let d = Departure {
                        id: parts.id[i],
                        x: parts.x[i],
                        y: parts.y[i],
                    };
                    departures.push((d, b));
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
    fn migrate_nothing(&mut self, comm: &Comm) -> Result<()> {
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
            .map(|&r| (send[r as usize].len() as u64).to_le_bytes())
            .collect();
        let size_msgs: Vec<(i32, &[u8])> =
            peers.iter().zip(&lens).map(|(&r, l)| (r, &l[..])).collect();
        let size_recv: Vec<(i32, usize)> = peers.iter().map(|&r| (r, 8)).collect();
        let got = comm.exchange_with(&size_msgs, &size_recv, 18)?;
        let data_msgs: Vec<(i32, &[u8])> = peers
            .iter()
            .map(|&r| (r, send[r as usize].as_slice()))
            .collect();
        let data_recv: Vec<(i32, usize)> = peers
            .iter()
            .zip(&got)
            .map(|(&r, b)| (r, read_u64(b, 0) as usize))
            .collect();
        self.stats.bytes_sent += data_msgs.iter().map(|m| m.1.len() as u64 + 8).sum::<u64>();
        let mut bufs = comm.exchange_with(&data_msgs, &data_recv, 19)?;
        drop(data_msgs);
        bufs.push(std::mem::take(&mut send[me as usize]));
        self.push_records(&bufs)?;
        err.map_or(Ok(()), Err)
    }

    /// Appends the records `(patch as u64, packed particle)` of `bufs` to
    /// their patches, each patch's arrivals sorted by global id.
    fn push_records(&mut self, bufs: &[Vec<u8>]) -> Result<()> {
        let rec = 8 + Particles::PACKED_BYTES;
        // (dest patch, id, buffer, offset of the packed particle)
        let mut arr: Vec<(usize, u64, usize, usize)> = Vec::new();
        for (bi, b) in bufs.iter().enumerate() {
            for (n, c) in b.chunks_exact(rec).enumerate() {
                arr.push((read_u64(c, 0) as usize, read_u64(c, 8), bi, n * rec + 8));
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
                    .map(|&(_, _, bi, off)| &bufs[bi][off..off + Particles::PACKED_BYTES]),
            );
            at = end;
        }
        Ok(())
    }

    /// Delivers particles to the patches that own them (collective):
    /// `send[r]` holds records `(patch index as u64, packed particle)` for
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

    /// Appends a record `(patch holding the particle's cell, packed
    /// particle i of parts)` to the buffer of the patch owner; returns false
    /// when no patch of the level holds the cell.
    pub fn pack_for(&self, parts: &Particles, i: usize, send: &mut [Vec<u8>]) -> bool {
        self.pack_as(parts, i, None, send)
    }

    /// As [`Level::pack_for`], with the particle's `copy` flag replaced by
    /// `copy` when given.
    pub fn pack_as(
        &self,
        parts: &Particles,
        i: usize,
        copy: Option<f64>,
        send: &mut [Vec<u8>],
    ) -> bool {
        let c = self.cell_of(parts.x[i], parts.y[i]);
        match self.find_patch(c) {
            Some(q) => {
                let buf = &mut send[self.owner[q] as usize];
                buf.extend_from_slice(&(q as u64).to_le_bytes());
                parts.pack(i, buf);
                if let Some(v) = copy {
                    // The copy flag is the last packed field.
                    let at = buf.len() - 8;
                    buf[at..].copy_from_slice(&v.to_le_bytes());
                }
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
                buf.extend_from_slice(&(p.k as u64).to_le_bytes());
                p.parts.pack(i, buf);
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
        let rec = 8 + Particles::PACKED_BYTES;
        // A moved patch arrives from one rank, in its (canonical) order.
        for c in recv.chunks_exact(rec) {
            let q = read_u64(c, 0) as usize;
            self.local_mut(q)
                .expect("moved patches go to their new owner")
                .parts
                .push_packed(&c[8..]);
        }
        Ok(())
    }
}

/// A level's local patches as the kernel's step sees them: sums through
/// [`Level::exchange`], contact through the level's contact phase.
struct LevelPatches<'l, 'c> {
    lv: &'l mut Level,
    comm: &'l Comm,
    contact: Option<LevelStepContact<'c>>,
}

impl Patches for LevelPatches<'_, '_> {
    fn count(&self) -> usize {
        self.lv.local.len()
    }

    fn patch(&mut self, i: usize) -> Option<PatchMut<'_>> {
        let p = &mut self.lv.local[i];
        let grid = p.grid.as_mut()?;
        Some(PatchMut {
            grid,
            parts: &mut p.parts,
            body: None,
            prepared: &mut p.prepared,
        })
    }

    fn sum(&mut self, fields: Fields) -> Result<()> {
        self.lv.exchange(self.comm, fields)
    }

    fn contact(&mut self, prm: &StepParams) -> Result<()> {
        match &mut self.contact {
            Some(c) => self.lv.contact_phase(self.comm, prm, c),
            None => Ok(()),
        }
    }
}

/// Agrees across the ranks of `comm` whether any has an error in `err`
/// (collective): every rank returns an error when one does, this rank's own
/// or, on a rank without one, a pointer to the failing rank's message.
fn agreed(comm: &Comm, err: &mut Option<Error>) -> Result<()> {
    let bad = comm.any(err.is_some())?;
    if let Some(e) = err.take() {
        return Err(e);
    }
    if bad {
        return Err(Error::elsewhere(
            Status::Unstable,
            "the level step failed on another rank (for example non-finite or inverted particles there); see that rank's message",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::Prepared;

    /// Asserts that `a` equals `b` field by field, bit for bit (particles,
    /// grids, preparations, layout and bookkeeping), and that every array
    /// keeps the storage's layout property.
    fn assert_same(a: &Level, b: &Level) {
        // Every field named (no `..`): a new field must be compared here.
        let Level {
            l,
            h,
            origin,
            domain,
            boxes,
            owned,
            patch_size,
            patches,
            owner,
            local,
            bc,
            crossings,
            stats,
            // No state (written before it is read): not copied or compared.
            scratch: _,
            step_dt_cfl1,
        } = a;
        assert_eq!(*l, b.l);
        assert_eq!(h.to_bits(), b.h.to_bits());
        assert_eq!(origin.map(f64::to_bits), b.origin.map(f64::to_bits));
        assert_eq!((domain, boxes, owned), (&b.domain, &b.boxes, &b.owned));
        assert_eq!(
            (patch_size, patches, owner),
            (&b.patch_size, &b.patches, &b.owner)
        );
        assert_eq!((bc, crossings, stats), (&b.bc, &b.crossings, &b.stats));
        assert_eq!(step_dt_cfl1.to_bits(), b.step_dt_cfl1.to_bits());
        assert_eq!(local.len(), b.local.len());
        for (p, q) in local.iter().zip(&b.local) {
            let LocalPatch {
                k,
                cells,
                parts,
                grid,
                prepared,
                nbrs,
            } = p;
            assert_eq!(
                (k, cells, prepared, nbrs),
                (&q.k, &q.cells, &q.prepared, &q.nbrs)
            );
            parts.assert_same(&q.parts);
            assert_eq!(grid.is_some(), q.grid.is_some(), "patch {k}: grid");
            if let (Some(g), Some(r)) = (grid, &q.grid) {
                let Grid {
                    origin,
                    h,
                    lo,
                    n,
                    ghost,
                    mass,
                    mom_force,
                    vel,
                    dil,
                    xpic,
                } = g;
                assert_eq!(origin.map(f64::to_bits), r.origin.map(f64::to_bits));
                assert_eq!(
                    (h.to_bits(), lo, n, ghost),
                    (r.h.to_bits(), &r.lo, &r.n, &r.ghost)
                );
                assert_eq!(mass.bytes(), r.mass.bytes());
                assert_eq!(mom_force.bytes(), r.mom_force.bytes());
                assert_eq!(vel.bytes(), r.vel.bytes());
                assert_eq!(dil.bytes(), r.dil.bytes());
                assert_eq!(xpic.bytes(), r.xpic.bytes());
                mass.assert_layout();
                mom_force.assert_layout();
                vel.assert_layout();
                dil.assert_layout();
                xpic.assert_layout();
            }
        }
    }

    /// A value that differs with every argument (and is never a whole
    /// number, so that no two fields agree by accident).
    fn val(seed: u64, field: usize, i: usize) -> f64 {
        (seed as f64) * 1e3 + field as f64 + i as f64 * 1e-4 + 0.125
    }

    /// A level of 128 x 64 cells tiled with `patch`-sized patches (all
    /// owned by this rank); local patch `k` holds `counts[k % len]`
    /// particles whose every field (the APIC matrix, load codes, plastic
    /// strain and copy flags included) is set from `seed`; patches with
    /// particles get a grid with values in every array (the dilatation
    /// only when `dil`), and every other such patch a preparation.
    fn level(patch: [i64; 2], counts: &[usize], seed: u64, dil: bool) -> Level {
        let domain = IBox::new([0, 0], [128, 64]);
        let np = domain.tile(patch).len();
        let mut lv = Level::new(
            1,
            0.5,
            [0.0, -1.0],
            domain,
            vec![domain],
            vec![domain],
            patch,
            vec![0; np],
            0,
        );
        for (k, p) in lv.local.iter_mut().enumerate() {
            let n = counts[k % counts.len()];
            for i in 0..n {
                p.parts.id.push(seed * 1_000_000 + (k * 10_000 + i) as u64);
                p.parts.material.push((i % 3) as u32 + seed as u32);
                for (f, v) in p.parts.f64_fields_mut().into_iter().enumerate() {
                    v.push(val(seed, f, i));
                }
            }
        }
        lv.ensure_grids().expect("grids");
        for (k, p) in lv.local.iter_mut().enumerate() {
            let Some(g) = &mut p.grid else { continue };
            for (i, m) in g.mass.iter_mut().enumerate() {
                *m = val(seed, 100, i);
            }
            for (i, m) in g.mom_force.iter_mut().enumerate() {
                m.0 = [0, 1, 2, 3].map(|c| val(seed, 101 + c, i));
            }
            for (i, m) in g.vel.iter_mut().enumerate() {
                m.0 = [0, 1, 2, 3].map(|c| val(seed, 105 + c, i));
            }
            if dil {
                let n = g.mass.len();
                g.dil
                    .extend((0..n).map(|i| [val(seed, 109, i), val(seed, 110, i)]));
            }
            if k % 2 == 0 {
                p.prepared = Some(Prepared::sample(val(seed, 111, k)));
            }
        }
        lv.crossings = 17 + seed;
        lv.stats.steps = 3 + seed;
        lv.stats.compute = val(seed, 112, 0);
        lv.scratch
            .extend((0..(50 * seed as usize)).map(|i| val(seed, 113, i)));
        lv.step_dt_cfl1 = val(seed, 114, 0);
        lv
    }

    #[test]
    fn clone_from_equals_a_fresh_clone_whatever_the_old_sizes() {
        // Sources and targets of other sizes: more and fewer particles
        // (above and below the storage's stagger threshold), other patch
        // tilings (more and fewer local patches), patches that gain or lose
        // their grid, with and without the dilatation array.
        let cases = [
            level([64, 64], &[5000, 0, 20], 1, true),
            level([64, 64], &[300], 2, false),
            level([32, 64], &[0, 6000, 1, 4100], 3, true),
            level([128, 64], &[9000], 4, false),
            level([32, 32], &[0], 5, false),
            level([16, 64], &[7, 5000], 6, true),
        ];
        for src in &cases {
            let fresh = src.clone();
            assert_same(&fresh, src);
            for old in &cases {
                let mut snap = old.clone();
                snap.clone_from(src);
                assert_same(&snap, &fresh);
                // Twice (the buffers now fit): still the same.
                snap.clone_from(src);
                assert_same(&snap, &fresh);
            }
        }
    }

    #[test]
    fn clone_from_of_the_same_sizes_allocates_nothing() {
        // The snapshot of a step taken again after the state changed but
        // not its sizes: every array stays where it was.
        let src1 = level([64, 64], &[5000, 0, 20], 1, true);
        let src2 = level([64, 64], &[5000, 0, 20], 7, true);
        let mut snap = src1.clone();
        let ptrs = |lv: &Level| -> Vec<usize> {
            lv.local
                .iter()
                .flat_map(|p| {
                    let mut v: Vec<usize> = p
                        .parts
                        .f64_fields()
                        .iter()
                        .map(|f| f.as_ptr() as usize)
                        .collect();
                    v.push(p.parts.id.as_ptr() as usize);
                    v.push(p.parts.material.as_ptr() as usize);
                    if let Some(g) = &p.grid {
                        v.push(g.mass.as_ptr() as usize);
                        v.push(g.mom_force.as_ptr() as usize);
                        v.push(g.vel.as_ptr() as usize);
                        v.push(g.dil.as_ptr() as usize);
                    }
                    v
                })
                .collect()
        };
        let before = ptrs(&snap);
        snap.clone_from(&src2);
        assert_same(&snap, &src2.clone());
        assert_eq!(ptrs(&snap), before);
        // And back: the rollback direction.
        let mut live = src2.clone();
        let before = ptrs(&live);
        live.clone_from(&src1);
        assert_same(&live, &src1);
        assert_eq!(ptrs(&live), before);
    }
}
