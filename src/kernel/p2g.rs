//! Particle-to-grid transfers: mass, momentum and force.

use super::block::{Block, Lane, LANES};
use super::isa::multiversion;
use super::simd::F2;
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

/// Where a patch's grid sits, in the form the per-particle loops use.
#[derive(Clone, Copy)]
pub(crate) struct Geo {
    pub(crate) inv_h: f64,
    pub(crate) ox: f64,
    pub(crate) oy: f64,
    pub(crate) lox: i64,
    pub(crate) loy: i64,
    pub(crate) nx: usize,
    pub(crate) nxi: i64,
    pub(crate) nyi: i64,
    /// `lo` as floats.
    lof: [f64; 2],
    /// Largest first stencil node (local), `n - 3`, as floats.
    maxf: [f64; 2],
}

impl Geo {
    pub(crate) fn of(grid: &Grid) -> Geo {
        Geo {
            inv_h: 1.0 / grid.h,
            ox: grid.origin[0],
            oy: grid.origin[1],
            lox: grid.lo[0],
            loy: grid.lo[1],
            nx: grid.n[0],
            nxi: grid.n[0] as i64,
            nyi: grid.n[1] as i64,
            lof: [grid.lo[0] as f64, grid.lo[1] as f64],
            maxf: [grid.n[0] as f64 - 3.0, grid.n[1] as f64 - 3.0],
        }
    }

    /// Origin of the level's node 0 (`(ox, oy)`).
    #[inline(always)]
    pub(crate) fn origin(&self) -> [f64; 2] {
        [self.ox, self.oy]
    }

    /// The grid's first node index per axis, as floats.
    #[inline(always)]
    pub(crate) fn lo_f(&self) -> [f64; 2] {
        self.lof
    }

    /// Largest first stencil node (local index), `n - 3` per axis, as
    /// floats.
    #[inline(always)]
    pub(crate) fn max_first(&self) -> [f64; 2] {
        self.maxf
    }

    /// Number of nodes every grid array must hold for the unchecked
    /// stencil access (`nx * ny`).
    pub(crate) fn nodes(&self) -> usize {
        self.nx * self.nyi as usize
    }
}

/// `s[k]` without a bounds check.
///
/// # Safety
/// `k < s.len()`.
#[inline(always)]
pub(crate) unsafe fn at(s: &[f64], k: usize) -> &f64 {
    debug_assert!(k < s.len());
    // SAFETY: the caller's contract.
    unsafe { s.get_unchecked(k) }
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

/// What one particle scatters: mass, momentum `m v`, external force `fe`,
/// and the stress terms `vs = J vol0 σ / h` (as the pairs the force needs:
/// `(vs_xx, vs_xy)` against the x slope, `(vs_xy, vs_yy)` against the y
/// slope).
#[derive(Clone, Copy)]
pub(crate) struct Contribution {
    pub(crate) m: f64,
    pub(crate) mv: F2,
    pub(crate) fe: F2,
    pub(crate) vs_gx: F2,
    pub(crate) vs_gy: F2,
}

impl Contribution {
    /// The contribution of a particle with mass `m`, velocity `(vx, vy)`,
    /// Jacobian `j`, reference volume `vol0`, stress `(sxx, sxy, syy)` and
    /// external force `(fex, fey)` (only the parts `FORCE` needs are formed).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn new<const FORCE: bool>(
        m: f64,
        vx: f64,
        vy: f64,
        j: f64,
        vol0: f64,
        inv_h: f64,
        s: (f64, f64, f64),
        fe: (f64, f64),
    ) -> Contribution {
        let (mut vs_gx, mut vs_gy) = (F2::zero(), F2::zero());
        if FORCE {
            let v = F2::splat(j * vol0 * inv_h);
            vs_gx = v.mul(F2::new(s.0, s.1));
            vs_gy = v.mul(F2::new(s.1, s.2));
        }
        Contribution {
            m,
            mv: F2::splat(m).mul(F2::new(vx, vy)),
            fe: F2::new(fe.0, fe.1),
            vs_gx,
            vs_gy,
        }
    }
}

/// The grid's mass, momentum x/y and force x/y arrays.
pub(crate) struct Sinks<'a> {
    pub(crate) m: &'a mut [f64],
    pub(crate) px: &'a mut [f64],
    pub(crate) py: &'a mut [f64],
    pub(crate) fx: &'a mut [f64],
    pub(crate) fy: &'a mut [f64],
}

impl<'a> Sinks<'a> {
    pub(crate) fn of(g: &'a mut Grid) -> Sinks<'a> {
        Sinks {
            m: &mut g.mass,
            px: &mut g.px,
            py: &mut g.py,
            fx: &mut g.fx,
            fy: &mut g.fy,
        }
    }

    /// True when every array has `n` entries.
    pub(crate) fn all_len(&self, n: usize) -> bool {
        [&*self.m, &*self.px, &*self.py, &*self.fx, &*self.fy]
            .iter()
            .all(|a| a.len() == n)
    }
}

/// Scatter with local sums: contributions of consecutive particles with the
/// same stencil are summed in a local 3x3 block and added to the grid once
/// per run of such particles. The grid's read-modify-write chains (one per
/// node and array) are the cost of P2G, and particles sorted by stencil base
/// (see [`crate::kernel::stencil_order`]) come in runs of ~ppc.
///
/// Each particle's nodal values are tensor products of its 1D weights `wx`,
/// `gx` (slope), `wy`, `gy`, formed row by row: with the row factors
/// `M_b = m wy_b`, `P_b = m v wy_b`, `A_b = fe wy_b − (vs_xy, vs_yy) gy_b`,
/// `B_b = (vs_xx, vs_xy) wy_b`, node `(a, b)` gets mass `wx_a M_b`,
/// momentum `wx_a P_b` and force `wx_a A_b − gx_a B_b`, which is
/// `S fe − V σ·∇S` with `S = wx_a wy_b`, `∇S = (gx_a wy_b, wx_a gy_b)/h`
/// (the x and y components side by side in one register).
pub(crate) struct Scatter {
    cur: usize,
    m: [f64; 9],
    p: [F2; 9],
    f: [F2; 9],
}

impl Scatter {
    pub(crate) fn new() -> Scatter {
        Scatter {
            cur: usize::MAX,
            m: [0.0; 9],
            p: [F2::zero(); 9],
            f: [F2::zero(); 9],
        }
    }

    /// Adds the local sums to the grid's 3×3 block and zeroes them.
    ///
    /// # Safety
    /// `self.cur` is a `k0` from [`Geo::stencil`] for a grid whose arrays
    /// hold `nx ny` nodes.
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
                    if MOM {
                        *at_mut(g.px, n) += self.p[k].lo();
                        *at_mut(g.py, n) += self.p[k].hi();
                    }
                    if FORCE {
                        *at_mut(g.fx, n) += self.f[k].lo();
                        *at_mut(g.fy, n) += self.f[k].hi();
                    }
                }
                if MASS {
                    self.m[k] = 0.0;
                }
                if MOM {
                    self.p[k] = F2::zero();
                }
                if FORCE {
                    self.f[k] = F2::zero();
                }
            }
        }
    }

    /// Scatters one particle with the stencil and weights `w`.
    ///
    /// # Safety
    /// `w` is an `ok` lane of a [`Block`] evaluated for a grid whose `g`
    /// arrays hold `nx ny` nodes (as every earlier lane of this scatter).
    #[inline(always)]
    pub(crate) unsafe fn add<const MASS: bool, const MOM: bool, const FORCE: bool>(
        &mut self,
        w: &Lane,
        c: &Contribution,
        nx: usize,
        g: &mut Sinks,
    ) {
        let k0 = w.k0();
        if k0 != self.cur {
            if self.cur != usize::MAX {
                // SAFETY: forwarded contract.
                unsafe { self.flush::<MASS, MOM, FORCE>(nx, g) };
            }
            self.cur = k0;
        }
        for b in 0..3 {
            let (wyb, gyb) = (w.wy2(b), w.gy2(b));
            let mb = c.m * w.wy(b);
            let pb = c.mv.mul(wyb);
            let ab = c.fe.mul(wyb).sub(c.vs_gy.mul(gyb));
            let bb = c.vs_gx.mul(wyb);
            for a in 0..3 {
                let k = a + 3 * b;
                if MASS {
                    self.m[k] += w.wx(a) * mb;
                }
                if MOM {
                    self.p[k] = self.p[k].add(w.wx2(a).mul(pb));
                }
                if FORCE {
                    self.f[k] = self.f[k].add(w.wx2(a).mul(ab).sub(w.gx2(a).mul(bb)));
                }
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

/// External force on a particle: `fext lf + m (gravity + body)`.
#[inline(always)]
pub(crate) fn external_force(
    fext: (f64, f64),
    lf: f64,
    m: f64,
    g: [f64; 2],
    body: Option<BodyForce>,
    p: usize,
) -> (f64, f64) {
    let (bx, by) = match body {
        Some(b) => (b.bx[p], b.by[p]),
        None => (0.0, 0.0),
    };
    (fext.0 * lf + m * (g[0] + bx), fext.1 * lf + m * (g[1] + by))
}

multiversion! {
    /// Scatters particle data to the grid's accumulators (which the caller has
    /// reset, or which hold other patches' contributions to be summed):
    /// `MASS` adds mass, `MOM` adds momentum `m v`, `FORCE` adds the internal
    /// force `-V σ·∇S` (with the current volume `V = J vol0`) and the external
    /// force `S (fext · load_factor + m (gravity + body))`.
    ///
    /// Weights use each particle's position and current half-lengths.
    pub(crate) fn p2g_impl
        [S: Shape1D, const MASS: bool, const MOM: bool, const FORCE: bool]
        [S, MASS, MOM, FORCE]
        (grid: &mut Grid, parts: &Particles, prm: &StepParams, body: Option<BodyForce>)
        -> Result<()> = p2g_body;
}

/// The loop of [`p2g_impl`].
#[inline(always)]
fn p2g_body<S: Shape1D, const MASS: bool, const MOM: bool, const FORCE: bool>(
    grid: &mut Grid,
    parts: &Particles,
    prm: &StepParams,
    body: Option<BodyForce>,
) -> Result<()> {
    let np = parts.len();
    let geo = Geo::of(grid);
    let range = [grid.mappable_range(0), grid.mappable_range(1)];
    let lf = prm.load_factor;
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
    let mut sc = Scatter::new();
    let mut blk = Block::new();
    let mut s = 0;
    while s < np {
        let e = (s + LANES).min(np);
        blk.eval_into::<S>(&geo, &x[s..e], &y[s..e], &lpx[s..e], &lpy[s..e]);
        for l in 0..e - s {
            let p = s + l;
            if !blk.ok[l] {
                return Err(outside_error(parts, p, range));
            }
            let m = mass[p];
            let c = if FORCE {
                let j = parts.fxx[p] * parts.fyy[p] - parts.fxy[p] * parts.fyx[p];
                let fe = external_force(
                    (parts.fext_x[p], parts.fext_y[p]),
                    lf,
                    m,
                    prm.gravity,
                    body,
                    p,
                );
                Contribution::new::<true>(
                    m,
                    vx[p],
                    vy[p],
                    j,
                    parts.vol0[p],
                    geo.inv_h,
                    (parts.sxx[p], parts.sxy[p], parts.syy[p]),
                    fe,
                )
            } else {
                Contribution::new::<false>(
                    m,
                    vx[p],
                    vy[p],
                    0.0,
                    0.0,
                    0.0,
                    (0.0, 0.0, 0.0),
                    (0.0, 0.0),
                )
            };
            // SAFETY: an `ok` lane, and the arrays hold all nodes.
            unsafe { sc.add::<MASS, MOM, FORCE>(&blk.lane(l), &c, geo.nx, &mut sinks) };
        }
        s = e;
    }
    // SAFETY: as above.
    unsafe { sc.finish::<MASS, MOM, FORCE>(geo.nx, &mut sinks) };
    Ok(())
}
