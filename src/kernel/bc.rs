//! Grid updates (nodal velocities from momentum and force) and the boundary
//! conditions on the physical domain faces.

use super::{FaceBc, Grid, PatchBoundary};

/// Computes `v0 = p/m` and `v = (p + f dt)/m` on every node whose mass
/// exceeds `mass_tol`; lighter nodes are treated as empty (zero velocities).
/// Then applies the boundary conditions (zero normal, or all, components of
/// momentum, force and both velocities on the constrained nodes).
pub fn grid_update(grid: &mut Grid, dt: f64, mass_tol: f64, bnd: &PatchBoundary) {
    let Grid {
        mass,
        px,
        py,
        fx,
        fy,
        v0x,
        v0y,
        vx,
        vy,
        ..
    } = grid;
    let n = mass.len();
    let (px, py, fx, fy) = (&px[..n], &py[..n], &fx[..n], &fy[..n]);
    let (v0x, v0y, vx, vy) = (&mut v0x[..n], &mut v0y[..n], &mut vx[..n], &mut vy[..n]);
    for k in 0..n {
        let m = mass[k];
        if m > mass_tol {
            let inv = 1.0 / m;
            v0x[k] = px[k] * inv;
            v0y[k] = py[k] * inv;
            vx[k] = (px[k] + fx[k] * dt) * inv;
            vy[k] = (py[k] + fy[k] * dt) * inv;
        } else {
            v0x[k] = 0.0;
            v0y[k] = 0.0;
            vx[k] = 0.0;
            vy[k] = 0.0;
        }
    }
    apply_bc(grid, bnd);
}

/// Computes `v0 = p/m` only (USF's first grid pass, MUSL's re-mapped
/// momentum), with the same empty-node rule and boundary conditions.
pub fn grid_velocity(grid: &mut Grid, mass_tol: f64, bnd: &PatchBoundary) {
    let n = grid.mass.len();
    let (mass, px, py) = (&grid.mass[..n], &grid.px[..n], &grid.py[..n]);
    let (v0x, v0y) = (&mut grid.v0x[..n], &mut grid.v0y[..n]);
    for k in 0..n {
        let m = mass[k];
        if m > mass_tol {
            let inv = 1.0 / m;
            v0x[k] = px[k] * inv;
            v0y[k] = py[k] * inv;
        } else {
            v0x[k] = 0.0;
            v0y[k] = 0.0;
        }
    }
    apply_bc(grid, bnd);
}

/// Applies the face conditions of `bnd` to the nodes on each constrained
/// domain face and beyond it (nodes outside the domain carry no material in
/// a well-posed run; constraining them too keeps stray particles from
/// crossing a wall). `Roller` zeroes the normal component of momentum, force
/// and both velocities (a symmetry plane); `Fixed` zeroes both components;
/// `Free` does nothing.
pub fn apply_bc(grid: &mut Grid, bnd: &PatchBoundary) {
    let [nx, ny] = grid.n;
    let [lox, loy] = grid.lo;
    for (side, face) in bnd.faces.iter().enumerate() {
        let Some(face) = face else { continue };
        if face.bc == FaceBc::Free {
            continue;
        }
        // Node range (local indices) constrained by this face.
        let (ia, ib, ja, jb) = match side {
            0 => (0, (face.node - lox + 1).clamp(0, nx as i64), 0, ny as i64),
            1 => (
                (face.node - lox).clamp(0, nx as i64),
                nx as i64,
                0,
                ny as i64,
            ),
            2 => (0, nx as i64, 0, (face.node - loy + 1).clamp(0, ny as i64)),
            _ => (
                0,
                nx as i64,
                (face.node - loy).clamp(0, ny as i64),
                ny as i64,
            ),
        };
        let normal_x = side < 2;
        let zero_x = face.bc == FaceBc::Fixed || normal_x;
        let zero_y = face.bc == FaceBc::Fixed || !normal_x;
        for j in ja..jb {
            let row = j as usize * nx;
            for i in ia..ib {
                let k = row + i as usize;
                if zero_x {
                    grid.px[k] = 0.0;
                    grid.fx[k] = 0.0;
                    grid.v0x[k] = 0.0;
                    grid.vx[k] = 0.0;
                }
                if zero_y {
                    grid.py[k] = 0.0;
                    grid.fy[k] = 0.0;
                    grid.v0y[k] = 0.0;
                    grid.vy[k] = 0.0;
                }
            }
        }
    }
}
