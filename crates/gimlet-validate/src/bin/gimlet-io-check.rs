//! MPI check of the `io` layer: run with `mpirun -n 1` and `mpirun -n 2`.
//!
//! Writes distributed datasets (ranks with different counts, some with none),
//! reads them back element by element, writes and validates an XDMF series,
//! checks that foreign, truncated, wrong-kind and wrong-version files are
//! rejected, that a failed atomic write keeps the previous file, the CSV
//! series, and that a checkpoint of a whole simulation reads back with every
//! setting and every particle field in its patch order, and continues
//! bitwise. Prints one line per check; exits 0 only when every check passed.
//!
//! Usage: `gimlet-io-check [work-dir]` (default: a fresh directory under the
//! system temporary directory, removed on success).

use gimlet::comm::Comm;
use gimlet::error::{Error, Status};
use gimlet::io::atomic::write_atomic;
use gimlet::io::checkpoint;
use gimlet::io::csv::CsvSeries;
use gimlet::io::format::{self, FileKind, FORMAT_VERSION};
use gimlet::io::h5::{split_even, Attributes, File, H5Type, NumKind};
use gimlet::io::xdmf::{self, DataRef, Snapshot, XdmfAttribute};
use gimlet::kernel::{FaceBc, Scheme, Side};
use gimlet::material::Material;
use gimlet::shape::ShapeKind;
use gimlet::sim::{Fill, Outflow, Simulation};
use std::path::{Path, PathBuf};
use std::time::Instant;

type Check = std::result::Result<(), String>;
/// One named check of the run.
type CheckFn = fn(&Comm, &Path) -> Check;

macro_rules! ensure {
    ($cond:expr, $($fmt:tt)*) => {
        if !$cond {
            return Err(format!($($fmt)*));
        }
    };
}

/// Converts a library error into a check failure with context.
fn ctx<T>(r: gimlet::error::Result<T>, what: &str) -> std::result::Result<T, String> {
    r.map_err(|e| format!("{what}: {:?}: {}", e.status, e.msg))
}

/// Rows this rank contributes to dataset number `which`: different on every
/// rank, and zero on some rank (on rank 0 for `which` odd, on the last rank
/// otherwise; on one rank, zero for `which == 3`).
fn local_count(comm: &Comm, which: u64) -> u64 {
    let (r, p) = (comm.rank() as u64, comm.size() as u64);
    let zero = if p == 1 {
        which == 3
    } else if which % 2 == 1 {
        r == 0
    } else {
        r == p - 1
    };
    if zero {
        0
    } else {
        3 + 2 * r + which
    }
}

/// The value stored at global element `g` of a dataset (exact in every type).
fn value<T: FromU64>(g: u64, salt: u64) -> T {
    T::from_u64(g * 7 + salt)
}

/// Builds test values from integers.
trait FromU64: H5Type + PartialEq + std::fmt::Debug {
    fn from_u64(v: u64) -> Self;
}
impl FromU64 for f64 {
    fn from_u64(v: u64) -> f64 {
        v as f64 * 0.25 + 1.0 / 3.0
    }
}
impl FromU64 for u64 {
    fn from_u64(v: u64) -> u64 {
        v * 1_000_000_007 + (1 << 40)
    }
}
impl FromU64 for i64 {
    fn from_u64(v: u64) -> i64 {
        -(v as i64) * 3_000_000_019
    }
}
impl FromU64 for i32 {
    fn from_u64(v: u64) -> i32 {
        -(v as i32) * 13
    }
}
impl FromU64 for u8 {
    fn from_u64(v: u64) -> u8 {
        (v % 251) as u8
    }
}

/// Writes one distributed dataset (k columns, or 1D when `k == 0`) and reads
/// it back three ways: the rank's own rows, the whole dataset, an even split.
fn roundtrip<T: FromU64>(f: &File, path: &str, which: u64, k: usize) -> Check {
    let comm = f.comm();
    let gp = "/level_1/particles";
    let g = if ctx(ctx(f.root(), "root")?.exists(gp), "exists")? {
        ctx(f.group(gp), "open group")?
    } else {
        ctx(f.create_group(gp), "create group")?
    };
    let n = local_count(comm, which);
    let kk = k.max(1) as u64;
    let offset = ctx(comm.exscan_u64(n), "exscan")?;
    let local: Vec<T> = (0..n * kk).map(|i| value(offset * kk + i, which)).collect();
    let slab = if k == 0 {
        ctx(g.write(path, &local), "write")?
    } else {
        ctx(g.write_2d(path, &local, k), "write_2d")?
    };
    drop(g);
    ensure!(
        slab.offset == offset && slab.count == n,
        "slab {slab:?} for offset {offset} count {n}"
    );
    let g = ctx(f.group("/level_1/particles"), "open group")?;
    let dims = ctx(g.dims(path), "dims")?;
    let want_dims = if k == 0 {
        vec![slab.total]
    } else {
        vec![slab.total, kk]
    };
    ensure!(
        dims == want_dims,
        "{path}: dims {dims:?}, expected {want_dims:?}"
    );
    ensure!(ctx(g.len(path), "len")? == slab.total, "{path}: len");
    let mine: Vec<T> = ctx(g.read_rows(path, offset, n), "read own rows")?;
    ensure!(
        mine == local,
        "{path}: own rows differ: {mine:?} vs {local:?}"
    );
    let all: Vec<T> = ctx(g.read_all(path), "read all")?;
    ensure!(
        all.len() as u64 == slab.total * kk,
        "{path}: read_all length {}",
        all.len()
    );
    for (i, v) in all.iter().enumerate() {
        ensure!(
            *v == value::<T>(i as u64, which),
            "{path}: element {i} is {v:?}"
        );
    }
    let (o, c) = split_even(slab.total, comm.size() - 1 - comm.rank(), comm.size());
    let part: Vec<T> = ctx(g.read_rows(path, o, c), "read even split")?;
    ensure!(
        part[..] == all[(o * kk) as usize..((o + c) * kk) as usize],
        "{path}: split rows differ"
    );
    Ok(())
}

fn check_datasets(comm: &Comm, dir: &Path) -> Check {
    let p = dir.join("data.h5");
    let f = ctx(format::create(comm, &p, FileKind::Output), "create")?;
    roundtrip::<f64>(&f, "x", 0, 0)?;
    roundtrip::<u64>(&f, "id", 1, 0)?;
    roundtrip::<i64>(&f, "sid", 2, 0)?;
    roundtrip::<i32>(&f, "level", 3, 0)?;
    roundtrip::<u8>(&f, "material", 4, 0)?;
    roundtrip::<f64>(&f, "xy", 5, 2)?;
    roundtrip::<f64>(&f, "stress", 6, 4)?;
    // A dataset with no rows anywhere.
    let g = ctx(f.create_group("/empty"), "create /empty")?;
    ctx(g.write::<f64>("x", &[]), "write empty")?;
    ensure!(ctx(g.len("x"), "len")? == 0, "empty dataset has rows");
    let e: Vec<f64> = ctx(g.read_all("x"), "read empty")?;
    ensure!(e.is_empty(), "empty dataset read {} values", e.len());
    drop(g);
    ctx(f.close(), "close")?;
    // Read it again after closing: the data are on disk.
    let f = ctx(format::open(comm, &p, FileKind::Output), "reopen")?;
    let g = ctx(f.group("/level_1/particles"), "group")?;
    let x: Vec<f64> = ctx(g.read_all("x"), "read x")?;
    for (i, v) in x.iter().enumerate() {
        ensure!(
            *v == value::<f64>(i as u64, 0),
            "after reopen, x[{i}] = {v}"
        );
    }
    // Asking for the wrong type, a missing dataset, or rows past the end fails
    // with an Io/argument error that names the file and the dataset.
    let err = g
        .read_all::<i32>("x")
        .err()
        .ok_or("reading f64 data as i32 succeeded")?;
    ensure!(
        err.status == Status::Io
            && err.msg.contains("/level_1/particles/x")
            && err.msg.contains("data.h5"),
        "type mismatch message: {}",
        err.msg
    );
    let err = g
        .len("nope")
        .err()
        .ok_or("len of a missing dataset succeeded")?;
    ensure!(
        err.status == Status::Io
            && err.msg.contains("/level_1/particles/nope")
            && err.msg.contains("data.h5"),
        "missing dataset message: {}",
        err.msg
    );
    let err = g
        .read_rows::<f64>("x", 0, x.len() as u64 + 1)
        .err()
        .ok_or("reading past the end succeeded")?;
    ensure!(
        err.status == Status::InvalidArgument,
        "past-the-end status {:?}",
        err.status
    );
    let err = g
        .check_len("x", x.len() as u64 + 5)
        .err()
        .ok_or("check_len of a short dataset succeeded")?;
    ensure!(
        err.status == Status::Io && err.msg.contains("truncated"),
        "check_len message: {}",
        err.msg
    );
    ensure!(
        ctx(g.exists("x"), "exists")? && !ctx(g.exists("a/b/c"), "exists")?,
        "exists"
    );
    Ok(())
}

fn check_attributes(comm: &Comm, dir: &Path) -> Check {
    let p = dir.join("attrs.h5");
    {
        let f = ctx(File::create(comm, &p), "create")?;
        let root = ctx(f.root(), "root")?;
        ctx(root.set_attr("time", 0.1 + 0.2), "f64")?;
        ctx(root.set_attr("step", -12345678901234_i64), "i64")?;
        ctx(root.set_attr("seed", u64::MAX - 3), "u64")?;
        ctx(
            root.set_attr_array("domain", &[0.0, 60e-6, 0.0, 40e-6]),
            "array",
        )?;
        ctx(root.set_attr_str("units", "SI (m, kg, s)"), "str")?;
        ctx(root.set_attr("step", 7_i64), "overwrite")?;
        let g = ctx(f.create_group("/level_2"), "group")?;
        ctx(g.set_attr("h", 125e-9), "group attr")?;
        ctx(g.write::<u8>("m", &[1, 2]), "write")?;
        let d = ctx(g.dataset("m"), "dataset")?;
        ctx(d.set_attr_str("unit", "none"), "dataset attr")?;
        drop((d, g, root));
        ctx(f.close(), "close")?;
    }
    let f = ctx(File::open(comm, &p), "open")?;
    let root = ctx(f.root(), "root")?;
    ensure!(ctx(root.attr::<f64>("time"), "time")? == 0.1 + 0.2, "time");
    ensure!(
        ctx(root.attr::<i64>("step"), "step")? == 7,
        "step was not overwritten"
    );
    ensure!(
        ctx(root.attr::<u64>("seed"), "seed")? == u64::MAX - 3,
        "seed"
    );
    ensure!(
        ctx(root.attr_array::<f64>("domain"), "domain")? == [0.0, 60e-6, 0.0, 40e-6],
        "domain"
    );
    ensure!(
        ctx(root.attr_str("units"), "units")? == "SI (m, kg, s)",
        "units"
    );
    let g = ctx(f.group("/level_2"), "group")?;
    ensure!(ctx(g.attr::<f64>("h"), "h")? == 125e-9, "h");
    let d = ctx(g.dataset("m"), "dataset")?;
    ensure!(ctx(d.attr_str("unit"), "unit")? == "none", "unit");
    let err = root
        .attr::<f64>("absent")
        .err()
        .ok_or("missing attribute read")?;
    ensure!(
        err.status == Status::Io && err.msg.contains("absent") && err.msg.contains("attrs.h5"),
        "missing attribute message: {}",
        err.msg
    );
    ensure!(root.attr_str("time").is_err(), "a number read as a string");
    Ok(())
}

/// Expects `r` to be an `Io` error whose message contains every word.
fn expect_io<T>(r: gimlet::error::Result<T>, words: &[&str], what: &str) -> Check {
    match r {
        Ok(_) => Err(format!("{what} was accepted")),
        Err(Error {
            status: Status::Io,
            msg,
            ..
        }) => {
            for w in words {
                ensure!(msg.contains(w), "{what}: message '{msg}' lacks '{w}'");
            }
            Ok(())
        }
        Err(e) => Err(format!("{what}: status {:?} ({})", e.status, e.msg)),
    }
}

fn check_rejections(comm: &Comm, dir: &Path) -> Check {
    let good = dir.join("good.h5");
    {
        let f = ctx(format::create(comm, &good, FileKind::Checkpoint), "create")?;
        let g = ctx(f.create_group("/level_0"), "group")?;
        let data: Vec<f64> = (0..5000).map(|i| i as f64).collect();
        ctx(g.write("x", &data), "write")?;
        drop(g);
        ctx(f.close(), "close")?;
    }
    ctx(
        format::open(comm, &good, FileKind::Checkpoint),
        "open a good checkpoint",
    )?;
    expect_io(
        format::open(comm, &good, FileKind::Output),
        &["good.h5", "gimlet-checkpoint", "expected a gimlet-output"],
        "wrong kind",
    )?;
    let text = dir.join("foreign.txt");
    let plain = dir.join("plain.h5");
    let cut = dir.join("cut.h5");
    let newer = dir.join("newer.h5");
    if comm.rank() == 0 {
        std::fs::write(&text, "time,force\n0,1\n").map_err(|e| e.to_string())?;
        let bytes = std::fs::read(&good).map_err(|e| e.to_string())?;
        std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).map_err(|e| e.to_string())?;
    }
    ctx(comm.barrier(), "barrier")?;
    expect_io(
        format::open(comm, &text, FileKind::Checkpoint),
        &["foreign.txt", "not an HDF5 file", "gimlet-checkpoint"],
        "a text file",
    )?;
    expect_io(
        format::open(comm, &dir.join("absent.h5"), FileKind::Checkpoint),
        &["absent.h5", "no such file"],
        "a missing file",
    )?;
    expect_io(
        format::open(comm, &cut, FileKind::Checkpoint),
        &["cut.h5", "truncated"],
        "a truncated file",
    )?;
    {
        let f = ctx(File::create(comm, &plain), "create plain")?;
        ctx(f.close(), "close plain")?;
        let f = ctx(File::create(comm, &newer), "create newer")?;
        ctx(
            format::write_tag(&f, FileKind::Checkpoint, FORMAT_VERSION + 1),
            "tag newer",
        )?;
        ctx(f.close(), "close newer")?;
    }
    expect_io(
        format::open(comm, &plain, FileKind::Checkpoint),
        &["plain.h5", "not a Gimlet file", "gimlet_format"],
        "HDF5 without the tag",
    )?;
    let v = format!("format version {}", FORMAT_VERSION + 1);
    expect_io(
        format::open(comm, &newer, FileKind::Checkpoint),
        &["newer.h5", &v, "expected"],
        "a newer version",
    )?;
    Ok(())
}

fn write_snapshot(
    comm: &Comm,
    path: &Path,
    time: f64,
    which: u64,
) -> std::result::Result<Snapshot, String> {
    let n = local_count(comm, which);
    let off = ctx(comm.exscan_u64(n), "exscan")?;
    let f = ctx(format::create(comm, path, FileKind::Output), "create")?;
    let g = ctx(f.create_group("/particles"), "group")?;
    let xy: Vec<f64> = (0..2 * n)
        .map(|i| (off * 2 + i) as f64 * 1e-6 + time)
        .collect();
    let s = ctx(g.write_2d("xy", &xy, 2), "xy")?;
    let ints = |v: i32| vec![v; n as usize];
    ctx(g.write("level", &ints(which as i32)), "level")?;
    ctx(g.write("patch", &ints(comm.rank() % 2)), "patch")?;
    ctx(g.write("rank", &ints(comm.rank())), "rank")?;
    let ids: Vec<i64> = (0..n).map(|i| (off + i) as i64).collect();
    ctx(g.write("id", &ids), "id")?;
    ctx(
        g.write_2d("velocity", &vec![0.5; 3 * n as usize], 3),
        "velocity",
    )?;
    ctx(
        g.write_2d("stress", &vec![-1e6; 4 * n as usize], 4),
        "stress",
    )?;
    ctx(g.set_attr("time", time), "time attr")?;
    drop(g);
    ctx(f.close(), "close")?;
    let t = s.total;
    let a = |name: &str, data: DataRef| XdmfAttribute {
        name: name.into(),
        data,
    };
    Ok(Snapshot {
        time,
        file: path.file_name().unwrap().to_string_lossy().into_owned(),
        n: t,
        geometry: DataRef::new::<f64>("/particles/xy", &[t, 2]),
        attributes: vec![
            a("level", DataRef::new::<i32>("/particles/level", &[t])),
            a("patch", DataRef::new::<i32>("/particles/patch", &[t])),
            a("rank", DataRef::new::<i32>("/particles/rank", &[t])),
            a("id", DataRef::new::<i64>("/particles/id", &[t])),
            a(
                "velocity",
                DataRef::new::<f64>("/particles/velocity", &[t, 3]),
            ),
            a("stress", DataRef::new::<f64>("/particles/stress", &[t, 4])),
        ],
    })
}

fn check_xdmf(comm: &Comm, dir: &Path) -> Check {
    let mut series = Vec::new();
    for (i, t) in [0.0, 2.5e-9].into_iter().enumerate() {
        series.push(write_snapshot(
            comm,
            &dir.join(format!("out_{i:04}.h5")),
            t,
            i as u64,
        )?);
    }
    let xpath = dir.join("particles.xdmf");
    ctx(xdmf::write(comm, &xpath, &series), "write xdmf")?;
    let checked = ctx(xdmf::check(comm, &xpath), "check xdmf")?;
    ensure!(checked == 14, "checked {checked} data items, expected 14");
    // Wrong dimensions, a wrong type and a missing dataset must be caught.
    let mut bad = series.clone();
    bad[1].attributes[4].data.dims[1] = 2;
    let mut bad_type = series.clone();
    bad_type[0].attributes[3].data.kind = NumKind::UInt;
    let mut missing = series.clone();
    missing[0].attributes[0].data.dataset = "/particles/nope".into();
    let cases = [
        (bad, "dimensions"),
        (bad_type, "holds"),
        (missing, "missing"),
    ];
    for (i, (s, word)) in cases.into_iter().enumerate() {
        let p = dir.join(format!("bad_{i}.xdmf"));
        ctx(xdmf::write(comm, &p, &s), "write bad xdmf")?;
        expect_io(
            xdmf::check(comm, &p),
            &[word, &format!("bad_{i}.xdmf")],
            "a wrong XDMF",
        )?;
    }
    Ok(())
}

fn generation(comm: &Comm, p: &Path) -> std::result::Result<i64, String> {
    let f = ctx(format::open(comm, p, FileKind::Checkpoint), "open")?;
    let root = ctx(f.root(), "root")?;
    ctx(root.attr::<i64>("generation"), "generation")
}

fn write_generation(
    comm: &Comm,
    tmp: &Path,
    gen: i64,
    fail_on: Option<i32>,
) -> gimlet::error::Result<()> {
    let f = format::create(comm, tmp, FileKind::Checkpoint)?;
    f.root()?.set_attr("generation", gen)?;
    let g = f.create_group("/level_0")?;
    g.write("x", &vec![gen as f64; 1000])?;
    drop(g);
    f.close()?;
    if fail_on.is_some_and(|r| r == comm.rank()) {
        return Err(Error::new(
            Status::Io,
            "injected failure after writing the temporary",
        ));
    }
    Ok(())
}

fn leftovers(dir: &Path) -> usize {
    std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
                .count()
        })
        .unwrap_or(usize::MAX)
}

fn check_atomic(comm: &Comm, dir: &Path) -> Check {
    let p = dir.join("restart.h5");
    ctx(
        write_atomic(comm, &p, |t| write_generation(comm, t, 1, None)),
        "first write",
    )?;
    ensure!(generation(comm, &p)? == 1, "first generation");
    for fail_on in [0, comm.size() - 1] {
        let r = write_atomic(comm, &p, |t| write_generation(comm, t, 2, Some(fail_on)));
        ensure!(r.is_err(), "a write failing on rank {fail_on} succeeded");
        ensure!(
            generation(comm, &p)? == 1,
            "the previous file changed after a failed write"
        );
        ctx(comm.barrier(), "barrier")?;
        ensure!(
            comm.rank() != 0 || leftovers(dir) == 0,
            "a temporary file was left behind"
        );
    }
    ctx(
        write_atomic(comm, &p, |t| write_generation(comm, t, 3, None)),
        "third write",
    )?;
    ensure!(
        generation(comm, &p)? == 3,
        "the successful write did not replace the file"
    );
    ensure!(
        comm.rank() != 0 || leftovers(dir) == 0,
        "a temporary file was left behind"
    );
    Ok(())
}

fn check_csv(comm: &Comm, dir: &Path) -> Check {
    let p = dir.join("series.csv");
    let cols = ["time", "step", "force", "n_level_0"];
    let rows = [
        [0.0, 0.0, 0.0, 400.0],
        [1e-9 / 3.0, 1.0, -2.5e-3 * 0.1, 400.0],
        [2e-9 / 3.0, 2.0, 0.1 + 0.2, 1600.0],
    ];
    let s = ctx(CsvSeries::create(comm, &p, &cols), "create")?;
    ctx(s.row(comm, &rows[0]), "row")?;
    ctx(s.row(comm, &rows[1]), "row")?;
    ensure!(s.row(comm, &[1.0]).is_err(), "a short row was accepted");
    // "Restart": continue the same file.
    let s = ctx(CsvSeries::append_to(comm, &p, &cols), "append_to")?;
    ctx(s.row(comm, &rows[2]), "row")?;
    expect_io(
        CsvSeries::append_to(comm, &p, &["time", "other"]),
        &["series.csv", "header"],
        "a different header",
    )?;
    ctx(comm.barrier(), "barrier")?;
    let text = std::fs::read_to_string(&p).map_err(|e| e.to_string())?;
    let lines: Vec<&str> = text.lines().collect();
    ensure!(
        lines.len() == 4 && lines[0] == cols.join(","),
        "file is {text:?}"
    );
    for (line, want) in lines[1..].iter().zip(rows.iter()) {
        let got: Vec<f64> = line
            .split(',')
            .map(|v| v.parse().unwrap_or(f64::NAN))
            .collect();
        ensure!(
            got[..] == want[..],
            "row {line} reads back as {got:?}, wrote {want:?}"
        );
    }
    Ok(())
}

/// A one-level scene that uses every setting the checkpoint stores: two
/// materials, uneven patches, mixed face conditions, gravity, a ramped
/// traction, cpGIMP with USL and a FLIP fraction, and a fast block that
/// leaves through the free right face (removed and recorded); with
/// `levels`, a refined level in a corner of the slow block (particles cross
/// between levels, and each level keeps copies of the other's).
fn scene(comm: Comm, levels: bool) -> gimlet::error::Result<Simulation> {
    let mut s = Simulation::new(comm, -0.5, 0.25, 1.0, 0.5, 1.0 / 16.0)?;
    let mut h = s.hier().clone();
    if levels {
        h.add_level(&[[-0.5, 0.25, -0.25, 0.375]])?;
    }
    h.set_patch_size(0, 5, 3)?;
    s.set_hierarchy(h)?;
    s.set_thickness(0.1)?;
    s.add_material(Material::LinearElastic {
        e: 1e4,
        nu: 0.3,
        rho: 2.0,
    })?;
    s.add_material(Material::NeoHookean {
        e: 2e4,
        nu: 0.25,
        rho: 1.0,
    })?;
    let mut run = s.run();
    run.shape = ShapeKind::CpGimp;
    run.scheme = Scheme::Usl;
    run.flip = 0.9;
    run.cfl = 0.4;
    run.gravity = [0.5, -1.0];
    run.bc = [FaceBc::Fixed, FaceBc::Free, FaceBc::Roller, FaceBc::Free];
    run.ramp.t_ramp = 1e-3;
    run.outflow = Outflow::Remove;
    s.set_run(run)?;
    s.fill_rectangle(&Fill {
        rect: [-0.5, 0.25, 0.0, 0.5],
        n_per_cell: 2,
        material: 0,
        density: 2.0,
        velocity: [0.0, 0.0],
    })?;
    s.fill_rectangle(&Fill {
        rect: [0.25, 0.5, 0.5, 0.75],
        n_per_cell: 2,
        material: 1,
        density: 1.0,
        velocity: [30.0, 5.0],
    })?;
    s.apply_traction(Side::Top, 0.5, -0.5, 0.0, [0.0, -10.0])?;
    Ok(s)
}

/// FNV-1a of every particle (all fields, packed) of each patch of each
/// level, in patch order, summed over ranks (a patch lives on one rank), and
/// the global crossing counts: equal for two states exactly when every patch
/// holds the same particles in the same order (up to hash collisions).
fn fingerprint(s: &Simulation) -> gimlet::error::Result<Vec<u64>> {
    let mut out = Vec::new();
    for lv in s.levels() {
        let mut h = vec![0u64; lv.patches.len()];
        for p in &lv.local {
            let mut b = Vec::new();
            for i in 0..p.parts.len() {
                p.parts.pack(i, &mut b);
            }
            h[p.k] = b.iter().fold(0xcbf2_9ce4_8422_2325u64, |a, &x| {
                (a ^ u64::from(x)).wrapping_mul(0x100_0000_01b3)
            }) | 1;
        }
        s.comm().sum_u64(&mut h)?;
        out.extend(h);
        let mut c = [lv.crossings];
        s.comm().sum_u64(&mut c)?;
        out.push(c[0]);
    }
    Ok(out)
}

fn step_n(s: &mut Simulation, n: usize) -> gimlet::error::Result<()> {
    for _ in 0..n {
        let dt = s.stable_dt()?;
        s.step(dt)?;
    }
    Ok(())
}

fn check_checkpoint(comm: &Comm, dir: &Path) -> Check {
    for levels in [false, true] {
        checkpoint_scene(comm, dir, levels)
            .map_err(|e| format!("scene with levels = {levels}: {e}"))?;
    }
    Ok(())
}

fn checkpoint_scene(comm: &Comm, dir: &Path, levels: bool) -> Check {
    let world = || ctx(Comm::dup(comm.raw()), "dup");
    let mut a = ctx(scene(world()?, levels), "scene")?;
    ctx(step_n(&mut a, 12), "steps before the checkpoint")?;
    let mut lost = [a.lost().len() as u64];
    ctx(comm.sum_u64(&mut lost), "sum")?;
    ensure!(
        lost[0] > 0,
        "no particle left the domain: the scene does not test the lost list"
    );
    if levels {
        // Particles on the fine level, and copies kept for the coupling.
        let mut c = [0u64, 0];
        for lv in a.levels() {
            for p in &lv.local {
                c[0] += (lv.l == 1) as u64 * p.parts.len() as u64;
                c[1] += p.parts.copy.iter().filter(|&&k| k != 0.0).count() as u64;
            }
        }
        ctx(comm.sum_u64(&mut c), "sum")?;
        ensure!(
            c[0] > 0 && c[1] > 0,
            "the two-level scene has {} fine particles and {} copies",
            c[0],
            c[1]
        );
    }
    let p = dir.join("whole.ckpt.h5");
    ctx(checkpoint::write(&a, &p), "write checkpoint")?;
    let mut b = ctx(checkpoint::read(world()?, &p), "read checkpoint")?;
    ensure!(
        b.hier() == a.hier(),
        "hierarchy {:?} read back as {:?}",
        a.hier(),
        b.hier()
    );
    ensure!(b.thickness() == a.thickness(), "thickness");
    ensure!(
        b.materials() == a.materials(),
        "materials {:?} read back as {:?}",
        a.materials(),
        b.materials()
    );
    ensure!(
        b.run() == a.run(),
        "run settings {:?} read back as {:?}",
        a.run(),
        b.run()
    );
    ensure!(
        (b.time().to_bits(), b.steps(), b.next_id())
            == (a.time().to_bits(), a.steps(), a.next_id()),
        "time, steps, next_id"
    );
    ensure!(
        b.lost() == a.lost(),
        "the lost list of rank {} differs",
        comm.rank()
    );
    let fa = ctx(fingerprint(&a), "fingerprint")?;
    ensure!(
        ctx(fingerprint(&b), "fingerprint")? == fa,
        "particles differ after reading"
    );
    ensure!(b.num_local() > 0 || comm.size() > 1, "no particles read");
    // Both continue: bitwise the same particles, lost lists and counters.
    ctx(step_n(&mut a, 8), "steps after the checkpoint")?;
    ctx(step_n(&mut b, 8), "steps after the restart")?;
    ensure!(
        b.time().to_bits() == a.time().to_bits() && b.lost() == a.lost(),
        "time or lost list differ after continuing"
    );
    ensure!(
        ctx(fingerprint(&b), "fingerprint")? == ctx(fingerprint(&a), "fingerprint")?,
        "particles differ after continuing"
    );
    // A checkpoint is not an output and vice versa.
    expect_io(
        format::open(comm, &p, FileKind::Output),
        &["whole.ckpt.h5", "gimlet-checkpoint"],
        "a checkpoint read as an output",
    )?;
    Ok(())
}

/// Times a collective write and read of `n` f64 per rank.
fn throughput(comm: &Comm, dir: &Path) -> std::result::Result<String, String> {
    let n = 2_000_000usize;
    let data: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let p = dir.join("big.h5");
    ctx(comm.barrier(), "barrier")?;
    let t0 = Instant::now();
    let f = ctx(File::create(comm, &p), "create")?;
    ctx(ctx(f.root(), "root")?.write("x", &data), "write")?;
    ctx(f.close(), "close")?;
    let tw = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let f = ctx(File::open(comm, &p), "open")?;
    let off = comm.rank() as u64 * n as u64;
    let back: Vec<f64> = ctx(ctx(f.root(), "root")?.read_rows("x", off, n as u64), "read")?;
    let tr = t0.elapsed().as_secs_f64();
    ensure!(back == data, "big dataset read back differently");
    let mb = (n * 8 * comm.size() as usize) as f64 / 1e6;
    Ok(format!(
        "{mb:.0} MB: write {:.0} MB/s, read {:.0} MB/s",
        mb / tw,
        mb / tr
    ))
}

fn main() {
    // SAFETY: MPI is initialised once, here, and finalised at the end.
    unsafe { mpi_sys::MPI_Init(std::ptr::null_mut(), std::ptr::null_mut()) };
    let code = run();
    unsafe { mpi_sys::MPI_Finalize() };
    std::process::exit(code);
}

fn run() -> i32 {
    let comm = match Comm::world() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("FAIL comm: {}", e.msg);
            return 1;
        }
    };
    let tag = comm
        .allgather_u64(u64::from(std::process::id()))
        .map(|v| v[0])
        .unwrap_or(0);
    let (dir, fresh): (PathBuf, bool) = match std::env::args().nth(1) {
        Some(d) => (PathBuf::from(d), false),
        None => (
            std::env::temp_dir().join(format!("gimlet-io-check-{tag}-{}", comm.size())),
            true,
        ),
    };
    if comm.rank() == 0 {
        let _ = std::fs::create_dir_all(&dir);
    }
    let _ = comm.barrier();
    let checks: [(&str, CheckFn); 7] = [
        (
            "distributed datasets write/read (uneven counts, empty ranks)",
            check_datasets,
        ),
        ("attributes on file, group, dataset", check_attributes),
        (
            "rejection of foreign, truncated, wrong-kind, wrong-version files",
            check_rejections,
        ),
        (
            "XDMF series written and validated; wrong XDMF caught",
            check_xdmf,
        ),
        ("failed atomic write keeps the previous file", check_atomic),
        ("CSV series with append and round-trip numbers", check_csv),
        (
            "checkpoint of a whole simulation: settings, every particle field in patch order, lost list; continues bitwise",
            check_checkpoint,
        ),
    ];
    let mut failed = 0;
    for (name, f) in checks {
        let r = f(&comm, &dir);
        // Print a failure before agreeing on it, so that a rank stuck in a
        // collective still lets the message out.
        if let Err(msg) = &r {
            println!("FAIL [rank {}] {name}: {msg}", comm.rank());
        }
        let any = comm.any(r.is_err()).unwrap_or(true);
        if r.is_ok() && comm.rank() == 0 {
            if any {
                println!("FAIL {name} (on another rank)");
            } else {
                println!("ok   {name}");
            }
        }
        failed += usize::from(any);
    }
    match throughput(&comm, &dir) {
        Ok(s) if comm.rank() == 0 => println!("info {} ranks, {s}", comm.size()),
        Ok(_) => {}
        Err(e) => {
            println!("FAIL throughput: {e}");
            failed += 1;
        }
    }
    let failed = comm.any(failed > 0).unwrap_or(true);
    if comm.rank() == 0 {
        if !failed && fresh {
            let _ = std::fs::remove_dir_all(&dir);
        }
        println!(
            "{} ({} ranks)",
            if failed {
                "FAILED"
            } else {
                "all io checks passed"
            },
            comm.size()
        );
    }
    i32::from(failed)
}
