//! Grid-to-particle transfers: velocity (FLIP/PIC blend), position,
//! velocity gradient, deformation gradient, stress, cpGIMP half-lengths.
//!
//! One pass ([`g2p_impl`]) takes the particles a block of [`LANES`] at a
//! time through named phases ([`G2pLoop`]): the stencil sums lane by lane
//! (`gather`), then across the lanes the velocity update (`velocity`), the
//! lanes' material constants (`material_lanes`), the deformation gradient
//! and stress (`strain`), the move with its checks and the stable step
//! (`advance`), the notes of the rare problems (`notes`) and, in a fused
//! pass, the scatter of the updated particles (`scatter`). The phases are
//! inlined into the one loop, so the split costs nothing at run time.

// Lane loops index several arrays by the lane on purpose: that is the
// form the compiler turns into vector instructions.
#![allow(clippy::needless_range_loop)]

use super::block::{Block, LANES};
use super::geo::Geo;
use super::grid::Node4;
use super::isa::multiversion;
use super::lanes::{load, mask, store};
use super::p2g::{face_loads, Contribution, FaceLoads, Scatter, Sinks};
use super::simd::{Simd4, F4};
use super::stats::{first_nonfinite, note_first, note_leaving};
use super::{BodyForce, PassStats, StepParams, Transfer, MAX_STRAIN_INCREMENT};
use crate::material::axi::{
    advance_hoop, advance_hoop_midpoint, replace_dilatation, strain_increment2, Hoop,
};
use crate::material::{Constitutive, MatParams, Stress, Tensor2};
use crate::mode::Axisymmetric;
use crate::particles::{Particles, OWNED};
use crate::shape::{cpgimp_half_lengths, Shape1D, ShapeKind};
use std::marker::PhantomData;

/// [`MAX_STRAIN_INCREMENT`] squared.
const MAX_INC2: f64 = MAX_STRAIN_INCREMENT * MAX_STRAIN_INCREMENT;

/// The grid's velocities, read by G2P.
#[derive(Clone, Copy)]
pub(crate) struct Vel<'a> {
    /// `[vx, vy, v0x, v0y]` per node.
    pub(crate) v: &'a [Node4],
    /// Nodal mean dilatation `[d_i, weight]` (see [`super::nodal_dilatation`]),
    /// read by the strain pass of a law with
    /// [`Constitutive::NODAL_DILATATION`].
    pub(crate) dil: &'a [[f64; 2]],
}

/// What a fused pass scatters after updating a particle (the loads of the
/// P2G it stands for).
#[derive(Clone, Copy)]
pub(crate) struct ScatterLoads<'a> {
    /// Factor on the particles' reference external forces.
    pub(crate) load_factor: f64,
    /// Gravity.
    pub(crate) gravity: [f64; 2],
    /// Per-particle body force.
    pub(crate) body: Option<BodyForce<'a>>,
}

/// What a G2P pass reads besides the particles and the grid's
/// accumulators.
#[derive(Clone, Copy)]
pub(crate) struct G2pCtx<'a> {
    /// The grid's velocities (and nodal dilatation).
    pub(crate) vel: Vel<'a>,
    /// Where the grid sits.
    pub(crate) geo: Geo,
    /// Cell size.
    pub(crate) h: f64,
    /// The material table (every particle's index is in it).
    pub(crate) mats: &'a [MatParams],
    /// The step's parameters.
    pub(crate) prm: &'a StepParams,
    /// The loads of the fused scatter (read only by a pass that scatters).
    pub(crate) loads: ScatterLoads<'a>,
    /// Leave alone the blocks whose copy flags all equal this (see
    /// [`super::g2p_except`]; only for a pass that does not scatter).
    pub(crate) skip: Option<f64>,
}

multiversion! {
    /// One grid-to-particle pass over all particles, with the weights at the
    /// particles' current positions and half-lengths:
    ///
    /// * `VEL`: `v ← flip (v + Σ S (v_i − v0_i)) + (1 − flip) Σ S v_i`, or
    ///   with `AFF` (the APIC transfer, see [`super::Transfer`]) `v ← Σ S
    ///   v_i` and `C ← B D^{-1}` (uGIMP, cpGIMP) or `C ← Σ v_i ⊗ ∇S` (MPM);
    /// * `STRAIN`: `L = Σ v'_i ⊗ ∇S` with `v'` the grid's `v0` in a pass
    ///   without `VEL` (MUSL's second, USF's first) or `v` otherwise (USL); `F ← (I + dt L) F`,
    ///   or with `AFF` the midpoint (Cayley) form `F ← (I − dt/2 L)^{-1}
    ///   (I + dt/2 L) F`;
    ///   stress update by the law `M` (and its state, the equivalent plastic
    ///   strain, when it has one);
    /// * `POS`: `x ← x + dt Σ S v_i`, or for cpGIMP `x ← x + dt Σ S v'_i`
    ///   with `v'` the velocity the strain of the same pass reads (MUSL:
    ///   the re-mapped `v0`; USL: `v`); cpGIMP half-lengths from the new
    ///   `F`. A cpGIMP domain is `x ± F lp0`: moving its centre with `v`
    ///   while `F` integrates `v0` lets neighbouring domains drift into
    ///   gaps and overlaps, and in tension a gap opens further (a bar
    ///   pulled with MUSL tore at ~20 % strain); uGIMP and MPM keep the
    ///   updated `v`, which the contact's landing condition and the energy
    ///   figures of the hard cases rely on (with `v0` a vibrating block
    ///   gained 16 % energy in 100,000 steps instead of 3 %);
    ///   the CFL-1 time step `h / (c + |v|)`, and the finite and in-grid checks
    ///   (POS is the last pass of every scheme).
    ///
    /// Then, fused into the same loop, each updated particle is scattered to the
    /// grid's accumulators as [`super::p2g::p2g_impl`] would scatter it in a
    /// separate pass after this one (`MASS`, `MOM`, `FORCE`, with the loads
    /// of `ctx`): the pass reads only the grid's velocities and P2G writes only its
    /// accumulators, and the particles are visited in the same order, so the
    /// result is bit for bit that of the two passes. The scatter reuses the
    /// weights unless `POS` moved the particle; with `AFF` its momentum has
    /// the particle's affine part.
    pub(crate) fn g2p_impl
        [S: Shape1D, M: Constitutive, const VEL: bool, const POS: bool, const STRAIN: bool,
         const MASS: bool, const MOM: bool, const FORCE: bool, const AFF: bool]
        [S, M, VEL, POS, STRAIN, MASS, MOM, FORCE, AFF]
        (ctx: G2pCtx, sinks: Sinks, parts: &mut Particles) -> PassStats = g2p_body;
}

/// The loop of [`g2p_impl`]: the phases of [`G2pLoop`] for each block of
/// particles.
#[inline(always)]
fn g2p_body<
    I: Simd4,
    S: Shape1D,
    M: Constitutive,
    const VEL: bool,
    const POS: bool,
    const STRAIN: bool,
    const MASS: bool,
    const MOM: bool,
    const FORCE: bool,
    const AFF: bool,
>(
    ctx: G2pCtx,
    sinks: Sinks,
    parts: &mut Particles,
) -> PassStats {
    let np = parts.len();
    let scatter = MASS || MOM || FORCE;
    // Skipped particles would be missing from the scatter.
    assert!(
        ctx.skip.is_none() || !scatter,
        "a pass that scatters skips no particle"
    );
    let mut lp = G2pLoop::<I, S, M, VEL, POS, STRAIN, MASS, MOM, FORCE, AFF>::new(&ctx, sinks);
    let mut c = Cols::of::<M, AFF>(parts, S::AXI);
    let mut s = 0;
    while s < np {
        let e = (s + LANES).min(np);
        // A block of particles whose results are thrown away (see
        // `kernel::g2p_except`): left as it is.
        if let Some(f) = ctx.skip {
            if c.copy[s..e].iter().all(|&c| c == f) {
                s = e;
                continue;
            }
        }
        let b = Span { s, e };
        // The affine terms at the old positions only where they are read:
        // by the APIC velocity update, or by a scatter of the affine
        // momentum with the old weights (a pass that does not move).
        let (x, y, lx, ly) = (&c.x[s..e], &c.y[s..e], &c.lpx[s..e], &c.lpy[s..e]);
        if AFF && (VEL || (MOM && !POS)) {
            lp.blk.eval_into_aff::<S, true>(&lp.geo, x, y, lx, ly);
        } else {
            lp.blk.eval_into_aff::<S, false>(&lp.geo, x, y, lx, ly);
        }
        lp.gather(b, &mut c);
        let mut bv = BlockVals::new(lp.blk.ok, &c, b);
        lp.velocity(b, &mut c, &mut bv);
        if M::FROM_F && (STRAIN || POS) {
            lp.material_lanes(b, &c);
        }
        // F and the stress for a pass that updates, moves or scatters
        // force (MUSL's velocity pass reads neither).
        if STRAIN || POS || FORCE {
            bv.load_f_sig(&c, b, S::AXI);
        }
        if STRAIN {
            lp.strain(b, &mut c, &mut bv);
        }
        if POS {
            lp.advance(b, &mut c, &mut bv);
        }
        lp.notes(b, &bv);
        if scatter {
            lp.scatter(b, &c, &bv);
        }
        s = e;
    }
    lp.finish(parts)
}

/// The particles `s..e` of a block (`e − s <= LANES`).
#[derive(Clone, Copy)]
struct Span {
    s: usize,
    e: usize,
}

impl Span {
    /// Number of particles.
    #[inline(always)]
    fn n(self) -> usize {
        self.e - self.s
    }
}

/// The particle fields a pass touches, each sliced to the number of
/// particles up front, so that the loop's indexing needs no bounds checks.
struct Cols<'p> {
    copy: &'p [f64],
    x: &'p mut [f64],
    y: &'p mut [f64],
    vx: &'p mut [f64],
    vy: &'p mut [f64],
    mass: &'p [f64],
    vol0: &'p [f64],
    lpx0: &'p [f64],
    lpy0: &'p [f64],
    lpx: &'p mut [f64],
    lpy: &'p mut [f64],
    fxx: &'p mut [f64],
    fxy: &'p mut [f64],
    fyx: &'p mut [f64],
    fyy: &'p mut [f64],
    /// The hoop stretch (empty in plane strain).
    fzz: &'p mut [f64],
    sxx: &'p mut [f64],
    syy: &'p mut [f64],
    sxy: &'p mut [f64],
    szz: &'p mut [f64],
    fext_x: &'p [f64],
    fext_y: &'p [f64],
    fside_x: &'p [f64],
    fside_y: &'p [f64],
    load_faces: &'p [f64],
    material: &'p [u32],
    /// The laws' per-particle state (empty for a law without one: the loop
    /// does not see the field at all).
    eps_p: &'p mut [f64],
    /// The affine matrix (empty without `AFF`).
    cxx: &'p mut [f64],
    cxy: &'p mut [f64],
    cyx: &'p mut [f64],
    cyy: &'p mut [f64],
}

impl<'p> Cols<'p> {
    #[inline(always)]
    fn of<M: Constitutive, const AFF: bool>(parts: &'p mut Particles, axi: bool) -> Cols<'p> {
        let np = parts.len();
        let Particles {
            id: _,
            x,
            y,
            vx,
            vy,
            mass,
            vol0,
            lpx0,
            lpy0,
            lpx,
            lpy,
            fxx,
            fxy,
            fyx,
            fyy,
            fzz,
            sxx,
            syy,
            sxy,
            szz,
            fext_x,
            fext_y,
            fside_x,
            fside_y,
            load_faces,
            material,
            eps_p,
            cxx,
            cxy,
            cyx,
            cyy,
            copy,
            ..
        } = parts;
        let eps_p: &mut [f64] = if M::HAS_STATE {
            &mut eps_p[..np]
        } else {
            &mut []
        };
        let fzz: &mut [f64] = if axi { &mut fzz[..np] } else { &mut [] };
        let (cxx, cxy, cyx, cyy): (&mut [f64], &mut [f64], &mut [f64], &mut [f64]) = if AFF {
            (
                &mut cxx[..np],
                &mut cxy[..np],
                &mut cyx[..np],
                &mut cyy[..np],
            )
        } else {
            (&mut [], &mut [], &mut [], &mut [])
        };
        Cols {
            copy: &copy[..np],
            x: &mut x[..np],
            y: &mut y[..np],
            vx: &mut vx[..np],
            vy: &mut vy[..np],
            mass: &mass[..np],
            vol0: &vol0[..np],
            lpx0: &lpx0[..np],
            lpy0: &lpy0[..np],
            lpx: &mut lpx[..np],
            lpy: &mut lpy[..np],
            fxx: &mut fxx[..np],
            fxy: &mut fxy[..np],
            fyx: &mut fyx[..np],
            fyy: &mut fyy[..np],
            fzz,
            sxx: &mut sxx[..np],
            syy: &mut syy[..np],
            sxy: &mut sxy[..np],
            szz: &mut szz[..np],
            fext_x: &fext_x[..np],
            fext_y: &fext_y[..np],
            fside_x: &fside_x[..np],
            fside_y: &fside_y[..np],
            load_faces: &load_faces[..np],
            material: &material[..np],
            eps_p,
            cxx,
            cxy,
            cyx,
            cyy,
        }
    }
}

/// A block's particle values in lanes while the phases update them (lanes
/// past the block's particles, or not `ok`, keep their values and are not
/// written back), and what the phases note about each lane.
struct BlockVals {
    /// The lane's stencil was on the grid (at the old position).
    ok: [bool; LANES],
    /// Velocity.
    vx: [f64; LANES],
    vy: [f64; LANES],
    /// Deformation gradient (xx, xy, yx, yy); zeros in a pass that
    /// neither updates, moves nor scatters force (MUSL's velocity pass).
    f: [[f64; LANES]; 4],
    /// The hoop stretch `F_θθ` (axisymmetric shapes; 1 otherwise, and in a
    /// pass that leaves `f` at zeros).
    ft: [f64; LANES],
    /// Stress (xx, yy, xy, zz); zeros in a pass that neither reads nor
    /// writes it.
    sg: [[f64; LANES]; 4],
    /// F turned non-positive or NaN.
    inverted: [bool; LANES],
    /// The strain increment passed [`MAX_STRAIN_INCREMENT`].
    runaway: [bool; LANES],
    /// The new position is off the mappable cells.
    outside: [bool; LANES],
    /// The new position is off the patch's own cells.
    leaving: [bool; LANES],
}

impl BlockVals {
    /// The block's velocities; F and the stress follow in
    /// [`BlockVals::load_f_sig`].
    #[inline(always)]
    fn new(ok: [bool; LANES], c: &Cols, b: Span) -> BlockVals {
        let Span { s, e } = b;
        BlockVals {
            ok,
            vx: load(&c.vx[s..e]),
            vy: load(&c.vy[s..e]),
            f: [[0.0; LANES]; 4],
            ft: [1.0; LANES],
            sg: [[0.0; LANES]; 4],
            inverted: [false; LANES],
            runaway: [false; LANES],
            outside: [false; LANES],
            leaving: [false; LANES],
        }
    }

    /// Loads F (with the hoop stretch when `axi`, the weights' constant)
    /// and the stress.
    #[inline(always)]
    fn load_f_sig(&mut self, c: &Cols, b: Span, axi: bool) {
        let Span { s, e } = b;
        self.f = [
            load(&c.fxx[s..e]),
            load(&c.fxy[s..e]),
            load(&c.fyx[s..e]),
            load(&c.fyy[s..e]),
        ];
        if axi {
            self.ft = load(&c.fzz[s..e]);
        }
        self.sg = [
            load(&c.sxx[s..e]),
            load(&c.syy[s..e]),
            load(&c.sxy[s..e]),
            load(&c.szz[s..e]),
        ];
    }
}

/// One G2P pass: what stays the same through it (from its [`G2pCtx`]) and
/// what it carries from block to block (the per-lane buffers, the running
/// maxima of the stable step, the scatter's local sums, the stats). Its
/// methods are the phases of a block, in the order [`g2p_body`] runs them.
struct G2pLoop<
    's,
    I: Simd4,
    S: Shape1D,
    M: Constitutive,
    const VEL: bool,
    const POS: bool,
    const STRAIN: bool,
    const MASS: bool,
    const MOM: bool,
    const FORCE: bool,
    const AFF: bool,
> {
    geo: Geo,
    h: f64,
    inv_h: f64,
    nx: usize,
    /// Mappable cells per axis (a particle past them is `outside`).
    range: [(f64, f64); 2],
    /// The patch's own cells per axis (see [`Geo`]).
    home: [(f64, f64); 2],
    dt: f64,
    flip: f64,
    /// The XPIC velocity update (a loop-invariant branch).
    xpic: bool,
    cp: bool,
    gvel: &'s [Node4],
    gdil: &'s [[f64; 2]],
    /// The nodal dilatation was computed on this grid.
    smooth: bool,
    mats: &'s [MatParams],
    sl: ScatterLoads<'s>,
    sinks: Sinks<'s>,
    st: PassStats,
    /// Largest `c + |v|` per lane: `min h/(c + |v|)` is `h / max(c + |v|)`
    /// exactly (division is correctly rounded, hence monotone), at one
    /// division per pass instead of one per particle. Kept per lane of
    /// the blocks (independent chains instead of one through every
    /// particle; the largest value does not depend on the order, and the
    /// sum of the updated values is only tested for finiteness), folded
    /// at the end.
    lane_max: [f64; LANES],
    /// Sum of the updated values per lane (finiteness check).
    lane_acc: [f64; LANES],
    sc: Scatter<I>,
    /// The block's stencils at the old positions, and at the new ones for
    /// the scatter of a pass that moves the particles. Kept across blocks:
    /// every lane is rewritten (or marked not `ok`) for each block.
    blk: Block,
    blk_new: Block,
    lb: LaneBuf,
    /// The material of the lanes in `lb.mat` when all lanes had one
    /// material (`u32::MAX`: none yet, or mixed).
    lane_mat: u32,
    _law: PhantomData<(S, M)>,
}

impl<
        's,
        I: Simd4,
        S: Shape1D,
        M: Constitutive,
        const VEL: bool,
        const POS: bool,
        const STRAIN: bool,
        const MASS: bool,
        const MOM: bool,
        const FORCE: bool,
        const AFF: bool,
    > G2pLoop<'s, I, S, M, VEL, POS, STRAIN, MASS, MOM, FORCE, AFF>
{
    /// The pass's invariants, checked against the grid's arrays.
    #[inline(always)]
    fn new(ctx: &G2pCtx<'s>, sinks: Sinks<'s>) -> Self {
        let geo = ctx.geo;
        let Geo {
            inv_h,
            lox,
            loy,
            nx,
            nxi,
            nyi,
            ..
        } = geo;
        let prm = ctx.prm;
        let (gvel, gdil) = (ctx.vel.v, ctx.vel.dil);
        let nn = geo.nodes();
        assert!(
            gvel.len() == nn,
            "grid velocity array must hold n[0] * n[1] nodes"
        );
        assert!(
            !(MASS || MOM || FORCE) || sinks.all_len(nn),
            "grid accumulators must hold n[0] * n[1] nodes"
        );
        G2pLoop {
            geo,
            h: ctx.h,
            inv_h,
            nx,
            range: [
                (lox as f64 + 0.5, lox as f64 + nxi as f64 - 1.5),
                (loy as f64 + 0.5, loy as f64 + nyi as f64 - 1.5),
            ],
            home: geo.home,
            dt: prm.dt,
            flip: prm.flip,
            xpic: prm.transfer == Transfer::Xpic,
            cp: prm.shape == ShapeKind::CpGimp,
            gvel,
            gdil,
            // The nodal dilatation is read only when its phase ran on this
            // grid (kernel::nodal_dilatation). When it could not (its
            // allocation failed), that phase's error fails the step, which
            // is then undone: the pass must not panic on the way (on one
            // rank of a collective step).
            smooth: M::NODAL_DILATATION && gdil.len() == nn,
            mats: ctx.mats,
            sl: ctx.loads,
            sinks,
            st: PassStats {
                dt_cfl1: f64::INFINITY,
                ..PassStats::default()
            },
            lane_max: [0.0; LANES],
            lane_acc: [0.0; LANES],
            sc: Scatter::<I>::new(),
            blk: Block::new(),
            blk_new: Block::new(),
            lb: LaneBuf::new(),
            lane_mat: u32::MAX,
            _law: PhantomData,
        }
    }

    /// Phase 1, lane by lane: the sums over each particle's stencil (and
    /// the APIC velocity and matrix, which need the stencil's offsets, and
    /// the interpolated nodal dilatation).
    #[inline(always)]
    fn gather(&mut self, b: Span, c: &mut Cols) {
        let Span { s, .. } = b;
        let (blk, lb, nx, inv_h) = (&self.blk, &mut self.lb, self.nx, self.inv_h);
        let (gvel, gdil) = (self.gvel, self.gdil);
        let ok = blk.ok;
        // `h / D_p` per axis for the APIC matrix of the GIMP weights.
        let mut inv_d = [[0.0; LANES]; 2];
        if AFF && VEL && S::APIC_MOMENTS {
            for k in 0..2 {
                for l in 0..LANES {
                    inv_d[k][l] = inv_h / blk.d2[k][l];
                }
            }
        }
        for l in 0..b.n() {
            if !ok[l] {
                continue;
            }
            let p = s + l;
            let w = blk.lane(l);
            let k0 = w.k0();
            // Row sums first (over a, with wx and gx), then over rows (with
            // wy and gy), all four velocities of a node at once (lanes
            // [vx, vy, v0x, v0y]): sv = Σ S [v, v0], and the velocity
            // gradient columns (L_xx, L_yx) = Σ u ∂S/∂x, (L_xy, L_yy) =
            // Σ u ∂S/∂y (times h), with u = v for USL (lanes 0, 1) and v0
            // otherwise (lanes 2, 3).
            // With AFF and VEL also the first moments B (columns bcx =
            // Σ S v dx, bcy = Σ S v dy, in cells), and for MPM's weights
            // the gradient of v.
            let aff = AFF && VEL;
            // The gradient: for the strain, and for the APIC matrix of
            // the MPM weights (the GIMP weights take their moments).
            let grad = STRAIN || (aff && !S::APIC_MOMENTS);
            let (mut sv, mut lcx, mut lcy) = (F4::<I>::zero(), F4::zero(), F4::zero());
            let (mut bcx, mut bcy) = (F4::<I>::zero(), F4::zero());
            // Axisymmetry: the hoop sums Σ T v (lanes as `sv`).
            let hoop = S::AXI && STRAIN;
            let mut ht = F4::<I>::zero();
            for b in 0..3 {
                let r = k0 + b * nx;
                let (mut rv, mut gu, mut ru) = (F4::zero(), F4::zero(), F4::zero());
                let mut rt = F4::<I>::zero();
                for a in 0..3 {
                    // SAFETY: r + a <= k0 + 2 nx + 2 < nx ny, the length of
                    // the velocity array (checked before the loop).
                    let v = F4::load(unsafe { &gvel.get_unchecked(r + a).0 });
                    rv = rv.add(F4::splat(w.wx(a)).mul(v));
                    if grad {
                        gu = gu.add(F4::splat(w.gx(a)).mul(v));
                    }
                    if aff {
                        ru = ru.add(F4::splat(w.wdx(a)).mul(v));
                    }
                    if hoop {
                        rt = rt.add(F4::splat(w.tx(a)).mul(v));
                    }
                }
                let wyb = F4::splat(w.wy(b));
                sv = sv.add(wyb.mul(rv));
                if hoop {
                    ht = ht.add(wyb.mul(rt));
                }
                if grad {
                    lcx = lcx.add(wyb.mul(gu));
                    lcy = lcy.add(F4::splat(w.gy(b)).mul(rv));
                }
                if aff {
                    bcx = bcx.add(wyb.mul(ru));
                    bcy = bcy.add(F4::splat(w.wdy(b)).mul(rv));
                }
            }
            let sva = sv.to_array();
            for k in 0..4 {
                lb.sv[k][l] = sva[k];
            }
            let (lcx, lcy) = (lcx.to_array(), lcy.to_array());
            if STRAIN {
                let u = if VEL { 0 } else { 2 };
                lb.lc[0][l] = lcx[u];
                lb.lc[1][l] = lcy[u];
                lb.lc[2][l] = lcx[u + 1];
                lb.lc[3][l] = lcy[u + 1];
                if hoop {
                    // L_θθ = Σ v_r T (times h).
                    lb.lh[l] = ht.to_array()[u];
                }
            }
            if VEL && AFF {
                // APIC: the PIC velocity and the affine matrix, from the
                // updated grid velocity (lanes 0, 1).
                c.vx[p] = sva[0];
                c.vy[p] = sva[1];
                let (gx, gy) = (lcx, lcy);
                let (c_xx, c_yx, c_xy, c_yy) = if S::APIC_MOMENTS {
                    // D_p per axis: the second moments of the weights (in
                    // cells², >= l²/3 for the GIMP weights, l > 0), inverted
                    // across the lanes before the loop.
                    let (bx, by) = (bcx.to_array(), bcy.to_array());
                    let (ix, iy) = (inv_d[0][l], inv_d[1][l]);
                    (bx[0] * ix, bx[1] * ix, by[0] * iy, by[1] * iy)
                } else {
                    (gx[0] * inv_h, gx[1] * inv_h, gy[0] * inv_h, gy[1] * inv_h)
                };
                c.cxx[p] = c_xx;
                c.cxy[p] = c_xy;
                c.cyx[p] = c_yx;
                c.cyy[p] = c_yy;
            }
            if STRAIN && M::NODAL_DILATATION {
                // The trace of L becomes the interpolated nodal mean
                // dilatation for the materials that ask for it; the
                // deviatoric part stays the particle's.
                lb.smooth[l] =
                    self.smooth && M::nodal_dilatation(&self.mats[c.material[p] as usize]);
                if lb.smooth[l] {
                    let mut dbar = 0.0;
                    for b in 0..3 {
                        let r = k0 + b * nx;
                        let mut row = 0.0;
                        for a in 0..3 {
                            // SAFETY: as for the velocities (same length,
                            // checked before the loop).
                            row += w.wx(a) * unsafe { gdil.get_unchecked(r + a)[0] };
                        }
                        dbar += w.wy(b) * row;
                    }
                    lb.dbar[l] = dbar;
                }
            }
        }
    }

    /// Phase 2 (this and the phases below run across the lanes, vector
    /// instructions over the block's particles, with the same operations
    /// per particle as one at a time): the FLIP/PIC or XPIC velocity
    /// update (the APIC velocity was set by [`G2pLoop::gather`]).
    #[inline(always)]
    fn velocity(&self, b: Span, c: &mut Cols, bv: &mut BlockVals) {
        let Span { s, e } = b;
        let (lb, ok, flip) = (&self.lb, bv.ok, self.flip);
        let (vxl, vyl) = (&mut bv.vx, &mut bv.vy);
        if VEL && !AFF && self.xpic {
            // XPIC: the grid's `v0` lanes hold `v0 − (1 − flip) v*` (see
            // `super::xpic`).
            for l in 0..LANES {
                let [svx, svy, s0x, s0y] = [lb.sv[0][l], lb.sv[1][l], lb.sv[2][l], lb.sv[3][l]];
                let nvx = flip * vxl[l] + (svx - s0x);
                let nvy = flip * vyl[l] + (svy - s0y);
                vxl[l] = if ok[l] { nvx } else { vxl[l] };
                vyl[l] = if ok[l] { nvy } else { vyl[l] };
            }
            store(&mut c.vx[s..e], vxl);
            store(&mut c.vy[s..e], vyl);
        } else if VEL && !AFF {
            for l in 0..LANES {
                let [svx, svy, s0x, s0y] = [lb.sv[0][l], lb.sv[1][l], lb.sv[2][l], lb.sv[3][l]];
                let nvx = flip * (vxl[l] + (svx - s0x)) + (1.0 - flip) * svx;
                let nvy = flip * (vyl[l] + (svy - s0y)) + (1.0 - flip) * svy;
                vxl[l] = if ok[l] { nvx } else { vxl[l] };
                vyl[l] = if ok[l] { nvy } else { vyl[l] };
            }
            store(&mut c.vx[s..e], vxl);
            store(&mut c.vy[s..e], vyl);
        }
    }

    /// The lanes' λ, μ, ρ0 for the laws with the stress from F (one
    /// broadcast while the blocks keep one material).
    #[inline(always)]
    fn material_lanes(&mut self, b: Span, c: &Cols) {
        let Span { s, e } = b;
        let (mats, material, lb) = (self.mats, c.material, &mut self.lb);
        let m0 = material[s];
        if material[s..e].iter().all(|&m| m == m0) {
            if m0 != self.lane_mat {
                let mp = &mats[m0 as usize];
                lb.mat = [[mp.lambda; LANES], [mp.mu; LANES], [mp.rho0; LANES]];
                self.lane_mat = m0;
            }
        } else {
            for l in 0..b.n() {
                let mp = &mats[material[s + l] as usize];
                lb.mat[0][l] = mp.lambda;
                lb.mat[1][l] = mp.mu;
                lb.mat[2][l] = mp.rho0;
            }
            self.lane_mat = u32::MAX;
        }
    }

    /// The velocity gradient, the new deformation gradient (with the
    /// inversion and runaway checks), the stress by the law `M`, and both
    /// stored.
    #[inline(always)]
    fn strain(&mut self, b: Span, c: &mut Cols, bv: &mut BlockVals) {
        let Span { s, e } = b;
        let (dt, inv_h, mats) = (self.dt, self.inv_h, self.mats);
        let lb = &mut self.lb;
        let ok = bv.ok;
        let (fl, sg, ftl) = (&mut bv.f, &mut bv.sg, &mut bv.ft);
        for l in 0..LANES {
            let mut lt = Tensor2 {
                xx: lb.lc[0][l] * inv_h,
                xy: lb.lc[1][l] * inv_h,
                yx: lb.lc[2][l] * inv_h,
                yy: lb.lc[3][l] * inv_h,
            };
            // The hoop rate v_r/r (axisymmetry).
            let mut ltt = if S::AXI { lb.lh[l] * inv_h } else { 0.0 };
            if M::NODAL_DILATATION {
                if S::AXI {
                    if lb.smooth[l] {
                        replace_dilatation::<Axisymmetric>(&mut lt, &mut ltt, lb.dbar[l]);
                    }
                } else {
                    let c = 0.5 * (lb.dbar[l] - (lt.xx + lt.yy));
                    if lb.smooth[l] {
                        lt.xx += c;
                        lt.yy += c;
                    }
                }
            }
            let f = Tensor2 {
                xx: fl[0][l],
                xy: fl[1][l],
                yx: fl[2][l],
                yy: fl[3][l],
            };
            let fnew = if AFF {
                // The APIC mode's objective update (see
                // `super::Transfer`): F ← (I − dt/2 L)^{-1} (I + dt/2 L) F,
                // orthogonal for a skew L.
                let k = 0.5 * dt;
                let (a, b, c, d) = (1.0 - k * lt.xx, k * lt.xy, k * lt.yx, 1.0 - k * lt.yy);
                let inv = 1.0 / (a * d - b * c);
                // (I − kL)^{-1} = [[d, b], [c, a]] / det; times (I + kL).
                let (pxx, pxy, pyx, pyy) = (1.0 + k * lt.xx, b, c, 1.0 + k * lt.yy);
                let mxx = (d * pxx + b * pyx) * inv;
                let mxy = (d * pxy + b * pyy) * inv;
                let myx = (c * pxx + a * pyx) * inv;
                let myy = (c * pxy + a * pyy) * inv;
                Tensor2 {
                    xx: mxx * f.xx + mxy * f.yx,
                    xy: mxx * f.xy + mxy * f.yy,
                    yx: myx * f.xx + myy * f.yx,
                    yy: myx * f.xy + myy * f.yy,
                }
            } else {
                Tensor2 {
                    xx: f.xx + dt * (lt.xx * f.xx + lt.xy * f.yx),
                    xy: f.xy + dt * (lt.xx * f.xy + lt.xy * f.yy),
                    yx: f.yx + dt * (lt.yx * f.xx + lt.yy * f.yx),
                    yy: f.yy + dt * (lt.yx * f.xy + lt.yy * f.yy),
                }
            };
            // The hoop stretch (axisymmetry), by the same rule as F.
            let ftn = if !S::AXI {
                1.0
            } else if AFF {
                advance_hoop_midpoint(ftl[l], ltt, dt)
            } else {
                advance_hoop(ftl[l], ltt, dt)
            };
            // The strain increment |D| dt (squared; NaN is left to the
            // finiteness check).
            let inc2 = if S::AXI {
                strain_increment2::<Axisymmetric>(&lt, ltt, dt)
            } else {
                let dxy = 0.5 * (lt.xy + lt.yx);
                dt * dt * (lt.xx * lt.xx + lt.yy * lt.yy + 2.0 * dxy * dxy)
            };
            // The midpoint update of the APIC mode turns singular (and
            // inverts F) only at increments of order 2, far beyond the
            // bound: such a particle is reported as the runaway it is.
            let run = inc2 > MAX_INC2;
            let det = if S::AXI { fnew.det() * ftn } else { fnew.det() };
            // `&`, `|`: vector compares across the lanes, no branches.
            bv.inverted[l] = ok[l] & (det.is_nan() | (det <= 0.0)) & !(AFF && run);
            bv.runaway[l] = ok[l] & run;
            lb.inc2[l] = inc2;
            if !M::FROM_F {
                lb.lt[0][l] = lt.xx;
                lb.lt[1][l] = lt.xy;
                lb.lt[2][l] = lt.yx;
                lb.lt[3][l] = lt.yy;
                if S::AXI {
                    lb.ltt[l] = ltt;
                }
            }
            if S::AXI {
                ftl[l] = if ok[l] { ftn } else { ftl[l] };
            }
            fl[0][l] = if ok[l] { fnew.xx } else { fl[0][l] };
            fl[1][l] = if ok[l] { fnew.xy } else { fl[1][l] };
            fl[2][l] = if ok[l] { fnew.yx } else { fl[2][l] };
            fl[3][l] = if ok[l] { fnew.yy } else { fl[3][l] };
        }
        if M::FROM_F {
            // The stress from the new F, for all lanes at once.
            let pad = mats[c.material[s] as usize];
            for l in 0..LANES {
                let mp = lb.mat_params(l, &pad);
                let f = Tensor2 {
                    xx: fl[0][l],
                    xy: fl[1][l],
                    yx: fl[2][l],
                    yy: fl[3][l],
                };
                let r = if S::AXI {
                    let hoop = Hoop {
                        rate: 0.0,
                        f: ftl[l],
                    };
                    M::update_in::<Axisymmetric>(&mp, Stress::default(), &f, hoop, dt, &f, &mut 0.0)
                } else {
                    M::update(&mp, Stress::default(), &f, dt, &f, &mut 0.0)
                };
                // Written for every lane, selected below: without the
                // lane condition the SSE2 build vectorizes this loop
                // too (13.6 against 15.4 M particle-steps/s).
                lb.sig[0][l] = r.xx;
                lb.sig[1][l] = r.yy;
                lb.sig[2][l] = r.xy;
                lb.sig[3][l] = r.zz;
                if POS {
                    // The wave speed at the same J, in the same loop:
                    // the compiler then takes ln J once for both.
                    let j = f.xx * f.yy - f.xy * f.yx;
                    let j = if S::AXI { j * ftl[l] } else { j };
                    lb.wave[l] = M::wave_speed(&mp, j);
                }
            }
            for k in 0..4 {
                for l in 0..LANES {
                    sg[k][l] = if ok[l] { lb.sig[k][l] } else { sg[k][l] };
                }
            }
        } else {
            for l in 0..b.n() {
                if !ok[l] {
                    continue;
                }
                let p = s + l;
                let mp = &mats[c.material[p] as usize];
                let old = Stress {
                    xx: sg[0][l],
                    yy: sg[1][l],
                    xy: sg[2][l],
                    zz: sg[3][l],
                };
                let lt = Tensor2 {
                    xx: lb.lt[0][l],
                    xy: lb.lt[1][l],
                    yx: lb.lt[2][l],
                    yy: lb.lt[3][l],
                };
                let f = Tensor2 {
                    xx: fl[0][l],
                    xy: fl[1][l],
                    yx: fl[2][l],
                    yy: fl[3][l],
                };
                let mut scratch = 0.0;
                let state = if M::HAS_STATE {
                    &mut c.eps_p[p]
                } else {
                    &mut scratch
                };
                let r = if S::AXI {
                    let hoop = Hoop {
                        rate: lb.ltt[l],
                        f: ftl[l],
                    };
                    M::update_in::<Axisymmetric>(mp, old, &lt, hoop, dt, &f, state)
                } else {
                    M::update(mp, old, &lt, dt, &f, state)
                };
                sg[0][l] = r.xx;
                sg[1][l] = r.yy;
                sg[2][l] = r.xy;
                sg[3][l] = r.zz;
            }
        }
        store(&mut c.sxx[s..e], &sg[0]);
        store(&mut c.syy[s..e], &sg[1]);
        store(&mut c.sxy[s..e], &sg[2]);
        store(&mut c.szz[s..e], &sg[3]);
        store(&mut c.fxx[s..e], &fl[0]);
        store(&mut c.fxy[s..e], &fl[1]);
        store(&mut c.fyx[s..e], &fl[2]);
        store(&mut c.fyy[s..e], &fl[3]);
        if S::AXI {
            store(&mut c.fzz[s..e], ftl);
        }
    }

    /// The move (`POS`): new positions and their in-grid and own-cell
    /// checks, the cpGIMP half-lengths from the new F, the sum of the
    /// updated values (finiteness) and the particles' `c + |v|`.
    #[inline(always)]
    fn advance(&mut self, b: Span, c: &mut Cols, bv: &mut BlockVals) {
        let Span { s, e } = b;
        let (dt, inv_h, h, mats) = (self.dt, self.inv_h, self.h, self.mats);
        let (range, home) = (self.range, self.home);
        let (ox, oy) = (self.geo.ox, self.geo.oy);
        let cp = self.cp;
        let lb = &mut self.lb;
        let (ok, fl, sg) = (bv.ok, &bv.f, &bv.sg);
        let caff = if AFF {
            [
                load(&c.cxx[s..e]),
                load(&c.cxy[s..e]),
                load(&c.cyx[s..e]),
                load(&c.cyy[s..e]),
            ]
        } else {
            [[0.0; LANES]; 4]
        };
        let (mut xl, mut yl) = (load(&c.x[s..e]), load(&c.y[s..e]));
        // cpGIMP: a pass that also updates F moves the particle
        // with the velocity field F was updated from (MUSL: the
        // re-mapped `v0`), so that the particle's centre and its
        // domain `x ± F lp0` move together (see the pass's notes).
        let (ux, uy) = if cp && STRAIN && !VEL { (2, 3) } else { (0, 1) };
        for l in 0..LANES {
            let j = fl[0][l] * fl[3][l] - fl[1][l] * fl[2][l];
            let j = if S::AXI { j * bv.ft[l] } else { j };
            let xn = xl[l] + dt * lb.sv[ux][l];
            let yn = yl[l] + dt * lb.sv[uy][l];
            xl[l] = if ok[l] { xn } else { xl[l] };
            yl[l] = if ok[l] { yn } else { yl[l] };
            let (vxp, vyp) = (bv.vx[l], bv.vy[l]);
            lb.j[l] = j;
            lb.v2[l] = vxp * vxp + vyp * vyp;
            // The sum of the updated values (finiteness check).
            let mut a = xn + yn + vxp + vyp;
            if AFF {
                a += caff[0][l] + caff[1][l] + caff[2][l] + caff[3][l];
            }
            lb.acc[l] = a + j + (sg[0][l] + sg[1][l] + sg[2][l] + sg[3][l]);
            let xi = (xn - ox) * inv_h;
            let yi = (yn - oy) * inv_h;
            // `&`: vector compares across the lanes, no branches.
            let inr =
                (xi >= range[0].0) & (xi < range[0].1) & (yi >= range[1].0) & (yi < range[1].1);
            let inh = (xi >= home[0].0) & (xi < home[0].1) & (yi >= home[1].0) & (yi < home[1].1);
            bv.outside[l] = ok[l] & !inr;
            bv.leaving[l] = ok[l] & !inh;
        }
        store(&mut c.x[s..e], &xl);
        store(&mut c.y[s..e], &yl);
        if cp {
            // Across the lanes (vector square roots), kept where `ok`.
            let (lx0, ly0) = (load(&c.lpx0[s..e]), load(&c.lpy0[s..e]));
            let (mut lxl, mut lyl) = (load(&c.lpx[s..e]), load(&c.lpy[s..e]));
            for l in 0..LANES {
                let f = [fl[0][l], fl[1][l], fl[2][l], fl[3][l]];
                let (lx, ly) = cpgimp_half_lengths(lx0[l], ly0[l], f, h);
                lxl[l] = if ok[l] { lx } else { lxl[l] };
                lyl[l] = if ok[l] { ly } else { lyl[l] };
            }
            store(&mut c.lpx[s..e], &lxl);
            store(&mut c.lpy[s..e], &lyl);
        }
        let (lane_max, lane_acc) = (&mut self.lane_max, &mut self.lane_acc);
        // The stable step is that of the owned particles: copies are made
        // afresh by the synchronisation after the step, which gives theirs
        // (`coupling::Coupler::copies_dt_cfl1`); one level has none.
        let flags = load(&c.copy[s..e]);
        let mut owned = [false; LANES];
        for l in 0..LANES {
            owned[l] = ok[l] & (flags[l] == OWNED);
        }
        if M::FROM_F {
            let pad = mats[c.material[s] as usize];
            for l in 0..LANES {
                let mp = lb.mat_params(l, &pad);
                let c = if STRAIN {
                    lb.wave[l]
                } else {
                    M::wave_speed(&mp, lb.j[l])
                };
                let speed = c + lb.v2[l].sqrt();
                // Lanes without a particle count for nothing.
                lane_max[l] = lane_max[l].max(if owned[l] { speed } else { 0.0 });
                lane_acc[l] += if ok[l] { lb.acc[l] } else { 0.0 };
            }
        } else {
            for l in 0..b.n() {
                if ok[l] {
                    let mp = &mats[c.material[s + l] as usize];
                    let speed = M::wave_speed(mp, lb.j[l]) + lb.v2[l].sqrt();
                    if owned[l] {
                        lane_max[l] = lane_max[l].max(speed);
                    }
                    lane_acc[l] += lb.acc[l];
                }
            }
        }
    }

    /// The rare notes: lanes off the grid (before or after the move),
    /// inverted or runaway particles, particles leaving the patch.
    #[inline(always)]
    fn notes(&mut self, b: Span, bv: &BlockVals) {
        let n = b.n();
        // The block's particles (n <= LANES < 32).
        let live = (1u32 << n) - 1;
        if (!mask(&bv.ok) & live)
            | mask(&bv.inverted)
            | mask(&bv.runaway)
            | mask(&bv.outside)
            | mask(&bv.leaving)
            != 0
        {
            let notes = BlockNotes {
                ok: bv.ok,
                inverted: bv.inverted,
                runaway: bv.runaway,
                inc2: self.lb.inc2,
                outside: bv.outside,
                leaving: bv.leaving,
            };
            notes.record::<POS>(&mut self.st, b.s, n);
        }
    }

    /// Phase 3 of a fused pass: the scatter of the updated particles, in
    /// particle order, with the weights at their new positions when the
    /// pass moved them.
    #[inline(always)]
    fn scatter(&mut self, b: Span, c: &Cols, bv: &BlockVals) {
        let Span { s, e } = b;
        let (inv_h, h, nx, sl) = (self.inv_h, self.h, self.nx, self.sl);
        let lb = &mut self.lb;
        let (fl, sg) = (&bv.f, &bv.sg);
        // What each particle scatters (see `Contribution::new`), for all
        // lanes at once.
        let ml = load(&c.mass[s..e]);
        let (bxl, byl) = match sl.body {
            Some(b) => (load(&b.bx[s..e]), load(&b.by[s..e])),
            None => ([0.0; LANES], [0.0; LANES]),
        };
        let vol0l = if FORCE {
            load(&c.vol0[s..e])
        } else {
            [0.0; LANES]
        };
        for l in 0..LANES {
            if MOM {
                lb.mv[0][l] = ml[l] * bv.vx[l];
                lb.mv[1][l] = ml[l] * bv.vy[l];
            }
            if FORCE {
                let m = ml[l];
                lb.fe[0][l] = m * (sl.gravity[0] + bxl[l]);
                lb.fe[1][l] = m * (sl.gravity[1] + byl[l]);
                let j = fl[0][l] * fl[3][l] - fl[1][l] * fl[2][l];
                let j = if S::AXI { j * bv.ft[l] } else { j };
                let v = j * vol0l[l] * inv_h;
                lb.vs[0][l] = v * sg[0][l];
                lb.vs[1][l] = v * sg[2][l];
                lb.vs[2][l] = v * sg[1][l];
                if S::AXI {
                    lb.vs[3][l] = v * sg[3][l];
                }
            }
        }
        let blk = &self.blk;
        let blk1 = if POS {
            self.blk_new.eval_into_aff::<S, AFF>(
                &self.geo,
                &c.x[s..e],
                &c.y[s..e],
                &c.lpx[s..e],
                &c.lpy[s..e],
            );
            &self.blk_new
        } else {
            blk
        };
        for l in 0..e - s {
            let p = s + l;
            if !blk.ok[l] {
                continue;
            }
            if !blk1.ok[l] {
                note_first(&mut self.st.first_outside, p);
                continue;
            }
            let ct = Contribution::<I>::new::<MOM, FORCE>(
                ml[l],
                (lb.mv[0][l], lb.mv[1][l]),
                (lb.fe[0][l], lb.fe[1][l]),
                (lb.vs[0][l], lb.vs[1][l], lb.vs[2][l]),
            );
            let ct = if AFF && MOM {
                ct.with_affine((c.cxx[p], c.cxy[p], c.cyx[p], c.cyy[p]), h)
            } else {
                ct
            };
            let ct = if S::AXI && FORCE {
                ct.with_hoop(lb.vs[3][l])
            } else {
                ct
            };
            // SAFETY: the lane's stencil is from `Block::eval` (`ok`); the
            // sinks hold all nodes (checked before the loop).
            unsafe {
                self.sc.add::<MASS, MOM, FORCE, AFF>(
                    &blk1.lane(l),
                    &ct,
                    nx,
                    &mut self.sinks,
                    S::AXI,
                )
            };
            if FORCE && c.load_faces[p] != 0.0 {
                let f = FaceLoads {
                    x: c.x[p],
                    y: c.y[p],
                    lpx: c.lpx[p],
                    lpy: c.lpy[p],
                    code: c.load_faces[p],
                    fext: (c.fext_x[p], c.fext_y[p]),
                    fside: (c.fside_x[p], c.fside_y[p]),
                    f: [c.fxx[p], c.fxy[p], c.fyx[p], c.fyy[p]],
                    lp0: [c.lpx0[p], c.lpy0[p]],
                };
                face_loads(&mut self.sc, &blk1.lane(l), &self.geo, &f, sl.load_factor);
            }
        }
    }

    /// After the last block: the scatter's last local sums, the stable
    /// step and the finiteness check.
    #[inline(always)]
    fn finish(mut self, parts: &Particles) -> PassStats {
        let np = parts.len();
        if MASS || MOM || FORCE {
            // SAFETY: as above.
            unsafe { self.sc.finish::<MASS, MOM, FORCE>(self.nx, &mut self.sinks) };
        }
        let mut st = self.st;
        if POS {
            let max_speed = self.lane_max.iter().fold(0.0f64, |a, &b| a.max(b));
            let acc = self.lane_acc.iter().sum::<f64>();
            st.dt_cfl1 = if np == 0 {
                f64::INFINITY
            } else {
                self.h / max_speed
            };
            if !acc.is_finite() {
                st.first_nonfinite = Some(first_nonfinite(parts).unwrap_or(0));
            }
        }
        st
    }
}

/// A block's per-lane values between the phases of [`g2p_impl`]: the
/// stencil sums of phase 1 and what the lane loops of phase 2 hand on.
// Cache-line aligned: see `Block`.
#[repr(align(64))]
struct LaneBuf {
    /// `Σ S [vx, vy, v0x, v0y]`.
    sv: [[f64; LANES]; 4],
    /// The velocity gradient's sums (xx, xy, yx, yy), in cells.
    lc: [[f64; LANES]; 4],
    /// The velocity gradient (xx, xy, yx, yy) as the stress update takes
    /// it (laws that read it only).
    lt: [[f64; LANES]; 4],
    /// The hoop sum `Σ T v_r` in cells (axisymmetric shapes only).
    lh: [f64; LANES],
    /// The hoop rate as the stress update takes it (axisymmetric shapes,
    /// laws that read the rate).
    ltt: [f64; LANES],
    /// The lane's material takes the nodal mean dilatation (laws with
    /// [`Constitutive::NODAL_DILATATION`] only).
    smooth: [bool; LANES],
    /// The interpolated nodal mean dilatation (where `smooth`).
    dbar: [f64; LANES],
    /// λ, μ, ρ0 (laws with [`Constitutive::FROM_F`] only).
    mat: [[f64; LANES]; 3],
    /// The strain increment `(|D| dt)²`.
    inc2: [f64; LANES],
    /// `det F` after the pass.
    j: [f64; LANES],
    /// `|v|²`.
    v2: [f64; LANES],
    /// The stress at the new F (laws with [`Constitutive::FROM_F`]),
    /// before the lanes without a particle are left out.
    sig: [[f64; LANES]; 4],
    /// The wave speed at the new F (laws with [`Constitutive::FROM_F`],
    /// passes that update F).
    wave: [f64; LANES],
    /// Sum of the updated values (finiteness check).
    acc: [f64; LANES],
    /// `m (vx, vy)`, scattered as momentum.
    mv: [[f64; LANES]; 2],
    /// The external force `m (gravity + body)`.
    fe: [[f64; LANES]; 2],
    /// `J vol0 / h (σ_xx, σ_xy, σ_yy, σ_θθ)`, scattered as internal force
    /// (the last in axisymmetry only).
    vs: [[f64; LANES]; 4],
}

impl LaneBuf {
    /// Lane `l`'s material: its λ, μ, ρ0 from `mat`, the other fields from
    /// `pad` (the block's first particle's material: every lane has the
    /// pass's law, and the laws with the stress from F read only λ, μ, ρ0).
    #[inline(always)]
    fn mat_params(&self, l: usize, pad: &MatParams) -> MatParams {
        MatParams {
            lambda: self.mat[0][l],
            mu: self.mat[1][l],
            rho0: self.mat[2][l],
            ..*pad
        }
    }

    #[inline(always)]
    fn new() -> LaneBuf {
        LaneBuf {
            sv: [[0.0; LANES]; 4],
            lc: [[0.0; LANES]; 4],
            lt: [[0.0; LANES]; 4],
            lh: [0.0; LANES],
            ltt: [0.0; LANES],
            smooth: [false; LANES],
            dbar: [0.0; LANES],
            mat: [[0.0; LANES]; 3],
            inc2: [0.0; LANES],
            j: [0.0; LANES],
            v2: [0.0; LANES],
            wave: [0.0; LANES],
            sig: [[0.0; LANES]; 4],
            acc: [0.0; LANES],
            mv: [[0.0; LANES]; 2],
            fe: [[0.0; LANES]; 2],
            vs: [[0.0; LANES]; 4],
        }
    }
}

/// What a block's lanes found that the pass reports (see [`PassStats`]).
struct BlockNotes {
    /// The lane's stencil was on the grid (at the old position).
    ok: [bool; LANES],
    /// F turned non-positive or NaN.
    inverted: [bool; LANES],
    /// The strain increment passed [`MAX_STRAIN_INCREMENT`].
    runaway: [bool; LANES],
    /// The squared strain increment.
    inc2: [f64; LANES],
    /// The new position is off the mappable cells.
    outside: [bool; LANES],
    /// The new position is off the patch's own cells.
    leaving: [bool; LANES],
}

impl BlockNotes {
    /// Records the notes of the first `n` lanes (particles `s..s + n`) in
    /// particle order, as a pass over one particle at a time would.
    #[cold]
    #[inline(never)]
    fn record<const POS: bool>(&self, st: &mut PassStats, s: usize, n: usize) {
        for l in 0..n {
            let p = s + l;
            if !self.ok[l] {
                note_first(&mut st.first_outside, p);
                if POS {
                    note_leaving(&mut st.leaving, p);
                }
                continue;
            }
            if self.inverted[l] {
                note_first(&mut st.first_inverted, p);
            }
            if self.runaway[l] && st.first_runaway.is_none() {
                st.first_runaway = Some((p, self.inc2[l].sqrt()));
            }
            if self.outside[l] {
                note_first(&mut st.first_outside, p);
            }
            if self.leaving[l] {
                note_leaving(&mut st.leaving, p);
            }
        }
    }
}
