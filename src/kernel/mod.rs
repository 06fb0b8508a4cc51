//! One patch, one explicit step: P2G, grid update with boundary conditions,
//! G2P, deformation-gradient and stress update, for the USF, USL and MUSL
//! schemes.
//!
//! Everything here is a pure function of the patch's data: a [`Grid`] over
//! an integer node box of one level (the patch's cells plus ghost cells, not
//! the whole domain), the patch's [`Particles`], the material table and the
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
//! [`Constitutive::nodal_dilatation`]). Tables without J2 skip it.
//!
//! With [`Transfer::Xpic`] of order `m`, `m − 1` smoothing passes run after
//! the grid update and the contact phase, before the pass that updates the
//! particle velocities: each a particle pass that scatters momentum [Σ]
//! and a grid pass (see [`xpic`]).
//!
//! Within a step every pass uses the weights at the particles' start-of-step
//! positions and half-lengths (positions and cpGIMP half-lengths change in the
//! last pass only), so the weights are recomputed rather than stored: they
//! cost a few flops per axis, less than reading 27 stored numbers back.
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

pub mod bc;
mod block;
mod dilatation;
pub mod g2p;
pub mod grid;
pub mod isa;
mod lanes;
pub mod p2g;
mod simd;
pub mod step;
pub mod xpic;

pub use bc::{apply_bc, grid_update, grid_velocity};
pub use grid::Grid;
pub use step::{
    step_patches, Fields, OnePatch, PatchMut, Patches, Pipeline, Prepared, StepOutcome,
};

use crate::error::{Error, Result, Status};
use crate::material::{
    AnyLaw, Constitutive, J2Law, LinearElasticLaw, MatKind, MatParams, NeoHookeanLaw,
};
use crate::particles::Particles;
use crate::shape::{GimpShape, MpmShape, Shape1D, ShapeKind};
use isa::multiversion;

/// Relative mass of nodes the contact system leaves out (see the module
/// notes).
pub const MASS_TOL_REL: f64 = 1e-10;

/// Update scheme: when the stress is updated relative to the momentum.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Scheme {
    /// Update stress first (velocity gradient from the start-of-step grid
    /// velocity).
    Usf,
    /// Update stress last (velocity gradient from the updated grid velocity).
    Usl,
    /// Modified USL: the updated particle momentum is mapped back to the grid
    /// and its velocity drives the velocity gradient (the default).
    #[default]
    Musl,
}

/// How velocities go between particles and grid.
///
/// **FLIP/PIC** (`Flip`, the default): the particle carries its velocity
/// alone; P2G maps `m_p v_p`, G2P blends the FLIP increment and the PIC
/// interpolation by [`StepParams::flip`]. The nodal velocities are then
/// mass-weighted averages of particle velocities, which do not reproduce a
/// linear (e.g. rigid-rotation) velocity field where a node sees particles
/// on one side only (a body's free edge): there the velocity gradient of a
/// rigid motion is not skew, and a spinning body strains at first order in
/// its rate.
///
/// **APIC** (`Apic`, Jiang et al. 2015, 2017): the particle also carries an
/// affine matrix `C_p` ([`Particles::cxx`] ...). P2G maps the momentum
/// `m_p S_ip (v_p + C_p (x_i − x_p))`; G2P sets `v_p = Σ S_ip v_i` (the PIC
/// value: [`StepParams::flip`] is ignored, see below) and `C_p = B_p
/// D_p^{-1}` with `B_p = Σ S_ip v_i (x_i − x_p)^T` and `D_p = Σ S_ip (x_i −
/// x_p)(x_i − x_p)^T` (diagonal for tensor-product weights: the per-axis
/// second moments of the particle's weights). Both transfers reproduce an
/// affine velocity field exactly (to round-off), at a free edge too, so a
/// rigid rotation gives a skew velocity gradient; and at fixed particle
/// positions they conserve the angular momentum `Σ_p m_p (x_p × v_p +
/// ε : (C_p D_p))` exactly (P2G and G2P each).
///
/// `D_p` per shape: for the GIMP weights (a weight is the average of the
/// hat over the particle's domain `[x_p − l, x_p + l]`) it is the mean over
/// the domain of the hat's own second moment plus the domain's, `D ≥ l²/3 >
/// 0` (cell units): bounded away from zero by the fixed half-length for
/// uGIMP, and for cpGIMP by its current one, `l0 |F e_x|` (see
/// [`crate::shape::cpgimp_half_lengths`]), which is positive for every
/// non-singular `F`. For plain MPM it is `u (1 − u) h²` (`u` the position
/// in the cell), zero at a node; there `B_p D_p^{-1}` equals `Σ v_i ⊗ ∇S_ip`
/// wherever it is defined (for the hat both are the cell's difference
/// quotient), so MPM uses that gradient form, with identical results and no
/// division.
///
/// Why not the gradient form for GIMP as well (cpGIMP used it while its
/// half-length was `l0 F_ii`, which vanishes at a quarter turn): the two
/// forms differ at a node that a particle's domain barely reaches, one
/// that only the tails of domains touch (beyond a roller plane a domain
/// ends on, a free surface). Its weight `S` is of order `δ²` and its slope
/// `∇S` of order `δ` in the overlap `δ`, so its mass is of order `δ²` and
/// its force `−V σ ∇S` of order `δ`: its updated velocity has a part of
/// order `1/δ`. `B_p` weighs that velocity by `S`, a contribution of order
/// `δ` that vanishes as the domain leaves the node; the gradient form
/// weighs it by `∇S`, a contribution of order one that does not vanish as
/// `δ → 0` and jumps to zero at `δ = 0`, with a relative error of `ε / δ`
/// from the rounding of `δ`. A cpGIMP domain flush with a roller plane
/// (`δ` ≈ 1e-9 cells, set by round-off in its stretch) made the matrices,
/// and through them the stresses, depend on the patch layout at 1e-6.
///
/// **Deformation gradient under APIC.** The FLIP/PIC mode updates `F_{n+1}
/// = (I + dt L) F_n`, which is not orthogonal for a skew `L`: a rigid turn
/// in `n` steps stretches `F` by about `2π²/n`, and a law whose stress
/// follows from `F` (Neo-Hookean) then stresses a rotating body at that
/// level, whatever the transfer. APIC, whose point is that rigid motions
/// stay unstrained, uses the midpoint (Cayley) form `F_{n+1} = (I − dt/2
/// L)^{-1} (I + dt/2 L) F_n`, exactly orthogonal for a skew `L` and the
/// same to first order otherwise (it differs by O(dt²) per step). It stays
/// with APIC rather than replacing the default update, because it would
/// change every existing result at that order (see the commit that added
/// it for what it changes there).
///
/// Why `flip` is ignored under APIC: the FLIP increment `v_p + Σ S (v_i −
/// v0_i)` keeps whatever part of `v_p` the grid cannot represent and does
/// not reproduce affine fields (the edge error of a rotation stays), while
/// APIC's affine part already restores most of what PIC dissipates (the
/// rotational and shear modes within a particle's stencil). A blend would
/// lose the exactness that is the point of the transfer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Transfer {
    /// FLIP/PIC blend by [`StepParams::flip`] (the default).
    #[default]
    Flip,
    /// Affine particle-in-cell: PIC velocity plus the affine matrix `C_p`.
    Apic,
    /// Extended particle-in-cell of order [`StepParams::xpic_order`]
    /// (Hammerquist & Nairn 2017, see [`xpic`]): the particle's old velocity
    /// is filtered by `I − (I − S S⁺)^m` before the grid's velocity change
    /// is added, blended with FLIP by [`StepParams::flip`] (`flip = 0`: pure
    /// XPIC(m); order 1 is PIC). Costs `m − 1` extra particle passes and
    /// sums over shared nodes per step.
    Xpic,
}

/// Condition on one face of the domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FaceBc {
    /// Traction-free (no condition on the grid).
    #[default]
    Free,
    /// Zero velocity.
    Fixed,
    /// Zero normal velocity, free tangential motion (a symmetry plane).
    Roller,
}

/// A face of a rectangle; the index order of every `[_; 4]` face array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// x = min.
    Left = 0,
    /// x = max.
    Right = 1,
    /// y = min.
    Bottom = 2,
    /// y = max.
    Top = 3,
}

/// Time ramp of the external (traction) loads.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Ramp {
    /// Ramp duration; `0` means the loads act in full from `t = 0`.
    pub t_ramp: f64,
}

impl Ramp {
    /// Load factor `min(t / t_ramp, 1)` (1 when `t_ramp <= 0`, 0 for `t < 0`).
    pub fn factor(&self, t: f64) -> f64 {
        if self.t_ramp <= 0.0 {
            1.0
        } else {
            (t / self.t_ramp).clamp(0.0, 1.0)
        }
    }
}

/// A domain face that a patch side lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DomainFace {
    /// Node index (of the level, along the face normal) of the face.
    pub node: i64,
    /// The condition there.
    pub bc: FaceBc,
}

/// Which sides of a patch lie on the physical domain boundary
/// (`None`: the side borders another patch or the coarse level).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct PatchBoundary {
    /// Indexed by [`Side`].
    pub faces: [Option<DomainFace>; 4],
}

/// Per-particle body force per unit mass (in addition to gravity).
#[derive(Clone, Copy, Debug)]
pub struct BodyForce<'a> {
    /// x components, one per particle.
    pub bx: &'a [f64],
    /// y components, one per particle.
    pub by: &'a [f64],
}

/// Everything a patch step needs besides the grid, particles and materials.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepParams {
    /// Time step.
    pub dt: f64,
    /// Weight function.
    pub shape: ShapeKind,
    /// Update scheme.
    pub scheme: Scheme,
    /// FLIP fraction in `[0, 1]` (1 = pure FLIP); ignored by
    /// [`Transfer::Apic`].
    pub flip: f64,
    /// Particle–grid velocity transfer.
    pub transfer: Transfer,
    /// Order `m` of [`Transfer::Xpic`], in `1..=`[`xpic::MAX_XPIC_ORDER`]
    /// (read by that transfer only).
    pub xpic_order: u32,
    /// Factor on the particles' reference external forces (the ramp at the
    /// start of the step).
    pub load_factor: f64,
    /// Gravity (body force per unit mass).
    pub gravity: [f64; 2],
    /// Absolute nodal mass at or below which the contact phase leaves a node
    /// out of its system (the grid update keeps every node with mass).
    pub mass_tol: f64,
    /// The patch's sides on the domain boundary.
    pub boundary: PatchBoundary,
}

/// What a grid-to-particle pass found.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct PassStats {
    /// `min_p h / (c_p + |v_p|)` after the step: the stable step at CFL 1
    /// (infinite without particles; set by the last pass only).
    pub dt_cfl1: f64,
    /// First particle (slot) with a non-finite value.
    pub first_nonfinite: Option<usize>,
    /// First particle whose deformation gradient has `J <= 0`.
    pub first_inverted: Option<usize>,
    /// First particle whose stencil is not inside the grid.
    pub first_outside: Option<usize>,
    /// First particle whose strain increment in this step exceeded
    /// [`MAX_STRAIN_INCREMENT`], with the increment.
    pub first_runaway: Option<(usize, f64)>,
    /// First and last particle (slot) that may have left the grid's own
    /// cells (see [`Grid::ghost`]): set by the pass that moves the
    /// particles, conservatively (a particle within about 1e-9 cells of the
    /// border counts), so that every particle outside this range is
    /// certainly still in its cell box and a migration need not look at it.
    pub leaving: Option<(usize, usize)>,
}

/// The largest strain increment a particle may take in one step: the norm
/// `|D| dt = dt sqrt(Dxx² + Dyy² + 2 Dxy²)` of the symmetric part of the
/// velocity gradient times the step (rotations do not count). A stable
/// explicit step strains a particle by about `2 cfl |Δv|/c` (the velocity
/// jump across a cell over the wave speed, at most 1 at CFL 0.5 even for
/// an impact at the wave speed); an increment above 1, the particle
/// doubling its length in one step, is a run going unstable (an absurd
/// load, a step far beyond the stable one), caught at the step it happens
/// rather than steps later when the stable step has shrunk.
pub const MAX_STRAIN_INCREMENT: f64 = 1.0;

impl PassStats {
    fn merge(&mut self, o: &PassStats) {
        self.first_nonfinite = self.first_nonfinite.or(o.first_nonfinite);
        self.first_inverted = self.first_inverted.or(o.first_inverted);
        self.first_outside = self.first_outside.or(o.first_outside);
        self.first_runaway = self.first_runaway.or(o.first_runaway);
        self.leaving = union_range(self.leaving, o.leaving);
    }

    /// The error this pass reports, if any: non-finite values, inverted
    /// particles and strain increments above [`MAX_STRAIN_INCREMENT`] are
    /// `Unstable`, particles off the grid `ParticlesLeft`.
    pub fn to_result(&self, parts: &Particles) -> Result<()> {
        if let Some(p) = self.first_nonfinite {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "particle id {} has a non-finite position, velocity or stress after the step (reduce dt or check the loads)",
                    parts.id.get(p).copied().unwrap_or(0)
                ),
            ));
        }
        if let Some(p) = self.first_inverted {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "particle id {} has an inverted deformation gradient (det F <= 0) after the step",
                    parts.id[p]
                ),
            ));
        }
        if let Some((p, e)) = self.first_runaway {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "particle id {} took a strain increment of {e:.3e} in one step (at most {MAX_STRAIN_INCREMENT}): the run is unstable (reduce dt or check the loads)",
                    parts.id[p]
                ),
            ));
        }
        if let Some(p) = self.first_outside {
            return Err(Error::new(
                Status::ParticlesLeft,
                format!(
                    "particle id {} at ({}, {}) has left the patch grid",
                    parts.id[p], parts.x[p], parts.y[p]
                ),
            ));
        }
        Ok(())
    }
}

/// The smallest range holding both ranges (of [`PassStats::leaving`]).
pub fn union_range(a: Option<(usize, usize)>, b: Option<(usize, usize)>) -> Option<(usize, usize)> {
    match (a, b) {
        (Some(a), Some(b)) => Some((a.0.min(b.0), a.1.max(b.1))),
        (a, b) => a.or(b),
    }
}

/// The law every material of the table shares, if they all share one.
fn uniform_law(mats: &[MatParams]) -> Option<MatKind> {
    let k = mats.first()?.kind;
    mats.iter().all(|m| m.kind == k).then_some(k)
}

/// Checks the arguments a step relies on: finite positive `dt`, `flip` in
/// `[0, 1]`, material indices in the table, body-force lengths.
fn check_inputs(
    parts: &Particles,
    mats: &[MatParams],
    prm: &StepParams,
    body: Option<BodyForce>,
) -> Result<()> {
    if !(prm.dt.is_finite() && prm.dt > 0.0) {
        return Err(Error::arg(format!(
            "dt = {} must be finite and > 0",
            prm.dt
        )));
    }
    if !(0.0..=1.0).contains(&prm.flip) {
        return Err(Error::arg(format!(
            "flip = {} must lie in [0, 1]",
            prm.flip
        )));
    }
    if prm.transfer == Transfer::Xpic {
        xpic::xpic_order(prm.xpic_order.into())?;
    }
    if let Some(m) = parts.material.iter().copied().max() {
        if m as usize >= mats.len() {
            return Err(Error::arg(format!(
                "particle material index {m} must be < the number of materials ({})",
                mats.len()
            )));
        }
    }
    if let Some(b) = body {
        if b.bx.len() != parts.len() || b.by.len() != parts.len() {
            return Err(Error::arg(format!(
                "body force arrays have {} and {} entries, must have one per particle ({})",
                b.bx.len(),
                b.by.len(),
                parts.len()
            )));
        }
    }
    Ok(())
}

/// P2G phase. `mass`, `momentum`, `force` select what is scattered (see the
/// module table); the accumulators are added to, not reset.
pub fn p2g(
    grid: &mut Grid,
    parts: &Particles,
    prm: &StepParams,
    body: Option<BodyForce>,
    what: (bool, bool, bool),
) -> Result<()> {
    match prm.shape {
        ShapeKind::Mpm => p2g_s::<MpmShape>(grid, parts, prm, body, what),
        ShapeKind::UGimp | ShapeKind::CpGimp => p2g_s::<GimpShape>(grid, parts, prm, body, what),
    }
}

fn p2g_s<S: Shape1D>(
    grid: &mut Grid,
    parts: &Particles,
    prm: &StepParams,
    body: Option<BodyForce>,
    what: (bool, bool, bool),
) -> Result<()> {
    use p2g::p2g_impl;
    // The affine momentum (APIC) only where momentum is scattered.
    let apic = prm.transfer == Transfer::Apic;
    macro_rules! go {
        ($m:expr, $p:expr, $f:expr) => {
            if apic {
                p2g_impl::<S, $m, $p, $f, true>(grid, parts, prm, body)
            } else {
                p2g_impl::<S, $m, $p, $f, false>(grid, parts, prm, body)
            }
        };
    }
    match what {
        (true, true, true) => go!(true, true, true),
        (true, true, false) => go!(true, true, false),
        (false, true, false) => go!(false, true, false),
        (false, false, true) => p2g_impl::<S, false, false, true, false>(grid, parts, prm, body),
        (true, false, false) => p2g_impl::<S, true, false, false, false>(grid, parts, prm, body),
        (true, false, true) => p2g_impl::<S, true, false, true, false>(grid, parts, prm, body),
        (false, true, true) => go!(false, true, true),
        (false, false, false) => Ok(()),
    }
}

/// G2P phase selector (see the module table).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum G2pPass {
    /// USL: velocity, position and strain (gradient from `v`).
    UslAll,
    /// MUSL first pass: velocity only.
    MuslVelocity,
    /// MUSL second pass: position and strain (gradient from `v0`).
    MuslPositionStrain,
    /// USF first pass: strain only (gradient from `v0`).
    UsfStrain,
    /// USF last pass: velocity and position.
    UsfVelocityPosition,
}

/// G2P phase. Requires every particle's material index to be in `mats`.
pub fn g2p(
    grid: &Grid,
    parts: &mut Particles,
    mats: &[MatParams],
    prm: &StepParams,
    pass: G2pPass,
) -> PassStats {
    g2p_except(grid, parts, mats, prm, pass, None)
}

/// [`g2p`], except that with `skip = Some(flag)` a block of particles (the
/// pass's [`block::LANES`] consecutive slots, from slot 0) whose copy flags
/// ([`Particles::copy`]) all equal `flag` is left as it is: no update and
/// no checks. For passes whose results the owner of those particles throws
/// away (a level's copies that are replaced before anything reads them).
/// The other particles get bit for bit what [`g2p`] gives them: the blocks
/// are the same and the pass writes only particles.
pub fn g2p_except(
    grid: &Grid,
    parts: &mut Particles,
    mats: &[MatParams],
    prm: &StepParams,
    pass: G2pPass,
    skip: Option<f64>,
) -> PassStats {
    let gv = g2p::Vel {
        v: &grid.vel,
        dil: &grid.dil,
    };
    let sinks = p2g::Sinks {
        m: &mut [],
        mf: &mut [],
    };
    let sl = g2p::ScatterLoads {
        load_factor: 0.0,
        gravity: [0.0, 0.0],
        body: None,
    };
    let geo = p2g::Geo::of(grid);
    g2p_any(
        gv, sinks, geo, grid.h, parts, mats, prm, pass, NO_SCATTER, &sl, skip,
    )
}

/// True when a material of the table takes the nodal average of the
/// dilatation ([`Constitutive::nodal_dilatation`]: the J2 materials); only
/// then do the steps run [`nodal_dilatation`] before the strain pass.
pub fn needs_nodal_dilatation(mats: &[MatParams]) -> bool {
    mats.iter().any(AnyLaw::nodal_dilatation)
}

/// The scatter of the nodal dilatation (a phase of the steps whose material
/// table [`needs_nodal_dilatation`], after the grid velocities the strain
/// pass differentiates are final and before that pass): zeroes the grid's
/// dilatation sums (allocating them the first time) and adds `[S_ip V_p
/// div_p, S_ip V_p]` of every particle whose material takes it, with
/// `div_p` from `v0` when `from_v0` (MUSL, USF) or `v` (USL). A multi-patch
/// driver then sums [`Grid::DIL_NUM`] and [`Grid::DIL_DEN`] over the
/// patches and calls [`normalise_dilatation`].
pub fn nodal_dilatation(
    grid: &mut Grid,
    parts: &Particles,
    mats: &[MatParams],
    prm: &StepParams,
    from_v0: bool,
) -> Result<()> {
    grid.ensure_dilatation()?;
    grid.dil.fill([0.0; 2]);
    let geo = p2g::Geo::of(grid);
    let Grid { vel, dil, .. } = grid;
    macro_rules! go {
        ($s:ty, $m:ty) => {
            dilatation::scatter_dilatation::<$s, $m>(vel, dil, &geo, from_v0, parts, mats)
        };
    }
    match (prm.shape, uniform_law(mats)) {
        (_, Some(MatKind::LinearElastic | MatKind::NeoHookean)) => {}
        (ShapeKind::Mpm, Some(MatKind::J2)) => go!(MpmShape, J2Law),
        (ShapeKind::Mpm, None) => go!(MpmShape, AnyLaw),
        (_, Some(MatKind::J2)) => go!(GimpShape, J2Law),
        (_, None) => go!(GimpShape, AnyLaw),
    }
    Ok(())
}

/// Turns the grid's summed dilatation into the nodal means the strain pass
/// reads (after the sums over patches).
pub fn normalise_dilatation(grid: &mut Grid) {
    dilatation::normalise_dilatation(&mut grid.dil);
}

/// No P2G scatter (for [`g2p_any`]).
const NO_SCATTER: (bool, bool, bool) = (false, false, false);

/// The pairs of a G2P pass and a P2G scatter that [`g2p_p2g`] runs in one
/// loop: the ones the schemes use, i.e. a pass followed by the P2G the
/// scheme does next (the next step's first P2G after a last pass).
pub fn fusable(pass: G2pPass, what: (bool, bool, bool)) -> bool {
    matches!(
        (pass, what),
        (G2pPass::UslAll, (true, true, true))
            | (G2pPass::MuslVelocity, (false, true, false))
            | (G2pPass::MuslPositionStrain, (true, true, true))
            | (G2pPass::MuslPositionStrain, (true, true, false))
            | (G2pPass::UsfStrain, (false, false, true))
            | (G2pPass::UsfVelocityPosition, (true, true, false))
            | (G2pPass::UsfVelocityPosition, (true, true, true))
    )
}

/// A G2P pass followed by the P2G scatter `what` (mass, momentum, force, as
/// in [`p2g`], with the external-force factor `load_factor` and the body
/// force `body`) of the updated particles into the grid's accumulators,
/// which are added to, not reset. For the pairs [`fusable`] accepts, both
/// run in one loop over the particles (reading each particle once, and
/// evaluating its weights once unless the pass moves it); the result is bit
/// for bit that of [`g2p`] followed by [`p2g`], which is what runs for any
/// other pair. A particle whose new stencil is off the grid is not scattered
/// and is reported in `first_outside`.
#[allow(clippy::too_many_arguments)]
pub fn g2p_p2g(
    grid: &mut Grid,
    parts: &mut Particles,
    mats: &[MatParams],
    prm: &StepParams,
    pass: G2pPass,
    what: (bool, bool, bool),
    load_factor: f64,
    body: Option<BodyForce>,
) -> Result<PassStats> {
    if let Some(b) = body {
        if b.bx.len() != parts.len() || b.by.len() != parts.len() {
            return Err(Error::arg(format!(
                "body force arrays have {} and {} entries, must have one per particle ({})",
                b.bx.len(),
                b.by.len(),
                parts.len()
            )));
        }
    }
    if !fusable(pass, what) {
        let st = g2p(grid, parts, mats, prm, pass);
        let pp = StepParams {
            load_factor,
            ..*prm
        };
        p2g(grid, parts, &pp, body, what)?;
        return Ok(st);
    }
    let geo = p2g::Geo::of(grid);
    let h = grid.h;
    let Grid {
        mass,
        mom_force,
        vel,
        dil,
        ..
    } = grid;
    let gv = g2p::Vel { v: vel, dil };
    let sinks = p2g::Sinks {
        m: mass,
        mf: mom_force,
    };
    let sl = g2p::ScatterLoads {
        load_factor,
        gravity: prm.gravity,
        body,
    };
    Ok(g2p_any(
        gv, sinks, geo, h, parts, mats, prm, pass, what, &sl, None,
    ))
}

/// Dispatch on the shape and the material law.
#[allow(clippy::too_many_arguments)]
fn g2p_any(
    gv: g2p::Vel,
    sinks: p2g::Sinks,
    geo: p2g::Geo,
    h: f64,
    parts: &mut Particles,
    mats: &[MatParams],
    prm: &StepParams,
    pass: G2pPass,
    what: (bool, bool, bool),
    sl: &g2p::ScatterLoads,
    skip: Option<f64>,
) -> PassStats {
    macro_rules! go {
        ($s:ty, $m:ty) => {
            g2p_sm::<$s, $m>(gv, sinks, geo, h, parts, mats, prm, pass, what, sl, skip)
        };
    }
    match (prm.shape, uniform_law(mats)) {
        (ShapeKind::Mpm, Some(MatKind::LinearElastic)) => go!(MpmShape, LinearElasticLaw),
        (ShapeKind::Mpm, Some(MatKind::NeoHookean)) => go!(MpmShape, NeoHookeanLaw),
        (ShapeKind::Mpm, Some(MatKind::J2)) => go!(MpmShape, J2Law),
        (ShapeKind::Mpm, None) => go!(MpmShape, AnyLaw),
        (_, Some(MatKind::LinearElastic)) => go!(GimpShape, LinearElasticLaw),
        (_, Some(MatKind::NeoHookean)) => go!(GimpShape, NeoHookeanLaw),
        (_, Some(MatKind::J2)) => go!(GimpShape, J2Law),
        (_, None) => go!(GimpShape, AnyLaw),
    }
}

/// Dispatch on the pass and the scatter (`what` is `NO_SCATTER` or a pair
/// that [`fusable`] accepts).
#[allow(clippy::too_many_arguments)]
fn g2p_sm<S: Shape1D, M: Constitutive>(
    gv: g2p::Vel,
    sinks: p2g::Sinks,
    geo: p2g::Geo,
    h: f64,
    parts: &mut Particles,
    mats: &[MatParams],
    prm: &StepParams,
    pass: G2pPass,
    what: (bool, bool, bool),
    sl: &g2p::ScatterLoads,
    skip: Option<f64>,
) -> PassStats {
    use g2p::g2p_impl;
    const F: bool = false;
    const T: bool = true;
    // The APIC variant (velocity and affine matrix, affine momentum, the
    // objective update of F) where the transfer asks for it.
    let apic = prm.transfer == Transfer::Apic;
    macro_rules! go {
        ($vel:expr, $pos:expr, $strain:expr, $m:expr, $p:expr, $f:expr, $v0:expr) => {
            if apic {
                g2p_impl::<S, M, $vel, $pos, $strain, $m, $p, $f, true>(
                    gv, sinks, geo, h, $v0, parts, mats, prm, sl, skip,
                )
            } else {
                g2p_impl::<S, M, $vel, $pos, $strain, $m, $p, $f, false>(
                    gv, sinks, geo, h, $v0, parts, mats, prm, sl, skip,
                )
            }
        };
    }
    match (pass, what) {
        (G2pPass::UslAll, NO_SCATTER) => go!(T, T, T, F, F, F, false),
        (G2pPass::UslAll, (T, T, T)) => go!(T, T, T, T, T, T, false),
        (G2pPass::MuslVelocity, NO_SCATTER) => go!(T, F, F, F, F, F, false),
        (G2pPass::MuslVelocity, (F, T, F)) => go!(T, F, F, F, T, F, false),
        (G2pPass::MuslPositionStrain, NO_SCATTER) => go!(F, T, T, F, F, F, true),
        (G2pPass::MuslPositionStrain, (T, T, T)) => go!(F, T, T, T, T, T, true),
        (G2pPass::MuslPositionStrain, (T, T, F)) => go!(F, T, T, T, T, F, true),
        (G2pPass::UsfStrain, NO_SCATTER) => go!(F, F, T, F, F, F, true),
        (G2pPass::UsfStrain, (F, F, T)) => go!(F, F, T, F, F, T, true),
        (G2pPass::UsfVelocityPosition, NO_SCATTER) => go!(T, T, F, F, F, F, false),
        (G2pPass::UsfVelocityPosition, (T, T, F)) => go!(T, T, F, T, T, F, false),
        (G2pPass::UsfVelocityPosition, (T, T, T)) => go!(T, T, F, T, T, T, false),
        _ => unreachable!("g2p_sm is called with no scatter or a fusable pair"),
    }
}

/// Zeroes the nodal momentum (before MUSL's re-mapping).
pub fn reset_momentum(grid: &mut Grid) {
    for n in &mut grid.mom_force {
        n.0[grid::mf::PX] = 0.0;
        n.0[grid::mf::PY] = 0.0;
    }
}

/// Zeroes the nodal force (before USF's force pass).
pub fn reset_force(grid: &mut Grid) {
    for n in &mut grid.mom_force {
        n.0[grid::mf::FX] = 0.0;
        n.0[grid::mf::FY] = 0.0;
    }
}

/// Thread CPU seconds spent in each phase of the steps timed so far (see
/// [`step_patches`]). The stress update runs inside the G2P pass that
/// computes the strain, so it is counted under `g2p`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseTimes {
    /// Grid reset and particle-to-grid passes.
    pub p2g: f64,
    /// Grid updates and boundary conditions.
    pub grid: f64,
    /// Grid-to-particle passes (with the stress update).
    pub g2p: f64,
    /// Fused passes (G2P of one step with the P2G of the next).
    pub fused: f64,
    /// Particle sorting.
    pub sort: f64,
    /// Steps timed.
    pub steps: u64,
}

impl PhaseTimes {
    /// Sum of all phases.
    pub fn total(&self) -> f64 {
        self.p2g + self.grid + self.g2p + self.fused + self.sort
    }
}

/// CPU time of the calling thread, in seconds (`CLOCK_THREAD_CPUTIME_ID`):
/// unlike wall time it does not count the time other processes hold the
/// core, so timings on a shared machine stay comparable.
pub fn thread_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant
    // that every supported (POSIX) target provides.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return 0.0;
    }
    ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64
}

/// A stopwatch that adds the thread CPU time since the last lap to a phase,
/// or does nothing when timing is off.
pub(crate) struct Laps<'a> {
    t: Option<(&'a mut PhaseTimes, f64)>,
}

impl<'a> Laps<'a> {
    /// Starts timing into `t` (or not, for `None`).
    pub(crate) fn new(t: Option<&'a mut PhaseTimes>) -> Laps<'a> {
        Laps {
            t: t.map(|t| (t, thread_cpu_seconds())),
        }
    }

    /// Adds the time since the last lap to the phase `f` selects.
    #[inline]
    pub(crate) fn lap(&mut self, f: impl FnOnce(&mut PhaseTimes) -> &mut f64) {
        if let Some((t, last)) = &mut self.t {
            let now = thread_cpu_seconds();
            *f(t) += now - *last;
            *last = now;
        }
    }
}

/// One complete explicit step of a patch that owns all the nodes it touches
/// (no neighbour contributions to sum): [`step_patches`] on [`OnePatch`],
/// within-step passes merged, nothing prepared for the next step. Returns
/// the stats of the step (`dt_cfl1` for the next step) or the first problem
/// found: bad arguments, particles off the grid (`ParticlesLeft`, state
/// already advanced), non-finite values or inverted particles (`Unstable`).
pub fn step_patch(
    grid: &mut Grid,
    parts: &mut Particles,
    mats: &[MatParams],
    prm: &StepParams,
    body: Option<BodyForce>,
) -> Result<PassStats> {
    let mut prepared = None;
    let mut one = OnePatch {
        patch: PatchMut {
            grid,
            parts,
            body,
            prepared: &mut prepared,
        },
    };
    let pipe = Pipeline {
        fuse: true,
        next_load_factor: None,
        skip_last: None,
    };
    one_patch_result(&mut one, mats, prm, pipe, None)
}

/// [`step_patches`] on one patch, its outcome as one result: bad arguments
/// (finite positive `dt`, `flip` in `[0, 1]`, material indices in the
/// table, body-force lengths) before anything runs, then the first error
/// the step noted, else the stats' (see [`PassStats::to_result`]); the
/// stats with `dt_cfl1` infinite without particles.
pub fn one_patch_result(
    one: &mut OnePatch,
    mats: &[MatParams],
    prm: &StepParams,
    pipe: Pipeline,
    times: Option<&mut PhaseTimes>,
) -> Result<PassStats> {
    let p = &one.patch;
    check_inputs(p.parts, mats, prm, p.body)?;
    let out = step_patches(one, mats, prm, pipe, times)?;
    if let Some(e) = out.first_err {
        return Err(e);
    }
    let mut st = out.stats[0];
    if one.patch.parts.is_empty() {
        st.dt_cfl1 = f64::INFINITY;
    }
    st.to_result(one.patch.parts)?;
    Ok(st)
}

/// `min_p h / (c_p + |v_p|)` over the particles (the stable step at CFL 1),
/// with `c_p` the P-wave speed at the particle's current Jacobian. Infinite
/// without particles. Requires valid material indices.
///
/// Computed as `h / max_p (c_p + |v_p|)`, which is the same number:
/// `c_p + |v_p|` is never negative, and a correctly rounded division by a
/// non-negative number does not increase as the number grows (`NaN` speeds
/// are left out by both `min` and `max`; no particle, or only zero or `NaN`
/// speeds, give `h / 0 = ∞`). One division per call instead of one per
/// particle, and with one material the law's branch leaves the loop.
///
/// The loop runs with the best instruction set the CPU has (see
/// [`isa`]): the largest of a set of numbers does not depend on the order
/// it is taken in, so every build gives the same bits.
pub fn stable_dt_cfl1(parts: &Particles, mats: &[MatParams], h: f64) -> f64 {
    h / max_speed(parts, mats)
}

multiversion! {
    /// `max_p (c_p + |v_p|)` for [`stable_dt_cfl1`] (0 without particles).
    fn max_speed[][](parts: &Particles, mats: &[MatParams]) -> f64 = max_speed_body;
}

#[inline(always)]
fn max_speed_body<I: simd::Simd4>(parts: &Particles, mats: &[MatParams]) -> f64 {
    let n = parts.len();
    let (fxx, fxy, fyx, fyy) = (
        &parts.fxx[..n],
        &parts.fxy[..n],
        &parts.fyx[..n],
        &parts.fyy[..n],
    );
    let (vx, vy) = (&parts.vx[..n], &parts.vy[..n]);
    // Inlined into every loop (as a closure it stayed a call per particle).
    #[inline(always)]
    fn speed_of(mp: &MatParams, f: [f64; 4], v: [f64; 2]) -> f64 {
        let j = f[0] * f[3] - f[1] * f[2];
        mp.p_wave_speed(j) + (v[0] * v[0] + v[1] * v[1]).sqrt()
    }
    // Eight running maxima (independent lanes), folded at the end.
    const W: usize = 8;
    let mut top = [0.0f64; W];
    let mut fold = |mp: &MatParams, lo: usize| {
        for (l, t) in top.iter_mut().enumerate() {
            let p = lo + l;
            let s = speed_of(mp, [fxx[p], fxy[p], fyx[p], fyy[p]], [vx[p], vy[p]]);
            *t = t.max(s);
        }
    };
    let body = n - n % W;
    if let [mp] = mats {
        // One law for every particle: its branch leaves the loop.
        match mp.kind {
            MatKind::LinearElastic => {
                let mp = MatParams {
                    kind: MatKind::LinearElastic,
                    ..*mp
                };
                (0..body).step_by(W).for_each(|lo| fold(&mp, lo));
            }
            MatKind::J2 => {
                let mp = MatParams {
                    kind: MatKind::J2,
                    ..*mp
                };
                (0..body).step_by(W).for_each(|lo| fold(&mp, lo));
            }
            MatKind::NeoHookean => {
                let mp = MatParams {
                    kind: MatKind::NeoHookean,
                    ..*mp
                };
                (0..body).step_by(W).for_each(|lo| fold(&mp, lo));
            }
        }
    }
    let material = &parts.material[..n];
    let from = if mats.len() == 1 { body } else { 0 };
    let mut last = 0.0f64;
    for p in from..n {
        let mp = &mats[material[p] as usize];
        let s = speed_of(mp, [fxx[p], fxy[p], fyx[p], fyy[p]], [vx[p], vy[p]]);
        last = last.max(s);
    }
    top.iter().fold(last, |a, &b| a.max(b))
}

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

#[cfg(test)]
mod tests;
