//! Hierarchy creation and layout queries.

use super::agree::{args, collective};
use super::{check_len, fill_buffer, nonnull, slice, with_sim, GimletSim};
use crate::error::{Error, Result, Status};
use crate::sim::Simulation;
use std::os::raw::c_int;

fn level_index(s: &Simulation, level: c_int) -> Result<usize> {
    let n = s.hier().num_levels();
    if level < 0 || level as usize >= n {
        return Err(Error::arg(format!("level = {level} must be in [0, {n})")));
    }
    Ok(level as usize)
}

/// Sets the proper-nesting buffer, in cells of the coarser level (default 4),
/// that `gimlet_add_level` checks. Before the first `gimlet_add_level`.
/// Collective (the same `cells` on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_nesting_buffer(sim: *mut GimletSim, cells: c_int) -> c_int {
    collective(
        "gimlet_set_nesting_buffer",
        sim,
        args!(cells),
        |s| {
            s.check_layout_open("gimlet_set_nesting_buffer")?;
            let mut h = s.hier().clone();
            // The bound, named as the C call names the argument.
            h.set_nest_buffer(i64::from(cells)).map_err(|e| match e.status {
                Status::InvalidArgument => Error::arg(format!(
                    "cells = {cells} must be between {} (the fine ghost ring plus one cell) and 64 coarse cells",
                    crate::geom::MIN_NEST_BUFFER
                )),
                _ => e,
            })?;
            Ok(h)
        },
        |s, h| s.set_hierarchy(h),
    )
}

/// Adds a finer level (cell size half of the current finest) covering
/// `nboxes` boxes (1 to 4096) given as `boxes[4k..4k+4] = {xlo, ylo, xhi,
/// yhi}` in physical coordinates. Each box must be non-empty, aligned to the
/// cells of the current finest level, inside the domain, disjoint from the
/// others, and properly nested: grown by the nesting buffer it stays inside
/// the current finest level (the domain boundary excepted). Only before the
/// first particle insertion. Collective: every rank passes the same boxes
/// (the call fails on every rank otherwise).
#[no_mangle]
pub unsafe extern "C" fn gimlet_add_level(
    sim: *mut GimletSim,
    boxes: *const f64,
    nboxes: c_int,
) -> c_int {
    // The boxes take part in the agreement when the count is one the call
    // accepts (then `boxes` holds 4 nboxes values); otherwise the count
    // alone does, and the call is rejected before the boxes are read.
    let n = usize::try_from(nboxes)
        .ok()
        .filter(|&n| n <= crate::limits::MAX_BOXES_PER_LEVEL)
        .unwrap_or(0);
    let flat: &[f64] = if boxes.is_null() {
        &[]
    } else {
        std::slice::from_raw_parts(boxes, 4 * n)
    };
    collective(
        "gimlet_add_level",
        sim,
        args!(nboxes).with("boxes", flat),
        |s| {
            s.check_layout_open("gimlet_add_level")?;
            if nboxes <= 0 {
                return Err(Error::arg(format!("nboxes = {nboxes} must be >= 1")));
            }
            let n = check_len(
                nboxes as i64,
                "nboxes",
                crate::limits::MAX_BOXES_PER_LEVEL as i64,
            )?;
            let v = slice(boxes, 4 * n, "boxes")?;
            let bx: Vec<[f64; 4]> = v
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect();
            let mut h = s.hier().clone();
            h.add_level(&bx)?;
            Ok(h)
        },
        |s, h| s.set_hierarchy(h),
    )
}

/// Sets the largest patch of `level` to `px × py` cells (default: one patch
/// per box); its boxes are tiled by it. A level may have at most 16384
/// patches; a patch's grid at most 2^25 nodes (checked when the layout
/// freezes, since a default patch can be a whole large domain). Only before
/// the first particle insertion. Collective (the same values on every rank).
#[no_mangle]
pub unsafe extern "C" fn gimlet_set_patch_size(
    sim: *mut GimletSim,
    level: c_int,
    px: c_int,
    py: c_int,
) -> c_int {
    collective(
        "gimlet_set_patch_size",
        sim,
        args!(level, px, py),
        |s| {
            s.check_layout_open("gimlet_set_patch_size")?;
            let l = level_index(s, level)?;
            let mut h = s.hier().clone();
            h.set_patch_size(l, px as i64, py as i64)?;
            let boxes = h.computational_boxes(l, crate::geom::RING);
            crate::sim::check_patches(l, &boxes, h.levels[l].patch_size)?;
            Ok(h)
        },
        |s, h| s.set_hierarchy(h),
    )
}

/// Number of levels. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_num_levels(sim: *mut GimletSim, nlevels: *mut c_int) -> c_int {
    with_sim("gimlet_num_levels", sim, |s| {
        nonnull(nlevels, "nlevels")?;
        *nlevels = s.hier().num_levels() as c_int;
        Ok(())
    })
}

/// Where the steps of `level` spent their time on this rank since the
/// simulation was created, in seconds: `times[0]` the kernel phases (P2G, grid
/// update, G2P), `times[1]` the contact phase, `times[2]` the nodal sums
/// over shared nodes (exchange, including waiting for other ranks),
/// `times[3]` particle migration between patches, `times[4]` the coupling
/// with the next finer level (level changes and copies); `counts[0]` the
/// steps taken, `counts[1]` the bytes this rank sent to other ranks. Either
/// array may be NULL; zeros before the first step. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_level_stats(
    sim: *mut GimletSim,
    level: c_int,
    times: *mut f64,
    counts: *mut i64,
) -> c_int {
    with_sim("gimlet_level_stats", sim, |s| {
        let l = level_index(s, level)?;
        let st = s.levels().get(l).map(|lv| lv.stats).unwrap_or_default();
        let c = s
            .contact
            .levels
            .get(l)
            .map(|c| {
                c.stats.detect + c.stats.gather + c.stats.assemble + c.stats.solve + c.stats.apply
            })
            .unwrap_or(0.0);
        if !times.is_null() {
            let t = [
                (st.compute - c).max(0.0),
                c,
                st.exchange,
                st.migrate,
                st.coupling,
            ];
            for (k, v) in t.iter().enumerate() {
                *times.add(k) = *v;
            }
        }
        if !counts.is_null() {
            *counts = st.steps as i64;
            *counts.add(1) = st.bytes_sent as i64;
        }
        Ok(())
    })
}

/// Cell size, number of boxes and number of patches of `level`. Any output
/// may be NULL. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_level_info(
    sim: *mut GimletSim,
    level: c_int,
    h: *mut f64,
    nboxes: *mut c_int,
    npatches: *mut c_int,
) -> c_int {
    with_sim("gimlet_level_info", sim, |s| {
        let l = level_index(s, level)?;
        let np = match s.levels().get(l) {
            Some(lv) => lv.patches.len(),
            None => {
                let ps = s.hier().levels[l].patch_size;
                s.hier()
                    .computational_boxes(l, crate::geom::RING)
                    .iter()
                    .map(|b| b.tile(ps).len())
                    .sum()
            }
        };
        if !h.is_null() {
            *h = s.hier().h(l);
        }
        if !nboxes.is_null() {
            *nboxes = s.hier().levels[l].boxes.len() as c_int;
        }
        if !npatches.is_null() {
            *npatches = np as c_int;
        }
        Ok(())
    })
}

/// The boxes of `level` as `{xlo, ylo, xhi, yhi}` per box into `boxes`
/// (room for `capacity` boxes). `*count` receives the number of boxes; pass
/// `boxes = NULL` to ask for it only. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_level_boxes(
    sim: *mut GimletSim,
    level: c_int,
    boxes: *mut f64,
    capacity: i64,
    count: *mut i64,
) -> c_int {
    with_sim("gimlet_level_boxes", sim, |s| {
        let l = level_index(s, level)?;
        let flat: Vec<f64> = s.hier().levels[l]
            .boxes
            .iter()
            .flat_map(|b| s.hier().box_extent(l, b))
            .collect();
        fill_buffer(&flat, 4, boxes, capacity, count, "boxes")
    })
}

/// The patches of `level`: `cells[4k..4k+4] = {ilo, jlo, ihi, jhi}` (cell
/// indices of the level, `hi` exclusive; a refined level's patches tile its
/// boxes grown by its 4-cell ghost ring) and `owner[k]` the rank that owns
/// patch k, with room for `capacity` patches. `*count` receives the number of
/// patches; pass `cells = NULL` to ask for it only (`owner` may be NULL).
/// The owner is decided when the layout freezes (first particle insertion);
/// before that, owners are reported as -1. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_level_patches(
    sim: *mut GimletSim,
    level: c_int,
    cells: *mut i64,
    owner: *mut c_int,
    capacity: i64,
    count: *mut i64,
) -> c_int {
    with_sim("gimlet_level_patches", sim, |s| {
        let l = level_index(s, level)?;
        // The patches the level computes on: its boxes (with the ghost ring
        // of a refined level) tiled by the patch size.
        let patches: Vec<crate::geom::IBox> = match s.levels().get(l) {
            Some(lv) => lv.patches.clone(),
            None => {
                let ps = s.hier().levels[l].patch_size;
                s.hier()
                    .computational_boxes(l, crate::geom::RING)
                    .iter()
                    .flat_map(|b| b.tile(ps))
                    .collect()
            }
        };
        let flat: Vec<i64> = patches
            .iter()
            .flat_map(|b| [b.lo[0], b.lo[1], b.hi[0], b.hi[1]])
            .collect();
        fill_buffer(&flat, 4, cells, capacity, count, "cells")?;
        if !cells.is_null() && !owner.is_null() {
            for k in 0..patches.len() {
                *owner.add(k) = s.levels().get(l).map_or(-1, |lv| lv.owner[k]);
            }
        }
        Ok(())
    })
}
/// `gimlet_propose_levels` indenter: a wedge, `size` its tip half-angle in
/// degrees (0 to 90, exclusive).
pub const GIMLET_INDENTER_WEDGE: c_int = 0;
/// `gimlet_propose_levels` indenter: a cylinder, `size` its radius (m).
pub const GIMLET_INDENTER_CYLINDER: c_int = 1;
/// `gimlet_propose_levels` indenter: a flat punch, `size` its half-width (m).
pub const GIMLET_INDENTER_FLAT_PUNCH: c_int = 2;
/// `gimlet_propose_levels` indenter of the axisymmetric mode: a cone on the
/// axis, `size` its half-angle in degrees (0 to 90, exclusive; 70.3 for the
/// Berkovich- or Vickers-equivalent cone).
pub const GIMLET_INDENTER_CONE: c_int = 3;
/// `gimlet_propose_levels` indenter of the axisymmetric mode: a sphere on
/// the axis, `size` its radius (m).
pub const GIMLET_INDENTER_SPHERE: c_int = 4;
/// `gimlet_propose_levels` indenter of the axisymmetric mode: a flat
/// cylindrical punch on the axis, `size` its radius (m).
pub const GIMLET_INDENTER_CYLINDRICAL_PUNCH: c_int = 5;
/// `gimlet_propose_levels` response: elastic (the half-space closed forms,
/// plane-strain or axisymmetric, with sink-in).
pub const GIMLET_RESPONSE_ELASTIC: c_int = 0;
/// `gimlet_propose_levels` response: plastic (the indenter's intersection
/// with the undeformed surface; pile-up makes the contact larger).
pub const GIMLET_RESPONSE_PLASTIC: c_int = 1;
/// Result index of `gimlet_propose_levels`: the expected contact half-width
/// `a` at the final depth (m).
pub const GIMLET_PROPOSAL_CONTACT_HALF_WIDTH: c_int = 0;
/// Result index of `gimlet_propose_levels`: the finest level's cell size (m).
pub const GIMLET_PROPOSAL_FINEST_CELL: c_int = 1;
/// Result index of `gimlet_propose_levels`: the finest particles across `a`
/// the layout gives (at least the requested number).
pub const GIMLET_PROPOSAL_PARTICLES_ACROSS: c_int = 2;
/// The number of values `gimlet_propose_levels` writes to `results`.
pub const GIMLET_PROPOSAL_RESULTS: c_int = 3;

/// Proposes the levels and boxes of an indentation: given the domain
/// `domain = {x0, y0, lx, ly, h0}` as passed to `gimlet_create`, the
/// indenter's axis `axis_x` and the undeformed top surface `surface_y`, the
/// indenter (`GIMLET_INDENTER_*` with its `size`), the final `depth`, the
/// expected response (`GIMLET_RESPONSE_*`), `particles_per_cell` per axis
/// (1 to 8) and a target number `particles_across` of finest particles
/// across the expected contact half-width `a`, it writes the number of
/// levels to `*nlevels` and one box `{xlo, ylo, xhi, yhi}` per refined level
/// (level 1 first, `*nlevels - 1` boxes) to `boxes`, each to be passed to
/// `gimlet_add_level` in turn, and `GIMLET_PROPOSAL_RESULTS` values to
/// `results` (indexed by `GIMLET_PROPOSAL_*`; may be NULL). The finest cell
/// is the largest `h0 / 2^k` with at most `a / particles_across` per
/// particle; the finest box reaches `box_factor a` (at least 32 finest
/// cells) from the axis along and below the surface, up to the domain's
/// top, each coarser box twice as far, rounded out to the coarser cells and
/// clipped to the domain; they nest with any nesting buffer up to 15 coarse
/// cells. `box_factor` (1 to 1e6): 20 keeps the elastic main job within
/// 0.2 % of a run with halved cells (boxes at 10 and 5.6 half-widths cost
/// 0.6 % and 1.9 %; `docs/validation.md`). `a` comes from closed forms
/// (plane strain: the elastic half-space with the body's depth
/// `surface_y - y0` as the distance the depth is measured over, or the
/// intersection with the surface; axisymmetric: Sneddon's cone, Hertz's
/// sphere, the punch's radius, with the domain and the indenter on the axis,
/// `x0 = 0` and `axis_x = 0`; `docs/method.md`). `boxes` needs room
/// for `4 (max_levels - 1)` values (it may be NULL when `max_levels` is 1);
/// a target that needs more than `max_levels` (1 to 8) levels is refused
/// naming what the most levels would give. Outputs are written only on
/// success. Local and pure: no handle, no communication.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn gimlet_propose_levels(
    domain: *const f64,
    axis_x: f64,
    surface_y: f64,
    indenter: c_int,
    size: f64,
    depth: f64,
    response: c_int,
    particles_per_cell: c_int,
    particles_across: f64,
    box_factor: f64,
    max_levels: c_int,
    nlevels: *mut c_int,
    boxes: *mut f64,
    results: *mut f64,
) -> c_int {
    use crate::indentation::layout::{propose, Indenter, Request, Response};
    super::guard("gimlet_propose_levels", || {
        nonnull(nlevels, "nlevels")?;
        let d = slice(domain, 5, "domain")?;
        let indenter = match indenter {
            GIMLET_INDENTER_WEDGE => Indenter::Wedge {
                half_angle_deg: size,
            },
            GIMLET_INDENTER_CYLINDER => Indenter::Cylinder { radius: size },
            GIMLET_INDENTER_FLAT_PUNCH => Indenter::FlatPunch { half_width: size },
            GIMLET_INDENTER_CONE => Indenter::Cone {
                half_angle_deg: size,
            },
            GIMLET_INDENTER_SPHERE => Indenter::Sphere { radius: size },
            GIMLET_INDENTER_CYLINDRICAL_PUNCH => Indenter::CylindricalPunch { radius: size },
            _ => {
                return Err(Error::arg(format!(
                    "indenter = {indenter} must be GIMLET_INDENTER_WEDGE (0), GIMLET_INDENTER_CYLINDER (1), GIMLET_INDENTER_FLAT_PUNCH (2), GIMLET_INDENTER_CONE (3), GIMLET_INDENTER_SPHERE (4) or GIMLET_INDENTER_CYLINDRICAL_PUNCH (5)"
                )))
            }
        };
        let response = match response {
            GIMLET_RESPONSE_ELASTIC => Response::Elastic,
            GIMLET_RESPONSE_PLASTIC => Response::Plastic,
            _ => {
                return Err(Error::arg(format!(
                    "response = {response} must be GIMLET_RESPONSE_ELASTIC (0) or GIMLET_RESPONSE_PLASTIC (1)"
                )))
            }
        };
        let max = crate::geom::MAX_LEVELS;
        if !(1..=max as c_int).contains(&max_levels) {
            return Err(Error::arg(format!(
                "max_levels = {max_levels} must be between 1 and {max}"
            )));
        }
        if max_levels > 1 {
            nonnull(boxes, "boxes")?;
        }
        if !(1..=8).contains(&particles_per_cell) {
            return Err(Error::arg(format!(
                "particles_per_cell = {particles_per_cell} must be between 1 and 8"
            )));
        }
        let p = propose(&Request {
            domain: [d[0], d[1], d[2], d[3]],
            h0: d[4],
            axis_x,
            surface_y,
            indenter,
            depth,
            response,
            particles_per_cell: particles_per_cell as u32,
            particles_across,
            box_factor,
            max_levels: max_levels as usize,
        })?;
        for (k, b) in p.boxes.iter().enumerate() {
            std::ptr::copy_nonoverlapping(b.as_ptr(), boxes.add(4 * k), 4);
        }
        if !results.is_null() {
            let v = [p.contact_half_width, p.finest_cell, p.particles_across];
            debug_assert_eq!(v.len(), GIMLET_PROPOSAL_RESULTS as usize);
            std::ptr::copy_nonoverlapping(v.as_ptr(), results, v.len());
        }
        *nlevels = p.levels as c_int;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ffi::tests::message;
    use crate::ffi::{GIMLET_ERR_INVALID_ARGUMENT, GIMLET_OK};

    /// The main job's domain: 3.5 particles across the elastic wedge's
    /// half-width need 3 levels; outputs untouched on a refused call.
    #[test]
    fn propose_levels_through_the_c_abi() {
        let domain = [0.0, 0.0, 31e-6, 41e-6, 5e-7];
        let (mut n, mut boxes, mut res) = (-1, [0.0; 28], [0.0; 3]);
        let call = |across: f64, n: &mut c_int, boxes: &mut [f64; 28], res: &mut [f64; 3]| unsafe {
            gimlet_propose_levels(
                domain.as_ptr(),
                0.0,
                40e-6,
                GIMLET_INDENTER_WEDGE,
                65.0,
                4.5e-7,
                GIMLET_RESPONSE_ELASTIC,
                2,
                across,
                20.0,
                8,
                n,
                boxes.as_mut_ptr(),
                res.as_mut_ptr(),
            )
        };
        assert_eq!(call(3.5, &mut n, &mut boxes, &mut res), GIMLET_OK);
        assert_eq!(n, 3);
        assert_eq!(res[GIMLET_PROPOSAL_FINEST_CELL as usize], 1.25e-7);
        assert!(res[GIMLET_PROPOSAL_PARTICLES_ACROSS as usize] >= 3.5);
        // Level 2's box inside level 1's, both from the axis to the top.
        assert_eq!(
            (boxes[0], boxes[3], boxes[4], boxes[7]),
            (0.0, 41e-6, 0.0, 41e-6)
        );
        assert!(boxes[6] < boxes[2] && boxes[5] > boxes[1]);
        let before = (n, boxes, res);
        assert_eq!(
            call(-1.0, &mut n, &mut boxes, &mut res),
            GIMLET_ERR_INVALID_ARGUMENT
        );
        assert!(message().contains("particles_across = -1"), "{}", message());
        assert_eq!((n, boxes, res), before);
        let rc = unsafe {
            gimlet_propose_levels(
                domain.as_ptr(),
                0.0,
                40e-6,
                7,
                65.0,
                4.5e-7,
                GIMLET_RESPONSE_ELASTIC,
                2,
                3.5,
                20.0,
                8,
                &mut n,
                boxes.as_mut_ptr(),
                std::ptr::null_mut(),
            )
        };
        assert_eq!(rc, GIMLET_ERR_INVALID_ARGUMENT);
        assert!(message().contains("indenter = 7"));
        assert!(message().contains("GIMLET_INDENTER_CYLINDRICAL_PUNCH (5)"));
        // A sphere of 10 µm on the axis: Hertz's a = sqrt(R h).
        let rc = unsafe {
            gimlet_propose_levels(
                domain.as_ptr(),
                0.0,
                40e-6,
                GIMLET_INDENTER_SPHERE,
                1e-5,
                1e-7,
                GIMLET_RESPONSE_ELASTIC,
                2,
                4.0,
                20.0,
                8,
                &mut n,
                boxes.as_mut_ptr(),
                res.as_mut_ptr(),
            )
        };
        assert_eq!(rc, GIMLET_OK, "{}", message());
        let a = (1e-5f64 * 1e-7).sqrt();
        assert!((res[GIMLET_PROPOSAL_CONTACT_HALF_WIDTH as usize] / a - 1.0).abs() < 1e-15);
        assert_eq!(boxes[0], 0.0);
    }
}
