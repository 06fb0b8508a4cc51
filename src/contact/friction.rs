//! Coulomb friction in the contact problem of a level step (pure: no MPI).
//!
//! **The tangential unknowns.** Each contact particle `p` of the normal
//! problem ([`super::system`]) gets a tangential traction `q_p` along its
//! tangent `τ_p = (−n_y, n_x)` (the normal turned a quarter to the left),
//! so the contact force on node `i` becomes `Σ_p T_ip (λ_p n_p + q_p τ_p) t`.
//! The contact face's tangential displacement relative to the indenter
//! over the step (its **slip**), times `ℓ_p`, is linear in both:
//!
//! ```text
//! s = K_tn λ + K_tt q + r_t,   r_t,p = ℓ_p σ_p
//! w = K_nn λ + K_nt q + r_n    (the normal gaps of super::system)
//! ```
//!
//! with `K_ab,pq = Δt² t Σ_i T_ip T_iq (a_pᵀ C_i b_q) / m_i` (`a, b` each
//! `n` or `τ`; `K_tn = K_ntᵀ`, `K_tt` symmetric positive semidefinite) and
//! `σ_p` the slip the particle's face would make without contact forces:
//! its face-average velocity along `τ_p` times `Δt`, less the indenter's
//! displacement along `τ_p` over the step.
//!
//! **Coulomb's law** at each contact: `|q_p| ≤ μ λ_p`; `s_p = 0` where
//! `|q_p| < μ λ_p` (stick); `q_p = −μ λ_p sign(s_p)` where it slips (the
//! traction opposes the slip). For bounds held fixed (a Tresca law,
//! `lo ≤ q ≤ hi`), the pressures and tractions together minimise one convex
//! quadratic, `½ zᵀ K z + rᵀ z` over `z = (λ, q)` with `λ ≥ 0`, `K = [K_nn
//! K_nt; K_tn K_tt]` symmetric ([`combined`]; Gauss's least constraint over
//! the faces' normal and tangential motion): the bounded problem of
//! [`crate::linsolve::Linsolve::solve_box`]. Coulomb's bound `μ λ` moves
//! with the pressure, so Coulomb friction is not one convex problem: the
//! bounds are taken from the last iterate's pressures and the bounded
//! problem is solved again (a fixed point on the friction bounds, the
//! "Tresca iteration" of Panagiotopoulos' method), from the frictionless
//! pressures, until no pressure or traction changes by more than
//! [`super::ContactOptions::friction_tol`] times the largest pressure. The
//! map contracts when `μ` times the normal–tangential coupling is small,
//! which holds for a rigid indenter on a body of moderate Poisson ratio.
//! Each row's pressure for the next bounds is taken by a secant step
//! ([`bound_step`]) from its last two iterates: on an inclined face a
//! larger bound lowers the pressure (friction lifts the face), and at large
//! `μ` the plain iteration alternates between two states, while the
//! secant lands near the fixed point (the 65° wedge of the main job at
//! `μ = 3`: 2.5 iterations per solve, at most 8, against 6.0 and 144 with
//! plain steps halved once the iteration stalls; at `μ = 0.2`: 4.6 against
//! 8.5). The iteration counts are reported (a cylinder on 3 levels at
//! `μ = 0.5`: 4.1 per solve, at most 16), and a solve that does not
//! settle within [`super::ContactOptions::friction_max_iter`] fails the
//! step. (Solving
//! the normal and tangential problems in turn instead, each with the
//! other's last values, took 9.4 per solve and up to 73 there.)
//!
//! **Scaling.** As the normal system, `K_tt` is scaled to unit diagonal
//! and `ε` is added (two particles per cell make it singular too); the
//! cross block carries both scalings: `K'_nt = S_n K_nt S_t`.

use super::system::{Csr, Record};
use crate::linsolve::SymCsr;
use std::collections::BTreeMap;

/// The tangent of a contact with normal `n`: `n` turned a quarter to the
/// left (`(0, −1)` under a flat indenter gives `(1, 0)`).
#[inline]
pub fn tangent(n: [f64; 2]) -> [f64; 2] {
    [-n[1], n[0]]
}

/// The tangential blocks of a contact problem, scaled.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrictionBlocks {
    /// Which rows of the normal problem take part (a tangential traction
    /// that can move a node), as positions in the normal problem's rows;
    /// tangential row `k` is normal row `rows[k]`.
    pub rows: Vec<usize>,
    /// `K'_tt = S_t K_tt S_t + ε I` (symmetric, both triangles).
    pub k_tt: Csr,
    /// `K'_nt` (normal rows × tangential rows).
    pub k_nt: Csr,
    /// `K'_tn = K'_ntᵀ` (tangential rows × normal rows).
    pub k_tn: Csr,
    /// `r'_t = S_t r_t`.
    pub r: Vec<f64>,
    /// `S_t` (per tangential row).
    pub scale: Vec<f64>,
}

/// Compressed rows from per-row `(column, value)` lists (sorted here).
fn csr(n: usize, mut entries: Vec<Vec<(u32, f64)>>) -> Csr {
    let mut m = Csr {
        n,
        row_ptr: Vec::with_capacity(entries.len() + 1),
        cols: Vec::new(),
        vals: Vec::new(),
    };
    m.row_ptr.push(0);
    for row in &mut entries {
        row.sort_unstable_by_key(|e| e.0);
        for &(j, v) in row.iter() {
            m.cols.push(j);
            m.vals.push(v);
        }
        m.row_ptr.push(m.cols.len());
    }
    m
}

/// Assembles the tangential blocks for the records `recs` whose normal
/// rows are `n_rows` (record indices) with scales `n_scale` (from
/// [`super::system::assemble`]), for a step of `dt`, thickness `thickness`
/// and regularisation `eps`. Sums run in a fixed order (records, nodes by
/// level index), so the blocks depend only on the records.
pub fn assemble(
    recs: &[Record],
    n_rows: &[usize],
    n_scale: &[f64],
    dt: f64,
    thickness: f64,
    eps: f64,
) -> FrictionBlocks {
    let mut row_of_n = vec![usize::MAX; recs.len()];
    for (k, &p) in n_rows.iter().enumerate() {
        row_of_n[p] = k;
    }
    let mut at_node: BTreeMap<[i64; 2], Vec<(usize, f64)>> = BTreeMap::new();
    let mut node_info: BTreeMap<[i64; 2], (f64, [bool; 2])> = BTreeMap::new();
    for &p in n_rows {
        let r = &recs[p];
        for nd in &r.nodes[..r.nn as usize] {
            if nd.t == 0.0 || nd.inv_m == 0.0 || !(nd.free[0] || nd.free[1]) {
                continue;
            }
            let key = [nd.node[1], nd.node[0]];
            at_node.entry(key).or_default().push((p, nd.t));
            node_info.entry(key).or_insert((nd.inv_m, nd.free));
        }
    }
    let dot = |a: [f64; 2], b: [f64; 2], free: [bool; 2]| {
        (if free[0] { a[0] * b[0] } else { 0.0 }) + if free[1] { a[1] * b[1] } else { 0.0 }
    };
    let c = dt * dt * thickness;
    let mut tt: BTreeMap<(usize, usize), f64> = BTreeMap::new();
    let mut nt: BTreeMap<(usize, usize), f64> = BTreeMap::new();
    for (key, list) in &at_node {
        let (inv_m, free) = node_info[key];
        for &(p, tp) in list {
            for &(q, tq) in list {
                let (np, tau_p, tau_q) = (recs[p].n, tangent(recs[p].n), tangent(recs[q].n));
                let w = c * tp * tq * inv_m;
                if p <= q {
                    *tt.entry((p, q)).or_insert(0.0) += w * dot(tau_p, tau_q, free);
                }
                *nt.entry((p, q)).or_insert(0.0) += w * dot(np, tau_q, free);
            }
        }
    }
    let mut row_of_t = vec![usize::MAX; recs.len()];
    let mut rows = Vec::new();
    let mut t_recs = Vec::new();
    for &p in n_rows {
        if tt.get(&(p, p)).is_some_and(|&d| d > 0.0) {
            row_of_t[p] = t_recs.len();
            rows.push(row_of_n[p]);
            t_recs.push(p);
        }
    }
    let m = t_recs.len();
    let scale: Vec<f64> = t_recs.iter().map(|&p| 1.0 / tt[&(p, p)].sqrt()).collect();
    let mut e_tt: Vec<Vec<(u32, f64)>> = vec![Vec::new(); m];
    for (&(p, q), &v) in &tt {
        let (i, j) = (row_of_t[p], row_of_t[q]);
        if i == usize::MAX || j == usize::MAX {
            continue;
        }
        let s = scale[i] * v * scale[j];
        if i == j {
            e_tt[i].push((j as u32, s + eps));
        } else if s != 0.0 {
            e_tt[i].push((j as u32, s));
            e_tt[j].push((i as u32, s));
        }
    }
    let mut e_nt: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n_rows.len()];
    let mut e_tn: Vec<Vec<(u32, f64)>> = vec![Vec::new(); m];
    for (&(p, q), &v) in &nt {
        let (i, j) = (row_of_n[p], row_of_t[q]);
        if i == usize::MAX || j == usize::MAX {
            continue;
        }
        let s = n_scale[i] * v * scale[j];
        if s != 0.0 {
            e_nt[i].push((j as u32, s));
            e_tn[j].push((i as u32, s));
        }
    }
    let r = t_recs
        .iter()
        .zip(&scale)
        .map(|(&p, &s)| s * recs[p].len * recs[p].slip)
        .collect();
    FrictionBlocks {
        rows,
        k_tt: csr(m, e_tt),
        k_nt: csr(n_rows.len(), e_nt),
        k_tn: csr(m, e_tn),
        r,
        scale,
    }
}

/// The matrix of the normal and tangential unknowns together, `[K'_nn
/// K'_nt; K'_tn K'_tt]` (normal rows first, then the tangential rows of
/// `fb`), symmetric: with the friction bounds held fixed, the pressures
/// and tractions minimise one convex quadratic (Gauss's least constraint
/// over the contact faces' normal and tangential motion).
pub fn combined(k_nn: &Csr, fb: &FrictionBlocks) -> SymCsr {
    let (n, m) = (k_nn.n, fb.k_tt.n);
    let mut a = SymCsr {
        n: n + m,
        row_ptr: Vec::with_capacity(n + m + 1),
        cols: Vec::with_capacity(k_nn.cols.len() + 2 * fb.k_nt.cols.len() + fb.k_tt.cols.len()),
        vals: Vec::with_capacity(k_nn.cols.len() + 2 * fb.k_nt.cols.len() + fb.k_tt.cols.len()),
    };
    a.row_ptr.push(0);
    let push = |left: &Csr, right: &Csr, i: usize, a: &mut SymCsr| {
        for e in left.row_ptr[i]..left.row_ptr[i + 1] {
            a.cols.push(left.cols[e]);
            a.vals.push(left.vals[e]);
        }
        for e in right.row_ptr[i]..right.row_ptr[i + 1] {
            a.cols.push(n as u32 + right.cols[e]);
            a.vals.push(right.vals[e]);
        }
        a.row_ptr.push(a.cols.len());
    };
    for i in 0..n {
        push(k_nn, &fb.k_nt, i, &mut a);
    }
    for k in 0..m {
        push(&fb.k_tn, &fb.k_tt, k, &mut a);
    }
    a
}

/// The step `ω` of the next pressures the friction bounds are taken from,
/// `zb ← zb + ω (z − zb)`, for one row of the bound iteration `z = G(zb)`
/// (see the module notes), from the row's last two iterates: `db` the
/// change of `zb` and `dz` the change of `z = G(zb)` between them. Their
/// ratio `s` estimates `G`'s slope along the row, and `1 / (1 − s)` is the
/// step that lands on the fixed point of the line through the two iterates
/// (the secant; Aitken's extrapolation when `s > 0`). A negative slope
/// (a larger bound lowers the pressure: friction's lift on an inclined
/// face, the cause of the iteration's alternation at large `μ`) gives a
/// step below 1, at least 1/64; a positive one a step above 1, for
/// `s < 3/4` only (at most 4), where the line is a safe guide; otherwise
/// (no change, or a steep positive slope) the iteration's own `omega`.
pub fn bound_step(db: f64, dz: f64, omega: f64) -> f64 {
    if db == 0.0 {
        return omega;
    }
    let s = dz / db;
    if s < 0.0 {
        (1.0 / (1.0 - s)).max(1.0 / 64.0)
    } else if s < 0.75 {
        1.0 / (1.0 - s)
    } else {
        omega
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::contact::system::{assemble as assemble_normal, RecNode};

    fn rec(id: u64, n: [f64; 2], slip: f64, nodes: &[([i64; 2], f64, [bool; 2])]) -> Record {
        let mut r = Record {
            id,
            n,
            len: 0.5,
            gap: -1e-3,
            slip,
            owned: true,
            ..Record::default()
        };
        for (k, &(node, t, free)) in nodes.iter().enumerate() {
            r.nodes[k] = RecNode {
                node,
                t,
                inv_m: 0.5 + 0.1 * node[0] as f64,
                free,
            };
        }
        r.nn = nodes.len() as u8;
        r
    }

    /// The blocks against their definition, entry by entry (dense, from the
    /// records directly), with a fixed x component on one node.
    #[test]
    fn blocks_match_the_definition() {
        let s = 0.5f64.sqrt();
        let f = [true, true];
        let recs = vec![
            rec(
                1,
                [0.0, -1.0],
                1e-4,
                &[([0, 0], 0.2, [false, true]), ([1, 0], 0.3, f)],
            ),
            rec(2, [s, -s], -2e-4, &[([1, 0], 0.25, f), ([2, 0], 0.25, f)]),
            rec(3, [-0.6, -0.8], 3e-4, &[([2, 0], 0.1, f), ([2, 1], 0.4, f)]),
        ];
        let (dt, th, eps) = (1e-3, 2.0, 1e-6);
        let pn = assemble_normal(&recs, dt, th, eps);
        let fb = assemble(&recs, &pn.rows, &pn.scale, dt, th, eps);
        assert_eq!(fb.rows, vec![0, 1, 2]);
        let k = |p: usize, q: usize, a: [f64; 2], b: [f64; 2]| -> f64 {
            let mut v = 0.0;
            for np in &recs[p].nodes[..recs[p].nn as usize] {
                for nq in &recs[q].nodes[..recs[q].nn as usize] {
                    if np.node == nq.node {
                        let d = (if np.free[0] { a[0] * b[0] } else { 0.0 })
                            + if np.free[1] { a[1] * b[1] } else { 0.0 };
                        v += dt * dt * th * np.t * nq.t * np.inv_m * d;
                    }
                }
            }
            v
        };
        let dense = |m: &Csr, i: usize, j: usize| -> f64 {
            (m.row_ptr[i]..m.row_ptr[i + 1])
                .find(|&e| m.cols[e] as usize == j)
                .map_or(0.0, |e| m.vals[e])
        };
        for p in 0..3 {
            for q in 0..3 {
                let (tp, tq) = (tangent(recs[p].n), tangent(recs[q].n));
                let want_tt =
                    fb.scale[p] * k(p, q, tp, tq) * fb.scale[q] + if p == q { eps } else { 0.0 };
                let want_nt = pn.scale[p] * k(p, q, recs[p].n, tq) * fb.scale[q];
                assert!(
                    (dense(&fb.k_tt, p, q) - want_tt).abs() < 1e-13,
                    "tt {p} {q}"
                );
                assert!(
                    (dense(&fb.k_nt, p, q) - want_nt).abs() < 1e-13,
                    "nt {p} {q}"
                );
                assert_eq!(dense(&fb.k_tn, q, p), dense(&fb.k_nt, p, q), "tn {q} {p}");
            }
            let want_r = fb.scale[p] * recs[p].len * recs[p].slip;
            assert_eq!(fb.r[p], want_r);
        }
        assert!((dense(&fb.k_tt, 0, 0) - (1.0 + eps)).abs() < 1e-14);
    }

    #[test]
    fn tangent_is_the_normal_turned_left() {
        assert_eq!(tangent([0.0, -1.0]), [1.0, 0.0]);
        assert_eq!(tangent([1.0, 0.0]), [0.0, 1.0]);
    }

    #[test]
    fn the_bound_step_lands_on_the_fixed_point_of_a_linear_map() {
        // z = G(b) = a + s b: from two iterates, one step of
        // `bound_step` lands on the fixed point b* = a / (1 - s).
        for (a, s) in [(2.0, -5.0), (2.0, -0.3), (1.0, 0.5), (3.0, 0.7)] {
            let g = |b: f64| a + s * b;
            let (b0, b1) = (0.0, 1.0);
            let om = bound_step(b1 - b0, g(b1) - g(b0), 0.5);
            let b2 = b1 + om * (g(b1) - b1);
            let fixed = a / (1.0 - s);
            assert!(
                (b2 - fixed).abs() <= 1e-12 * fixed.abs(),
                "a {a} s {s}: {b2} against {fixed}"
            );
        }
        // Steep positive slopes and no change keep the iteration's own step;
        // the steepest negative ones are held at 1/64.
        assert_eq!(bound_step(1.0, 0.9, 0.5), 0.5);
        assert_eq!(bound_step(0.0, 1.0, 0.5), 0.5);
        assert_eq!(bound_step(1.0, -1000.0, 1.0), 1.0 / 64.0);
    }
}
