//! The particle passes' front doors: P2G ([`p2g`]), G2P ([`g2p`],
//! [`g2p_except`]) and a G2P pass fused with the P2G that follows it
//! ([`g2p_p2g`]), with the grid resets between mappings. Each shapes its
//! arguments into what the loops read and hands on to the dispatch
//! ([`super::dispatch`]), which picks the compiled loop.

use super::dispatch::{g2p_any, p2g_any, NO_SCATTER};
use super::g2p::{G2pCtx, ScatterLoads, Vel};
use super::geo::Geo;
use super::p2g::Sinks;
use super::{grid, BodyForce, Grid, PassStats, StepParams};
use crate::error::{Error, Result};
use crate::material::MatParams;
use crate::particles::Particles;

/// P2G phase. `mass`, `momentum`, `force` select what is scattered (see the
/// module table); the accumulators are added to, not reset.
pub fn p2g(
    grid: &mut Grid,
    parts: &Particles,
    prm: &StepParams,
    body: Option<BodyForce>,
    what: (bool, bool, bool),
) -> Result<()> {
    p2g_any(grid, parts, prm, body, what)
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
/// pass's `LANES` consecutive slots, from slot 0) whose copy flags
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
    let ctx = G2pCtx {
        vel: Vel {
            v: &grid.vel,
            dil: &grid.dil,
        },
        geo: Geo::of(grid),
        h: grid.h,
        mats,
        prm,
        loads: ScatterLoads {
            load_factor: 0.0,
            gravity: [0.0, 0.0],
            body: None,
        },
        skip,
    };
    let sinks = Sinks {
        m: &mut [],
        mf: &mut [],
    };
    g2p_any(ctx, sinks, parts, pass, NO_SCATTER)
}

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

/// A P2G scatter that follows a G2P pass (see [`g2p_p2g`]).
#[derive(Clone, Copy, Debug)]
pub struct Mapping<'a> {
    /// Mass, momentum, force: what is scattered, as in [`p2g`].
    pub what: (bool, bool, bool),
    /// Factor on the particles' reference external forces.
    pub load_factor: f64,
    /// Per-particle body force.
    pub body: Option<BodyForce<'a>>,
}

/// A G2P pass followed by the P2G scatter `map` of the updated particles
/// into the grid's accumulators, which are added to, not reset. For the
/// pairs [`fusable`] accepts, both run in one loop over the particles
/// (reading each particle once, and evaluating its weights once unless the
/// pass moves it); the result is bit for bit that of [`g2p`] followed by
/// [`p2g`], which is what runs for any other pair. A particle whose new
/// stencil is off the grid is not scattered and is reported in
/// `first_outside`.
pub fn g2p_p2g(
    grid: &mut Grid,
    parts: &mut Particles,
    mats: &[MatParams],
    prm: &StepParams,
    pass: G2pPass,
    map: Mapping,
) -> Result<PassStats> {
    let Mapping {
        what,
        load_factor,
        body,
    } = map;
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
    let geo = Geo::of(grid);
    let h = grid.h;
    let Grid {
        mass,
        mom_force,
        vel,
        dil,
        ..
    } = grid;
    let ctx = G2pCtx {
        vel: Vel { v: vel, dil },
        geo,
        h,
        mats,
        prm,
        loads: ScatterLoads {
            load_factor,
            gravity: prm.gravity,
            body,
        },
        skip: None,
    };
    let sinks = Sinks {
        m: mass,
        mf: mom_force,
    };
    Ok(g2p_any(ctx, sinks, parts, pass, what))
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
