//! Rigid indenters, their prescribed motion, and the contact-surface query.
//!
//! Conventions of every indenter: it points down (−y); `(x_tip, y_tip)`
//! is its tip at time 0 (the wedge's apex, the cylinder's lowest point, the
//! centre of the flat punch's face, the reference point of a polygon); its
//! **depth** is the downward displacement of the tip since time 0 (so the
//! tip is at `y_tip − depth(t)`), prescribed by a motion history (at rest
//! until one is set). Contact is frictionless unless a friction
//! coefficient is set (`gimlet_set_indenter_friction`, in `ffi::friction`);
//! the pressures are solved with PETSc (see `gimlet_set_petsc_options`). Indenters are numbered
//! from 0 in the order they are added; more than one may exist.

use super::agree::{args, collective, Args, Text};
use super::{check_len, fill_buffer, nonnull, slice, with_sim, GimletSim};
use crate::contact::{Motion, Shape};
use crate::error::{Error, Result};
use std::os::raw::{c_char, c_int};

/// Motion kind: the downward tip speed (m/s) at the given times, linear in
/// between, constant before the first and after the last time; the depth
/// is its exact integral from time 0.
pub const GIMLET_MOTION_VELOCITY: c_int = 0;
/// Motion kind: the depth at the given times, linear in between, constant
/// before the first and after the last time.
pub const GIMLET_MOTION_DEPTH: c_int = 1;

/// Contact option: the regularisation `ε` added to the unit diagonal of
/// the scaled contact system (default 1e-6, in `[0, 1]`).
pub const GIMLET_CONTACT_REGULARIZATION: c_int = 0;
/// Contact option: the relative tolerance of the KSP solves (default 1e-12,
/// in `(0, 1)`).
pub const GIMLET_CONTACT_KSP_RTOL: c_int = 1;
/// Contact option: systems with at most this many unknowns are solved
/// densely on every rank instead of with PETSc (an integer `>= 0`; 0 always
/// uses PETSc).
pub const GIMLET_CONTACT_DENSE_MAX: c_int = 2;
/// Contact option: the band, in cells of the particle's level, within which
/// particles that would not penetrate still enter the contact problem
/// (default 0.05, in `[0, 1]`).
pub const GIMLET_CONTACT_BAND: c_int = 3;
/// Contact option: where a contact particle's gap (its distance from the
/// indenter, kept `>= 0`) is measured: 1 (the default) the mean over its
/// contact faces, weighted as the contact pressure loads them; 0 the point
/// of its domain nearest the indenter (no point of the domain may enter the
/// indenter: a staircase of particles under an inclined flank is then
/// pushed in by up to `lx |n_x|`, and the wedge's load comes out 6 % high
/// with 3.7 particles across the contact half-width); 2 the middle of its
/// face in y. The three agree for faces parallel to the indenter's surface
/// (a flat punch on a flat surface).
pub const GIMLET_CONTACT_GAP: c_int = 4;
/// Contact option: the relative tolerance of the friction-bound iteration
/// of a frictional contact solve (each iteration solves the pressures and
/// tractions together under Coulomb bounds from the last pressures): it
/// stops when no pressure or tangential traction changes by more than this times the
/// largest pressure (default 1e-8, in `(0, 0.1]`).
pub const GIMLET_CONTACT_FRICTION_TOL: c_int = 5;
/// Contact option: the most friction-bound iterations of a frictional contact
/// solve; a solve that has not settled by then fails the step with
/// `GIMLET_ERR_UNSTABLE` (default 200, an integer in `[1, 10000]`).
pub const GIMLET_CONTACT_FRICTION_MAX_ITER: c_int = 6;

fn finite(v: f64, name: &str) -> Result<()> {
    if !v.is_finite() {
        return Err(Error::arg(format!("{name} = {v} must be finite")));
    }
    Ok(())
}

/// Adds an indenter: `shape` builds it (checked locally), the arguments
/// `args` are agreed over the ranks, then it is added. Collective.
fn add(
    sim: *mut GimletSim,
    name: &str,
    args: Args,
    id: *mut c_int,
    shape: impl FnOnce() -> Result<Shape>,
    tip: [f64; 2],
) -> c_int {
    collective(
        name,
        sim,
        args,
        |s| {
            nonnull(id, "indenter")?;
            finite(tip[0], "x_tip")?;
            finite(tip[1], "y_tip")?;
            s.check_indenter_axis(tip[0], false)?;
            let shape = shape()?;
            // Validated here, so a bad shape is rejected on every rank.
            crate::contact::Indenter::new(shape.clone(), tip)?;
            if s.contact.indenters.len() >= crate::contact::MAX_INDENTERS {
                return Err(Error::arg(format!(
                    "the indenter table is full ({} indenters)",
                    crate::contact::MAX_INDENTERS
                )));
            }
            Ok(shape)
        },
        |s, shape| {
            let k = s.contact.add_indenter(shape, tip)?;
            // SAFETY: checked non-null; the caller passes a valid int.
            unsafe { *id = k as c_int };
            Ok(())
        },
    )
}

/// Adds a rigid wedge of tip half-angle `half_angle_deg` (degrees, the
/// angle between the vertical axis and each flank, in (0, 90); 65 in the
/// paper's example, 70.3 for the Berkovich-equivalent) and height `height`
/// (> 0), apex at `(x_tip, y_tip)`. `*indenter` receives its index.
/// Collective (every rank passes the same arguments).
#[no_mangle]
pub unsafe extern "C" fn gimlet_add_indenter_wedge(
    sim: *mut GimletSim,
    half_angle_deg: f64,
    height: f64,
    x_tip: f64,
    y_tip: f64,
    indenter: *mut c_int,
) -> c_int {
    add(
        sim,
        "gimlet_add_indenter_wedge",
        args!(half_angle_deg, height, x_tip, y_tip),
        indenter,
        || {
            if !(half_angle_deg.is_finite() && half_angle_deg > 0.0 && half_angle_deg < 90.0) {
                return Err(Error::arg(format!(
                    "half_angle_deg = {half_angle_deg} must lie in (0, 90) degrees"
                )));
            }
            Ok(Shape::Wedge {
                half_angle: half_angle_deg.to_radians(),
                height,
            })
        },
        [x_tip, y_tip],
    )
}

/// Adds a rigid cylinder of radius `radius` (> 0) whose lowest point is at
/// `(x_tip, y_tip)`. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_add_indenter_cylinder(
    sim: *mut GimletSim,
    radius: f64,
    x_tip: f64,
    y_tip: f64,
    indenter: *mut c_int,
) -> c_int {
    add(
        sim,
        "gimlet_add_indenter_cylinder",
        args!(radius, x_tip, y_tip),
        indenter,
        || Ok(Shape::Cylinder { radius }),
        [x_tip, y_tip],
    )
}

/// Adds a rigid flat punch of half-width `half_width` (> 0) with rounded
/// bottom corners of radius `corner_radius` (0 for sharp corners, at most
/// `half_width`) and height `height` (> 0), its flat face centred on
/// `(x_tip, y_tip)`. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_add_indenter_flat_punch(
    sim: *mut GimletSim,
    half_width: f64,
    corner_radius: f64,
    height: f64,
    x_tip: f64,
    y_tip: f64,
    indenter: *mut c_int,
) -> c_int {
    add(
        sim,
        "gimlet_add_indenter_flat_punch",
        args!(half_width, corner_radius, height, x_tip, y_tip),
        indenter,
        || {
            Ok(Shape::FlatPunch {
                half_width,
                corner_radius,
                height,
            })
        },
        [x_tip, y_tip],
    )
}

/// Adds a rigid convex polygon of `n` (>= 3) vertices `xy` (`2 n` values,
/// x then y of each vertex, clockwise or counter-clockwise) given relative
/// to its reference point, which is placed at `(x_ref, y_ref)`. A
/// non-convex or degenerate polygon is rejected. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_add_indenter_polygon(
    sim: *mut GimletSim,
    n: i64,
    xy: *const f64,
    x_ref: f64,
    y_ref: f64,
    indenter: *mut c_int,
) -> c_int {
    // The vertices, when the arguments allow reading them (otherwise the
    // shape closure reports why).
    let v: &[f64] = match check_len(n, "n", 1 << 16) {
        Ok(k) => slice(xy, 2 * k, "xy").unwrap_or(&[]),
        Err(_) => &[],
    };
    add(
        sim,
        "gimlet_add_indenter_polygon",
        Args::new()
            .with("n", &n)
            .with("xy", v)
            .with("x_ref", &x_ref)
            .with("y_ref", &y_ref),
        indenter,
        || {
            let n = check_len(n, "n", 1 << 16)?;
            if n < 3 {
                return Err(Error::arg(format!("n = {n} must be >= 3 vertices")));
            }
            let v = slice(xy, 2 * n, "xy")?;
            Ok(Shape::Polygon {
                vertices: v.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
            })
        },
        [x_ref, y_ref],
    )
}

/// Prescribes the motion of indenter `indenter`: `kind` is
/// `GIMLET_MOTION_VELOCITY` (downward tip speeds) or `GIMLET_MOTION_DEPTH`
/// (depths), given at `n` (>= 1) strictly increasing times `times` (the
/// first >= 0), values `values`; replaces any earlier motion. A
/// load–hold–unload history is, for example, the speeds `0, v, v, 0, 0,
/// −v, −v` at the times `0, τ, t1, t1 + τ, t2, t2 + τ, t3` (short ramps of
/// length τ between the phases). Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_indenter_motion(
    sim: *mut GimletSim,
    indenter: c_int,
    kind: c_int,
    n: i64,
    times: *const f64,
    values: *const f64,
) -> c_int {
    let (t, v): (&[f64], &[f64]) = match check_len(n, "n", 1 << 24) {
        Ok(k) => (
            slice(times, k, "times").unwrap_or(&[]),
            slice(values, k, "values").unwrap_or(&[]),
        ),
        Err(_) => (&[], &[]),
    };
    collective(
        "gimlet_set_indenter_motion",
        sim,
        Args::new()
            .with("indenter", &indenter)
            .with("kind", &kind)
            .with("n", &n)
            .with("times", t)
            .with("values", v),
        |s| {
            let n = check_len(n, "n", 1 << 24)?;
            if n == 0 {
                return Err(Error::arg("n = 0 must be >= 1 (at least one time)"));
            }
            let t = slice(times, n, "times")?.to_vec();
            let v = slice(values, n, "values")?.to_vec();
            let m = match kind {
                GIMLET_MOTION_VELOCITY => Motion::Velocity { times: t, speed: v },
                GIMLET_MOTION_DEPTH => Motion::Depth { times: t, depth: v },
                _ => {
                    return Err(Error::arg(format!(
                    "kind = {kind} must be GIMLET_MOTION_VELOCITY (0) or GIMLET_MOTION_DEPTH (1)"
                )))
                }
            };
            let ni = s.contact.indenters.len();
            let ind = s
                .contact
                .indenters
                .get(indenter as usize)
                .filter(|_| indenter >= 0)
                .ok_or_else(|| {
                    Error::arg(format!(
                        "indenter = {indenter} must be in [0, {ni}) (the indenters added so far)"
                    ))
                })?;
            // Checked on a copy, so a bad history is rejected on every rank.
            ind.clone().set_motion(m.clone())?;
            Ok(m)
        },
        |s, m| s.contact.indenter_mut(indenter as i64)?.set_motion(m),
    )
}

/// The state of indenter `indenter` now: its depth, its downward speed, the
/// force on it per metre of thickness (`force[0]` x, `force[1]` y; a
/// positive `force[1]` pushes it up: the load of an indentation; in
/// axisymmetry the whole body's force in N, `force[0] = 0`), the mean
/// over the last coarse step (the contact impulse of every level's owned
/// particles, substeps included, over the step's length), and the number
/// of particles in contact after each level's last step. Any output may be
/// NULL. Local (every rank gets the same values without communication).
#[no_mangle]
pub unsafe extern "C" fn gimlet_indenter_state(
    sim: *mut GimletSim,
    indenter: c_int,
    depth: *mut f64,
    speed: *mut f64,
    force: *mut f64,
    contacts: *mut i64,
) -> c_int {
    with_sim("gimlet_indenter_state", sim, |s| {
        let t = s.time();
        let ind = s.contact.indenter_mut(indenter as i64)?;
        let (d, v) = (ind.depth(t), ind.speed(t));
        let f = s.indenter_force(indenter as usize);
        let n = s
            .contact
            .points()
            .filter(|p| p.owned && p.indenter == indenter as u32)
            .count();
        if !depth.is_null() {
            *depth = d;
        }
        if !speed.is_null() {
            *speed = v;
        }
        if !force.is_null() {
            *force = f[0];
            *force.add(1) = f[1];
        }
        if !contacts.is_null() {
            *contacts = n as i64;
        }
        Ok(())
    })
}

/// The particles in contact with indenter `indenter` (or any indenter for
/// `-1`) after their level's last step: `*count` receives their number; for
/// each, when the array is not NULL, `position` (x, y: 2 values, the
/// particle centre at the start of the step that found the contact),
/// `normal` (2: unit, the indenter's outward normal, pointing into the
/// body), `pressure` (compressive, > 0), `length` (the contact-face length:
/// the length of indenter surface the particle covers, so the force on it
/// is pressure × length per metre of thickness; in axisymmetry the
/// r-weighted length `∫ r ds`, an area per radian, so that 2π Σ pressure ×
/// length × |normal_y| is the whole body's load), `ids` (global particle
/// id), `level` and `rank` (where the particle lives). Only particles their
/// level owns are listed (the copies that couple levels are not). Pass all
/// arrays NULL to ask for the count; otherwise each non-NULL array has room
/// for `capacity` particles. Local: every rank gets the same complete list.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn gimlet_get_contacts(
    sim: *mut GimletSim,
    indenter: c_int,
    capacity: i64,
    count: *mut i64,
    position: *mut f64,
    normal: *mut f64,
    pressure: *mut f64,
    length: *mut f64,
    ids: *mut i64,
    level: *mut c_int,
    rank: *mut c_int,
) -> c_int {
    with_sim("gimlet_get_contacts", sim, |s| {
        nonnull(count, "count")?;
        let pts = owned_points(s, indenter)?;
        let none = [
            position.is_null(),
            normal.is_null(),
            pressure.is_null(),
            length.is_null(),
            ids.is_null(),
            level.is_null(),
            rank.is_null(),
        ]
        .iter()
        .all(|&b| b);
        let marker: Vec<u8> = vec![0; pts.len()];
        if none {
            return fill_buffer(&marker, 1, std::ptr::null_mut(), capacity, count, "arrays");
        }
        if capacity < pts.len() as i64 {
            // Reports the count and the error without writing.
            let mut dummy = 0u8;
            return fill_buffer(&marker, 1, &mut dummy, capacity, count, "the arrays");
        }
        for (k, p) in pts.iter().enumerate() {
            if !position.is_null() {
                *position.add(2 * k) = p.x[0];
                *position.add(2 * k + 1) = p.x[1];
            }
            if !normal.is_null() {
                *normal.add(2 * k) = p.normal[0];
                *normal.add(2 * k + 1) = p.normal[1];
            }
            if !pressure.is_null() {
                *pressure.add(k) = p.pressure;
            }
            if !length.is_null() {
                *length.add(k) = p.len;
            }
            if !ids.is_null() {
                *ids.add(k) = p.id as i64;
            }
            if !level.is_null() {
                *level.add(k) = p.level as c_int;
            }
            if !rank.is_null() {
                *rank.add(k) = p.rank;
            }
        }
        *count = pts.len() as i64;
        Ok(())
    })
}

/// The particles in contact with indenter `indenter` (`-1`: any) that
/// their level owns, in the order of `gimlet_get_contacts`; an error names
/// a bad indenter.
pub(crate) fn owned_points(
    s: &crate::sim::Simulation,
    indenter: c_int,
) -> Result<Vec<crate::contact::ContactPoint>> {
    let ni = s.contact.indenters.len() as i64;
    if indenter < -1 || indenter as i64 >= ni {
        return Err(Error::arg(format!(
            "indenter = {indenter} must be -1 (all) or in [0, {ni})"
        )));
    }
    Ok(s.contact
        .points()
        .filter(|p| p.owned && (indenter < 0 || p.indenter == indenter as u32))
        .copied()
        .collect())
}

/// Sets a contact option (`GIMLET_CONTACT_*`) to `value`, checked against
/// the option's bounds. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_contact_option(
    sim: *mut GimletSim,
    option: c_int,
    value: f64,
) -> c_int {
    collective(
        "gimlet_set_contact_option",
        sim,
        args!(option, value),
        |_| Ok(()),
        |s, ()| set_option(s, option, value),
    )
}

/// Applies a checked contact option (see `gimlet_set_contact_option`).
fn set_option(s: &mut crate::sim::Simulation, option: c_int, value: f64) -> Result<()> {
    {
        let c = &mut s.contact;
        let in_range = |lo: f64, hi: f64, lo_open: bool| {
            value.is_finite() && (if lo_open { value > lo } else { value >= lo }) && value <= hi
        };
        match option {
            GIMLET_CONTACT_REGULARIZATION => {
                if !in_range(0.0, 1.0, false) {
                    return Err(Error::arg(format!(
                        "value = {value} must lie in [0, 1] for GIMLET_CONTACT_REGULARIZATION"
                    )));
                }
                c.options.regularization = value;
            }
            GIMLET_CONTACT_KSP_RTOL => {
                if !(in_range(0.0, 1.0, true) && value < 1.0) {
                    return Err(Error::arg(format!(
                        "value = {value} must lie in (0, 1) for GIMLET_CONTACT_KSP_RTOL"
                    )));
                }
                c.lcp.rtol = value;
                c.solver = None;
            }
            GIMLET_CONTACT_DENSE_MAX => {
                if !(in_range(0.0, 1e6, false) && value.fract() == 0.0) {
                    return Err(Error::arg(format!(
                        "value = {value} must be an integer in [0, 1000000] for GIMLET_CONTACT_DENSE_MAX"
                    )));
                }
                c.lcp.dense_max = value as usize;
                c.solver = None;
            }
            GIMLET_CONTACT_BAND => {
                if !in_range(0.0, 1.0, false) {
                    return Err(Error::arg(format!(
                        "value = {value} must lie in [0, 1] for GIMLET_CONTACT_BAND"
                    )));
                }
                c.options.band_cells = value;
            }
            GIMLET_CONTACT_GAP => {
                if !(value == 0.0 || value == 1.0 || value == 2.0) {
                    return Err(Error::arg(format!(
                        "value = {value} must be 0, 1 or 2 for GIMLET_CONTACT_GAP"
                    )));
                }
                c.options.gap_mode = value as u8;
            }
            GIMLET_CONTACT_FRICTION_TOL => {
                if !in_range(0.0, 0.1, true) {
                    return Err(Error::arg(format!(
                        "value = {value} must lie in (0, 0.1] for GIMLET_CONTACT_FRICTION_TOL"
                    )));
                }
                c.options.friction_tol = value;
            }
            GIMLET_CONTACT_FRICTION_MAX_ITER => {
                if !(in_range(1.0, 1e4, false) && value.fract() == 0.0) {
                    return Err(Error::arg(format!(
                        "value = {value} must be an integer in [1, 10000] for GIMLET_CONTACT_FRICTION_MAX_ITER"
                    )));
                }
                c.options.friction_max_iter = value as u32;
            }
            _ => {
                return Err(Error::arg(format!(
                    "option = {option} must be one of the GIMLET_CONTACT_* options (0 to 6)"
                )))
            }
        }
        Ok(())
    }
}

/// Adds PETSc options for the contact solve to PETSc's options database,
/// e.g. `"-gimlet_contact_ksp_type gmres -gimlet_contact_pc_type bjacobi"`
/// (the contact KSP reads options with the prefix `gimlet_contact_`; see
/// PETSc's `KSPSetFromOptions`). They take effect at the next contact solve.
/// Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_petsc_options(
    sim: *mut GimletSim,
    options: *const c_char,
) -> c_int {
    let o = Text(options);
    collective(
        "gimlet_set_petsc_options",
        sim,
        Args::new().with("options", &o),
        |_| {
            nonnull(options, "options")?;
            // SAFETY: non-null, and documented NUL-terminated.
            let text = unsafe { std::ffi::CStr::from_ptr(options) }
                .to_str()
                .map_err(|_| Error::arg("options must be UTF-8 text"))?;
            if text.len() > 4096 {
                return Err(Error::arg(format!(
                    "options has {} bytes; at most 4096 are accepted",
                    text.len()
                )));
            }
            Ok(text.to_string())
        },
        |s, text| crate::linsolve::insert_options(s.comm(), &text),
    )
}

/// Where the contact phase's time went on this rank since creation, in
/// seconds (`times[0..5]`: detection, gathering the records, assembly,
/// complementarity solve, applying the forces), and what it solved
/// (`counts[0..6]`: contact solves, largest system, largest contact set,
/// linear solves, PETSc solves, KSP iterations in all). Either array may
/// be NULL. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_contact_stats(
    sim: *mut GimletSim,
    times: *mut f64,
    counts: *mut i64,
) -> c_int {
    with_sim("gimlet_contact_stats", sim, |s| {
        let st = s.contact.stats();
        if !times.is_null() {
            for (k, v) in [st.detect, st.gather, st.assemble, st.solve, st.apply]
                .iter()
                .enumerate()
            {
                *times.add(k) = *v;
            }
        }
        if !counts.is_null() {
            for (k, v) in [
                st.solves,
                st.max_unknowns as u64,
                st.max_contacts as u64,
                st.linear_solves,
                st.petsc_solves,
                st.ksp_iterations,
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
