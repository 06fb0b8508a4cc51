//! One patch that owns every node it touches (the single-patch reference
//! solver): the checked entry points of its step, [`step_patch`] and
//! [`one_patch_result`], over the one step of [`step_patches`] on
//! [`OnePatch`].

use super::{
    step_patches, xpic, BodyForce, Grid, OnePatch, PassStats, PatchMut, PhaseTimes, Pipeline,
    StepParams, Transfer,
};
use crate::error::{Error, Result};
use crate::material::MatParams;
use crate::particles::Particles;

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
