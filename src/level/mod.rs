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

mod exchange;
mod migrate;
mod step;
#[cfg(test)]
mod tests;

use crate::error::Result;
use crate::geom::IBox;
pub use crate::kernel::Fields;
use crate::kernel::{self, DomainFace, FaceBc, Grid, PatchBoundary, Prepared};
use crate::material::MatParams;
use crate::particles::Particles;
pub use step::GridHook;

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

/// The layout of a level, as [`Level::new`] builds it.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelLayout {
    /// Level index (0 = coarsest).
    pub l: usize,
    /// Cell size.
    pub h: f64,
    /// Domain origin (node `(0, 0)` of every level).
    pub origin: [f64; 2],
    /// The domain as a box of this level's cells.
    pub domain: IBox,
    /// The boxes the level computes on (its own boxes plus the ghost ring
    /// for a refined level), disjoint.
    pub boxes: Vec<IBox>,
    /// The level's own boxes.
    pub owned: Vec<IBox>,
    /// Patch size the boxes are tiled with.
    pub patch_size: [i64; 2],
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

impl Level {
    /// A level from its layout; `owner` gives each patch's rank (one per
    /// patch of the layout's boxes tiled by its patch size).
    pub fn new(layout: LevelLayout, owner: Vec<i32>, rank: i32) -> Level {
        let LevelLayout {
            l,
            h,
            origin,
            domain,
            boxes,
            owned,
            patch_size,
        } = layout;
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

    /// `min h / (c + |v|)` over this rank's particles of the level.
    pub fn local_dt_cfl1(&self, mats: &[MatParams]) -> f64 {
        self.particle_sets()
            .map(|p| kernel::stable_dt_cfl1(p, mats, self.h))
            .fold(f64::INFINITY, f64::min)
    }
}
