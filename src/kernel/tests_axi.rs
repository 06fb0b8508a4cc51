//! Unit tests of the patch kernel in the axisymmetric mode (x is the radius
//! r, y the axis z; see [`crate::mode`]): the r-weighted weights, the hoop
//! rate and the hoop force, on blocks of particles whose first column
//! touches the axis.

use super::grid::{mf, Node4};
use super::*;
use crate::material::Material;
use crate::mode::ModeKind;
use crate::particles::{NewParticle, Particles};
use crate::shape::ShapeKind;

const MAT: Material = Material::LinearElastic {
    e: 1.0e6,
    nu: 0.25,
    rho: 1000.0,
};

use super::tests::SHAPES;

/// A block of `nr x nz` cells from the axis (r in [0, nr h]) and z in [0, nz
/// h] on a grid with h = 0.1 and one ghost cell, 2x2 particles per cell
/// with per-radian volumes and masses (`4 lp² r_p`): the first column's
/// domains touch the axis.
fn axi_block(nr: i64, nz: i64) -> (Grid, Particles) {
    let h = 0.1;
    let grid = Grid::new([0.0, 0.0], h, [0, 0], [nr, nz], 1).unwrap();
    let mut parts = Particles::new();
    let lp = h / 4.0;
    let mut id = 0;
    for j in 0..2 * nz {
        for i in 0..2 * nr {
            let r = (i as f64 + 0.5) * 2.0 * lp;
            parts.push(
                &NewParticle {
                    id,
                    x: r,
                    y: (j as f64 + 0.5) * 2.0 * lp,
                    lpx: lp,
                    lpy: lp,
                    vx: 0.0,
                    vy: 0.0,
                    mass: 1000.0 * 4.0 * lp * lp * r,
                    material: 0,
                },
                r,
            );
            id += 1;
        }
    }
    (grid, parts)
}

fn params(shape: ShapeKind, scheme: Scheme, dt: f64) -> StepParams {
    StepParams {
        mode: ModeKind::Axisymmetric,
        ..super::tests::params(shape, scheme, dt)
    }
}

/// The velocity field `v_r = a r + c z`, `v_z = e r + b z + d` at `(r, z)`.
fn field(k: [f64; 5], r: f64, z: f64) -> [f64; 2] {
    let [a, b, c, d, e] = k;
    [a * r + c * z, e * r + b * z + d]
}

/// Sets both grid velocities of every node to [`field`].
fn set_field(grid: &mut Grid, k: [f64; 5]) {
    for j in 0..grid.n[1] {
        for i in 0..grid.n[0] {
            let [r, z] = grid.node_position(grid.lo[0] + i as i64, grid.lo[1] + j as i64);
            let v = field(k, r, z);
            grid.vel[j * grid.n[0] + i] = Node4([v[0], v[1], v[0], v[1]]);
        }
    }
}

/// The patch test of the axisymmetric mode: for a homogeneous expansion
/// `v = ε̇ (r, z)` plus shears and a translation along the axis (`v_r = a r
/// + c z`, `v_z = e r + b z + d`), the strain pass gives every particle,
/// the column whose domains touch the axis included, the exact velocity
/// gradient and hoop rate (`v_r/r` over the particle's volume, `a + c
/// z_p/r_p`): F after one USL step is `I + dt L` and `F_θθ = 1 + dt L_θθ`
/// to round-off, for MPM, uGIMP and cpGIMP.
#[test]
fn homogeneous_expansion_is_exact_at_every_particle_including_the_axis_column() {
    let k = [0.7, -0.3, 0.25, 0.4, -0.55];
    let dt = 1e-3;
    let mats = [MAT.params()];
    for shape in SHAPES {
        let (mut grid, mut parts) = axi_block(4, 3);
        set_field(&mut grid, k);
        let prm = params(shape, Scheme::Usl, dt);
        let (r0, z0) = (parts.x.to_vec(), parts.y.to_vec());
        let st = g2p(&grid, &mut parts, &mats, &prm, G2pPass::UslAll);
        assert!(st.first_outside.is_none() && st.first_inverted.is_none());
        let [a, b, c, _, e] = k;
        let mut worst = 0.0f64;
        for p in 0..parts.len() {
            let got = [
                parts.fxx[p],
                parts.fxy[p],
                parts.fyx[p],
                parts.fyy[p],
                parts.fzz[p],
            ];
            // v_r/r averaged over the particle's volume: a + c z_p/r_p
            // (∫ (a r + c z) dA / ∫ r dA), at the start-of-step position.
            let hoop = a + c * z0[p] / r0[p];
            let want = [1.0 + dt * a, dt * c, dt * e, 1.0 + dt * b, 1.0 + dt * hoop];
            for (g, w) in got.iter().zip(want) {
                worst = worst.max((g - w).abs());
            }
        }
        assert!(worst < 1e-14, "{shape:?}: F off by {worst:e}");
        // The hoop stress follows: the elastic law's σ_θθ from D_θθ.
        let (lam, mu) = (mats[0].lambda, mats[0].mu);
        for p in 0..parts.len() {
            let hoop = a + c * z0[p] / r0[p];
            let want = lam * dt * (a + b + hoop) + 2.0 * mu * dt * hoop;
            assert!(
                (parts.szz[p] - want).abs() < 1e-9 * want.abs(),
                "{shape:?}: particle {p}: σ_θθ {} against {want}",
                parts.szz[p]
            );
        }
    }
}

/// Equilibrium of a uniform hydrostatic stress `σ_rr = σ_zz = σ_θθ`: with
/// the GIMP weights integrated exactly, the internal force vanishes at
/// every node whose support lies in the block, the nodes on the axis
/// included (`∫ ∂(N_i r)/∂r dA = 0`). Without the hoop force the radial
/// force of the same nodes is the hoop term itself, which shows the test
/// can fail.
#[test]
fn hydrostatic_stress_gives_no_force_inside_the_block_and_on_the_axis() {
    for shape in [ShapeKind::UGimp, ShapeKind::CpGimp] {
        for hoop in [true, false] {
            let (mut grid, mut parts) = axi_block(6, 6);
            for p in 0..parts.len() {
                parts.sxx[p] = -2e3;
                parts.syy[p] = -2e3;
                parts.szz[p] = if hoop { -2e3 } else { 0.0 };
            }
            let prm = params(shape, Scheme::Usl, 1e-4);
            grid.reset();
            p2g(&mut grid, &parts, &prm, None, (true, true, true)).unwrap();
            let mut worst = 0.0f64;
            for j in 1..=5 {
                for i in 0..=5 {
                    let k = grid.index(i, j).unwrap();
                    let f = grid.mom_force[k].0;
                    worst = worst.max(f[mf::FX].abs()).max(f[mf::FY].abs());
                }
            }
            // The force scale: σ times a cell's per-radian face (h · h).
            let scale = 2e3 * 0.1 * 0.1;
            if hoop {
                assert!(worst < 1e-12 * scale, "{shape:?}: interior force {worst:e}");
            } else {
                assert!(
                    worst > 0.1 * scale,
                    "{shape:?}: without the hoop force {worst:e}"
                );
            }
        }
    }
}

/// APIC in axisymmetry: an affine particle velocity field with `C = A`
/// maps to the nodes and back exactly (the affine part expands about the
/// r-weighted centroid of each particle's volume, so it adds no momentum).
#[test]
fn apic_reproduces_affine_fields_in_axisymmetry() {
    let k = [0.5, -0.4, -1.3, 0.3, 0.9];
    let mats = [MAT.params()];
    for shape in SHAPES {
        let (mut grid, mut parts) = axi_block(4, 4);
        // The particle velocity is the field at the centroid of its volume
        // (what the r-weighted weights interpolate), `Σ S x_i`.
        for p in 0..parts.len() {
            let l = if shape == ShapeKind::Mpm {
                0.0
            } else {
                parts.lpx[p]
            };
            let rc = parts.x[p] + l * l / (3.0 * parts.x[p]);
            let v = field(k, rc, parts.y[p]);
            parts.vx[p] = v[0];
            parts.vy[p] = v[1];
            parts.cxx[p] = k[0];
            parts.cxy[p] = k[2];
            parts.cyx[p] = k[4];
            parts.cyy[p] = k[1];
        }
        let mut prm = params(shape, Scheme::Musl, 1e-4);
        prm.transfer = Transfer::Apic;
        grid.reset();
        p2g(&mut grid, &parts, &prm, None, (true, true, false)).unwrap();
        grid_update(&mut grid, prm.dt, &prm.boundary);
        let mut node_err = 0.0f64;
        for j in 0..grid.n[1] {
            for i in 0..grid.n[0] {
                let n = j * grid.n[0] + i;
                if grid.mass[n] == 0.0 {
                    continue;
                }
                let [r, z] = grid.node_position(grid.lo[0] + i as i64, grid.lo[1] + j as i64);
                let v = field(k, r, z);
                let g = grid.vel[n].0;
                node_err = node_err.max((g[0] - v[0]).abs().max((g[1] - v[1]).abs()));
            }
        }
        assert!(node_err < 1e-13, "{shape:?}: nodes off by {node_err:e}");
        let before: Vec<[f64; 2]> = (0..parts.len())
            .map(|p| [parts.vx[p], parts.vy[p]])
            .collect();
        let st = g2p(&grid, &mut parts, &mats, &prm, G2pPass::MuslVelocity);
        st.to_result(&parts).unwrap();
        let mut err = 0.0f64;
        for p in 0..parts.len() {
            err = err
                .max((parts.vx[p] - before[p][0]).abs())
                .max((parts.vy[p] - before[p][1]).abs())
                .max((parts.cxx[p] - k[0]).abs())
                .max((parts.cxy[p] - k[2]).abs())
                .max((parts.cyx[p] - k[4]).abs())
                .max((parts.cyy[p] - k[1]).abs());
        }
        assert!(err < 1e-12, "{shape:?}: particles off by {err:e}");
    }
}

/// Mass and axial momentum: P2G spreads the per-radian mass and momentum
/// without loss (the r-weighted weights sum to one).
#[test]
fn p2g_keeps_the_per_radian_mass_and_axial_momentum() {
    for shape in SHAPES {
        let (mut grid, mut parts) = axi_block(5, 3);
        for p in 0..parts.len() {
            parts.vy[p] = 0.3 + parts.x[p];
        }
        let prm = params(shape, Scheme::Usl, 1e-4);
        grid.reset();
        p2g(&mut grid, &parts, &prm, None, (true, true, false)).unwrap();
        let m: f64 = parts.mass.iter().sum();
        let pz: f64 = (0..parts.len()).map(|p| parts.mass[p] * parts.vy[p]).sum();
        let gm: f64 = grid.mass.iter().sum();
        let gpz: f64 = grid.mom_force.iter().map(|n| n.0[mf::PY]).sum();
        assert!((gm - m).abs() < 1e-14 * m, "{shape:?}: mass {gm} vs {m}");
        assert!((gpz - pz).abs() < 1e-14 * pz.abs(), "{shape:?}: momentum");
    }
}
