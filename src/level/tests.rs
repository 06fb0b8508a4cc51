//! Tests of the level's hand-written `Clone`.

use super::*;
use crate::kernel::Prepared;

/// Asserts that `a` equals `b` field by field, bit for bit (particles,
/// grids, preparations, layout and bookkeeping), and that every array
/// keeps the storage's layout property.
fn assert_same(a: &Level, b: &Level) {
    // Every field named (no `..`): a new field must be compared here.
    let Level {
        l,
        h,
        origin,
        domain,
        boxes,
        owned,
        patch_size,
        patches,
        owner,
        local,
        bc,
        crossings,
        stats,
        // No state (written before it is read): not copied or compared.
        scratch: _,
        step_dt_cfl1,
    } = a;
    assert_eq!(*l, b.l);
    assert_eq!(h.to_bits(), b.h.to_bits());
    assert_eq!(origin.map(f64::to_bits), b.origin.map(f64::to_bits));
    assert_eq!((domain, boxes, owned), (&b.domain, &b.boxes, &b.owned));
    assert_eq!(
        (patch_size, patches, owner),
        (&b.patch_size, &b.patches, &b.owner)
    );
    assert_eq!((bc, crossings, stats), (&b.bc, &b.crossings, &b.stats));
    assert_eq!(step_dt_cfl1.to_bits(), b.step_dt_cfl1.to_bits());
    assert_eq!(local.len(), b.local.len());
    for (p, q) in local.iter().zip(&b.local) {
        let LocalPatch {
            k,
            cells,
            parts,
            grid,
            prepared,
            nbrs,
        } = p;
        assert_eq!(
            (k, cells, prepared, nbrs),
            (&q.k, &q.cells, &q.prepared, &q.nbrs)
        );
        parts.assert_same(&q.parts);
        assert_eq!(grid.is_some(), q.grid.is_some(), "patch {k}: grid");
        if let (Some(g), Some(r)) = (grid, &q.grid) {
            let Grid {
                origin,
                h,
                lo,
                n,
                ghost,
                mass,
                mom_force,
                vel,
                dil,
                xpic,
            } = g;
            assert_eq!(origin.map(f64::to_bits), r.origin.map(f64::to_bits));
            assert_eq!(
                (h.to_bits(), lo, n, ghost),
                (r.h.to_bits(), &r.lo, &r.n, &r.ghost)
            );
            assert_eq!(mass.bytes(), r.mass.bytes());
            assert_eq!(mom_force.bytes(), r.mom_force.bytes());
            assert_eq!(vel.bytes(), r.vel.bytes());
            assert_eq!(dil.bytes(), r.dil.bytes());
            assert_eq!(xpic.bytes(), r.xpic.bytes());
            mass.assert_layout();
            mom_force.assert_layout();
            vel.assert_layout();
            dil.assert_layout();
            xpic.assert_layout();
        }
    }
}

/// A value that differs with every argument (and is never a whole
/// number, so that no two fields agree by accident).
fn val(seed: u64, field: usize, i: usize) -> f64 {
    (seed as f64) * 1e3 + field as f64 + i as f64 * 1e-4 + 0.125
}

/// A level of 128 x 64 cells tiled with `patch`-sized patches (all
/// owned by this rank); local patch `k` holds `counts[k % len]`
/// particles whose every field (the APIC matrix, load codes, plastic
/// strain and copy flags included) is set from `seed`; patches with
/// particles get a grid with values in every array (the dilatation
/// only when `dil`), and every other such patch a preparation.
fn level(patch: [i64; 2], counts: &[usize], seed: u64, dil: bool) -> Level {
    let domain = IBox::new([0, 0], [128, 64]);
    let np = domain.tile(patch).len();
    let layout = LevelLayout {
        l: 1,
        h: 0.5,
        origin: [0.0, -1.0],
        domain,
        boxes: vec![domain],
        owned: vec![domain],
        patch_size: patch,
    };
    let mut lv = Level::new(layout, vec![0; np], 0);
    for (k, p) in lv.local.iter_mut().enumerate() {
        let n = counts[k % counts.len()];
        for i in 0..n {
            p.parts.id.push(seed * 1_000_000 + (k * 10_000 + i) as u64);
            p.parts.material.push((i % 3) as u32 + seed as u32);
            for (f, v) in p.parts.f64_fields_mut().into_iter().enumerate() {
                v.push(val(seed, f, i));
            }
        }
    }
    lv.ensure_grids().expect("grids");
    for (k, p) in lv.local.iter_mut().enumerate() {
        let Some(g) = &mut p.grid else { continue };
        for (i, m) in g.mass.iter_mut().enumerate() {
            *m = val(seed, 100, i);
        }
        for (i, m) in g.mom_force.iter_mut().enumerate() {
            m.0 = [0, 1, 2, 3].map(|c| val(seed, 101 + c, i));
        }
        for (i, m) in g.vel.iter_mut().enumerate() {
            m.0 = [0, 1, 2, 3].map(|c| val(seed, 105 + c, i));
        }
        if dil {
            let n = g.mass.len();
            g.dil
                .extend((0..n).map(|i| [val(seed, 109, i), val(seed, 110, i)]));
        }
        if k % 2 == 0 {
            p.prepared = Some(Prepared::sample(val(seed, 111, k)));
        }
    }
    lv.crossings = 17 + seed;
    lv.stats.steps = 3 + seed;
    lv.stats.compute = val(seed, 112, 0);
    lv.scratch
        .extend((0..(50 * seed as usize)).map(|i| val(seed, 113, i)));
    lv.step_dt_cfl1 = val(seed, 114, 0);
    lv
}

#[test]
fn clone_from_equals_a_fresh_clone_whatever_the_old_sizes() {
    // Sources and targets of other sizes: more and fewer particles
    // (above and below the storage's stagger threshold), other patch
    // tilings (more and fewer local patches), patches that gain or lose
    // their grid, with and without the dilatation array.
    let cases = [
        level([64, 64], &[5000, 0, 20], 1, true),
        level([64, 64], &[300], 2, false),
        level([32, 64], &[0, 6000, 1, 4100], 3, true),
        level([128, 64], &[9000], 4, false),
        level([32, 32], &[0], 5, false),
        level([16, 64], &[7, 5000], 6, true),
    ];
    for src in &cases {
        let fresh = src.clone();
        assert_same(&fresh, src);
        for old in &cases {
            let mut snap = old.clone();
            snap.clone_from(src);
            assert_same(&snap, &fresh);
            // Twice (the buffers now fit): still the same.
            snap.clone_from(src);
            assert_same(&snap, &fresh);
        }
    }
}

#[test]
fn clone_from_of_the_same_sizes_allocates_nothing() {
    // The snapshot of a step taken again after the state changed but
    // not its sizes: every array stays where it was.
    let src1 = level([64, 64], &[5000, 0, 20], 1, true);
    let src2 = level([64, 64], &[5000, 0, 20], 7, true);
    let mut snap = src1.clone();
    let ptrs = |lv: &Level| -> Vec<usize> {
        lv.local
            .iter()
            .flat_map(|p| {
                let mut v: Vec<usize> = p
                    .parts
                    .f64_fields()
                    .iter()
                    .map(|f| f.as_ptr() as usize)
                    .collect();
                v.push(p.parts.id.as_ptr() as usize);
                v.push(p.parts.material.as_ptr() as usize);
                if let Some(g) = &p.grid {
                    v.push(g.mass.as_ptr() as usize);
                    v.push(g.mom_force.as_ptr() as usize);
                    v.push(g.vel.as_ptr() as usize);
                    v.push(g.dil.as_ptr() as usize);
                }
                v
            })
            .collect()
    };
    let before = ptrs(&snap);
    snap.clone_from(&src2);
    assert_same(&snap, &src2.clone());
    assert_eq!(ptrs(&snap), before);
    // And back: the rollback direction.
    let mut live = src2.clone();
    let before = ptrs(&live);
    live.clone_from(&src1);
    assert_same(&live, &src1);
    assert_eq!(ptrs(&live), before);
}
