//! The nodal average of the dilatation of the particles whose law flows at
//! constant volume ([`Constitutive::nodal_dilatation`]): each such particle
//! scatters `S_ip V_p div_p` and `S_ip V_p` to its nodes (`div_p` the
//! divergence of the grid velocity the strain pass differentiates, `V_p =
//! J_p V0_p`); after the sums over patches the node holds the
//! volume-weighted mean `d_i` of the dilatation around it, and the strain
//! pass gives such a particle the trace `Σ_i S_ip d_i` instead of its own.
//! Nodes near a free surface average only the particles that are there, so
//! partly filled nodes need no special case.

// Lane loops index several arrays by the lane on purpose.
#![allow(clippy::needless_range_loop)]

use super::block::{Block, LANES};
use super::dispatch::uniform_law;
use super::geo::Geo;
use super::grid::Node4;
use super::{Grid, StepParams};
use crate::error::Result;
use crate::material::{AnyLaw, Constitutive, J2Law, MatKind, MatParams};
use crate::mode::ModeKind;
use crate::particles::Particles;
use crate::shape::{Axi, GimpShape, MpmShape, Shape1D, ShapeKind};

/// Adds `[S_ip V_p div_p, S_ip V_p]` of every particle whose material takes
/// the nodal dilatation to `dil` (one entry per node of the grid `geo`
/// describes). The divergence is of the velocity lanes `[v0x, v0y]` of
/// `vel` when `from_v0`, else `[vx, vy]`, as in the strain pass. Particles
/// whose stencil is off the grid are skipped (the pass that follows reports
/// them).
fn scatter_dilatation<S: Shape1D, M: Constitutive>(
    vel: &[Node4],
    dil: &mut [[f64; 2]],
    geo: &Geo,
    from_v0: bool,
    parts: &Particles,
    mats: &[MatParams],
) {
    if !M::NODAL_DILATATION {
        return;
    }
    let nn = geo.nodes();
    assert!(
        vel.len() == nn && dil.len() == nn,
        "grid velocity and dilatation arrays must hold n[0] * n[1] nodes"
    );
    let np = parts.len();
    let u = if from_v0 { 2 } else { 0 };
    let nx = geo.nx;
    let inv_h = geo.inv_h;
    let (x, y, lpx, lpy) = (
        &parts.x[..np],
        &parts.y[..np],
        &parts.lpx[..np],
        &parts.lpy[..np],
    );
    let (vol0, material) = (&parts.vol0[..np], &parts.material[..np]);
    let (fxx, fxy, fyx, fyy) = (
        &parts.fxx[..np],
        &parts.fxy[..np],
        &parts.fyx[..np],
        &parts.fyy[..np],
    );
    let mut blk = Block::new();
    let mut s = 0;
    while s < np {
        let e = (s + LANES).min(np);
        blk.eval_into::<S>(geo, &x[s..e], &y[s..e], &lpx[s..e], &lpy[s..e]);
        for l in 0..e - s {
            let p = s + l;
            if !blk.ok[l] || !M::nodal_dilatation(&mats[material[p] as usize]) {
                continue;
            }
            let w = blk.lane(l);
            let k0 = w.k0();
            let mut div = 0.0;
            for b in 0..3 {
                for a in 0..3 {
                    let v = vel[k0 + a + b * nx].0;
                    div += v[u] * w.gx(a) * w.wy(b) + v[u + 1] * w.wx(a) * w.gy(b);
                    if S::AXI {
                        // The hoop rate v_r/r.
                        div += v[u] * w.tx(a) * w.wy(b);
                    }
                }
            }
            let j = fxx[p] * fyy[p] - fxy[p] * fyx[p];
            let j = if S::AXI { j * parts.fzz[p] } else { j };
            let vp = j * vol0[p];
            let vd = vp * div * inv_h;
            for b in 0..3 {
                for a in 0..3 {
                    let sw = w.wx(a) * w.wy(b);
                    let d = &mut dil[k0 + a + b * nx];
                    d[0] += sw * vd;
                    d[1] += sw * vp;
                }
            }
        }
        s = e;
    }
}

/// Turns the summed `[Σ S V div, Σ S V]` of every node into `[mean, Σ S V]`
/// (mean 0 where no particle contributed).
fn normalise_sums(dil: &mut [[f64; 2]]) {
    for d in dil {
        d[0] = if d[1] > 0.0 { d[0] / d[1] } else { 0.0 };
    }
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
    let geo = Geo::of(grid);
    let Grid { vel, dil, .. } = grid;
    macro_rules! go {
        ($s:ty, $m:ty) => {
            scatter_dilatation::<$s, $m>(vel, dil, &geo, from_v0, parts, mats)
        };
    }
    let axi = prm.mode == ModeKind::Axisymmetric;
    match (prm.shape, axi, uniform_law(mats)) {
        (_, _, Some(MatKind::LinearElastic | MatKind::NeoHookean)) => {}
        (ShapeKind::Mpm, false, Some(MatKind::J2)) => go!(MpmShape, J2Law),
        (ShapeKind::Mpm, false, None) => go!(MpmShape, AnyLaw),
        (_, false, Some(MatKind::J2)) => go!(GimpShape, J2Law),
        (_, false, None) => go!(GimpShape, AnyLaw),
        (ShapeKind::Mpm, true, Some(MatKind::J2)) => go!(Axi<MpmShape>, J2Law),
        (ShapeKind::Mpm, true, None) => go!(Axi<MpmShape>, AnyLaw),
        (_, true, Some(MatKind::J2)) => go!(Axi<GimpShape>, J2Law),
        (_, true, None) => go!(Axi<GimpShape>, AnyLaw),
    }
    Ok(())
}

/// Turns the grid's summed dilatation into the nodal means the strain pass
/// reads (after the sums over patches).
pub fn normalise_dilatation(grid: &mut Grid) {
    normalise_sums(&mut grid.dil);
}
