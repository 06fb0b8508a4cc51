//! One patch, one explicit step: P2G, grid update with boundary conditions,
//! G2P, deformation-gradient and stress update, for the USF, USL and MUSL
//! schemes.
//!
//! Everything here is a pure function of the patch's data: a [`Grid`] over
//! an integer node box of one level (the patch's cells plus ghost cells, not
//! the whole domain), the patch's
//! [`Particles`](crate::particles::Particles), the material table and the
//! [`StepParams`]. The phases are public so that a multi-patch driver can
//! sum nodal data across patches (ghost exchange) between them; for one patch
//! that owns the whole domain, [`step_patch`] runs a complete step; both run
//! the one step of [`step_patches`].
//!
//! Phases of one step, per scheme (`[Σ]` marks where a multi-patch driver
//! sums the nodal accumulators of neighbouring patches):
//!
//! | scheme | phases |
//! |--------|--------|
//! | USL  | `reset`, `p2g(mass, momentum, force)` [Σ], `grid_update`, `g2p(vel, pos, strain from v)` |
//! | MUSL | `reset`, `p2g(mass, momentum, force)` [Σ], `grid_update`, `g2p(vel)`, `reset_momentum`, `p2g(momentum)` [Σ], `grid_velocity`, `g2p(pos, strain from v0)` (cpGIMP: pos from v0 too) |
//! | USF  | `reset`, `p2g(mass, momentum)` [Σ], `grid_velocity`, `g2p(strain from v0)`, `p2g(force)` [Σ], `grid_update`, `g2p(vel, pos)` |
//!
//! With a J2 material in the table, [`nodal_dilatation`] (summed over
//! patches) and [`normalise_dilatation`] run just before the strain pass (after
//! `grid_update` for USL, after `grid_velocity` for MUSL and USF): the J2
//! particles take the nodal average of the dilatation as the trace of their
//! velocity gradient (the cure of volumetric locking, see
//! [`crate::material::Constitutive::nodal_dilatation`]). Tables without J2 skip it.
//!
//! With [`Transfer::Xpic`] of order `m`, `m − 1` smoothing passes run after
//! the grid update and the contact phase, before the pass that updates the
//! particle velocities: each a particle pass that scatters momentum [Σ]
//! and a grid pass (see [`xpic`]).
//!
//! Within a step every pass uses the weights at the particles' start-of-step
//! positions and half-lengths (positions and cpGIMP half-lengths change in the
//! last pass only), so the weights are recomputed rather than stored: they
//! cost a few flops per axis, less than reading the stored numbers back.
//! (Measured on 2026-12-08: keeping each block's stencils from the pass
//! that evaluated them for the passes after it, in the layout the loops
//! read, bit for bit the same results, took the default scheme on the
//! comparison scene from 10.2 to 7.6 M particle-steps/s, and gained
//! nothing on a 128² copy whose stencils fit in the cache.)
//!
//! **FLIP/PIC.** `flip = 1` (the default) is pure FLIP: no numerical
//! dissipation, so the second-order convergence of GIMP and the energy
//! balance are kept; MUSL already removes the small-mass velocity noise that
//! makes pure FLIP troublesome with USL. Lower values blend in PIC, which
//! damps high-frequency noise (impacts) at the cost of dissipation.
//!
//! **Nearly empty nodes.** Every node that carries mass, however little,
//! gets its velocity `(p + f dt)/m` (see [`bc::grid_update`]): a particle
//! reads a light node's large acceleration times its own small weight, so
//! its velocity change stays bounded, and the momentum the particles receive
//! is exactly the nodes' impulse `Σ f dt`; no force is dropped, and momentum
//! in free flight is kept to round-off with GIMP weights too.
//! [`StepParams::mass_tol`] (an absolute mass; callers set it to
//! [`MASS_TOL_REL`] times a reference particle mass, the same on every patch
//! and rank) is used by the contact phase only, which leaves nodes that
//! light out of its system (they would make it ill-conditioned).
//!
//! **Loads.** External force on node `i`: `Σ_p S_ip (fext_p · load_factor +
//! m_p (gravity + body_p))`, with `fext_p` the particle's reference external
//! force (traction × face length × thickness), `load_factor` from a [`Ramp`],
//! and `body_p` an optional per-particle body force per unit mass.
//!
//! **Files.** `params.rs`: what a step is told ([`StepParams`] and the
//! scheme, transfer, boundary and load types). `step.rs`: the step, written
//! once over a set of patches; `one_patch.rs`: its checked single-patch
//! entries. `passes.rs`: the front doors of the particle passes;
//! `dispatch.rs`: the choice of the compiled loop; `p2g.rs`, `g2p.rs`,
//! `xpic.rs`, `dilatation.rs`: the loops; `block.rs`, `geo.rs`, `lanes.rs`,
//! `simd.rs`, `isa.rs`: what the loops are built from. `bc.rs`: the grid
//! update and boundary conditions; `grid.rs`: the nodal arrays. `stats.rs`:
//! what the passes report; `stable_dt.rs`: the stable time step;
//! `sort.rs`: the particle order; `timing.rs`: CPU time per phase.

pub mod bc;
mod block;
mod dilatation;
mod dispatch;
pub mod g2p;
mod geo;
pub mod grid;
pub mod isa;
mod lanes;
mod one_patch;
pub mod p2g;
mod params;
mod passes;
mod simd;
mod sort;
mod stable_dt;
mod stats;
pub mod step;
mod timing;
pub mod xpic;

pub use bc::{apply_bc, grid_update, grid_velocity};
pub use dilatation::{needs_nodal_dilatation, nodal_dilatation, normalise_dilatation};
pub use grid::Grid;
pub use one_patch::{one_patch_result, step_patch};
pub use params::{
    BodyForce, DomainFace, FaceBc, PatchBoundary, Ramp, Scheme, Side, StepParams, Transfer,
    MASS_TOL_REL,
};
pub use passes::{
    fusable, g2p, g2p_except, g2p_p2g, p2g, reset_force, reset_momentum, G2pPass, Mapping,
};
pub use sort::{sort_by_stencil, stencil_order, SortScratch};
pub(crate) use stable_dt::speed_of;
pub use stable_dt::stable_dt_cfl1;
pub use stats::{union_range, PassStats, MAX_STRAIN_INCREMENT};
pub use step::{
    step_patches, Fields, GridPhase, OnePatch, PatchMut, Patches, Pipeline, Prepared, StepOutcome,
};
pub(crate) use timing::Laps;
pub use timing::{thread_cpu_seconds, PhaseTimes};

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_axi;
