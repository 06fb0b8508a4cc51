//! Gives the shared library its SONAME, `libgimlet.so.<major>`, in every
//! build of the crate: cargo test, clippy and the CMake build then compile
//! the library with the same flags and share it (an argument passed to
//! rustc by one of them alone would make cargo rebuild the library for the
//! others).

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    if os == "linux" {
        let major = std::env::var("CARGO_PKG_VERSION_MAJOR").unwrap_or_else(|_| "0".into());
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libgimlet.so.{major}");
    }
}
