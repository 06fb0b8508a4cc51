//! Particle-to-grid transfers: mass, momentum and force.

use super::block::{Block, Lane, LANES};
use super::geo::Geo;
use super::grid::Node4;
use super::isa::multiversion;
use super::simd::{Simd4, F4};
use super::{BodyForce, Grid, StepParams};
use crate::error::{Error, Result, Status};
use crate::particles::Particles;
use crate::shape::Shape1D;

/// Error for a particle whose stencil leaves the grid.
pub(crate) fn outside_error(parts: &Particles, p: usize, range: [(f64, f64); 2]) -> Error {
    Error::new(
        Status::ParticlesLeft,
        format!(
            "particle id {} at ({}, {}) has left the patch grid (mappable cell range x [{}, {}), y [{}, {}))",
            parts.id[p],
            parts.x[p],
            parts.y[p],
            range[0].0,
            range[0].1,
            range[1].0,
            range[1].1
        ),
    )
}

/// `&mut s[k]` without a bounds check.
///
/// # Safety
/// `k < s.len()`.
#[inline(always)]
unsafe fn at_mut(s: &mut [f64], k: usize) -> &mut f64 {
    debug_assert!(k < s.len());
    // SAFETY: the caller's contract.
    unsafe { s.get_unchecked_mut(k) }
}

/// What one particle scatters, as the row factors of its tensor-product
/// weights need it. Node `(a, b)` gets mass `wx_a (m wy_b)` and
/// `[px, py, fx, fy]` += `wx_a (wy_b w − gy_b g) − gx_a (wy_b x)`, with
/// `w = [m vx, m vy, fex, fey]`, `g = [0, 0, vs_xy, vs_yy]`,
/// `x = [0, 0, vs_xx, vs_xy]` and `vs = J vol0 σ / h`: momentum `S m v` and
/// force `S fe − V σ·∇S` with `S = wx_a wy_b`, `∇S = (gx_a wy_b, wx_a gy_b)/h`
/// and the current volume `V = J vol0`.
#[derive(Clone, Copy)]
pub(crate) struct Contribution<I: Simd4> {
    pub(crate) m: f64,
    pub(crate) w: F4<I>,
    pub(crate) g: F4<I>,
    pub(crate) x: F4<I>,
    /// The affine momentum of the APIC transfer (read by the scatters with
    /// `AFF` only): `[m h C_xx, m h C_yx, 0, 0]` and `[m h C_xy, m h C_yy, 0,
    /// 0]`, the columns of `m C` times `h`, so that node `(a, b)` gets
    /// `S (ax dx_a + ay dy_b)` with the offsets in cells.
    pub(crate) ax: F4<I>,
    /// See `ax`.
    pub(crate) ay: F4<I>,
    /// The hoop force of the axisymmetric mode, `[0, 0, vs_θθ, 0]` with
    /// `vs_θθ = J vol0 σ_θθ / h` (read by the scatters with `hoop` only):
    /// node `(a, b)` gets `− T_a w_b vs_θθ` radially.
    pub(crate) t: F4<I>,
}

impl<I: Simd4> Contribution<I> {
    /// The contribution of a particle of mass `m` from its products: the
    /// momentum `mv = (m vx, m vy)` (read when `MOM`), and when `FORCE` the
    /// external force `fe` and `vs = v (σ_xx, σ_xy, σ_yy)` with `v = J vol0
    /// / h` (see [`volume_stress`]); the other lanes zero.
    #[inline(always)]
    pub(crate) fn new<const MOM: bool, const FORCE: bool>(
        m: f64,
        mv: (f64, f64),
        fe: (f64, f64),
        vs: (f64, f64, f64),
    ) -> Self {
        let (mvx, mvy) = if MOM { mv } else { (0.0, 0.0) };
        if FORCE {
            Contribution {
                m,
                w: F4::new(mvx, mvy, fe.0, fe.1),
                g: F4::new(0.0, 0.0, vs.1, vs.2),
                x: F4::new(0.0, 0.0, vs.0, vs.1),
                ax: F4::zero(),
                ay: F4::zero(),
                t: F4::zero(),
            }
        } else {
            Contribution {
                m,
                w: F4::new(mvx, mvy, 0.0, 0.0),
                g: F4::zero(),
                x: F4::zero(),
                ax: F4::zero(),
                ay: F4::zero(),
                t: F4::zero(),
            }
        }
    }

    /// The same with the affine momentum of a particle with the matrix `c =
    /// (C_xx, C_xy, C_yx, C_yy)` on a grid of cell size `h` (for the
    /// scatters with `AFF` and `MOM`).
    #[inline(always)]
    pub(crate) fn with_affine(mut self, c: (f64, f64, f64, f64), h: f64) -> Self {
        let mh = self.m * h;
        self.ax = F4::new(mh * c.0, mh * c.2, 0.0, 0.0);
        self.ay = F4::new(mh * c.1, mh * c.3, 0.0, 0.0);
        self
    }

    /// The same with the hoop force `vs_tt = J vol0 σ_θθ / h` of the
    /// axisymmetric mode (for the scatters with `hoop` and `FORCE`).
    #[inline(always)]
    pub(crate) fn with_hoop(mut self, vs_tt: f64) -> Self {
        self.t = F4::new(0.0, 0.0, vs_tt, 0.0);
        self
    }
}

/// `v (σ_xx, σ_xy, σ_yy)` with `v = J vol0 / h` (the current volume over
/// the cell size), for a particle with Jacobian `j`, reference volume
/// `vol0` and stress `s = (σ_xx, σ_xy, σ_yy)` on a grid with `1/h = inv_h`:
/// what [`Contribution::new`] takes as `vs`.
#[inline(always)]
pub(crate) fn volume_stress(j: f64, vol0: f64, inv_h: f64, s: (f64, f64, f64)) -> (f64, f64, f64) {
    let v = j * vol0 * inv_h;
    (v * s.0, v * s.1, v * s.2)
}

/// The grid's accumulators: mass, and `[px, py, fx, fy]` per node.
pub(crate) struct Sinks<'a> {
    pub(crate) m: &'a mut [f64],
    pub(crate) mf: &'a mut [Node4],
}

impl<'a> Sinks<'a> {
    pub(crate) fn of(g: &'a mut Grid) -> Sinks<'a> {
        Sinks {
            m: &mut g.mass,
            mf: &mut g.mom_force,
        }
    }

    /// True when every array has `n` entries.
    pub(crate) fn all_len(&self, n: usize) -> bool {
        self.m.len() == n && self.mf.len() == n
    }
}

/// Scatter with local sums: contributions of consecutive particles with the
/// same stencil are summed in a local 3x3 block and added to the grid once
/// per run of such particles. The grid's read-modify-write chains (one per
/// node) are the cost of P2G, and particles sorted by stencil base (see
/// [`crate::kernel::stencil_order`]) come in runs of ~ppc. A node's
/// momentum and force are one vector (see [`Contribution`]).
// Cache-line aligned: see `Block`.
#[repr(align(64))]
pub(crate) struct Scatter<I: Simd4> {
    cur: usize,
    m: [f64; 9],
    mf: [F4<I>; 9],
}

impl<I: Simd4> Scatter<I> {
    pub(crate) fn new() -> Self {
        Scatter {
            cur: usize::MAX,
            m: [0.0; 9],
            mf: [F4::zero(); 9],
        }
    }

    /// Adds the local sums to the grid's 3×3 block (the next particle then
    /// overwrites them). Lanes a scatter does not form (force for `MOM`
    /// alone, momentum for `FORCE` alone) add zeros.
    ///
    /// # Safety
    /// `self.cur` is the first stencil node of an `ok` lane of a [`Block`]
    /// for a grid whose arrays hold `nx ny` nodes.
    #[inline(always)]
    unsafe fn flush<const MASS: bool, const MOM: bool, const FORCE: bool>(
        &mut self,
        nx: usize,
        g: &mut Sinks,
    ) {
        let k0 = self.cur;
        for b in 0..3 {
            for a in 0..3 {
                let k = a + 3 * b;
                let n = k0 + b * nx + a;
                // SAFETY: n <= k0 + 2 nx + 2 < nx ny (the caller's contract).
                unsafe {
                    if MASS {
                        *at_mut(g.m, n) += self.m[k];
                    }
                    if MOM || FORCE {
                        let d = &mut g.mf.get_unchecked_mut(n).0;
                        *d = F4::<I>::load(d).add(self.mf[k]).to_array();
                    }
                }
            }
        }
    }

    /// Scatters one particle with the stencil and weights `w`, with the
    /// affine momentum of the contribution when `AFF` and `MOM` (the lane's
    /// offsets [`Lane::dx`], [`Lane::dy`] must then be filled).
    ///
    /// # Safety
    /// `w` is an `ok` lane of a [`Block`] evaluated for a grid whose `g`
    /// arrays hold `nx ny` nodes (as every earlier lane of this scatter).
    #[inline(always)]
    pub(crate) unsafe fn add<
        const MASS: bool,
        const MOM: bool,
        const FORCE: bool,
        const AFF: bool,
    >(
        &mut self,
        w: &Lane,
        c: &Contribution<I>,
        nx: usize,
        g: &mut Sinks,
        hoop: bool,
    ) {
        let k0 = w.k0();
        if k0 == self.cur {
            self.nodes::<false, MASS, MOM, FORCE, AFF>(w, c, hoop);
        } else {
            if self.cur != usize::MAX {
                // SAFETY: forwarded contract.
                unsafe { self.flush::<MASS, MOM, FORCE>(nx, g) };
            }
            self.cur = k0;
            self.nodes::<true, MASS, MOM, FORCE, AFF>(w, c, hoop);
        }
    }

    /// Adds the particle's contributions to the local sums, or, for the
    /// first particle of a run (`START`), stores them there. (Storing `t`
    /// instead of adding it to zero differs only for `t = −0`, which then
    /// adds the same to a grid value, never −0 as sums from +0 are not.)
    /// `hoop` (a constant of the pass: the axisymmetric mode) adds the hoop
    /// force `− T_a w_b vs_θθ` of [`Contribution::t`].
    #[inline(always)]
    fn nodes<
        const START: bool,
        const MASS: bool,
        const MOM: bool,
        const FORCE: bool,
        const AFF: bool,
    >(
        &mut self,
        w: &Lane,
        c: &Contribution<I>,
        hoop: bool,
    ) {
        let aff = AFF && MOM;
        let hoop = hoop && FORCE;
        for b in 0..3 {
            let wyb = F4::splat(w.wy(b));
            let mb = c.m * w.wy(b);
            let (mut rw, rx) = if FORCE {
                (c.w.mul(wyb).sub(c.g.mul(F4::splat(w.gy(b)))), c.x.mul(wyb))
            } else {
                (c.w.mul(wyb), F4::zero())
            };
            // The affine momentum `S m C (x_i − x_p)`: the y column with
            // the row's `wy_b dy_b`, the x column below with `wx_a dx_a`.
            let ra = if aff {
                rw = rw.add(c.ay.mul(F4::splat(w.wdy(b))));
                c.ax.mul(wyb)
            } else {
                F4::zero()
            };
            let rt = if hoop { c.t.mul(wyb) } else { F4::zero() };
            for a in 0..3 {
                let k = a + 3 * b;
                if MASS {
                    let t = w.wx(a) * mb;
                    self.m[k] = if START { t } else { self.m[k] + t };
                }
                if MOM || FORCE {
                    let t = if FORCE {
                        F4::splat(w.wx(a)).mul(rw).sub(F4::splat(w.gx(a)).mul(rx))
                    } else {
                        F4::splat(w.wx(a)).mul(rw)
                    };
                    let t = if aff {
                        t.add(F4::splat(w.wdx(a)).mul(ra))
                    } else {
                        t
                    };
                    let t = if hoop {
                        t.sub(F4::splat(w.tx(a)).mul(rt))
                    } else {
                        t
                    };
                    self.mf[k] = if START { t } else { self.mf[k].add(t) };
                }
            }
        }
    }

    /// Adds the force `f` with the weights `wx_a wy_b` to the local sums of
    /// the current run (the stencil of the particle [`Scatter::add`] last
    /// took).
    #[inline(always)]
    pub(crate) fn add_load(&mut self, wx: &[f64; 3], wy: &[f64; 3], f: (f64, f64)) {
        let fv = F4::<I>::new(0.0, 0.0, f.0, f.1);
        for (b, &wyb) in wy.iter().enumerate() {
            for (a, &wxa) in wx.iter().enumerate() {
                let k = a + 3 * b;
                self.mf[k] = self.mf[k].add(fv.mul(F4::splat(wxa * wyb)));
            }
        }
    }

    /// Adds what is left in the local sums to the grid.
    ///
    /// # Safety
    /// As for [`Scatter::add`].
    #[inline(always)]
    pub(crate) unsafe fn finish<const MASS: bool, const MOM: bool, const FORCE: bool>(
        &mut self,
        nx: usize,
        g: &mut Sinks,
    ) {
        if self.cur != usize::MAX {
            // SAFETY: forwarded contract.
            unsafe { self.flush::<MASS, MOM, FORCE>(nx, g) };
            self.cur = usize::MAX;
        }
    }
}

/// Body force on a particle: `m (gravity + body)` (the surface loads go
/// through [`face_loads`]).
#[inline(always)]
pub(crate) fn external_force(m: f64, g: [f64; 2], body: Option<BodyForce>, p: usize) -> (f64, f64) {
    let (bx, by) = match body {
        Some(b) => (b.bx[p], b.by[p]),
        None => (0.0, 0.0),
    };
    (m * (g[0] + bx), m * (g[1] + by))
}

/// Values of the linear hat functions of the nodes `base`, `base + 1`,
/// `base + 2` at the coordinate `xi` (both in cells from the level's node 0).
#[inline(always)]
fn hats(xi: f64, base: f64) -> [f64; 3] {
    let u = xi - base;
    [
        (1.0 - u.abs()).max(0.0),
        (1.0 - (u - 1.0).abs()).max(0.0),
        (1.0 - (u - 2.0).abs()).max(0.0),
    ]
}

/// A particle's surface loads, for [`face_loads`].
#[derive(Clone, Copy)]
pub(crate) struct FaceLoads {
    /// Position.
    pub(crate) x: f64,
    /// Position.
    pub(crate) y: f64,
    /// Current half-lengths.
    pub(crate) lpx: f64,
    /// Current half-lengths.
    pub(crate) lpy: f64,
    /// [`Particles::load_faces`] code.
    pub(crate) code: f64,
    /// Reference force on the face in y.
    pub(crate) fext: (f64, f64),
    /// Reference force on the face in x.
    pub(crate) fside: (f64, f64),
    /// Deformation gradient (xx, xy, yx, yy), which turns and scales the
    /// forces of a follower load and moves its faces.
    pub(crate) f: [f64; 4],
    /// Reference half-lengths (where a follower load's faces were).
    pub(crate) lp0: [f64; 2],
}

/// The current force of a face load of kind `kind` (see
/// [`crate::particles::LoadKind`]) with reference force `f0` on a face of
/// reference tangent `e_x` (`in_y`, a face in y) or `e_y`: `f0` for a dead
/// load, `f0 |F T|` for [`LoadKind::FollowArea`](crate::particles::LoadKind),
/// `f0 (F T) / T` (complex numbers: turned with the face and scaled by its
/// stretch) for `FollowFace`.
#[inline(always)]
pub(crate) fn face_force(
    f0: (f64, f64),
    f: &[f64; 4],
    in_y: bool,
    kind: crate::particles::LoadKind,
) -> (f64, f64) {
    use crate::particles::LoadKind;
    let [fxx, fxy, fyx, fyy] = *f;
    // (F T) / T as a complex number c + i s: T = e_x gives F e_x = (fxx,
    // fyx); T = e_y (= i) gives (fxy + i fyy) / i = fyy - i fxy.
    let (c, s) = if in_y { (fxx, fyx) } else { (fyy, -fxy) };
    match kind {
        LoadKind::Dead => f0,
        LoadKind::FollowArea => {
            let m = (c * c + s * s).sqrt();
            (f0.0 * m, f0.1 * m)
        }
        LoadKind::FollowFace => (f0.0 * c - f0.1 * s, f0.0 * s + f0.1 * c),
    }
}

/// Adds a particle's surface loads (times the load factor `lf`) to the
/// scatter's local sums with the **face integral** of the node shape
/// functions, `F_i = f ∫_face S_i ds / |face|`: along the face the volume
/// average of the particle's weights in that direction (the lane's weights,
/// which average over the particle's half-length), across it the hat
/// functions at the face's coordinate. The loaded rows of particles then
/// carry the load as the continuum does (with the load at the particle
/// centre, the top row carried about a quarter of it). A dead load's face
/// is the particle's domain face (`x ± lp`); a follower load's is the
/// deformed face, `x + F (±lp0)` across it (where cpGIMP's domain face is
/// while its half-lengths are not clamped; beyond uGIMP's fixed domain),
/// clamped to the two cells of the particle's stencil so that no force is
/// lost, and its force is scaled (and turned) with the face first (see
/// [`face_force`]). Call it right after [`Scatter::add`] of the same
/// particle with the same lane.
#[cold]
#[inline(never)]
pub(crate) fn face_loads<I: Simd4>(
    sc: &mut Scatter<I>,
    w: &Lane,
    geo: &Geo,
    f: &FaceLoads,
    lf: f64,
) {
    let (ty, tx) = crate::particles::load_faces_of(f.code);
    let kind = crate::particles::load_kind_of(f.code);
    let k0 = w.k0();
    let bx = (k0 % geo.nx) as f64 + geo.lof[0];
    let by = (k0 / geo.nx) as f64 + geo.lof[1];
    let wx = [w.wx(0), w.wx(1), w.wx(2)];
    let wy = [w.wy(0), w.wy(1), w.wy(2)];
    let follow = kind != crate::particles::LoadKind::Dead;
    if ty != 0 {
        let yf = if follow {
            f.y + ty as f64 * f.f[3] * f.lp0[1]
        } else {
            f.y + ty as f64 * f.lpy
        };
        let yi = (yf - geo.oy) * geo.inv_h;
        let hy = hats(if follow { yi.clamp(by, by + 2.0) } else { yi }, by);
        let fe = face_force(f.fext, &f.f, true, kind);
        sc.add_load(&wx, &hy, (fe.0 * lf, fe.1 * lf));
    }
    if tx != 0 {
        let xf = if follow {
            f.x + tx as f64 * f.f[0] * f.lp0[0]
        } else {
            f.x + tx as f64 * f.lpx
        };
        let xi = (xf - geo.ox) * geo.inv_h;
        let hx = hats(if follow { xi.clamp(bx, bx + 2.0) } else { xi }, bx);
        let fs = face_force(f.fside, &f.f, false, kind);
        sc.add_load(&hx, &wy, (fs.0 * lf, fs.1 * lf));
    }
}

multiversion! {
    /// Scatters particle data to the grid's accumulators (which the caller has
    /// reset, or which hold other patches' contributions to be summed):
    /// `MASS` adds mass, `MOM` adds momentum `m v`, `FORCE` adds the internal
    /// force `-V σ·∇S` (with the current volume `V = J vol0`) and the external
    /// force `S (fext · load_factor + m (gravity + body))`. With `AFF`
    /// (the APIC transfer) the momentum is `m S (v + C (x_i − x_p))`.
    ///
    /// Weights use each particle's position and current half-lengths.
    pub(crate) fn p2g_impl
        [S: Shape1D, const MASS: bool, const MOM: bool, const FORCE: bool, const AFF: bool]
        [S, MASS, MOM, FORCE, AFF]
        (grid: &mut Grid, parts: &Particles, prm: &StepParams, body: Option<BodyForce>)
        -> Result<()> = p2g_body;
}

/// The loop of [`p2g_impl`].
#[inline(always)]
fn p2g_body<
    I: Simd4,
    S: Shape1D,
    const MASS: bool,
    const MOM: bool,
    const FORCE: bool,
    const AFF: bool,
>(
    grid: &mut Grid,
    parts: &Particles,
    prm: &StepParams,
    body: Option<BodyForce>,
) -> Result<()> {
    let np = parts.len();
    let geo = Geo::of(grid);
    let range = [grid.mappable_range(0), grid.mappable_range(1)];
    let lf = prm.load_factor;
    let grid_h = grid.h;
    let mut sinks = Sinks::of(grid);
    assert!(
        sinks.all_len(geo.nodes()),
        "grid arrays must hold n[0] * n[1] nodes"
    );
    let x = &parts.x[..np];
    let y = &parts.y[..np];
    let lpx = &parts.lpx[..np];
    let lpy = &parts.lpy[..np];
    let mass = &parts.mass[..np];
    let vx = &parts.vx[..np];
    let vy = &parts.vy[..np];
    let faces = &parts.load_faces[..np];
    let mut sc = Scatter::<I>::new();
    let mut blk = Block::new();
    let mut s = 0;
    while s < np {
        let e = (s + LANES).min(np);
        blk.eval_into_aff::<S, AFF>(&geo, &x[s..e], &y[s..e], &lpx[s..e], &lpy[s..e]);
        for l in 0..e - s {
            let p = s + l;
            if !blk.ok[l] {
                return Err(outside_error(parts, p, range));
            }
            let m = mass[p];
            let mv = (m * vx[p], m * vy[p]);
            let c = if FORCE {
                let j = parts.fxx[p] * parts.fyy[p] - parts.fxy[p] * parts.fyx[p];
                // The volume's Jacobian: times the hoop stretch in
                // axisymmetry.
                let j = if S::AXI { j * parts.fzz[p] } else { j };
                let fe = external_force(m, prm.gravity, body, p);
                let s = (parts.sxx[p], parts.sxy[p], parts.syy[p]);
                let vs = volume_stress(j, parts.vol0[p], geo.inv_h, s);
                let c = Contribution::new::<MOM, true>(m, mv, fe, vs);
                if S::AXI {
                    c.with_hoop(j * parts.vol0[p] * geo.inv_h * parts.szz[p])
                } else {
                    c
                }
            } else {
                Contribution::new::<MOM, false>(m, mv, (0.0, 0.0), (0.0, 0.0, 0.0))
            };
            let c = if AFF && MOM {
                let a = (parts.cxx[p], parts.cxy[p], parts.cyx[p], parts.cyy[p]);
                c.with_affine(a, grid_h)
            } else {
                c
            };
            // SAFETY: an `ok` lane, and the arrays hold all nodes.
            unsafe {
                sc.add::<MASS, MOM, FORCE, AFF>(&blk.lane(l), &c, geo.nx, &mut sinks, S::AXI)
            };
            if FORCE && faces[p] != 0.0 {
                let f = FaceLoads {
                    x: x[p],
                    y: y[p],
                    lpx: lpx[p],
                    lpy: lpy[p],
                    code: faces[p],
                    fext: (parts.fext_x[p], parts.fext_y[p]),
                    fside: (parts.fside_x[p], parts.fside_y[p]),
                    f: [parts.fxx[p], parts.fxy[p], parts.fyx[p], parts.fyy[p]],
                    lp0: [parts.lpx0[p], parts.lpy0[p]],
                };
                face_loads(&mut sc, &blk.lane(l), &geo, &f, lf);
            }
        }
        s = e;
    }
    // SAFETY: as above.
    unsafe { sc.finish::<MASS, MOM, FORCE>(geo.nx, &mut sinks) };
    Ok(())
}
