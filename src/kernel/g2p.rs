//! Grid-to-particle transfers: velocity (FLIP/PIC blend), position,
//! velocity gradient, deformation gradient, stress, cpGIMP half-lengths.

// Lane loops index several arrays by the lane on purpose: that is the
// form the compiler turns into vector instructions.
#![allow(clippy::needless_range_loop)]

use super::block::{Block, LANES};
use super::grid::Node4;
use super::isa::multiversion;
use super::p2g::{external_force, face_loads, Contribution, FaceLoads, Geo, Scatter, Sinks};
use super::simd::{Simd4, F4};
use super::{BodyForce, PassStats, StepParams, MAX_STRAIN_INCREMENT};

/// [`MAX_STRAIN_INCREMENT`] squared.
const MAX_INC2: f64 = MAX_STRAIN_INCREMENT * MAX_STRAIN_INCREMENT;
use crate::material::{Constitutive, MatParams, Stress, Tensor2};
use crate::particles::Particles;
use crate::shape::{cpgimp_half_lengths, Shape1D, ShapeKind};

/// The grid's velocities, read by G2P.
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

multiversion! {
    /// One grid-to-particle pass over all particles, with the weights at the
    /// particles' current positions and half-lengths:
    ///
    /// * `VEL`: `v ← flip (v + Σ S (v_i − v0_i)) + (1 − flip) Σ S v_i`, or
    ///   with `AFF` (the APIC transfer, see [`super::Transfer`]) `v ← Σ S
    ///   v_i` and `C ← B D^{-1}` (uGIMP, cpGIMP) or `C ← Σ v_i ⊗ ∇S` (MPM);
    /// * `STRAIN`: `L = Σ v'_i ⊗ ∇S` with `v'` the grid's `v0` when
    ///   `grad_from_v0` (USF, MUSL) or `v` otherwise (USL); `F ← (I + dt L) F`,
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
    /// `sl`): the pass reads only the grid's velocities and P2G writes only its
    /// accumulators, and the particles are visited in the same order, so the
    /// result is bit for bit that of the two passes. The scatter reuses the
    /// weights unless `POS` moved the particle; with `AFF` its momentum has
    /// the particle's affine part.
    pub(crate) fn g2p_impl
        [S: Shape1D, M: Constitutive, const VEL: bool, const POS: bool, const STRAIN: bool,
         const MASS: bool, const MOM: bool, const FORCE: bool, const AFF: bool]
        [S, M, VEL, POS, STRAIN, MASS, MOM, FORCE, AFF]
        (gv: Vel, sinks: Sinks, geo: Geo, h: f64, grad_from_v0: bool, parts: &mut Particles,
         mats: &[MatParams], prm: &StepParams, sl: &ScatterLoads) -> PassStats = g2p_body;
}

/// The loop of [`g2p_impl`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
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
    gv: Vel,
    mut sinks: Sinks,
    geo: Geo,
    h: f64,
    grad_from_v0: bool,
    parts: &mut Particles,
    mats: &[MatParams],
    prm: &StepParams,
    sl: &ScatterLoads,
) -> PassStats {
    let np = parts.len();
    let scatter = MASS || MOM || FORCE;
    let Geo {
        inv_h,
        ox,
        oy,
        lox,
        loy,
        nx,
        nxi,
        nyi,
        ..
    } = geo;
    let home = geo.home;
    let range = [
        (lox as f64 + 0.5, lox as f64 + nxi as f64 - 1.5),
        (loy as f64 + 0.5, loy as f64 + nyi as f64 - 1.5),
    ];
    let dt = prm.dt;
    let flip = prm.flip;
    let cp = prm.shape == ShapeKind::CpGimp;
    // The APIC matrix from the weights' second moments (uGIMP, cpGIMP) or
    // from the velocity gradient (MPM, where the two are equal and the
    // moments vanish at a node): see `super::Transfer`.
    let aff_moments = prm.shape.is_gimp();
    let gvel = gv.v;
    let gdil = gv.dil;
    // The velocity gradient comes from v0 exactly in the passes without the
    // velocity update (MUSL's second, USF's first).
    assert_eq!(grad_from_v0, !VEL, "velocity gradient source");
    let nn = geo.nodes();
    assert!(
        gvel.len() == nn,
        "grid velocity array must hold n[0] * n[1] nodes"
    );
    // The nodal dilatation is read only when its phase ran on this grid
    // (kernel::nodal_dilatation). When it could not (its allocation
    // failed), that phase's error fails the step, which is then undone: the
    // pass must not panic on the way (on one rank of a collective step).
    let smooth = M::NODAL_DILATATION && gdil.len() == nn;
    assert!(
        !(MASS || MOM || FORCE) || sinks.all_len(nn),
        "grid accumulators must hold n[0] * n[1] nodes"
    );
    let mut st = PassStats {
        dt_cfl1: f64::INFINITY,
        ..PassStats::default()
    };
    // Largest `c + |v|`: `min h/(c + |v|)` is `h / max(c + |v|)` exactly
    // (division is correctly rounded, hence monotone), at one division per
    // pass instead of one per particle.
    let mut max_speed = 0.0f64;
    let mut acc = 0.0f64;
    // The same per lane of the blocks (independent chains instead of one
    // through every particle); folded into the two above at the end.
    let (mut lane_max, mut lane_acc) = ([0.0f64; LANES], [0.0f64; LANES]);
    let mut sc = Scatter::<I>::new();
    // Every field sliced to `np` up front, so the loop's indexing needs no
    // bounds checks.
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
        ..
    } = parts;
    let (x, y, vx, vy) = (&mut x[..np], &mut y[..np], &mut vx[..np], &mut vy[..np]);
    let (lpx0, lpy0) = (&lpx0[..np], &lpy0[..np]);
    let (lpx, lpy) = (&mut lpx[..np], &mut lpy[..np]);
    let (mass, vol0) = (&mass[..np], &vol0[..np]);
    let (fext_x, fext_y) = (&fext_x[..np], &fext_y[..np]);
    let (fside_x, fside_y) = (&fside_x[..np], &fside_y[..np]);
    let load_faces = &load_faces[..np];
    let (fxx, fxy, fyx, fyy) = (
        &mut fxx[..np],
        &mut fxy[..np],
        &mut fyx[..np],
        &mut fyy[..np],
    );
    let (sxx, syy, sxy, szz) = (
        &mut sxx[..np],
        &mut syy[..np],
        &mut sxy[..np],
        &mut szz[..np],
    );
    let material = &material[..np];
    // The laws' per-particle state, touched only by a law that has one
    // (for the others the loop does not see the field at all).
    let eps_p: &mut [f64] = if M::HAS_STATE {
        &mut eps_p[..np]
    } else {
        &mut []
    };
    // The affine matrix, read or written only with AFF.
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
    // Kept across blocks: every lane is rewritten (or marked not `ok`) for
    // each block.
    let (mut blk, mut blk_new, mut hb) = (Block::new(), Block::new(), HyperBlock::new());
    let mut s = 0;
    while s < np {
        let e = (s + LANES).min(np);
        blk.eval_into_aff::<S, AFF>(&geo, &x[s..e], &y[s..e], &lpx[s..e], &lpy[s..e]);
        hb.ok = [false; LANES];
        for l in 0..e - s {
            let p = s + l;
            if !blk.ok[l] {
                note_first(&mut st.first_outside, p);
                if POS {
                    note_leaving(&mut st.leaving, p);
                }
                continue;
            }
            let w = blk.lane(l);
            let k0 = w.k0();
            // Row sums first (over a, with wx and gx), then over rows (with
            // wy and gy), all four velocities of a node at once (lanes
            // [vx, vy, v0x, v0y]): sv = Σ S [v, v0], and the velocity
            // gradient columns (L_xx, L_yx) = Σ u ∂S/∂x, (L_xy, L_yy) =
            // Σ u ∂S/∂y (times h), with u = v for USL (lanes 0, 1) and v0
            // otherwise (lanes 2, 3).
            // With AFF and VEL also the first moments B (columns bcx =
            // Σ S v dx, bcy = Σ S v dy, in cells) and the gradient of v.
            let aff = AFF && VEL;
            let grad = STRAIN || aff;
            let (mut sv, mut lcx, mut lcy) = (F4::<I>::zero(), F4::zero(), F4::zero());
            let (mut bcx, mut bcy) = (F4::<I>::zero(), F4::zero());
            for b in 0..3 {
                let r = k0 + b * nx;
                let (mut rv, mut gu, mut ru) = (F4::zero(), F4::zero(), F4::zero());
                for a in 0..3 {
                    // SAFETY: r + a <= k0 + 2 nx + 2 < nx ny, the length of
                    // the velocity array (checked before the loop).
                    let v = F4::load(unsafe { &gvel.get_unchecked(r + a).0 });
                    rv = rv.add(F4::splat(w.wx(a)).mul(v));
                    if grad {
                        gu = gu.add(F4::splat(w.gx(a)).mul(v));
                    }
                    if aff {
                        ru = ru.add(F4::splat(w.wx(a) * w.dx(a)).mul(v));
                    }
                }
                let wyb = F4::splat(w.wy(b));
                sv = sv.add(wyb.mul(rv));
                if grad {
                    lcx = lcx.add(wyb.mul(gu));
                    lcy = lcy.add(F4::splat(w.gy(b)).mul(rv));
                }
                if aff {
                    bcx = bcx.add(wyb.mul(ru));
                    bcy = bcy.add(F4::splat(w.wy(b) * w.dy(b)).mul(rv));
                }
            }
            let [svx, svy, s0x, s0y] = sv.to_array();
            let (lcx, lcy) = (lcx.to_array(), lcy.to_array());
            let u = if VEL { 0 } else { 2 };
            let (lxx, lyx, lxy, lyy) = (lcx[u], lcx[u + 1], lcy[u], lcy[u + 1]);
            if VEL && AFF {
                // APIC: the PIC velocity and the affine matrix, from the
                // updated grid velocity (lanes 0, 1).
                vx[p] = svx;
                vy[p] = svy;
                let (gx, gy) = (lcx, lcy);
                let (c_xx, c_yx, c_xy, c_yy) = if aff_moments {
                    // D_p per axis: the second moments of the weights (in
                    // cells², >= l²/3 for the GIMP weights, l > 0).
                    let (mut dxx, mut dyy) = (0.0, 0.0);
                    for a in 0..3 {
                        dxx += w.wx(a) * w.dx(a) * w.dx(a);
                        dyy += w.wy(a) * w.dy(a) * w.dy(a);
                    }
                    let (bx, by) = (bcx.to_array(), bcy.to_array());
                    let (ix, iy) = (inv_h / dxx, inv_h / dyy);
                    (bx[0] * ix, bx[1] * ix, by[0] * iy, by[1] * iy)
                } else {
                    (gx[0] * inv_h, gx[1] * inv_h, gy[0] * inv_h, gy[1] * inv_h)
                };
                cxx[p] = c_xx;
                cxy[p] = c_xy;
                cyx[p] = c_yx;
                cyy[p] = c_yy;
            } else if VEL {
                vx[p] = flip * (vx[p] + (svx - s0x)) + (1.0 - flip) * svx;
                vy[p] = flip * (vy[p] + (svy - s0y)) + (1.0 - flip) * svy;
            }
            let mp = &mats[material[p] as usize];
            if STRAIN {
                let mut l = Tensor2 {
                    xx: lxx * inv_h,
                    xy: lxy * inv_h,
                    yx: lyx * inv_h,
                    yy: lyy * inv_h,
                };
                if smooth && M::nodal_dilatation(mp) {
                    // The trace of L becomes the interpolated nodal mean
                    // dilatation; the deviatoric part stays the particle's.
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
                    let c = 0.5 * (dbar - (l.xx + l.yy));
                    l.xx += c;
                    l.yy += c;
                }
                let f = Tensor2 {
                    xx: fxx[p],
                    xy: fxy[p],
                    yx: fyx[p],
                    yy: fyy[p],
                };
                let fnew = if AFF {
                    // The APIC mode's objective update (see
                    // `super::Transfer`): F ← (I − dt/2 L)^{-1} (I + dt/2 L) F,
                    // orthogonal for a skew L.
                    let k = 0.5 * dt;
                    let (a, b, c, d) = (1.0 - k * l.xx, k * l.xy, k * l.yx, 1.0 - k * l.yy);
                    let inv = 1.0 / (a * d - b * c);
                    // (I − kL)^{-1} = [[d, b], [c, a]] / det; times (I + kL).
                    let (pxx, pxy, pyx, pyy) = (1.0 + k * l.xx, b, c, 1.0 + k * l.yy);
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
                        xx: f.xx + dt * (l.xx * f.xx + l.xy * f.yx),
                        xy: f.xy + dt * (l.xx * f.xy + l.xy * f.yy),
                        yx: f.yx + dt * (l.yx * f.xx + l.yy * f.yx),
                        yy: f.yy + dt * (l.yx * f.xy + l.yy * f.yy),
                    }
                };
                // The strain increment |D| dt (squared; NaN is left to the
                // finiteness check).
                let dxy = 0.5 * (l.xy + l.yx);
                let inc2 = dt * dt * (l.xx * l.xx + l.yy * l.yy + 2.0 * dxy * dxy);
                // The midpoint update of the APIC mode turns singular (and
                // inverts F) only at increments of order 2, far beyond the
                // bound: such a particle is reported as the runaway it is.
                let runaway = AFF && inc2 > MAX_INC2;
                if (fnew.det().is_nan() || fnew.det() <= 0.0) && !runaway {
                    note_first(&mut st.first_inverted, p);
                }
                if inc2 > MAX_INC2 && st.first_runaway.is_none() {
                    st.first_runaway = Some((p, inc2.sqrt()));
                }
                // A law with the stress from F alone is evaluated for the
                // whole block after this loop.
                if !M::FROM_F {
                    let s = Stress {
                        xx: sxx[p],
                        yy: syy[p],
                        xy: sxy[p],
                        zz: szz[p],
                    };
                    let mut scratch = 0.0;
                    let state = if M::HAS_STATE {
                        &mut eps_p[p]
                    } else {
                        &mut scratch
                    };
                    let s = M::update(mp, s, &l, dt, &fnew, state);
                    sxx[p] = s.xx;
                    syy[p] = s.yy;
                    sxy[p] = s.xy;
                    szz[p] = s.zz;
                }
                fxx[p] = fnew.xx;
                fxy[p] = fnew.xy;
                fyx[p] = fnew.yx;
                fyy[p] = fnew.yy;
            }
            if M::FROM_F {
                hb.ok[l] = true;
                hb.mat[0][l] = mp.lambda;
                hb.mat[1][l] = mp.mu;
                hb.mat[2][l] = mp.rho0;
                hb.f[0][l] = fxx[p];
                hb.f[1][l] = fxy[p];
                hb.f[2][l] = fyx[p];
                hb.f[3][l] = fyy[p];
            }
            if POS {
                let j = fxx[p] * fyy[p] - fxy[p] * fyx[p];
                // cpGIMP: a pass that also updates F moves the particle
                // with the velocity field F was updated from (MUSL: the
                // re-mapped `v0`), so that the particle's centre and its
                // domain `x ± F lp0` move together (see the pass's notes).
                let (pvx, pvy) = if cp && STRAIN && !VEL {
                    (s0x, s0y)
                } else {
                    (svx, svy)
                };
                let xn = x[p] + dt * pvx;
                let yn = y[p] + dt * pvy;
                x[p] = xn;
                y[p] = yn;
                if cp {
                    let (lx, ly) =
                        cpgimp_half_lengths(lpx0[p], lpy0[p], [fxx[p], fxy[p], fyx[p], fyy[p]], h);
                    lpx[p] = lx;
                    lpy[p] = ly;
                }
                let (vxp, vyp) = (vx[p], vy[p]);
                if M::FROM_F {
                    hb.v2[l] = vxp * vxp + vyp * vyp;
                    hb.acc[l] = xn + yn + vxp + vyp;
                    if AFF {
                        // The affine matrix joins the finiteness check.
                        hb.acc[l] += cxx[p] + cxy[p] + cyx[p] + cyy[p];
                    }
                    if !STRAIN {
                        // The stress is not updated by this pass.
                        hb.acc[l] += sxx[p] + syy[p] + sxy[p] + szz[p];
                    }
                } else {
                    let speed = M::wave_speed(mp, j) + (vxp * vxp + vyp * vyp).sqrt();
                    max_speed = max_speed.max(speed);
                    acc += xn + yn + vxp + vyp + j + sxx[p] + syy[p] + sxy[p] + szz[p];
                    if AFF {
                        acc += cxx[p] + cxy[p] + cyx[p] + cyy[p];
                    }
                }
                let xi = (xn - ox) * inv_h;
                let yi = (yn - oy) * inv_h;
                if !(xi >= range[0].0 && xi < range[0].1 && yi >= range[1].0 && yi < range[1].1) {
                    note_first(&mut st.first_outside, p);
                }
                if !(xi >= home[0].0 && xi < home[0].1 && yi >= home[1].0 && yi < home[1].1) {
                    note_leaving(&mut st.leaving, p);
                }
            }
        }
        if M::FROM_F && (STRAIN || POS) {
            // The stress and wave speed of the block, from F alone, lane by
            // lane (vector instructions across the particles).
            let pad = mats[material[s] as usize];
            for l in 0..LANES {
                let mp = MatParams {
                    lambda: hb.mat[0][l],
                    mu: hb.mat[1][l],
                    rho0: hb.mat[2][l],
                    ..pad
                };
                let f = Tensor2 {
                    xx: hb.f[0][l],
                    xy: hb.f[1][l],
                    yx: hb.f[2][l],
                    yy: hb.f[3][l],
                };
                let mut sum = 0.0;
                if STRAIN {
                    let sg = M::update(&mp, Stress::default(), &f, dt, &f, &mut 0.0);
                    hb.sig[0][l] = sg.xx;
                    hb.sig[1][l] = sg.yy;
                    hb.sig[2][l] = sg.xy;
                    hb.sig[3][l] = sg.zz;
                    sum = sg.xx + sg.yy + sg.xy + sg.zz;
                }
                if POS {
                    let j = f.xx * f.yy - f.xy * f.yx;
                    let speed = M::wave_speed(&mp, j) + hb.v2[l].sqrt();
                    // Lanes without a particle count for nothing.
                    let ok = hb.ok[l];
                    lane_max[l] = lane_max[l].max(if ok { speed } else { 0.0 });
                    lane_acc[l] += if ok { hb.acc[l] + j + sum } else { 0.0 };
                }
            }
            for l in 0..e - s {
                if !hb.ok[l] {
                    continue;
                }
                let p = s + l;
                if STRAIN {
                    sxx[p] = hb.sig[0][l];
                    syy[p] = hb.sig[1][l];
                    sxy[p] = hb.sig[2][l];
                    szz[p] = hb.sig[3][l];
                }
            }
        }
        if !scatter {
            s = e;
            continue;
        }
        // The scatter of the updated particles, in particle order, with the
        // weights at their new positions when the pass moved them.
        let blk1 = if POS {
            blk_new.eval_into_aff::<S, AFF>(&geo, &x[s..e], &y[s..e], &lpx[s..e], &lpy[s..e]);
            &blk_new
        } else {
            &blk
        };
        for l in 0..e - s {
            let p = s + l;
            if !blk.ok[l] {
                continue;
            }
            if !blk1.ok[l] {
                note_first(&mut st.first_outside, p);
                continue;
            }
            let m = mass[p];
            let c = if FORCE {
                let j = fxx[p] * fyy[p] - fxy[p] * fyx[p];
                let fe = external_force(m, sl.gravity, sl.body, p);
                Contribution::new::<MOM, true>(
                    m,
                    vx[p],
                    vy[p],
                    j,
                    vol0[p],
                    inv_h,
                    (sxx[p], sxy[p], syy[p]),
                    fe,
                )
            } else {
                Contribution::new::<MOM, false>(
                    m,
                    vx[p],
                    vy[p],
                    0.0,
                    0.0,
                    0.0,
                    (0.0, 0.0, 0.0),
                    (0.0, 0.0),
                )
            };
            let c = if AFF && MOM {
                c.with_affine((cxx[p], cxy[p], cyx[p], cyy[p]), h)
            } else {
                c
            };
            // SAFETY: the lane's stencil is from `Block::eval` (`ok`); the
            // sinks hold all nodes (checked before the loop).
            unsafe { sc.add::<MASS, MOM, FORCE, AFF>(&blk1.lane(l), &c, nx, &mut sinks) };
            if FORCE && load_faces[p] != 0.0 {
                let f = FaceLoads {
                    x: x[p],
                    y: y[p],
                    lpx: lpx[p],
                    lpy: lpy[p],
                    code: load_faces[p],
                    fext: (fext_x[p], fext_y[p]),
                    fside: (fside_x[p], fside_y[p]),
                    f: [fxx[p], fxy[p], fyx[p], fyy[p]],
                    lp0: [lpx0[p], lpy0[p]],
                };
                face_loads(&mut sc, &blk1.lane(l), &geo, &f, sl.load_factor);
            }
        }
        s = e;
    }
    if scatter {
        // SAFETY: as above.
        unsafe { sc.finish::<MASS, MOM, FORCE>(nx, &mut sinks) };
    }
    if POS {
        max_speed = lane_max.iter().fold(max_speed, |a, &b| a.max(b));
        acc += lane_acc.iter().sum::<f64>();
        st.dt_cfl1 = if np == 0 {
            f64::INFINITY
        } else {
            h / max_speed
        };
        if !acc.is_finite() {
            st.first_nonfinite = Some(first_nonfinite(parts).unwrap_or(0));
        }
    }
    st
}

/// A block's lanes for a law whose stress follows from F alone
/// ([`Constitutive::FROM_F`]): filled per particle, then the stress and wave
/// speed evaluated for all lanes at once.
// Cache-line aligned: see `Block`.
#[repr(align(64))]
struct HyperBlock {
    /// The lane's particle was updated.
    ok: [bool; LANES],
    /// λ, μ, ρ0.
    mat: [[f64; LANES]; 3],
    /// F (xx, xy, yx, yy) after the update.
    f: [[f64; LANES]; 4],
    /// New stress (xx, yy, xy, zz).
    sig: [[f64; LANES]; 4],
    /// `|v|²`.
    v2: [f64; LANES],
    /// Sum of the updated values (finiteness check).
    acc: [f64; LANES],
}

impl HyperBlock {
    #[inline(always)]
    fn new() -> HyperBlock {
        HyperBlock {
            ok: [false; LANES],
            mat: [[0.0; LANES]; 3],
            f: [[0.0; LANES]; 4],
            sig: [[0.0; LANES]; 4],
            v2: [0.0; LANES],
            acc: [0.0; LANES],
        }
    }
}

/// Widens `range` to hold particle `p`.
#[inline(always)]
fn note_leaving(range: &mut Option<(usize, usize)>, p: usize) {
    *range = Some(range.map_or((p, p), |(a, b)| (a.min(p), b.max(p))));
}

/// Records `p` in `first` unless a smaller index is there already.
#[inline(always)]
pub(crate) fn note_first(first: &mut Option<usize>, p: usize) {
    *first = Some(first.map_or(p, |q| q.min(p)));
}

/// First particle with a non-finite position, velocity, F, stress or
/// affine matrix.
pub(crate) fn first_nonfinite(p: &Particles) -> Option<usize> {
    (0..p.len()).find(|&i| {
        ![
            p.x[i], p.y[i], p.vx[i], p.vy[i], p.fxx[i], p.fxy[i], p.fyx[i], p.fyy[i], p.sxx[i],
            p.syy[i], p.sxy[i], p.szz[i], p.cxx[i], p.cxy[i], p.cyx[i], p.cyy[i],
        ]
        .iter()
        .all(|v| v.is_finite())
    })
}
