//! One output time of a simulation, for viewing: the particle fields and the
//! grid layout in one HDF5 file, written collectively (every rank writes its
//! own rows of each dataset through MPI-IO).
//!
//! Each particle appears once, on the level that owns it: the copies a level
//! keeps to couple with its neighbours are not written. File layout (all
//! datasets have one row per particle, in rank order, then each rank's
//! level, patch and slot order):
//!
//! | path | type | shape | content |
//! |---|---|---|---|
//! | `/particles/position` | f64 | n × 2 | x, y |
//! | `/particles/velocity` | f64 | n × 3 | vx, vy, 0 (3 columns so viewers draw vectors) |
//! | `/particles/stress` | f64 | n × 4 | Cauchy xx, yy, xy, zz |
//! | `/particles/strain` | f64 | n × 4 | Green–Lagrange xx, yy, xy, zz (zz = 0 in plane strain) |
//! | `/particles/half_length` | f64 | n × 2 | current lpx, lpy |
//! | `/particles/mass` | f64 | n | mass per thickness |
//! | `/particles/contact_pressure` | f64 | n | contact pressure after the last step (0 away from indenters) |
//! | `/particles/plastic_strain` | f64 | n | equivalent plastic strain (0 for elastic laws) |
//! | `/particles/affine` | f64 | n × 4 | the APIC matrix C: xx, xy, yx, yy (only with the APIC transfer) |
//! | `/particles/hoop_stretch` | f64 | n | the hoop stretch F_θθ (only in axisymmetry) |
//! | `/particles/level`, `patch`, `rank` | i32 | n | where the particle lives |
//! | `/particles/id` | i64 | n | global id |
//! | `/grid/level_<l>/boxes`, `patches` | i64 | m × 4 | `lo_i, lo_j, hi_i, hi_j` (cells of level l, half-open) |
//! | `/grid/level_<l>/owner` | i32 | patches | owner rank of each patch |
//! | `/grid/level_<l>/patch_particles` | i64 | patches | particles owned by each patch |
//!
//! Root attributes: `time`, `step`, `num_particles`, `num_levels`,
//! `num_ranks`, `thickness`; `/grid` has `origin` and `ncells0`;
//! `/grid/level_<l>` has `h`, `patch_size`, `domain`.

use super::format::{self, FileKind};
use super::h5::{Attributes, File};
use super::xdmf::{DataRef, Snapshot, XdmfAttribute};
use crate::error::{Error, Result, Status};
use crate::geom::IBox;
use crate::kernel::Transfer;
use crate::particles::{Particles, OWNED};
use crate::sim::{Field, Simulation};
use std::path::Path;

/// The XDMF description of an output file `file` (a name relative to the
/// XDMF file) holding `n` particles at time `time`: positions as geometry,
/// every other particle dataset as an attribute (`affine` when the file has
/// the APIC matrices, `hoop_stretch` when it has the hoop stretches).
pub fn describe(file: &str, time: f64, n: u64, affine: bool, hoop: bool) -> Snapshot {
    let a = |name: &str, data: DataRef| XdmfAttribute {
        name: name.to_string(),
        data,
    };
    let f = |name: &str, k: u64| {
        let path = format!("/particles/{name}");
        if k == 1 {
            DataRef::new::<f64>(&path, &[n])
        } else {
            DataRef::new::<f64>(&path, &[n, k])
        }
    };
    let mut attributes = vec![
        a("velocity", f("velocity", 3)),
        a("stress", f("stress", 4)),
        a("strain", f("strain", 4)),
        a("half_length", f("half_length", 2)),
        a("mass", f("mass", 1)),
        a("contact_pressure", f("contact_pressure", 1)),
        a("plastic_strain", f("plastic_strain", 1)),
    ];
    if affine {
        attributes.push(a("affine", f("affine", 4)));
    }
    if hoop {
        attributes.push(a("hoop_stretch", f("hoop_stretch", 1)));
    }
    attributes.extend([
        a("level", DataRef::new::<i32>("/particles/level", &[n])),
        a("patch", DataRef::new::<i32>("/particles/patch", &[n])),
        a("rank", DataRef::new::<i32>("/particles/rank", &[n])),
        a("id", DataRef::new::<i64>("/particles/id", &[n])),
    ]);
    Snapshot {
        time,
        file: file.to_string(),
        n,
        geometry: f("position", 2),
        attributes,
    }
}

/// The slots of the particles `p` owns (not copies from another level).
pub(crate) fn owned(p: &Particles) -> impl Iterator<Item = usize> + '_ {
    p.copy
        .iter()
        .enumerate()
        .filter(|(_, &c)| c == OWNED)
        .map(|(i, _)| i)
}

/// Rows `lo_i, lo_j, hi_i, hi_j` of boxes, flattened.
pub(crate) fn box_rows(boxes: &[IBox]) -> Vec<i64> {
    boxes
        .iter()
        .flat_map(|b| [b.lo[0], b.lo[1], b.hi[0], b.hi[1]])
        .collect()
}

/// Rank 0's rows, nothing elsewhere (for datasets every rank knows whole).
fn root_only<T: Clone>(comm_rank: i32, v: Vec<T>) -> Vec<T> {
    if comm_rank == 0 {
        v
    } else {
        Vec::new()
    }
}

/// Writes the output file of the current state of `sim` at `path` (created
/// or truncated; not atomic by itself, see [`super::series`]) and returns its
/// XDMF description, naming the file as `name`. Collective.
pub fn write(sim: &Simulation, path: &Path, name: &str) -> Result<Snapshot> {
    let comm = sim.comm();
    let rank = comm.rank();
    // Where each local owned particle lives, in the order of
    // `Simulation::gather` (levels, then local patches, then slots).
    let mut level = Vec::new();
    let mut patch = Vec::new();
    let mut id = Vec::new();
    for lv in sim.levels() {
        for p in &lv.local {
            for i in owned(&p.parts) {
                level.push(lv.l as i32);
                patch.push(p.k as i32);
                id.push(p.parts.id[i] as i64);
            }
        }
    }
    let n = id.len();
    let mut buf = Vec::new();
    let mut field = |f: Field| {
        sim.gather(f, &mut buf);
        buf.clone()
    };
    let position = field(Field::Position);
    let vel2 = field(Field::Velocity);
    let stress = field(Field::Stress);
    let strain3 = field(Field::Strain);
    let hoop = field(Field::HoopStretch);
    let half = field(Field::HalfLength);
    let mass = field(Field::Mass);
    let pressure = field(Field::ContactPressure);
    let plastic_strain = field(Field::PlasticStrain);
    // The APIC matrices mean something only under that transfer (under
    // FLIP/PIC the particles carry none).
    let affine = (sim.run().transfer == Transfer::Apic).then(|| field(Field::Affine));
    if position.len() != 2 * n || mass.len() != n {
        return Err(Error::new(
            Status::Internal,
            format!(
                "output: {} particle positions for {n} particles in the patches",
                position.len() / 2
            ),
        ));
    }
    let velocity: Vec<f64> = vel2
        .chunks_exact(2)
        .flat_map(|v| [v[0], v[1], 0.0])
        .collect();
    // The fourth component: the out-of-plane Green–Lagrange strain, E_θθ
    // in axisymmetry (F_zz = 1 gives exactly 0 in plane strain).
    let strain: Vec<f64> = strain3
        .chunks_exact(3)
        .zip(&hoop)
        .flat_map(|(e, f)| [e[0], e[1], e[2], 0.5 * (f * f - 1.0)])
        .collect();

    let f = format::create(comm, path, FileKind::Output)?;
    let g = f.create_group("/particles")?;
    let slab = g.write_2d("position", &position, 2)?;
    g.write_2d("velocity", &velocity, 3)?;
    g.write_2d("stress", &stress, 4)?;
    g.write_2d("strain", &strain, 4)?;
    g.write_2d("half_length", &half, 2)?;
    g.write("mass", &mass)?;
    g.write("contact_pressure", &pressure)?;
    g.write("plastic_strain", &plastic_strain)?;
    if let Some(c) = &affine {
        g.write_2d("affine", c, 4)?;
    }
    // F_θθ itself in axisymmetry (in plane strain it is 1 everywhere).
    let axisym = sim.mode() == crate::mode::ModeKind::Axisymmetric;
    if axisym {
        g.write("hoop_stretch", &hoop)?;
    }
    g.write("level", &level)?;
    g.write("patch", &patch)?;
    g.write("rank", &vec![rank; n])?;
    g.write("id", &id)?;
    drop(g);
    let root = f.root()?;
    root.set_attr("time", sim.time())?;
    root.set_attr("step", sim.steps() as i64)?;
    root.set_attr("num_particles", slab.total)?;
    root.set_attr("num_levels", sim.hier().num_levels() as i64)?;
    root.set_attr("num_ranks", comm.size() as i64)?;
    root.set_attr("thickness", sim.thickness())?;
    root.set_attr(
        "geometry",
        match sim.mode() {
            crate::mode::ModeKind::PlaneStrain => 0i32,
            crate::mode::ModeKind::Axisymmetric => 1i32,
        },
    )?;
    drop(root);
    write_grid(sim, &f)?;
    f.close()?;
    Ok(describe(
        name,
        sim.time(),
        slab.total,
        affine.is_some(),
        axisym,
    ))
}

/// The grid layout: per level its boxes, patches, owners and particle counts.
fn write_grid(sim: &Simulation, f: &File) -> Result<()> {
    let comm = sim.comm();
    let rank = comm.rank();
    let g = f.create_group("/grid")?;
    g.set_attr_array("origin", &sim.hier().origin)?;
    g.set_attr_array("ncells0", &sim.hier().ncells0)?;
    g.set_attr("num_levels", sim.hier().num_levels() as i64)?;
    for l in 0..sim.hier().num_levels() {
        let gl = g.create_group(&format!("level_{l}"))?;
        let hl = &sim.hier().levels[l];
        gl.set_attr("h", hl.h)?;
        gl.set_attr_array("patch_size", &hl.patch_size)?;
        let d = sim.hier().domain_box(l);
        gl.set_attr_array("domain", &[d.lo[0], d.lo[1], d.hi[0], d.hi[1]])?;
        gl.write_2d("boxes", &root_only(rank, box_rows(&hl.boxes)), 4)?;
        // The frozen layout when there is one, else the hierarchy's.
        let (patches, owner, counts) = match sim.levels().get(l) {
            Some(lv) => {
                let mut c = vec![0u64; lv.patches.len()];
                for p in &lv.local {
                    c[p.k] = owned(&p.parts).count() as u64;
                }
                comm.sum_u64(&mut c)?;
                (lv.patches.clone(), lv.owner.clone(), c)
            }
            None => {
                let p = sim.hier().patches(l);
                let k = p.len();
                (p, vec![0; k], vec![0; k])
            }
        };
        gl.write_2d("patches", &root_only(rank, box_rows(&patches)), 4)?;
        gl.write("owner", &root_only(rank, owner))?;
        let counts: Vec<i64> = counts.into_iter().map(|c| c as i64).collect();
        gl.write("patch_particles", &root_only(rank, counts))?;
    }
    Ok(())
}
