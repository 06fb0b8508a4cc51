//! The XPIC(m) particle velocity update (extended particle-in-cell of order
//! `m`; Hammerquist & Nairn, CMAME 2017), [`super::Transfer::Xpic`].
//!
//! With `S` the grid-to-particle interpolation (`v_p = Σ_i S_ip v_i`) and
//! `S⁺` the mass-weighted particle-to-grid map (`v_i = Σ_p m_p S_ip v_p /
//! m_i`), PIC replaces the particle's old velocity by `A v_p` with `A = S
//! S⁺` before adding the grid's velocity change; FLIP keeps `v_p`, including
//! the part of it in the null space of `S⁺`, which the grid never sees and
//! nothing damps. XPIC(m) replaces `v_p` by `(I − (I − A)^m) v_p`: order 1
//! is PIC, and as `m` grows the filter approaches the orthogonal removal of
//! that null-space part alone, damping the grid-resolved modes far less
//! than PIC. With `B = S⁺ S` (grid to particles and back),
//! `(I − (I − A)^m) v_p = S v*` with the grid velocity
//!
//! ```text
//! v* = Σ_{j=0}^{m−1} (I − B)^j v0,     v0 = S⁺ v_p (the step's first P2G),
//! ```
//!
//! computed here term by term (`r_0 = v0`, `r_{j+1} = r_j − B r_j`): every
//! term is bounded by the one before (the eigenvalues of `B` lie in `[0,
//! 1]`), so there is none of the cancellation of the binomial form `Σ_k
//! (−1)^{k+1} C(m, k) B^{k−1} v0`. Each `B` is a particle pass (interpolate
//! `r_j`, scatter `m_p` times it as momentum) and a sum over the nodes that
//! patches share ([`super::step::Fields::Momentum`], as MUSL's re-map), then
//! a division by the nodal mass with the boundary conditions applied to
//! the new term. The particle update is then, with the FLIP fraction `β`
//! ([`super::StepParams::flip`]),
//!
//! ```text
//! v_p ← β v_p + (1 − β) S v* + S (v − v0)
//! ```
//!
//! (`β = 0`: pure XPIC(m); `m = 1`: the FLIP/PIC blend). [`xpic_finish`]
//! stores `d = v0 − (1 − β) v*` in the grid's `v0` lanes, so that the
//! velocity pass computes `β v_p + S v − S d` from the same four lanes it
//! reads anyway.
//!
//! Only the particle velocity changes: positions, and the velocity
//! gradient of USL, read the updated lumped grid velocity `v` as under
//! FLIP (and MUSL re-maps the new particle momenta as usual). Reading `v* +
//! (v − v0)` there instead (the grid field the XPIC particle velocities
//! interpolate) was measured and not kept, being no better: the uGIMP bar
//! of `test_hard` (MUSL, order 5) held 10 % with either and tore at 20 %
//! with it (with `v` the end stayed within 1.3 h), and the vibrating block
//! lost 79 % of its energy in 1000 steps at order 16 (81 % with `v`); see
//! `docs/method.md`, "The default scheme and why".

// Lane loops index several arrays by the lane on purpose.
#![allow(clippy::needless_range_loop)]

use super::bc::{constrained_nodes, inv_mass};
use super::block::{Block, LANES};
use super::dispatch::with_shape;
use super::geo::Geo;
use super::grid::{mf, vl, Node4};
use super::isa::multiversion;
use super::p2g::{outside_error, Contribution, Scatter, Sinks};
use super::simd::{Simd4, F4};
use super::{reset_momentum, Grid, PatchBoundary};
use crate::error::Result;
use crate::mode::ModeKind;
use crate::particles::Particles;
use crate::shape::{Shape1D, ShapeKind};

/// The largest XPIC order accepted: each order costs a particle pass and a
/// sum over shared nodes per step, and Nairn reports orders above about 40
/// unstable; order 16 already removes the null-space part of all but the
/// slowest-decaying grid modes.
pub const MAX_XPIC_ORDER: u32 = 16;

/// `order` as an XPIC order if it lies in `[1, MAX_XPIC_ORDER]`, else an
/// argument error naming the bound.
pub fn xpic_order(order: i64) -> Result<u32> {
    u32::try_from(order)
        .ok()
        .filter(|m| (1..=MAX_XPIC_ORDER).contains(m))
        .ok_or_else(|| {
            crate::error::Error::arg(format!(
                "xpic order = {order} must lie in [1, {MAX_XPIC_ORDER}]"
            ))
        })
}

/// Starts the series on a grid whose `v0` lanes hold the step's first
/// velocities: allocates the work space if needed and sets `r_0 = s = v0`.
pub fn xpic_start(grid: &mut Grid) -> Result<()> {
    grid.ensure_xpic()?;
    let n = grid.len();
    let (vel, w) = (&grid.vel[..n], &mut grid.xpic[..n]);
    for k in 0..n {
        let v = vel[k].0;
        w[k] = Node4([v[vl::V0X], v[vl::V0Y], v[vl::V0X], v[vl::V0Y]]);
    }
    Ok(())
}

/// The particle pass of one application of `B`: zeroes the grid's momentum
/// and scatters `m_p S_ip (Σ_j S_jp r_j)` into it (to be summed over the
/// patches, then turned into the next term by [`xpic_next`]). A grid
/// without the work space (its allocation failed, an error the caller has
/// noted) is left as it is.
pub fn xpic_scatter(
    grid: &mut Grid,
    parts: &Particles,
    shape: ShapeKind,
    mode: ModeKind,
) -> Result<()> {
    if grid.xpic.len() != grid.len() {
        return Ok(());
    }
    reset_momentum(grid);
    with_shape!(shape, mode, S => smooth_impl::<S>(grid, parts))
}

multiversion! {
    /// The loop of [`xpic_scatter`].
    fn smooth_impl[S: Shape1D][S](grid: &mut Grid, parts: &Particles) -> Result<()> = smooth_body;
}

#[inline(always)]
fn smooth_body<I: Simd4, S: Shape1D>(grid: &mut Grid, parts: &Particles) -> Result<()> {
    let np = parts.len();
    let geo = Geo::of(grid);
    let range = [grid.mappable_range(0), grid.mappable_range(1)];
    let nn = geo.nodes();
    let Grid {
        mass,
        mom_force,
        xpic,
        ..
    } = grid;
    let r = &xpic[..];
    let mut sinks = Sinks {
        m: mass,
        mf: mom_force,
    };
    assert!(
        sinks.all_len(nn) && r.len() == nn,
        "grid arrays must hold n[0] * n[1] nodes"
    );
    let (x, y) = (&parts.x[..np], &parts.y[..np]);
    let (lpx, lpy) = (&parts.lpx[..np], &parts.lpy[..np]);
    let m = &parts.mass[..np];
    let nx = geo.nx;
    let mut sc = Scatter::<I>::new();
    let mut blk = Block::new();
    let mut s = 0;
    while s < np {
        let e = (s + LANES).min(np);
        blk.eval_into::<S>(&geo, &x[s..e], &y[s..e], &lpx[s..e], &lpy[s..e]);
        for l in 0..e - s {
            let p = s + l;
            if !blk.ok[l] {
                return Err(outside_error(parts, p, range));
            }
            let w = blk.lane(l);
            let k0 = w.k0();
            let mut u = F4::<I>::zero();
            for b in 0..3 {
                let row = k0 + b * nx;
                let mut ru = F4::<I>::zero();
                for a in 0..3 {
                    // SAFETY: row + a <= k0 + 2 nx + 2 < nx ny = r.len()
                    // for an `ok` lane (checked before the loop).
                    let v = F4::load(unsafe { &r.get_unchecked(row + a).0 });
                    ru = ru.add(F4::splat(w.wx(a)).mul(v));
                }
                u = u.add(F4::splat(w.wy(b)).mul(ru));
            }
            let [ux, uy, _, _] = u.to_array();
            let mv = (m[p] * ux, m[p] * uy);
            let c = Contribution::new::<true, false>(m[p], mv, (0.0, 0.0), (0.0, 0.0, 0.0));
            // SAFETY: an `ok` lane, and the arrays hold all nodes.
            unsafe { sc.add::<false, true, false, false>(&w, &c, nx, &mut sinks, false) };
        }
        s = e;
    }
    // SAFETY: as above.
    unsafe { sc.finish::<false, true, false>(nx, &mut sinks) };
    Ok(())
}

/// The grid pass of one application of `B`, after the momentum of
/// [`xpic_scatter`] has been summed over the patches: `r ← r − p/m` on
/// every node with mass (`r ← r` where there is none: there `B r` is zero),
/// the boundary conditions of `bnd` on the new term, and `s ← s + r`.
pub fn xpic_next(grid: &mut Grid, bnd: &PatchBoundary) {
    let n = grid.len();
    if grid.xpic.len() != n {
        return;
    }
    let (mass, mfs, w) = (&grid.mass[..n], &grid.mom_force[..n], &mut grid.xpic[..n]);
    for k in 0..n {
        if let Some(inv) = inv_mass(mass[k]) {
            let p = mfs[k].0;
            w[k].0[0] -= p[mf::PX] * inv;
            w[k].0[1] -= p[mf::PY] * inv;
        }
    }
    constrained_nodes(grid.n, grid.lo, bnd, |k, zx, zy| {
        if zx {
            w[k].0[0] = 0.0;
        }
        if zy {
            w[k].0[1] = 0.0;
        }
    });
    for k in 0..n {
        let t = &mut w[k].0;
        t[2] += t[0];
        t[3] += t[1];
    }
}

/// Ends the series: the grid's `v0` lanes become `d = v0 − (1 − flip) v*`
/// (see the module notes), which the velocity pass of the XPIC transfer
/// reads.
pub fn xpic_finish(grid: &mut Grid, flip: f64) {
    let n = grid.len();
    if grid.xpic.len() != n {
        return;
    }
    let (vel, w) = (&mut grid.vel[..n], &grid.xpic[..n]);
    let q = 1.0 - flip;
    for k in 0..n {
        let s = w[k].0;
        let v = &mut vel[k].0;
        v[vl::V0X] -= q * s[2];
        v[vl::V0Y] -= q * s[3];
    }
}
