//! Grid-to-particle transfers: velocity (FLIP/PIC blend), position,
//! velocity gradient, deformation gradient, stress, cpGIMP half-lengths.

use super::{Grid, PassStats, StepParams};
use crate::material::{Constitutive, MatParams, Stress, Tensor2};
use crate::particles::Particles;
use crate::shape::{cpgimp_half_lengths, Shape1D, ShapeKind};

/// One grid-to-particle pass over all particles, with the weights at the
/// particles' current positions and half-lengths:
///
/// * `VEL`: `v ← flip (v + Σ S (v_i − v0_i)) + (1 − flip) Σ S v_i`;
/// * `STRAIN`: `L = Σ v'_i ⊗ ∇S` with `v'` the grid's `v0` when
///   `grad_from_v0` (USF, MUSL) or `v` otherwise (USL); `F ← (I + dt L) F`;
///   stress update by the law `M`;
/// * `POS`: `x ← x + dt Σ S v_i`; cpGIMP half-lengths from the new `F`;
///   the CFL-1 time step `h / (c + |v|)`, and the finite and in-grid checks
///   (POS is the last pass of every scheme).
pub(crate) fn g2p_impl<
    S: Shape1D,
    M: Constitutive,
    const VEL: bool,
    const POS: bool,
    const STRAIN: bool,
>(
    grid: &Grid,
    grad_from_v0: bool,
    parts: &mut Particles,
    mats: &[MatParams],
    prm: &StepParams,
) -> PassStats {
    let np = parts.len();
    let h = grid.h;
    let inv_h = 1.0 / h;
    let [ox, oy] = grid.origin;
    let [lox, loy] = grid.lo;
    let [nx, ny] = grid.n;
    let (nxi, nyi) = (nx as i64, ny as i64);
    let range = [grid.mappable_range(0), grid.mappable_range(1)];
    let dt = prm.dt;
    let flip = prm.flip;
    let cp = prm.shape == ShapeKind::CpGimp;
    let (gvx, gvy, gv0x, gv0y) = (&grid.vx[..], &grid.vy[..], &grid.v0x[..], &grid.v0y[..]);
    let (lvx, lvy) = if grad_from_v0 {
        (gv0x, gv0y)
    } else {
        (gvx, gvy)
    };
    let mut st = PassStats {
        dt_cfl1: f64::INFINITY,
        ..PassStats::default()
    };
    let mut acc = 0.0f64;
    // Every field sliced to `np` up front, so the loop's indexing needs no
    // bounds checks.
    let Particles {
        id: _,
        x,
        y,
        vx,
        vy,
        lpx0,
        lpy0,
        lpx,
        lpy,
        fxx,
        fxy,
        fyx,
        fyy,
        sxx,
        syy,
        sxy,
        szz,
        material,
        ..
    } = parts;
    let (x, y, vx, vy) = (&mut x[..np], &mut y[..np], &mut vx[..np], &mut vy[..np]);
    let (lpx0, lpy0) = (&lpx0[..np], &lpy0[..np]);
    let (lpx, lpy) = (&mut lpx[..np], &mut lpy[..np]);
    let (fxx, fxy, fyx, fyy) = (
        &mut fxx[..np],
        &mut fxy[..np],
        &mut fyx[..np],
        &mut fyy[..np],
    );
    let (sxx, syy, sxy, szz) = (
        &mut sxx[..np],
        &mut syy[..np],
        &mut sxy[..np],
        &mut szz[..np],
    );
    let material = &material[..np];
    for p in 0..np {
        let wx = S::eval((x[p] - ox) * inv_h, lpx[p] * inv_h);
        let wy = S::eval((y[p] - oy) * inv_h, lpy[p] * inv_h);
        let ix = wx.base - lox;
        let iy = wy.base - loy;
        if ix < 0 || iy < 0 || ix + 2 >= nxi || iy + 2 >= nyi {
            st.first_outside.get_or_insert(p);
            continue;
        }
        let k0 = iy as usize * nx + ix as usize;
        let (mut svx, mut svy, mut s0x, mut s0y) = (0.0, 0.0, 0.0, 0.0);
        let (mut lxx, mut lxy, mut lyx, mut lyy) = (0.0, 0.0, 0.0, 0.0);
        for b in 0..3 {
            let r = k0 + b * nx;
            let (wyb, gyb) = (wy.w[b], wy.g[b]);
            let (gvx, gvy) = (&gvx[r..r + 3], &gvy[r..r + 3]);
            let (gv0x, gv0y) = (&gv0x[r..r + 3], &gv0y[r..r + 3]);
            let (lvx, lvy) = (&lvx[r..r + 3], &lvy[r..r + 3]);
            for a in 0..3 {
                let w = wx.w[a] * wyb;
                if VEL || POS {
                    svx += w * gvx[a];
                    svy += w * gvy[a];
                }
                if VEL {
                    s0x += w * gv0x[a];
                    s0y += w * gv0y[a];
                }
                if STRAIN {
                    let dx = wx.g[a] * wyb;
                    let dy = wx.w[a] * gyb;
                    lxx += lvx[a] * dx;
                    lxy += lvx[a] * dy;
                    lyx += lvy[a] * dx;
                    lyy += lvy[a] * dy;
                }
            }
        }
        if VEL {
            vx[p] = flip * (vx[p] + (svx - s0x)) + (1.0 - flip) * svx;
            vy[p] = flip * (vy[p] + (svy - s0y)) + (1.0 - flip) * svy;
        }
        let mp = &mats[material[p] as usize];
        if STRAIN {
            let l = Tensor2 {
                xx: lxx * inv_h,
                xy: lxy * inv_h,
                yx: lyx * inv_h,
                yy: lyy * inv_h,
            };
            let f = Tensor2 {
                xx: fxx[p],
                xy: fxy[p],
                yx: fyx[p],
                yy: fyy[p],
            };
            let fnew = Tensor2 {
                xx: f.xx + dt * (l.xx * f.xx + l.xy * f.yx),
                xy: f.xy + dt * (l.xx * f.xy + l.xy * f.yy),
                yx: f.yx + dt * (l.yx * f.xx + l.yy * f.yx),
                yy: f.yy + dt * (l.yx * f.xy + l.yy * f.yy),
            };
            if fnew.det().is_nan() || fnew.det() <= 0.0 {
                st.first_inverted.get_or_insert(p);
            }
            let s = Stress {
                xx: sxx[p],
                yy: syy[p],
                xy: sxy[p],
                zz: szz[p],
            };
            let s = M::update(mp, s, &l, dt, &fnew);
            fxx[p] = fnew.xx;
            fxy[p] = fnew.xy;
            fyx[p] = fnew.yx;
            fyy[p] = fnew.yy;
            sxx[p] = s.xx;
            syy[p] = s.yy;
            sxy[p] = s.xy;
            szz[p] = s.zz;
        }
        if POS {
            let xn = x[p] + dt * svx;
            let yn = y[p] + dt * svy;
            x[p] = xn;
            y[p] = yn;
            let (fxx, fyy) = (fxx[p], fyy[p]);
            if cp {
                let (lx, ly) = cpgimp_half_lengths(lpx0[p], lpy0[p], fxx, fyy, h);
                lpx[p] = lx;
                lpy[p] = ly;
            }
            let j = fxx * fyy - fxy[p] * fyx[p];
            let (vxp, vyp) = (vx[p], vy[p]);
            let speed = M::wave_speed(mp, j) + (vxp * vxp + vyp * vyp).sqrt();
            st.dt_cfl1 = st.dt_cfl1.min(h / speed);
            acc += xn + yn + vxp + vyp + j + sxx[p] + syy[p] + sxy[p] + szz[p];
            let xi = (xn - ox) * inv_h;
            let yi = (yn - oy) * inv_h;
            if !(xi >= range[0].0 && xi < range[0].1 && yi >= range[1].0 && yi < range[1].1) {
                st.first_outside.get_or_insert(p);
            }
        }
    }
    if POS && !acc.is_finite() {
        st.first_nonfinite = Some(first_nonfinite(parts).unwrap_or(0));
    }
    st
}

/// First particle with a non-finite position, velocity, F or stress.
pub(crate) fn first_nonfinite(p: &Particles) -> Option<usize> {
    (0..p.len()).find(|&i| {
        ![
            p.x[i], p.y[i], p.vx[i], p.vy[i], p.fxx[i], p.fxy[i], p.fyx[i], p.fyy[i], p.sxx[i],
            p.syy[i], p.sxy[i], p.szz[i],
        ]
        .iter()
        .all(|v| v.is_finite())
    })
}
