//! Output (HDF5 + XDMF series, CSV series) and checkpoint/restart.
//!
//! Every path argument is a NUL-terminated UTF-8 string and must be the same
//! on every rank (a path that differs is an error on every rank); the ranks
//! must share a file system. Every call here is collective. Files are replaced atomically: a failed write leaves the
//! previous file at the path as it was.

use super::agree::{collective, collective_handle, create_on, Args, Text};
use super::{guard, nonnull, GimletSim, MPI_Comm, MPI_Fint};
use crate::comm::Comm;
use crate::error::{Error, Result};
use crate::io::{checkpoint, series, xdmf};
use std::ffi::CStr;
use std::os::raw::{c_char, c_int};
use std::path::Path;

/// A path argument as a `&str`: non-NULL, UTF-8, non-empty.
///
/// # Safety
/// `p` must be NULL or point to a NUL-terminated string.
unsafe fn text_arg<'a>(p: *const c_char, name: &str) -> Result<&'a str> {
    nonnull(p, name)?;
    let s = CStr::from_ptr(p)
        .to_str()
        .map_err(|_| Error::arg(format!("{name} is not valid UTF-8")))?;
    if s.is_empty() {
        return Err(Error::arg(format!("{name} is an empty string")));
    }
    check_path_len(s, name)?;
    Ok(s)
}

/// Refuses a path the system cannot take: longer than `PATH_MAX - 1` =
/// 4095 bytes, or with a component longer than `NAME_MAX` = 255 bytes.
/// (Long paths within these limits work: see `io::h5` for how they reach
/// MPI-IO.)
fn check_path_len(s: &str, name: &str) -> Result<()> {
    let max = crate::io::h5::PATH_MAX;
    if s.len() > max {
        return Err(Error::arg(format!(
            "{name} is {} bytes long, more than the {max} bytes a path may have",
            s.len()
        )));
    }
    if let Some(c) = s.split('/').find(|c| c.len() > 255) {
        return Err(Error::arg(format!(
            "{name} has a component of {} bytes, more than the 255 bytes a file name may have",
            c.len()
        )));
    }
    Ok(())
}

/// Opens the output series of the handle: files
/// `<dir>/<basename>_<step, 6 digits>.h5` and `<dir>/<basename>.xdmf`
/// (open the XDMF file in ParaView or VisIt to see the whole time series).
/// `dir` is created (with its parents) when missing. `basename` is a plain
/// file name (no `/`). When the handle has already taken steps (for example
/// after `gimlet_read_checkpoint`) and the XDMF file exists, the outputs it
/// lists up to the current step are kept and later ones dropped, so a
/// restarted run continues the series. Replaces any series opened before.
/// Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_output_open(
    sim: *mut GimletSim,
    dir: *const c_char,
    basename: *const c_char,
) -> c_int {
    let (d, b) = (Text(dir), Text(basename));
    collective_handle(
        "gimlet_output_open",
        sim,
        Args::new().with("dir", &d).with("basename", &b),
        |_| {
            let dir = text_arg(dir, "dir")?;
            let basename = text_arg(basename, "basename")?;
            series::check_basename(basename)?;
            Ok((dir, basename))
        },
        |h, (dir, basename)| {
            let s = &h.sim;
            let series = series::OutputSeries::open(s.comm(), Path::new(dir), basename, s.steps())?;
            h.outputs.series = Some(series);
            Ok(())
        },
    )
}

/// Writes the particles (position, velocity, stress, strain, half-lengths,
/// mass, contact pressure, plastic strain, level, patch, rank, global id,
/// and under `GIMLET_TRANSFER_APIC` the affine matrices) and the grid
/// layout (levels, boxes, patches, owners) of the current state to
/// `<dir>/<basename>_<step>.h5`, collectively through MPI-IO, and rewrites
/// `<dir>/<basename>.xdmf` to list every output of the series so far (an
/// output at a step already listed replaces it). Needs
/// `gimlet_output_open` first. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_write_output(sim: *mut GimletSim) -> c_int {
    collective_handle(
        "gimlet_write_output",
        sim,
        Args::new(),
        |h| {
            if h.outputs.series.is_none() {
                return Err(Error::state(
                    "no output series is open: call gimlet_output_open first",
                ));
            }
            Ok(())
        },
        |h, ()| {
            let Some(series) = &mut h.outputs.series else {
                return Err(Error::state(
                    "no output series is open: call gimlet_output_open first",
                ));
            };
            series.write(&h.sim).map(|_| ())
        },
    )
}

/// Opens the CSV time series at `path`: a header line `time, step,
/// indenter_displacement, indenter_force, indenter_force_x, contacts,
/// kinetic_energy, strain_energy, momentum_x, momentum_y, mass,
/// particles_level_0, ...` (the first indenter's depth, force and owned
/// contact particles, NaN for the indenter columns while no indenter
/// exists; forces, energies, momenta and mass per the thickness, in
/// axisymmetry the whole body's as `gimlet_indenter_state` and
/// `gimlet_diagnostics` report them; one count column per level). Open
/// it after the levels are defined. On a handle that has not stepped, the
/// file is created or truncated; on one that has (after a restart) an
/// existing file with the same header keeps its rows up to the current
/// step. Rank 0 writes. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_csv_open(sim: *mut GimletSim, path: *const c_char) -> c_int {
    let t = Text(path);
    collective_handle(
        "gimlet_csv_open",
        sim,
        Args::new().with("path", &t),
        |_| text_arg(path, "path"),
        |h, p| {
            let csv = series::csv_open(&h.sim, Path::new(p))?;
            h.outputs.csv = Some(csv);
            Ok(())
        },
    )
}

/// Appends one row of the current state to the CSV series (global sums;
/// numbers print so that they read back exactly). Needs `gimlet_csv_open`
/// first. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_csv_append(sim: *mut GimletSim) -> c_int {
    let none = || Error::state("no CSV series is open: call gimlet_csv_open first");
    collective_handle(
        "gimlet_csv_append",
        sim,
        Args::new(),
        |h| h.outputs.csv.as_ref().map(|_| ()).ok_or_else(none),
        |h, ()| {
            let csv = h.outputs.csv.as_ref().ok_or_else(none)?;
            series::csv_append(&h.sim, csv)
        },
    )
}

/// Writes a checkpoint of the whole state to `path`, atomically (the file
/// at `path`, if any, is replaced only once the new one is complete).
/// Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_write_checkpoint(
    sim: *mut GimletSim,
    path: *const c_char,
) -> c_int {
    let t = Text(path);
    collective(
        "gimlet_write_checkpoint",
        sim,
        Args::new().with("path", &t),
        |_| text_arg(path, "path"),
        |s, p| checkpoint::write(s, Path::new(p)),
    )
}

/// Replaces the whole state of the handle (layout, materials, run settings,
/// the indenters with their prescribed motions and the contact options,
/// time, step count, particles in their patch order with every field, lost
/// particles, counters) by the checkpoint at `path`; the handle keeps its
/// communicator and its output and CSV settings (outputs listed after the
/// checkpoint's step are dropped from the series). Continuing then gives
/// the uninterrupted run's result: bitwise on the number of ranks that wrote
/// the checkpoint, to round-off on another number (with contact solved by
/// PETSc, to its KSP tolerance: the first solve after a restart starts from
/// zero; PETSc's options database, `gimlet_set_petsc_options`, is the
/// process's and not stored). `gimlet_indenter_state` reports a zero force
/// until the first step. Checkpoints of format version 3 (before the
/// indenters were stored) are refused. On any failure (missing,
/// not HDF5, truncated, not a Gimlet checkpoint, another format version or
/// build, damaged content) returns `GIMLET_ERR_IO` with a message naming the
/// path and what was wrong, and the handle is unchanged. Collective.
#[no_mangle]
pub unsafe extern "C" fn gimlet_read_checkpoint(sim: *mut GimletSim, path: *const c_char) -> c_int {
    let t = Text(path);
    collective_handle(
        "gimlet_read_checkpoint",
        sim,
        Args::new().with("path", &t),
        |_| text_arg(path, "path"),
        |h, p| {
            let s = &mut h.sim;
            let fresh = checkpoint::read(Comm::dup(s.comm().raw())?, Path::new(p))?;
            s.replace_state(fresh);
            if let Some(series) = &mut h.outputs.series {
                series.forget_after(s.steps());
            }
            Ok(())
        },
    )
}

fn create_from(
    name: &str,
    comm: Result<Comm>,
    path: *const c_char,
    out: *mut *mut GimletSim,
) -> Result<()> {
    let t = Text(path);
    create_on(
        comm,
        name,
        Args::new().with("path", &t),
        out,
        // SAFETY: the caller passes NULL or a NUL-terminated string.
        || unsafe { text_arg(path, "path") },
        |c, p| checkpoint::read(c, Path::new(p)),
    )
}

/// Creates a simulation on a duplicate of `comm` from the checkpoint at
/// `path` (any number of ranks; see `gimlet_read_checkpoint`). On success
/// `*out` receives the handle; on failure (`GIMLET_ERR_IO` for a rejected
/// file) `*out` is unchanged. Collective over `comm`.
#[no_mangle]
pub unsafe extern "C" fn gimlet_create_from_checkpoint(
    comm: MPI_Comm,
    path: *const c_char,
    out: *mut *mut GimletSim,
) -> c_int {
    guard("gimlet_create_from_checkpoint", || {
        create_from("gimlet_create_from_checkpoint", Comm::dup(comm), path, out)
    })
}

/// As `gimlet_create_from_checkpoint`, with the communicator given by its
/// Fortran handle.
#[no_mangle]
pub unsafe extern "C" fn gimlet_create_from_checkpoint_f(
    fcomm: MPI_Fint,
    path: *const c_char,
    out: *mut *mut GimletSim,
) -> c_int {
    guard("gimlet_create_from_checkpoint_f", || {
        create_from(
            "gimlet_create_from_checkpoint_f",
            Comm::from_fortran(fcomm),
            path,
            out,
        )
    })
}

/// Checks the XDMF file at `path` against the HDF5 files it names: every
/// dataset it references exists with the stated dimensions and number type,
/// and its first dimension equals its grid's element count. `*items`
/// receives the number of datasets checked. Returns `GIMLET_ERR_IO` naming
/// the first mismatch. Collective (the HDF5 files are opened collectively
/// over the handle's communicator).
#[no_mangle]
pub unsafe extern "C" fn gimlet_check_xdmf(
    sim: *mut GimletSim,
    path: *const c_char,
    items: *mut i64,
) -> c_int {
    let t = Text(path);
    collective(
        "gimlet_check_xdmf",
        sim,
        Args::new().with("path", &t),
        |_| {
            nonnull(items, "items")?;
            text_arg(path, "path")
        },
        |s, p| {
            let n = xdmf::check(s.comm(), Path::new(p))?;
            *items = n as i64;
            Ok(())
        },
    )
}
