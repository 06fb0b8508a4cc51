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
