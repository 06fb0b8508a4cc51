//! Creating and destroying a simulation handle; materials and global settings.

use super::agree::{args, collective, create_on};
use super::{guard, nonnull, with_sim, GimletSim, MPI_Comm, MPI_Fint};
use crate::comm::Comm;
use crate::error::Result;
use crate::material::{Hardening, Material};
use crate::sim::Simulation;
use std::os::raw::c_int;

fn create(name: &str, comm: Result<Comm>, dom: [f64; 5], out: *mut *mut GimletSim) -> Result<()> {
    let [x0, y0, lx, ly, h] = dom;
    create_on(
        comm,
        name,
        args!(x0, y0, lx, ly, h),
        out,
        || crate::geom::Hierarchy::new(x0, y0, lx, ly, h).map(|_| ()),
        |c, ()| Simulation::new(c, x0, y0, lx, ly, h),
    )
}

/// Creates a simulation on a duplicate of `comm` (the caller keeps and frees
/// its own communicator) over the domain `[x0, x0+lx] × [y0, y0+ly]` with
/// level-0 cells of size `h` (`lx/h`, `ly/h` integers). The hierarchy has
/// one level until `gimlet_add_level` is called. MPI must be initialized by
/// the caller; the library never calls `MPI_Init` or `MPI_Finalize`. On
/// success `*out` receives the handle; on failure `*out` is unchanged.
/// Collective over `comm`: every rank must pass the same domain (otherwise
/// every rank fails with `GIMLET_ERR_INVALID_ARGUMENT`).
///
/// `comm` is checked before any MPI call that could abort the process:
/// `MPI_COMM_NULL`, a NULL handle and (with Open MPI) a handle that is not a
/// live communicator of the process (for example a copy of a freed one) are
/// rejected with `GIMLET_ERR_INVALID_ARGUMENT`, an inter-communicator too;
/// the duplicate gets `MPI_ERRORS_RETURN`, so an MPI failure inside the
/// library is `GIMLET_ERR_MPI`. Not detectable: a communicator valid on some
/// ranks only, or different communicators on different ranks (the ranks
/// with a valid one wait in `MPI_Comm_dup`).
#[no_mangle]
pub unsafe extern "C" fn gimlet_create(
    comm: MPI_Comm,
    x0: f64,
    y0: f64,
    lx: f64,
    ly: f64,
    h: f64,
    out: *mut *mut GimletSim,
) -> c_int {
    guard("gimlet_create", || {
        create("gimlet_create", Comm::dup(comm), [x0, y0, lx, ly, h], out)
    })
}

/// As `gimlet_create`, with the communicator given by its Fortran handle
/// (converted with `MPI_Comm_f2c`), for `iso_c_binding` callers. A negative
/// handle, or one that is not a live communicator (never created, or freed:
/// Open MPI's `MPI_Comm_f2c` returns an invalid handle for it without
/// invoking an error handler), is rejected with
/// `GIMLET_ERR_INVALID_ARGUMENT` before any MPI call that could abort.
#[no_mangle]
pub unsafe extern "C" fn gimlet_create_f(
    fcomm: MPI_Fint,
    x0: f64,
    y0: f64,
    lx: f64,
    ly: f64,
    h: f64,
    out: *mut *mut GimletSim,
) -> c_int {
    guard("gimlet_create_f", || {
        create(
            "gimlet_create_f",
            Comm::from_fortran(fcomm),
            [x0, y0, lx, ly, h],
            out,
        )
    })
}

/// Destroys the handle at `*sim`, frees its communicator duplicate, and sets
/// `*sim` to NULL. `sim == NULL` or `*sim == NULL` is a no-op success.
/// Collective (it frees a communicator): call it on every rank, before
/// `MPI_Finalize`. It has no argument to agree on and makes no agreement.
#[no_mangle]
pub unsafe extern "C" fn gimlet_destroy(sim: *mut *mut GimletSim) -> c_int {
    guard("gimlet_destroy", || {
        if sim.is_null() || (*sim).is_null() {
            return Ok(());
        }
        let b = Box::from_raw(*sim);
        *sim = std::ptr::null_mut();
        drop(b);
        Ok(())
    })
}

/// This rank and the communicator size. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_comm_info(
    sim: *mut GimletSim,
    rank: *mut c_int,
    size: *mut c_int,
) -> c_int {
    with_sim("gimlet_comm_info", sim, |s| {
        nonnull(rank, "rank")?;
        nonnull(size, "size")?;
        *rank = s.comm().rank();
        *size = s.comm().size();
        Ok(())
    })
}

/// Sets the plane-strain thickness `t` (default 1; between 1e-30 and 1e30,
/// see the input bounds in `docs/embedding.md`): particle volume is `4 lpx lpy t`, masses
/// and forces are per this thickness. Only before the first particle
/// insertion. Collective (the same `thickness` on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_thickness(sim: *mut GimletSim, thickness: f64) -> c_int {
    collective(
        "gimlet_set_thickness",
        sim,
        args!(thickness),
        |s| s.check_thickness(thickness),
        |s, ()| s.set_thickness(thickness),
    )
}

/// `geometry` of [`gimlet_set_geometry`]: plane strain, the default.
pub const GIMLET_PLANE_STRAIN: c_int = 0;
/// `geometry` of [`gimlet_set_geometry`]: axisymmetry about the y axis.
pub const GIMLET_AXISYMMETRIC: c_int = 1;

/// Sets the geometry: `GIMLET_PLANE_STRAIN` (the default) or
/// `GIMLET_AXISYMMETRIC`. Only before the first particle insertion.
/// Collective (the same `geometry` on every rank).
///
/// In axisymmetry x is the radius r and y the axis z:
/// - the domain must start at x0 >= 0, and every particle's domain must
///   lie at r >= 0 (`x - lpx >= 0`);
/// - every particle quantity is **per radian**: volume `4 lpx lpy r`, mass
///   `rho 4 lpx lpy r` (a mass passed to `gimlet_insert_particles` is per
///   radian too), tractions give forces per radian;
/// - the fourth stress component is the hoop stress `σ_θθ`, and the
///   particles carry the hoop stretch `F_θθ`;
/// - a free left face at x0 = 0 is the axis and takes `v_r = 0` (a roller);
/// - `gimlet_set_thickness` is refused, and this call is refused after a
///   thickness was set.
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_geometry(sim: *mut GimletSim, geometry: c_int) -> c_int {
    let mode = match geometry {
        GIMLET_PLANE_STRAIN => Some(crate::mode::ModeKind::PlaneStrain),
        GIMLET_AXISYMMETRIC => Some(crate::mode::ModeKind::Axisymmetric),
        _ => None,
    };
    collective(
        "gimlet_set_geometry",
        sim,
        args!(geometry),
        |s| {
            let m = mode.ok_or_else(|| {
                crate::error::Error::arg(format!(
                    "geometry = {geometry} must be GIMLET_PLANE_STRAIN (0) or GIMLET_AXISYMMETRIC (1)"
                ))
            })?;
            s.check_mode(m)?;
            Ok(m)
        },
        |s, m| s.set_mode(m),
    )
}

/// The geometry (`GIMLET_PLANE_STRAIN` or `GIMLET_AXISYMMETRIC`). Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_get_geometry(sim: *mut GimletSim, geometry: *mut c_int) -> c_int {
    with_sim("gimlet_get_geometry", sim, |s| {
        nonnull(geometry, "geometry")?;
        *geometry = match s.mode() {
            crate::mode::ModeKind::PlaneStrain => GIMLET_PLANE_STRAIN,
            crate::mode::ModeKind::Axisymmetric => GIMLET_AXISYMMETRIC,
        };
        Ok(())
    })
}

fn add_material(sim: *mut GimletSim, name: &str, m: Material, id: *mut c_int) -> c_int {
    // Every parameter of the law is agreed (the hardening's too), under the
    // name the C call gives it.
    let args = match m {
        Material::LinearElastic { e, nu, rho } | Material::NeoHookean { e, nu, rho } => {
            args!(e, nu, rho)
        }
        Material::J2 {
            e,
            nu,
            rho,
            hardening: Hardening::Linear { sigma_y, h },
        } => args!(e, nu, rho, sigma_y, h),
        Material::J2 {
            e,
            nu,
            rho,
            hardening: Hardening::Power { sigma_0, n, eps_0 },
        } => args!(e, nu, rho, sigma_0, n, eps_0),
    };
    collective(
        name,
        sim,
        args,
        |s| {
            nonnull(id, "id")?;
            s.check_material(&m)
        },
        |s, ()| {
            let k = s.add_material(m)?;
            // SAFETY: checked non-null.
            unsafe { *id = k as c_int };
            Ok(())
        },
    )
}

/// Adds a linear elastic material (the 3D law in plane strain or
/// axisymmetry, Jaumann stress rate for large rotations): Young's modulus `e` and density `rho` between 1e-30
/// and 1e30, Poisson's ratio `-1 < nu < 0.5`. `*id` receives its index.
/// Collective (the same material on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_add_material_linear_elastic(
    sim: *mut GimletSim,
    e: f64,
    nu: f64,
    rho: f64,
    id: *mut c_int,
) -> c_int {
    add_material(
        sim,
        "gimlet_add_material_linear_elastic",
        Material::LinearElastic { e, nu, rho },
        id,
    )
}

/// Adds a compressible Neo-Hookean material (plane strain or axisymmetry) with small-strain
/// constants `e` and `rho` between 1e-30 and 1e30, `-1 < nu < 0.5`. `*id`
/// receives its index. Collective (the same material on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_add_material_neo_hookean(
    sim: *mut GimletSim,
    e: f64,
    nu: f64,
    rho: f64,
    id: *mut c_int,
) -> c_int {
    add_material(
        sim,
        "gimlet_add_material_neo_hookean",
        Material::NeoHookean { e, nu, rho },
        id,
    )
}

/// Adds a J2 (von Mises) elastic–plastic material with linear isotropic
/// hardening (plane strain or axisymmetry, radial return on the
/// Jaumann-rate hypo-elastic law over the three normal components): Young's modulus `e > 0`, Poisson's ratio `-1 < nu < 0.5`, density
/// `rho > 0`, initial (uniaxial) yield stress `sigma_y > 0` and hardening
/// modulus `h >= 0` (`σ_y(ε_p) = sigma_y + h ε_p`; `h = 0` is perfectly
/// plastic), all finite. The equivalent plastic strain `ε_p` is the field
/// `GIMLET_FIELD_PLASTIC_STRAIN`. `*id` receives its index. Collective (the
/// same material on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_add_material_j2_linear(
    sim: *mut GimletSim,
    e: f64,
    nu: f64,
    rho: f64,
    sigma_y: f64,
    h: f64,
    id: *mut c_int,
) -> c_int {
    add_material(
        sim,
        "gimlet_add_material_j2_linear",
        Material::J2 {
            e,
            nu,
            rho,
            hardening: Hardening::Linear { sigma_y, h },
        },
        id,
    )
}

/// Adds a J2 (von Mises) elastic–plastic material with power-law isotropic
/// hardening `σ_y(ε_p) = sigma_0 (1 + ε_p / eps_0)^n` (plane strain or
/// axisymmetry, as `gimlet_add_material_j2_linear`): `e > 0`, `-1 < nu < 0.5`, `rho > 0`,
/// `sigma_0 > 0`, `0 <= n < 1`, `eps_0 > 0`, all finite. `*id` receives its
/// index. Collective (the same material on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_add_material_j2_power(
    sim: *mut GimletSim,
    e: f64,
    nu: f64,
    rho: f64,
    sigma_0: f64,
    n: f64,
    eps_0: f64,
    id: *mut c_int,
) -> c_int {
    add_material(
        sim,
        "gimlet_add_material_j2_power",
        Material::J2 {
            e,
            nu,
            rho,
            hardening: Hardening::Power { sigma_0, n, eps_0 },
        },
        id,
    )
}
