//! A small safe wrapper over `hdf5-sys` for parallel (MPI-IO) HDF5 files.
//!
//! Every call here is **collective** over the communicator the file was
//! opened with: all ranks call the same functions with the same names in the
//! same order (attribute values must also be identical on every rank). Ranks
//! contribute different amounts of data only to [`Group::write`],
//! [`Group::write_2d`] and [`Group::read_rows`]; a rank with nothing to
//! contribute still calls them (it selects nothing).
//!
//! Every failing HDF5 call becomes an [`Error`] with status [`Status::Io`]
//! naming the file and the object. HDF5's automatic error printing is switched
//! off, so the library never prints unasked. Every HDF5 handle is closed by a
//! drop guard on all paths.

use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use hdf5_sys::h5::{herr_t, hsize_t};
use hdf5_sys::h5a::{
    H5Aclose, H5Acreate2, H5Adelete, H5Aexists, H5Aget_space, H5Aget_type, H5Aopen, H5Aread,
    H5Awrite,
};
use hdf5_sys::h5d::{H5Dclose, H5Dcreate2, H5Dget_space, H5Dget_type, H5Dopen2, H5Dread, H5Dwrite};
use hdf5_sys::h5e::{
    H5E_direction_t, H5E_error2_t, H5Eclear2, H5Eset_auto2, H5Ewalk2, H5E_DEFAULT,
};
use hdf5_sys::h5f::{H5Fclose, H5Fcreate, H5Fis_hdf5, H5Fopen, H5F_ACC_RDONLY, H5F_ACC_TRUNC};
use hdf5_sys::h5g::{H5Gclose, H5Gcreate2, H5Gopen2};
use hdf5_sys::h5i::hid_t;
use hdf5_sys::h5l::H5Lexists;
use hdf5_sys::h5p::{
    H5Pclose, H5Pcreate, H5Pset_create_intermediate_group, H5P_CLS_DATASET_XFER,
    H5P_CLS_FILE_ACCESS, H5P_CLS_LINK_CREATE, H5P_DEFAULT,
};
use hdf5_sys::h5s::{
    H5S_class_t, H5S_seloper_t, H5Sclose, H5Screate, H5Screate_simple, H5Sget_simple_extent_dims,
    H5Sget_simple_extent_ndims, H5Sselect_hyperslab, H5Sselect_none,
};
use hdf5_sys::h5t::{
    H5T_class_t, H5T_sign_t, H5Tclose, H5Tcopy, H5Tget_class, H5Tget_sign, H5Tget_size,
    H5Tis_variable_str, H5Tset_size, H5T_C_S1,
};
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int, c_uint, c_void};
use std::path::{Path, PathBuf};
use std::ptr;
use std::sync::Once;

// Declared here rather than through hdf5-sys's `mpio` feature, which pulls an
// mpi-sys version that conflicts with ours (see docs/ARCHITECTURE.md,
// "Dependencies").
extern "C" {
    fn H5Pset_fapl_mpio(fapl: hid_t, comm: mpi_sys::MPI_Comm, info: mpi_sys::MPI_Info) -> herr_t;
    fn H5Pset_dxpl_mpio(dxpl: hid_t, xfer_mode: c_int) -> herr_t;
}
/// `H5FD_MPIO_COLLECTIVE` of `H5FD_mpio_xfer_t` in `H5FDmpio.h`.
const H5FD_MPIO_COLLECTIVE: c_int = 1;

static INIT: Once = Once::new();

/// Opens the HDF5 library and silences its automatic error printing.
fn init() {
    INIT.call_once(|| {
        // SAFETY: H5open is idempotent; a null handler disables printing on
        // the default error stack.
        unsafe {
            hdf5_sys::h5::H5open();
            H5Eset_auto2(H5E_DEFAULT, None, ptr::null_mut());
        }
    });
}

fn io_err(msg: String) -> Error {
    Error::new(Status::Io, msg)
}

/// Records the innermost entry of the HDF5 error stack (walk index 0).
unsafe extern "C" fn innermost(n: c_uint, e: *const H5E_error2_t, out: *mut c_void) -> herr_t {
    if n == 0 && !e.is_null() {
        let out = &mut *(out as *mut String);
        let text = |p: *const c_char| {
            if p.is_null() {
                String::new()
            } else {
                CStr::from_ptr(p).to_string_lossy().into_owned()
            }
        };
        *out = format!("{} ({})", text((*e).desc), text((*e).func_name));
    }
    0
}

/// An `Io` error for a failed HDF5 call: `msg`, plus HDF5's own innermost
/// reason when the library recorded one (the error stack is then cleared).
fn h5_err(msg: String) -> Error {
    let mut detail = String::new();
    // SAFETY: the callback only writes into `detail` while H5Ewalk2 runs.
    unsafe {
        H5Ewalk2(
            H5E_DEFAULT,
            H5E_direction_t::H5E_WALK_UPWARD,
            Some(innermost),
            &mut detail as *mut String as *mut c_void,
        );
        H5Eclear2(H5E_DEFAULT);
    }
    if detail.is_empty() {
        io_err(msg)
    } else {
        io_err(format!("{msg}: {detail}"))
    }
}

/// An HDF5 identifier with the function that closes it; closed on drop.
struct Hid {
    id: hid_t,
    close: unsafe extern "C" fn(hid_t) -> herr_t,
}

impl Hid {
    /// Wraps `id`, or fails with `what()` when HDF5 returned a negative id.
    fn new(
        id: hid_t,
        close: unsafe extern "C" fn(hid_t) -> herr_t,
        what: impl FnOnce() -> String,
    ) -> Result<Hid> {
        if id < 0 {
            Err(h5_err(what()))
        } else {
            Ok(Hid { id, close })
        }
    }

    /// Closes now and reports a failure (drop would ignore it).
    fn close_checked(mut self, what: impl FnOnce() -> String) -> Result<()> {
        let id = std::mem::replace(&mut self.id, -1);
        // SAFETY: id is a valid open identifier owned by self, closed once.
        if unsafe { (self.close)(id) } < 0 {
            return Err(h5_err(what()));
        }
        Ok(())
    }
}

impl Drop for Hid {
    fn drop(&mut self) {
        if self.id >= 0 {
            // SAFETY: id is a valid open identifier owned by self.
            unsafe { (self.close)(self.id) };
        }
    }
}

fn check(rc: herr_t, what: impl FnOnce() -> String) -> Result<()> {
    if rc < 0 {
        Err(h5_err(what()))
    } else {
        Ok(())
    }
}

fn cstr(s: &str, what: &str) -> Result<CString> {
    CString::new(s).map_err(|_| Error::arg(format!("{what} '{s}' contains a NUL byte")))
}

/// Kinds of numbers an HDF5 dataset or attribute can hold here.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NumKind {
    /// IEEE floating point.
    Float,
    /// Signed integer.
    Int,
    /// Unsigned integer.
    UInt,
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for f64 {}
    impl Sealed for u64 {}
    impl Sealed for i64 {}
    impl Sealed for i32 {}
    impl Sealed for u8 {}
}

/// Element types that can be stored: `f64`, `u64`, `i64`, `i32`, `u8`.
pub trait H5Type: Copy + Default + sealed::Sealed {
    /// Name for messages (`"f64"`, ...).
    const NAME: &'static str;
    /// The number kind (for type checks on read).
    const KIND: NumKind;
    /// The native HDF5 memory type.
    fn native() -> hid_t;
}

macro_rules! h5type {
    ($t:ty, $name:literal, $kind:ident, $native:ident) => {
        impl H5Type for $t {
            const NAME: &'static str = $name;
            const KIND: NumKind = NumKind::$kind;
            fn native() -> hid_t {
                init();
                // The library is open (init), so the global type ids are set.
                *hdf5_sys::h5t::$native
            }
        }
    };
}
h5type!(f64, "f64", Float, H5T_NATIVE_DOUBLE);
h5type!(u64, "u64", UInt, H5T_NATIVE_UINT64);
h5type!(i64, "i64", Int, H5T_NATIVE_INT64);
h5type!(i32, "i32", Int, H5T_NATIVE_INT32);
h5type!(u8, "u8", UInt, H5T_NATIVE_UINT8);

/// The number kind and byte size of a stored type, `None` for non-numbers.
fn type_info(tid: hid_t) -> Option<(NumKind, usize)> {
    // SAFETY: tid is a valid datatype identifier.
    let (class, size, sign) = unsafe { (H5Tget_class(tid), H5Tget_size(tid), H5Tget_sign(tid)) };
    let kind = match class {
        H5T_class_t::H5T_FLOAT => NumKind::Float,
        H5T_class_t::H5T_INTEGER if sign == H5T_sign_t::H5T_SGN_NONE => NumKind::UInt,
        H5T_class_t::H5T_INTEGER => NumKind::Int,
        _ => return None,
    };
    Some((kind, size))
}

/// Reads a stored type's description for messages (`"f64"`, `"u32"`, ...).
fn type_name(info: Option<(NumKind, usize)>) -> String {
    match info {
        Some((k, s)) => {
            let p = match k {
                NumKind::Float => "f",
                NumKind::Int => "i",
                NumKind::UInt => "u",
            };
            format!("{p}{}", 8 * s)
        }
        None => "a non-numeric type".to_string(),
    }
}

/// Where a rank's rows landed in a distributed dataset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slab {
    /// First row written by this rank.
    pub offset: u64,
    /// Rows written by this rank.
    pub count: u64,
    /// Rows in the whole dataset.
    pub total: u64,
}

/// The rows `[offset, offset + count)` rank `rank` of `size` reads when
/// `total` rows are split as evenly as possible (the first `total % size`
/// ranks get one more).
pub fn split_even(total: u64, rank: i32, size: i32) -> (u64, u64) {
    let (r, p) = (rank as u64, size.max(1) as u64);
    let base = total / p;
    let extra = total % p;
    let count = base + u64::from(r < extra);
    (r * base + r.min(extra), count)
}

/// An open parallel HDF5 file. Closed on drop; [`File::close`] reports errors.
pub struct File<'c> {
    id: Hid,
    path: PathBuf,
    comm: &'c Comm,
    /// The descriptor behind a `/proc/self/fd` name given to MPI-IO (see
    /// [`mpio_name`]); kept open while the file is.
    _alias: Option<std::fs::File>,
}

/// Longest path handed to MPI-IO as it is. Open MPI 4.1's OMPIO queries
/// every shared-file-pointer (`sharedfp`) component on each
/// `MPI_File_open`; the `lockedfile` component's query writes the path plus
/// `.locktest.<rank>` into a 256-byte stack buffer with `sprintf`, which
/// aborts the process ("buffer overflow detected") for paths of about 240
/// bytes and more. No per-file hint skips the query (the
/// `io_ompio_sharedfp_lazy_open` MCA parameter defers only the sharedfp
/// open); the component can be excluded only for the whole process before
/// its first `MPI_File_open` (MCA parameter `sharedfp=^lockedfile`, or
/// ROMIO with `io=romio321`), which is the host's decision, not a
/// library's. So longer paths reach MPI-IO through a short alias.
pub const MPIO_PATH_MAX: usize = 200;

/// Longest path the library accepts (Linux's `PATH_MAX` less the NUL).
pub const PATH_MAX: usize = 4095;

/// The name under which MPI-IO opens `path`, and the descriptor it needs.
/// Paths up to [`MPIO_PATH_MAX`] bytes are used as they are. Longer ones
/// go through `/proc/self/fd`: a file to create as
/// `/proc/self/fd/<directory fd>/<file name>` (the library's temporary
/// files have short names), an existing file to read as
/// `/proc/self/fd/<file fd>`. Each rank opens its own descriptor, so the
/// names differ between ranks but name the same file. Where `/proc/self/fd`
/// is missing, a long path is refused with an error naming the limit.
fn mpio_name(path: &Path, create: bool) -> Result<(CString, Option<std::fs::File>)> {
    let bytes = path.as_os_str().len();
    if bytes > PATH_MAX {
        return Err(Error::arg(format!(
            "path '{}' is {bytes} bytes long, more than the {PATH_MAX} the system allows",
            path.display()
        )));
    }
    if bytes <= MPIO_PATH_MAX {
        return Ok((path_cstr(path)?, None));
    }
    let proc_fd = Path::new("/proc/self/fd");
    if !proc_fd.is_dir() {
        return Err(Error::arg(format!(
            "path '{}' is {bytes} bytes long; without /proc/self/fd the library hands MPI-IO paths of at most {MPIO_PATH_MAX} bytes (Open MPI's sharedfp/lockedfile component overflows a 256-byte buffer on longer ones): use a shorter path",
            path.display()
        )));
    }
    let open_err =
        |what: &Path, e: std::io::Error| io_err(format!("cannot open '{}': {e}", what.display()));
    use std::os::fd::AsRawFd;
    if create {
        let name = path.file_name().map(|n| n.len()).unwrap_or(0);
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        // "/proc/self/fd/" + descriptor + "/" + name must stay short.
        if name + 32 > MPIO_PATH_MAX {
            return Err(Error::arg(format!(
                "the file name of '{}' is {name} bytes long; MPI-IO can create files with names of at most {} bytes",
                path.display(),
                MPIO_PATH_MAX - 32
            )));
        }
        let d = std::fs::File::open(dir).map_err(|e| open_err(dir, e))?;
        let alias = proc_fd
            .join(d.as_raw_fd().to_string())
            .join(path.file_name().unwrap_or_default());
        Ok((path_cstr(&alias)?, Some(d)))
    } else {
        let f = std::fs::File::open(path).map_err(|e| open_err(path, e))?;
        let alias = proc_fd.join(f.as_raw_fd().to_string());
        Ok((path_cstr(&alias)?, Some(f)))
    }
}

impl std::fmt::Debug for File<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "File({})", self.path.display())
    }
}

fn mpio_fapl(comm: &Comm, path: &Path) -> Result<Hid> {
    let what = || {
        format!(
            "cannot set up MPI-IO access for HDF5 file '{}'",
            path.display()
        )
    };
    // SAFETY: the class id is valid once the library is open (init).
    let fapl = Hid::new(unsafe { H5Pcreate(*H5P_CLS_FILE_ACCESS) }, H5Pclose, what)?;
    // SAFETY: fapl is a file-access list; comm is a valid communicator that
    // HDF5 duplicates; MPI_INFO_NULL is a valid info handle.
    check(
        unsafe { H5Pset_fapl_mpio(fapl.id, comm.raw(), mpi_sys::RSMPI_INFO_NULL) },
        what,
    )?;
    Ok(fapl)
}

fn path_cstr(path: &Path) -> Result<CString> {
    let s = path
        .to_str()
        .ok_or_else(|| Error::arg(format!("path '{}' is not valid UTF-8", path.display())))?;
    cstr(s, "path")
}

impl<'c> File<'c> {
    /// Creates (or truncates) `path` collectively over `comm`.
    pub fn create(comm: &'c Comm, path: &Path) -> Result<File<'c>> {
        Self::create_with(comm, path, false)
    }

    /// As [`File::create`], with the metadata in HDF5's 1.8 format or later
    /// (superblock version 2 and object headers version 2, which carry
    /// checksums HDF5 verifies on read).
    pub fn create_checksummed(comm: &'c Comm, path: &Path) -> Result<File<'c>> {
        Self::create_with(comm, path, true)
    }

    fn create_with(comm: &'c Comm, path: &Path, checksummed: bool) -> Result<File<'c>> {
        init();
        let (cpath, alias) = mpio_name(path, true)?;
        let fapl = mpio_fapl(comm, path)?;
        if checksummed {
            // SAFETY: fapl is a file-access list.
            check(
                unsafe {
                    hdf5_sys::h5p::H5Pset_libver_bounds(
                        fapl.id,
                        hdf5_sys::h5f::H5F_libver_t::H5F_LIBVER_V18,
                        hdf5_sys::h5f::H5F_LIBVER_LATEST,
                    )
                },
                || format!("cannot set the format of HDF5 file '{}'", path.display()),
            )?;
        }
        // SAFETY: cpath is NUL-terminated; fapl is valid.
        let id = unsafe { H5Fcreate(cpath.as_ptr(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.id) };
        let id = Hid::new(id, H5Fclose, || {
            format!(
                "cannot create HDF5 file '{}' (check that the directory exists and is writable)",
                path.display()
            )
        })?;
        Ok(File {
            id,
            path: path.to_path_buf(),
            comm,
            _alias: alias,
        })
    }

    /// Opens an existing `path` read-only, collectively over `comm`. The error
    /// says whether the file is missing, not HDF5, or HDF5 but unreadable
    /// (typically truncated).
    pub fn open(comm: &'c Comm, path: &Path) -> Result<File<'c>> {
        init();
        let cpath = path_cstr(path)?;
        if path.as_os_str().len() > PATH_MAX {
            return Err(Error::arg(format!(
                "path '{}' is {} bytes long, more than the {PATH_MAX} the system allows",
                path.display(),
                path.as_os_str().len()
            )));
        }
        if path.is_dir() {
            return Err(io_err(format!(
                "cannot open '{}': it is a directory, not a file",
                path.display()
            )));
        }
        if !path.is_file() {
            return Err(io_err(format!(
                "cannot open '{}': no such file",
                path.display()
            )));
        }
        // SAFETY: cpath is NUL-terminated. H5Fis_hdf5 only reads the signature.
        if unsafe { H5Fis_hdf5(cpath.as_ptr()) } <= 0 {
            return Err(io_err(format!(
                "'{}' is not an HDF5 file (no HDF5 signature)",
                path.display()
            )));
        }
        let (mpio, alias) = mpio_name(path, false)?;
        let fapl = mpio_fapl(comm, path)?;
        // SAFETY: as above.
        let id = unsafe { H5Fopen(mpio.as_ptr(), H5F_ACC_RDONLY, fapl.id) };
        let id = Hid::new(id, H5Fclose, || {
            format!(
                "'{}' has an HDF5 signature but HDF5 cannot open it: the file is truncated or damaged",
                path.display()
            )
        })?;
        Ok(File {
            id,
            path: path.to_path_buf(),
            comm,
            _alias: alias,
        })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The communicator the file was opened on.
    pub fn comm(&self) -> &'c Comm {
        self.comm
    }

    /// The root group `/` (file-level attributes live here).
    pub fn root(&self) -> Result<Group<'_>> {
        self.group("/")
    }

    /// Opens the existing group at `path` (absolute, e.g. `/level_1/particles`).
    pub fn group(&self, path: &str) -> Result<Group<'_>> {
        Group {
            id: LocId::Borrowed(self.id.id),
            file: self,
            path: String::new(),
        }
        .group(path)
    }

    /// Creates the group at `path`, with any missing parent groups.
    pub fn create_group(&self, path: &str) -> Result<Group<'_>> {
        self.root()?.create_group(path)
    }

    /// Closes the file and reports a failure to flush or close it.
    pub fn close(self) -> Result<()> {
        let p = self.path.display().to_string();
        self.id
            .close_checked(|| format!("closing HDF5 file '{p}' failed (data may not be on disk)"))
    }
}

/// A location id that is either owned (closed on drop) or borrowed.
enum LocId {
    Owned(Hid),
    Borrowed(hid_t),
}
impl LocId {
    fn get(&self) -> hid_t {
        match self {
            LocId::Owned(h) => h.id,
            LocId::Borrowed(id) => *id,
        }
    }
}

/// An open group in a [`File`]. Closed on drop.
pub struct Group<'f> {
    id: LocId,
    file: &'f File<'f>,
    path: String,
}

impl std::fmt::Debug for Group<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Group({}:{})", self.file.path.display(), self.path)
    }
}

/// An open dataset (only used to read and write its attributes). Closed on drop.
pub struct Dataset<'f> {
    id: Hid,
    file: &'f File<'f>,
    path: String,
}

impl std::fmt::Debug for Dataset<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Dataset({}:{})", self.file.path.display(), self.path)
    }
}

/// Joins a group path and a relative name (absolute names are kept).
fn join(base: &str, name: &str) -> String {
    if name.starts_with('/') {
        name.to_string()
    } else if base.ends_with('/') || base.is_empty() {
        format!("{}{name}", if base.is_empty() { "/" } else { base })
    } else {
        format!("{base}/{name}")
    }
}

fn intermediate_lcpl(what: impl Fn() -> String) -> Result<Hid> {
    // SAFETY: the class id is valid once the library is open.
    let lcpl = Hid::new(unsafe { H5Pcreate(*H5P_CLS_LINK_CREATE) }, H5Pclose, &what)?;
    // SAFETY: lcpl is a link-creation list.
    check(
        unsafe { H5Pset_create_intermediate_group(lcpl.id, 1) },
        what,
    )?;
    Ok(lcpl)
}

fn collective_dxpl(what: impl Fn() -> String) -> Result<Hid> {
    // SAFETY: the class id is valid once the library is open.
    let dxpl = Hid::new(unsafe { H5Pcreate(*H5P_CLS_DATASET_XFER) }, H5Pclose, &what)?;
    // SAFETY: dxpl is a transfer list.
    check(
        unsafe { H5Pset_dxpl_mpio(dxpl.id, H5FD_MPIO_COLLECTIVE) },
        what,
    )?;
    Ok(dxpl)
}

fn simple_space(dims: &[hsize_t], what: impl FnOnce() -> String) -> Result<Hid> {
    // SAFETY: dims has dims.len() entries; NULL maxdims means fixed size.
    let id = unsafe { H5Screate_simple(dims.len() as c_int, dims.as_ptr(), ptr::null()) };
    Hid::new(id, H5Sclose, what)
}

/// Selects rows `[offset, offset + count)` (all columns) of `space`, or
/// nothing when `count == 0`.
fn select_rows(space: hid_t, dims: &[hsize_t], offset: u64, count: u64) -> herr_t {
    // SAFETY: space is a valid dataspace of rank dims.len() (1 or 2).
    unsafe {
        if count == 0 {
            return H5Sselect_none(space);
        }
        let start = [offset, 0];
        let cnt = [count, dims.get(1).copied().unwrap_or(1)];
        H5Sselect_hyperslab(
            space,
            H5S_seloper_t::H5S_SELECT_SET,
            start.as_ptr(),
            ptr::null(),
            cnt.as_ptr(),
            ptr::null(),
        )
    }
}

fn space_dims(space: hid_t) -> Option<Vec<u64>> {
    // SAFETY: space is a valid dataspace; dims has room for its rank.
    unsafe {
        let n = H5Sget_simple_extent_ndims(space);
        if n < 0 {
            return None;
        }
        let mut dims = vec![0 as hsize_t; n as usize];
        if n > 0 && H5Sget_simple_extent_dims(space, dims.as_mut_ptr(), ptr::null_mut()) < 0 {
            return None;
        }
        Some(dims)
    }
}

impl<'f> Group<'f> {
    fn what(&self, name: &str, doing: &str) -> String {
        format!(
            "HDF5 {doing} '{}' in file '{}' failed",
            join(&self.path, name),
            self.file.path.display()
        )
    }

    /// The group's absolute path in the file.
    pub fn path(&self) -> &str {
        if self.path.is_empty() {
            "/"
        } else {
            &self.path
        }
    }

    /// The file this group belongs to.
    pub fn file(&self) -> &'f File<'f> {
        self.file
    }

    /// Opens the existing group `name` (relative to this group, or absolute).
    pub fn group(&self, name: &str) -> Result<Group<'f>> {
        let c = cstr(name, "group name")?;
        // SAFETY: c is NUL-terminated; the location id is open.
        let id = unsafe { H5Gopen2(self.id.get(), c.as_ptr(), H5P_DEFAULT) };
        let id = Hid::new(id, H5Gclose, || self.what(name, "opening group"))?;
        Ok(Group {
            id: LocId::Owned(id),
            file: self.file,
            path: join(self.path(), name),
        })
    }

    /// Creates the group `name` (relative or absolute), with missing parents.
    pub fn create_group(&self, name: &str) -> Result<Group<'f>> {
        let c = cstr(name, "group name")?;
        let what = || self.what(name, "creating group");
        let lcpl = intermediate_lcpl(what)?;
        // SAFETY: as above; lcpl is a valid link-creation list.
        let id =
            unsafe { H5Gcreate2(self.id.get(), c.as_ptr(), lcpl.id, H5P_DEFAULT, H5P_DEFAULT) };
        let id = Hid::new(id, H5Gclose, what)?;
        Ok(Group {
            id: LocId::Owned(id),
            file: self.file,
            path: join(self.path(), name),
        })
    }

    /// True when every component of the path `name` exists (group or dataset).
    pub fn exists(&self, name: &str) -> Result<bool> {
        let mut prefix = if name.starts_with('/') {
            String::from("/")
        } else {
            String::new()
        };
        for part in name.split('/').filter(|p| !p.is_empty()) {
            prefix.push_str(part);
            let c = cstr(&prefix, "object name")?;
            // SAFETY: c is NUL-terminated; every parent of prefix exists.
            let rc = unsafe { H5Lexists(self.id.get(), c.as_ptr(), H5P_DEFAULT) };
            if rc < 0 {
                return Err(h5_err(self.what(name, "looking up")));
            }
            if rc == 0 {
                return Ok(false);
            }
            prefix.push('/');
        }
        Ok(true)
    }

    /// Opens the dataset `name` (to reach its attributes).
    pub fn dataset(&self, name: &str) -> Result<Dataset<'f>> {
        let id = self.open_dataset(name)?;
        Ok(Dataset {
            id,
            file: self.file,
            path: join(self.path(), name),
        })
    }

    fn open_dataset(&self, name: &str) -> Result<Hid> {
        let c = cstr(name, "dataset name")?;
        // SAFETY: c is NUL-terminated; the location id is open.
        let id = unsafe { H5Dopen2(self.id.get(), c.as_ptr(), H5P_DEFAULT) };
        Hid::new(id, H5Dclose, || {
            format!(
                "dataset '{}' is missing from file '{}' (or cannot be opened)",
                join(self.path(), name),
                self.file.path.display()
            )
        })
    }

    /// Writes a 1D dataset `name` whose rows are every rank's `local`, in
    /// rank order (collective; a rank may pass an empty slice).
    pub fn write<T: H5Type>(&self, name: &str, local: &[T]) -> Result<Slab> {
        self.write_nd(name, local, None)
    }

    /// Writes an `(n × k)` 2D dataset `name`; `local` holds this rank's rows,
    /// row-major (`local.len()` must be a multiple of `k`).
    pub fn write_2d<T: H5Type>(&self, name: &str, local: &[T], k: usize) -> Result<Slab> {
        self.write_nd(name, local, Some(k))
    }

    fn write_nd<T: H5Type>(&self, name: &str, local: &[T], k: Option<usize>) -> Result<Slab> {
        let comm = self.file.comm;
        let kk = k.unwrap_or(1);
        let bad = kk == 0 || local.len() % kk != 0;
        if comm.any(bad)? {
            return Err(Error::arg(format!(
                "write_2d of '{}': every rank's slice length must be a positive multiple of k = {kk} (one rank passed {})",
                join(self.path(), name),
                local.len()
            )));
        }
        let count = (local.len() / kk) as u64;
        let offset = comm.exscan_u64(count)?;
        let mut total = [count];
        comm.sum_u64(&mut total)?;
        let total = total[0];
        let dims: Vec<hsize_t> = match k {
            Some(k) => vec![total, k as u64],
            None => vec![total],
        };
        let what = || self.what(name, "writing dataset");
        let c = cstr(name, "dataset name")?;
        let fspace = simple_space(&dims, what)?;
        let lcpl = intermediate_lcpl(what)?;
        // SAFETY: all ids are open; c is NUL-terminated.
        let dset = unsafe {
            H5Dcreate2(
                self.id.get(),
                c.as_ptr(),
                T::native(),
                fspace.id,
                lcpl.id,
                H5P_DEFAULT,
                H5P_DEFAULT,
            )
        };
        let dset = Hid::new(dset, H5Dclose, what)?;
        if total == 0 {
            // An empty dataset has no storage to write to.
            dset.close_checked(what)?;
            return Ok(Slab {
                offset,
                count,
                total,
            });
        }
        let mut mdims = dims.clone();
        mdims[0] = count;
        let mspace = simple_space(&mdims, what)?;
        check(select_rows(fspace.id, &dims, offset, count), what)?;
        check(select_rows(mspace.id, &mdims, 0, count), what)?;
        let dxpl = collective_dxpl(what)?;
        // SAFETY: local holds count*kk elements of T, matching mspace's selection.
        let rc = unsafe {
            H5Dwrite(
                dset.id,
                T::native(),
                mspace.id,
                fspace.id,
                dxpl.id,
                local.as_ptr() as *const c_void,
            )
        };
        check(rc, what)?;
        dset.close_checked(what)?;
        Ok(Slab {
            offset,
            count,
            total,
        })
    }

    /// The dimensions of dataset `name` (`[n]` or `[n, k]`).
    pub fn dims(&self, name: &str) -> Result<Vec<u64>> {
        let dset = self.open_dataset(name)?;
        self.dims_of(&dset, name)
    }

    fn dims_of(&self, dset: &Hid, name: &str) -> Result<Vec<u64>> {
        let what = || self.what(name, "reading the shape of dataset");
        // SAFETY: dset is an open dataset.
        let space = Hid::new(unsafe { H5Dget_space(dset.id) }, H5Sclose, what)?;
        space_dims(space.id).ok_or_else(|| h5_err(what()))
    }

    /// The number of rows (first dimension) of dataset `name`.
    pub fn len(&self, name: &str) -> Result<u64> {
        let d = self.dims(name)?;
        Ok(d.first().copied().unwrap_or(1))
    }

    /// Fails with a clear `Io` error when dataset `name` does not have exactly
    /// `expected` rows (for example the count stored in an attribute): a
    /// shorter dataset means a truncated or damaged file.
    pub fn check_len(&self, name: &str, expected: u64) -> Result<()> {
        let n = self.len(name)?;
        if n != expected {
            return Err(io_err(format!(
                "dataset '{}' in file '{}' has {n} rows but the file says it should have {expected}: the file is truncated or damaged",
                join(self.path(), name),
                self.file.path.display()
            )));
        }
        Ok(())
    }

    /// The stored element type of dataset `name`, for messages and checks:
    /// its kind and size in bytes, or `None` for a non-numeric type.
    pub fn stored_type(&self, name: &str) -> Result<Option<(NumKind, usize)>> {
        let dset = self.open_dataset(name)?;
        let what = || self.what(name, "reading the type of dataset");
        // SAFETY: dset is open.
        let t = Hid::new(unsafe { H5Dget_type(dset.id) }, H5Tclose, what)?;
        Ok(type_info(t.id))
    }

    /// Reads rows `[offset, offset + count)` of dataset `name` (all columns of
    /// a 2D dataset, row-major) into a new vector. Collective: every rank
    /// passes its own range; `count` may be 0. The stored type must be the
    /// same kind and size as `T`.
    pub fn read_rows<T: H5Type>(&self, name: &str, offset: u64, count: u64) -> Result<Vec<T>> {
        let comm = self.file.comm;
        let dset = self.open_dataset(name)?;
        let dims = self.dims_of(&dset, name)?;
        let what = || self.what(name, "reading dataset");
        // SAFETY: dset is open.
        let ftype = Hid::new(unsafe { H5Dget_type(dset.id) }, H5Tclose, what)?;
        let info = type_info(ftype.id);
        if info != Some((T::KIND, std::mem::size_of::<T>())) {
            return Err(io_err(format!(
                "dataset '{}' in file '{}' holds {} but {} was expected",
                join(self.path(), name),
                self.file.path.display(),
                type_name(info),
                T::NAME
            )));
        }
        if dims.is_empty() || dims.len() > 2 {
            return Err(io_err(format!(
                "dataset '{}' in file '{}' has rank {} but 1 or 2 was expected",
                join(self.path(), name),
                self.file.path.display(),
                dims.len()
            )));
        }
        let n = dims[0];
        let bad = offset.checked_add(count).map_or(true, |e| e > n);
        if comm.any(bad)? {
            return Err(Error::arg(format!(
                "reading '{}' from '{}': rows [offset, offset + count) must lie within its {n} rows (one rank asked for {offset} + {count})",
                join(self.path(), name),
                self.file.path.display()
            )));
        }
        let k = dims.get(1).copied().unwrap_or(1);
        let mut out = vec![T::default(); (count * k) as usize];
        if n == 0 {
            // An empty dataset has no storage to read from.
            return Ok(out);
        }
        // SAFETY: dset is open.
        let fspace = Hid::new(unsafe { H5Dget_space(dset.id) }, H5Sclose, what)?;
        let mut mdims = dims.clone();
        mdims[0] = count;
        let mspace = simple_space(&mdims, what)?;
        check(select_rows(fspace.id, &dims, offset, count), what)?;
        check(select_rows(mspace.id, &mdims, 0, count), what)?;
        let dxpl = collective_dxpl(what)?;
        // SAFETY: out holds count*k elements of T, matching mspace.
        let rc = unsafe {
            H5Dread(
                dset.id,
                T::native(),
                mspace.id,
                fspace.id,
                dxpl.id,
                out.as_mut_ptr() as *mut c_void,
            )
        };
        check(rc, what)?;
        Ok(out)
    }

    /// Reads the whole dataset `name` on every rank (row-major).
    pub fn read_all<T: H5Type>(&self, name: &str) -> Result<Vec<T>> {
        let n = self.len(name)?;
        self.read_rows(name, 0, n)
    }
}

/// Attribute access on files' groups and datasets. Writing is collective and
/// every rank must pass the same value; an existing attribute is replaced.
pub trait Attributes {
    /// The HDF5 id of the object.
    #[doc(hidden)]
    fn loc_id(&self) -> hid_t;
    /// `"attribute 'name' of '/obj' in file 'path'"`, for messages.
    #[doc(hidden)]
    fn describe(&self, attr: &str) -> String;

    /// True when the attribute `name` exists.
    fn has_attr(&self, name: &str) -> Result<bool> {
        let c = cstr(name, "attribute name")?;
        // SAFETY: c is NUL-terminated; the object is open.
        let rc = unsafe { H5Aexists(self.loc_id(), c.as_ptr()) };
        if rc < 0 {
            return Err(io_err(format!("looking up {} failed", self.describe(name))));
        }
        Ok(rc > 0)
    }

    /// Writes a scalar numeric attribute.
    fn set_attr<T: H5Type>(&self, name: &str, v: T) -> Result<()> {
        // SAFETY: creating a scalar dataspace has no preconditions.
        let space = Hid::new(
            unsafe { H5Screate(H5S_class_t::H5S_SCALAR) },
            H5Sclose,
            || format!("writing {} failed", self.describe(name)),
        )?;
        write_attr(
            self,
            name,
            T::native(),
            &space,
            &v as *const T as *const c_void,
        )
    }

    /// Writes a 1D numeric array attribute (at least one element; HDF5 keeps
    /// attributes small: stay under 64 KiB, use a dataset for more).
    fn set_attr_array<T: H5Type>(&self, name: &str, v: &[T]) -> Result<()> {
        if v.is_empty() {
            return Err(Error::arg(format!(
                "{} needs at least one element",
                self.describe(name)
            )));
        }
        let space = simple_space(&[v.len() as hsize_t], || {
            format!("writing {} failed", self.describe(name))
        })?;
        write_attr(self, name, T::native(), &space, v.as_ptr() as *const c_void)
    }

    /// Writes a fixed-length string attribute.
    fn set_attr_str(&self, name: &str, v: &str) -> Result<()> {
        let what = || format!("writing {} failed", self.describe(name));
        let bytes = cstr(v, "string attribute value")?;
        let t = string_type(bytes.as_bytes().len().max(1), what)?;
        // SAFETY: as in set_attr.
        let space = Hid::new(
            unsafe { H5Screate(H5S_class_t::H5S_SCALAR) },
            H5Sclose,
            what,
        )?;
        write_attr(self, name, t.id, &space, bytes.as_ptr() as *const c_void)
    }

    /// Reads a scalar (or one-element) numeric attribute; integers and floats
    /// are converted by HDF5 when the stored kind differs.
    fn attr<T: H5Type>(&self, name: &str) -> Result<T> {
        let v = self.attr_array::<T>(name)?;
        if v.len() != 1 {
            return Err(io_err(format!(
                "{} has {} elements but one was expected",
                self.describe(name),
                v.len()
            )));
        }
        Ok(v[0])
    }

    /// Reads a numeric attribute of any length.
    fn attr_array<T: H5Type>(&self, name: &str) -> Result<Vec<T>> {
        let (a, what) = open_attr(self, name)?;
        // SAFETY: a is an open attribute.
        let t = Hid::new(unsafe { H5Aget_type(a.id) }, H5Tclose, &what)?;
        if type_info(t.id).is_none() {
            return Err(io_err(format!("{} is not numeric", self.describe(name))));
        }
        // SAFETY: as above.
        let space = Hid::new(unsafe { H5Aget_space(a.id) }, H5Sclose, &what)?;
        let n: u64 = space_dims(space.id)
            .ok_or_else(|| h5_err(what()))?
            .iter()
            .product();
        let mut out = vec![T::default(); n as usize];
        // SAFETY: out holds every element of the attribute.
        check(
            unsafe { H5Aread(a.id, T::native(), out.as_mut_ptr() as *mut c_void) },
            &what,
        )?;
        Ok(out)
    }

    /// Reads a fixed-length string attribute.
    fn attr_str(&self, name: &str) -> Result<String> {
        let (a, what) = open_attr(self, name)?;
        // SAFETY: a is an open attribute.
        let t = Hid::new(unsafe { H5Aget_type(a.id) }, H5Tclose, &what)?;
        // SAFETY: t is an open datatype.
        let (class, vlen, size) = unsafe {
            (
                H5Tget_class(t.id),
                H5Tis_variable_str(t.id),
                H5Tget_size(t.id),
            )
        };
        if class != H5T_class_t::H5T_STRING || vlen != 0 {
            return Err(io_err(format!(
                "{} is not a fixed-length string",
                self.describe(name)
            )));
        }
        let mt = string_type(size, &what)?;
        let mut buf = vec![0u8; size + 1];
        // SAFETY: buf has room for `size` bytes plus a terminator.
        check(
            unsafe { H5Aread(a.id, mt.id, buf.as_mut_ptr() as *mut c_void) },
            &what,
        )?;
        let end = buf.iter().position(|&b| b == 0).unwrap_or(size);
        String::from_utf8(buf[..end].to_vec())
            .map_err(|_| io_err(format!("{} is not valid UTF-8", self.describe(name))))
    }
}

fn string_type(size: usize, what: impl Fn() -> String) -> Result<Hid> {
    // SAFETY: the library is open (callers hold an open object).
    let t = Hid::new(unsafe { H5Tcopy(*H5T_C_S1) }, H5Tclose, &what)?;
    // SAFETY: t is a string type copy we own.
    check(unsafe { H5Tset_size(t.id, size) }, what)?;
    Ok(t)
}

fn open_attr<A: Attributes + ?Sized>(obj: &A, name: &str) -> Result<(Hid, impl Fn() -> String)> {
    let desc = obj.describe(name);
    if !obj.has_attr(name)? {
        return Err(io_err(format!("{desc} is missing")));
    }
    let c = cstr(name, "attribute name")?;
    let what = move || format!("reading {desc} failed");
    // SAFETY: c is NUL-terminated; the object is open.
    let a = Hid::new(
        unsafe { H5Aopen(obj.loc_id(), c.as_ptr(), H5P_DEFAULT) },
        H5Aclose,
        &what,
    )?;
    Ok((a, what))
}

fn write_attr<A: Attributes + ?Sized>(
    obj: &A,
    name: &str,
    tid: hid_t,
    space: &Hid,
    buf: *const c_void,
) -> Result<()> {
    let what = || format!("writing {} failed", obj.describe(name));
    let c = cstr(name, "attribute name")?;
    if obj.has_attr(name)? {
        // SAFETY: c is NUL-terminated; the object is open.
        check(unsafe { H5Adelete(obj.loc_id(), c.as_ptr()) }, what)?;
    }
    // SAFETY: all ids are open; buf points to data of type tid and space's size.
    let a = unsafe {
        H5Acreate2(
            obj.loc_id(),
            c.as_ptr(),
            tid,
            space.id,
            H5P_DEFAULT,
            H5P_DEFAULT,
        )
    };
    let a = Hid::new(a, H5Aclose, what)?;
    // SAFETY: as above.
    check(unsafe { H5Awrite(a.id, tid, buf) }, what)?;
    a.close_checked(what)
}

impl Attributes for Group<'_> {
    fn loc_id(&self) -> hid_t {
        self.id.get()
    }
    fn describe(&self, attr: &str) -> String {
        format!(
            "attribute '{attr}' of '{}' in file '{}'",
            self.path(),
            self.file.path.display()
        )
    }
}

impl Attributes for Dataset<'_> {
    fn loc_id(&self) -> hid_t {
        self.id.id
    }
    fn describe(&self, attr: &str) -> String {
        format!(
            "attribute '{attr}' of dataset '{}' in file '{}'",
            self.path,
            self.file.path.display()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_even_covers_all_rows_once() {
        for total in [0u64, 1, 7, 100] {
            for size in 1..6 {
                let mut next = 0;
                for r in 0..size {
                    let (o, c) = split_even(total, r, size);
                    assert_eq!(o, next);
                    next += c;
                    assert!(c <= total / size as u64 + 1);
                }
                assert_eq!(next, total);
            }
        }
    }

    #[test]
    fn join_paths() {
        assert_eq!(join("", "a/b"), "/a/b");
        assert_eq!(join("/", "a"), "/a");
        assert_eq!(join("/g", "x"), "/g/x");
        assert_eq!(join("/g", "/x"), "/x");
    }
}
