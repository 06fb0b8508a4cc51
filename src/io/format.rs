//! The format tag every Gimlet HDF5 file carries, and its check on open.
//!
//! The root group of every file holds a string attribute [`FORMAT_ATTR`]
//! (`"gimlet-checkpoint"` or `"gimlet-output"`) and an integer attribute
//! [`VERSION_ATTR`]. [`open`] rejects, with a `Status::Io` error naming the
//! path and what was expected: a file that is not HDF5, an HDF5 file without
//! the tag (a foreign file), a truncated file, a file of the other kind, and a
//! version mismatch.

use super::h5::{Attributes, File};
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use std::path::Path;

/// Name of the root attribute holding the file kind.
pub const FORMAT_ATTR: &str = "gimlet_format";
/// Name of the root attribute holding the format version.
pub const VERSION_ATTR: &str = "gimlet_format_version";
/// The format version of checkpoints this library writes and reads (2:
/// every dataset carries a digest and the settings a digest, see
/// `checkpoint`; checkpoints of version 1 had none and are refused; 3: the
/// particles' APIC matrix `cxx, cxy, cyx, cyy` and the run's `transfer`,
/// which version-2 files lack; 4: the indenters and contact options,
/// `/contact`, which version-3 files lack; 5: the geometry (plane strain
/// or axisymmetry) and the particles' hoop stretch `fzz`).
pub const FORMAT_VERSION: i64 = 5;

/// The format version of output files this library writes and reads.
pub const OUTPUT_VERSION: i64 = 1;

/// What a Gimlet HDF5 file is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// A restart file: everything needed to continue a run exactly.
    Checkpoint,
    /// A visualisation snapshot (read through XDMF).
    Output,
}

impl FileKind {
    /// The value of [`FORMAT_ATTR`] for this kind.
    pub fn tag(self) -> &'static str {
        match self {
            FileKind::Checkpoint => "gimlet-checkpoint",
            FileKind::Output => "gimlet-output",
        }
    }

    /// The format version of this kind ([`FORMAT_VERSION`] for checkpoints,
    /// [`OUTPUT_VERSION`] for outputs).
    pub fn version(self) -> i64 {
        match self {
            FileKind::Checkpoint => FORMAT_VERSION,
            FileKind::Output => OUTPUT_VERSION,
        }
    }
}

/// Creates `path` collectively and writes the format tag for `kind`.
pub fn create<'c>(comm: &'c Comm, path: &Path, kind: FileKind) -> Result<File<'c>> {
    let f = File::create(comm, path)?;
    write_tag(&f, kind, kind.version())?;
    Ok(f)
}

/// As [`create`], with the file's metadata in HDF5's 1.8 format or later,
/// whose superblock and object headers carry checksums that HDF5 checks
/// when it reads them (used for checkpoints).
pub fn create_checksummed<'c>(comm: &'c Comm, path: &Path, kind: FileKind) -> Result<File<'c>> {
    let f = File::create_checksummed(comm, path)?;
    write_tag(&f, kind, kind.version())?;
    Ok(f)
}

/// Writes the format tag (kind and `version`) on the root group of `file`.
pub fn write_tag(file: &File, kind: FileKind, version: i64) -> Result<()> {
    let root = file.root()?;
    root.set_attr_str(FORMAT_ATTR, kind.tag())?;
    root.set_attr(VERSION_ATTR, version)
}

/// Opens `path` collectively and checks it is a `kind` file of its
/// format version ([`FileKind::version`]).
pub fn open<'c>(comm: &'c Comm, path: &Path, kind: FileKind) -> Result<File<'c>> {
    let expected = || format!("a {} file of format version {}", kind.tag(), kind.version());
    let f = File::open(comm, path)
        .map_err(|e| Error::new(Status::Io, format!("{}; expected {}", e.msg, expected())))?;
    validate(&f, kind, kind.version())?;
    Ok(f)
}

/// Checks the format tag of an open file against `kind` and `version`.
pub fn validate(file: &File, kind: FileKind, version: i64) -> Result<()> {
    let p = file.path().display();
    let fail = |what: String| {
        Err(Error::new(
            Status::Io,
            format!(
                "'{p}' {what}; expected a {} file of format version {version}",
                kind.tag()
            ),
        ))
    };
    let root = file.root()?;
    if !root.has_attr(FORMAT_ATTR)? {
        return fail(format!(
            "is an HDF5 file but not a Gimlet file (no '{FORMAT_ATTR}' attribute)"
        ));
    }
    let tag = match root.attr_str(FORMAT_ATTR) {
        Ok(t) => t,
        Err(_) => {
            return fail(format!(
                "has a '{FORMAT_ATTR}' attribute that is not a string"
            ))
        }
    };
    if tag != kind.tag() {
        return fail(format!("is a '{tag}' file"));
    }
    let v = match root.attr::<i64>(VERSION_ATTR) {
        Ok(v) => v,
        Err(_) => return fail(format!("has no integer '{VERSION_ATTR}' attribute")),
    };
    if v != version {
        return fail(format!("has format version {v}"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_differ_and_name_the_kind() {
        assert_eq!(FileKind::Checkpoint.tag(), "gimlet-checkpoint");
        assert_eq!(FileKind::Output.tag(), "gimlet-output");
    }
}
