//! Particle insertion and counts.

use super::agree::{args, collective, Args};
use super::{check_len, nonnull, slice, with_sim, GimletSim};
use crate::sim::{Fill, ParticleArrays};
use std::os::raw::c_int;

/// Inserts `n` particles from caller arrays (each rank passes its own; `n`
/// may be 0 on some ranks). Positions `x, y` must lie in the domain;
/// half-lengths `0 < lpx, lpy <= h/2` of the level that holds the position;
/// velocities `vx, vy`; exactly one of `mass` (per thickness) and `density`
/// is non-NULL; `material` indexes the materials added so far. The library
/// puts each particle on the finest level holding it and on the rank owning
/// its patch, and gives it the next global ids (rank order, then array
/// order). Bounds: half-lengths at least 1e-30, `|vx|, |vy| <= 1e30`, the
/// density (given, or implied by the mass) between 1e-30 and 1e30, at most
/// 2^31 particles in all, and memory for them on each rank. If any rank's
/// input is rejected, every rank fails with that rank's status and message
/// and nothing is inserted. Freezes the hierarchy layout (refused when a
/// patch would be too large, see `gimlet_set_patch_size`). Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_insert_particles(
    sim: *mut GimletSim,
    n: i64,
    x: *const f64,
    y: *const f64,
    lpx: *const f64,
    lpy: *const f64,
    vx: *const f64,
    vy: *const f64,
    mass: *const f64,
    density: *const f64,
    material: *const c_int,
) -> c_int {
    collective(
        "gimlet_insert_particles",
        sim,
        Args::new(),
        |s| {
            let n = check_len(n, "n", crate::limits::MAX_NEW_PARTICLES as i64)?;
            let a = ParticleArrays {
                x: slice(x, n, "x")?,
                y: slice(y, n, "y")?,
                lpx: slice(lpx, n, "lpx")?,
                lpy: slice(lpy, n, "lpy")?,
                vx: slice(vx, n, "vx")?,
                vy: slice(vy, n, "vy")?,
                mass: if mass.is_null() {
                    None
                } else {
                    Some(slice(mass, n, "mass")?)
                },
                density: if density.is_null() {
                    None
                } else {
                    Some(slice(density, n, "density")?)
                },
                material: slice(material, n, "material")?,
            };
            if n > 0 && a.mass.is_some() && a.density.is_some() {
                return Err(crate::error::Error::arg(
                    "mass and density are both given: pass exactly one of them (the other NULL)",
                ));
            }
            s.check_arrays(&a)?;
            Ok(a)
        },
        |s, a| s.insert_checked(&a),
    )
}

/// Fills the rectangle `[xlo, xhi] × [ylo, yhi]` (inside the domain) with
/// `n_per_cell × n_per_cell` particles per cell (1 to 8) of the level that
/// owns each cell, of `material`, `density` (between 1e-30 and 1e30) and
/// velocity `(vx, vy)` (components of magnitude at most 1e30).
/// Particle centres fall on the regular sub-cell lattice and must lie in the
/// rectangle; the fill is refused when it could add more than 2^31
/// particles or more than the memory available. Every rank passes the same
/// arguments (the call fails on every rank otherwise); global ids follow the
/// lattice, so they do not depend on the number of ranks. `*added` (may be
/// NULL) receives the global number of particles added. Freezes the layout.
/// Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_fill_rectangle(
    sim: *mut GimletSim,
    xlo: f64,
    ylo: f64,
    xhi: f64,
    yhi: f64,
    n_per_cell: c_int,
    material: c_int,
    density: f64,
    vx: f64,
    vy: f64,
    added: *mut i64,
) -> c_int {
    let fill = Fill {
        rect: [xlo, ylo, xhi, yhi],
        n_per_cell,
        material,
        density,
        velocity: [vx, vy],
    };
    collective(
        "gimlet_fill_rectangle",
        sim,
        args!(xlo, ylo, xhi, yhi, n_per_cell, material, density, vx, vy),
        |s| s.check_fill(&fill),
        |s, ()| {
            let k = s.fill_rectangle(&fill)?;
            if !added.is_null() {
                *added = k as i64;
            }
            Ok(())
        },
    )
}

/// The number of particles on this rank (`local`) and on all ranks
/// (`global`), over all levels (copies that coupling keeps on a coarser
/// level are not counted twice). Either output may be NULL. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_particle_count(
    sim: *mut GimletSim,
    local: *mut i64,
    global: *mut i64,
) -> c_int {
    collective(
        "gimlet_particle_count",
        sim,
        Args::new(),
        |_| Ok(()),
        |s, ()| {
            let (l, g) = s.counts()?;
            if !local.is_null() {
                *local = l as i64;
            }
            if !global.is_null() {
                *global = g as i64;
            }
            Ok(())
        },
    )
}

/// The number of particles of `level` on this rank. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_level_particle_count(
    sim: *mut GimletSim,
    level: c_int,
    local: *mut i64,
) -> c_int {
    with_sim("gimlet_level_particle_count", sim, |s| {
        nonnull(local, "local")?;
        let nl = s.hier().num_levels();
        if level < 0 || level as usize >= nl {
            return Err(crate::error::Error::arg(format!(
                "level = {level} must be in [0, {nl})"
            )));
        }
        *local = s
            .levels()
            .get(level as usize)
            .map_or(0, |lv| lv.num_owned_particles() as i64);
        Ok(())
    })
}
