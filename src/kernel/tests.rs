//! Unit tests of the patch kernel: conservation, rigid motion, boundary
//! conditions, argument checks.

use super::grid::{mf, vl, Node4};
use super::*;
use crate::error::Status;
use crate::material::{MatParams, Material};
use crate::particles::{NewParticle, Particles};
use crate::shape::ShapeKind;

const MAT: Material = Material::LinearElastic {
    e: 1.0e6,
    nu: 0.25,
    rho: 1000.0,
};

/// Lane `i` of every node.
fn lane(v: &[Node4], i: usize) -> Vec<f64> {
    v.iter().map(|n| n.0[i]).collect()
}

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A block of `n x n` cells starting at cell (2, 2) of a grid with h = 0.1,
/// 2x2 particles per cell, uniform velocity `v`.
fn block(n: i64, v: [f64; 2]) -> (Grid, Particles) {
    let h = 0.1;
    let grid = Grid::new([0.0, 0.0], h, [0, 0], [n + 4, n + 4], 1).unwrap();
    let mut parts = Particles::new();
    let lp = h / 4.0;
    let mut id = 0;
    for j in 0..2 * n {
        for i in 0..2 * n {
            parts.push(
                &NewParticle {
                    id,
                    x: 0.2 + (i as f64 + 0.5) * 2.0 * lp,
                    y: 0.2 + (j as f64 + 0.5) * 2.0 * lp,
                    lpx: lp,
                    lpy: lp,
                    vx: v[0],
                    vy: v[1],
                    mass: 1000.0 * 4.0 * lp * lp,
                    material: 0,
                },
                1.0,
            );
            id += 1;
        }
    }
    (grid, parts)
}

pub(super) fn params(shape: ShapeKind, scheme: Scheme, dt: f64) -> StepParams {
    StepParams {
        dt,
        shape,
        scheme,
        flip: 1.0,
        transfer: Transfer::Flip,
        xpic_order: 1,
        load_factor: 1.0,
        gravity: [0.0, 0.0],
        mass_tol: 0.0,
        boundary: PatchBoundary::default(),
        mode: crate::mode::ModeKind::PlaneStrain,
    }
}

pub(super) const SHAPES: [ShapeKind; 3] = [ShapeKind::Mpm, ShapeKind::UGimp, ShapeKind::CpGimp];
const SCHEMES: [Scheme; 3] = [Scheme::Usf, Scheme::Usl, Scheme::Musl];

#[test]
fn p2g_conserves_mass_momentum_and_force() {
    let (mut grid, mut parts) = block(4, [0.0, 0.0]);
    let mut r = Lcg(3);
    for p in 0..parts.len() {
        parts.x[p] += 0.04 * (r.next() - 0.5);
        parts.y[p] += 0.04 * (r.next() - 0.5);
        parts.vx[p] = r.next() - 0.5;
        parts.vy[p] = r.next() - 0.5;
        parts.sxx[p] = 1e3 * (r.next() - 0.5);
        parts.syy[p] = 1e3 * (r.next() - 0.5);
        parts.sxy[p] = 1e3 * (r.next() - 0.5);
        // Surface loads on a face in y and one in x (signs at random).
        parts.fext_x[p] = r.next();
        parts.fext_y[p] = -r.next();
        parts.fside_x[p] = r.next() - 0.5;
        parts.fside_y[p] = r.next() - 0.5;
        let ty = if r.next() < 0.5 { -1 } else { 1 };
        let tx = [-1, 0, 1][(3.0 * r.next()) as usize % 3];
        parts.load_faces[p] =
            crate::particles::load_faces_code(ty, tx, crate::particles::LoadKind::Dead);
    }
    for shape in SHAPES {
        let mut prm = params(shape, Scheme::Usl, 1e-4);
        prm.load_factor = 0.5;
        prm.gravity = [0.0, -9.81];
        grid.reset();
        p2g(&mut grid, &parts, &prm, None, (true, true, true)).unwrap();
        let sum = |v: &[f64]| v.iter().sum::<f64>();
        let pm = sum(&parts.mass);
        let pmx: f64 = (0..parts.len()).map(|p| parts.mass[p] * parts.vx[p]).sum();
        let pmy: f64 = (0..parts.len()).map(|p| parts.mass[p] * parts.vy[p]).sum();
        let side = |p: usize| crate::particles::load_faces_of(parts.load_faces[p]).1 != 0;
        let fsx: f64 = (0..parts.len())
            .filter(|&p| side(p))
            .map(|p| parts.fside_x[p])
            .sum();
        let fsy: f64 = (0..parts.len())
            .filter(|&p| side(p))
            .map(|p| parts.fside_y[p])
            .sum();
        let fex = 0.5 * (sum(&parts.fext_x) + fsx);
        let fey = 0.5 * (sum(&parts.fext_y) + fsy) - 9.81 * pm;
        assert!((sum(&grid.mass) - pm).abs() < 1e-13 * pm);
        assert!((sum(&lane(&grid.mom_force, mf::PX)) - pmx).abs() < 1e-13 * pm);
        assert!((sum(&lane(&grid.mom_force, mf::PY)) - pmy).abs() < 1e-13 * pm);
        // internal forces sum to zero (gradients of a partition of unity)
        let scale = 1e3 * 0.1;
        assert!(
            (sum(&lane(&grid.mom_force, mf::FX)) - fex).abs() < 1e-12 * scale,
            "{shape:?}"
        );
        assert!(
            (sum(&lane(&grid.mom_force, mf::FY)) - fey).abs() < 1e-12 * scale,
            "{shape:?}"
        );
    }
}

/// A surface load goes to the nodes with the face integral of their shape
/// functions: along the face, the particle's GIMP average; across it, the
/// hat functions at the face.
#[test]
fn surface_loads_use_the_face_integral() {
    let (mut grid, mut parts) = block(4, [0.0, 0.0]);
    // One particle of the block (centre (0.275, 0.225), lp = h/4), loaded on
    // its top face.
    let p = 3;
    let (x, y, lx, ly) = (parts.x[p], parts.y[p], parts.lpx[p], parts.lpy[p]);
    parts.fext_y[p] = -2.0;
    parts.load_faces[p] = crate::particles::load_faces_code(1, 0, crate::particles::LoadKind::Dead);
    let mut only = Particles::new();
    only.push_from(&parts, p);
    for shape in [ShapeKind::UGimp, ShapeKind::CpGimp] {
        let prm = params(shape, Scheme::Usl, 1e-4);
        grid.reset();
        p2g(&mut grid, &only, &prm, None, (false, false, true)).unwrap();
        let h = grid.h;
        let yf = y + ly;
        for j in grid.lo[1]..grid.lo[1] + grid.n[1] as i64 {
            for i in grid.lo[0]..grid.lo[0] + grid.n[0] as i64 {
                let (xi, yj) = (i as f64 * h, j as f64 * h);
                // ∫ over [x - lx, x + lx] of the hat in x, by quadrature.
                let n = 4000;
                let ax: f64 = (0..n)
                    .map(|k| {
                        let s = x - lx + (k as f64 + 0.5) * 2.0 * lx / n as f64;
                        (1.0 - (s - xi).abs() / h).max(0.0)
                    })
                    .sum::<f64>()
                    / n as f64;
                let ay = (1.0 - (yf - yj).abs() / h).max(0.0);
                let k = grid.index(i, j).unwrap();
                let want = -2.0 * ax * ay;
                let got = grid.mom_force[k].0[mf::FY];
                assert!(
                    (got - want).abs() < 1e-6,
                    "{shape:?} node ({i},{j}): {got} vs {want}"
                );
            }
        }
    }
}

/// Follower loads: the total force on the grid is the reference force
/// scaled by the face's stretch (`FollowArea`), or also turned with the
/// face (`FollowFace`, Nanson), on a face in x and on one in y; a dead load
/// on the same particle keeps its reference force.
#[test]
fn follower_loads_turn_and_stretch_with_the_face() {
    use crate::particles::{load_faces_code, LoadKind};
    let (mut grid, mut parts) = block(4, [0.0, 0.0]);
    let p = 5;
    // F = R(0.3) diag(1.4, 0.8) plus a shear: the faces turn and stretch.
    let (c, s) = (0.3f64.cos(), 0.3f64.sin());
    let u = [[1.4, 0.2], [0.0, 0.8]];
    let f = [
        c * u[0][0] - s * u[1][0],
        c * u[0][1] - s * u[1][1],
        s * u[0][0] + c * u[1][0],
        s * u[0][1] + c * u[1][1],
    ];
    parts.fxx[p] = f[0];
    parts.fxy[p] = f[1];
    parts.fyx[p] = f[2];
    parts.fyy[p] = f[3];
    parts.fside_x[p] = 3.0;
    parts.fside_y[p] = 0.5;
    parts.fext_x[p] = -0.25;
    parts.fext_y[p] = 2.0;
    let mut only = Particles::new();
    for (kind, want) in [
        (LoadKind::Dead, [3.0 - 0.25, 0.5 + 2.0]),
        (LoadKind::FollowArea, {
            // |F e_y| and |F e_x| scale the forces; directions kept.
            let (sy, sx) = (f[1].hypot(f[3]), f[0].hypot(f[2]));
            [3.0 * sy - 0.25 * sx, 0.5 * sy + 2.0 * sx]
        }),
        (LoadKind::FollowFace, {
            // Right face: N = e_x, n da / dA = J F^-T e_x = (fyy, -fxy);
            // normal and tangential components (3, 0.5) on it, the tangent
            // the normal turned by +90°.
            let (nx, ny) = (f[3], -f[1]);
            let side = [3.0 * nx - 0.5 * ny, 3.0 * ny + 0.5 * nx];
            // Top face: N = e_y, J F^-T e_y = (-fyx, fxx); components
            // (normal 2.0, tangential -0.25 along e_x = N turned by -90°,
            // which turns with the face).
            let (mx, my) = (-f[2], f[0]);
            let top = [2.0 * mx - 0.25 * my, 2.0 * my + 0.25 * mx];
            [side[0] + top[0], side[1] + top[1]]
        }),
    ] {
        parts.load_faces[p] = load_faces_code(1, 1, kind);
        only.clear();
        only.push_from(&parts, p);
        for shape in [ShapeKind::UGimp, ShapeKind::CpGimp] {
            let mut prm = params(shape, Scheme::Usl, 1e-4);
            prm.load_factor = 0.5;
            grid.reset();
            p2g(&mut grid, &only, &prm, None, (false, false, true)).unwrap();
            let fx: f64 = lane(&grid.mom_force, mf::FX).iter().sum();
            let fy: f64 = lane(&grid.mom_force, mf::FY).iter().sum();
            assert!(
                (fx - 0.5 * want[0]).abs() < 1e-13,
                "{kind:?} {shape:?}: {fx} vs {}",
                0.5 * want[0]
            );
            assert!(
                (fy - 0.5 * want[1]).abs() < 1e-13,
                "{kind:?} {shape:?}: {fy} vs {}",
                0.5 * want[1]
            );
        }
    }
}

#[test]
fn uniform_stress_gives_no_interior_force_with_gimp() {
    // GIMP particles tiling a block integrate ∇S exactly: a uniform stress
    // produces no force on nodes whose support is inside the block.
    let (mut grid, mut parts) = block(6, [0.0, 0.0]);
    for p in 0..parts.len() {
        parts.sxx[p] = 2e3;
        parts.syy[p] = -1e3;
        parts.sxy[p] = 5e2;
    }
    let prm = params(ShapeKind::UGimp, Scheme::Usl, 1e-4);
    grid.reset();
    p2g(&mut grid, &parts, &prm, None, (true, true, true)).unwrap();
    let mut edge_max = 0.0f64;
    for j in 3..=7 {
        for i in 3..=7 {
            let k = grid.index(i, j).unwrap();
            assert!(
                grid.mom_force[k].0[mf::FX].abs() < 1e-10
                    && grid.mom_force[k].0[mf::FY].abs() < 1e-10,
                "node ({i},{j})"
            );
        }
    }
    for i in 2..=8 {
        let k = grid.index(i, 2).unwrap();
        edge_max = edge_max.max(grid.mom_force[k].0[mf::FY].abs());
    }
    // ... while the boundary nodes carry the traction σ·n (not zero).
    assert!(edge_max > 10.0);
}

#[test]
fn rigid_translation_is_exact_for_all_schemes_and_shapes() {
    let v = [0.3, -0.2];
    let dt = 1e-3;
    for shape in SHAPES {
        for scheme in SCHEMES {
            for flip in [1.0, 0.0, 0.95] {
                let (mut grid, mut parts) = block(3, v);
                let x0 = parts.x.clone();
                let y0 = parts.y.clone();
                let mats = [MAT.params()];
                let mut prm = params(shape, scheme, dt);
                prm.flip = flip;
                let st = step_patch(&mut grid, &mut parts, &mats, &prm, None).unwrap();
                for p in 0..parts.len() {
                    assert!((parts.x[p] - x0[p] - v[0] * dt).abs() < 1e-14);
                    assert!((parts.y[p] - y0[p] - v[1] * dt).abs() < 1e-14);
                    assert!((parts.vx[p] - v[0]).abs() < 1e-13);
                    assert!((parts.vy[p] - v[1]).abs() < 1e-13);
                    assert!(parts.sxx[p].abs() < 1e-6 && parts.sxy[p].abs() < 1e-6);
                    assert!((parts.fxx[p] - 1.0).abs() < 1e-12);
                }
                let c = MAT.p_wave_speed(1.0);
                let speed = c + (v[0] * v[0] + v[1] * v[1]).sqrt();
                assert!((st.dt_cfl1 - 0.1 / speed).abs() < 1e-12 * st.dt_cfl1);
            }
        }
    }
}

#[test]
fn momentum_is_conserved_without_external_force() {
    for shape in SHAPES {
        for scheme in SCHEMES {
            let (mut grid, mut parts) = block(4, [0.0, 0.0]);
            let mut r = Lcg(11);
            for p in 0..parts.len() {
                parts.vx[p] = 0.1 * (r.next() - 0.5);
                parts.vy[p] = 0.1 * (r.next() - 0.5);
            }
            let mats = [MAT.params()];
            let prm = params(shape, scheme, 2e-5);
            let mom = |p: &Particles| {
                (0..p.len()).fold([0.0, 0.0], |a, i| {
                    [a[0] + p.mass[i] * p.vx[i], a[1] + p.mass[i] * p.vy[i]]
                })
            };
            let m0 = mom(&parts);
            for _ in 0..20 {
                step_patch(&mut grid, &mut parts, &mats, &prm, None).unwrap();
            }
            let m1 = mom(&parts);
            let total: f64 = parts.mass.iter().sum::<f64>() * 0.05;
            assert!(
                (m1[0] - m0[0]).abs() < 1e-12 * total,
                "{shape:?} {scheme:?}"
            );
            assert!(
                (m1[1] - m0[1]).abs() < 1e-12 * total,
                "{shape:?} {scheme:?}"
            );
            // and something did happen: the stresses are no longer zero
            assert!(parts.sxx.iter().any(|s| s.abs() > 1.0));
        }
    }
}

#[test]
fn roller_and_fixed_faces_stop_normal_motion() {
    // Block at cells 2.. moving left into a wall at node 2 (x = 0.2).
    for (bc, tangential_kept) in [(FaceBc::Roller, true), (FaceBc::Fixed, false)] {
        let (mut grid, mut parts) = block(3, [-0.5, 0.25]);
        let mats = [MAT.params()];
        let mut prm = params(ShapeKind::UGimp, Scheme::Usl, 1e-4);
        prm.boundary.faces[Side::Left as usize] = Some(DomainFace { node: 2, bc });
        step_patch(&mut grid, &mut parts, &mats, &prm, None).unwrap();
        for j in grid.lo[1]..grid.lo[1] + grid.n[1] as i64 {
            for i in grid.lo[0]..=2 {
                let k = grid.index(i, j).unwrap();
                assert_eq!(grid.vel[k].0[vl::VX], 0.0);
                assert_eq!(grid.vel[k].0[vl::V0X], 0.0);
                assert_eq!(grid.mom_force[k].0[mf::FX], 0.0);
                if grid.mass[k] > 0.0 {
                    assert_eq!(
                        grid.vel[k].0[vl::VY] != 0.0,
                        tangential_kept,
                        "node ({i},{j})"
                    );
                }
            }
        }
        // the nodes further in still move left
        let k = grid.index(4, 4).unwrap();
        assert!(grid.vel[k].0[vl::VX] < -0.4);
    }
}

#[test]
fn nearly_empty_nodes_keep_their_force() {
    let (mut grid, mut parts) = block(2, [1.0, 0.0]);
    // one particle sits so that node (6, *) gets a tiny weight: at
    // xi = 4.750001 with li = 0.25 the node at distance 1.25 - 1e-6 gets
    // (1e-6)^2 / (4 li) = 1e-12 of its x-weight.
    parts.x[0] = 0.4750001;
    parts.sxx[0] = 1e3;
    let mats = [MAT.params()];
    let prm = params(ShapeKind::UGimp, Scheme::Usl, 1e-4);
    grid.reset();
    p2g(&mut grid, &parts, &prm, None, (true, true, true)).unwrap();
    grid_update(&mut grid, prm.dt, &prm.boundary);
    let mref = parts.mass.iter().cloned().fold(0.0, f64::max);
    let k = grid.index(6, 2).unwrap();
    let [px, _, fx, _] = grid.mom_force[k].0;
    // a node lighter than the old threshold (1e-10 of a particle), with a
    // force on it, is not treated as empty: its velocity change is f dt / m
    assert!(grid.mass[k] > 0.0 && grid.mass[k] < MASS_TOL_REL * mref);
    assert!(fx != 0.0);
    let dv = grid.vel[k].0[vl::VX] - grid.vel[k].0[vl::V0X];
    assert!((dv * grid.mass[k] - fx * prm.dt).abs() <= 1e-12 * (fx * prm.dt).abs());
    assert!((grid.vel[k].0[vl::V0X] * grid.mass[k] - px).abs() <= 1e-12 * px.abs());
    let k = grid.index(5, 2).unwrap();
    assert!((grid.vel[k].0[vl::V0X] - 1.0).abs() < 1e-12);
    // the particles receive the whole impulse Σ f dt: momentum after the
    // step (FLIP) equals momentum before plus the impulse of every node
    let p0: f64 = (0..parts.len()).map(|p| parts.mass[p] * parts.vx[p]).sum();
    let imp: f64 = grid.mom_force.iter().map(|n| n.0[mf::FX]).sum::<f64>() * prm.dt;
    let _ = step_patch(&mut grid, &mut parts, &mats, &prm, None).unwrap();
    let p1: f64 = (0..parts.len()).map(|p| parts.mass[p] * parts.vx[p]).sum();
    assert!(
        (p1 - p0 - imp).abs() <= 1e-14 * p0.abs(),
        "momentum {p0} + impulse {imp} != {p1}"
    );
    assert!(parts.vx.iter().all(|v| v.is_finite()));
}

#[test]
fn ramp_factor() {
    let r = Ramp { t_ramp: 2.0 };
    assert_eq!(r.factor(0.5), 0.25);
    assert_eq!(r.factor(3.0), 1.0);
    assert_eq!(Ramp { t_ramp: 0.0 }.factor(0.1), 1.0);
}

#[test]
fn bad_inputs_are_rejected() {
    let (mut grid, mut parts) = block(2, [0.0, 0.0]);
    let mats = [MAT.params()];
    let mut prm = params(ShapeKind::UGimp, Scheme::Musl, -1.0);
    let e = step_patch(&mut grid, &mut parts, &mats, &prm, None).unwrap_err();
    assert!(e.msg.contains("dt = -1"), "{}", e.msg);
    prm.dt = 1e-4;
    prm.flip = 1.5;
    let e = step_patch(&mut grid, &mut parts, &mats, &prm, None).unwrap_err();
    assert!(e.msg.contains("flip = 1.5"));
    prm.flip = 1.0;
    let b = [0.0; 3];
    let e = step_patch(
        &mut grid,
        &mut parts,
        &mats,
        &prm,
        Some(BodyForce { bx: &b, by: &b }),
    )
    .unwrap_err();
    assert!(e.msg.contains("body force"));
    parts.material[0] = 1;
    let e = step_patch(&mut grid, &mut parts, &mats, &prm, None).unwrap_err();
    assert!(e.msg.contains("material index 1"));
}

#[test]
fn particle_leaving_the_grid_is_reported() {
    let (mut grid, mut parts) = block(2, [0.0, 0.0]);
    let mats = [MAT.params()];
    let prm = params(ShapeKind::UGimp, Scheme::Usl, 1e-4);
    parts.x[3] = -0.2;
    let e = step_patch(&mut grid, &mut parts, &mats, &prm, None).unwrap_err();
    assert_eq!(e.status, Status::ParticlesLeft);
    assert!(e.msg.contains("id 3"), "{}", e.msg);
}

#[test]
fn a_runaway_strain_increment_fails_the_step() {
    let mats = [MAT.params()];
    for scheme in [Scheme::Usl, Scheme::Musl, Scheme::Usf] {
        // a stable step (c = 36 m/s, h = 0.1: h/c = 2.8e-3), a particle
        // stressed to 100 E: its neighbours' strain increment in one
        // step is far above MAX_STRAIN_INCREMENT
        let prm = params(ShapeKind::UGimp, scheme, 1e-3);
        let (mut grid, mut parts) = block(2, [0.0, 0.0]);
        parts.sxx[5] = 100.0 * 1.0e6;
        // caught at the first step (USL, MUSL) or the second (USF takes
        // the strain from the velocity before the force acts)
        let e = step_patch(&mut grid, &mut parts, &mats, &prm, None)
            .and_then(|_| step_patch(&mut grid, &mut parts, &mats, &prm, None))
            .unwrap_err();
        assert_eq!(e.status, Status::Unstable, "{scheme:?}: {}", e.msg);
        assert!(
            e.msg.contains("strain increment") || e.msg.contains("inverted"),
            "{}",
            e.msg
        );
        // the same particle at 1e-3 E steps normally
        let (mut grid, mut parts) = block(2, [0.0, 0.0]);
        parts.sxx[5] = 1e-3 * 1.0e6;
        let st = step_patch(&mut grid, &mut parts, &mats, &prm, None).unwrap();
        assert!(st.first_runaway.is_none());
    }
}

#[test]
fn last_pass_notes_exactly_the_particles_leaving_the_patch_cells() {
    // Own cells [2, 6)^2, one ghost cell; the block fills them, 2x2
    // particles per cell, and translates rigidly by 0.6 h upwards: the top
    // particle row (0.75 h into the top cell) leaves the cells, the row
    // below (0.25 h) stays.
    let (n, h, dt) = (4i64, 0.1, 1e-3);
    let v = 0.6 * h / dt;
    for shape in SHAPES {
        for scheme in SCHEMES {
            let mut grid = Grid::new([0.0, 0.0], h, [2, 2], [2 + n, 2 + n], 1).unwrap();
            let (_, mut parts) = block(n, [0.0, v]);
            let prm = params(shape, scheme, dt);
            let st = step_patch(&mut grid, &mut parts, &[MAT.params()], &prm, None).unwrap();
            let np = parts.len();
            let row = 2 * n as usize;
            assert_eq!(
                st.leaving,
                Some((np - row, np - 1)),
                "{shape:?} {scheme:?}: the top row only"
            );
            let (a, b) = st.leaving.unwrap();
            for p in 0..np {
                let c = [
                    (parts.x[p] / h).floor() as i64,
                    (parts.y[p] / h).floor() as i64,
                ];
                let inside = (2..2 + n).contains(&c[0]) && (2..2 + n).contains(&c[1]);
                assert_eq!(
                    inside,
                    !(a..=b).contains(&p),
                    "{shape:?} {scheme:?} slot {p}"
                );
            }
        }
    }
}

/// The three laws (linear elastic, Neo-Hookean, J2 with linear hardening)
/// on one block's worth of constants.
fn three_laws() -> [Material; 3] {
    [
        MAT,
        Material::NeoHookean {
            e: 1.0e6,
            nu: 0.3,
            rho: 1000.0,
        },
        Material::J2 {
            e: 1.0e6,
            nu: 0.3,
            rho: 1000.0,
            hardening: crate::material::Hardening::Linear {
                sigma_y: 1.0e3,
                h: 0.0,
            },
        },
    ]
}

#[test]
fn the_last_pass_gives_the_stable_step_of_the_new_state_bit_for_bit() {
    // The step's own dt_cfl1 (h / max(c + |v|) over the last pass) must be
    // exactly what a separate pass over the new state computes
    // (min h / (c + |v|)): the simulation keeps it instead of recomputing
    // it, and a restarted run (which recomputes it) must choose the same
    // step. A block with a random velocity field (so J and |v| vary), every
    // law, shape and scheme, several steps.
    for law in three_laws() {
        let mats = [law.params()];
        for shape in SHAPES {
            for scheme in SCHEMES {
                let (mut grid, mut parts) = block(4, [0.0, 0.0]);
                let mut r = Lcg(11);
                for p in 0..parts.len() {
                    parts.vx[p] = 0.5 * (r.next() - 0.5);
                    parts.vy[p] = 0.5 * (r.next() - 0.5);
                }
                let prm = params(shape, scheme, 2e-4);
                for step in 0..6 {
                    let st = step_patch(&mut grid, &mut parts, &mats, &prm, None).unwrap();
                    let again = stable_dt_cfl1(&parts, &mats, grid.h);
                    assert_eq!(
                        st.dt_cfl1.to_bits(),
                        again.to_bits(),
                        "{law:?} {shape:?} {scheme:?} step {step}: {} vs {again}",
                        st.dt_cfl1
                    );
                }
            }
        }
    }
}

#[test]
fn the_stable_step_is_the_smallest_per_particle_step_on_every_instruction_set() {
    // `stable_dt_cfl1` takes `h / max(c + |v|)` in lanes, with the law's
    // branch out of the loop for one material: it must be bitwise the
    // smallest `h / (c + |v|)` over the particles, with any number of
    // particles (a partial last lane group), one or two materials, every
    // law, and every instruction set the CPU has.
    let laws = three_laws();
    let h = 0.1;
    let mut r = Lcg(5);
    for n in [0usize, 1, 7, 8, 37, 64] {
        let (_, mut parts) = block(4, [0.0, 0.0]);
        let gone: Vec<usize> = (n.min(parts.len())..parts.len()).collect();
        parts.remove_sorted(&gone);
        for p in 0..parts.len() {
            parts.vx[p] = r.next() - 0.5;
            parts.vy[p] = r.next() - 0.5;
            parts.fxx[p] = 0.8 + 0.4 * r.next();
            parts.fyy[p] = 0.8 + 0.4 * r.next();
            parts.material[p] = (p % 2) as u32;
        }
        for law in laws {
            for two in [false, true] {
                let mut mats = vec![law.params()];
                if two {
                    mats.push(laws[0].params());
                } else {
                    parts.material.iter_mut().for_each(|m| *m = 0);
                }
                let want = (0..parts.len())
                    .map(|p| {
                        let mp = &mats[parts.material[p] as usize];
                        let j = parts.fxx[p] * parts.fyy[p] - parts.fxy[p] * parts.fyx[p];
                        let v2 = parts.vx[p] * parts.vx[p] + parts.vy[p] * parts.vy[p];
                        h / (mp.p_wave_speed(j) + v2.sqrt())
                    })
                    .fold(f64::INFINITY, f64::min);
                for cap in [isa::Isa::Base, isa::Isa::Avx2, isa::Isa::Avx512] {
                    let old = isa::set_cap(cap);
                    let got = stable_dt_cfl1(&parts, &mats, h);
                    isa::set_cap(old);
                    assert_eq!(
                        got.to_bits(),
                        want.to_bits(),
                        "n {n}, {law:?}, two {two}, {cap:?}: {got} vs {want}"
                    );
                }
            }
        }
    }
}

/// A J2 material that stays elastic under the small strains of the tests
/// below, and the linear elastic one with the same constants.
fn j2_and_elastic() -> (Vec<MatParams>, Vec<MatParams>) {
    let j2 = Material::J2 {
        e: 1.0e6,
        nu: 0.25,
        rho: 1000.0,
        hardening: crate::material::Hardening::Linear {
            sigma_y: 1.0e9,
            h: 0.0,
        },
    };
    (vec![j2.params()], vec![MAT.params()])
}

/// Sets both grid velocities of every node (also the empty ones) to the
/// affine field `v = A x + v0`.
fn affine_velocity(grid: &mut Grid, a: [[f64; 2]; 2], v0: [f64; 2]) {
    for j in 0..grid.n[1] {
        for i in 0..grid.n[0] {
            let [x, y] = grid.node_position(grid.lo[0] + i as i64, grid.lo[1] + j as i64);
            let vx = a[0][0] * x + a[0][1] * y + v0[0];
            let vy = a[1][0] * x + a[1][1] * y + v0[1];
            grid.vel[j * grid.n[0] + i] = Node4([vx, vy, vx, vy]);
        }
    }
}

#[test]
fn nodal_dilatation_is_exact_for_an_affine_flow_up_to_the_free_surface() {
    // A uniform dilatation is left as it is, at the particles of the block's
    // edges too (their outer nodes carry part of a cell's material only):
    // the average sees the particles that are there, not the empty nodes.
    let (j2, el) = j2_and_elastic();
    let a = [[0.3, -0.7], [0.45, -0.1]];
    for shape in SHAPES {
        for from_v0 in [true, false] {
            let (mut grid, parts) = block(3, [0.0, 0.0]);
            affine_velocity(&mut grid, a, [0.2, -0.4]);
            let prm = params(shape, Scheme::Musl, 1e-3);
            nodal_dilatation(&mut grid, &parts, &j2, &prm, from_v0).unwrap();
            normalise_dilatation(&mut grid);
            let mut used = 0;
            for d in grid.dil.iter() {
                if d[1] > 0.0 {
                    used += 1;
                    assert!((d[0] - 0.2).abs() < 1e-13, "{shape:?}: nodal mean {}", d[0]);
                } else {
                    assert_eq!(d[0], 0.0);
                }
            }
            // 6 x 6 particles in 3 x 3 cells touch at least the 4 x 4 nodes
            assert!(used >= 16, "{shape:?}: {used} nodes");
            // The strain pass gives the J2 particles the F of the elastic law.
            let pass = if from_v0 {
                G2pPass::MuslPositionStrain
            } else {
                G2pPass::UslAll
            };
            let (mut pj, mut pe) = (parts.clone(), parts.clone());
            g2p(&grid, &mut pj, &j2, &prm, pass);
            g2p(&grid, &mut pe, &el, &prm, pass);
            for p in 0..parts.len() {
                for (u, v) in [
                    (pj.fxx[p], pe.fxx[p]),
                    (pj.fxy[p], pe.fxy[p]),
                    (pj.fyx[p], pe.fyx[p]),
                    (pj.fyy[p], pe.fyy[p]),
                ] {
                    assert!(
                        (u - v).abs() < 1e-15,
                        "{shape:?}: particle {p}: F {u} vs {v}"
                    );
                }
                assert!((pj.sxx[p] - pe.sxx[p]).abs() < 1e-6, "{shape:?}: stress");
            }
        }
    }
}

#[test]
fn nodal_dilatation_smooths_a_checkerboard_and_keeps_the_volume_rate() {
    // The hourglass mode (nodal velocities alternating in sign from node
    // to node) gives each particle a large dilatation of alternating sign:
    // the volumetric locking mode. On top of a uniform dilatation of 0.5,
    // the nodal average removes 90 % of the mode (what is left comes from
    // the nodes at the block's edges), and keeps the total volume rate
    // Σ V_p tr L_p exactly (Σ_i S_ip = 1).
    let (j2, el) = j2_and_elastic();
    let (mut grid, parts) = block(4, [0.0, 0.0]);
    let a = [[0.3, 0.0], [0.0, 0.2]];
    affine_velocity(&mut grid, a, [0.0, 0.0]);
    for j in 0..grid.n[1] {
        for i in 0..grid.n[0] {
            let s = if (i + j) % 2 == 0 { 1.0 } else { -1.0 };
            for c in 0..4 {
                grid.vel[j * grid.n[0] + i].0[c] += s;
            }
        }
    }
    let dt = 1e-6;
    for shape in [ShapeKind::UGimp, ShapeKind::CpGimp] {
        let prm = params(shape, Scheme::Musl, dt);
        nodal_dilatation(&mut grid, &parts, &j2, &prm, true).unwrap();
        normalise_dilatation(&mut grid);
        let (mut pj, mut pe) = (parts.clone(), parts.clone());
        g2p(&grid, &mut pj, &j2, &prm, G2pPass::MuslPositionStrain);
        g2p(&grid, &mut pe, &el, &prm, G2pPass::MuslPositionStrain);
        // F was I: tr L = (F_xx + F_yy - 2) / dt.
        let tr = |q: &Particles, p: usize| (q.fxx[p] + q.fyy[p] - 2.0) / dt;
        let (mut abs_j, mut abs_e, mut vol_j, mut vol_e, mut vol) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for p in 0..parts.len() {
            let v = parts.vol0[p];
            abs_j += v * (tr(&pj, p) - 0.5).abs();
            abs_e += v * (tr(&pe, p) - 0.5).abs();
            vol_j += v * tr(&pj, p);
            vol_e += v * tr(&pe, p);
            vol += v;
        }
        // 16 cells of 0.01 (the block's volume) at |div - 0.5| = 10
        assert!(
            abs_e > 9.0 * vol,
            "{shape:?}: the mode's dilatation {abs_e}"
        );
        assert!(
            abs_j < 0.15 * abs_e,
            "{shape:?}: smoothed {abs_j} vs own {abs_e}"
        );
        assert!(
            (vol_j - 0.5 * vol).abs() < 1e-6 * vol && (vol_j - vol_e).abs() < 1e-9 * vol,
            "{shape:?}: volume rate {vol_j} vs {vol_e} (uniform part {})",
            0.5 * vol
        );
    }
}

#[test]
fn elastic_tables_take_no_nodal_dilatation() {
    let (j2, el) = j2_and_elastic();
    assert!(needs_nodal_dilatation(&j2));
    assert!(!needs_nodal_dilatation(&el));
    let (mut grid, mut parts) = block(3, [1.0, 0.5]);
    let prm = params(ShapeKind::UGimp, Scheme::Musl, 1e-4);
    step_patch(&mut grid, &mut parts, &el, &prm, None).unwrap();
    assert!(
        grid.dil.is_empty(),
        "an elastic step allocated the dilatation"
    );
    step_patch(&mut grid, &mut parts, &j2, &prm, None).unwrap();
    assert_eq!(grid.dil.len(), grid.len());
}

/// The block of [`block`] (4 x 4 cells in a grid of 8 x 8: free edges on
/// every side, where nodes see particles on one side only) with jittered
/// positions, and for cpGIMP half-lengths from a varied stretch.
fn apic_block(shape: ShapeKind, seed: u64) -> (Grid, Particles) {
    let (grid, mut parts) = block(4, [0.0, 0.0]);
    let mut r = Lcg(seed);
    for p in 0..parts.len() {
        parts.x[p] += 0.045 * (r.next() - 0.5);
        parts.y[p] += 0.045 * (r.next() - 0.5);
        if shape == ShapeKind::CpGimp {
            parts.fxx[p] = 0.6 + 0.8 * r.next();
            parts.fyy[p] = 0.6 + 0.8 * r.next();
            let (lx, ly) = crate::shape::cpgimp_half_lengths(
                parts.lpx0[p],
                parts.lpy0[p],
                [parts.fxx[p], parts.fxy[p], parts.fyx[p], parts.fyy[p]],
                grid.h,
            );
            parts.lpx[p] = lx;
            parts.lpy[p] = ly;
        }
    }
    (grid, parts)
}

/// APIC: a particle velocity field `v = a + A x` with `C = A` is mapped to
/// the nodes exactly (every node with mass, the block's edge nodes
/// included), and back to the particles exactly (`v` and `C`), for every
/// shape, up to round-off. The FLIP/PIC transfer of the same field misses
/// at the edges by a fraction of `|A| h`.
#[test]
fn apic_reproduces_affine_velocity_fields_exactly() {
    let (a0, a) = ([0.3, -0.2], [[0.5, -1.3], [0.9, -0.4]]);
    let field = |x: f64, y: f64| {
        [
            a0[0] + a[0][0] * x + a[0][1] * y,
            a0[1] + a[1][0] * x + a[1][1] * y,
        ]
    };
    let mats = [MAT.params()];
    for shape in SHAPES {
        for transfer in [Transfer::Apic, Transfer::Flip] {
            let (mut grid, mut parts) = apic_block(shape, 11);
            for p in 0..parts.len() {
                let v = field(parts.x[p], parts.y[p]);
                parts.vx[p] = v[0];
                parts.vy[p] = v[1];
                parts.cxx[p] = a[0][0];
                parts.cxy[p] = a[0][1];
                parts.cyx[p] = a[1][0];
                parts.cyy[p] = a[1][1];
            }
            let mut prm = params(shape, Scheme::Musl, 1e-4);
            prm.transfer = transfer;
            prm.flip = 0.0;
            grid.reset();
            p2g(&mut grid, &parts, &prm, None, (true, true, false)).unwrap();
            grid_update(&mut grid, prm.dt, &prm.boundary);
            let mut node_err = 0.0f64;
            for j in 0..grid.n[1] {
                for i in 0..grid.n[0] {
                    let k = j * grid.n[0] + i;
                    if grid.mass[k] == 0.0 {
                        continue;
                    }
                    let xi = grid.origin[0] + (grid.lo[0] + i as i64) as f64 * grid.h;
                    let yi = grid.origin[1] + (grid.lo[1] + j as i64) as f64 * grid.h;
                    let v = field(xi, yi);
                    let g = grid.vel[k].0;
                    node_err = node_err.max((g[0] - v[0]).abs().max((g[1] - v[1]).abs()));
                }
            }
            let st = g2p(&grid, &mut parts, &mats, &prm, G2pPass::MuslVelocity);
            st.to_result(&parts).unwrap();
            let (mut v_err, mut c_err) = (0.0f64, 0.0f64);
            for p in 0..parts.len() {
                let v = field(parts.x[p], parts.y[p]);
                v_err = v_err.max((parts.vx[p] - v[0]).abs().max((parts.vy[p] - v[1]).abs()));
                let c = [parts.cxx[p], parts.cxy[p], parts.cyx[p], parts.cyy[p]];
                let e = [a[0][0], a[0][1], a[1][0], a[1][1]];
                for d in 0..4 {
                    c_err = c_err.max((c[d] - e[d]).abs());
                }
            }
            if transfer == Transfer::Apic {
                assert!(node_err < 1e-14, "{shape:?}: nodes off by {node_err:e}");
                assert!(v_err < 1e-14, "{shape:?}: particle v off by {v_err:e}");
                assert!(c_err < 1e-12, "{shape:?}: C off by {c_err:e}");
            } else {
                // The contrast: PIC averages miss the field at the edges.
                assert!(
                    node_err > 1e-3,
                    "{shape:?}: FLIP/PIC nodes off by {node_err:e}"
                );
            }
        }
    }
}

/// The APIC angular momentum about the origin, `Σ m (x × v + ε:(C D))`,
/// with `D` the second moments of each particle's weights.
fn apic_angular_momentum(parts: &Particles, shape: ShapeKind, h: f64) -> f64 {
    use crate::shape::{GimpShape, MpmShape, Shape1D};
    let moment = |x: f64, l: f64| {
        let w = match shape {
            ShapeKind::Mpm => MpmShape::eval(x / h, l / h),
            _ => GimpShape::eval(x / h, l / h),
        };
        (0..3)
            .map(|a| w.w[a] * ((w.base + a as i64) as f64 * h - x).powi(2))
            .sum::<f64>()
    };
    (0..parts.len())
        .map(|p| {
            let dxx = moment(parts.x[p], parts.lpx[p]);
            let dyy = moment(parts.y[p], parts.lpy[p]);
            // ε:(C D) = (C D)_yx − (C D)_xy with D diagonal.
            let spin = parts.cyx[p] * dxx - parts.cxy[p] * dyy;
            parts.mass[p] * (parts.x[p] * parts.vy[p] - parts.y[p] * parts.vx[p] + spin)
        })
        .sum()
}

/// APIC conserves the angular momentum in each transfer (every shape: uGIMP
/// and cpGIMP, whose `C` is `B D^{-1}`, and MPM, whose gradient form equals
/// it): random particle velocities and matrices, P2G
/// gives the grid `Σ x_i × m_i v_i` equal to the particles' `Σ m (x × v +
/// ε:(C D))`, and G2P at the same positions gives it back, to round-off.
#[test]
fn apic_transfers_conserve_angular_momentum() {
    let mats = [MAT.params()];
    for shape in SHAPES {
        let (mut grid, mut parts) = apic_block(shape, 5);
        let mut r = Lcg(17);
        for p in 0..parts.len() {
            parts.vx[p] = r.next() - 0.5;
            parts.vy[p] = r.next() - 0.5;
            parts.cxx[p] = 10.0 * (r.next() - 0.5);
            parts.cxy[p] = 10.0 * (r.next() - 0.5);
            parts.cyx[p] = 10.0 * (r.next() - 0.5);
            parts.cyy[p] = 10.0 * (r.next() - 0.5);
        }
        let mut prm = params(shape, Scheme::Musl, 1e-4);
        prm.transfer = Transfer::Apic;
        let l0 = apic_angular_momentum(&parts, shape, grid.h);
        grid.reset();
        p2g(&mut grid, &parts, &prm, None, (true, true, false)).unwrap();
        grid_update(&mut grid, prm.dt, &prm.boundary);
        let mut lg = 0.0;
        // Scale: Σ m |x| |v| (the sums' round-off is relative to it).
        let scale: f64 = (0..parts.len())
            .map(|p| parts.mass[p] * parts.x[p].hypot(parts.y[p]) * parts.vx[p].hypot(parts.vy[p]))
            .sum();
        for j in 0..grid.n[1] {
            for i in 0..grid.n[0] {
                let k = j * grid.n[0] + i;
                let xi = (grid.lo[0] + i as i64) as f64 * grid.h;
                let yi = (grid.lo[1] + j as i64) as f64 * grid.h;
                let [px, py, _, _] = grid.mom_force[k].0;
                lg += xi * py - yi * px;
            }
        }
        let st = g2p(&grid, &mut parts, &mats, &prm, G2pPass::MuslVelocity);
        st.to_result(&parts).unwrap();
        let l1 = apic_angular_momentum(&parts, shape, grid.h);
        assert!(
            (lg - l0).abs() < 1e-14 * scale,
            "{shape:?}: P2G changed L by {:e} of {scale:e}",
            lg - l0
        );
        assert!(
            (l1 - lg).abs() < 1e-14 * scale,
            "{shape:?}: G2P changed L by {:e} of {scale:e}",
            l1 - lg
        );
        // Without the affine part the transfers lose most of it (the
        // matrices hold much of the particles' angular momentum here).
        let l_plain: f64 = (0..parts.len())
            .map(|p| parts.mass[p] * (parts.x[p] * parts.vy[p] - parts.y[p] * parts.vx[p]))
            .sum();
        assert!((l_plain - l1).abs() > 1e-6 * scale);
    }
}

/// XPIC(m) on one patch against the same filter formed with dense
/// matrices: `v_p ← (I − (I − A)^m) v_p` with `A = S S⁺` (`S_pi` the uGIMP
/// weights, `S⁺_ip = m_p S_pi / m_i`), for random particle velocities; the
/// kernel forms it on the grid as `S v*` (see `super::xpic`).
#[test]
// Dense matrices are indexed by particle and node on purpose.
#[allow(clippy::needless_range_loop)]
fn xpic_matches_the_dense_filter() {
    use crate::shape::{GimpShape, Shape1D};
    let (mut grid, mut parts) = block(3, [0.0, 0.0]);
    let mut rng = Lcg(7);
    for p in 0..parts.len() {
        parts.vx[p] = rng.next() - 0.5;
        parts.vy[p] = rng.next() - 0.5;
    }
    let prm = params(ShapeKind::UGimp, Scheme::Musl, 1e-3);
    let (np, nn, h) = (parts.len(), grid.len(), grid.h);
    let (nx, lo) = (grid.n[0], grid.lo);
    // Dense S (np x nn) and the nodal masses.
    let mut s = vec![vec![0.0; nn]; np];
    let mut mi = vec![0.0; nn];
    for p in 0..np {
        let wx = GimpShape::eval(parts.x[p] / h, parts.lpx[p] / h);
        let wy = GimpShape::eval(parts.y[p] / h, parts.lpy[p] / h);
        for b in 0..3 {
            for a in 0..3 {
                let k = (wy.base + b as i64 - lo[1]) as usize * nx
                    + (wx.base + a as i64 - lo[0]) as usize;
                s[p][k] += wx.w[a] * wy.w[b];
                mi[k] += parts.mass[p] * wx.w[a] * wy.w[b];
            }
        }
    }
    let to_grid = |v: &[f64]| -> Vec<f64> {
        let mut g = vec![0.0; nn];
        for p in 0..np {
            for k in 0..nn {
                g[k] += parts.mass[p] * s[p][k] * v[p];
            }
        }
        (0..nn)
            .map(|k| if mi[k] > 0.0 { g[k] / mi[k] } else { 0.0 })
            .collect()
    };
    let to_parts = |g: &[f64]| -> Vec<f64> {
        (0..np)
            .map(|p| (0..nn).map(|k| s[p][k] * g[k]).sum())
            .collect()
    };
    for order in [1u32, 2, 3, 6] {
        grid.reset();
        p2g(&mut grid, &parts, &prm, None, (true, true, false)).unwrap();
        grid_velocity(&mut grid, &PatchBoundary::default());
        let v0 = grid.vel.clone();
        xpic::xpic_start(&mut grid).unwrap();
        for _ in 1..order {
            xpic::xpic_scatter(
                &mut grid,
                &parts,
                ShapeKind::UGimp,
                crate::mode::ModeKind::PlaneStrain,
            )
            .unwrap();
            xpic::xpic_next(&mut grid, &PatchBoundary::default());
        }
        xpic::xpic_finish(&mut grid, 0.0);
        for (c, vp) in [(vl::V0X, &parts.vx), (vl::V0Y, &parts.vy)] {
            // Reference: v − (I − A)^m v.
            let mut t = vp.to_vec();
            for _ in 0..order {
                let at = to_parts(&to_grid(&t));
                for p in 0..np {
                    t[p] -= at[p];
                }
            }
            let want: Vec<f64> = (0..np).map(|p| vp[p] - t[p]).collect();
            // The kernel: S v* with v* = v0 − d.
            let vstar: Vec<f64> = (0..nn).map(|k| v0[k].0[c] - grid.vel[k].0[c]).collect();
            let got = to_parts(&vstar);
            let err = (0..np)
                .map(|p| (got[p] - want[p]).abs())
                .fold(0.0, f64::max);
            assert!(
                err < 1e-12,
                "order {order}, lane {c}: max difference {err:e}"
            );
        }
    }
}
