//! The contact phase of one level step (collective over the simulation's
//! communicator): after the grid update has given every node its velocity
//! without contact (eq. 9) and before the grid-to-particle passes use it.
//!
//! 1. **Detection** (local): on each patch near an indenter, every particle
//!    (owned or copy) whose contact faces, moved by their predicted
//!    displacement, would end the step closer to the indenter than
//!    [`ContactOptions::band_cells`] cells becomes a candidate record: its
//!    predicted gap `b` (negative: it would penetrate; measured where
//!    [`ContactOptions::gap_mode`] says, by default the faces' mean
//!    distance, see [`super::face::gap_offset`]), normal, face length
//!    and face integrals on its nodes with their masses and boundary masks.
//!    A particle that would not reach the indenter in this step is never a
//!    candidate, so an indenter that stops short of the body puts no force
//!    on it (no early contact), and one that moves away faster than the
//!    surface follows releases it at once (no late separation).
//! 2. **Gather**: the records of every rank, sorted by (indenter, id), on
//!    every rank: the contact set lies on the body's surface, so it is small
//!    beside the particles; every rank then assembles the same system.
//! 3. **Solve**: the complementarity problem of [`super::system`] through
//!    [`crate::linsolve`] (PETSc in parallel, or a dense path for small
//!    systems).
//! 4. **Apply**: each patch adds the contact forces of every contact
//!    particle whose face touches its nodes, in record order, to the nodal
//!    force and velocity; copies of a node on several patches get the same
//!    sums in the same order, so they stay bitwise equal.
//!
//! The records, hence the system and its solution, depend only on the
//! particles and the nodal values, which are the same on any number of
//! patches and ranks.

use super::face::{face_weights, gap_offset};
use super::face_axi::face_weights_axi;
use super::friction::{self, tangent};
use super::indenter::Indenter;
use super::system::{assemble, ContactOptions, RecNode, Record};
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::kernel::grid::{mf, vl};
use crate::kernel::{FaceBc, Grid, PatchBoundary};
use crate::linsolve::{Linsolve, SymCsr};
use crate::particles::{Particles, OWNED};
use crate::shape::ShapeKind;

/// A particle touches the indenter at the end of a step when it carries a
/// pressure or ends within this many cells of it while its neighbours carry
/// the load (with two particles per cell, a particle can rest a fraction of
/// a cell's curvature error off a curved indenter, `h² / 8R`, and must
/// still count as part of the contact surface when the pressure is
/// recovered).
const TOUCH: f64 = 2e-3;

/// What the contact phase needs to know about the level it runs on.
#[derive(Clone, Copy, Debug)]
pub struct LevelGeometry {
    /// Level index.
    pub l: usize,
    /// Cell size.
    pub h: f64,
    /// Position of node 0.
    pub origin: [f64; 2],
    /// Extent of the level's computational region `[xlo, ylo, xhi, yhi]`
    /// (the same on every rank).
    pub extent: [f64; 4],
    /// Domain faces and their conditions.
    pub boundary: PatchBoundary,
    /// Weight function (for the face integrals).
    pub shape: ShapeKind,
    /// Nodes with at most this mass are empty.
    pub mass_tol: f64,
    /// The level's step.
    pub dt: f64,
    /// Time at the end of the step.
    pub t_end: f64,
    /// Plane-strain thickness (1 in axisymmetry).
    pub thickness: f64,
    /// Axisymmetry: the face integrals are r-weighted
    /// ([`super::face_axi`]), and forces are per radian.
    pub axi: bool,
    /// The share of an existing penetration this step removes: `min(1,
    /// dt / dt_prev)` with `dt_prev` the level's previous step.
    pub catch_up: f64,
}

/// A local patch as the contact phase sees it.
pub struct PatchRef<'a> {
    /// Its particles (read only).
    pub parts: &'a Particles,
    /// Its grid, after the grid update.
    pub grid: &'a mut Grid,
}

/// A particle in contact after a level step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactPoint {
    /// Global particle id.
    pub id: u64,
    /// Level.
    pub level: u32,
    /// Indenter.
    pub indenter: u32,
    /// Rank holding the particle.
    pub rank: i32,
    /// Owned by its level (false: a copy kept for coupling levels).
    pub owned: bool,
    /// Particle centre at the start of the step.
    pub x: [f64; 2],
    /// Contact normal (unit, from the indenter into the body: the outward
    /// normal of the indenter's surface).
    pub normal: [f64; 2],
    /// Contact pressure (> 0, compressive).
    pub pressure: f64,
    /// Contact-face length (the length of indenter surface the particle
    /// covers).
    pub len: f64,
    /// Tangential traction on the body along the tangent
    /// [`super::friction::tangent`] of `normal` (0 without friction).
    pub traction: f64,
    /// The contact face's tangential displacement relative to the indenter
    /// over the step, along the tangent (m; 0 without friction).
    pub slip: f64,
    /// Whether the surface sticks at the particle: the solve holds its
    /// traction strictly inside Coulomb's bound (a particle without a
    /// pressure multiplier of its own reports its nearest loaded
    /// neighbour's state); false without friction.
    pub stick: bool,
}

/// Where the contact phase's time went and what it solved, summed over the
/// level steps since creation (this rank).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactStats {
    /// Seconds in detection.
    pub detect: f64,
    /// Seconds gathering the records.
    pub gather: f64,
    /// Seconds assembling the system.
    pub assemble: f64,
    /// Seconds in the complementarity solve (linear solves included).
    pub solve: f64,
    /// Seconds applying the forces to the grids.
    pub apply: f64,
    /// Level steps that solved a contact problem.
    pub solves: u64,
    /// Largest number of unknowns of a contact problem.
    pub max_unknowns: usize,
    /// Largest number of particles in contact after a solve.
    pub max_contacts: usize,
    /// Active-set iterations, summed.
    pub pivots: u64,
    /// Linear solves, summed.
    pub linear_solves: u64,
    /// Linear solves done with PETSc.
    pub petsc_solves: u64,
    /// KSP iterations, summed.
    pub ksp_iterations: u64,
    /// Largest number of KSP iterations of one linear solve.
    pub ksp_iterations_max: u64,
    /// Level steps that solved a contact problem with friction.
    pub friction_solves: u64,
    /// Friction-bound iterations of those, summed.
    pub friction_iterations: u64,
    /// Most friction-bound iterations of one frictional solve.
    pub friction_iterations_max: u64,
}

/// The contact state of one level after its last step.
#[derive(Clone, Debug, Default)]
pub struct LevelContact {
    /// The particles in contact (every rank holds the whole list), in
    /// (indenter, id) order.
    pub points: Vec<ContactPoint>,
    /// Force on each indenter from this level's owned particles in its
    /// last step, per metre of thickness (pressure × face length; copies are
    /// not counted, their owners are).
    pub force: Vec<[f64; 2]>,
    /// The impulse on each indenter from this level's owned particles since
    /// the start of the current coarse step (force × step, summed over the
    /// level's substeps).
    pub impulse: Vec<[f64; 2]>,
    /// Time of the end of the level's last step.
    pub time: f64,
    /// The level's last step (0 before the first).
    pub last_dt: f64,
    /// Energy dissipated by friction at each indenter by this level's owned
    /// particles since creation, per metre of thickness (J/m).
    pub dissipation: Vec<f64>,
    /// Time and work, since creation.
    pub stats: ContactStats,
}

/// What a level step needs to run its contact phase.
pub struct LevelStepContact<'a> {
    /// The indenters.
    pub indenters: &'a [Indenter],
    /// Options.
    pub opts: &'a ContactOptions,
    /// The complementarity solver.
    pub solver: &'a mut Linsolve,
    /// The level's contact state, written by the phase.
    pub out: &'a mut LevelContact,
    /// Time at the end of the level step.
    pub t_end: f64,
    /// Plane-strain thickness.
    pub thickness: f64,
}

/// The contact pressure (and, with friction, the tangential traction) of
/// each touching record recovered from the nodal contact forces. With more
/// contact particles than nodes along the surface (two per cell), the
/// multipliers of the complementarity problem are not unique: the discrete
/// pressure space is richer than the trace of the nodal velocities (the
/// inf–sup condition of mixed methods fails), and pressure patterns that
/// alternate from particle to particle put no net force on any node. The
/// nodal forces `F_i = Σ_p T_ip (λ_p n_p + q_p τ_p)` are unique. The
/// reported pressure is their lumped projection onto the touching faces:
/// the nodal pressure `p_i = F_i · n̄_i / Σ_{p touching} T_ip` (`n̄_i` the
/// `T`-weighted mean normal), averaged over each face, `P_p = Σ_i T_ip p_i
/// / ℓ_p`; the traction likewise along the mean tangent `τ̄_i` (the normal
/// turned left). A uniform multiplier field is reproduced exactly, and
/// `Σ_p P_p ℓ_p` equals the total normal force when the normals agree.
/// Without friction (`q = None`) the tractions are zero.
fn recovered(
    recs: &[Record],
    lambda: &[f64],
    q: Option<&[f64]>,
    touching: &[bool],
) -> (Vec<f64>, Vec<f64>) {
    use std::collections::BTreeMap;
    // Per node: force (x, y), touching length, T-weighted normal.
    let mut nodes: BTreeMap<[i64; 2], [f64; 5]> = BTreeMap::new();
    for (k, r) in recs.iter().enumerate() {
        let qk = q.map_or(0.0, |q| q[k]);
        if !(touching[k] || lambda[k] > 0.0 || qk != 0.0) {
            continue;
        }
        let tau = tangent(r.n);
        for nd in &r.nodes[..r.nn as usize] {
            let e = nodes.entry(nd.node).or_insert([0.0; 5]);
            e[0] += nd.t * lambda[k] * r.n[0];
            e[1] += nd.t * lambda[k] * r.n[1];
            if q.is_some() {
                e[0] += nd.t * qk * tau[0];
                e[1] += nd.t * qk * tau[1];
            }
            if touching[k] {
                e[2] += nd.t;
                e[3] += nd.t * r.n[0];
                e[4] += nd.t * r.n[1];
            }
        }
    }
    let mut pressure = vec![0.0; recs.len()];
    let mut traction = vec![0.0; recs.len()];
    for (k, r) in recs.iter().enumerate() {
        if !touching[k] {
            continue;
        }
        let (mut acc, mut acc_t) = (0.0, 0.0);
        for nd in &r.nodes[..r.nn as usize] {
            let e = nodes[&nd.node];
            let nl = (e[3] * e[3] + e[4] * e[4]).sqrt();
            if e[2] > 0.0 && nl > 0.0 {
                let pi = (e[0] * e[3] + e[1] * e[4]) / nl / e[2];
                acc += nd.t * pi;
                if q.is_some() {
                    // τ̄ = (−n̄_y, n̄_x).
                    let ti = (-e[0] * e[4] + e[1] * e[3]) / nl / e[2];
                    acc_t += nd.t * ti;
                }
            }
        }
        pressure[k] = (acc / r.len).max(0.0);
        traction[k] = acc_t / r.len;
    }
    (pressure, traction)
}

/// Whether the surface sticks at record `k`: for a record with a pressure,
/// whether the solve holds its traction strictly inside Coulomb's bound;
/// for one without (with two particles per cell, one of a pair may carry
/// its cell's load alone), the state of the nearest record of the same
/// indenter that has a pressure (its slip differs from that one's only by
/// their face weights on the nodes they share).
fn stick_state(recs: &[Record], lambda: &[f64], stick: &[bool], k: usize) -> bool {
    if lambda[k] > 0.0 {
        return stick[k];
    }
    let c = recs[k].c;
    let mut best: Option<(f64, usize)> = None;
    for (j, r) in recs.iter().enumerate() {
        if lambda[j] > 0.0 && r.indenter == recs[k].indenter {
            let d = (r.c[0] - c[0]).powi(2) + (r.c[1] - c[1]).powi(2);
            if best.map_or(true, |(bd, _)| d < bd) {
                best = Some((d, j));
            }
        }
    }
    best.is_some_and(|(_, j)| stick[j])
}

/// The friction part of a level step's solve (see [`super::friction`]):
/// from the frictionless normal solution `x` (scaled pressures of the
/// normal problem `pr`), solves the pressures and tangential tractions
/// together as one bounded problem (pressures `≥ 0`, tractions within
/// `±μ λ` of the previous iterate's pressures), until no pressure or
/// traction changes by more than `friction_tol` times the largest pressure.
/// On return `x` holds the normal solution, `gaps` the normal problem's
/// scaled end-of-step gaps, and `q`, `slip` and `stick` (per record) the
/// tangential tractions, the faces' end-of-step slips and whether the
/// traction lies strictly inside its bound (records with a pressure).
#[allow(clippy::too_many_arguments)]
fn solve_friction(
    recs: &[Record],
    pr: &super::system::ContactProblem,
    x: &mut Vec<f64>,
    gaps: &mut Vec<f64>,
    indenters: &[Indenter],
    opts: &ContactOptions,
    geo: &LevelGeometry,
    comm: &Comm,
    solver: &mut Linsolve,
    st: &mut ContactStats,
    q: &mut [f64],
    slip: &mut [f64],
    stick: &mut [bool],
) -> Result<()> {
    let fb = friction::assemble(
        recs,
        &pr.rows,
        &pr.scale,
        geo.dt,
        geo.thickness,
        opts.regularization,
    );
    let m = fb.rows.len();
    if m == 0 {
        gaps.clear();
        gaps.extend_from_slice(solver.gaps());
        return Ok(());
    }
    let n = pr.rows.len();
    let kc = friction::combined(&pr.k, &fb);
    let mut rc = pr.r.clone();
    rc.extend_from_slice(&fb.r);
    let mu: Vec<f64> = fb
        .rows
        .iter()
        .map(|&row| indenters[recs[pr.rows[row]].indenter as usize].friction())
        .collect();
    let (mut lo, mut hi) = (vec![0.0; n + m], vec![f64::INFINITY; n + m]);
    let mut z = x.clone();
    z.resize(n + m, 0.0);
    let mut prev = z.clone();
    // The tangential bounds ±μλ from the pressures `zb` (each particle's
    // own multiplier: with two particles per cell, one of a pair may carry
    // a cell's load and the other none, and only the first has friction).
    // `zb` moves towards each iterate's pressures by a step per row from
    // the row's last two iterates (`friction::bound_step`: the secant's
    // fixed point; without a usable slope, all the way, or half-way once
    // the iteration stops contracting). Finite μ only: under μ = ∞ a bound
    // is infinite or zero, and follows the last pressures.
    // Under μ = ∞ a particle sticks where it has pressure, and keeps
    // sticking while it still touches (its end gap within `TOUCH` cells)
    // after its pressure has gone to zero: the limit of a large μ, where a
    // particle slips at `μλ` with `λ → 0` (without it, a particle that loses
    // its pressure once stuck and regains it once free makes the iteration
    // alternate).
    // A particle whose state changes twice within one solve (stuck, free,
    // stuck; or the reverse) sticks from then on. At μ = ∞ a particle can
    // alternate between sticking with no pressure and a face that opens
    // just past `TOUCH` under its tangential traction, and slipping freely
    // with a pressure, which μ = ∞ forbids: neither state is consistent,
    // and the iteration would cycle between them. The large-μ limit of
    // that particle is the first: a pressure that tends to zero while
    // `μλ` stays finite (without this rule the main job at μ = ∞ cycles
    // so at step 2194, 440 nm).
    let touch =
        |w: &[f64], row: usize| w[row] / pr.scale[row] / recs[pr.rows[row]].len <= TOUCH * geo.h;
    let mut flips = vec![0u8; m];
    let mut bounds =
        |zb: &[f64], z: &[f64], w: &[f64], lo: &mut [f64], hi: &mut [f64], count: bool| {
            for k in 0..m {
                let row = fb.rows[k];
                let b = if mu[k] == 0.0 {
                    0.0
                } else if mu[k].is_infinite() {
                    let stuck = hi[n + k] == f64::INFINITY;
                    let mut stick =
                        flips[k] >= 2 || pr.scale[row] * z[row] > 0.0 || stuck && touch(w, row);
                    if count && stick != stuck {
                        // The second change of state locks the particle stuck.
                        flips[k] = flips[k].saturating_add(1);
                        stick |= flips[k] >= 2;
                    }
                    if stick {
                        f64::INFINITY
                    } else {
                        0.0
                    }
                } else {
                    let lam = pr.scale[row] * zb[row];
                    if lam > 0.0 {
                        mu[k] * lam / fb.scale[k]
                    } else {
                        0.0
                    }
                };
                lo[n + k] = -b;
                hi[n + k] = b;
            }
        };
    let mut zb = z.clone();
    let mut zb_prev = z.clone();
    let mut w: Vec<f64> = solver.gaps().to_vec();
    let mut omega = 1.0;
    let mut last_change = f64::INFINITY;
    let mut iters: u64 = 0;
    loop {
        iters += 1;
        bounds(&zb, &z, &w, &mut lo, &mut hi, iters > 1);
        let rep = solver.solve_box(Some(comm), &kc, &rc, &lo, &hi, &mut z)?;
        w.clear();
        w.extend_from_slice(&solver.box_residual()[..n]);
        st.pivots += rep.pivots as u64;
        st.linear_solves += (rep.direct_solves + rep.petsc_solves) as u64;
        st.petsc_solves += rep.petsc_solves as u64;
        st.ksp_iterations += rep.ksp_iterations as u64;
        st.ksp_iterations_max = st.ksp_iterations_max.max(rep.ksp_iterations_max as u64);
        st.max_unknowns = st.max_unknowns.max(n + m);
        let mut lmax = 0.0f64;
        let mut change = 0.0f64;
        for i in 0..n {
            lmax = lmax.max(pr.scale[i] * z[i]);
            change = change.max((pr.scale[i] * (z[i] - prev[i])).abs());
        }
        for k in 0..m {
            change = change.max((fb.scale[k] * (z[n + k] - prev[n + k])).abs());
        }
        if change <= opts.friction_tol * lmax {
            break;
        }
        if iters >= opts.friction_max_iter as u64 {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "the frictional contact solve on level {} did not settle within friction_max_iter = {} iterations: the last one changed a pressure or traction by {:.3e} of the largest pressure {:.3e} Pa (tolerance {:.1e}); lower the step or raise GIMLET_CONTACT_FRICTION_MAX_ITER",
                    geo.l,
                    opts.friction_max_iter,
                    if lmax > 0.0 { change / lmax } else { change },
                    lmax,
                    opts.friction_tol
                ),
            ));
        }
        if change >= 0.9 * last_change {
            omega = 0.5;
        }
        last_change = change;
        for i in 0..n {
            let om = if iters >= 2 {
                friction::bound_step(zb[i] - zb_prev[i], z[i] - prev[i], omega)
            } else {
                omega
            };
            zb_prev[i] = zb[i];
            zb[i] += om * (z[i] - zb[i]);
        }
        prev.clone_from(&z);
    }
    st.friction_solves += 1;
    st.friction_iterations += iters;
    st.friction_iterations_max = st.friction_iterations_max.max(iters);
    gaps.clone_from(&w);
    // The tractions within the bounds of the final pressures (they moved by
    // at most the tolerance; the slips are those of the solve).
    bounds(&z, &z, &w, &mut lo, &mut hi, false);
    let w = solver.box_residual();
    for k in 0..m {
        let p = pr.rows[fb.rows[k]];
        let zt = z[n + k].clamp(lo[n + k], hi[n + k]);
        q[p] = fb.scale[k] * zt;
        slip[p] = w[n + k] / fb.scale[k] / recs[p].len;
        stick[p] = hi[n + k] > 0.0 && zt.abs() < hi[n + k] * (1.0 - 1e-9);
    }
    x.truncate(n);
    x.copy_from_slice(&z[..n]);
    Ok(())
}

/// Whether the components of node `(i, j)` are free of the domain faces'
/// conditions (the node ranges `kernel::apply_bc` constrains).
fn free_mask(bnd: &PatchBoundary, i: i64, j: i64) -> [bool; 2] {
    let mut free = [true, true];
    for (side, face) in bnd.faces.iter().enumerate() {
        let Some(face) = face else { continue };
        if face.bc == FaceBc::Free {
            continue;
        }
        let on = match side {
            0 => i <= face.node,
            1 => i >= face.node,
            2 => j <= face.node,
            _ => j >= face.node,
        };
        if !on {
            continue;
        }
        let normal_x = side < 2;
        if face.bc == FaceBc::Fixed || normal_x {
            free[0] = false;
        }
        if face.bc == FaceBc::Fixed || !normal_x {
            free[1] = false;
        }
    }
    free
}

fn overlaps(a: [f64; 4], b: [f64; 4]) -> bool {
    a[0] <= b[2] && b[0] <= a[2] && a[1] <= b[3] && b[1] <= a[3]
}

fn grow(b: [f64; 4], d: f64) -> [f64; 4] {
    [b[0] - d, b[1] - d, b[2] + d, b[3] + d]
}

/// Local storage index of level node `(i, j)` in `g`, if stored.
fn local_index(g: &Grid, i: i64, j: i64) -> Option<usize> {
    let (a, b) = (i - g.lo[0], j - g.lo[1]);
    (a >= 0 && b >= 0 && (a as usize) < g.n[0] && (b as usize) < g.n[1])
        .then(|| b as usize * g.n[0] + a as usize)
}

/// The candidate records of one patch against one indenter.
fn detect(
    p: &PatchRef,
    geo: &LevelGeometry,
    ind: &Indenter,
    k_ind: u32,
    rank: i32,
    opts: &ContactOptions,
    out: &mut Vec<Record>,
) {
    let band = opts.band_cells * geo.h;
    let g = &*p.grid;
    let at = ind.at(geo.t_end);
    // The indenter's displacement over the step (for the slip).
    let moved = if ind.friction() > 0.0 {
        let t0 = ind.tip(geo.t_end - geo.dt);
        [at.tip()[0] - t0[0], at.tip()[1] - t0[1]]
    } else {
        [0.0; 2]
    };
    let ib = ind.bbox(geo.t_end);
    let gb = [
        geo.origin[0] + g.lo[0] as f64 * geo.h,
        geo.origin[1] + g.lo[1] as f64 * geo.h,
        geo.origin[0] + (g.lo[0] + g.n[0] as i64 - 1) as f64 * geo.h,
        geo.origin[1] + (g.lo[1] + g.n[1] as i64 - 1) as f64 * geo.h,
    ];
    if !overlaps(grow(ib, geo.h), gb) {
        return;
    }
    // How far a face can move in the step: the fastest node of the patch.
    let vmax = g
        .vel
        .iter()
        .map(|n| n.0[vl::VX].abs().max(n.0[vl::VY].abs()))
        .fold(0.0f64, f64::max)
        * std::f64::consts::SQRT_2;
    let reach = geo.dt * vmax + band;
    let q = p.parts;
    for i in 0..q.len() {
        let (c, half) = ([q.x[i], q.y[i]], [q.lpx[i], q.lpy[i]]);
        let rb = [
            c[0] - half[0],
            c[1] - half[1],
            c[0] + half[0],
            c[1] + half[1],
        ];
        if !overlaps(grow(rb, reach), ib) {
            continue;
        }
        let gap = at.gap_rect(c, half);
        if gap.dist > reach {
            continue;
        }
        let n = gap.normal;
        let fw = if geo.axi {
            face_weights_axi(geo.shape, geo.origin, geo.h, c, half, n, ib)
        } else {
            face_weights(geo.shape, geo.origin, geo.h, c, half, n, ib)
        };
        if fw.len.is_nan() || fw.len <= 0.0 {
            continue;
        }
        let mut rec = Record {
            id: q.id[i],
            indenter: k_ind,
            rank,
            owned: q.copy[i] == OWNED,
            c,
            n,
            len: fw.len,
            ..Record::default()
        };
        // The face's velocity: the face average of the nodal velocities.
        let mut vf = [0.0; 2];
        for b in 0..3 {
            for a in 0..3 {
                let t = fw.t[a + 3 * b];
                if t == 0.0 {
                    continue;
                }
                let (ni, nj) = (fw.base[0] + a as i64, fw.base[1] + b as i64);
                let Some(k) = local_index(g, ni, nj) else {
                    // The face leaves the patch grid: the particle is about
                    // to migrate; its stencil is checked by the kernel.
                    continue;
                };
                let m = g.mass[k];
                let v = g.vel[k].0;
                vf[0] += t * v[vl::VX];
                vf[1] += t * v[vl::VY];
                rec.nodes[rec.nn as usize] = RecNode {
                    node: [ni, nj],
                    t,
                    inv_m: if m > geo.mass_tol { 1.0 / m } else { 0.0 },
                    free: free_mask(&geo.boundary, ni, nj),
                };
                rec.nn += 1;
            }
        }
        // A penetration left from earlier steps (the contact faces end on
        // the indenter, the rectangles within round-off of it) is taken
        // out at the rate of a full step: a much shorter step (the last
        // one before an output time) removes only its share, rather than
        // turning it into a velocity of gap / dt.
        // Measured where `gap_mode` says, except against a sharp vertex (no
        // surface for the faces to lie along: the nearest point).
        let dist = if gap.vertex {
            gap.dist
        } else {
            gap.dist + gap_offset(opts.gap_mode, n, half)
        };
        let g0 = if dist < 0.0 {
            dist * geo.catch_up
        } else {
            dist
        };
        rec.gap = g0 + geo.dt * (n[0] * vf[0] + n[1] * vf[1]) / fw.len;
        if ind.friction() > 0.0 {
            let tau = tangent(n);
            rec.slip = geo.dt * (tau[0] * vf[0] + tau[1] * vf[1]) / fw.len
                - (tau[0] * moved[0] + tau[1] * moved[1]);
        }
        if rec.gap < band {
            out.push(rec);
        }
    }
}

/// Runs the contact phase of a level step on the local patches `patches`
/// against `indenters` (collective; see the module notes). Writes the
/// level's contact state to `out`.
#[allow(clippy::too_many_arguments)]
pub fn resolve(
    patches: &mut [PatchRef],
    geo: &LevelGeometry,
    comm: &Comm,
    indenters: &[Indenter],
    opts: &ContactOptions,
    solver: &mut Linsolve,
    out: &mut LevelContact,
) -> Result<()> {
    out.points.clear();
    out.force.clear();
    out.force.resize(indenters.len(), [0.0; 2]);
    out.impulse.resize(indenters.len(), [0.0; 2]);
    out.time = geo.t_end;
    out.last_dt = geo.dt;
    // Levels no indenter can reach do nothing, on every rank alike (the
    // decision uses only data every rank has).
    let near = indenters
        .iter()
        .any(|ind| overlaps(grow(ind.bbox(geo.t_end), 2.0 * geo.h), geo.extent));
    if !near {
        return Ok(());
    }
    let clock = std::time::Instant::now;
    let t0 = clock();
    let mut recs = Vec::new();
    for (k, ind) in indenters.iter().enumerate() {
        for p in patches.iter() {
            detect(p, geo, ind, k as u32, comm.rank(), opts, &mut recs);
        }
    }
    let t1 = clock();
    let mut bytes = Vec::new();
    for r in &recs {
        r.encode(&mut bytes);
    }
    let all = comm.allgatherv_bytes(&bytes)?;
    let mut recs = Record::decode_all(&all).ok_or_else(|| {
        Error::new(
            Status::Internal,
            "contact records arrived damaged from another rank",
        )
    })?;
    recs.sort_by_key(|r| (r.indenter, r.id));

    let t2 = clock();
    let st = &mut out.stats;
    st.detect += (t1 - t0).as_secs_f64();
    st.gather += (t2 - t1).as_secs_f64();
    if recs.iter().all(|r| r.gap >= 0.0) {
        // No candidate would penetrate: no pressure anywhere.
        return Ok(());
    }
    let pr = assemble(&recs, geo.dt, geo.thickness, opts.regularization);
    let t3 = clock();
    st.assemble += (t3 - t2).as_secs_f64();
    let a = SymCsr {
        n: pr.k.n,
        row_ptr: pr.k.row_ptr.clone(),
        cols: pr.k.cols.clone(),
        vals: pr.k.vals.clone(),
    };
    let mut x = Vec::new();
    let rep = solver.solve_lcp(comm, &a, &pr.r, &mut x)?;
    st.solves += 1;
    st.max_unknowns = st.max_unknowns.max(pr.rows.len());
    st.pivots += rep.pivots as u64;
    st.linear_solves += (rep.direct_solves + rep.petsc_solves) as u64;
    st.petsc_solves += rep.petsc_solves as u64;
    st.ksp_iterations += rep.ksp_iterations as u64;
    st.ksp_iterations_max = st.ksp_iterations_max.max(rep.ksp_iterations_max as u64);
    // Friction: only when an indenter with friction has a candidate (the
    // frictionless path is left as it was, bit for bit).
    let frictional = recs
        .iter()
        .any(|r| indenters[r.indenter as usize].friction() > 0.0);
    let mut q = vec![0.0; if frictional { recs.len() } else { 0 }];
    let mut slip = q.clone();
    let mut stick = vec![false; q.len()];
    let mut friction_gaps = Vec::new();
    if frictional {
        solve_friction(
            &recs,
            &pr,
            &mut x,
            &mut friction_gaps,
            indenters,
            opts,
            geo,
            comm,
            solver,
            st,
            &mut q,
            &mut slip,
            &mut stick,
        )?;
    }
    let t4 = clock();
    st.solve += (t4 - t3).as_secs_f64();
    // The multipliers, checked.
    let t = geo.thickness;
    let mut lambda = vec![0.0; recs.len()];
    for (row, &p) in pr.rows.iter().enumerate() {
        let pp = pr.scale[row] * x[row];
        if !pp.is_finite() {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "the contact pressure of particle id {} on level {} is not finite",
                    recs[p].id, geo.l
                ),
            ));
        }
        if pp > 0.0 {
            lambda[p] = pp;
        }
    }
    if let Some(k) = q.iter().position(|v| !v.is_finite()) {
        return Err(Error::new(
            Status::Unstable,
            format!(
                "the friction traction of particle id {} on level {} is not finite",
                recs[k].id, geo.l
            ),
        ));
    }
    // The particles touching the indenter at the end of the step (see
    // `TOUCH`).
    let ws = if frictional {
        &friction_gaps[..]
    } else {
        solver.gaps()
    };
    let mut touching = vec![false; recs.len()];
    for (row, &p) in pr.rows.iter().enumerate() {
        let end_gap = ws
            .get(row)
            .map_or(f64::INFINITY, |w| w / pr.scale[row] / recs[p].len);
        touching[p] = lambda[p] > 0.0 || end_gap <= TOUCH * geo.h;
    }
    let (pressure, traction) = recovered(
        &recs,
        &lambda,
        frictional.then_some(q.as_slice()),
        &touching,
    );
    if out.dissipation.len() < indenters.len() {
        out.dissipation.resize(indenters.len(), 0.0);
    }
    for (k, r) in recs.iter().enumerate() {
        if r.owned && lambda[k] > 0.0 {
            let f = &mut out.force[r.indenter as usize];
            f[0] -= lambda[k] * r.len * r.n[0];
            f[1] -= lambda[k] * r.len * r.n[1];
        }
        if frictional && r.owned && q[k] != 0.0 {
            let tau = tangent(r.n);
            let f = &mut out.force[r.indenter as usize];
            f[0] -= q[k] * r.len * tau[0];
            f[1] -= q[k] * r.len * tau[1];
            out.dissipation[r.indenter as usize] += (q[k] * slip[k]).abs() * r.len;
        }
        if !(touching[k] && pressure[k] > 0.0) {
            continue;
        }
        out.points.push(ContactPoint {
            id: r.id,
            level: geo.l as u32,
            indenter: r.indenter,
            rank: r.rank,
            owned: r.owned,
            x: r.c,
            normal: r.n,
            pressure: pressure[k],
            len: r.len,
            traction: traction[k],
            slip: if frictional { slip[k] } else { 0.0 },
            stick: frictional && stick_state(&recs, &lambda, &stick, k),
        });
    }
    for (i, f) in out.force.iter().enumerate() {
        out.impulse[i][0] += f[0] * geo.dt;
        out.impulse[i][1] += f[1] * geo.dt;
    }
    out.stats.max_contacts = out.stats.max_contacts.max(out.points.len());
    let pressure = lambda;
    // Forces onto every local grid holding the nodes, in record order.
    for p in patches.iter_mut() {
        let g = &mut *p.grid;
        for (k, (r, &pp)) in recs.iter().zip(&pressure).enumerate() {
            let qk = if frictional { q[k] } else { 0.0 };
            if pp <= 0.0 && qk == 0.0 {
                continue;
            }
            let tau = tangent(r.n);
            for nd in &r.nodes[..r.nn as usize] {
                if nd.inv_m == 0.0 {
                    continue;
                }
                let Some(k) = local_index(g, nd.node[0], nd.node[1]) else {
                    continue;
                };
                let s = nd.t * pp * t;
                let mut f = [
                    if nd.free[0] { s * r.n[0] } else { 0.0 },
                    if nd.free[1] { s * r.n[1] } else { 0.0 },
                ];
                if qk != 0.0 {
                    let s = nd.t * qk * t;
                    if nd.free[0] {
                        f[0] += s * tau[0];
                    }
                    if nd.free[1] {
                        f[1] += s * tau[1];
                    }
                }
                let mfk = &mut g.mom_force[k].0;
                mfk[mf::FX] += f[0];
                mfk[mf::FY] += f[1];
                let v = &mut g.vel[k].0;
                v[vl::VX] += geo.dt * f[0] * nd.inv_m;
                v[vl::VY] += geo.dt * f[1] * nd.inv_m;
            }
        }
    }
    out.stats.apply += clock().elapsed_since(t4);
    Ok(())
}

/// `Instant` arithmetic in seconds.
trait Since {
    fn elapsed_since(self, t: std::time::Instant) -> f64;
}

impl Since for std::time::Instant {
    fn elapsed_since(self, t: std::time::Instant) -> f64 {
        (self - t).as_secs_f64()
    }
}
