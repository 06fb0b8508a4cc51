//! Checkpoint and restart: one HDF5 file holding everything a simulation
//! needs to continue exactly as if it had not stopped.
//!
//! The state is: the hierarchy layout, the plane-strain thickness, the
//! materials, the run settings, the indenters and contact options, time, step count, the next free global id,
//! the lost-particle list, per-level patch-crossing counts, and every
//! particle with every field, its level and patch, **in its patch's order**
//! (the step's floating-point sums run over that order, so it is part of the
//! state). Patch owners are not stored: they are recomputed on read and do
//! not change results. Cached quantities (stable step, reference mass, load
//! balance) are recomputed from the state.
//!
//! Continuing from a checkpoint on the same number of ranks is bitwise the
//! uninterrupted run; on another number of ranks it is the run on that
//! number of ranks (within round-off of the nodal sums' association).
//!
//! File layout (format tag `gimlet-checkpoint`):
//!
//! | path | content |
//! |---|---|
//! | `/` attributes | `time`, `steps`, `next_id`, `thickness`, `geometry` (0 plane strain, 1 axisymmetry), `num_ranks` (writer's), `frozen` (whether the layout was frozen), `particle_fields` (comma-separated names) |
//! | `/hierarchy` | attributes `origin`, `ncells0`, `nest_buffer`, `num_levels`; `/hierarchy/level_<l>`: `h`, `patch_size`, `boxes` (flattened `lo_i, lo_j, hi_i, hi_j`) |
//! | `/materials` | attributes `count`, and when non-zero `kind` (0 linear elastic, 1 Neo-Hookean, 2 J2 with linear hardening, 3 J2 with power-law hardening), `e`, `nu`, `rho`, `yield_stress` (σ_y or σ_0), `hardening` (h or n), `ref_strain` (ε_0) (one per material; 0 where a law has no such parameter) |
//! | `/run` | attributes `shape`, `scheme`, `flip`, `transfer` (0 FLIP/PIC, 1 APIC, 2 XPIC), `xpic_order`, `cfl`, `gravity`, `bc`, `t_ramp`, `outflow` |
//! | `/levels/level_<l>` | attribute `crossings` (summed over ranks) |
//! | `/particles` | attribute `count`; datasets `id` (u64), `material`, `level` (i32), `patch` (i64), and one f64 dataset per name of [`Particles::F64_NAMES`] |
//! | `/lost` | attribute `count`; datasets `id` (u64), `x`, `y` (f64), `rank` (i32) |
//! | `/contact` | the indenters and contact options (format version 4; see [`super::checkpoint_contact`]) |
//!
//! Particles are stored in rank order, each rank's by level, patch and
//! slot, so each patch's particles are one contiguous run in patch order.
//!
//! **Integrity** (format version 2 and later; 3 adds the APIC matrix). Every dataset carries an attribute
//! `digest`: the sum (mod 2^64) over its rows of the FNV-1a hash of the row's
//! index and bytes, computed collectively at write (each rank its rows) and
//! checked at read (each rank the rows it reads, summed over ranks), so any
//! change confined to one row, a single flipped bit included, is always
//! detected (FNV-1a maps inputs differing in one byte to different hashes),
//! and rows moved between indices almost surely. The root attribute
//! `settings_digest` is the FNV-1a hash of every setting read back (the
//! layout, materials, run settings, clock, counters, the writer's rank
//! count and the particle field names), checked against them at read. The
//! file's metadata is written in HDF5's 1.8 format or later, whose object
//! headers and superblock carry their own checksums. A file that fails any
//! check is refused with `Io` ("damaged").
//!
//! A checkpoint written before the layout froze (no particle yet) stores
//! zero crossings for every level and round-trips like any other.

use super::atomic::write_atomic;
use super::checkpoint_contact::{self, ContactSetup};
use super::format::{self, FileKind};
use super::h5::H5Type;
use super::h5::{split_even, Attributes, File, Group};
use super::{agree, snapshot::box_rows};
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::fnv::{fnv1a, FNV_OFFSET};
use crate::geom::{Hierarchy, IBox, Level as HLevel};
use crate::kernel::{FaceBc, Ramp, Scheme, Transfer};
use crate::level::Departure;
use crate::material::{Hardening, Material};
use crate::mode::ModeKind;
use crate::particles::{pack_values, Particles};
use crate::records::Restart;
use crate::shape::ShapeKind;
use crate::sim::{Outflow, Restore, RunConfig, Simulation};
use std::path::Path;

/// Most levels a checkpoint may declare (a bound for validation only).
const MAX_LEVELS: i64 = 32;

fn shape_code(s: ShapeKind) -> i32 {
    match s {
        ShapeKind::Mpm => 0,
        ShapeKind::UGimp => 1,
        ShapeKind::CpGimp => 2,
    }
}
fn shape_from(c: i32) -> Option<ShapeKind> {
    [ShapeKind::Mpm, ShapeKind::UGimp, ShapeKind::CpGimp]
        .into_iter()
        .find(|&s| shape_code(s) == c)
}
fn scheme_code(s: Scheme) -> i32 {
    match s {
        Scheme::Usf => 0,
        Scheme::Usl => 1,
        Scheme::Musl => 2,
    }
}
fn scheme_from(c: i32) -> Option<Scheme> {
    [Scheme::Usf, Scheme::Usl, Scheme::Musl]
        .into_iter()
        .find(|&s| scheme_code(s) == c)
}
fn transfer_code(t: Transfer) -> i32 {
    match t {
        Transfer::Flip => 0,
        Transfer::Apic => 1,
        Transfer::Xpic => 2,
    }
}
fn transfer_from(c: i32) -> Option<Transfer> {
    [Transfer::Flip, Transfer::Apic, Transfer::Xpic]
        .into_iter()
        .find(|&t| transfer_code(t) == c)
}
fn bc_code(b: FaceBc) -> i32 {
    match b {
        FaceBc::Free => 0,
        FaceBc::Fixed => 1,
        FaceBc::Roller => 2,
    }
}
fn bc_from(c: i32) -> Option<FaceBc> {
    [FaceBc::Free, FaceBc::Fixed, FaceBc::Roller]
        .into_iter()
        .find(|&b| bc_code(b) == c)
}
fn outflow_code(o: Outflow) -> i32 {
    match o {
        Outflow::Fail => 0,
        Outflow::Remove => 1,
    }
}
fn outflow_from(c: i32) -> Option<Outflow> {
    [Outflow::Fail, Outflow::Remove]
        .into_iter()
        .find(|&o| outflow_code(o) == c)
}
/// Names of the stored material parameters, in the order of
/// [`material_code`].
const MATERIAL_PARAMS: [&str; 6] = ["e", "nu", "rho", "yield_stress", "hardening", "ref_strain"];

/// Material kind code and its parameters `e, nu, rho` and the hardening's
/// (`sigma_y, h, 0` or `sigma_0, n, eps_0`; zeros for the elastic laws).
fn material_code(m: &Material) -> (i32, [f64; 6]) {
    match *m {
        Material::LinearElastic { e, nu, rho } => (0, [e, nu, rho, 0.0, 0.0, 0.0]),
        Material::NeoHookean { e, nu, rho } => (1, [e, nu, rho, 0.0, 0.0, 0.0]),
        Material::J2 {
            e,
            nu,
            rho,
            hardening: Hardening::Linear { sigma_y, h },
        } => (2, [e, nu, rho, sigma_y, h, 0.0]),
        Material::J2 {
            e,
            nu,
            rho,
            hardening: Hardening::Power { sigma_0, n, eps_0 },
        } => (3, [e, nu, rho, sigma_0, n, eps_0]),
    }
}
fn material_from(c: i32, p: [f64; 6]) -> Option<Material> {
    let [e, nu, rho, h1, h2, h3] = p;
    match c {
        0 => Some(Material::LinearElastic { e, nu, rho }),
        1 => Some(Material::NeoHookean { e, nu, rho }),
        2 => Some(Material::J2 {
            e,
            nu,
            rho,
            hardening: Hardening::Linear { sigma_y: h1, h: h2 },
        }),
        3 => Some(Material::J2 {
            e,
            nu,
            rho,
            hardening: Hardening::Power {
                sigma_0: h1,
                n: h2,
                eps_0: h3,
            },
        }),
        _ => None,
    }
}

/// The geometry as stored (attribute `geometry`): 0 plane strain, 1
/// axisymmetry.
fn mode_code(m: ModeKind) -> i32 {
    match m {
        ModeKind::PlaneStrain => 0,
        ModeKind::Axisymmetric => 1,
    }
}

/// The comma-separated particle field names this build stores.
fn field_names() -> String {
    Particles::F64_NAMES.join(",")
}

/// Writes a checkpoint of `sim` to `path`, atomically: the previous file at
/// `path`, if any, is replaced only when the new one is complete. Collective.
pub fn write(sim: &Simulation, path: &Path) -> Result<()> {
    write_atomic(sim.comm(), path, |tmp| write_file(sim, tmp))
}

fn write_file(sim: &Simulation, tmp: &Path) -> Result<()> {
    let comm = sim.comm();
    let lay = layout_of(sim)?;
    let f = format::create_checksummed(comm, tmp, FileKind::Checkpoint)?;
    write_layout(&lay, &f)?;
    write_particles(sim, &f)?;
    {
        let g = f.create_group("/lost")?;
        let id: Vec<u64> = sim.lost().iter().map(|d| d.id).collect();
        let x: Vec<f64> = sim.lost().iter().map(|d| d.x).collect();
        let y: Vec<f64> = sim.lost().iter().map(|d| d.y).collect();
        let slab = write_digested(comm, &g, "id", &id)?;
        write_digested(comm, &g, "x", &x)?;
        write_digested(comm, &g, "y", &y)?;
        write_digested(comm, &g, "rank", &vec![comm.rank(); id.len()])?;
        g.set_attr("count", slab.total)?;
    }
    f.close()
}

/// The bytes of a slice of stored numbers (native byte order).
fn bytes_of<T: H5Type>(v: &[T]) -> &[u8] {
    // SAFETY: every H5Type is a plain number type without padding.
    unsafe { std::slice::from_raw_parts(v.as_ptr() as *const u8, std::mem::size_of_val(v)) }
}

/// The digest contribution of rows `first..first + v.len()` of a 1D
/// dataset: the sum (mod 2^64) of the FNV-1a hash of each row's index and
/// bytes.
fn rows_digest<T: H5Type>(first: u64, v: &[T]) -> u64 {
    bytes_of(v)
        .chunks_exact(std::mem::size_of::<T>())
        .enumerate()
        .fold(0u64, |acc, (i, row)| {
            let h = fnv1a(FNV_OFFSET, &(first + i as u64).to_le_bytes());
            acc.wrapping_add(fnv1a(h, row))
        })
}

/// Writes the 1D dataset `name` (every rank's rows, in rank order) and its
/// `digest` attribute (collective).
fn write_digested<T: H5Type>(
    comm: &Comm,
    g: &Group,
    name: &str,
    local: &[T],
) -> Result<super::h5::Slab> {
    let slab = g.write(name, local)?;
    let mut d = [rows_digest(slab.offset, local)];
    comm.sum_u64(&mut d)?;
    g.dataset(name)?.set_attr("digest", d[0])?;
    Ok(slab)
}

/// Reads rows `off..off + cnt` of the 1D dataset `name` and checks the
/// dataset's digest: over the rows every rank read when `shared` is false
/// (together they read every row once), over this rank's rows when it is
/// true (every rank read all of them). Collective; the same outcome on
/// every rank.
fn read_verified<T: H5Type>(
    comm: &Comm,
    g: &Group,
    name: &str,
    (off, cnt): (u64, u64),
    shared: bool,
    path: &Path,
) -> Result<Vec<T>> {
    let v = g.read_rows::<T>(name, off, cnt)?;
    let mut d = [rows_digest(off, &v)];
    if !shared {
        comm.sum_u64(&mut d)?;
    }
    let stored = g.dataset(name)?.attr::<u64>("digest")?;
    if stored != d[0] {
        return Err(bad(
            path,
            format!(
                "is damaged: dataset '{}/{name}' does not match its stored digest",
                g.path()
            ),
        ));
    }
    Ok(v)
}

/// The settings of `sim` as a checkpoint stores them (collective: the
/// crossings are summed over ranks).
fn layout_of(sim: &Simulation) -> Result<Layout> {
    let h = &sim.hier();
    let mut crossings: Vec<u64> = if sim.levels().is_empty() {
        vec![0; h.num_levels()]
    } else {
        sim.levels().iter().map(|l| l.crossings).collect()
    };
    sim.comm().sum_u64(&mut crossings)?;
    Ok(Layout {
        origin: h.origin,
        ncells0: h.ncells0,
        nest_buffer: h.nest_buffer,
        levels: h.levels.clone(),
        thickness: sim.thickness(),
        mode: sim.mode(),
        materials: sim.materials().to_vec(),
        run: sim.run(),
        time: sim.time(),
        steps: sim.steps(),
        next_id: sim.next_id(),
        crossings,
        frozen: sim.is_frozen(),
        copies_current: sim.copies_current(),
        num_ranks: sim.comm().size() as i64,
        contact: checkpoint_contact::setup_of(sim),
    })
}

/// The FNV-1a hash of every setting of `lay` and the particle field names,
/// in a fixed order.
fn settings_digest(lay: &Layout) -> u64 {
    let mut h = fnv1a(FNV_OFFSET, field_names().as_bytes());
    let mut f = |b: &[u8]| h = fnv1a(h, b);
    let r = |v: f64| v.to_bits().to_le_bytes();
    f(&r(lay.origin[0]));
    f(&r(lay.origin[1]));
    f(&lay.ncells0[0].to_le_bytes());
    f(&lay.ncells0[1].to_le_bytes());
    f(&lay.nest_buffer.to_le_bytes());
    f(&(lay.levels.len() as u64).to_le_bytes());
    for lv in &lay.levels {
        f(&r(lv.h));
        f(&lv.patch_size[0].to_le_bytes());
        f(&lv.patch_size[1].to_le_bytes());
        for v in box_rows(&lv.boxes) {
            f(&v.to_le_bytes());
        }
    }
    f(&r(lay.thickness));
    f(&mode_code(lay.mode).to_le_bytes());
    f(&(lay.materials.len() as u64).to_le_bytes());
    for m in &lay.materials {
        let (k, p) = material_code(m);
        f(&k.to_le_bytes());
        for v in p {
            f(&r(v));
        }
    }
    let run = &lay.run;
    for c in [
        shape_code(run.shape),
        scheme_code(run.scheme),
        outflow_code(run.outflow),
        transfer_code(run.transfer),
    ] {
        f(&c.to_le_bytes());
    }
    // The XPIC order counts while that transfer is set (the digests of
    // checkpoints of the other transfers are as before it existed).
    if run.transfer == Transfer::Xpic {
        f(&run.xpic_order.to_le_bytes());
    }
    for b in run.bc {
        f(&bc_code(b).to_le_bytes());
    }
    for v in [
        run.flip,
        run.cfl,
        run.gravity[0],
        run.gravity[1],
        run.ramp.t_ramp,
        lay.time,
    ] {
        f(&r(v));
    }
    f(&lay.steps.to_le_bytes());
    f(&lay.next_id.to_le_bytes());
    for c in &lay.crossings {
        f(&c.to_le_bytes());
    }
    f(&[u8::from(lay.frozen), u8::from(lay.copies_current)]);
    f(&lay.num_ranks.to_le_bytes());
    checkpoint_contact::digest(h, &lay.contact)
}

fn write_layout(lay: &Layout, f: &File) -> Result<()> {
    let root = f.root()?;
    root.set_attr("time", lay.time)?;
    root.set_attr("steps", lay.steps)?;
    root.set_attr("next_id", lay.next_id)?;
    root.set_attr("thickness", lay.thickness)?;
    root.set_attr("geometry", mode_code(lay.mode))?;
    root.set_attr("num_ranks", lay.num_ranks)?;
    root.set_attr("frozen", i32::from(lay.frozen))?;
    // Whether the copies that couple levels (stored with the other
    // particles) are current; a restart then continues without a fresh
    // synchronisation, exactly like the uninterrupted run.
    root.set_attr("copies_current", i32::from(lay.copies_current))?;
    root.set_attr_str("particle_fields", &field_names())?;
    root.set_attr("settings_digest", settings_digest(lay))?;
    let g = f.create_group("/hierarchy")?;
    g.set_attr_array("origin", &lay.origin)?;
    g.set_attr_array("ncells0", &lay.ncells0)?;
    g.set_attr("nest_buffer", lay.nest_buffer)?;
    g.set_attr("num_levels", lay.levels.len() as i64)?;
    for (l, lv) in lay.levels.iter().enumerate() {
        let gl = g.create_group(&format!("level_{l}"))?;
        gl.set_attr("h", lv.h)?;
        gl.set_attr_array("patch_size", &lv.patch_size)?;
        gl.set_attr_array("boxes", &box_rows(&lv.boxes))?;
    }
    let g = f.create_group("/materials")?;
    g.set_attr("count", lay.materials.len() as i64)?;
    if !lay.materials.is_empty() {
        let coded: Vec<(i32, [f64; 6])> = lay.materials.iter().map(material_code).collect();
        g.set_attr_array("kind", &coded.iter().map(|c| c.0).collect::<Vec<_>>())?;
        for (j, name) in MATERIAL_PARAMS.into_iter().enumerate() {
            g.set_attr_array(name, &coded.iter().map(|c| c.1[j]).collect::<Vec<_>>())?;
        }
    }
    let r = &lay.run;
    let g = f.create_group("/run")?;
    g.set_attr("shape", shape_code(r.shape))?;
    g.set_attr("scheme", scheme_code(r.scheme))?;
    g.set_attr("flip", r.flip)?;
    g.set_attr("transfer", transfer_code(r.transfer))?;
    g.set_attr("xpic_order", r.xpic_order as i32)?;
    g.set_attr("cfl", r.cfl)?;
    g.set_attr_array("gravity", &r.gravity)?;
    g.set_attr_array("bc", &r.bc.map(bc_code))?;
    g.set_attr("t_ramp", r.ramp.t_ramp)?;
    g.set_attr("outflow", outflow_code(r.outflow))?;
    for (l, c) in lay.crossings.iter().enumerate() {
        f.create_group(&format!("/levels/level_{l}"))?
            .set_attr("crossings", *c)?;
    }
    checkpoint_contact::write(f, &lay.contact)
}

fn write_particles(sim: &Simulation, f: &File) -> Result<()> {
    let comm = sim.comm();
    let mut id = Vec::new();
    let mut material = Vec::new();
    let mut level = Vec::new();
    let mut patch = Vec::new();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); Particles::N_F64];
    for lv in sim.levels() {
        for p in &lv.local {
            let n = p.parts.len();
            id.extend_from_slice(&p.parts.id);
            material.extend(p.parts.material.iter().map(|&m| m as i32));
            level.extend(std::iter::repeat(lv.l as i32).take(n));
            patch.extend(std::iter::repeat(p.k as i64).take(n));
            for (c, v) in cols.iter_mut().zip(p.parts.f64_fields()) {
                c.extend_from_slice(v);
            }
        }
    }
    let g = f.create_group("/particles")?;
    let slab = write_digested(comm, &g, "id", &id)?;
    write_digested(comm, &g, "material", &material)?;
    write_digested(comm, &g, "level", &level)?;
    write_digested(comm, &g, "patch", &patch)?;
    for (name, c) in Particles::F64_NAMES.iter().zip(&cols) {
        write_digested(comm, &g, name, c)?;
    }
    g.set_attr("count", slab.total)
}

/// Everything but the particles, as read from a checkpoint.
struct Layout {
    origin: [f64; 2],
    ncells0: [i64; 2],
    nest_buffer: i64,
    levels: Vec<HLevel>,
    thickness: f64,
    mode: ModeKind,
    materials: Vec<Material>,
    run: RunConfig,
    time: f64,
    steps: u64,
    next_id: u64,
    crossings: Vec<u64>,
    frozen: bool,
    copies_current: bool,
    /// The number of ranks that wrote the checkpoint.
    num_ranks: i64,
    /// The indenters and contact options.
    contact: ContactSetup,
}

/// An `Io` error naming the checkpoint.
fn bad(path: &Path, what: String) -> Error {
    Error::new(
        Status::Io,
        format!("checkpoint '{}' {what}", path.display()),
    )
}

fn pair<T: super::h5::H5Type>(g: &Group, name: &str, path: &Path) -> Result<[T; 2]> {
    let v = g.attr_array::<T>(name)?;
    match v[..] {
        [a, b] => Ok([a, b]),
        _ => Err(bad(
            path,
            format!(
                "has {} values in attribute '{name}' where 2 belong",
                v.len()
            ),
        )),
    }
}

fn read_layout(f: &File, path: &Path) -> Result<Layout> {
    let root = f.root()?;
    let names = root.attr_str("particle_fields")?;
    if names != field_names() {
        return Err(bad(
            path,
            format!(
                "stores the particle fields [{names}] but this library has [{}]: it was written by an incompatible build",
                field_names()
            ),
        ));
    }
    let g = f.group("/hierarchy")?;
    let origin = pair::<f64>(&g, "origin", path)?;
    let ncells0 = pair::<i64>(&g, "ncells0", path)?;
    let nest_buffer = g.attr::<i64>("nest_buffer")?;
    let nl = g.attr::<i64>("num_levels")?;
    if !(1..=MAX_LEVELS).contains(&nl) {
        return Err(bad(
            path,
            format!("declares {nl} levels (1 to {MAX_LEVELS} are possible)"),
        ));
    }
    let mut levels = Vec::new();
    for l in 0..nl {
        let gl = f.group(&format!("/hierarchy/level_{l}"))?;
        let h = gl.attr::<f64>("h")?;
        let patch_size = pair::<i64>(&gl, "patch_size", path)?;
        let flat = gl.attr_array::<i64>("boxes")?;
        if flat.len() % 4 != 0 || !(h.is_finite() && h > 0.0) {
            return Err(bad(path, format!("has a damaged layout of level {l}")));
        }
        let boxes: Vec<IBox> = flat
            .chunks_exact(4)
            .map(|b| IBox::new([b[0], b[1]], [b[2], b[3]]))
            .collect();
        levels.push(HLevel {
            h,
            boxes,
            patch_size,
        });
    }
    let thickness = root.attr::<f64>("thickness")?;
    let mode = match root.attr::<i32>("geometry")? {
        0 => ModeKind::PlaneStrain,
        1 => ModeKind::Axisymmetric,
        k => return Err(bad(path, format!("has the unknown geometry {k}"))),
    };
    let g = f.group("/materials")?;
    let nm = g.attr::<i64>("count")?;
    let mut materials = Vec::new();
    if nm > 0 {
        let kind = g.attr_array::<i32>("kind")?;
        let p: Vec<Vec<f64>> = MATERIAL_PARAMS
            .iter()
            .map(|n| g.attr_array::<f64>(n))
            .collect::<Result<_>>()?;
        if kind.len() as i64 != nm || p.iter().any(|v| v.len() as i64 != nm) {
            return Err(bad(
                path,
                format!("has a damaged material table ({nm} materials declared)"),
            ));
        }
        for (i, &k) in kind.iter().enumerate() {
            let m = material_from(k, std::array::from_fn(|j| p[j][i]))
                .ok_or_else(|| bad(path, format!("has material {i} of unknown kind {k}")))?;
            materials.push(m);
        }
    }
    let g = f.group("/run")?;
    let code = |name: &str| g.attr::<i32>(name);
    let unknown = |what: &str, c: i32| bad(path, format!("has an unknown {what} code {c}"));
    let bcs = g.attr_array::<i32>("bc")?;
    if bcs.len() != 4 {
        return Err(bad(
            path,
            format!("has {} face conditions where 4 belong", bcs.len()),
        ));
    }
    let mut bc = [FaceBc::Free; 4];
    for (b, &c) in bc.iter_mut().zip(&bcs) {
        *b = bc_from(c).ok_or_else(|| unknown("face condition", c))?;
    }
    let (sc, sk, oc) = (code("shape")?, code("scheme")?, code("outflow")?);
    let tc = code("transfer")?;
    let run = RunConfig {
        shape: shape_from(sc).ok_or_else(|| unknown("shape", sc))?,
        scheme: scheme_from(sk).ok_or_else(|| unknown("scheme", sk))?,
        flip: g.attr::<f64>("flip")?,
        transfer: transfer_from(tc).ok_or_else(|| unknown("transfer", tc))?,
        // Written since the XPIC transfer exists; older files have the
        // default.
        xpic_order: if g.has_attr("xpic_order")? {
            let o = code("xpic_order")?;
            crate::kernel::xpic::xpic_order(o.into()).map_err(|_| unknown("xpic order", o))?
        } else {
            crate::sim::DEFAULT_XPIC_ORDER
        },
        cfl: g.attr::<f64>("cfl")?,
        gravity: pair::<f64>(&g, "gravity", path)?,
        bc,
        ramp: Ramp {
            t_ramp: g.attr::<f64>("t_ramp")?,
        },
        outflow: outflow_from(oc).ok_or_else(|| unknown("outflow policy", oc))?,
    };
    let crossings = (0..nl)
        .map(|l| {
            f.group(&format!("/levels/level_{l}"))?
                .attr::<u64>("crossings")
        })
        .collect::<Result<Vec<u64>>>()?;
    let lay = Layout {
        origin,
        ncells0,
        nest_buffer,
        levels,
        thickness,
        mode,
        materials,
        run,
        time: root.attr::<f64>("time")?,
        steps: root.attr::<u64>("steps")?,
        next_id: root.attr::<u64>("next_id")?,
        crossings,
        frozen: root.attr::<i32>("frozen")? != 0,
        copies_current: root.attr::<i32>("copies_current")? != 0,
        num_ranks: root.attr::<i64>("num_ranks")?,
        contact: checkpoint_contact::read(f, path)?,
    };
    if root.attr::<u64>("settings_digest")? != settings_digest(&lay) {
        return Err(bad(
            path,
            "is damaged: its settings do not match their stored digest".into(),
        ));
    }
    Ok(lay)
}

/// Checks that the stored hierarchy is one the library could have built:
/// positive patch sizes, levels refining by 2, boxes non-empty and inside
/// the domain.
fn check_hierarchy(lay: &Layout, path: &Path) -> Result<()> {
    let n0 = lay.ncells0;
    if n0[0] < 1 || n0[1] < 1 || n0[0] > 1 << 24 || n0[1] > 1 << 24 {
        return Err(bad(
            path,
            format!("has a domain of {} x {} cells", n0[0], n0[1]),
        ));
    }
    for (l, lv) in lay.levels.iter().enumerate() {
        let f = 1i64 << l;
        let dom = IBox::new([0, 0], [n0[0] * f, n0[1] * f]);
        let ok = lv.patch_size.iter().all(|&p| (1..=1 << 24).contains(&p))
            && !lv.boxes.is_empty()
            && lv
                .boxes
                .iter()
                .all(|b| !b.is_empty() && dom.contains_box(b))
            && (l == 0 || lv.h == lay.levels[l - 1].h / 2.0);
        if !ok {
            return Err(bad(path, format!("has an invalid layout of level {l}")));
        }
    }
    Ok(())
}

/// Builds the simulation of `lay` on `comm`, with its layout frozen when
/// it was and no particles.
fn build(comm: Comm, lay: &Layout, path: &Path) -> Result<Simulation> {
    let h0 = lay.levels[0].h;
    let lx = lay.ncells0[0] as f64 * h0;
    let ly = lay.ncells0[1] as f64 * h0;
    let mut hier = Hierarchy::new(lay.origin[0], lay.origin[1], lx, ly, h0)?;
    if hier.ncells0 != lay.ncells0 {
        return Err(bad(
            path,
            "has a domain that does not tile into its cells".into(),
        ));
    }
    hier.levels = lay.levels.clone();
    hier.nest_buffer = lay.nest_buffer;
    let saved = Restore {
        hier,
        thickness: lay.thickness,
        mode: lay.mode,
        materials: lay.materials.clone(),
        run: lay.run,
        time: lay.time,
        steps: lay.steps,
        next_id: lay.next_id,
        frozen: lay.frozen,
        copies_current: lay.copies_current,
        crossings: lay.crossings.clone(),
    };
    let rejected = |e: Error| {
        bad(
            path,
            format!("holds a setting the library rejects: {}", e.msg),
        )
    };
    let mut sim = Simulation::restore(comm, saved).map_err(rejected)?;
    checkpoint_contact::apply(&mut sim, &lay.contact).map_err(rejected)?;
    Ok(sim)
}

/// Reads the particles of the checkpoint: each rank reads an even share of
/// the rows and sends every particle to the owner of its patch, which
/// appends them to the patch in file order. Collective.
fn read_particles(sim: &mut Simulation, path: &Path) -> Result<()> {
    let (recv, lost) = read_rows(sim, path)?;
    let mut rows: Vec<_> = recv
        .chunks_exact(Restart::BYTES)
        .map(Restart::read)
        .collect();
    // Shares arrive in rank order, which is file order; sort to be sure.
    rows.sort_by_key(|r| r.0);
    for (_, l, k, particle) in rows {
        sim.restore_particle(l, k, particle)?;
    }
    sim.restore_lost(lost);
    Ok(())
}

/// The collective part of [`read_particles`]: each rank reads an even
/// share of the particle rows, checks them and sends each to the owner of
/// its patch; returns the records ([`Restart`]) this rank received and its
/// lost particles.
fn read_rows(sim: &Simulation, path: &Path) -> Result<(Vec<u8>, Vec<Departure>)> {
    let comm = sim.comm();
    let levels = sim.levels();
    let nmat = sim.materials().len() as i64;
    let f = format::open(comm, path, FileKind::Checkpoint)?;
    let g = f.group("/particles")?;
    let n = g.attr::<u64>("count")?;
    for name in ["id", "material", "level", "patch"]
        .into_iter()
        .chain(Particles::F64_NAMES)
    {
        g.check_len(name, n)?;
    }
    let (off, cnt) = split_even(n, comm.rank(), comm.size());
    let rows = (off, cnt);
    let id = read_verified::<u64>(comm, &g, "id", rows, false, path)?;
    let material = read_verified::<i32>(comm, &g, "material", rows, false, path)?;
    let level = read_verified::<i32>(comm, &g, "level", rows, false, path)?;
    let patch = read_verified::<i64>(comm, &g, "patch", rows, false, path)?;
    let cols = Particles::F64_NAMES
        .iter()
        .map(|name| read_verified::<f64>(comm, &g, name, rows, false, path))
        .collect::<Result<Vec<Vec<f64>>>>()?;
    // Validate before anything is sent, so every rank agrees on failure.
    let mut send = vec![Vec::new(); comm.size() as usize];
    let mut problem = None;
    for i in 0..cnt as usize {
        let (l, k, m) = (level[i], patch[i], material[i]);
        let ok = l >= 0
            && (l as usize) < levels.len()
            && k >= 0
            && (k as usize) < levels[l as usize].patches.len()
            && m >= 0
            && (m as i64) < nmat;
        if !ok {
            problem = Some(bad(
                path,
                format!(
                    "has particle row {} with level {l}, patch {k}, material {m} outside the stored layout",
                    off + i as u64
                ),
            ));
            break;
        }
        let particle = pack_values(id[i], m as u32, cols.iter().map(|c| c[i]));
        let (l, k) = (l as usize, k as usize);
        let buf = &mut send[levels[l].owner[k] as usize];
        Restart::write(buf, off + i as u64, l, k, &particle);
    }
    agree(comm, problem.map_or(Ok(()), Err))?;
    let (recv, _) = comm.alltoallv_bytes(&send)?;
    drop(g);
    // The lost particles: back to their rank when the rank count matches,
    // otherwise all to rank 0.
    let g = f.group("/lost")?;
    let nl = g.attr::<u64>("count")?;
    for name in ["id", "x", "y", "rank"] {
        g.check_len(name, nl)?;
    }
    let all = (0, nl);
    let id = read_verified::<u64>(comm, &g, "id", all, true, path)?;
    let x = read_verified::<f64>(comm, &g, "x", all, true, path)?;
    let y = read_verified::<f64>(comm, &g, "y", all, true, path)?;
    let rank = read_verified::<i32>(comm, &g, "rank", all, true, path)?;
    let root = f.root()?;
    let same = root.attr::<i64>("num_ranks")? == comm.size() as i64;
    let me = comm.rank();
    let lost = (0..nl as usize)
        .filter(|&i| if same { rank[i] == me } else { me == 0 })
        .map(|i| Departure {
            id: id[i],
            x: x[i],
            y: y[i],
        })
        .collect();
    drop((g, root));
    f.close()?;
    Ok((recv, lost))
}

/// Reads the checkpoint at `path` into a new simulation on `comm` (which it
/// takes over). Every failure is an `Io` error naming the path and what was
/// wrong (missing, not HDF5, truncated, not a Gimlet checkpoint, another
/// format version, an incompatible build, damaged content), the same on
/// every rank. Collective.
pub fn read(comm: Comm, path: &Path) -> Result<Simulation> {
    let lay = {
        let r = format::open(&comm, path, FileKind::Checkpoint).and_then(|f| {
            let lay = read_layout(&f, path)?;
            f.close()?;
            check_hierarchy(&lay, path)?;
            Ok(lay)
        });
        agree(&comm, r.map_err(|e| as_io(e, path)))?
    };
    // `build` fails the same way on every rank (it only checks the layout).
    let mut sim = build(comm, &lay, path)?;
    let r = read_particles(&mut sim, path).map_err(|e| as_io(e, path));
    agree(sim.comm(), r)?;
    Ok(sim)
}

/// Any failure while reading a checkpoint is an `Io` error that names the
/// file (HDF5 errors already do; others get the path added).
fn as_io(e: Error, path: &Path) -> Error {
    let p = path.display().to_string();
    if e.msg.contains(&p) {
        Error::new(Status::Io, e.msg)
    } else {
        bad(path, format!("cannot be read: {}", e.msg))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::particles::NewParticle;

    #[test]
    fn codes_round_trip() {
        for s in [ShapeKind::Mpm, ShapeKind::UGimp, ShapeKind::CpGimp] {
            assert_eq!(shape_from(shape_code(s)), Some(s));
        }
        for s in [Scheme::Usf, Scheme::Usl, Scheme::Musl] {
            assert_eq!(scheme_from(scheme_code(s)), Some(s));
        }
        for b in [FaceBc::Free, FaceBc::Fixed, FaceBc::Roller] {
            assert_eq!(bc_from(bc_code(b)), Some(b));
        }
        for o in [Outflow::Fail, Outflow::Remove] {
            assert_eq!(outflow_from(outflow_code(o)), Some(o));
        }
        for m in [
            Material::LinearElastic {
                e: 1.0,
                nu: 0.25,
                rho: 3.0,
            },
            Material::NeoHookean {
                e: 2.0,
                nu: 0.3,
                rho: 4.0,
            },
            Material::J2 {
                e: 70e9,
                nu: 0.33,
                rho: 2700.0,
                hardening: Hardening::Linear {
                    sigma_y: 1e8,
                    h: 1e9,
                },
            },
            Material::J2 {
                e: 70e9,
                nu: 0.33,
                rho: 2700.0,
                hardening: Hardening::Power {
                    sigma_0: 1e8,
                    n: 0.1,
                    eps_0: 1e8 / 70e9,
                },
            },
        ] {
            let (c, p) = material_code(&m);
            assert_eq!(material_from(c, p), Some(m));
        }
        assert_eq!(shape_from(7), None);
    }

    /// The stored columns packed by `pack_values` give back the particle
    /// exactly (the layout of `Particles::pack`).
    #[test]
    fn stored_columns_pack_as_the_particles_do() {
        let mut p = Particles::new();
        for i in 0..3u64 {
            p.push(
                &NewParticle {
                    id: 10 + i,
                    x: 0.1 * i as f64,
                    y: 0.3,
                    lpx: 0.25,
                    lpy: 0.125,
                    vx: -1.5,
                    vy: 2.0,
                    mass: 7.0,
                    material: i as u32,
                },
                2.0,
            );
        }
        p.sxy[1] = 1.0 / 3.0;
        let cols: Vec<Vec<f64>> = p.f64_fields().iter().map(|v| v.to_vec()).collect();
        for i in 0..3 {
            let b = pack_values(p.id[i], p.material[i], cols.iter().map(|c| c[i]));
            assert_eq!(p.packed(i), b);
        }
        assert_eq!(field_names().split(',').count(), Particles::N_F64);
    }
}
