//! Rigid indenters: shape, placement, prescribed motion, and the signed gap
//! between an indenter and a GIMP particle's rectangle (the geometry of the
//! contact algorithm of Ma et al. 2005, section 2.1).
//!
//! # Conventions
//!
//! - **Units and plane.** SI throughout: lengths in m, times in s, speeds in
//!   m/s. 2D plane strain: an indenter is a prism, infinite along z. Angles
//!   are in radians in Rust (the C API takes the wedge half-angle in degrees).
//! - **Orientation.** Every indenter points down (−y); the body lies below it.
//! - **Tip.** The point by which an indenter is placed and moved:
//!   - wedge: the apex;
//!   - cylinder: the lowest point of the circle (its centre is at
//!     `tip + (0, R)`);
//!   - flat punch: the centre of the flat bottom face;
//!   - polygon: the origin of the vertices' coordinates (the vertices are
//!     given relative to the tip).
//! - **Depth and speed.** `depth(t)` is the downward displacement of the tip
//!   since its placement: `tip(t) = tip0 − (0, depth(t))`; `speed(t) =
//!   d depth/dt`. Both are positive moving down into the body (loading) and
//!   negative moving up (unloading). The indenter does not rotate; it moves
//!   sideways only by its lateral table ([`Indenter::set_lateral`]):
//!   `tip(t) = tip0 + (lateral(t), −depth(t))`. At rest (the default)
//!   `depth ≡ 0` and `lateral ≡ 0`.
//! - **Friction.** Each indenter has a Coulomb coefficient `μ`
//!   ([`Indenter::set_friction`]): 0 (the default) is frictionless, `∞`
//!   sticks wherever there is pressure.
//! - **Gap.** [`Indenter::gap_rect`] compares the indenter at time `t` with
//!   an axis-aligned rectangle (a GIMP particle's domain: centre `c`,
//!   half-lengths `half`), both taken as closed sets:
//!   - `dist > 0`: apart; `dist` is the Euclidean distance between the sets;
//!   - `dist < 0`: overlapping; `−dist` is the penetration depth, the length
//!     of the shortest translation of the rectangle that separates the two,
//!     and that translation is `−dist · normal`;
//!   - `dist = 0`: touching.
//!
//!   `normal` is a unit vector from the indenter toward the rectangle: the
//!   outward normal of the indenter's surface at `point`, and the gradient of
//!   `dist` with respect to the rectangle's centre (a rectangle straight
//!   below the indenter gets `(0, −1)`). A contact pressure pushes the body
//!   along `+normal`. `point` is the point of the indenter's surface nearest
//!   to the rectangle (apart) or the indenter's surface point where the
//!   rectangle is deepest (overlapping); it is where the rectangle touches
//!   the indenter after a translation by `−dist · normal`.
//!   `dist` is exact (no sampling; only rounding), 1-Lipschitz and
//!   continuous in `c` and `half`. `normal` is continuous in `c` except
//!   for overlaps deeper than the shape's corner radius (any overlap for
//!   the sharp shapes), where it switches between two faces' normals on the
//!   set of centres equidistant from both (the medial axis).
//!
//! # Shapes
//!
//! Every shape is a convex core polygon `K` (one point, a segment, or a convex
//! polygon) grown by a disc of radius `r` (the Minkowski sum `K ⊕ D_r`):
//!
//! | shape | core `K` (relative to the tip) | `r` |
//! |---|---|---|
//! | wedge, half-angle `α`, height `H` | triangle `(0,0)`, `(H tan α, H)`, `(−H tan α, H)` | 0 |
//! | cylinder, radius `R` | the point `(0, R)` | `R` |
//! | flat punch, half-width `a`, corner radius `ρ`, height `H` | rectangle `[−(a−ρ), a−ρ] × [ρ, H−ρ]` | `ρ` |
//! | polygon | the given vertices (CCW, collinear vertices removed) | 0 |
//!
//! The wedge's flanks run from the apex up to `y_tip + H` and a horizontal top
//! edge closes it. The flat punch occupies `[−a, a] × [y_tip, y_tip + H]`
//! with its corners rounded by `ρ`: its two bottom corners (the ones that
//! touch the body) and, because one disc grows the whole core, its two top
//! corners too (so `H ≥ 2ρ` is required); `ρ = 0` gives sharp corners.
//!
//! # Method
//!
//! The rectangle `c ⊕ B` (with `B = [−lx, lx] × [−ly, ly]`) overlaps
//! `K ⊕ D_r` exactly when `c` lies in `(K ⊕ B) ⊕ D_r`; hence `dist` is the
//! signed distance from `c` to the convex polygon `P = K ⊕ B`, minus `r`.
//! `P` is never built: its faces are `K`'s edges translated by the corner of
//! `B` that supports their normal (computed once at construction) and `B`'s
//! edges translated to the vertices of `K` extreme along the axes. Per call,
//! one pass over `P`'s `n + 4` face normals finds the face whose half-plane
//! `c` violates most; the foot of `c` on that face, clamped to the face, is
//! the nearest point of `P`'s boundary (see `Core::gap` for why). No search,
//! no allocation; tens of ns per call.

use crate::error::{Error, Result};
use std::f64::consts::PI;

/// Relative tolerance below which the sine of a polygon's turn counts as a
/// straight continuation (the vertex is collinear with its neighbours).
const TURN_TOL: f64 = 1e-12;
/// Relative tolerance (to the polygon's diameter) below which an edge counts
/// as having zero length.
const EDGE_TOL: f64 = 1e-12;
/// Largest length or coordinate accepted (m): far beyond any physical scene,
/// small enough that no sum, difference or square of lengths overflows.
const MAX_LEN: f64 = 1e100;

/// The geometry of an indenter, pointing down (−y), relative to its tip.
/// See the module documentation for what "tip" means for each shape.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A 2D wedge (plane-strain cone): apex at the tip, flanks at
    /// `half_angle` (radians) from the vertical axis, rising to `height`
    /// above the apex, closed by a horizontal top edge.
    /// Bounds: `0 < half_angle < π/2`, `height > 0`, both finite. Typical
    /// values: 65° (quoted for the paper's wedge example; its text does not
    /// state the angle) and 70.3° (the Berkovich-equivalent cone).
    Wedge {
        /// Angle between the vertical axis and each flank, radians.
        half_angle: f64,
        /// Height of the flanks above the apex, m.
        height: f64,
    },
    /// A circle of the given radius whose lowest point is the tip.
    /// Bounds: `radius > 0`, finite.
    Cylinder {
        /// Radius, m.
        radius: f64,
    },
    /// A flat punch occupying `[−half_width, half_width] × [0, height]`
    /// relative to the tip (the centre of the flat bottom face), with all four
    /// corners rounded by `corner_radius` (0: sharp).
    /// Bounds: `half_width > 0`, `0 ≤ corner_radius ≤ half_width`,
    /// `height > 0`, `height ≥ 2 corner_radius`, all finite.
    FlatPunch {
        /// Half of the punch's width, m.
        half_width: f64,
        /// Radius of the rounded corners, m.
        corner_radius: f64,
        /// Height of the punch, m.
        height: f64,
    },
    /// A convex polygon with vertices given relative to the tip (the
    /// reference point by which it is placed and moved).
    /// Bounds: at least 3 finite vertices, clockwise or counter-clockwise,
    /// convex, nonzero area, no zero-length edge (shorter than 1e-12 times
    /// the polygon's diameter), winding once. Collinear consecutive vertices
    /// (the sine of the turn within 1e-12, the vertex between its neighbours)
    /// are accepted and dropped; a vertex where the outline folds back is
    /// rejected.
    Polygon {
        /// The vertices `[x, y]`, m, relative to the tip.
        vertices: Vec<[f64; 2]>,
    },
}

/// A prescribed motion of the indenter along −y (see the module
/// documentation for the sign of depth and speed).
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    /// At rest at its placement: `depth ≡ 0`, `speed ≡ 0` (the default).
    Rest,
    /// Downward tip speed (m/s, > 0 into the body, < 0 out of it) given at
    /// increasing times, linear in between; before the first time the first
    /// value, after the last the last value. The depth is its exact integral
    /// from `t = 0` (piecewise quadratic; for `t < 0`, `speed[0] · t`).
    /// Bounds: equal lengths ≥ 1, every value finite, times strictly
    /// increasing, `times[0] ≥ 0`.
    Velocity {
        /// Times, s.
        times: Vec<f64>,
        /// Downward tip speed at each time, m/s.
        speed: Vec<f64>,
    },
    /// Depth (downward tip displacement from its placement, m) given at
    /// increasing times, linear in between, held constant outside (so the
    /// depth before `times[0]` is `depth[0]`, which need not be 0).
    /// The speed is the slope of the interval containing `t`, taken from the
    /// right at the given times, and 0 before the first and from the last.
    /// Bounds: equal lengths ≥ 1, every value finite, times strictly
    /// increasing, `times[0] ≥ 0`.
    Depth {
        /// Times, s.
        times: Vec<f64>,
        /// Depth at each time, m.
        depth: Vec<f64>,
    },
}

/// The signed gap between an indenter and a rectangle (or a point); see the
/// module documentation for the conventions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gap {
    /// Signed separation, m: > 0 apart (the distance), < 0 overlapping (minus
    /// the penetration depth along `normal`).
    pub dist: f64,
    /// Unit normal from the indenter toward the rectangle.
    pub normal: [f64; 2],
    /// The point of the indenter's surface nearest to the rectangle (apart),
    /// or the surface point where the rectangle is deepest (overlapping).
    pub point: [f64; 2],
    /// True when the rectangle is apart and nearest to a sharp vertex of
    /// the indenter (a wedge's apex, a sharp punch corner): `normal` is
    /// then the direction from the vertex, not the normal of a surface the
    /// rectangle's faces lie along.
    pub vertex: bool,
}

/// One vertex of the core polygon and the edge that leaves it.
#[derive(Clone, Debug)]
struct CoreVertex {
    /// Position relative to the tip.
    p: [f64; 2],
    /// Outward unit normal of the edge from this vertex to the next.
    n: [f64; 2],
    /// Unit tangent of that edge (from this vertex to the next).
    tan: [f64; 2],
    /// Length of that edge.
    len: f64,
    /// `n · p`: the edge's offset.
    off: f64,
    /// Corner of `B` (index into `SX`/`SY`) that supports `n`: the translation
    /// of this edge in `P = K ⊕ B`.
    support: u8,
    /// True when `n` is an axis direction (its half-plane is one of the axis
    /// half-planes) or undefined (one-point core).
    axis: bool,
}

/// A core edge that is not axis-aligned, as the gap needs it (the
/// axis-aligned ones coincide with faces of `P` along `B`'s edges, handled
/// through `Core::ext`).
#[derive(Clone, Debug)]
struct Face {
    /// Outward unit normal.
    n: [f64; 2],
    /// `|n|` componentwise: `B`'s support along `n` is `lx |nx| + ly |ny|`.
    an: [f64; 2],
    /// `n · p`.
    off: f64,
    /// Start vertex (relative to the tip).
    p: [f64; 2],
    /// End vertex.
    q: [f64; 2],
    /// Unit tangent from `p` to `q`.
    tan: [f64; 2],
    /// Length `|q − p|`.
    len: f64,
    /// Corner of `B` supporting `n`: the edge's translation in `P`.
    support: u8,
}

/// The convex core `K` and the radius `r` it is grown by.
#[derive(Clone, Debug)]
struct Core {
    /// The vertices counter-clockwise (one for a point, two for a segment),
    /// each with the edge that leaves it.
    v: Vec<CoreVertex>,
    /// The edges that are not axis-aligned (the loop of the gap).
    faces: Vec<Face>,
    /// Lower-left corner of `K`'s bounding box, relative to the tip.
    lo: [f64; 2],
    /// Upper-right corner of `K`'s bounding box, relative to the tip.
    hi: [f64; 2],
    /// For the axis directions +x, +y, −x, −y (in that order): the interval
    /// of the other coordinate over which `K` reaches its extreme.
    ext: [[f64; 2]; 4],
    /// Radius of the disc `K` is grown by.
    r: f64,
}

/// Signs of `B`'s corners, counter-clockwise from the lower right:
/// 0 = (+lx, −ly), 1 = (+lx, +ly), 2 = (−lx, +ly), 3 = (−lx, −ly).
const SX: [f64; 4] = [1.0, 1.0, -1.0, -1.0];
const SY: [f64; 4] = [-1.0, 1.0, 1.0, -1.0];
/// Outward normals of the axis half-planes: +x, +y, −x, −y.
const AXN: [[f64; 2]; 4] = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];

#[inline(always)]
fn corner(i: u8, half: [f64; 2]) -> [f64; 2] {
    let i = (i & 3) as usize;
    [SX[i] * half[0], SY[i] * half[1]]
}

/// The corner of `B` that supports direction `n` (unique unless `n` is an
/// axis direction, whose faces are handled apart): angle in [−90°, 0°) → 0,
/// [0°, 90°) → 1, [90°, 180°) → 2, [180°, 270°) → 3.
fn support_corner(n: [f64; 2]) -> u8 {
    let (nx, ny) = (n[0], n[1]);
    if ny < 0.0 || (ny == 0.0 && nx < 0.0) {
        if nx < 0.0 {
            3
        } else {
            0
        }
    } else if nx > 0.0 {
        1
    } else {
        2
    }
}

#[inline(always)]
fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

#[inline(always)]
fn add(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] + b[0], a[1] + b[1]]
}

#[inline(always)]
fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

#[inline(always)]
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// A number for an error message: the shorter of Rust's plain and exponent
/// forms (`0.5`, `1e-9`, `1e300`), both exact round trips.
fn num(x: f64) -> String {
    let plain = format!("{x}");
    let exp = format!("{x:e}");
    if exp.len() < plain.len() {
        exp
    } else {
        plain
    }
}

/// A number for an error message: degrees rounded to 9 decimals, so that a
/// value given in degrees and converted to radians reads back as given.
fn degrees(rad: f64) -> String {
    let d = rad.to_degrees();
    if d.is_finite() {
        format!("{}", (d * 1e9).round() / 1e9)
    } else {
        format!("{d}")
    }
}

fn positive(name: &str, x: f64) -> Result<()> {
    if !(x.is_finite() && x > 0.0) {
        Err(Error::arg(format!(
            "{name} = {} must be finite and > 0",
            num(x)
        )))
    } else if x > MAX_LEN {
        Err(Error::arg(format!(
            "{name} = {} must be <= {MAX_LEN:e} (m)",
            num(x)
        )))
    } else {
        Ok(())
    }
}

impl Core {
    /// The core from its vertices: one point, a segment (two distinct
    /// points), or a convex polygon in counter-clockwise order with no
    /// repeated or collinear vertex.
    fn new(p: Vec<[f64; 2]>, r: f64) -> Core {
        let n = p.len();
        debug_assert!(n >= 1);
        let mut lo = p[0];
        let mut hi = p[0];
        for q in &p {
            lo = [lo[0].min(q[0]), lo[1].min(q[1])];
            hi = [hi[0].max(q[0]), hi[1].max(q[1])];
        }
        // Extreme sets along each axis direction.
        let mut ext = [[f64::INFINITY, f64::NEG_INFINITY]; 4];
        for q in &p {
            let widen = |e: &mut [f64; 2], s: f64| {
                e[0] = e[0].min(s);
                e[1] = e[1].max(s);
            };
            if q[0] == hi[0] {
                widen(&mut ext[0], q[1]);
            }
            if q[1] == hi[1] {
                widen(&mut ext[1], q[0]);
            }
            if q[0] == lo[0] {
                widen(&mut ext[2], q[1]);
            }
            if q[1] == lo[1] {
                widen(&mut ext[3], q[0]);
            }
        }
        let mut v: Vec<CoreVertex> = p
            .iter()
            .map(|&q| CoreVertex {
                p: q,
                n: [0.0, 0.0],
                tan: [0.0, 0.0],
                len: 0.0,
                off: 0.0,
                support: 0,
                axis: true,
            })
            .collect();
        if n >= 2 {
            for i in 0..n {
                let d = sub(p[(i + 1) % n], p[i]);
                let len = d[0].hypot(d[1]);
                let tan = [d[0] / len, d[1] / len];
                let nrm = [tan[1], -tan[0]];
                let cv = &mut v[i];
                cv.n = nrm;
                cv.tan = tan;
                cv.len = len;
                cv.off = dot(nrm, p[i]);
                cv.support = support_corner(nrm);
                cv.axis = nrm[0] == 0.0 || nrm[1] == 0.0;
            }
        }
        let faces = v
            .iter()
            .enumerate()
            .filter(|(_, cv)| !cv.axis)
            .map(|(i, cv)| Face {
                n: cv.n,
                an: [cv.n[0].abs(), cv.n[1].abs()],
                off: cv.off,
                p: cv.p,
                q: v[(i + 1) % n].p,
                tan: cv.tan,
                len: cv.len,
                support: cv.support,
            })
            .collect();
        Core {
            v,
            faces,
            lo,
            hi,
            ext,
            r,
        }
    }

    /// The signed gap from the core grown by `r` to the rectangle of centre
    /// `x` (relative to the tip) and half-lengths `half`; `point` relative to
    /// the tip.
    ///
    /// Let `g(u) = u·x − h_P(u)` for unit `u` (`h_P` the support function of
    /// `P = K ⊕ B`). Inside `P`, the signed distance is the largest `g` over
    /// `P`'s face normals. Outside, the distance is the largest `g` over all
    /// directions, reached at the direction from the nearest point `q` to `x`;
    /// the directions with `g > 0` form one arc (`g` is concave and
    /// positively homogeneous), on which `g` is concave in the angle (a
    /// cosine within each vertex's normal cone, with downward kinks of the
    /// slope at face normals). So `q` lies on the face `F` whose normal gives
    /// the largest `g`, or at an end of `F`: the foot of `x` on `F`'s line,
    /// clamped to `F`, is `q` (past an end, the slope of `g` at `F`'s normal
    /// points into that end's normal cone, where the maximum must lie since
    /// the next face's `g` is smaller). One pass over the `n + 4` face
    /// normals, no search.
    #[inline]
    fn gap(&self, x: [f64; 2], half: [f64; 2]) -> Gap {
        let [lx, ly] = half;
        if (x[0] + x[1] + lx + ly).is_nan() {
            // NaN input (or opposite infinities): NaN out, not a silent number.
            return Gap {
                dist: f64::NAN,
                normal: [f64::NAN; 2],
                point: [f64::NAN; 2],
                vertex: false,
            };
        }
        // The face normals of P: the axis directions (codes 0..4) and the
        // core's other edge normals (code 4 + i for `faces[i]`).
        let mut best = x[0] - (self.hi[0] + lx);
        let mut arg = 0usize;
        let cand = x[1] - (self.hi[1] + ly);
        if cand > best {
            best = cand;
            arg = 1;
        }
        let cand = (self.lo[0] - lx) - x[0];
        if cand > best {
            best = cand;
            arg = 2;
        }
        let cand = (self.lo[1] - ly) - x[1];
        if cand > best {
            best = cand;
            arg = 3;
        }
        for (i, f) in self.faces.iter().enumerate() {
            let cand = dot(f.n, x) - f.off - (lx * f.an[0] + ly * f.an[1]);
            if cand > best {
                best = cand;
                arg = 4 + i;
            }
        }
        // The foot of x on the face, clamped to the face: q (a point of P's
        // boundary) and the core point k it comes from (q = k + a point of B).
        let (normal, q, k, on_face) = if arg < 4 {
            // Axis face: fixed coordinate `a`, free coordinate `f`.
            let (a, f) = if arg % 2 == 0 { (0, 1) } else { (1, 0) };
            let sign = if arg < 2 { 1.0 } else { -1.0 };
            let e = self.ext[arg];
            let l = half[f];
            let s = x[f];
            let s_face = s.max(e[0] - l).min(e[1] + l);
            let mut q = [0.0; 2];
            let mut k = [0.0; 2];
            k[a] = if arg < 2 { self.hi[a] } else { self.lo[a] };
            q[a] = k[a] + sign * half[a];
            k[f] = s.max(e[0]).min(e[1]);
            q[f] = s_face;
            (AXN[arg], q, k, s == s_face)
        } else {
            let f = &self.faces[arg - 4];
            let b = corner(f.support, half);
            let s = dot(sub(sub(x, b), f.p), f.tan);
            let k = if s <= 0.0 {
                f.p
            } else if s >= f.len {
                f.q
            } else {
                [f.p[0] + s * f.tan[0], f.p[1] + s * f.tan[1]]
            };
            (f.n, add(k, b), k, s >= 0.0 && s <= f.len)
        };
        if best <= 0.0 || on_face {
            // Inside P, or outside with the foot on the face: the distance to
            // the face's line.
            return self.finish(best, normal, k, false);
        }
        // Outside, nearest to the end q of the face.
        let e = sub(x, q);
        let dist = dot(e, e).sqrt();
        let nrm = if dist > 0.0 {
            [e[0] / dist, e[1] / dist]
        } else {
            normal
        };
        self.finish(dist, nrm, k, true)
    }

    /// The gap from the core's distance; `at_vertex`: nearest to a vertex
    /// of the core from outside (sharp unless the core is grown by `r`).
    #[inline(always)]
    fn finish(&self, dist_core: f64, normal: [f64; 2], k: [f64; 2], at_vertex: bool) -> Gap {
        let r = self.r;
        Gap {
            dist: dist_core - r,
            normal,
            point: [k[0] + r * normal[0], k[1] + r * normal[1]],
            vertex: at_vertex && r == 0.0,
        }
    }
}

/// Validate a polygon and return its vertices counter-clockwise with the
/// collinear ones dropped.
fn convex_polygon(vs: &[[f64; 2]]) -> Result<Vec<[f64; 2]>> {
    let n = vs.len();
    if n < 3 {
        return Err(Error::arg(format!(
            "vertices: a polygon needs at least 3 vertices (got {n})"
        )));
    }
    for (i, v) in vs.iter().enumerate() {
        if !(v[0].is_finite() && v[1].is_finite()) {
            return Err(Error::arg(format!(
                "vertices[{i}] = ({}, {}) must be finite",
                num(v[0]),
                num(v[1])
            )));
        }
        if v[0].abs().max(v[1].abs()) > MAX_LEN {
            return Err(Error::arg(format!(
                "vertices[{i}] = ({}, {}): coordinates must be <= {MAX_LEN:e} (m) in magnitude",
                num(v[0]),
                num(v[1])
            )));
        }
    }
    let mut lo = vs[0];
    let mut hi = vs[0];
    for v in vs {
        lo = [lo[0].min(v[0]), lo[1].min(v[1])];
        hi = [hi[0].max(v[0]), hi[1].max(v[1])];
    }
    let diam = (hi[0] - lo[0]).hypot(hi[1] - lo[1]);
    // Checks on coordinates scaled to the unit box, so tolerances are
    // relative to the polygon's size.
    let u: Vec<[f64; 2]> = vs
        .iter()
        .map(|v| [(v[0] - lo[0]) / diam, (v[1] - lo[1]) / diam])
        .collect();
    for i in 0..n {
        let j = (i + 1) % n;
        let e = sub(u[j], u[i]);
        let l = e[0].hypot(e[1]);
        if l <= EDGE_TOL {
            return Err(Error::arg(format!(
                "vertices: edge {i} from vertices[{i}] = ({}, {}) to vertices[{j}] = ({}, {}) \
                 has zero length (shorter than 1e-12 times the polygon's diameter {})",
                num(vs[i][0]),
                num(vs[i][1]),
                num(vs[j][0]),
                num(vs[j][1]),
                num(diam)
            )));
        }
    }
    let area2: f64 = (0..n).map(|i| cross(u[i], u[(i + 1) % n])).sum();
    if area2.abs() <= EDGE_TOL {
        return Err(Error::arg(
            "vertices: the polygon has zero area (its vertices are collinear, or its \
             outline crosses itself into lobes of opposite orientation)",
        ));
    }
    let order: Vec<usize> = if area2 > 0.0 {
        (0..n).collect()
    } else {
        (0..n).rev().collect()
    };
    let mut kept = Vec::with_capacity(n);
    let mut turning = 0.0;
    for m in 0..n {
        let i = order[m];
        let ip = order[(m + n - 1) % n];
        let inx = order[(m + 1) % n];
        let e1 = sub(u[i], u[ip]);
        let e2 = sub(u[inx], u[i]);
        let cr = cross(e1, e2);
        let dt = dot(e1, e2);
        let sine = cr / (e1[0].hypot(e1[1]) * e2[0].hypot(e2[1]));
        if sine > TURN_TOL {
            kept.push(vs[i]);
            turning += cr.atan2(dt);
        } else if sine >= -TURN_TOL {
            if dt <= 0.0 {
                return Err(Error::arg(format!(
                    "vertices: the polygon folds back on itself at vertices[{i}] = ({}, {})",
                    num(vs[i][0]),
                    num(vs[i][1])
                )));
            }
            // Collinear with its neighbours: dropped.
        } else {
            return Err(Error::arg(format!(
                "vertices: the polygon is not convex (it turns the other way at \
                 vertices[{i}] = ({}, {}))",
                num(vs[i][0]),
                num(vs[i][1])
            )));
        }
    }
    if (turning - 2.0 * PI).abs() > 1e-6 {
        return Err(Error::arg(format!(
            "vertices: the polygon winds {:.3} times around its centre (its outline crosses \
             itself); a convex polygon winds once",
            turning / (2.0 * PI)
        )));
    }
    Ok(kept)
}

/// Validated times/values of a motion table.
fn check_table(tname: &str, times: &[f64], vname: &str, vals: &[f64]) -> Result<()> {
    if times.is_empty() || times.len() != vals.len() {
        return Err(Error::arg(format!(
            "{tname} and {vname} must have equal lengths >= 1 ({tname} has {}, {vname} has {})",
            times.len(),
            vals.len()
        )));
    }
    for (i, &t) in times.iter().enumerate() {
        if !t.is_finite() {
            return Err(Error::arg(format!(
                "{tname}[{i}] = {} must be finite",
                num(t)
            )));
        }
    }
    if times[0] < 0.0 {
        return Err(Error::arg(format!(
            "{tname}[0] = {} must be >= 0",
            num(times[0])
        )));
    }
    for i in 1..times.len() {
        if times[i] <= times[i - 1] {
            return Err(Error::arg(format!(
                "{tname} must be strictly increasing ({tname}[{i}] = {} <= {tname}[{}] = {})",
                num(times[i]),
                i - 1,
                num(times[i - 1])
            )));
        }
    }
    for (i, &v) in vals.iter().enumerate() {
        if !v.is_finite() {
            return Err(Error::arg(format!(
                "{vname}[{i}] = {} must be finite",
                num(v)
            )));
        }
    }
    Ok(())
}

/// The index `i` with `times[i] <= t < times[i + 1]`, for
/// `times[0] < t < times[last]`.
#[inline]
fn interval(times: &[f64], t: f64) -> usize {
    times.partition_point(|&s| s <= t) - 1
}

/// A rigid indenter: a validated [`Shape`], its placement (the tip's position
/// at depth 0) and its prescribed [`Motion`].
#[derive(Clone, Debug)]
pub struct Indenter {
    shape: Shape,
    tip0: [f64; 2],
    core: Core,
    motion: Motion,
    /// For [`Motion::Velocity`]: the depth at each of its times.
    depth_at: Vec<f64>,
    /// Sideways tip displacement table (times, x), empty: none.
    lateral: (Vec<f64>, Vec<f64>),
    /// Coulomb friction coefficient (0: frictionless, `∞`: stick).
    friction: f64,
}

/// An indenter frozen at one time (its tip computed once), for evaluating
/// many gaps in a loop. Obtained from [`Indenter::at`].
#[derive(Clone, Copy, Debug)]
pub struct IndenterAt<'a> {
    ind: &'a Indenter,
    tip: [f64; 2],
}

impl IndenterAt<'_> {
    /// The tip's position.
    pub fn tip(&self) -> [f64; 2] {
        self.tip
    }

    /// [`Indenter::gap_rect`] at this time.
    #[inline]
    pub fn gap_rect(&self, c: [f64; 2], half: [f64; 2]) -> Gap {
        let x = sub(c, self.tip);
        let mut g = self.ind.core.gap(x, half);
        g.point = add(g.point, self.tip);
        g
    }

    /// [`Indenter::gap_point`] at this time.
    #[inline]
    pub fn gap_point(&self, p: [f64; 2]) -> Gap {
        self.gap_rect(p, [0.0, 0.0])
    }
}

impl Indenter {
    /// A validated indenter of the given shape with its tip at `tip`, at rest.
    /// Errors name the bad argument and its bound (see [`Shape`]).
    pub fn new(shape: Shape, tip: [f64; 2]) -> Result<Indenter> {
        if !(tip[0].is_finite() && tip[1].is_finite()) {
            return Err(Error::arg(format!(
                "tip = ({}, {}) must be finite",
                num(tip[0]),
                num(tip[1])
            )));
        }
        if tip[0].abs().max(tip[1].abs()) > MAX_LEN {
            return Err(Error::arg(format!(
                "tip = ({}, {}): coordinates must be <= {MAX_LEN:e} (m) in magnitude",
                num(tip[0]),
                num(tip[1])
            )));
        }
        let core = match &shape {
            &Shape::Wedge { half_angle, height } => {
                if !(half_angle.is_finite() && half_angle > 0.0 && half_angle < PI / 2.0) {
                    return Err(Error::arg(format!(
                        "half_angle = {} rad ({} degrees) must lie in (0, 90) degrees",
                        num(half_angle),
                        degrees(half_angle)
                    )));
                }
                positive("height", height)?;
                let w = height * half_angle.tan();
                if !(w > 0.0 && w <= MAX_LEN) {
                    return Err(Error::arg(format!(
                        "half_angle = {} rad and height = {}: the top half-width \
                         height tan(half_angle) = {} must lie in (0, {MAX_LEN:e}] (m)",
                        num(half_angle),
                        num(height),
                        num(w)
                    )));
                }
                Core::new(vec![[0.0, 0.0], [w, height], [-w, height]], 0.0)
            }
            &Shape::Cylinder { radius } => {
                positive("radius", radius)?;
                Core::new(vec![[0.0, radius]], radius)
            }
            &Shape::FlatPunch {
                half_width,
                corner_radius,
                height,
            } => {
                positive("half_width", half_width)?;
                if !(corner_radius.is_finite()
                    && corner_radius >= 0.0
                    && corner_radius <= half_width)
                {
                    return Err(Error::arg(format!(
                        "corner_radius = {} must be finite and lie in [0, half_width = {}]",
                        num(corner_radius),
                        num(half_width)
                    )));
                }
                positive("height", height)?;
                if height < 2.0 * corner_radius {
                    return Err(Error::arg(format!(
                        "height = {} must be >= 2 corner_radius = {} (the top corners are \
                         rounded too)",
                        num(height),
                        num(2.0 * corner_radius)
                    )));
                }
                let w = half_width - corner_radius;
                let (y0, y1) = (corner_radius, height - corner_radius);
                let mut p: Vec<[f64; 2]> = Vec::with_capacity(4);
                for q in [[-w, y0], [w, y0], [w, y1], [-w, y1]] {
                    if p.last() != Some(&q) && p.first() != Some(&q) {
                        p.push(q);
                    }
                }
                Core::new(p, corner_radius)
            }
            Shape::Polygon { vertices } => Core::new(convex_polygon(vertices)?, 0.0),
        };
        Ok(Indenter {
            shape,
            tip0: tip,
            core,
            motion: Motion::Rest,
            depth_at: Vec::new(),
            lateral: (Vec::new(), Vec::new()),
            friction: 0.0,
        })
    }

    /// Sets the Coulomb friction coefficient: `mu ≥ 0` and finite, or `+∞`
    /// (stick wherever a particle carries pressure). On error the previous
    /// value stays.
    pub fn set_friction(&mut self, mu: f64) -> Result<()> {
        if !(mu >= 0.0) {
            return Err(Error::arg(format!(
                "mu = {}: the friction coefficient must be >= 0 (or infinity for stick)",
                num(mu)
            )));
        }
        self.friction = mu;
        Ok(())
    }

    /// The Coulomb friction coefficient (0: frictionless).
    pub fn friction(&self) -> f64 {
        self.friction
    }

    /// Prescribes the sideways motion: the tip's x displacement from its
    /// placement `x[k]` (m) at the strictly increasing `times[k]` (the first
    /// `>= 0`), linear in between, held constant before the first and after
    /// the last time. Empty tables remove it. On error the previous table
    /// stays.
    pub fn set_lateral(&mut self, times: &[f64], x: &[f64]) -> Result<()> {
        if times.is_empty() && x.is_empty() {
            self.lateral = (Vec::new(), Vec::new());
            return Ok(());
        }
        check_table("times", times, "x", x)?;
        if let Some(i) = x.iter().position(|v| v.abs() > MAX_LEN) {
            return Err(Error::arg(format!(
                "x[{i}] = {}: must be <= {MAX_LEN:e} (m) in magnitude",
                num(x[i])
            )));
        }
        self.lateral = (times.to_vec(), x.to_vec());
        Ok(())
    }

    /// The sideways table `(times, x)` as given (empty: none).
    pub fn lateral(&self) -> (&[f64], &[f64]) {
        (&self.lateral.0, &self.lateral.1)
    }

    /// Sideways displacement of the tip at time `t` (m).
    pub fn lateral_offset(&self, t: f64) -> f64 {
        let (times, x) = (&self.lateral.0, &self.lateral.1);
        let n = times.len();
        if n == 0 {
            return 0.0;
        }
        if t.is_nan() {
            return f64::NAN;
        }
        if t <= times[0] {
            return x[0];
        }
        if t >= times[n - 1] {
            return x[n - 1];
        }
        let i = interval(times, t);
        let f = (t - times[i]) / (times[i + 1] - times[i]);
        x[i] + f * (x[i + 1] - x[i])
    }

    /// Sideways speed of the tip at time `t` (m/s): the slope of the
    /// interval containing `t` (from the right at the given times), 0
    /// outside the table.
    pub fn lateral_speed(&self, t: f64) -> f64 {
        let (times, x) = (&self.lateral.0, &self.lateral.1);
        let n = times.len();
        if n == 0 {
            return 0.0;
        }
        if t.is_nan() {
            return f64::NAN;
        }
        if t < times[0] || t >= times[n - 1] {
            return 0.0;
        }
        let i = interval(times, t);
        (x[i + 1] - x[i]) / (times[i + 1] - times[i])
    }

    /// Prescribe the motion (validated; on error the previous motion stays).
    pub fn set_motion(&mut self, m: Motion) -> Result<()> {
        let depth_at = match &m {
            Motion::Rest => Vec::new(),
            Motion::Velocity { times, speed } => {
                check_table("times", times, "speed", speed)?;
                let mut d: Vec<f64> = Vec::with_capacity(times.len());
                for i in 0..times.len() {
                    let next = if i == 0 {
                        speed[0] * times[0]
                    } else {
                        d[i - 1] + 0.5 * (times[i] - times[i - 1]) * (speed[i - 1] + speed[i])
                    };
                    if !next.is_finite() {
                        return Err(Error::arg(format!(
                            "speed and times: the depth at times[{i}] = {} overflows ({next})",
                            num(times[i])
                        )));
                    }
                    d.push(next);
                }
                d
            }
            Motion::Depth { times, depth } => {
                check_table("times", times, "depth", depth)?;
                Vec::new()
            }
        };
        self.motion = m;
        self.depth_at = depth_at;
        Ok(())
    }

    /// The shape as given.
    pub fn shape(&self) -> &Shape {
        &self.shape
    }

    /// The motion as given ([`Motion::Rest`] by default).
    pub fn motion(&self) -> &Motion {
        &self.motion
    }

    /// The tip's position at depth 0 (its placement).
    pub fn placement(&self) -> [f64; 2] {
        self.tip0
    }

    /// Downward displacement of the tip since placement at time `t` (m)
    /// (NaN for a NaN `t` unless at rest).
    pub fn depth(&self, t: f64) -> f64 {
        match &self.motion {
            Motion::Rest => 0.0,
            _ if t.is_nan() => f64::NAN,
            Motion::Velocity { times, speed } => {
                let n = times.len();
                if t <= times[0] {
                    return speed[0] * t;
                }
                if t >= times[n - 1] {
                    return self.depth_at[n - 1] + speed[n - 1] * (t - times[n - 1]);
                }
                let i = interval(times, t);
                let tau = t - times[i];
                let h = times[i + 1] - times[i];
                self.depth_at[i] + tau * (speed[i] + (speed[i + 1] - speed[i]) * tau / (2.0 * h))
            }
            Motion::Depth { times, depth } => {
                let n = times.len();
                if t <= times[0] {
                    return depth[0];
                }
                if t >= times[n - 1] {
                    return depth[n - 1];
                }
                let i = interval(times, t);
                let f = (t - times[i]) / (times[i + 1] - times[i]);
                depth[i] + f * (depth[i + 1] - depth[i])
            }
        }
    }

    /// Downward speed of the tip at time `t` (m/s): `d depth / dt`
    /// (NaN for a NaN `t` unless at rest).
    pub fn speed(&self, t: f64) -> f64 {
        match &self.motion {
            Motion::Rest => 0.0,
            _ if t.is_nan() => f64::NAN,
            Motion::Velocity { times, speed } => {
                let n = times.len();
                if t <= times[0] {
                    return speed[0];
                }
                if t >= times[n - 1] {
                    return speed[n - 1];
                }
                let i = interval(times, t);
                let f = (t - times[i]) / (times[i + 1] - times[i]);
                speed[i] + f * (speed[i + 1] - speed[i])
            }
            Motion::Depth { times, depth } => {
                let n = times.len();
                if t < times[0] || t >= times[n - 1] {
                    return 0.0;
                }
                let i = interval(times, t);
                (depth[i + 1] - depth[i]) / (times[i + 1] - times[i])
            }
        }
    }

    /// The tip's velocity at time `t`: `(lateral_speed(t), −speed(t))`
    /// (m/s).
    pub fn velocity(&self, t: f64) -> [f64; 2] {
        [self.lateral_speed(t), -self.speed(t)]
    }

    /// The tip's position at time `t`: `placement + (lateral(t), −depth(t))`.
    pub fn tip(&self, t: f64) -> [f64; 2] {
        [
            self.tip0[0] + self.lateral_offset(t),
            self.tip0[1] - self.depth(t),
        ]
    }

    /// The indenter at time `t`, for many gap queries at one time.
    pub fn at(&self, t: f64) -> IndenterAt<'_> {
        IndenterAt {
            ind: self,
            tip: self.tip(t),
        }
    }

    /// The indenter's bounding box at time `t`: `[xlo, ylo, xhi, yhi]` (exact:
    /// the smallest axis-aligned box containing it).
    pub fn bbox(&self, t: f64) -> [f64; 4] {
        let tip = self.tip(t);
        let c = &self.core;
        [
            tip[0] + c.lo[0] - c.r,
            tip[1] + c.lo[1] - c.r,
            tip[0] + c.hi[0] + c.r,
            tip[1] + c.hi[1] + c.r,
        ]
    }

    /// Signed separation between the indenter at time `t` and the rectangle
    /// of centre `c` and half-lengths `half` (`≥ 0`, finite; not checked
    /// here, the caller validates particles: other values give meaningless
    /// numbers but never a panic, and NaN propagates): `dist > 0` apart
    /// (the Euclidean distance between the two sets), `< 0` overlapping (minus
    /// the penetration depth along `normal`); `normal` unit, from the indenter
    /// toward the rectangle; `point` on the indenter's surface (see the module
    /// documentation). Allocation-free.
    pub fn gap_rect(&self, t: f64, c: [f64; 2], half: [f64; 2]) -> Gap {
        self.at(t).gap_rect(c, half)
    }

    /// [`Indenter::gap_rect`] for a point (`half = 0`): the signed distance
    /// from the indenter's surface, negative inside.
    pub fn gap_point(&self, t: f64, p: [f64; 2]) -> Gap {
        self.at(t).gap_rect(p, [0.0, 0.0])
    }

    /// The indenter's outline at time `t` as a closed polyline,
    /// counter-clockwise, its first point repeated at the end. Arcs (rounded
    /// shapes) are sampled with `arc_segments` segments per full turn (each
    /// arc gets at least one, a full circle at least three; values above
    /// 65536 count as 65536); every point lies on the surface. For plots and
    /// output.
    pub fn outline(&self, t: f64, arc_segments: usize) -> Vec<[f64; 2]> {
        let tip = self.tip(t);
        let c = &self.core;
        let nv = c.v.len();
        let mut out: Vec<[f64; 2]> = Vec::new();
        if c.r == 0.0 {
            out.extend(c.v.iter().map(|cv| add(tip, cv.p)));
        } else {
            for i in 0..nv {
                let cv = &c.v[i];
                let (a0, da) = if nv == 1 {
                    (-PI / 2.0, 2.0 * PI)
                } else {
                    let np = c.v[(i + nv - 1) % nv].n;
                    let mut da = cross(np, cv.n).atan2(dot(np, cv.n));
                    if da <= 0.0 {
                        da += 2.0 * PI;
                    }
                    (np[1].atan2(np[0]), da)
                };
                let per_turn = arc_segments.min(1 << 16) as f64;
                let mut m = ((da / (2.0 * PI)) * per_turn).ceil().max(1.0) as usize;
                if nv == 1 {
                    m = m.max(3);
                }
                // A full circle's last point is its first.
                let jmax = if nv == 1 { m - 1 } else { m };
                for j in 0..=jmax {
                    let a = a0 + da * (j as f64 / m as f64);
                    out.push([
                        tip[0] + cv.p[0] + c.r * a.cos(),
                        tip[1] + cv.p[1] + c.r * a.sin(),
                    ]);
                }
            }
        }
        out.push(out[0]);
        out
    }
}

#[cfg(test)]
mod tests;
