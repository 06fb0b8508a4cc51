//! What a pair of levels' layout decides for the coupling: the deep cells
//! without copies, the ring cells and nodes of the ring copies' nodal
//! field, and the position tests the synchronisation uses.

use super::ring_field::NF;
use crate::geom::IBox;
use crate::level::{Level, GHOST};

/// `v.floor() as i64` (saturating, NaN to 0) without a call to `floor`.
#[inline]
pub(super) fn floor_i64(v: f64) -> i64 {
    let t = v as i64;
    if (t as f64) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// The cell of a level with origin `o` and cell size `h` holding a point:
/// the same as [`Level::cell_of`].
#[inline]
pub(super) fn cell_at(o: [f64; 2], h: f64, x: f64, y: f64) -> [i64; 2] {
    [floor_i64((x - o[0]) / h), floor_i64((y - o[1]) / h)]
}

/// The cells of a box as a rectangle of positions shrunk by a margin far
/// above the rounding of `(x - o) / h` and of the rectangle's corners: a
/// point strictly inside it lies in a cell of the box (a test without
/// division; points near the edges, or NaN, take the exact test).
#[derive(Clone, Copy, Debug)]
pub(super) struct Inside {
    pub(super) lo: [f64; 2],
    pub(super) hi: [f64; 2],
}

impl Inside {
    /// The box's cells shrunk by the margin (see above).
    pub(super) fn of(b: &IBox, o: [f64; 2], h: f64) -> Inside {
        Inside::with_margin(b, o, h, 1.0)
    }

    /// The rectangle of the box's cells moved inwards (`sign` 1) or
    /// outwards (`sign` -1) by the margin on every side.
    fn with_margin(b: &IBox, o: [f64; 2], h: f64, sign: f64) -> Inside {
        let axis = |a: usize| {
            let (lo, hi) = (o[a] + b.lo[a] as f64 * h, o[a] + b.hi[a] as f64 * h);
            let m = sign * (1e-6 * h + 1e-12 * (o[a].abs() + lo.abs() + hi.abs()));
            (lo + m, hi - m)
        };
        let (x, y) = (axis(0), axis(1));
        Inside {
            lo: [x.0, y.0],
            hi: [x.1, y.1],
        }
    }

    #[inline]
    pub(super) fn holds(&self, x: f64, y: f64) -> bool {
        x > self.lo[0] && x < self.hi[0] && y > self.lo[1] && y < self.hi[1]
    }

    /// The cells of a box as a rectangle of positions grown by the margin
    /// of [`Inside::of`]: a point outside it (see [`Inside::excludes`])
    /// lies in no cell of the box.
    pub(super) fn around(b: &IBox, o: [f64; 2], h: f64) -> Inside {
        Inside::with_margin(b, o, h, -1.0)
    }

    /// Whether `(x, y)` lies outside the rectangle (NaN does not: it takes
    /// the exact test).
    #[inline]
    pub(super) fn excludes(&self, x: f64, y: f64) -> bool {
        x < self.lo[0] || x > self.hi[0] || y < self.lo[1] || y > self.hi[1]
    }
}

/// Whether one of `boxes` surely holds `(x, y)` (see [`Inside`]).
#[inline]
pub(super) fn surely_in(boxes: &[Inside], x: f64, y: f64) -> bool {
    boxes.iter().any(|b| b.holds(x, y))
}

/// Whether `(x, y)` surely lies in no cell of the boxes whose grown
/// rectangles ([`Inside::around`]) are `around`.
#[inline]
pub(super) fn surely_out(around: &[Inside], x: f64, y: f64) -> bool {
    around.iter().all(|b| b.excludes(x, y))
}

/// Whether one of `boxes` contains cell `c`.
#[inline]
pub(super) fn in_any(boxes: &[IBox], c: [i64; 2]) -> bool {
    boxes.iter().any(|b| b.contains_cell(c[0], c[1]))
}

/// The layout of a pair of levels: coarse patches, fine boxes, fine owned
/// boxes, fine domain.
pub(super) type LayoutKey = (Vec<IBox>, Vec<IBox>, Vec<IBox>, IBox);

/// What a pair of levels' layout decides for the coupling, computed once
/// per layout: the fine level's deep boxes and, per coarse patch, which
/// cells and nodes the ring copies' nodal field involves.
#[derive(Default)]
pub(super) struct PairLayout {
    /// The layout these were computed for: coarse patches, fine boxes,
    /// fine owned boxes, fine domain.
    pub(super) key: Option<LayoutKey>,
    /// The depth of the copies' layer, in coarse cells, `deep` was made
    /// for (0: none yet).
    pub(super) depth: i64,
    /// The fine cells deep inside the fine region (no copies on the coarse
    /// level), see [`deep_boxes`].
    pub(super) deep: Vec<IBox>,
    /// `deep` as positions (see [`Inside`]).
    pub(super) deep_in: Vec<Inside>,
    /// The fine level's own boxes as positions (see [`Inside`]).
    pub(super) owned_in: Vec<Inside>,
    /// The fine level's own boxes as grown rectangles (see
    /// [`Inside::around`]).
    pub(super) owned_around: Vec<Inside>,
    /// Per coarse patch (built when this rank first holds it).
    pub(super) patches: Vec<Option<PatchRing>>,
    /// Per coarse patch: the nodal field at its `read` nodes, `NF` values
    /// per node of its grid (node-major): the summed mass, then (where it
    /// is positive) the eight mass-weighted averages (stress, deformation
    /// gradient) and the material index's mean and variance (zero without
    /// the material sums).
    pub(super) fin: Vec<Vec<f64>>,
    /// The number of sums per node of `fin` and of the patches' `part`
    /// ([`NF`], or [`super::ring_field::NF_LIN`] with the linear sums), set
    /// by the last field built.
    pub(super) nf: usize,
    /// Origin of the coarse level.
    pub(super) origin: [f64; 2],
    /// Cell size of the coarse level.
    pub(super) h: f64,
}

/// The nodal field's footprint on one coarse patch's grid (the grid the
/// patch has while it holds particles: its cells grown by [`GHOST`]).
///
/// A cell is a *ring* cell when a coarse particle in it can be copied into
/// the fine ghost ring: one of the fine cells it covers lies in the fine
/// level's boxes and not in its own region. When the fine cells halve the
/// coarse ones exactly (the same origin, half the cell size: always, for
/// the levels of a simulation) a coarse particle's fine cell is one of the
/// two per axis its coarse cell covers, and this footprint is exact;
/// otherwise (a particle's fine cell from its own division) the fine cells
/// within one fine cell of the cell count too, a margin over rounding. A
/// node is *needed* when it is a corner
/// of a ring cell; a cell *contributes* when one of its corners is needed.
/// Ring copies read the field at the corners of their cell, which are
/// needed nodes; the particles that contribute to a needed node are those
/// of contributing cells, so the sums there are the whole level's, in the
/// same order.
pub(super) struct PatchRing {
    /// Cells whose four corners are on the grid: the patch's cells grown by
    /// [`GHOST`]; the grid's first node is `ext.lo`.
    pub(super) ext: IBox,
    /// Grid nodes per axis.
    pub(super) nn: [usize; 2],
    /// Per cell of `ext` (row-major): whether it contributes.
    pub(super) contrib: Vec<bool>,
    /// Per cell of `ext`: whether it is a ring cell.
    pub(super) ring: Vec<bool>,
    /// Per grid node: whether it is needed (by this or another patch).
    pub(super) need: Vec<bool>,
    /// Per grid node: whether it is a corner of a ring cell of `ext`.
    pub(super) read: Vec<bool>,
    /// Grid nodes the partial sums write or send: needed nodes and the
    /// corners of contributing cells.
    pub(super) touch: Vec<u32>,
    /// Grid nodes that are corners of ring cells of `ext`.
    pub(super) read_list: Vec<u32>,
    /// Per cell of `ext`: whether it or one of its eight neighbours
    /// contributes (the quick test of [`FieldExchange::build`], whose cell
    /// estimate may be one cell off).
    pub(super) near: Vec<bool>,
    /// Whether any cell of `ext` contributes.
    pub(super) any_contrib: bool,
    /// Patches whose grid overlaps this one's (increasing index), with the
    /// overlap (node indices, half-open) and its number of needed nodes.
    pub(super) nbrs: Vec<(usize, IBox, usize)>,
    /// This patch's partial sums: `NF` per grid node, node-major (valid at
    /// `touch` nodes).
    pub(super) part: Vec<f64>,
}

/// The nodes a patch's grid stores, as a half-open box of node indices
/// (as `level::node_box`).
pub(super) fn grid_nodes(cells: &IBox) -> IBox {
    let e = cells.grow(GHOST);
    IBox::new(e.lo, [e.hi[0] + 1, e.hi[1] + 1])
}

/// Whether coarse cell `c` is a ring cell of the pair (see [`PatchRing`]):
/// with `exact` the fine cells it covers count, without it also those
/// within one fine cell of it.
pub(super) fn is_ring_cell(fine: &Level, c: [i64; 2], exact: bool) -> bool {
    let m = i64::from(!exact);
    for fj in 2 * c[1] - m..2 * c[1] + 2 + m {
        for fi in 2 * c[0] - m..2 * c[0] + 2 + m {
            let f = [fi, fj];
            if in_any(&fine.boxes, f) && !in_any(&fine.owned, f) {
                return true;
            }
        }
    }
    false
}

impl PatchRing {
    /// The footprint on coarse patch `k` of `patches`; `exact` when the fine
    /// cells halve the coarse ones exactly (see [`is_ring_cell`]).
    pub(super) fn new(k: usize, patches: &[IBox], fine: &Level, exact: bool) -> PatchRing {
        let cells = patches[k];
        let ext = cells.grow(GHOST);
        let nb = grid_nodes(&cells);
        let nn = [nb.shape()[0] as usize, nb.shape()[1] as usize];
        let ew = (nn[0] - 1, nn[1] - 1);
        // Ring flags over the cells around every grid node.
        let rb = ext.grow(1);
        let rw = rb.shape()[0] as usize;
        let ring_big: Vec<bool> = (rb.lo[1]..rb.hi[1])
            .flat_map(|j| (rb.lo[0]..rb.hi[0]).map(move |i| [i, j]))
            .map(|c| is_ring_cell(fine, c, exact))
            .collect();
        // Cell (a, b) of ext is cell (a + 1, b + 1) of rb; node (a, b) of
        // the grid is the upper-right corner of cell (a, b) of rb.
        let rbig = |a: usize, b: usize| ring_big[b * rw + a];
        let mut need = vec![false; nn[0] * nn[1]];
        for b in 0..nn[1] {
            for a in 0..nn[0] {
                need[b * nn[0] + a] =
                    rbig(a, b) || rbig(a + 1, b) || rbig(a, b + 1) || rbig(a + 1, b + 1);
            }
        }
        let corners = |a: usize, b: usize| {
            let n = b * nn[0] + a;
            [n, n + 1, n + nn[0], n + nn[0] + 1]
        };
        let mut ring = vec![false; ew.0 * ew.1];
        let mut contrib = vec![false; ew.0 * ew.1];
        let mut read = vec![false; nn[0] * nn[1]];
        let mut touched = need.clone();
        for b in 0..ew.1 {
            for a in 0..ew.0 {
                let c = b * ew.0 + a;
                ring[c] = rbig(a + 1, b + 1);
                contrib[c] = corners(a, b).iter().any(|&n| need[n]);
                for n in corners(a, b) {
                    read[n] |= ring[c];
                    touched[n] |= contrib[c];
                }
            }
        }
        let list =
            |m: &[bool]| -> Vec<u32> { (0..m.len()).filter(|&n| m[n]).map(|n| n as u32).collect() };
        let nbrs = (0..patches.len())
            .filter(|&q| q != k)
            .filter_map(|q| {
                let ov = nb.intersect(&grid_nodes(&patches[q]));
                if ov.is_empty() {
                    return None;
                }
                let cnt = (ov.lo[1]..ov.hi[1])
                    .flat_map(|j| (ov.lo[0]..ov.hi[0]).map(move |i| [i, j]))
                    .filter(|&[i, j]| {
                        need[(j - nb.lo[1]) as usize * nn[0] + (i - nb.lo[0]) as usize]
                    })
                    .count();
                Some((q, ov, cnt))
            })
            .collect();
        let mut near = vec![false; ew.0 * ew.1];
        for b in 0..ew.1 {
            for a in 0..ew.0 {
                near[b * ew.0 + a] = (b.saturating_sub(1)..(b + 2).min(ew.1)).any(|bb| {
                    (a.saturating_sub(1)..(a + 2).min(ew.0)).any(|aa| contrib[bb * ew.0 + aa])
                });
            }
        }
        PatchRing {
            ext,
            nn,
            near,
            any_contrib: contrib.iter().any(|&c| c),
            touch: list(&touched),
            read_list: list(&read),
            contrib,
            ring,
            need,
            read,
            nbrs,
            part: vec![0.0; NF * nn[0] * nn[1]],
        }
    }

    /// Storage index of node `(i, j)` (on the grid).
    #[inline]
    pub(super) fn node(&self, i: i64, j: i64) -> usize {
        (j - self.ext.lo[1]) as usize * self.nn[0] + (i - self.ext.lo[0]) as usize
    }
}

impl PairLayout {
    /// Recomputes the layout-derived data when the layout of the two
    /// levels changed (never, in a simulation after its first step).
    pub(super) fn update(&mut self, coarse: &Level, fine: &Level) {
        let same = self.key.as_ref().is_some_and(|(p, b, o, d)| {
            *p == coarse.patches && *b == fine.boxes && *o == fine.owned && *d == fine.domain
        });
        if same {
            return;
        }
        self.key = Some((
            coarse.patches.clone(),
            fine.boxes.clone(),
            fine.owned.clone(),
            fine.domain,
        ));
        self.depth = 0;
        self.deep.clear();
        self.deep_in.clear();
        self.owned_in = fine
            .owned
            .iter()
            .map(|b| Inside::of(b, fine.origin, fine.h))
            .collect();
        self.owned_around = fine
            .owned
            .iter()
            .map(|b| Inside::around(b, fine.origin, fine.h))
            .collect();
        self.patches = (0..coarse.patches.len()).map(|_| None).collect();
        self.fin = vec![Vec::new(); coarse.patches.len()];
    }

    /// Sets the depth of the copies' layer, in coarse cells (see
    /// [`copy_depth`]): the deep cells are recomputed when it changes.
    pub(super) fn set_depth(&mut self, depth: i64, fine: &Level) {
        if depth == self.depth {
            return;
        }
        self.depth = depth;
        self.deep = deep_boxes(&fine.owned, &fine.domain, 2 * depth);
        self.deep_in = self
            .deep
            .iter()
            .map(|b| Inside::of(b, fine.origin, fine.h))
            .collect();
    }
}

/// The four nodes of the cell holding `(x, y)` on a grid of nodes
/// starting at node `lo`, `n` nodes per axis, of a level with origin
/// `origin` and cell size `h` (storage indices), and their bilinear
/// weights; `None` when the cell's nodes are not all on the grid.
pub(super) fn stencil_at(
    lo: [i64; 2],
    n: [usize; 2],
    origin: [f64; 2],
    h: f64,
    x: f64,
    y: f64,
) -> Option<([usize; 4], [f64; 4])> {
    let xi = (x - origin[0]) / h;
    let yi = (y - origin[1]) / h;
    let (i, j) = (floor_i64(xi), floor_i64(yi));
    let (fx, fy) = (xi - i as f64, yi - j as f64);
    let (i, j) = (i - lo[0], j - lo[1]);
    if i < 0 || j < 0 || i + 1 >= n[0] as i64 || j + 1 >= n[1] as i64 {
        return None;
    }
    let k = j as usize * n[0] + i as usize;
    Some((
        [k, k + 1, k + n[0], k + n[0] + 1],
        [
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        ],
    ))
}

/// The cells of `owned` farther than `r` cells from the region's boundary
/// (sides on the domain boundary do not count as boundary): each box shrunk
/// by `r` on its inner sides. For a union of several boxes this is
/// conservative (cells near a box-to-box interface count as shallow).
pub(super) fn deep_boxes(owned: &[IBox], domain: &IBox, r: i64) -> Vec<IBox> {
    owned
        .iter()
        .map(|b| {
            let mut d = *b;
            for a in 0..2 {
                if b.lo[a] > domain.lo[a] {
                    d.lo[a] += r;
                }
                if b.hi[a] < domain.hi[a] {
                    d.hi[a] -= r;
                }
            }
            d
        })
        .filter(|d| !d.is_empty())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_i64_matches_floor() {
        let vals = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999_999_999_999_999_6,
            -2.999_999_999_999_999_6,
            1e15 + 0.5,
            -1e15 - 0.5,
            9.3e18,
            -9.3e18,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        for v in vals {
            assert_eq!(floor_i64(v), v.floor() as i64, "{v}");
        }
    }

    #[test]
    fn a_point_surely_inside_a_box_lies_in_one_of_its_cells_and_one_surely_outside_in_none() {
        // Deterministic pseudo-random points around the edges of boxes at
        // several scales and offsets of the origin.
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for (o, h) in [
            ([0.0, 0.0], 1.0),
            ([-3.7, 12.25], 0.1),
            ([1e3, -2e3], 1e-7),
            ([0.0, 0.0], 1.220_703_125e-7),
        ] {
            let b = IBox::new([3, -5], [17, 9]);
            let ins = Inside::of(&b, o, h);
            let out = Inside::around(&b, o, h);
            let (mut n_in, mut n_out) = (0, 0);
            for _ in 0..20_000 {
                let e = [[3.0, 17.0], [-5.0, 9.0]];
                // An edge, and an offset from it of up to ten margins
                // either way (`ins` and `out` are two margins apart).
                let pick = |side: f64, r: f64, a: usize| {
                    let edge = if side < 0.5 { e[a][0] } else { e[a][1] };
                    let spread = 10.0 * (ins.lo[a] - out.lo[a]);
                    o[a] + edge * h + (r - 0.5) * spread
                };
                let x = pick(next(), next(), 0);
                let y = pick(next(), next(), 1);
                let c = cell_at(o, h, x, y);
                if ins.holds(x, y) {
                    assert!(b.contains_cell(c[0], c[1]), "({x}, {y}) h {h}");
                    n_in += 1;
                }
                if surely_out(&[out], x, y) {
                    assert!(!b.contains_cell(c[0], c[1]), "({x}, {y}) h {h}");
                    n_out += 1;
                }
                assert!(!(ins.holds(x, y) && out.excludes(x, y)));
            }
            // Both quick answers occur.
            assert!(n_in > 1000 && n_out > 1000, "{n_in} {n_out}");
        }
        assert!(!Inside::around(&IBox::new([0, 0], [1, 1]), [0.0; 2], 1.0).excludes(f64::NAN, 0.5));
    }
}
