//! Time integration settings, loads, boundary conditions and stepping.

use super::agree::{args, collective, Args};
use super::{nonnull, with_sim, GimletSim};
use crate::error::{Error, Result};
use crate::kernel::{FaceBc, Scheme, Side, Transfer};
use crate::particles::LoadKind;
use crate::shape::ShapeKind;
use crate::sim::{Outflow, RunConfig, Simulation, StepReport};
use std::os::raw::c_int;

/// Plain linear-hat MPM weights (for comparison).
pub const GIMLET_SHAPE_MPM: c_int = 0;
/// uGIMP: GIMP weights with fixed particle half-lengths (the paper's; the
/// examples' indentation scenes use it).
pub const GIMLET_SHAPE_UGIMP: c_int = 1;
/// cpGIMP (the default): axis-aligned domains whose half-lengths follow the
/// stretch of the material fibres, `lp0 |F e_x|` and `lp0 |F e_y|`.
pub const GIMLET_SHAPE_CPGIMP: c_int = 2;

/// Update stress first.
pub const GIMLET_SCHEME_USF: c_int = 0;
/// Update stress last.
pub const GIMLET_SCHEME_USL: c_int = 1;
/// Modified update stress last (the default).
pub const GIMLET_SCHEME_MUSL: c_int = 2;

/// Velocity transfer: FLIP/PIC blend by `gimlet_set_flip` (the paper's).
pub const GIMLET_TRANSFER_FLIP: c_int = 0;
/// Velocity transfer: affine particle-in-cell (APIC, the default). Each
/// particle also carries an affine matrix C (`GIMLET_FIELD_AFFINE`); linear
/// velocity fields (a rigid rotation) go between particles and grid
/// exactly, also at a body's free edge. The particle velocity is the PIC
/// interpolation plus the affine part: the FLIP fraction is ignored (kept,
/// and used again after a switch back to `GIMLET_TRANSFER_FLIP`).
pub const GIMLET_TRANSFER_APIC: c_int = 1;
/// Velocity transfer: extended particle-in-cell XPIC(m) (Hammerquist &
/// Nairn 2017) of the order `gimlet_set_xpic_order` sets (default 5). The
/// particle's old velocity is filtered by `I − (I − S S⁺)^m` (`S S⁺`: grid
/// to particles after particles to grid), which removes the particle-scale
/// (null-space) part that FLIP keeps while damping grid-resolved motion far
/// less than PIC; the FLIP fraction of `gimlet_set_flip` blends it with FLIP
/// (`flip = 0`: pure XPIC(m); order 1 is PIC). Costs `m − 1` extra particle
/// passes per step.
pub const GIMLET_TRANSFER_XPIC: c_int = 2;

/// Face index: x = xmin.
pub const GIMLET_FACE_LEFT: c_int = 0;
/// Face index: x = xmax.
pub const GIMLET_FACE_RIGHT: c_int = 1;
/// Face index: y = ymin.
pub const GIMLET_FACE_BOTTOM: c_int = 2;
/// Face index: y = ymax.
pub const GIMLET_FACE_TOP: c_int = 3;

/// Face condition: traction-free.
pub const GIMLET_BC_FREE: c_int = 0;
/// Face condition: zero velocity.
pub const GIMLET_BC_FIXED: c_int = 1;
/// Face condition: zero normal velocity (roller, symmetry plane).
pub const GIMLET_BC_ROLLER: c_int = 2;

/// Outflow policy (the default): a step in which particles would leave the
/// domain fails with `GIMLET_ERR_PARTICLES_LEFT` and is undone like any
/// failed step: the particles stay where they were, the lost list, the
/// clock and every other part of the state are as before the call (lower
/// `dt`, or switch to `GIMLET_OUTFLOW_REMOVE` to let them go). Behaviour
/// change: before steps were transactional, such a step advanced the
/// state, removed and recorded the particles, then returned the status.
pub const GIMLET_OUTFLOW_FAIL: c_int = 0;
/// Outflow policy: particles leaving the domain (from any level) are
/// removed and recorded (`gimlet_lost_particles`); the step succeeds.
pub const GIMLET_OUTFLOW_REMOVE: c_int = 1;

fn side(face: c_int) -> Result<Side> {
    Ok(match face {
        GIMLET_FACE_LEFT => Side::Left,
        GIMLET_FACE_RIGHT => Side::Right,
        GIMLET_FACE_BOTTOM => Side::Bottom,
        GIMLET_FACE_TOP => Side::Top,
        _ => {
            return Err(Error::arg(format!(
                "face = {face} must be one of GIMLET_FACE_LEFT (0), RIGHT (1), BOTTOM (2), TOP (3)"
            )))
        }
    })
}

/// A run setting: `f` changes a copy of the settings, which are checked
/// (locally), agreed with `args`, then applied. Collective.
fn set(
    sim: *mut GimletSim,
    name: &str,
    args: Args,
    f: impl FnOnce(&mut RunConfig) -> Result<()>,
) -> c_int {
    collective(
        name,
        sim,
        args,
        |s: &Simulation| {
            let mut run = s.run();
            f(&mut run)?;
            run.validate()?;
            Ok(run)
        },
        |s, run| s.set_run(run),
    )
}

/// Chooses the weight function: `GIMLET_SHAPE_MPM`, `_UGIMP` or `_CPGIMP`
/// (default; with MUSL and APIC the combination that passes every hard
/// case, see `docs/method.md`). Collective (every rank passes the same value).
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_shape(sim: *mut GimletSim, shape: c_int) -> c_int {
    set(sim, "gimlet_set_shape", args!(shape), |r| {
        r.shape = match shape {
            GIMLET_SHAPE_MPM => ShapeKind::Mpm,
            GIMLET_SHAPE_UGIMP => ShapeKind::UGimp,
            GIMLET_SHAPE_CPGIMP => ShapeKind::CpGimp,
            _ => {
                return Err(Error::arg(format!(
                    "shape = {shape} must be GIMLET_SHAPE_MPM (0), _UGIMP (1) or _CPGIMP (2)"
                )))
            }
        };
        Ok(())
    })
}

/// Chooses the update scheme: `GIMLET_SCHEME_USF`, `_USL` or `_MUSL`
/// (default). Collective (the same value on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_scheme(sim: *mut GimletSim, scheme: c_int) -> c_int {
    set(sim, "gimlet_set_scheme", args!(scheme), |r| {
        r.scheme = match scheme {
            GIMLET_SCHEME_USF => Scheme::Usf,
            GIMLET_SCHEME_USL => Scheme::Usl,
            GIMLET_SCHEME_MUSL => Scheme::Musl,
            _ => {
                return Err(Error::arg(format!(
                    "scheme = {scheme} must be GIMLET_SCHEME_USF (0), _USL (1) or _MUSL (2)"
                )))
            }
        };
        Ok(())
    })
}

/// Sets the FLIP fraction `flip` in `[0, 1]` of the particle velocity
/// update (1 = pure FLIP, the default; 0 = PIC) of `GIMLET_TRANSFER_FLIP`
/// and `_XPIC` (APIC, the default transfer, ignores it). Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_flip(sim: *mut GimletSim, flip: f64) -> c_int {
    set(sim, "gimlet_set_flip", args!(flip), |r| {
        r.flip = flip;
        Ok(())
    })
}

/// Chooses the particle–grid velocity transfer: `GIMLET_TRANSFER_FLIP`
/// (FLIP/PIC blend by `gimlet_set_flip`), `GIMLET_TRANSFER_APIC`
/// (default; affine particle-in-cell: PIC velocity plus each particle's
/// affine matrix C; the FLIP fraction is ignored while it is set) or
/// `GIMLET_TRANSFER_XPIC` (XPIC of the order `gimlet_set_xpic_order` sets,
/// blended with FLIP by `gimlet_set_flip`). The matrix is
/// particle state (it migrates, is copied between levels, checkpointed and
/// undone with a failed step); it starts at zero, or as set through
/// `GIMLET_FIELD_AFFINE`, and a switch to APIC uses it as it stands.
/// Collective (the same value on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_transfer(sim: *mut GimletSim, transfer: c_int) -> c_int {
    set(sim, "gimlet_set_transfer", args!(transfer), |r| {
        r.transfer = match transfer {
            GIMLET_TRANSFER_FLIP => Transfer::Flip,
            GIMLET_TRANSFER_APIC => Transfer::Apic,
            GIMLET_TRANSFER_XPIC => Transfer::Xpic,
            _ => {
                return Err(Error::arg(format!(
                    "transfer = {transfer} must be GIMLET_TRANSFER_FLIP (0), _APIC (1) or _XPIC (2)"
                )))
            }
        };
        Ok(())
    })
}

/// Sets the order `m` in `[1, 16]` of `GIMLET_TRANSFER_XPIC` (default 5;
/// kept, and used only while that transfer is set). Each order above 1
/// adds a particle pass and a sum over shared nodes to every step.
/// Collective (the same value on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_xpic_order(sim: *mut GimletSim, order: c_int) -> c_int {
    set(sim, "gimlet_set_xpic_order", args!(order), |r| {
        r.xpic_order = crate::kernel::xpic::xpic_order(order.into())?;
        Ok(())
    })
}

/// Sets the Courant number `cfl` in `(0, 1]` (default 0.5) of the stable
/// step `cfl · min_p h/(c_p + |v_p|)`. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_cfl(sim: *mut GimletSim, cfl: f64) -> c_int {
    set(sim, "gimlet_set_cfl", args!(cfl), |r| {
        r.cfl = cfl;
        Ok(())
    })
}

/// Sets gravity (body force per unit mass; components of magnitude at most
/// 1e30). Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_gravity(sim: *mut GimletSim, gx: f64, gy: f64) -> c_int {
    set(sim, "gimlet_set_gravity", args!(gx, gy), |r| {
        r.gravity = [gx, gy];
        Ok(())
    })
}

/// Sets the condition of one domain face (`GIMLET_FACE_*`) to
/// `GIMLET_BC_FREE`, `_FIXED` or `_ROLLER`. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_face_bc(sim: *mut GimletSim, face: c_int, bc: c_int) -> c_int {
    set(sim, "gimlet_set_face_bc", args!(face, bc), |r| {
        let s = side(face)?;
        r.bc[s as usize] = match bc {
            GIMLET_BC_FREE => FaceBc::Free,
            GIMLET_BC_FIXED => FaceBc::Fixed,
            GIMLET_BC_ROLLER => FaceBc::Roller,
            _ => {
                return Err(Error::arg(format!(
                    "bc = {bc} must be GIMLET_BC_FREE (0), _FIXED (1) or _ROLLER (2)"
                )))
            }
        };
        Ok(())
    })
}

/// Sets the load ramp: tractions grow linearly from 0 at t = 0 to full at
/// `t_ramp` and stay (`t_ramp = 0`: full from the start; at most 1e30).
/// Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_load_ramp(sim: *mut GimletSim, t_ramp: f64) -> c_int {
    set(sim, "gimlet_set_load_ramp", args!(t_ramp), |r| {
        r.ramp.t_ramp = t_ramp;
        Ok(())
    })
}

/// Sets the outflow policy (`GIMLET_OUTFLOW_FAIL` or `_REMOVE`).
/// Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_outflow(sim: *mut GimletSim, policy: c_int) -> c_int {
    set(sim, "gimlet_set_outflow", args!(policy), |r| {
        r.outflow = match policy {
            GIMLET_OUTFLOW_FAIL => Outflow::Fail,
            GIMLET_OUTFLOW_REMOVE => Outflow::Remove,
            _ => {
                return Err(Error::arg(format!(
                    "policy = {policy} must be GIMLET_OUTFLOW_FAIL (0) or _REMOVE (1)"
                )))
            }
        };
        Ok(())
    })
}

/// Puts a traction `(tx, ty)` on the particles whose face on side `face`
/// lies on the line `at` (`x = at` for left/right faces, `y = at` for
/// bottom/top) and overlaps `[lo, hi]` along it: each receives `traction ×
/// overlap length × thickness`, added to its reference external force and
/// scaled by the load ramp. The paper's pressure `p` on a top surface at
/// `y = Y` is `face = GIMLET_FACE_TOP, at = Y, (tx, ty) = (0, -p)`.
/// `*loaded` (may be NULL) receives the global number of particles loaded.
/// Every value finite with magnitude at most 1e30. Collective (the same
/// arguments on every rank).
///
/// This is a dead load: the force keeps the direction and size it was
/// given whatever the body does (a nominal traction on the reference
/// face). For a load that turns and stretches with the face (a pressure
/// on a surface that rotates, a bar pulled to large strain), see
/// `gimlet_apply_follower_traction`.
#[no_mangle]
pub unsafe extern "C" fn gimlet_apply_traction(
    sim: *mut GimletSim,
    face: c_int,
    at: f64,
    lo: f64,
    hi: f64,
    tx: f64,
    ty: f64,
    loaded: *mut i64,
) -> c_int {
    traction(
        "gimlet_apply_traction",
        sim,
        face,
        [at, lo, hi, tx, ty],
        Ok(LoadKind::Dead),
        loaded,
    )
}

/// Follower traction: per current area, direction kept (see
/// `gimlet_apply_follower_traction`).
pub const GIMLET_FOLLOW_AREA: c_int = 0;
/// Follower traction: per current area, turning with the face (see
/// `gimlet_apply_follower_traction`).
pub const GIMLET_FOLLOW_FACE: c_int = 1;

/// Puts a follower traction `(tx, ty)` on the particles that
/// `gimlet_apply_traction` would select with the same arguments (the
/// particles' faces on side `face` on the line `at`, overlapping `[lo,
/// hi]`, in the configuration at the time of the call), with the same
/// reference force `traction × overlap length × thickness` and the same
/// load ramp, but acting on the face as it deforms: `(tx, ty)` is a Cauchy
/// traction, a force per **current** area of the face.
///
/// Each loaded particle's face has reference length `dA`, outward normal
/// `N`, tangent `T` (`e_y` for a left or right face, `e_x` for a bottom or
/// top one); with the particle's deformation gradient `F` its current
/// length is `da = |F T| dA` (Nanson's `n da = J F^{-T} N dA`; the
/// plane-strain thickness does not change). `follow` says where the force
/// points:
///
/// * `GIMLET_FOLLOW_AREA`: in the fixed direction `(tx, ty)`; the force
///   is `(tx, ty) × da × thickness`.
/// * `GIMLET_FOLLOW_FACE`: its normal and tangential components stay
///   fixed relative to the face, `(tx, ty)` giving them in the reference
///   face's axes: the force is `(tx, ty) × da × thickness` turned by the
///   angle from `T` to `F T` (Nanson's `J F^{-T} N dA` times the traction
///   and the thickness). `(0, -p)` on
///   a top face is then a pressure `p` normal to the current surface.
///
/// Either way `(s, 0)` on a right face pulls a bar with Cauchy stress `s`
/// on its end while the end stays square. The force acts on the deformed
/// face, at `x + F (±lp0)` across it (where cpGIMP's domain face is;
/// clamped to the particle's stencil for uGIMP, whose domain keeps its
/// reference size), spread over the nodes with the face integral of the
/// shape functions as for a dead load. The face's turning comes from the
/// one particle's F, which carries the grid's particle-scale noise: with
/// pure FLIP the turning load can pump that noise (a follower load is not
/// conservative), so `GIMLET_FOLLOW_AREA` is the robust choice where the
/// face does not turn much (see the `bar` hard case).
///
/// A particle carries loads of one kind (dead, or follower of one
/// `follow`): a particle selected here that carries a load of another
/// kind is rejected with `GIMLET_ERR_INVALID_ARGUMENT` and nothing is
/// loaded on any rank, as for a particle loaded on the opposite face.
/// `*loaded` (may be NULL) receives the global number of particles
/// loaded. Every value finite with magnitude at most 1e30. Collective (the
/// same arguments on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_apply_follower_traction(
    sim: *mut GimletSim,
    face: c_int,
    at: f64,
    lo: f64,
    hi: f64,
    tx: f64,
    ty: f64,
    follow: c_int,
    loaded: *mut i64,
) -> c_int {
    let kind = match follow {
        GIMLET_FOLLOW_AREA => Ok(LoadKind::FollowArea),
        GIMLET_FOLLOW_FACE => Ok(LoadKind::FollowFace),
        _ => Err(follow),
    };
    traction(
        "gimlet_apply_follower_traction",
        sim,
        face,
        [at, lo, hi, tx, ty],
        kind,
        loaded,
    )
}

/// The body of the traction calls: `a` holds `at, lo, hi, tx, ty`;
/// `kind` is the load kind or the invalid `follow` value.
fn traction(
    name: &str,
    sim: *mut GimletSim,
    face: c_int,
    a: [f64; 5],
    kind: std::result::Result<LoadKind, c_int>,
    loaded: *mut i64,
) -> c_int {
    let [at, lo, hi, tx, ty] = a;
    let follow = match kind {
        Ok(LoadKind::FollowFace) => GIMLET_FOLLOW_FACE,
        Ok(_) => GIMLET_FOLLOW_AREA,
        Err(f) => f,
    };
    let dead = kind == Ok(LoadKind::Dead);
    let agreed = if dead {
        args!(face, at, lo, hi, tx, ty)
    } else {
        args!(face, at, lo, hi, tx, ty, follow)
    };
    collective(
        name,
        sim,
        agreed,
        |s| {
            let kind = kind.map_err(|f| {
                Error::arg(format!(
                    "follow = {f} must be GIMLET_FOLLOW_AREA (0) or GIMLET_FOLLOW_FACE (1)"
                ))
            })?;
            let sd = side(face)?;
            crate::diag::check_traction(at, lo, hi, [tx, ty])?;
            for (name, v) in [("at", at), ("lo", lo), ("hi", hi), ("tx", tx), ("ty", ty)] {
                crate::limits::magnitude(name, v)?;
            }
            s.check_layout()?;
            Ok((sd, kind))
        },
        |s, (sd, kind)| {
            let n = s.apply_traction_of(sd, at, lo, hi, [tx, ty], kind)?;
            if !loaded.is_null() {
                // SAFETY: callers pass NULL or a valid pointer.
                unsafe { *loaded = n as i64 };
            }
            Ok(())
        },
    )
}

/// The stable time step of the current state (CFL included; `INFINITY`
/// without particles). Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_stable_dt(sim: *mut GimletSim, dt: *mut f64) -> c_int {
    collective(
        "gimlet_stable_dt",
        sim,
        Args::new(),
        |s| {
            nonnull(dt, "dt")?;
            s.check_steppable()
        },
        |s, ()| {
            *dt = s.stable_dt()?;
            Ok(())
        },
    )
}

fn report(r: &StepReport, time: *mut f64, steps: *mut i64) {
    // SAFETY: callers pass NULL or valid pointers.
    unsafe {
        if !time.is_null() {
            *time = r.time;
        }
        if !steps.is_null() {
            *steps = r.steps as i64;
        }
    }
}

/// Advances one step of `dt` (`dt <= 0` takes the stable step; `|dt| <=
/// 1e30`, and a `dt` too small to change the time is refused). A `dt`
/// above the stable step is rejected with `GIMLET_ERR_UNSTABLE` and nothing
/// changes. Without particles the stable step is undefined: `dt <= 0` is
/// then refused with `GIMLET_ERR_INVALID_STATE` and nothing changes, while
/// `dt > 0` advances the clock. Particles that leave the domain are removed
/// and recorded, or fail the step (see `gimlet_set_outflow`). `time` and
/// `steps` (may be NULL) receive the time and step count reached.
///
/// The step is transactional: when it fails for any reason
/// (`GIMLET_ERR_UNSTABLE` for non-finite values or an inverted deformation
/// gradient, named by particle id, level and patch, or for a new state
/// whose stable step is zero or cannot advance the clock;
/// `GIMLET_ERR_PARTICLES_LEFT` under `GIMLET_OUTFLOW_FAIL`; a contact
/// solve; an internal error), every particle of every level and patch
/// (coupling copies, plastic strain and contact state included), the
/// clock, the step count and the lost list are bitwise as before the call
/// on every rank: lower `dt` and retry. (The library keeps a copy of the
/// state at most 32 steps old and replays the steps since it; any other
/// call that changes the state makes it take a fresh copy.) Collective: every rank
/// passes the same `dt`; the step's status is the same on every rank (when
/// ranks fail differently, the most severe status wins: an unstable step,
/// `GIMLET_ERR_UNSTABLE`, outranks particles that left,
/// `GIMLET_ERR_PARTICLES_LEFT`).
#[no_mangle]
pub unsafe extern "C" fn gimlet_step(
    sim: *mut GimletSim,
    dt: f64,
    time: *mut f64,
    steps: *mut i64,
) -> c_int {
    collective(
        "gimlet_step",
        sim,
        args!(dt),
        |s| s.check_dt(dt),
        |s, ()| {
            let dt = if dt <= 0.0 {
                let stable = s.stable_dt()?;
                s.check_stable_dt(stable)?;
                stable
            } else {
                dt
            };
            let r = s.step(dt)?;
            report(&r, time, steps);
            Ok(())
        },
    )
}

/// Advances to time `t_end` with stable steps (equal steps that land on
/// `t_end`), at most `max_steps` of them (without particles: one step to
/// `t_end`). `t_end` must be finite, at most 1e30 and not before the current
/// time. When `max_steps` steps do not reach `t_end`, returns
/// `GIMLET_ERR_INVALID_STATE` with the state advanced by those steps
/// (`gimlet_time` tells how far); a step that fails is undone as in
/// `gimlet_step`, the steps before it stay. Collective (the same `t_end` and
/// `max_steps` on every rank; the status agrees as for `gimlet_step`).
#[no_mangle]
pub unsafe extern "C" fn gimlet_advance_to(
    sim: *mut GimletSim,
    t_end: f64,
    max_steps: i64,
    time: *mut f64,
    steps: *mut i64,
) -> c_int {
    collective(
        "gimlet_advance_to",
        sim,
        args!(t_end, max_steps),
        |s| {
            if max_steps < 1 {
                return Err(Error::arg(format!("max_steps = {max_steps} must be >= 1")));
            }
            if !(t_end.is_finite() && t_end >= s.time()) {
                return Err(Error::arg(format!(
                    "t_end = {t_end} must be finite and >= the current time {}",
                    s.time()
                )));
            }
            crate::limits::magnitude("t_end", t_end)?;
            s.check_steppable()
        },
        |s, ()| {
            let r = s.advance_to(t_end, max_steps as u64)?;
            report(&r, time, steps);
            Ok(())
        },
    )
}

/// The current time and step count. Local; either output may be NULL.
#[no_mangle]
pub unsafe extern "C" fn gimlet_time(
    sim: *mut GimletSim,
    time: *mut f64,
    steps: *mut i64,
) -> c_int {
    with_sim("gimlet_time", sim, |s| {
        if !time.is_null() {
            *time = s.time();
        }
        if !steps.is_null() {
            *steps = s.steps() as i64;
        }
        Ok(())
    })
}
