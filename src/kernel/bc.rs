//! Grid updates (nodal velocities from momentum and force) and the boundary
//! conditions on the physical domain faces.

use super::grid::{mf, vl, Node4};
use super::{FaceBc, Grid, PatchBoundary};

/// The reciprocal of a nodal mass, or `None` for a node that carries no
/// mass (or one so small that `1/m` overflows, below about 2e-308 of the
/// mass unit, where the weights that made it have underflowed anyway).
///
/// There is deliberately no relative threshold: a nearly empty node (GIMP's
/// quadratic weight tails give masses of 1e-12 of a particle's and less)
/// keeps its velocity `(p + f dt)/m` however light it is. Its acceleration
/// `f/m` may be large, but every particle reads it multiplied by its weight
/// `S_ip <= m_i / m_p`, so a particle's velocity change from it is at most
/// `|f_i| dt / m_p`, bounded, and the momentum the particles receive,
/// `Σ_p m_p S_ip f_i dt / m_i = f_i dt`, is exactly the force's impulse.
/// Dropping such nodes (zero velocity) dropped their forces: momentum in
/// free flight drifted by 3e-11 relative per thousand steps with GIMP.
#[inline(always)]
pub(crate) fn inv_mass(m: f64) -> Option<f64> {
    let inv = 1.0 / m;
    (m > 0.0 && inv < f64::INFINITY).then_some(inv)
}

/// Computes `v0 = p/m` and `v = (p + f dt)/m` on every node that carries
/// mass, however little (see [`inv_mass`]); nodes without mass get zero
/// velocities. Then applies the boundary conditions (zero normal, or all,
/// components of momentum, force and both velocities on the constrained
/// nodes).
pub fn grid_update(grid: &mut Grid, dt: f64, bnd: &PatchBoundary) {
    let n = grid.mass.len();
    let (mass, mf, vel) = (&grid.mass[..n], &grid.mom_force[..n], &mut grid.vel[..n]);
    for k in 0..n {
        vel[k] = match inv_mass(mass[k]) {
            Some(inv) => {
                let [px, py, fx, fy] = mf[k].0;
                Node4([
                    (px + fx * dt) * inv,
                    (py + fy * dt) * inv,
                    px * inv,
                    py * inv,
                ])
            }
            None => Node4::default(),
        };
    }
    apply_bc(grid, bnd);
}

/// Computes `v0 = p/m` only (USF's first grid pass, MUSL's re-mapped
/// momentum), with the same rule for nodes without mass and the boundary
/// conditions (`v` is left as it is).
pub fn grid_velocity(grid: &mut Grid, bnd: &PatchBoundary) {
    let n = grid.mass.len();
    let (mass, mf, vel) = (&grid.mass[..n], &grid.mom_force[..n], &mut grid.vel[..n]);
    for k in 0..n {
        let v0 = match inv_mass(mass[k]) {
            Some(inv) => [mf[k].0[mf::PX] * inv, mf[k].0[mf::PY] * inv],
            None => [0.0, 0.0],
        };
        vel[k].0[vl::V0X] = v0[0];
        vel[k].0[vl::V0Y] = v0[1];
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
    let (n, lo) = (grid.n, grid.lo);
    let (mfs, vel) = (&mut grid.mom_force, &mut grid.vel);
    constrained_nodes(n, lo, bnd, |k, zero_x, zero_y| {
        let (f, v) = (&mut mfs[k].0, &mut vel[k].0);
        if zero_x {
            f[mf::PX] = 0.0;
            f[mf::FX] = 0.0;
            v[vl::VX] = 0.0;
            v[vl::V0X] = 0.0;
        }
        if zero_y {
            f[mf::PY] = 0.0;
            f[mf::FY] = 0.0;
            v[vl::VY] = 0.0;
            v[vl::V0Y] = 0.0;
        }
    });
}

/// Calls `f(k, zero_x, zero_y)` for every node `k` (storage index of a grid
/// of `n` nodes from `lo`) that a face condition of `bnd` constrains, with
/// the components it zeroes (see [`apply_bc`]); a node on two constrained
/// faces is visited once per face.
pub(crate) fn constrained_nodes(
    n: [usize; 2],
    lo: [i64; 2],
    bnd: &PatchBoundary,
    mut f: impl FnMut(usize, bool, bool),
) {
    let [nx, ny] = n;
    let [lox, loy] = lo;
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
                f(row + i as usize, zero_x, zero_y);
            }
        }
    }
}
