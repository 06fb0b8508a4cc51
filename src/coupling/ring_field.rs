//! The ring copies' nodal field: the coarse level's mass-weighted nodal
//! average of stress and deformation gradient at the nodes ring copies
//! read, summed over patches and ranks, and its interpolation at a copy.

use super::layout::{cell_at, floor_i64, in_any, stencil_at, PairLayout, PatchRing};
use super::sync::Candidate;
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::geom::IBox;
use crate::level::Level;
use crate::records::NodalSums;

/// Number of nodal sums of the coarse nodal field: mass, mass times the
/// four stress components, the four deformation-gradient components and
/// the out-of-plane stretch `fzz` (the hoop stretch in axisymmetry, 1 in
/// plane strain), the material index and its square.
pub(super) const NF: usize = 12;

/// Number of nodal sums with the stress's limited linear reconstruction
/// (laws whose ring copies sum owned particles only; see
/// [`PairLayout::smooth`]): the [`NF`] sums, then the particles' offsets
/// from the node in cells `Σ wm dx, Σ wm dy`, their second moments
/// `Σ wm dx², Σ wm dx dy, Σ wm dy²`, the stress components times the
/// offsets `Σ wm σ_c dx` (4), `Σ wm σ_c dy` (4) and squared `Σ wm σ_c²` (4),
/// all raw sums (not divided by the mass).
pub(super) const NF_LIN: usize = NF + 17;

/// MPI tag of the exchange of the nodal field's partial sums.
pub(super) const TAG_RING_FIELD: i32 = 23;

impl PairLayout {
    /// The stress and deformation gradient of the coarse nodal field at
    /// `(x, y)` in coarse patch `k`, for a particle of material `mat` whose
    /// own values are `own` (stress `sxx, syy, sxy, szz`, then `fxx, fxy,
    /// fyx, fyy, fzz`): `None` for a group the particle keeps. It keeps both
    /// unless every stencil node with weight has mass and (with
    /// `materials`) holds only its material; and it keeps a group the
    /// field equals to round-off, so that a uniform state (at rest, uniform
    /// stress, rigid motion) stays bitwise uniform.
    #[allow(clippy::type_complexity)]
    pub(super) fn smooth(
        &self,
        k: usize,
        x: f64,
        y: f64,
        mat: u32,
        own: [f64; 9],
        materials: bool,
        lin: bool,
    ) -> (Option<[f64; 4]>, Option<[f64; 5]>) {
        let (Some(pr), s) = (&self.patches[k], &self.fin[k]) else {
            return (None, None);
        };
        let Some((nodes, w)) = stencil_at(pr.ext.lo, pr.nn, self.origin, self.h, x, y) else {
            return (None, None);
        };
        let linear = self.nf == NF_LIN && lin;
        let nf = self.nf;
        let mat = mat as f64;
        let mut acc = [0.0; 9];
        for (kk, ww) in nodes.iter().zip(w) {
            if ww == 0.0 {
                continue;
            }
            debug_assert!(pr.read[*kk], "ring copies read the field at read nodes");
            let node = &s[nf * kk..nf * (kk + 1)];
            if node[0].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return (None, None);
            }
            let (mean, var) = (node[NF - 2], node[NF - 1]);
            if materials
                && ((mean - mat).abs() > 1e-9 * (1.0 + mat) || var > 1e-12 * (1.0 + mat * mat))
            {
                return (None, None);
            }
            let stress = if linear {
                limited_plane(node)
            } else {
                [node[1], node[2], node[3], node[4]]
            };
            for (a, v) in acc.iter_mut().zip(stress.iter().chain(&node[5..NF - 2])) {
                *a += ww * v;
            }
        }
        let same = |r: std::ops::Range<usize>| {
            let scale = r
                .clone()
                .map(|c| own[c].abs().max(acc[c].abs()))
                .fold(0.0, f64::max);
            r.map(|c| (acc[c] - own[c]).abs())
                .all(|d| d <= 1e-12 * scale)
        };
        let stress = (!same(0..4)).then(|| [acc[0], acc[1], acc[2], acc[3]]);
        let grad = (!same(4..9)).then(|| [acc[4], acc[5], acc[6], acc[7], acc[8]]);
        (stress, grad)
    }
}

/// The limit of [`limited_plane`]'s correction, in standard deviations of
/// the particles' values around the node. Measured on the J2 wedge whose
/// plastic zone crosses the finest box's edge (docs/validation.md): 0 (the
/// mean), 0.5, 1, √3 and no limit give E_r +56, +23, +13, +22 and +17 %
/// (the uniform twin +9.7 %) and the load at 600 nm −0.7, −1.3, −2.3,
/// −3.1 and −3.2 % from the twin; with the plastic zone inside the box
/// every limit from 1 up gives the twin's load within 0.05 %.
const LIMIT: f64 = 1.0;

/// The stress at a node of the field with the linear sums ([`NF_LIN`]):
/// the value at the node of the mass-weighted least-squares plane through
/// the particles around it, limited by the particles' spread. The plane's
/// slope `b` solves `C b = g` with `C` the covariance of the particles'
/// offsets and `g` their covariance with the component; the plane's value
/// at the node is `mean − b · (centroid offset)`. On a node with particles
/// on one side only (next to a refined region whose particles the field
/// leaves out) the mean is off by the slope times the centroid's offset,
/// which the plane removes; the correction is kept within [`LIMIT`]
/// standard deviations of the particles' values around the node, so that
/// a plane through a kinked field (an elastic–plastic front) cannot carry
/// the node far beyond the values around it. Without a usable plane (fewer
/// than three particles off one line) the mean.
fn limited_plane(node: &[f64]) -> [f64; 4] {
    let m = node[0];
    let mean = [node[1], node[2], node[3], node[4]];
    let e = &node[NF..NF_LIN];
    let (dx, dy) = (e[0] / m, e[1] / m);
    let cxx = e[2] / m - dx * dx;
    let cxy = e[3] / m - dx * dy;
    let cyy = e[4] / m - dy * dy;
    let det = cxx * cyy - cxy * cxy;
    let tr = cxx + cyy;
    if !(det > 1e-6 * tr * tr) || !(tr > 1e-12) {
        return mean;
    }
    let mut out = mean;
    for c in 0..4 {
        let gx = e[5 + c] / m - mean[c] * dx;
        let gy = e[9 + c] / m - mean[c] * dy;
        let bx = (cyy * gx - cxy * gy) / det;
        let by = (cxx * gy - cxy * gx) / det;
        let var = (e[13 + c] / m - mean[c] * mean[c]).max(0.0);
        let lim = LIMIT * var.sqrt();
        let corr = (-(bx * dx + by * dy)).clamp(-lim, lim);
        if corr.is_finite() {
            out[c] = mean[c] + corr;
        }
    }
    out
}

/// What the nodal field needs to know of the materials (see
/// [`FieldExchange::build`]).
#[derive(Clone, Copy)]
pub(super) struct FieldMaterials<'a> {
    /// Sum the material index and its square (read by
    /// [`PairLayout::smooth`]'s material check).
    pub(super) check: bool,
    /// Per material index: only owned particles of it enter the sums.
    pub(super) owned_only: &'a [bool],
    /// Sum the field at all; without, [`FieldExchange::build`] only lists
    /// the ring copies to make (they keep their owners' values: the fine
    /// ring's velocities are prescribed, see the notes of
    /// [`crate::coupling`]).
    pub(super) sum: bool,
}

/// Buffers of the exchange of the nodal field's partial sums between
/// ranks, kept between synchronisations.
#[derive(Default)]
pub(super) struct FieldExchange {
    /// Outgoing messages, one per peer rank.
    pub(super) send: Vec<(i32, Vec<u8>)>,
    /// Expected message sizes, one per peer rank.
    pub(super) recv: Vec<(i32, usize)>,
    /// Incoming partial sums: (destination patch, source patch, message,
    /// offset), sorted.
    pub(super) incoming: Vec<(usize, usize, usize, usize)>,
}

impl FieldExchange {
    /// The coarse level's mass-weighted nodal average of particle stress and
    /// deformation gradient (bilinear weights, all its particles: owned
    /// ones and copies of the finer level's), summed over the patches
    /// sharing a node in increasing patch index as [`Level::exchange`] sums
    /// (point-to-point with the neighbour ranks), at the nodes the ring
    /// copies read; and the ring copies to make (`cand`: coarse-owned
    /// particles whose fine cell is in the fine ghost ring). Without
    /// `materials` the material sums (the last two of the `NF`, read only
    /// by [`PairLayout::smooth`]'s material check) are left at zero.
    /// Particles whose material index is flagged in `mats.owned_only` enter
    /// the sums only where the coarse level owns them, not as its copies of
    /// a neighbouring level's (laws that take the nodal dilatation; see the
    /// notes of [`crate::coupling`]); with any such material the sums carry
    /// the linear moments too ([`NF_LIN`] per node instead of [`NF`]), from
    /// which [`limited_plane`] reconstructs those laws' nodal stress.
    pub(super) fn build(
        &mut self,
        pair: &mut PairLayout,
        coarse: &Level,
        fine: &Level,
        comm: &Comm,
        cand: &mut Vec<Candidate>,
        mats: FieldMaterials,
    ) -> Result<u64> {
        let FieldMaterials {
            check: materials,
            owned_only,
            sum,
        } = mats;
        use crate::particles::OWNED;
        let (origin, h) = (coarse.origin, coarse.h);
        pair.origin = origin;
        pair.h = h;
        let linear = owned_only.iter().any(|&o| o);
        let nf = if linear { NF_LIN } else { NF };
        pair.nf = nf;
        let me = comm.rank();
        // The fine patch a coarse-owned particle at (x, y) is copied to:
        // its fine cell is in a fine patch but not in the fine region.
        // The fine cell of a coarse particle whose `(x - origin) / h` is
        // `(xi, yi)`: twice those, floored, when the fine cells halve the
        // coarse ones exactly (see `Coupler::sync`), else its own division.
        let halves = fine.origin == origin && fine.h * 2.0 == h;
        let fine_cell = |x: f64, y: f64, xi: f64, yi: f64| {
            if halves {
                [floor_i64(2.0 * xi), floor_i64(2.0 * yi)]
            } else {
                cell_at(fine.origin, fine.h, x, y)
            }
        };
        // The last fine patch found (patches are disjoint).
        let mut last: Option<(IBox, usize)> = None;
        let mut ring_dest = |c: [i64; 2]| {
            if in_any(&fine.owned, c) {
                return None;
            }
            match last {
                Some((b, q)) if b.contains_cell(c[0], c[1]) => Some(q),
                _ => {
                    let q = fine.find_patch(c)?;
                    last = Some((fine.patches[q], q));
                    Some(q)
                }
            }
        };
        cand.clear();
        // Partial sums of each local patch at the nodes it touches.
        for (pi, p) in coarse.local.iter().enumerate() {
            let pr = pair.patches[p.k]
                .get_or_insert_with(|| PatchRing::new(p.k, &coarse.patches, fine, halves));
            if pr.part.len() != nf * pr.nn[0] * pr.nn[1] {
                // The sums per node changed (a new material table): start
                // from zeros, not the old layout's values.
                pr.part.clear();
                pr.part.resize(nf * pr.nn[0] * pr.nn[1], 0.0);
            }
            if sum {
                for &n in &pr.touch {
                    let n = n as usize;
                    pr.part[nf * n..nf * (n + 1)].fill(0.0);
                }
            }
            if !pr.any_contrib {
                continue;
            }
            let q = &p.parts;
            let nn0 = pr.nn[0];
            let ew = [(pr.nn[0] - 1) as i64, (pr.nn[1] - 1) as i64];
            // Quick test without division: `(x - lo) * inv` is within a
            // small fraction of a cell of the exact `(x - origin) / h - lo`,
            // so its cell is at most one off the exact one. A particle whose
            // estimated cell lies inside `ext` shrunk by one cell (so the
            // exact cell is on the grid) with no contributing cell around
            // neither contributes nor can be a ring copy: skipped.
            let inv = 1.0 / h;
            let lo = [
                origin[0] + pr.ext.lo[0] as f64 * h,
                origin[1] + pr.ext.lo[1] as f64 * h,
            ];
            let (ew0, ew1) = (ew[0] as usize, ew[1] as usize);
            for i in 0..q.len() {
                let (x, y) = (q.x[i], q.y[i]);
                // Truncation: negative estimates (and NaN) give 0, which is
                // not inside; inside estimates are positive, truncation is
                // the floor there.
                let ea = ((x - lo[0]) * inv) as usize;
                let eb = ((y - lo[1]) * inv) as usize;
                if ea >= 1 && eb >= 1 && ea < ew0 - 1 && eb < ew1 - 1 && !pr.near[eb * ew0 + ea] {
                    continue;
                }
                let xi = (x - origin[0]) / h;
                let yi = (y - origin[1]) / h;
                let (ci, cj) = (floor_i64(xi), floor_i64(yi));
                let (a, b) = (ci - pr.ext.lo[0], cj - pr.ext.lo[1]);
                // Off the grid's stencils (never: a particle lies in its
                // patch's cells): nothing to sum, but a copy.
                let c = (a >= 0 && b >= 0 && a < ew[0] && b < ew[1])
                    .then(|| b as usize * ew[0] as usize + a as usize);
                let skip = q.copy[i] != OWNED
                    && owned_only
                        .get(q.material[i] as usize)
                        .copied()
                        .unwrap_or(false);
                if sum && c.is_some_and(|c| pr.contrib[c]) && !skip {
                    let (fx, fy) = (xi - ci as f64, yi - cj as f64);
                    let w = [
                        (1.0 - fx) * (1.0 - fy),
                        fx * (1.0 - fy),
                        (1.0 - fx) * fy,
                        fx * fy,
                    ];
                    let n0 = b as usize * nn0 + a as usize;
                    let mat = q.material[i] as f64;
                    let vals = [
                        q.mass[i],
                        q.sxx[i],
                        q.syy[i],
                        q.sxy[i],
                        q.szz[i],
                        q.fxx[i],
                        q.fxy[i],
                        q.fyx[i],
                        q.fyy[i],
                        q.fzz[i],
                        mat,
                        mat * mat,
                    ];
                    let off = [
                        (fx, fy),
                        (fx - 1.0, fy),
                        (fx, fy - 1.0),
                        (fx - 1.0, fy - 1.0),
                    ];
                    for ((kk, ww), (dx, dy)) in [n0, n0 + 1, n0 + nn0, n0 + nn0 + 1]
                        .into_iter()
                        .zip(w)
                        .zip(off)
                    {
                        let wm = ww * q.mass[i];
                        let node = &mut pr.part[nf * kk..nf * (kk + 1)];
                        node[0] += wm;
                        for f in 1..NF - 2 {
                            node[f] += wm * vals[f];
                        }
                        if materials {
                            for f in NF - 2..NF {
                                node[f] += wm * vals[f];
                            }
                        }
                        if linear {
                            let e = &mut node[NF..NF_LIN];
                            e[0] += wm * dx;
                            e[1] += wm * dy;
                            e[2] += wm * dx * dx;
                            e[3] += wm * dx * dy;
                            e[4] += wm * dy * dy;
                            for c in 0..4 {
                                let v = wm * vals[1 + c];
                                e[5 + c] += v * dx;
                                e[9 + c] += v * dy;
                                e[13 + c] += v * vals[1 + c];
                            }
                        }
                    }
                }
                if q.copy[i] == OWNED && c.map_or(true, |c| pr.ring[c]) {
                    if let Some(fq) = ring_dest(fine_cell(x, y, xi, yi)) {
                        cand.push(Candidate {
                            q: fq as u32,
                            id: q.id[i],
                            pi: pi as u32,
                            i: i as u32,
                        });
                    }
                }
            }
        }
        if !sum {
            return Ok(0);
        }
        // Partial sums at the needed nodes shared with other ranks'
        // patches; every pair of overlapping patches sends (zeros for a
        // patch without particles), so sizes follow from the layout.
        for (_, b) in &mut self.send {
            b.clear();
        }
        for (_, n) in &mut self.recv {
            *n = 0;
        }
        let slot = |v: &mut Vec<(i32, Vec<u8>)>, r: i32| match v.binary_search_by_key(&r, |e| e.0) {
            Ok(s) => s,
            Err(s) => {
                v.insert(s, (r, Vec::new()));
                s
            }
        };
        for p in &coarse.local {
            let pr = pair.patches[p.k].as_ref().expect("built above");
            for &(q, ov, cnt) in &pr.nbrs {
                let r = coarse.owner[q];
                if r == me {
                    continue;
                }
                let s = slot(&mut self.send, r);
                let buf = &mut self.send[s].1;
                NodalSums::begin(buf, q, p.k);
                for j in ov.lo[1]..ov.hi[1] {
                    for i in ov.lo[0]..ov.hi[0] {
                        let n = pr.node(i, j);
                        if pr.need[n] {
                            for &v in &pr.part[nf * n..nf * (n + 1)] {
                                NodalSums::push(buf, v);
                            }
                        }
                    }
                }
                let s = match self.recv.binary_search_by_key(&r, |e| e.0) {
                    Ok(s) => s,
                    Err(s) => {
                        self.recv.insert(s, (r, 0));
                        s
                    }
                };
                self.recv[s].1 += NodalSums::HEADER + 8 * nf * cnt;
            }
        }
        self.incoming.clear();
        let mut sent = 0u64;
        let bufs = if self.send.iter().any(|e| !e.1.is_empty()) {
            let sends: Vec<(i32, &[u8])> = self
                .send
                .iter()
                .filter(|e| !e.1.is_empty())
                .map(|e| (e.0, e.1.as_slice()))
                .collect();
            let recvs: Vec<(i32, usize)> = self.recv.iter().filter(|e| e.1 > 0).copied().collect();
            sent = sends.iter().map(|e| e.1.len() as u64).sum();
            let bufs = comm.exchange_with(&sends, &recvs, TAG_RING_FIELD)?;
            for (bi, recv) in bufs.iter().enumerate() {
                let mut at = 0;
                while at + NodalSums::HEADER <= recv.len() {
                    let (dest, src) = NodalSums::header(recv, at);
                    let cnt = pair.patches[dest]
                        .as_ref()
                        .and_then(|pr| pr.nbrs.iter().find(|e| e.0 == src))
                        .map(|e| e.2)
                        .ok_or_else(|| {
                            Error::new(
                                Status::Internal,
                                format!("nodal field sums for patch {dest} from patch {src}, which do not overlap here"),
                            )
                        })?;
                    self.incoming.push((dest, src, bi, at + NodalSums::HEADER));
                    at += NodalSums::HEADER + 8 * nf * cnt;
                }
            }
            self.incoming.sort_unstable();
            bufs
        } else {
            Vec::new()
        };
        // The sums at the nodes the ring copies read: contributions in
        // increasing patch index, the own one in its place.
        let mut last = usize::MAX;
        for c in cand.iter() {
            let pi = c.pi as usize;
            if pi == last {
                continue;
            }
            last = pi;
            let k = coarse.local[pi].k;
            let pr = pair.patches[k].as_ref().expect("built above");
            let fin = &mut pair.fin[k];
            fin.resize(pr.part.len(), 0.0);
            for &n in &pr.read_list {
                let n = n as usize;
                fin[nf * n..nf * (n + 1)].fill(0.0);
            }
            let add_own = |fin: &mut Vec<f64>| {
                for &n in &pr.read_list {
                    let n = n as usize;
                    let r = nf * n..nf * (n + 1);
                    for (d, v) in fin[r.clone()].iter_mut().zip(&pr.part[r]) {
                        *d += v;
                    }
                }
            };
            let mut own_done = false;
            for &(q, ov, _) in &pr.nbrs {
                if !own_done && q > k {
                    add_own(fin);
                    own_done = true;
                }
                if coarse.owner[q] == me {
                    let qr = pair.patches[q].as_ref().expect("local patches are built");
                    for j in ov.lo[1]..ov.hi[1] {
                        for i in ov.lo[0]..ov.hi[0] {
                            let n = pr.node(i, j);
                            if pr.read[n] {
                                let m = qr.node(i, j);
                                for f in 0..nf {
                                    fin[nf * n + f] += qr.part[nf * m + f];
                                }
                            }
                        }
                    }
                } else {
                    let e = self.incoming.partition_point(|e| (e.0, e.1) < (k, q));
                    let Some(&(_, _, bi, off)) =
                        self.incoming.get(e).filter(|e| (e.0, e.1) == (k, q))
                    else {
                        return Err(Error::new(
                            Status::Internal,
                            format!("no nodal field sums arrived for patch {k} from patch {q}"),
                        ));
                    };
                    let recv = &bufs[bi];
                    let mut r = 0;
                    for j in ov.lo[1]..ov.hi[1] {
                        for i in ov.lo[0]..ov.hi[0] {
                            let n = pr.node(i, j);
                            if !pr.need[n] {
                                continue;
                            }
                            if pr.read[n] {
                                for f in 0..nf {
                                    fin[nf * n + f] += NodalSums::value(recv, off, nf * r + f);
                                }
                            }
                            r += 1;
                        }
                    }
                }
            }
            if !own_done {
                add_own(fin);
            }
            // The sums as nodal averages, once per node (see
            // `PairLayout::smooth`): mass, the eight field values over the
            // mass, the material index's mean and variance.
            for &n in &pr.read_list {
                let node = &mut fin[nf * n as usize..nf * (n as usize + 1)];
                let m = node[0];
                if m.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    continue;
                }
                for v in &mut node[1..NF - 2] {
                    *v /= m;
                }
                if materials {
                    let mean = node[NF - 2] / m;
                    node[NF - 1] = node[NF - 1] / m - mean * mean;
                    node[NF - 2] = mean;
                }
            }
        }
        Ok(sent)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The node sums of [`FieldExchange::build`] (mass, the stress means,
    /// and the linear sums) for particles at offsets `d` (cells) with
    /// weights times masses `wm` and stresses `sig(d)`.
    fn node_of(pts: &[([f64; 2], f64)], sig: impl Fn([f64; 2]) -> [f64; 4]) -> Vec<f64> {
        let mut n = vec![0.0; NF_LIN];
        for &(d, wm) in pts {
            let v = sig(d);
            n[0] += wm;
            for c in 0..4 {
                n[1 + c] += wm * v[c];
            }
            let e = &mut n[NF..NF_LIN];
            e[0] += wm * d[0];
            e[1] += wm * d[1];
            e[2] += wm * d[0] * d[0];
            e[3] += wm * d[0] * d[1];
            e[4] += wm * d[1] * d[1];
            for c in 0..4 {
                e[5 + c] += wm * v[c] * d[0];
                e[9 + c] += wm * v[c] * d[1];
                e[13 + c] += wm * v[c] * v[c];
            }
        }
        for c in 0..4 {
            n[1 + c] /= n[0];
        }
        n
    }

    /// Four particles per cell (offsets ±1/4, ±3/4 of a cell around the
    /// cell centre) in the cells `cells` around the node, weighted by the
    /// bilinear hat of the node.
    fn particles(cells: &[[i32; 2]]) -> Vec<([f64; 2], f64)> {
        let mut v = Vec::new();
        for c in cells {
            for (a, b) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                let d = [c[0] as f64 + a, c[1] as f64 + b];
                let w = (1.0 - d[0].abs()) * (1.0 - d[1].abs());
                v.push((d, 2.0 * w));
            }
        }
        v
    }

    #[test]
    fn a_uniform_stress_comes_back_to_round_off() {
        // (A copy whose field equals its own values to round-off keeps its
        // own bits: `PairLayout::smooth`.)
        let s0 = [-3.0e8, 1.25e8, 7.0e7, -2.0e7];
        let n = node_of(&particles(&[[0, 0], [-1, 0]]), |_| s0);
        for (p, s) in limited_plane(&n).into_iter().zip(s0) {
            assert!((p - s).abs() <= 1e-14 * s.abs(), "{p} against {s}");
        }
    }

    #[test]
    fn particles_around_the_node_give_a_linear_field_exactly() {
        // All four cells: the plane through a linear field is the field, and
        // the node's value is the field at the node, with or without the
        // mean being off (it is not, by symmetry; the plane agrees).
        let lin = |d: [f64; 2]| [1.0 + 2.0 * d[0] - d[1], -4.0 + 0.5 * d[1], 3.0 * d[0], 7.0];
        let n = node_of(&particles(&[[0, 0], [-1, 0], [0, -1], [-1, -1]]), lin);
        let p = limited_plane(&n);
        for (c, want) in [1.0, -4.0, 0.0, 7.0].into_iter().enumerate() {
            assert!(
                (p[c] - want).abs() < 1e-12,
                "component {c}: {} against {want}",
                p[c]
            );
        }
    }

    #[test]
    fn a_one_sided_node_moves_by_at_most_one_deviation() {
        // Particles on the right of the node only (a refined region on the
        // left): the mean of a field rising to the right is high by the
        // slope times the centroid's offset; the plane's value at the node
        // is the field's, the correction limited to one deviation of the
        // particles' values.
        let lin = |d: [f64; 2]| [10.0 * d[0], 0.0, 5.0 + 2.0 * d[0], 0.0];
        let pts = particles(&[[0, 0], [0, -1]]);
        let n = node_of(&pts, lin);
        let p = limited_plane(&n);
        let m: f64 = pts.iter().map(|e| e.1).sum();
        let cx: f64 = pts.iter().map(|e| e.1 * e.0[0]).sum::<f64>() / m;
        let sd = (pts.iter().map(|e| e.1 * (e.0[0] - cx).powi(2)).sum::<f64>() / m).sqrt();
        // The needed correction, -slope * cx, exceeds one deviation,
        // slope * sd: the limit holds it there.
        assert!(cx > sd);
        for (c, slope, at0) in [(0, 10.0, 0.0), (2, 2.0, 5.0)] {
            let mean = at0 + slope * cx;
            assert!((n[1 + c] - mean).abs() < 1e-12);
            let want = mean - slope * sd;
            assert!(
                (p[c] - want).abs() < 1e-12,
                "component {c}: {} against {want}",
                p[c]
            );
        }
        assert_eq!([p[1], p[3]], [0.0, 0.0]);
    }

    #[test]
    fn particles_on_one_line_keep_the_mean() {
        let pts: Vec<([f64; 2], f64)> = [0.1, 0.3, 0.6].iter().map(|&x| ([x, 0.25], 1.0)).collect();
        let n = node_of(&pts, |d| [d[0], 2.0 * d[0], 0.0, 1.0]);
        assert_eq!(limited_plane(&n), [n[1], n[2], n[3], n[4]]);
    }
}
