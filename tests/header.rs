//! The checked-in `include/gimlet.h` must equal a fresh cbindgen generation.
//! Run with `GIMLET_BLESS=1` to rewrite it after changing the C ABI.

use std::path::PathBuf;

fn generate() -> String {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut config =
        cbindgen::Config::from_file(root.join("cbindgen.toml")).expect("cbindgen.toml");
    config.after_includes = Some(format!(
        "\n#define GIMLET_VERSION_MAJOR {}\n#define GIMLET_VERSION_MINOR {}\n#define GIMLET_VERSION_PATCH {}\n#define GIMLET_VERSION_STRING \"{}\"",
        env!("CARGO_PKG_VERSION_MAJOR"),
        env!("CARGO_PKG_VERSION_MINOR"),
        env!("CARGO_PKG_VERSION_PATCH"),
        env!("CARGO_PKG_VERSION"),
    ));
    let mut out = Vec::new();
    // Only the ffi layer is the C ABI: parse it (cbindgen follows its `mod`
    // declarations), not the whole crate.
    let b = cbindgen::Builder::new()
        .with_config(config)
        .with_src(root.join("src/ffi/mod.rs"));
    b.generate().expect("cbindgen generation").write(&mut out);
    String::from_utf8(out).expect("utf-8 header")
}

#[test]
fn header_is_current() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("include/gimlet.h");
    let fresh = generate();
    if std::env::var_os("GIMLET_BLESS").is_some() {
        std::fs::write(&path, &fresh).expect("write include/gimlet.h");
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == fresh,
        "include/gimlet.h is stale: the C ABI changed without regenerating the header; run `GIMLET_BLESS=1 cargo test --test header` and commit include/gimlet.h"
    );
}

#[test]
fn header_version_macros_match_cargo() {
    let h = generate();
    for (name, v) in [
        ("MAJOR", env!("CARGO_PKG_VERSION_MAJOR")),
        ("MINOR", env!("CARGO_PKG_VERSION_MINOR")),
        ("PATCH", env!("CARGO_PKG_VERSION_PATCH")),
    ] {
        assert!(
            h.contains(&format!("#define GIMLET_VERSION_{name} {v}\n")),
            "GIMLET_VERSION_{name}"
        );
    }
}
