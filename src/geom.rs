//! Integer boxes of cells and the layout of a hierarchy: the domain, its
//! levels (refinement ratio 2), each level's refined boxes, and the patches
//! that tile them. Knows nothing of MPI: the rank that owns a patch is decided
//! elsewhere from this layout.
//!
//! Cell `(i, j)` of level `l` covers `[x0 + i h_l, x0 + (i+1) h_l) ×
//! [y0 + j h_l, y0 + (j+1) h_l)`, with `h_l = h_0 / 2^l`. Boxes are half-open
//! in cell indices: `lo` inclusive, `hi` exclusive.

use crate::error::{Error, Result};

/// Spatial (and temporal) refinement ratio between neighbouring levels.
pub const RATIO: i64 = 2;

/// Most levels a hierarchy may have.
pub const MAX_LEVELS: usize = 8;

/// A half-open box of cells `[lo, hi)` in one level's index space.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct IBox {
    /// Lowest cell index (inclusive).
    pub lo: [i64; 2],
    /// One past the highest cell index (exclusive).
    pub hi: [i64; 2],
}

impl IBox {
    /// The box `[lo, hi)`.
    pub const fn new(lo: [i64; 2], hi: [i64; 2]) -> IBox {
        IBox { lo, hi }
    }

    /// True when the box holds no cell.
    pub fn is_empty(&self) -> bool {
        self.hi[0] <= self.lo[0] || self.hi[1] <= self.lo[1]
    }

    /// Number of cells along each axis (0 when empty).
    pub fn shape(&self) -> [i64; 2] {
        [
            (self.hi[0] - self.lo[0]).max(0),
            (self.hi[1] - self.lo[1]).max(0),
        ]
    }

    /// Number of cells.
    pub fn num_cells(&self) -> i64 {
        let s = self.shape();
        s[0] * s[1]
    }

    /// The intersection (possibly empty).
    pub fn intersect(&self, o: &IBox) -> IBox {
        IBox::new(
            [self.lo[0].max(o.lo[0]), self.lo[1].max(o.lo[1])],
            [self.hi[0].min(o.hi[0]), self.hi[1].min(o.hi[1])],
        )
    }

    /// True when the two boxes share at least one cell.
    pub fn overlaps(&self, o: &IBox) -> bool {
        !self.intersect(o).is_empty()
    }

    /// True when every cell of `o` is in `self` (an empty `o` is contained).
    pub fn contains_box(&self, o: &IBox) -> bool {
        o.is_empty()
            || (o.lo[0] >= self.lo[0]
                && o.lo[1] >= self.lo[1]
                && o.hi[0] <= self.hi[0]
                && o.hi[1] <= self.hi[1])
    }

    /// True when cell `(i, j)` is in the box.
    pub fn contains_cell(&self, i: i64, j: i64) -> bool {
        i >= self.lo[0] && i < self.hi[0] && j >= self.lo[1] && j < self.hi[1]
    }

    /// The box grown by `n` cells on every side (shrunk when `n < 0`).
    pub fn grow(&self, n: i64) -> IBox {
        IBox::new(
            [self.lo[0] - n, self.lo[1] - n],
            [self.hi[0] + n, self.hi[1] + n],
        )
    }

    /// The same region in the index space of the next finer level.
    pub fn refine(&self) -> IBox {
        IBox::new(
            [self.lo[0] * RATIO, self.lo[1] * RATIO],
            [self.hi[0] * RATIO, self.hi[1] * RATIO],
        )
    }

    /// The smallest box of the next coarser level that covers this one.
    pub fn coarsen(&self) -> IBox {
        IBox::new(
            [self.lo[0].div_euclid(RATIO), self.lo[1].div_euclid(RATIO)],
            [
                (self.hi[0] + RATIO - 1).div_euclid(RATIO),
                (self.hi[1] + RATIO - 1).div_euclid(RATIO),
            ],
        )
    }

    /// `self` minus `o`, as at most four disjoint boxes.
    pub fn difference(&self, o: &IBox) -> Vec<IBox> {
        let cut = self.intersect(o);
        if cut.is_empty() {
            return if self.is_empty() { vec![] } else { vec![*self] };
        }
        let mut out = Vec::with_capacity(4);
        // Slabs below and above the cut (full width), then left and right.
        let below = IBox::new(self.lo, [self.hi[0], cut.lo[1]]);
        let above = IBox::new([self.lo[0], cut.hi[1]], self.hi);
        let left = IBox::new([self.lo[0], cut.lo[1]], [cut.lo[0], cut.hi[1]]);
        let right = IBox::new([cut.hi[0], cut.lo[1]], [self.hi[0], cut.hi[1]]);
        for b in [below, above, left, right] {
            if !b.is_empty() {
                out.push(b);
            }
        }
        out
    }

    /// The part of `self` not covered by any box of `others`.
    pub fn difference_all(&self, others: &[IBox]) -> Vec<IBox> {
        let mut rest = vec![*self];
        for o in others {
            rest = rest.iter().flat_map(|b| b.difference(o)).collect();
            if rest.is_empty() {
                break;
            }
        }
        rest
    }

    /// Tiles the box by patches of at most `size` cells per axis, in
    /// row-major order (x fastest).
    pub fn tile(&self, size: [i64; 2]) -> Vec<IBox> {
        let mut out = Vec::new();
        let mut j = self.lo[1];
        while j < self.hi[1] {
            let j1 = (j + size[1]).min(self.hi[1]);
            let mut i = self.lo[0];
            while i < self.hi[0] {
                let i1 = (i + size[0]).min(self.hi[0]);
                out.push(IBox::new([i, j], [i1, j1]));
                i = i1;
            }
            j = j1;
        }
        out
    }
}

/// One level of the hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    /// Cell size of this level.
    pub h: f64,
    /// Disjoint boxes (in this level's index space) the level covers.
    pub boxes: Vec<IBox>,
    /// Largest patch, in cells per axis; boxes are tiled by it.
    pub patch_size: [i64; 2],
}

/// The layout of a hierarchy of nested levels over a rectangular domain.
#[derive(Clone, Debug, PartialEq)]
pub struct Hierarchy {
    /// Lower-left corner of the domain.
    pub origin: [f64; 2],
    /// Number of level-0 cells along each axis.
    pub ncells0: [i64; 2],
    /// Levels, coarsest first; level 0 covers the domain.
    pub levels: Vec<Level>,
    /// Proper-nesting buffer: a level's boxes grown by this many cells of the
    /// next coarser level must lie inside that level's boxes (or outside the
    /// domain).
    pub nest_buffer: i64,
}

/// Default proper-nesting buffer in coarse cells: the fine level's ghost
/// ring (4 fine cells = 2 coarse cells) plus a band of 2 coarse cells of
/// fine-sized particles it may move into.
pub const DEFAULT_NEST_BUFFER: i64 = 4;

/// Width, in cells of a refined level, of its ghost ring: the band outside
/// its boxes where it computes with copies of the coarser level's particles
/// (4, as in the paper). The nesting buffer must leave room for it.
pub const RING: i64 = 4;

/// Smallest proper-nesting buffer (coarse cells): the ring (`RING / 2`
/// coarse cells) plus one cell of room to move.
pub const MIN_NEST_BUFFER: i64 = RING / 2 + 1;

/// Relative tolerance used when snapping physical coordinates to cell edges.
const SNAP_TOL: f64 = 1e-9;

fn snap(v: f64, what: &str, h: f64) -> Result<i64> {
    let r = v.round();
    if (v - r).abs() > SNAP_TOL * r.abs().max(1.0) {
        return Err(Error::arg(format!(
            "{what} = {v} cells is not aligned to the cells of size {h} of the coarser level; it must be an integer multiple within a relative {SNAP_TOL:e}"
        )));
    }
    Ok(r as i64)
}

impl Hierarchy {
    /// A one-level hierarchy over `[x0, x0+lx] × [y0, y0+ly]` with cells of
    /// size `h`; `lx/h` and `ly/h` must be integers.
    pub fn new(x0: f64, y0: f64, lx: f64, ly: f64, h: f64) -> Result<Hierarchy> {
        for (name, v) in [("x0", x0), ("y0", y0)] {
            crate::limits::magnitude(name, v)?;
        }
        for (name, v) in [("lx", lx), ("ly", ly), ("h", h)] {
            crate::limits::positive(name, v)?;
        }
        // Positions must resolve to a fraction of the finest cell: the
        // farthest domain corner at most MAX_EXTENT_CELLS cells from 0.
        let far = [x0.abs(), (x0 + lx).abs(), y0.abs(), (y0 + ly).abs()]
            .into_iter()
            .fold(0.0f64, f64::max);
        if far / h > crate::limits::MAX_EXTENT_CELLS {
            return Err(Error::arg(format!(
                "h = {h} is too small for a domain whose corners lie up to {far} from the origin of coordinates: at most {} cells of size h may separate them (move the origin closer to the domain, or use larger cells)",
                crate::limits::MAX_EXTENT_CELLS
            )));
        }
        let nx = snap(lx / h, "lx/h", h)?;
        let ny = snap(ly / h, "ly/h", h)?;
        if nx < 1 || ny < 1 || nx > (1 << 24) || ny > (1 << 24) {
            return Err(Error::arg(format!(
                "lx/h = {nx} and ly/h = {ny} must each be between 1 and 2^24 cells"
            )));
        }
        let full = IBox::new([0, 0], [nx, ny]);
        Ok(Hierarchy {
            origin: [x0, y0],
            ncells0: [nx, ny],
            levels: vec![Level {
                h,
                boxes: vec![full],
                patch_size: [nx, ny],
            }],
            nest_buffer: DEFAULT_NEST_BUFFER,
        })
    }

    /// Number of levels.
    pub fn num_levels(&self) -> usize {
        self.levels.len()
    }

    /// Cell size of level `l`.
    pub fn h(&self, l: usize) -> f64 {
        self.levels[l].h
    }

    /// The whole domain as a box of level `l`.
    pub fn domain_box(&self, l: usize) -> IBox {
        let f = RATIO.pow(l as u32);
        IBox::new([0, 0], [self.ncells0[0] * f, self.ncells0[1] * f])
    }

    /// Upper-right corner of the domain.
    pub fn upper(&self) -> [f64; 2] {
        let h = self.levels[0].h;
        [
            self.origin[0] + self.ncells0[0] as f64 * h,
            self.origin[1] + self.ncells0[1] as f64 * h,
        ]
    }

    /// True when the point lies in the closed domain rectangle.
    pub fn contains_point(&self, x: f64, y: f64) -> bool {
        let up = self.upper();
        x >= self.origin[0] && x <= up[0] && y >= self.origin[1] && y <= up[1]
    }

    /// Physical extent `[xlo, ylo, xhi, yhi]` of a box of level `l`.
    pub fn box_extent(&self, l: usize, b: &IBox) -> [f64; 4] {
        let h = self.h(l);
        [
            self.origin[0] + b.lo[0] as f64 * h,
            self.origin[1] + b.lo[1] as f64 * h,
            self.origin[0] + b.hi[0] as f64 * h,
            self.origin[1] + b.hi[1] as f64 * h,
        ]
    }

    /// The cell of level `l` that holds the point (points on the upper domain
    /// edge belong to the last cell).
    pub fn cell_of(&self, l: usize, x: f64, y: f64) -> [i64; 2] {
        let h = self.h(l);
        let d = self.domain_box(l);
        let i = (((x - self.origin[0]) / h).floor() as i64).clamp(0, d.hi[0] - 1);
        let j = (((y - self.origin[1]) / h).floor() as i64).clamp(0, d.hi[1] - 1);
        [i, j]
    }

    /// The finest level whose boxes hold the point.
    pub fn level_of_point(&self, x: f64, y: f64) -> usize {
        for l in (1..self.levels.len()).rev() {
            let [i, j] = self.cell_of(l, x, y);
            if self.levels[l].boxes.iter().any(|b| b.contains_cell(i, j)) {
                return l;
            }
        }
        0
    }

    /// Sets the proper-nesting buffer (coarse cells) checked by `add_level`.
    pub fn set_nest_buffer(&mut self, n: i64) -> Result<()> {
        if self.levels.len() > 1 {
            return Err(Error::state(
                "the nesting buffer must be set before the first refined level is added",
            ));
        }
        if !(MIN_NEST_BUFFER..=64).contains(&n) {
            return Err(Error::arg(format!(
                "nest_buffer = {n} must be between {MIN_NEST_BUFFER} (the fine ghost ring plus one cell) and 64 coarse cells"
            )));
        }
        self.nest_buffer = n;
        Ok(())
    }

    /// Adds a finer level covering the given boxes, each `[xlo, ylo, xhi,
    /// yhi]` in physical coordinates. Every box must be non-empty, aligned to
    /// the cells of the current finest level, inside the domain, disjoint from
    /// the others, and nested in the current finest level with the nesting
    /// buffer (except where it touches the physical boundary).
    pub fn add_level(&mut self, boxes: &[[f64; 4]]) -> Result<()> {
        if self.levels.len() >= MAX_LEVELS {
            return Err(Error::arg(format!(
                "the hierarchy already has {} levels, the most allowed ({MAX_LEVELS})",
                self.levels.len()
            )));
        }
        if boxes.is_empty() {
            return Err(Error::arg("nboxes = 0: a level needs at least one box"));
        }
        if boxes.len() > crate::limits::MAX_BOXES_PER_LEVEL {
            return Err(Error::arg(format!(
                "nboxes = {} must be at most {} boxes per level",
                boxes.len(),
                crate::limits::MAX_BOXES_PER_LEVEL
            )));
        }
        let c = self.levels.len() - 1; // coarser level
        let hc = self.h(c);
        let cdom = self.domain_box(c);
        let mut cboxes = Vec::with_capacity(boxes.len());
        for (k, b) in boxes.iter().enumerate() {
            if b.iter().any(|v| !v.is_finite()) {
                return Err(Error::arg(format!(
                    "boxes[{k}] has a non-finite coordinate"
                )));
            }
            if !(b[2] > b[0] && b[3] > b[1]) {
                return Err(Error::arg(format!(
                    "boxes[{k}] = [{}, {}, {}, {}] is empty: it needs xhi > xlo and yhi > ylo",
                    b[0], b[1], b[2], b[3]
                )));
            }
            let ib = IBox::new(
                [
                    snap(
                        (b[0] - self.origin[0]) / hc,
                        &format!("boxes[{k}].xlo offset"),
                        hc,
                    )?,
                    snap(
                        (b[1] - self.origin[1]) / hc,
                        &format!("boxes[{k}].ylo offset"),
                        hc,
                    )?,
                ],
                [
                    snap(
                        (b[2] - self.origin[0]) / hc,
                        &format!("boxes[{k}].xhi offset"),
                        hc,
                    )?,
                    snap(
                        (b[3] - self.origin[1]) / hc,
                        &format!("boxes[{k}].yhi offset"),
                        hc,
                    )?,
                ],
            );
            if !cdom.contains_box(&ib) {
                let up = self.upper();
                return Err(Error::arg(format!(
                    "boxes[{k}] = [{}, {}, {}, {}] is not inside the domain [{}, {}, {}, {}]",
                    b[0], b[1], b[2], b[3], self.origin[0], self.origin[1], up[0], up[1]
                )));
            }
            for (m, o) in cboxes.iter().enumerate() {
                if ib.overlaps(o) {
                    return Err(Error::arg(format!(
                        "boxes[{k}] overlaps boxes[{m}]; the boxes of one level must be disjoint"
                    )));
                }
            }
            // Proper nesting: the box grown by the buffer, clipped to the
            // domain, must be covered by the coarser level's boxes.
            let grown = ib.grow(self.nest_buffer).intersect(&cdom);
            if !grown.difference_all(&self.levels[c].boxes).is_empty() {
                return Err(Error::arg(format!(
                    "boxes[{k}] = [{}, {}, {}, {}] is not nested in level {c}: grown by the nesting buffer of {} cells of size {hc} it leaves level {c}'s boxes",
                    b[0], b[1], b[2], b[3], self.nest_buffer
                )));
            }
            cboxes.push(ib);
        }
        let fine: Vec<IBox> = cboxes.iter().map(|b| b.refine()).collect();
        // Default patch: the largest box with its ghost ring.
        let ps = fine.iter().fold([1, 1], |a, b| {
            let s = b.grow(RING).shape();
            [a[0].max(s[0]), a[1].max(s[1])]
        });
        self.levels.push(Level {
            h: hc / RATIO as f64,
            boxes: fine,
            patch_size: ps,
        });
        Ok(())
    }

    /// Sets the largest patch size (cells per axis) of level `l`.
    pub fn set_patch_size(&mut self, l: usize, px: i64, py: i64) -> Result<()> {
        if l >= self.levels.len() {
            return Err(Error::arg(format!(
                "level = {l} must be below the number of levels ({})",
                self.levels.len()
            )));
        }
        for (name, v) in [("px", px), ("py", py)] {
            if !(1..=(1 << 24)).contains(&v) {
                return Err(Error::arg(format!(
                    "{name} = {v} must be between 1 and 2^24 cells"
                )));
            }
        }
        self.levels[l].patch_size = [px, py];
        Ok(())
    }

    /// The patches of level `l`: each box tiled by the level's patch size,
    /// boxes in order.
    pub fn patches(&self, l: usize) -> Vec<IBox> {
        let lv = &self.levels[l];
        lv.boxes
            .iter()
            .flat_map(|b| b.tile(lv.patch_size))
            .collect()
    }

    /// The region level `l` computes on: its boxes grown by `ring` cells of
    /// the level (the ghost ring of copied particles), clipped to the
    /// domain, as disjoint boxes (each box's own cells first, then the parts
    /// of its ring not already covered). Level 0 is the domain.
    pub fn computational_boxes(&self, l: usize, ring: i64) -> Vec<IBox> {
        let dom = self.domain_box(l);
        let mut out: Vec<IBox> = Vec::new();
        for b in &self.levels[l].boxes {
            let g = b.grow(if l == 0 { 0 } else { ring }).intersect(&dom);
            let pieces = g.difference_all(&out);
            out.extend(pieces);
        }
        out
    }

    /// The index of the patch of level `l` that holds cell `c`, if any.
    pub fn patch_of_cell(&self, patches: &[IBox], c: [i64; 2]) -> Option<usize> {
        patches.iter().position(|p| p.contains_cell(c[0], c[1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_calculus() {
        let a = IBox::new([0, 0], [10, 6]);
        let b = IBox::new([4, 2], [7, 9]);
        assert_eq!(a.intersect(&b), IBox::new([4, 2], [7, 6]));
        let d = a.difference(&b);
        let cells: i64 = d.iter().map(|x| x.num_cells()).sum();
        assert_eq!(cells, a.num_cells() - a.intersect(&b).num_cells());
        for (i, x) in d.iter().enumerate() {
            assert!(!x.overlaps(&b));
            for y in &d[i + 1..] {
                assert!(!x.overlaps(y));
            }
        }
        assert_eq!(
            IBox::new([1, 1], [3, 3]).refine(),
            IBox::new([2, 2], [6, 6])
        );
        assert_eq!(
            IBox::new([1, 1], [3, 4]).coarsen(),
            IBox::new([0, 0], [2, 2])
        );
        assert_eq!(
            IBox::new([-3, -1], [3, 4]).coarsen(),
            IBox::new([-2, -1], [2, 2])
        );
        let t = a.tile([4, 4]);
        assert_eq!(t.len(), 6);
        assert_eq!(t.iter().map(|x| x.num_cells()).sum::<i64>(), 60);
        assert!(a.difference_all(&t).is_empty());
    }

    #[test]
    fn nesting_checks() {
        let mut h = Hierarchy::new(0.0, 0.0, 60.0, 40.0, 1.0).unwrap();
        // Touching the domain boundary is allowed (symmetry plane).
        h.add_level(&[[0.0, 20.0, 20.0, 40.0]]).unwrap();
        assert_eq!(h.levels[1].boxes[0], IBox::new([0, 40], [40, 80]));
        // Level 2 too close to level 1's inner edge (x = 20): rejected.
        let e = h.add_level(&[[0.0, 30.0, 19.0, 40.0]]).unwrap_err();
        assert!(e.msg.contains("not nested"), "{}", e.msg);
        // Misaligned to level-1 cells (0.5): rejected.
        let e = h.add_level(&[[0.0, 30.0, 10.25, 40.0]]).unwrap_err();
        assert!(e.msg.contains("aligned"), "{}", e.msg);
        h.add_level(&[[0.0, 30.0, 10.0, 40.0]]).unwrap();
        assert_eq!(h.level_of_point(1.0, 39.0), 2);
        assert_eq!(h.level_of_point(15.0, 39.0), 1);
        assert_eq!(h.level_of_point(50.0, 5.0), 0);
        let cb = h.computational_boxes(2, 4);
        assert_eq!(cb, vec![IBox::new([0, 116], [44, 160])]);
        assert_eq!(h.computational_boxes(0, 4), h.levels[0].boxes);
        let e = Hierarchy::new(0.0, 0.0, 1.0, 1.0, 0.3).unwrap_err();
        assert!(e.msg.contains("lx/h"), "{}", e.msg);
    }
}
