//! Particle-to-grid transfers: mass, momentum and force.

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

/// Local sums of a run of particles sharing one 3×3 stencil.
#[derive(Default)]
struct Acc {
    m: [f64; 9],
    px: [f64; 9],
    py: [f64; 9],
    fx: [f64; 9],
    fy: [f64; 9],
}

/// The grid's mass, momentum x/y and force x/y arrays.
type GridSinks<'a> = (
    &'a mut [f64],
    &'a mut [f64],
    &'a mut [f64],
    &'a mut [f64],
    &'a mut [f64],
);

/// Adds the local sums to the grid's 3×3 block starting at `k0` and zeroes
/// them.
#[inline(always)]
fn flush<const MASS: bool, const MOM: bool, const FORCE: bool>(
    k0: usize,
    nx: usize,
    acc: &mut Acc,
    g: GridSinks,
) {
    let (gm, gpx, gpy, gfx, gfy) = g;
    for b in 0..3 {
        let r = k0 + b * nx;
        let (gm, gpx, gpy) = (&mut gm[r..r + 3], &mut gpx[r..r + 3], &mut gpy[r..r + 3]);
        let (gfx, gfy) = (&mut gfx[r..r + 3], &mut gfy[r..r + 3]);
        for a in 0..3 {
            let k = a + 3 * b;
            if MASS {
                gm[a] += acc.m[k];
                acc.m[k] = 0.0;
            }
            if MOM {
                gpx[a] += acc.px[k];
                gpy[a] += acc.py[k];
                acc.px[k] = 0.0;
                acc.py[k] = 0.0;
            }
            if FORCE {
                gfx[a] += acc.fx[k];
                gfy[a] += acc.fy[k];
                acc.fx[k] = 0.0;
                acc.fy[k] = 0.0;
            }
        }
    }
}

/// Scatters particle data to the grid's accumulators (which the caller has
/// reset, or which hold other patches' contributions to be summed):
/// `MASS` adds mass, `MOM` adds momentum `m v`, `FORCE` adds the internal
/// force `-V σ·∇S` (with the current volume `V = J vol0`) and the external
/// force `S (fext · load_factor + m (gravity + body))`.
///
/// Weights use each particle's position and current half-lengths.
pub(crate) fn p2g_impl<S: Shape1D, const MASS: bool, const MOM: bool, const FORCE: bool>(
    grid: &mut Grid,
    parts: &Particles,
    prm: &StepParams,
    body: Option<BodyForce>,
) -> Result<()> {
    let np = parts.len();
    let inv_h = 1.0 / grid.h;
    let [ox, oy] = grid.origin;
    let [lox, loy] = grid.lo;
    let [nx, ny] = grid.n;
    let (nxi, nyi) = (nx as i64, ny as i64);
    let range = [grid.mappable_range(0), grid.mappable_range(1)];
    let lf = prm.load_factor;
    let [gx, gy] = prm.gravity;
    let Grid {
        mass: gm,
        px: gpx,
        py: gpy,
        fx: gfx,
        fy: gfy,
        ..
    } = grid;
    let x = &parts.x[..np];
    let y = &parts.y[..np];
    let lpx = &parts.lpx[..np];
    let lpy = &parts.lpy[..np];
    let mass = &parts.mass[..np];
    let vx = &parts.vx[..np];
    let vy = &parts.vy[..np];
    // Contributions of consecutive particles with the same stencil are summed
    // in a local 3x3 block and added to the grid once per run of such
    // particles: the grid's read-modify-write chains (one per node and array)
    // are the cost of P2G, and particles sorted by stencil base (see
    // `crate::kernel::stencil_order`) come in runs of ~ppc.
    let mut cur = usize::MAX;
    let mut acc = Acc::default();
    for p in 0..np {
        let wx = S::eval((x[p] - ox) * inv_h, lpx[p] * inv_h);
        let wy = S::eval((y[p] - oy) * inv_h, lpy[p] * inv_h);
        let ix = wx.base - lox;
        let iy = wy.base - loy;
        if ix < 0 || iy < 0 || ix + 2 >= nxi || iy + 2 >= nyi {
            return Err(outside_error(parts, p, range));
        }
        let k0 = iy as usize * nx + ix as usize;
        if k0 != cur {
            if cur != usize::MAX {
                flush::<MASS, MOM, FORCE>(cur, nx, &mut acc, (gm, gpx, gpy, gfx, gfy));
            }
            cur = k0;
        }
        let m = mass[p];
        let (mvx, mvy) = (m * vx[p], m * vy[p]);
        // Force terms (only used when FORCE).
        let (mut vsxx, mut vsxy, mut vsyy, mut fex, mut fey) = (0.0, 0.0, 0.0, 0.0, 0.0);
        if FORCE {
            let j = parts.fxx[p] * parts.fyy[p] - parts.fxy[p] * parts.fyx[p];
            let v = j * parts.vol0[p] * inv_h;
            vsxx = v * parts.sxx[p];
            vsxy = v * parts.sxy[p];
            vsyy = v * parts.syy[p];
            let (bx, by) = match body {
                Some(b) => (b.bx[p], b.by[p]),
                None => (0.0, 0.0),
            };
            fex = parts.fext_x[p] * lf + m * (gx + bx);
            fey = parts.fext_y[p] * lf + m * (gy + by);
        }
        for b in 0..3 {
            let (wyb, gyb) = (wy.w[b], wy.g[b]);
            for a in 0..3 {
                let k = a + 3 * b;
                let w = wx.w[a] * wyb;
                if MASS {
                    acc.m[k] += w * m;
                }
                if MOM {
                    acc.px[k] += w * mvx;
                    acc.py[k] += w * mvy;
                }
                if FORCE {
                    let dx = wx.g[a] * wyb;
                    let dy = wx.w[a] * gyb;
                    acc.fx[k] += w * fex - (vsxx * dx + vsxy * dy);
                    acc.fy[k] += w * fey - (vsxy * dx + vsyy * dy);
                }
            }
        }
    }
    if cur != usize::MAX {
        flush::<MASS, MOM, FORCE>(cur, nx, &mut acc, (gm, gpx, gpy, gfx, gfy));
    }
    Ok(())
}
