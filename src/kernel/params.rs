//! What a patch step is told: the update scheme, the velocity transfer, the
//! domain's boundary conditions, the load ramp and body forces, and
//! [`StepParams`], which bundles them with the time step for every pass.

use crate::mode::ModeKind;
use crate::shape::ShapeKind;

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
/// affine matrix `C_p` ([`crate::particles::Particles::cxx`] ...). P2G maps the momentum
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
    /// (Hammerquist & Nairn 2017, see [`super::xpic`]): the particle's old velocity
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
    /// Order `m` of [`Transfer::Xpic`], in `1..=`[`super::xpic::MAX_XPIC_ORDER`]
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
    /// Plane strain or axisymmetry (see [`crate::mode`]): the passes are
    /// compiled for each and pick theirs once per pass.
    pub mode: ModeKind,
}
