//! The output settings a simulation handle carries: a series of HDF5 output
//! files described by one XDMF file, and a CSV time series of global
//! quantities.
//!
//! Both continue cleanly after a restart: opening a series on a handle that
//! has already taken steps (one read from a checkpoint) keeps what the
//! existing files hold up to the current step and drops what lies beyond
//! it, so a restarted run extends the series without duplicates.

use super::atomic::write_atomic;
use super::csv::CsvSeries;
use super::format::{self, FileKind};
use super::h5::Attributes;
use super::xdmf::{self, Snapshot};
use super::{agree, snapshot};
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::sim::Simulation;
use std::path::{Path, PathBuf};

/// Output settings of a simulation (none until opened).
#[derive(Debug, Default)]
pub struct Outputs {
    /// The HDF5 + XDMF output series, once `gimlet_output_open` was called.
    pub series: Option<OutputSeries>,
    /// The CSV time series, once `gimlet_csv_open` was called.
    pub csv: Option<CsvSeries>,
}

/// A series of output files `<dir>/<basename>_<step>.h5` and the XDMF file
/// `<dir>/<basename>.xdmf` listing them.
#[derive(Debug)]
pub struct OutputSeries {
    dir: PathBuf,
    basename: String,
    /// Outputs written so far, by increasing step.
    written: Vec<(u64, Snapshot)>,
}

fn io_err(msg: String) -> Error {
    Error::new(Status::Io, msg)
}

/// Checks an output basename: a plain, non-empty file name.
pub fn check_basename(basename: &str) -> Result<()> {
    if basename.is_empty()
        || basename.contains(['/', '\\'])
        || basename.starts_with('.')
        || basename.chars().any(|c| c.is_control())
    {
        return Err(Error::arg(format!(
            "basename '{basename}' must be a non-empty file name without '/', '\\' or control characters, not starting with '.'"
        )));
    }
    Ok(())
}

/// Creates `dir` (and its parents) on rank 0. Collective.
fn make_dir(comm: &Comm, dir: &Path) -> Result<()> {
    let local = if comm.rank() == 0 {
        std::fs::create_dir_all(dir).map_err(|e| {
            io_err(format!(
                "cannot create output directory '{}': {e}",
                dir.display()
            ))
        })
    } else {
        Ok(())
    };
    agree(comm, local)?;
    if !dir.is_dir() {
        return Err(io_err(format!(
            "output directory '{}' is not visible on rank {} (the ranks need a shared file system)",
            dir.display(),
            comm.rank()
        )));
    }
    Ok(())
}

impl OutputSeries {
    /// Opens a series in `dir` (created when missing) with file names
    /// starting with `basename`. When `steps > 0` (a handle that has run, for
    /// example after a restart) and the XDMF file exists, the outputs it
    /// lists at steps up to `steps` are kept in the series (later ones are
    /// dropped); otherwise the series starts empty. Collective.
    pub fn open(comm: &Comm, dir: &Path, basename: &str, steps: u64) -> Result<OutputSeries> {
        check_basename(basename)?;
        if dir.as_os_str().is_empty() {
            return Err(Error::arg("dir is empty; pass a directory path"));
        }
        make_dir(comm, dir)?;
        let mut s = OutputSeries {
            dir: dir.to_path_buf(),
            basename: basename.to_string(),
            written: Vec::new(),
        };
        if steps > 0 && comm.any(s.xdmf_path().is_file())? {
            s.written = agree(comm, s.existing(comm, steps))?;
        }
        Ok(s)
    }

    /// The outputs listed by the existing XDMF file with step `<= steps`,
    /// rebuilt from their HDF5 files (which must exist and be outputs).
    fn existing(&self, comm: &Comm, steps: u64) -> Result<Vec<(u64, Snapshot)>> {
        let xp = self.xdmf_path();
        let text = std::fs::read_to_string(&xp)
            .map_err(|e| io_err(format!("cannot read XDMF file '{}': {e}", xp.display())))?;
        let items =
            xdmf::parse(&text).map_err(|m| io_err(format!("XDMF file '{}': {m}", xp.display())))?;
        let mut files: Vec<(u64, String)> = Vec::new();
        for it in items {
            if let Some(step) = self.step_of(&it.file) {
                if step <= steps && !files.iter().any(|(s, _)| *s == step) {
                    files.push((step, it.file));
                }
            }
        }
        files.sort();
        let mut out = Vec::new();
        for (step, file) in files {
            let f = format::open(comm, &self.dir.join(&file), FileKind::Output)?;
            let root = f.root()?;
            let time = root.attr::<f64>("time")?;
            let n = root.attr::<u64>("num_particles")?;
            let affine = root.exists("/particles/affine")?;
            let hoop = root.exists("/particles/hoop_stretch")?;
            out.push((step, snapshot::describe(&file, time, n, affine, hoop)));
        }
        Ok(out)
    }

    /// The step of an output file name of this series, if it is one.
    fn step_of(&self, file: &str) -> Option<u64> {
        let digits = file
            .strip_prefix(&self.basename)?
            .strip_prefix('_')?
            .strip_suffix(".h5")?;
        if digits.len() < 6 || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        digits.parse().ok()
    }

    /// The output file name for `step`: `<basename>_<step, 6 digits>.h5`.
    pub fn file_name(&self, step: u64) -> String {
        format!("{}_{step:06}.h5", self.basename)
    }

    /// The XDMF file: `<dir>/<basename>.xdmf`.
    pub fn xdmf_path(&self) -> PathBuf {
        self.dir.join(format!("{}.xdmf", self.basename))
    }

    /// The steps of the outputs in the series so far.
    pub fn steps(&self) -> Vec<u64> {
        self.written.iter().map(|(s, _)| *s).collect()
    }

    /// Forgets the outputs after `step` (after the handle was rewound by a
    /// checkpoint read); the XDMF file is rewritten at the next output.
    pub fn forget_after(&mut self, step: u64) {
        self.written.retain(|(s, _)| *s <= step);
    }

    /// Writes the output of the current state of `sim` to
    /// `<dir>/<basename>_<step>.h5` and rewrites the XDMF file to list every
    /// output so far (an output at a step already listed replaces it). Both
    /// files are replaced atomically. Returns the output's path. Collective.
    pub fn write(&mut self, sim: &Simulation) -> Result<PathBuf> {
        let step = sim.steps();
        let name = self.file_name(step);
        let path = self.dir.join(&name);
        let mut snap = None;
        write_atomic(sim.comm(), &path, |tmp| {
            snap = Some(snapshot::write(sim, tmp, &name)?);
            Ok(())
        })?;
        let snap = snap
            .ok_or_else(|| Error::new(Status::Internal, "output written without a description"))?;
        let mut list = self.written.clone();
        list.retain(|(s, _)| *s != step);
        list.push((step, snap));
        list.sort_by_key(|(s, _)| *s);
        let snaps: Vec<Snapshot> = list.iter().map(|(_, s)| s.clone()).collect();
        xdmf::write(sim.comm(), &self.xdmf_path(), &snaps)?;
        self.written = list;
        Ok(path)
    }
}

/// The CSV columns before the per-level particle counts. The indenter
/// columns describe the first indenter (NaN without one):
/// `indenter_displacement` is its depth (downward displacement of its tip
/// since its placement), `indenter_force` and `indenter_force_x` the force
/// on it per metre of thickness (vertical component positive upward: the
/// load pushing back on an indenter that presses down), `contacts` the
/// number of particles in contact with any indenter.
pub const CSV_COLUMNS: [&str; 11] = [
    "time",
    "step",
    "indenter_displacement",
    "indenter_force",
    "indenter_force_x",
    "contacts",
    "kinetic_energy",
    "strain_energy",
    "momentum_x",
    "momentum_y",
    "mass",
];

/// The CSV header of a simulation with `levels` levels: [`CSV_COLUMNS`],
/// then `particles_level_0` .. `particles_level_<levels-1>` (the particles
/// each level owns; copies kept for coupling levels are not counted).
pub fn csv_columns(levels: usize) -> Vec<String> {
    CSV_COLUMNS
        .iter()
        .map(|c| c.to_string())
        .chain((0..levels).map(|l| format!("particles_level_{l}")))
        .collect()
}

/// Opens the CSV time series of `sim` at `path`. On a handle that has not
/// stepped, the file is created (or truncated) with the header. On a handle
/// that has stepped (after a restart) and an existing file with the same
/// header, the rows with `step <=` the current step are kept, later rows are
/// dropped (the file is replaced atomically), and new rows are appended.
/// Collective.
pub fn csv_open(sim: &Simulation, path: &Path) -> Result<CsvSeries> {
    let comm = sim.comm();
    let cols = csv_columns(sim.hier().num_levels());
    let cols: Vec<&str> = cols.iter().map(String::as_str).collect();
    let exists = comm.any(comm.rank() == 0 && path.is_file())?;
    if sim.steps() == 0 || !exists {
        return CsvSeries::create(comm, path, &cols);
    }
    let header = cols.join(",");
    let step_col = 1;
    let mut kept = String::new();
    let local = if comm.rank() == 0 {
        std::fs::read_to_string(path)
            .map_err(|e| io_err(format!("cannot read CSV file '{}': {e}", path.display())))
            .and_then(|text| {
                let mut lines = text.lines();
                let first = lines.next().unwrap_or("");
                if first != header {
                    return Err(io_err(format!(
                        "CSV file '{}' has header '{first}' but '{header}' was expected; not continuing it",
                        path.display()
                    )));
                }
                kept.push_str(&header);
                kept.push('\n');
                for line in lines {
                    let step = line
                        .split(',')
                        .nth(step_col)
                        .and_then(|v| v.trim().parse::<f64>().ok());
                    // Rows cut short by a crash (no step) are dropped too.
                    if step.is_some_and(|s| s <= sim.steps() as f64)
                        && line.split(',').count() == cols.len()
                    {
                        kept.push_str(line);
                        kept.push('\n');
                    }
                }
                Ok(())
            })
    } else {
        Ok(())
    };
    agree(comm, local)?;
    write_atomic(comm, path, |tmp| {
        if comm.rank() == 0 {
            std::fs::write(tmp, kept.as_bytes()).map_err(|e| {
                io_err(format!("writing CSV file '{}' failed: {e}", path.display()))
            })?;
        }
        Ok(())
    })?;
    CsvSeries::append_to(comm, path, &cols)
}

/// The first indenter's depth and force (y, x) per metre of thickness (in
/// axisymmetry the whole body's, as `gimlet_indenter_state`), and the
/// number of owned particles in contact, for the CSV series (NaN for the
/// indenter values without an indenter: the columns are kept so that files
/// of every scene share them).
fn indenter_values(sim: &Simulation) -> [f64; 4] {
    let c = &sim.contact;
    let n = c.points().filter(|p| p.owned).count() as f64;
    match c.indenters.first() {
        Some(ind) => {
            let f = sim.indenter_force(0);
            [ind.depth(sim.time()), f[1], f[0], n]
        }
        None => [f64::NAN, f64::NAN, f64::NAN, n],
    }
}

/// One CSV row of the current state of `sim`, in the order of
/// [`csv_columns`] for `levels` levels. Collective (global sums).
pub fn csv_row(sim: &Simulation, levels: usize) -> Result<Vec<f64>> {
    if sim.hier().num_levels() != levels {
        return Err(Error::state(format!(
            "the hierarchy has {} levels but the CSV series was opened with {levels}; open it after the layout is complete",
            sim.hier().num_levels()
        )));
    }
    let d = sim.diagnostics()?;
    let mut counts: Vec<u64> = (0..levels)
        .map(|l| {
            sim.levels().get(l).map_or(0, |lv| {
                lv.local
                    .iter()
                    .map(|p| snapshot::owned(&p.parts).count() as u64)
                    .sum()
            })
        })
        .collect();
    sim.comm().sum_u64(&mut counts)?;
    let [disp, fy, fx, n] = indenter_values(sim);
    let mut row = vec![sim.time(), sim.steps() as f64, disp, fy, fx, n];
    row.extend_from_slice(&d);
    row.extend(counts.iter().map(|&c| c as f64));
    Ok(row)
}

/// Appends one row of the current state of `sim` to `csv`. Collective.
pub fn csv_append(sim: &Simulation, csv: &CsvSeries) -> Result<()> {
    let levels = csv.columns().len() - CSV_COLUMNS.len();
    let row = csv_row(sim, levels)?;
    csv.row(sim.comm(), &row)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_and_names() {
        let c = csv_columns(2);
        assert_eq!(c.len(), 13);
        assert_eq!(c[0], "time");
        assert_eq!(c[3], "indenter_force");
        assert_eq!(c[5], "contacts");
        assert_eq!(c[12], "particles_level_1");
        assert!(check_basename("plate").is_ok());
        for bad in ["", "a/b", ".hidden", "x\ny"] {
            assert!(check_basename(bad).is_err(), "{bad:?}");
        }
        let s = OutputSeries {
            dir: PathBuf::from("out"),
            basename: "run_a".into(),
            written: Vec::new(),
        };
        assert_eq!(s.file_name(42), "run_a_000042.h5");
        assert_eq!(s.step_of("run_a_000042.h5"), Some(42));
        assert_eq!(s.step_of("run_a_1234567.h5"), Some(1234567));
        assert_eq!(s.step_of("run_a_42.h5"), None);
        assert_eq!(s.step_of("run_b_000042.h5"), None);
        assert_eq!(s.xdmf_path(), PathBuf::from("out/run_a.xdmf"));
    }
}
