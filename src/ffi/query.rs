//! Field queries of local particles, global diagnostics, lost particles.

use super::agree::{args, collective, Args};
use super::{fill_buffer, nonnull, with_sim, GimletSim};
use crate::error::Error;
use crate::sim::Field;
use std::os::raw::c_int;

/// Field: position x, y (2 per particle).
pub const GIMLET_FIELD_POSITION: c_int = 0;
/// Field: velocity x, y (2).
pub const GIMLET_FIELD_VELOCITY: c_int = 1;
/// Field: Cauchy stress xx, yy, xy, zz (4).
pub const GIMLET_FIELD_STRESS: c_int = 2;
/// Field: Green–Lagrange strain xx, yy, xy from F (3).
pub const GIMLET_FIELD_STRAIN: c_int = 3;
/// Field: deformation gradient xx, xy, yx, yy (4).
pub const GIMLET_FIELD_DEFGRAD: c_int = 4;
/// Field: current half-lengths lpx, lpy (2).
pub const GIMLET_FIELD_HALF_LENGTH: c_int = 5;
/// Field: mass (1).
pub const GIMLET_FIELD_MASS: c_int = 6;
/// Field: level (1, as a double).
pub const GIMLET_FIELD_LEVEL: c_int = 7;
/// Field: reference volume (1).
pub const GIMLET_FIELD_VOLUME0: c_int = 8;
/// Field: reference (initial) position x0, y0 (2).
pub const GIMLET_FIELD_REFERENCE: c_int = 9;
/// Field: contact pressure after the last step, 0 away from the
/// indenters (1).
pub const GIMLET_FIELD_CONTACT_PRESSURE: c_int = 11;
/// Field: equivalent plastic strain of a J2 material (1; 0 for the elastic
/// laws).
pub const GIMLET_FIELD_PLASTIC_STRAIN: c_int = 10;
/// Field: the affine velocity matrix C of the APIC transfer, xx, xy, yx, yy
/// (4; the particle's velocity field is `v + C (x − x_p)`). Zero until a
/// step with `GIMLET_TRANSFER_APIC` or `gimlet_set_field` sets it; the
/// FLIP/PIC transfer neither reads nor changes it.
pub const GIMLET_FIELD_AFFINE: c_int = 12;
/// Field: the out-of-plane stretch (1): the hoop stretch `F_θθ = r/R` in
/// axisymmetry (`gimlet_set_geometry`), 1 in plane strain.
pub const GIMLET_FIELD_HOOP_STRETCH: c_int = 13;

fn field(f: c_int) -> Result<Field, Error> {
    Ok(match f {
        GIMLET_FIELD_POSITION => Field::Position,
        GIMLET_FIELD_VELOCITY => Field::Velocity,
        GIMLET_FIELD_STRESS => Field::Stress,
        GIMLET_FIELD_STRAIN => Field::Strain,
        GIMLET_FIELD_DEFGRAD => Field::DefGrad,
        GIMLET_FIELD_HALF_LENGTH => Field::HalfLength,
        GIMLET_FIELD_MASS => Field::Mass,
        GIMLET_FIELD_LEVEL => Field::Level,
        GIMLET_FIELD_VOLUME0 => Field::Volume0,
        GIMLET_FIELD_REFERENCE => Field::Reference,
        GIMLET_FIELD_CONTACT_PRESSURE => Field::ContactPressure,
        GIMLET_FIELD_PLASTIC_STRAIN => Field::PlasticStrain,
        GIMLET_FIELD_AFFINE => Field::Affine,
        GIMLET_FIELD_HOOP_STRETCH => Field::HoopStretch,
        _ => {
            return Err(Error::arg(format!(
                "field = {f} must be one of the GIMLET_FIELD_* values (0 to 13)"
            )))
        }
    })
}

/// Number of components per particle of `field` (`GIMLET_FIELD_*`). Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_field_components(
    sim: *mut GimletSim,
    fld: c_int,
    ncomp: *mut c_int,
) -> c_int {
    with_sim("gimlet_field_components", sim, |_| {
        nonnull(ncomp, "ncomp")?;
        *ncomp = field(fld)?.ncomp() as c_int;
        Ok(())
    })
}

/// Copies `field` of this rank's particles into `out` (room for `capacity`
/// particles, `ncomp` values each, interleaved). The order is the same for
/// every field and for `gimlet_get_ids` until the next step or insertion.
/// `*count` receives the number of particles; `out = NULL` asks for it only.
/// Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_get_field(
    sim: *mut GimletSim,
    fld: c_int,
    out: *mut f64,
    capacity: i64,
    count: *mut i64,
) -> c_int {
    with_sim("gimlet_get_field", sim, |s| {
        let f = field(fld)?;
        let mut v = Vec::new();
        if !out.is_null() {
            s.gather(f, &mut v);
        } else {
            v.resize(s.num_local() * f.ncomp(), 0.0);
        }
        fill_buffer(&v, f.ncomp(), out, capacity, count, "out")
    })
}

/// Sets `field` of this rank's particles from `values` (`n` particles,
/// `ncomp` values each, in the order of `gimlet_get_field`; `n` must be the
/// local count; every value finite with magnitude at most 1e30). Only
/// `GIMLET_FIELD_VELOCITY` (initial velocities), `GIMLET_FIELD_STRESS`
/// (initial stresses) and `GIMLET_FIELD_AFFINE` (the APIC matrix, e.g. the
/// gradient of an initial velocity field; setting the velocity leaves it
/// as it is) can be set. Collective: every rank calls it with the
/// same `fld` (and its own values); if any rank's values are rejected,
/// every rank fails and nothing is set.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_field(
    sim: *mut GimletSim,
    fld: c_int,
    values: *const f64,
    n: i64,
) -> c_int {
    collective(
        "gimlet_set_field",
        sim,
        args!(fld),
        |s| {
            let f = field(fld)?;
            let n = super::check_len(n, "n", 1 << 40)?;
            let v = super::slice(values, n * f.ncomp(), "values")?;
            s.check_scatter(f, v)?;
            Ok((f, v))
        },
        |s, (f, v)| {
            s.scatter_checked(f, v);
            Ok(())
        },
    )
}

/// Copies the global ids of this rank's particles into `ids` (same order as
/// `gimlet_get_field`). `*count` receives the number; `ids = NULL` asks for
/// it only. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_get_ids(
    sim: *mut GimletSim,
    ids: *mut u64,
    capacity: i64,
    count: *mut i64,
) -> c_int {
    with_sim("gimlet_get_ids", sim, |s| {
        // Owned particles only, like gimlet_get_field.
        let v: Vec<u64> = s
            .local_sets()
            .flat_map(|(_, p)| {
                p.id.iter()
                    .zip(&p.copy)
                    .filter(|&(_, &c)| c == crate::particles::OWNED)
                    .map(|(&id, _)| id)
            })
            .collect();
        fill_buffer(&v, 1, ids, capacity, count, "ids")
    })
}

/// Global diagnostics: kinetic energy, strain energy, linear momentum
/// (x, y) and total mass, per the plane-strain thickness; in axisymmetry
/// the whole body's (2π times the per-radian sums; the x momentum is then
/// 0, the radial momenta cancelling). Any output may be NULL. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_diagnostics(
    sim: *mut GimletSim,
    kinetic: *mut f64,
    strain: *mut f64,
    momentum_x: *mut f64,
    momentum_y: *mut f64,
    mass: *mut f64,
) -> c_int {
    collective(
        "gimlet_diagnostics",
        sim,
        Args::new(),
        |_| Ok(()),
        |s, ()| {
            let d = s.diagnostics()?;
            for (p, v) in [kinetic, strain, momentum_x, momentum_y, mass]
                .into_iter()
                .zip(d)
            {
                if !p.is_null() {
                    *p = v;
                }
            }
            Ok(())
        },
    )
}

/// The particles this rank removed because they left the domain: global
/// ids and last positions `xy[2k], xy[2k+1]` (either may be NULL), room for
/// `capacity`. `*count` receives the number. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_lost_particles(
    sim: *mut GimletSim,
    ids: *mut u64,
    xy: *mut f64,
    capacity: i64,
    count: *mut i64,
) -> c_int {
    with_sim("gimlet_lost_particles", sim, |s| {
        let idv: Vec<u64> = s.lost().iter().map(|d| d.id).collect();
        let xyv: Vec<f64> = s.lost().iter().flat_map(|d| [d.x, d.y]).collect();
        // Check the capacity for both buffers before writing either.
        fill_buffer(&idv, 1, std::ptr::null_mut(), 0, count, "ids")?;
        if (!ids.is_null() || !xy.is_null()) && capacity < *count {
            return Err(Error::new(
                crate::error::Status::BufferTooSmall,
                format!(
                    "capacity = {capacity} but {} lost particles are recorded (reported in count)",
                    *count
                ),
            ));
        }
        if !ids.is_null() {
            fill_buffer(&idv, 1, ids, capacity, count, "ids")?;
        }
        if !xy.is_null() {
            fill_buffer(&xyv, 2, xy, capacity, count, "xy")?;
        }
        Ok(())
    })
}

/// The number of times a particle moved from one patch to another (summed
/// over levels and ranks) since creation. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_patch_crossings(sim: *mut GimletSim, crossings: *mut i64) -> c_int {
    collective(
        "gimlet_patch_crossings",
        sim,
        Args::new(),
        |_| nonnull(crossings, "crossings"),
        |s, ()| {
            let mut n = [s.levels().iter().map(|l| l.crossings).sum::<u64>()];
            s.comm().sum_u64(&mut n)?;
            *crossings = n[0] as i64;
            Ok(())
        },
    )
}
