//! XDMF 3 descriptions of particle snapshots, for ParaView and VisIt.
//!
//! A series is a temporal collection of uniform grids, one per output time,
//! each naming datasets inside that time's HDF5 file: `Polyvertex` topology
//! (one vertex per particle), `XY` geometry from an `(n × 2)` dataset, and
//! attributes (scalars from 1D datasets; `Vector` for 3 columns, `Tensor6`
//! for 6, `Tensor` for 9, `Matrix` otherwise). Integer attributes such as
//! `level`, `patch`, `rank`, `id` let a viewer colour by them; store them as
//! `i32`/`i64` (some readers do not accept 64-bit unsigned integers).
//!
//! [`write`] renders the series on rank 0 and replaces the file atomically;
//! [`check`] verifies that every dataset an XDMF file names exists with the
//! stated dimensions and number type.

use super::atomic::write_atomic;
use super::csv::format_value;
use super::h5::{File, H5Type, NumKind};
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// A dataset inside an HDF5 file, with the shape and type XDMF states.
#[derive(Clone, Debug, PartialEq)]
pub struct DataRef {
    /// Absolute path of the dataset inside its HDF5 file (`/particles/x`).
    pub dataset: String,
    /// Dimensions: `[n]` or `[n, k]`.
    pub dims: Vec<u64>,
    /// Number kind of the stored elements.
    pub kind: NumKind,
    /// Bytes per element (1, 4 or 8).
    pub size: usize,
}

impl DataRef {
    /// A reference to a dataset of element type `T` with dimensions `dims`.
    pub fn new<T: H5Type>(dataset: &str, dims: &[u64]) -> DataRef {
        DataRef {
            dataset: dataset.to_string(),
            dims: dims.to_vec(),
            kind: T::KIND,
            size: std::mem::size_of::<T>(),
        }
    }

    fn number_type(&self) -> &'static str {
        match (self.kind, self.size) {
            (NumKind::Float, _) => "Float",
            (NumKind::Int, 1) => "Char",
            (NumKind::UInt, 1) => "UChar",
            (NumKind::Int, _) => "Int",
            (NumKind::UInt, _) => "UInt",
        }
    }
}

/// One named attribute of a snapshot.
#[derive(Clone, Debug, PartialEq)]
pub struct XdmfAttribute {
    /// The name a viewer shows.
    pub name: String,
    /// The dataset holding it (`[n]` for a scalar, `[n, k]` otherwise).
    pub data: DataRef,
}

/// One output time: an HDF5 file with the particles at time `time`.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// Simulation time.
    pub time: f64,
    /// The HDF5 file, relative to the XDMF file's directory (or absolute).
    pub file: String,
    /// Number of particles.
    pub n: u64,
    /// Positions, an `(n × 2)` dataset.
    pub geometry: DataRef,
    /// Attributes to colour by.
    pub attributes: Vec<XdmfAttribute>,
}

fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

fn attribute_type(dims: &[u64]) -> &'static str {
    match dims {
        [_] | [_, 1] => "Scalar",
        [_, 3] => "Vector",
        [_, 6] => "Tensor6",
        [_, 9] => "Tensor",
        _ => "Matrix",
    }
}

fn data_item(out: &mut String, indent: &str, file: &str, d: &DataRef) {
    let dims: Vec<String> = d.dims.iter().map(|v| v.to_string()).collect();
    let _ = writeln!(
        out,
        "{indent}<DataItem Dimensions=\"{}\" NumberType=\"{}\" Precision=\"{}\" Format=\"HDF\">{}:{}</DataItem>",
        dims.join(" "),
        d.number_type(),
        d.size,
        escape(file),
        escape(&d.dataset)
    );
}

/// The XDMF 3 text for `series` (a temporal collection named `particles`).
pub fn render(series: &[Snapshot]) -> String {
    let mut s = String::new();
    s.push_str("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n");
    s.push_str(
        "    <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
    );
    for (i, snap) in series.iter().enumerate() {
        let _ = writeln!(s, "      <Grid Name=\"snapshot_{i}\" GridType=\"Uniform\">");
        let _ = writeln!(s, "        <Time Value=\"{}\"/>", format_value(snap.time));
        let _ = writeln!(
            s,
            "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{}\" NodesPerElement=\"1\"/>",
            snap.n
        );
        s.push_str("        <Geometry GeometryType=\"XY\">\n");
        data_item(&mut s, "          ", &snap.file, &snap.geometry);
        s.push_str("        </Geometry>\n");
        for a in &snap.attributes {
            let _ = writeln!(
                s,
                "        <Attribute Name=\"{}\" AttributeType=\"{}\" Center=\"Node\">",
                escape(&a.name),
                attribute_type(&a.data.dims)
            );
            data_item(&mut s, "          ", &snap.file, &a.data);
            s.push_str("        </Attribute>\n");
        }
        s.push_str("      </Grid>\n");
    }
    s.push_str("    </Grid>\n  </Domain>\n</Xdmf>\n");
    s
}

/// Renders `series` and writes it to `path` on rank 0, replacing any previous
/// file atomically. Collective over `comm`.
pub fn write(comm: &Comm, path: &Path, series: &[Snapshot]) -> Result<()> {
    let text = if comm.rank() == 0 {
        render(series)
    } else {
        String::new()
    };
    write_atomic(comm, path, |tmp| {
        if comm.rank() == 0 {
            std::fs::write(tmp, text.as_bytes()).map_err(|e| {
                Error::new(
                    Status::Io,
                    format!("writing XDMF file '{}' failed: {e}", path.display()),
                )
            })?;
        }
        Ok(())
    })
}

/// A heavy-data reference found in an XDMF file.
#[derive(Clone, Debug, PartialEq)]
pub struct ParsedItem {
    /// The HDF5 file as written in the XDMF text.
    pub file: String,
    /// What the XDMF says about the dataset.
    pub data: DataRef,
    /// `NumberOfElements` of the enclosing grid's topology, if any.
    pub elements: Option<u64>,
}

/// The value of `key="..."` inside one tag's text.
fn attr_value(tag: &str, key: &str) -> Option<String> {
    let pat = format!(" {key}=\"");
    let start = tag.find(&pat)? + pat.len();
    let end = tag[start..].find('"')? + start;
    Some(unescape(&tag[start..end]))
}

/// Extracts every HDF5 `DataItem` of an XDMF text written by [`render`] (or of
/// the same shape), with the enclosing grid's element count.
pub fn parse(text: &str) -> std::result::Result<Vec<ParsedItem>, String> {
    let mut items = Vec::new();
    let mut elements = None;
    let mut rest = text;
    while let Some(lt) = rest.find('<') {
        rest = &rest[lt..];
        let gt = rest.find('>').ok_or("a tag is not closed")?;
        let tag = &rest[..=gt];
        if tag.starts_with("<Grid ") && attr_value(tag, "GridType").as_deref() == Some("Uniform") {
            elements = None;
        } else if tag.starts_with("<Topology ") {
            elements = attr_value(tag, "NumberOfElements")
                .map(|v| {
                    v.trim()
                        .parse::<u64>()
                        .map_err(|_| format!("bad NumberOfElements '{v}'"))
                })
                .transpose()?;
        } else if tag.starts_with("<DataItem") {
            let body_end = rest.find("</DataItem>").ok_or("a DataItem is not closed")?;
            let body = unescape(rest[gt + 1..body_end].trim());
            let format = attr_value(tag, "Format").unwrap_or_else(|| "XML".into());
            if format != "HDF" {
                return Err(format!("DataItem '{body}' has Format '{format}', not HDF"));
            }
            let (file, dataset) = body
                .rsplit_once(':')
                .ok_or_else(|| format!("DataItem '{body}' is not of the form file:/dataset"))?;
            let dims = attr_value(tag, "Dimensions")
                .ok_or_else(|| format!("DataItem '{body}' has no Dimensions"))?
                .split_whitespace()
                .map(|v| {
                    v.parse::<u64>()
                        .map_err(|_| format!("DataItem '{body}' has bad Dimensions"))
                })
                .collect::<std::result::Result<Vec<u64>, String>>()?;
            let nt = attr_value(tag, "NumberType").unwrap_or_else(|| "Float".into());
            let size: usize = attr_value(tag, "Precision")
                .unwrap_or_else(|| "4".into())
                .parse()
                .map_err(|_| format!("DataItem '{body}' has a bad Precision"))?;
            let kind = match nt.as_str() {
                "Float" => NumKind::Float,
                "Int" | "Char" => NumKind::Int,
                "UInt" | "UChar" => NumKind::UInt,
                other => {
                    return Err(format!(
                        "DataItem '{body}' has unknown NumberType '{other}'"
                    ))
                }
            };
            let size = if nt.ends_with("Char") { 1 } else { size };
            items.push(ParsedItem {
                file: file.to_string(),
                data: DataRef {
                    dataset: dataset.to_string(),
                    dims,
                    kind,
                    size,
                },
                elements,
            });
        }
        rest = &rest[gt + 1..];
    }
    Ok(items)
}

/// Checks the XDMF file at `path` against the HDF5 files it names: every
/// referenced dataset exists with exactly the stated dimensions and number
/// type, and its first dimension equals its grid's element count. Returns how
/// many datasets were checked. Collective over `comm` (the HDF5 files are
/// opened collectively).
pub fn check(comm: &Comm, path: &Path) -> Result<usize> {
    let fail = |m: String| Error::new(Status::Io, format!("XDMF file '{}': {m}", path.display()));
    let text = std::fs::read_to_string(path).map_err(|e| fail(format!("cannot be read: {e}")))?;
    let items = parse(&text).map_err(fail)?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut by_file: BTreeMap<&str, Vec<&ParsedItem>> = BTreeMap::new();
    for it in &items {
        by_file.entry(it.file.as_str()).or_default().push(it);
    }
    for (file, its) in by_file {
        let h5 = dir.join(file);
        let f = File::open(comm, &h5).map_err(|e| fail(e.msg))?;
        let root = f.root()?;
        for it in its {
            let d = &it.data;
            let name = &d.dataset;
            if !root.exists(name)? {
                return Err(fail(format!(
                    "dataset '{name}' is missing from '{}'",
                    h5.display()
                )));
            }
            let dims = root.dims(name)?;
            if dims != d.dims {
                return Err(fail(format!(
                    "dataset '{name}' in '{}' has dimensions {dims:?} but the XDMF states {:?}",
                    h5.display(),
                    d.dims
                )));
            }
            let ty = root.stored_type(name)?;
            if ty != Some((d.kind, d.size)) {
                return Err(fail(format!(
                    "dataset '{name}' in '{}' holds {ty:?} but the XDMF states {:?} of {} bytes",
                    h5.display(),
                    d.kind,
                    d.size
                )));
            }
            if let Some(n) = it.elements {
                if d.dims.first() != Some(&n) {
                    return Err(fail(format!(
                        "dataset '{name}' has {:?} rows but its grid has {n} elements",
                        d.dims.first()
                    )));
                }
            }
        }
    }
    Ok(items.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snap(t: f64, n: u64) -> Snapshot {
        Snapshot {
            time: t,
            file: format!("out_{t}.h5"),
            n,
            geometry: DataRef::new::<f64>("/particles/xy", &[n, 2]),
            attributes: vec![
                XdmfAttribute {
                    name: "level".into(),
                    data: DataRef::new::<i32>("/particles/level", &[n]),
                },
                XdmfAttribute {
                    name: "id".into(),
                    data: DataRef::new::<i64>("/particles/id", &[n]),
                },
                XdmfAttribute {
                    name: "stress".into(),
                    data: DataRef::new::<f64>("/particles/stress", &[n, 4]),
                },
                XdmfAttribute {
                    name: "v<&>".into(),
                    data: DataRef::new::<f64>("/particles/v", &[n, 3]),
                },
                XdmfAttribute {
                    name: "m".into(),
                    data: DataRef::new::<u8>("/particles/m", &[n]),
                },
            ],
        }
    }

    #[test]
    fn render_then_parse_gives_back_every_reference() {
        let series = vec![snap(0.0, 5), snap(1.25e-3, 7)];
        let text = render(&series);
        let items = parse(&text).unwrap();
        assert_eq!(items.len(), 2 * 6);
        let mut k = 0;
        for s in &series {
            let want = std::iter::once(&s.geometry).chain(s.attributes.iter().map(|a| &a.data));
            for d in want {
                assert_eq!(items[k].file, s.file);
                assert_eq!(&items[k].data, d);
                assert_eq!(items[k].elements, Some(s.n));
                k += 1;
            }
        }
    }

    #[test]
    fn render_states_types_times_and_escapes_names() {
        let text = render(&[snap(1.25e-3, 3)]);
        assert!(text.contains("<Time Value=\"1.25e-3\"/>"));
        assert!(text.contains("TopologyType=\"Polyvertex\" NumberOfElements=\"3\""));
        assert!(text.contains("Name=\"stress\" AttributeType=\"Matrix\""));
        assert!(text.contains("Name=\"v&lt;&amp;&gt;\" AttributeType=\"Vector\""));
        assert!(text.contains("Dimensions=\"3\" NumberType=\"Int\" Precision=\"4\""));
        assert!(text.contains("Dimensions=\"3\" NumberType=\"UChar\" Precision=\"1\""));
        // Times print with round-trip precision.
        let t = 0.1f64 + 0.2;
        let text = render(&[snap(t, 1)]);
        let v = attr_value(&text[text.find("<Time").unwrap()..], "Value").unwrap();
        assert_eq!(v.parse::<f64>().unwrap(), t);
    }

    #[test]
    fn parse_rejects_non_hdf_items() {
        let bad =
            "<Grid GridType=\"Uniform\"><DataItem Dimensions=\"2\" Format=\"XML\">1 2</DataItem>";
        assert!(parse(bad).unwrap_err().contains("not HDF"));
    }
}
