//! The contact problem of one level step, assembled from the contact
//! records every rank contributes (pure: no MPI).
//!
//! **Eq. 11 in least-constraint form.** Without contact, a level step gives
//! each node `i` the velocity `v⁰_i = (p⁰_i + F⁰_i Δt)/m_i` (eq. 9). A
//! contact particle `p` (normal `n_p` from the indenter into the body,
//! contact-face integrals `T_ip`, face length `ℓ_p`; see
//! [`super::face`]) would end the step with the gap `b_p` between its
//! rectangle and the indenter (`b_p < 0`: it would penetrate). Unknown
//! pressures `P_q ≥ 0` add the nodal forces `F^c_i = Σ_q T_iq P_q n_q t`
//! (eq. 10, `t` the thickness), hence the velocities `Δv_i = Δt C_i
//! F^c_i / m_i` (`C_i` removes the components a boundary condition fixes).
//! The contact face of `p` moves with the face average of the nodal
//! velocities, `Σ_i T_ip v_i / ℓ_p`, so its end-of-step gap becomes
//!
//! ```text
//! b_p + Δt² t Σ_q [Σ_i T_ip T_iq (n_p · C_i n_q) / m_i] P_q / ℓ_p
//! ```
//!
//! Multiplied by `ℓ_p`: `w = K P + r` with the **symmetric positive
//! semidefinite** `K_pq = Δt² t Σ_i T_ip T_iq (n_pᵀ C_i n_q) / m_i` and
//! `r_p = ℓ_p b_p`. The contact conditions (compressive pressures only,
//! no penetration, and no pressure where the particle separates) are the
//! linear complementarity problem `P ≥ 0, w ≥ 0, P_p w_p = 0`: the
//! Karush–Kuhn–Tucker conditions of Gauss's least-constraint principle,
//! the smallest change of the nodal kinetic energy that keeps every
//! contact face out of the indenter. Compared with the paper's form (the
//! particle-centre velocity `Σ_i S̄_ip v_i` on the left of eq. 11), the face
//! velocity makes the system symmetric: the compressive-only problem is then
//! a convex quadratic program with a unique nodal response, which a
//! pivoting method solves in a few steps, where the unsymmetric form can
//! cycle.
//!
//! **Scaling and regularisation.** With more contact particles than nodes
//! along the surface (two per cell with 2×2 particles per cell), `K` is
//! singular: some pressure patterns put no net force on any node. The
//! system is scaled to unit diagonal (`K' = S K S`, `S = diag(K)^{-1/2}`)
//! and `ε I` is added (`ε` = [`ContactOptions::regularization`]): the
//! problem becomes positive definite, and among the pressures that give the
//! same nodal forces the smallest is chosen; the end-of-step penetration
//! this leaves is `ε` times what the particle's own pressure corrects,
//! a vanishing fraction of a step's approach.

use std::collections::BTreeMap;

/// Options of the contact algorithm.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactOptions {
    /// `ε` added to the unit diagonal of the scaled system (see the module
    /// notes); default `1e-6`.
    pub regularization: f64,
    /// Particles whose predicted gap is below this many cells of their level
    /// enter the problem as candidates (those with a positive gap carry no
    /// pressure unless their neighbours' contact pushes them into the
    /// indenter); default `0.05`.
    pub band_cells: f64,
    /// Where a contact particle's gap is measured (see
    /// [`super::face::gap_offset`]): 1 (the default) the mean over its
    /// loaded faces, 0 the rectangle's nearest point (no point of the
    /// domain inside the indenter: the main job's load 6 % high at 3.7
    /// particles across the contact half-width), 2 the middle of its face
    /// in y.
    pub gap_mode: u8,
    /// Relative tolerance of the friction-bound iteration of a frictional
    /// solve (see [`super::friction`]): it stops when no
    /// pressure or traction changes by more than this times the largest
    /// pressure; default `1e-8`, bounds `(0, 0.1]`.
    pub friction_tol: f64,
    /// Most friction-bound iterations of a frictional solve before the step
    /// fails; default 200, bounds `1..=10000`.
    pub friction_max_iter: u32,
}

impl Default for ContactOptions {
    fn default() -> Self {
        ContactOptions {
            regularization: 1e-6,
            band_cells: 0.05,
            gap_mode: 1,
            friction_tol: 1e-8,
            friction_max_iter: 200,
        }
    }
}

/// One stencil node of a contact record.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RecNode {
    /// Level node indices.
    pub node: [i64; 2],
    /// Face integral `T_ip` (length units).
    pub t: f64,
    /// `1/m_i`, or 0 for a node the grid treats as empty.
    pub inv_m: f64,
    /// Whether the x and y components are free (not fixed by a boundary
    /// condition).
    pub free: [bool; 2],
}

/// A particle that may touch an indenter during the step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Record {
    /// Global particle id.
    pub id: u64,
    /// Indenter index.
    pub indenter: u32,
    /// Rank holding the particle.
    pub rank: i32,
    /// Whether the particle is owned by this level (not a copy kept for
    /// coupling levels).
    pub owned: bool,
    /// Particle centre at the start of the step.
    pub c: [f64; 2],
    /// Contact normal, unit, from the indenter into the body.
    pub n: [f64; 2],
    /// Contact-face length `ℓ_p`.
    pub len: f64,
    /// Predicted end-of-step gap `b_p` without contact.
    pub gap: f64,
    /// Predicted tangential slip of the contact face relative to the
    /// indenter over the step without contact (m, along
    /// [`super::friction::tangent`]); used only with friction.
    pub slip: f64,
    /// Nodes with a nonzero face integral (the first `nn`).
    pub nodes: [RecNode; 9],
    /// Number of nodes used.
    pub nn: u8,
}

/// Bytes of a record's fixed part in [`Record::encode`].
const HEAD: usize = 8 * 10;
/// Bytes per node.
const NODE: usize = 32;

impl Record {
    /// Appends the record to `out` (little-endian; [`Record::decode_all`]
    /// reads it back).
    pub fn encode(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.id.to_le_bytes());
        out.extend_from_slice(&self.indenter.to_le_bytes());
        out.extend_from_slice(&self.rank.to_le_bytes());
        let flags = (self.owned as u64) | ((self.nn as u64) << 8);
        out.extend_from_slice(&flags.to_le_bytes());
        for v in [
            self.c[0], self.c[1], self.n[0], self.n[1], self.len, self.gap, self.slip,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for nd in &self.nodes[..self.nn as usize] {
            out.extend_from_slice(&(nd.node[0] as i32).to_le_bytes());
            out.extend_from_slice(&(nd.node[1] as i32).to_le_bytes());
            out.extend_from_slice(&nd.t.to_le_bytes());
            out.extend_from_slice(&nd.inv_m.to_le_bytes());
            let f = (nd.free[0] as u64) | ((nd.free[1] as u64) << 1);
            out.extend_from_slice(&f.to_le_bytes());
        }
    }

    /// Decodes every record of `b` (a concatenation of [`Record::encode`]
    /// outputs); `None` when the bytes are not such a concatenation.
    pub fn decode_all(b: &[u8]) -> Option<Vec<Record>> {
        let u64_at = |k: usize| -> Option<u64> {
            Some(u64::from_le_bytes(b.get(k..k + 8)?.try_into().ok()?))
        };
        let f64_at = |k: usize| u64_at(k).map(f64::from_bits);
        let i32_at = |k: usize| -> Option<i32> {
            Some(i32::from_le_bytes(b.get(k..k + 4)?.try_into().ok()?))
        };
        let mut out = Vec::new();
        let mut at = 0;
        while at < b.len() {
            let mut r = Record {
                id: u64_at(at)?,
                indenter: i32_at(at + 8)? as u32,
                rank: i32_at(at + 12)?,
                ..Record::default()
            };
            let flags = u64_at(at + 16)?;
            r.owned = flags & 1 == 1;
            r.nn = ((flags >> 8) & 0xff) as u8;
            if r.nn > 9 {
                return None;
            }
            r.c = [f64_at(at + 24)?, f64_at(at + 32)?];
            r.n = [f64_at(at + 40)?, f64_at(at + 48)?];
            r.len = f64_at(at + 56)?;
            r.gap = f64_at(at + 64)?;
            r.slip = f64_at(at + 72)?;
            at += HEAD;
            for k in 0..r.nn as usize {
                let f = u64_at(at + 24)?;
                r.nodes[k] = RecNode {
                    node: [i32_at(at)? as i64, i32_at(at + 4)? as i64],
                    t: f64_at(at + 8)?,
                    inv_m: f64_at(at + 16)?,
                    free: [f & 1 == 1, f & 2 == 2],
                };
                at += NODE;
            }
            out.push(r);
        }
        Some(out)
    }
}

/// A symmetric matrix in compressed rows (both triangles stored, columns
/// sorted within a row).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Csr {
    /// Number of rows and columns.
    pub n: usize,
    /// Row starts (`n + 1` entries).
    pub row_ptr: Vec<usize>,
    /// Column indices.
    pub cols: Vec<u32>,
    /// Values.
    pub vals: Vec<f64>,
}

impl Csr {
    /// `y = A x`.
    pub fn mul(&self, x: &[f64], y: &mut [f64]) {
        for (i, yi) in y.iter_mut().enumerate().take(self.n) {
            *yi = (self.row_ptr[i]..self.row_ptr[i + 1])
                .map(|k| self.vals[k] * x[self.cols[k] as usize])
                .sum();
        }
    }
}

/// The scaled contact problem of a set of records: find `x ≥ 0` with
/// `w = K' x + r' ≥ 0`, `x w = 0`; the pressures are `P = scale · x`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContactProblem {
    /// Which records take part (those whose pressure can move a node), as
    /// indices into the record list; row `k` of the system is record
    /// `rows[k]`.
    pub rows: Vec<usize>,
    /// `K' = S K S + ε I`.
    pub k: Csr,
    /// `r' = S r`.
    pub r: Vec<f64>,
    /// `S` (per row).
    pub scale: Vec<f64>,
}

/// Assembles the contact problem of `recs` (in the order given, which the
/// caller makes the same on every rank: sorted by id) for a step of `dt`
/// with plane-strain thickness `thickness`. Every sum runs in a fixed order
/// (records in order, nodes in increasing level index), so the result
/// depends only on the records, not on how particles are spread over
/// patches and ranks.
pub fn assemble(recs: &[Record], dt: f64, thickness: f64, eps: f64) -> ContactProblem {
    // Node -> the records touching it, with T, 1/m and the free mask.
    let mut at_node: BTreeMap<[i64; 2], Vec<(usize, f64)>> = BTreeMap::new();
    let mut node_info: BTreeMap<[i64; 2], (f64, [bool; 2])> = BTreeMap::new();
    for (p, r) in recs.iter().enumerate() {
        for nd in &r.nodes[..r.nn as usize] {
            if nd.t == 0.0 || nd.inv_m == 0.0 || !(nd.free[0] || nd.free[1]) {
                continue;
            }
            // Swapped (j, i) keys: rows of nodes in storage order.
            at_node
                .entry([nd.node[1], nd.node[0]])
                .or_default()
                .push((p, nd.t));
            node_info
                .entry([nd.node[1], nd.node[0]])
                .or_insert((nd.inv_m, nd.free));
        }
    }
    // Pair sums over nodes, p <= q, in node order.
    let mut pairs: BTreeMap<(usize, usize), f64> = BTreeMap::new();
    let c = dt * dt * thickness;
    for (key, list) in &at_node {
        let (inv_m, free) = node_info[key];
        for (a, &(p, tp)) in list.iter().enumerate() {
            for &(q, tq) in &list[a..] {
                let (np, nq) = (recs[p].n, recs[q].n);
                let nn = if free[0] { np[0] * nq[0] } else { 0.0 }
                    + if free[1] { np[1] * nq[1] } else { 0.0 };
                let (lo, hi) = if p <= q { (p, q) } else { (q, p) };
                *pairs.entry((lo, hi)).or_insert(0.0) += c * tp * tq * nn * inv_m;
            }
        }
    }
    // Rows: records with a positive diagonal (a pressure that moves them).
    let mut row_of = vec![usize::MAX; recs.len()];
    let mut rows = Vec::new();
    for (p, rp) in row_of.iter_mut().enumerate() {
        if pairs.get(&(p, p)).is_some_and(|&d| d > 0.0) {
            *rp = rows.len();
            rows.push(p);
        }
    }
    let n = rows.len();
    let scale: Vec<f64> = rows.iter().map(|&p| 1.0 / pairs[&(p, p)].sqrt()).collect();
    let mut entries: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n];
    for (&(p, q), &v) in &pairs {
        let (i, j) = (row_of[p], row_of[q]);
        if i == usize::MAX || j == usize::MAX {
            continue;
        }
        let s = scale[i] * v * scale[j];
        if i == j {
            entries[i].push((j as u32, s + eps));
        } else if s != 0.0 {
            entries[i].push((j as u32, s));
            entries[j].push((i as u32, s));
        }
    }
    let mut k = Csr {
        n,
        row_ptr: Vec::with_capacity(n + 1),
        cols: Vec::new(),
        vals: Vec::new(),
    };
    k.row_ptr.push(0);
    for row in &mut entries {
        row.sort_unstable_by_key(|e| e.0);
        for &(j, v) in row.iter() {
            k.cols.push(j);
            k.vals.push(v);
        }
        k.row_ptr.push(k.cols.len());
    }
    let r = rows
        .iter()
        .zip(&scale)
        .map(|(&p, &s)| s * recs[p].len * recs[p].gap)
        .collect();
    ContactProblem { rows, k, r, scale }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(id: u64, x: f64, gap: f64, n: [f64; 2], nodes: &[([i64; 2], f64)]) -> Record {
        let mut r = Record {
            id,
            c: [x, 0.0],
            n,
            len: nodes.iter().map(|e| e.1).sum(),
            gap,
            nn: nodes.len() as u8,
            owned: true,
            ..Record::default()
        };
        for (k, &(node, t)) in nodes.iter().enumerate() {
            r.nodes[k] = RecNode {
                node,
                t,
                inv_m: 1.0 / (1.0 + node[0] as f64),
                free: [true, true],
            };
        }
        r
    }

    #[test]
    fn records_round_trip_through_bytes() {
        let mut a = rec(7, 1.5, -0.25, [0.6, -0.8], &[([1, 2], 0.5), ([2, 2], 0.25)]);
        a.nodes[1].free = [false, true];
        a.rank = 3;
        let b = rec(9, 2.5, 0.1, [0.0, -1.0], &[([2, 2], 0.5)]);
        let mut bytes = Vec::new();
        a.encode(&mut bytes);
        b.encode(&mut bytes);
        let back = Record::decode_all(&bytes).unwrap();
        assert_eq!(back, vec![a, b]);
        assert!(Record::decode_all(&bytes[..bytes.len() - 3]).is_none());
    }

    #[test]
    fn system_is_symmetric_scaled_and_matches_the_definition() {
        let n = [0.0, -1.0];
        let nd = [0.6f64.sin(), -(0.6f64.cos())];
        let recs = [
            rec(1, 0.0, -1e-3, n, &[([0, 4], 0.3), ([1, 4], 0.2)]),
            rec(
                2,
                1.0,
                -2e-3,
                nd,
                &[([1, 4], 0.25), ([2, 4], 0.25), ([2, 5], 0.1)],
            ),
            rec(3, 2.0, 5e-3, n, &[([2, 4], 0.4), ([3, 4], 0.1)]),
        ];
        let (dt, th, eps) = (1e-3, 2.0, 1e-6);
        let pr = assemble(&recs, dt, th, eps);
        assert_eq!(pr.rows, vec![0, 1, 2]);
        // Dense K from the definition.
        let mut kd = [[0.0f64; 3]; 3];
        for p in 0..3 {
            for q in 0..3 {
                for a in &recs[p].nodes[..recs[p].nn as usize] {
                    for b in &recs[q].nodes[..recs[q].nn as usize] {
                        if a.node == b.node {
                            let dot = recs[p].n[0] * recs[q].n[0] + recs[p].n[1] * recs[q].n[1];
                            kd[p][q] += dt * dt * th * a.t * b.t * dot * a.inv_m;
                        }
                    }
                }
            }
        }
        let mut dense = [[0.0f64; 3]; 3];
        for (i, row) in dense.iter_mut().enumerate() {
            for k in pr.k.row_ptr[i]..pr.k.row_ptr[i + 1] {
                row[pr.k.cols[k] as usize] = pr.k.vals[k];
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                let want = pr.scale[i] * kd[i][j] * pr.scale[j] + if i == j { eps } else { 0.0 };
                assert!((dense[i][j] - want).abs() < 1e-14, "({i},{j})");
                assert_eq!(dense[i][j].to_bits(), dense[j][i].to_bits());
            }
            assert!((dense[i][i] - 1.0 - eps).abs() < 1e-14);
            let r = pr.scale[i] * recs[i].len * recs[i].gap;
            assert_eq!(pr.r[i], r);
        }
    }

    #[test]
    fn a_record_no_pressure_can_move_is_left_out() {
        let n = [0.0, -1.0];
        let mut fixed = rec(1, 0.0, -1e-3, n, &[([0, 4], 0.5)]);
        fixed.nodes[0].free = [true, false]; // y fixed: a normal pressure moves nothing
        let free = rec(2, 1.0, -1e-3, n, &[([1, 4], 0.5)]);
        let pr = assemble(&[fixed, free], 1e-3, 1.0, 0.0);
        assert_eq!(pr.rows, vec![1]);
        assert_eq!(pr.k.n, 1);
    }
}
