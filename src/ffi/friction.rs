//! Coulomb friction at the indenters and their sideways motion: the
//! coefficient, the lateral tip history, the tangential side of the
//! contact query and the friction statistics (see `contact::friction` for
//! the solve).

use super::agree::{collective, Args};
use super::{check_len, fill_buffer, nonnull, slice, with_sim, GimletSim};
use crate::error::{Error, Result};
use crate::sim::Simulation;
use std::os::raw::c_int;

/// The indenter `indenter` of `s`, or an error naming the bound.
fn indenter_ref(s: &Simulation, indenter: c_int) -> Result<&crate::contact::Indenter> {
    let ni = s.contact.indenters.len();
    s.contact
        .indenters
        .get(indenter as usize)
        .filter(|_| indenter >= 0)
        .ok_or_else(|| {
            Error::arg(format!(
                "indenter = {indenter} must be in [0, {ni}) (the indenters added so far)"
            ))
        })
}

/// Sets the Coulomb friction coefficient of indenter `indenter`: `mu >= 0`
/// and finite, or `INFINITY` for stick only (full adhesion wherever a
/// particle carries a pressure; no tangential traction where a particle
/// that is not stuck has none; a stuck particle keeps sticking while it
/// still touches the indenter after its pressure has gone to zero, the
/// limit of a large `mu`, so on an inclined face the indenter can feel a
/// small pull while it is withdrawn).
/// 0 (the default) is frictionless, bit for bit as without this call.
/// With friction, each contact solve finds the pressures and the
/// tangential tractions together (`|t| <= mu p`, stick or slip), repeated
/// with the bounds `mu p` of the last pressures until they agree
/// (`GIMLET_CONTACT_FRICTION_TOL`, `GIMLET_CONTACT_FRICTION_MAX_ITER`).
/// Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_indenter_friction(
    sim: *mut GimletSim,
    indenter: c_int,
    mu: f64,
) -> c_int {
    collective(
        "gimlet_set_indenter_friction",
        sim,
        Args::new().with("indenter", &indenter).with("mu", &mu),
        |s| {
            // Checked on a copy, so a bad value is rejected on every rank.
            indenter_ref(s, indenter)?.clone().set_friction(mu)
        },
        |s, ()| s.contact.indenter_mut(indenter as i64)?.set_friction(mu),
    )
}

/// Prescribes the sideways motion of indenter `indenter`: the tip's x
/// displacement from its placement (m, `+x`) at `n >= 1` strictly
/// increasing `times` (the first `>= 0`), linear in between, held constant
/// before the first and after the last time; `n = 0` removes it. Independent
/// of `gimlet_set_indenter_motion` (the vertical depth): the tip is at
/// `(x_tip + x(t), y_tip − depth(t))`. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_indenter_lateral(
    sim: *mut GimletSim,
    indenter: c_int,
    n: i64,
    times: *const f64,
    x: *const f64,
) -> c_int {
    let (t, v): (&[f64], &[f64]) = match check_len(n, "n", 1 << 24) {
        Ok(k) => (
            slice(times, k, "times").unwrap_or(&[]),
            slice(x, k, "x").unwrap_or(&[]),
        ),
        Err(_) => (&[], &[]),
    };
    collective(
        "gimlet_set_indenter_lateral",
        sim,
        Args::new()
            .with("indenter", &indenter)
            .with("n", &n)
            .with("times", t)
            .with("x", v),
        |s| {
            let n = check_len(n, "n", 1 << 24)?;
            let t = slice(times, n, "times")?.to_vec();
            let v = slice(x, n, "x")?.to_vec();
            indenter_ref(s, indenter)?.clone().set_lateral(&t, &v)?;
            s.check_indenter_axis(0.0, !t.is_empty())?;
            Ok((t, v))
        },
        |s, (t, v)| s.contact.indenter_mut(indenter as i64)?.set_lateral(&t, &v),
    )
}

/// The tangential side of the contact, for the same particles in the same
/// order as `gimlet_get_contacts(sim, indenter, ...)`: `traction` the
/// tangential traction on the body along the tangent `t = (−n_y, n_x)`
/// (`n` the contact normal; under a flat indenter `n = (0, −1)` and
/// `t = (1, 0)`), Pa, recovered from the nodal forces like the pressure
/// (its force per metre of thickness is `traction × length`; per radian
/// in axisymmetry); `slip` the
/// contact face's tangential displacement relative to the indenter during
/// its level's last step, along `t` (m); `stick` 1 where the surface
/// sticks at the particle (the solve holds its traction strictly inside
/// `mu × pressure`; with `mu = INFINITY` wherever it carries pressure), 0
/// where it slips (the traction at the bound) or the indenter is
/// frictionless. Coulomb's bound acts on each particle's own pressure
/// multiplier; with two particles per cell one of a pair may carry its
/// cell's load alone, and the other reports the state of its nearest
/// loaded neighbour (its slip differs from that one's only by their face
/// weights on the nodes they share). Any array may be NULL (all NULL: the
/// count only); each non-NULL one has room for `capacity` particles.
/// Local: every rank gets the same complete list.
#[no_mangle]
pub unsafe extern "C" fn gimlet_get_contact_friction(
    sim: *mut GimletSim,
    indenter: c_int,
    capacity: i64,
    count: *mut i64,
    traction: *mut f64,
    slip: *mut f64,
    stick: *mut c_int,
) -> c_int {
    with_sim("gimlet_get_contact_friction", sim, |s| {
        nonnull(count, "count")?;
        let pts = super::contact::owned_points(s, indenter)?;
        let marker: Vec<u8> = vec![0; pts.len()];
        if traction.is_null() && slip.is_null() && stick.is_null() {
            return fill_buffer(&marker, 1, std::ptr::null_mut(), capacity, count, "arrays");
        }
        if capacity < pts.len() as i64 {
            let mut dummy = 0u8;
            return fill_buffer(&marker, 1, &mut dummy, capacity, count, "the arrays");
        }
        for (k, p) in pts.iter().enumerate() {
            if !traction.is_null() {
                *traction.add(k) = p.traction;
            }
            if !slip.is_null() {
                *slip.add(k) = p.slip;
            }
            if !stick.is_null() {
                *stick.add(k) = p.stick as c_int;
            }
        }
        *count = pts.len() as i64;
        Ok(())
    })
}

/// The energy dissipated by friction at indenter `indenter` since the
/// simulation was created, per metre of thickness (J/m; in axisymmetry the
/// whole body's, J): the sum over level
/// steps and the contact particles their level owns (not the copies that
/// couple levels) of `|traction| × |slip| × length`
/// (the solve's tractions and end-of-step slips). And what the frictional
/// solves did: `counts[0]` contact solves with friction,
/// `counts[1]` friction-bound iterations summed over them,
/// `counts[2]` the most iterations of one solve. Either output may be
/// NULL. Local, and the same on every rank: every rank holds every contact
/// record of a level step, so the dissipation is the whole body's (do not
/// sum it over ranks).
#[no_mangle]
pub unsafe extern "C" fn gimlet_friction_stats(
    sim: *mut GimletSim,
    indenter: c_int,
    dissipation: *mut f64,
    counts: *mut i64,
) -> c_int {
    with_sim("gimlet_friction_stats", sim, |s| {
        indenter_ref(s, indenter)?;
        if !dissipation.is_null() {
            *dissipation = s.whole_body() * s.contact.dissipation(indenter as usize);
        }
        if !counts.is_null() {
            let st = s.contact.stats();
            for (k, v) in [
                st.friction_solves,
                st.friction_iterations,
                st.friction_iterations_max,
            ]
            .iter()
            .enumerate()
            {
                *counts.add(k) = *v as i64;
            }
        }
        Ok(())
    })
}
