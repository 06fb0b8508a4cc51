//! A time-series CSV writer: one header line of column names given by the
//! caller, then one line of numbers per call. Rank 0 writes; every call is
//! collective so that all ranks agree on success. Numbers print so that they
//! read back exactly: integers up to 2^53 as integers, everything else as the
//! shortest round-trip exponent form (`1.25e-3`).

use super::agree;
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use std::fs::OpenOptions;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// A CSV file of a time series, written by rank 0.
#[derive(Debug)]
pub struct CsvSeries {
    path: PathBuf,
    columns: Vec<String>,
}

/// Formats one value so that parsing it gives back the same `f64`.
pub fn format_value(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 9.007_199_254_740_992e15 {
        // Exactly representable integer: print without exponent or point
        // (`-0.0` prints as `-0`, which also reads back as -0.0).
        format!("{}", v)
    } else {
        format!("{:e}", v)
    }
}

/// The header line (without newline) for `columns`.
fn header(columns: &[String]) -> String {
    columns.join(",")
}

fn check_columns(columns: &[&str]) -> Result<Vec<String>> {
    if columns.is_empty() {
        return Err(Error::arg("a CSV series needs at least one column"));
    }
    for c in columns {
        if c.is_empty() || c.contains([',', '\n', '\r', '"']) {
            return Err(Error::arg(format!(
                "CSV column name '{c}' must be non-empty and contain no comma, quote or newline"
            )));
        }
    }
    Ok(columns.iter().map(|c| c.to_string()).collect())
}

impl CsvSeries {
    /// Creates (or truncates) `path` and writes the header. Collective.
    pub fn create(comm: &Comm, path: &Path, columns: &[&str]) -> Result<CsvSeries> {
        let columns = check_columns(columns)?;
        let s = CsvSeries {
            path: path.to_path_buf(),
            columns,
        };
        let local = if comm.rank() == 0 {
            std::fs::write(path, format!("{}\n", header(&s.columns)))
                .map_err(|e| s.err("creating", e))
        } else {
            Ok(())
        };
        agree(comm, local)?;
        Ok(s)
    }

    /// Continues an existing series at `path` (after a restart) without
    /// rewriting any of it: the header must equal `columns`. A missing file is
    /// created with the header. When the last line was cut short (no final
    /// newline), a newline is appended so new rows start on their own line.
    /// Collective.
    pub fn append_to(comm: &Comm, path: &Path, columns: &[&str]) -> Result<CsvSeries> {
        let columns = check_columns(columns)?;
        let exists = comm.any(comm.rank() == 0 && path.exists())?;
        if !exists {
            return Self::create(
                comm,
                path,
                &columns.iter().map(String::as_str).collect::<Vec<_>>(),
            );
        }
        let s = CsvSeries {
            path: path.to_path_buf(),
            columns,
        };
        let local = if comm.rank() == 0 { s.reopen() } else { Ok(()) };
        agree(comm, local)?;
        Ok(s)
    }

    fn err(&self, doing: &str, e: std::io::Error) -> Error {
        Error::new(
            Status::Io,
            format!("{doing} CSV file '{}' failed: {e}", self.path.display()),
        )
    }

    fn reopen(&self) -> Result<()> {
        let mut f = OpenOptions::new()
            .read(true)
            .append(true)
            .open(&self.path)
            .map_err(|e| self.err("opening", e))?;
        let mut text = String::new();
        f.read_to_string(&mut text)
            .map_err(|e| self.err("reading", e))?;
        let first = text.lines().next().unwrap_or("");
        let want = header(&self.columns);
        if first != want {
            return Err(Error::new(
                Status::Io,
                format!(
                    "CSV file '{}' has header '{first}' but '{want}' was expected; not appending to it",
                    self.path.display()
                ),
            ));
        }
        if !text.ends_with('\n') {
            f.seek(SeekFrom::End(0))
                .map_err(|e| self.err("seeking in", e))?;
            f.write_all(b"\n")
                .map_err(|e| self.err("appending to", e))?;
        }
        Ok(())
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The column names.
    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    /// Appends one row; `values` must have one number per column (the same on
    /// every rank; rank 0's are written). Collective.
    pub fn row(&self, comm: &Comm, values: &[f64]) -> Result<()> {
        if values.len() != self.columns.len() {
            return Err(Error::arg(format!(
                "CSV row for '{}' has {} values but the series has {} columns",
                self.path.display(),
                values.len(),
                self.columns.len()
            )));
        }
        let local = if comm.rank() == 0 {
            let line: Vec<String> = values.iter().map(|&v| format_value(v)).collect();
            OpenOptions::new()
                .append(true)
                .open(&self.path)
                .and_then(|mut f| f.write_all(format!("{}\n", line.join(",")).as_bytes()))
                .map_err(|e| self.err("appending to", e))
        } else {
            Ok(())
        };
        agree(comm, local)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_read_back_exactly() {
        let vals = [
            0.0,
            -0.0,
            1.0,
            -42.0,
            0.1 + 0.2,
            1.0 / 3.0,
            6.02214076e23,
            -1.602176634e-19,
            f64::MIN_POSITIVE,
            f64::MAX,
            9.007_199_254_740_993e15,
            123456789.0,
        ];
        for v in vals {
            let s = format_value(v);
            let back: f64 = s.parse().unwrap();
            assert_eq!(back.to_bits(), v.to_bits(), "{v} printed as {s}");
        }
        assert_eq!(format_value(12.0), "12");
        assert_eq!(format_value(1.25e-3), "1.25e-3");
    }

    #[test]
    fn column_names_are_checked() {
        assert!(check_columns(&[]).is_err());
        assert!(check_columns(&["a,b"]).is_err());
        assert_eq!(
            check_columns(&["time", "force"]).unwrap(),
            vec!["time", "force"]
        );
    }
}
