//! The layer rule, checked: every file under `src/` imports only what the
//! table in the doc comment of `src/lib.rs` allows its module (see "Layers"
//! there), and uses C types and system bindings only where the table says.
//!
//! The table is read from `src/lib.rs` (between `<!-- layers:begin -->`
//! and `<!-- layers:end -->`), so the rule is written once. Each file is
//! reduced to its code (comments, strings and character literals removed),
//! then every `crate::` (and `$crate::`) path, every `super::` path that
//! leaves the file's top module, and every outside path the table knows
//! (`libc`, `mpi_sys`, `petsc_sys`, `hdf5_sys`, `std::os::raw`,
//! `std::ffi`, `core::ffi`, `extern "C"`) is checked against the file's
//! row. The checker itself is tested on small sources that must pass and
//! must fail.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The outside paths the checker looks for: system bindings and C types.
const SYSTEM: [&str; 8] = [
    "libc",
    "mpi_sys",
    "petsc_sys",
    "hdf5_sys",
    "std::os::raw",
    "std::ffi",
    "core::ffi",
    "extern \"C\"",
];

/// One row of the table: the modules a module may import, and the outside
/// paths (prefixes) it may use.
#[derive(Debug, Default)]
struct Row {
    imports: BTreeSet<String>,
    system: Vec<String>,
}

/// The backticked names of a table cell.
fn ticked(cell: &str) -> Vec<String> {
    cell.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// The table of the doc comment of `lib` (the text of `src/lib.rs`).
fn table(lib: &str) -> BTreeMap<String, Row> {
    let body: Vec<&str> = lib
        .lines()
        .map(|l| l.trim_start_matches("//!").trim())
        .skip_while(|l| *l != "<!-- layers:begin -->")
        .skip(1)
        .take_while(|l| *l != "<!-- layers:end -->")
        .collect();
    let mut rows = BTreeMap::new();
    for line in body.iter().skip(2) {
        let cells: Vec<&str> = line.trim_matches('|').split('|').collect();
        assert_eq!(cells.len(), 3, "a row of the layer table: {line}");
        let name = ticked(cells[0]);
        assert_eq!(name.len(), 1, "one module per row: {line}");
        let row = Row {
            imports: ticked(cells[1]).into_iter().collect(),
            system: ticked(cells[2]),
        };
        assert!(
            rows.insert(name[0].clone(), row).is_none(),
            "module {} has two rows",
            name[0]
        );
    }
    assert!(!rows.is_empty(), "no layer table in src/lib.rs");
    rows
}

/// The code of a Rust source: comments, string literals (their contents)
/// and character literals removed, newlines kept; `extern "C"` becomes
/// `extern_C_abi` first so that the ABI string survives.
fn code(src: &str) -> String {
    let src = src.replace("extern \"C\"", "extern_C_abi");
    let c: Vec<char> = src.chars().collect();
    let mut out = String::with_capacity(c.len());
    let mut i = 0;
    while i < c.len() {
        if ch(&c, i) == '/' && ch(&c, i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch(&c, i) == '/' && ch(&c, i + 1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if ch(&c, i) == '/' && ch(&c, i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if ch(&c, i) == '*' && ch(&c, i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if c[i] == '\n' {
                        out.push('\n');
                    }
                    i += 1;
                }
            }
        } else if ch(&c, i) == 'r'
            && (ch(&c, i + 1) == '"'
                || (ch(&c, i + 1) == '#' && (ch(&c, i + 2) == '"' || ch(&c, i + 2) == '#')))
            && raw_start(&c, i)
        {
            // A raw string: r"..." or r#"..."#.
            let mut hashes = 0;
            i += 1;
            while ch(&c, i) == '#' {
                hashes += 1;
                i += 1;
            }
            i += 1;
            loop {
                if i >= c.len() {
                    break;
                }
                if c[i] == '"' && (1..=hashes).all(|k| ch(&c, i + k) == '#') {
                    i += 1 + hashes;
                    break;
                }
                if c[i] == '\n' {
                    out.push('\n');
                }
                i += 1;
            }
            out.push_str("\"\"");
        } else if ch(&c, i) == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                if c[i] == '\\' {
                    i += 1;
                } else if c[i] == '\n' {
                    out.push('\n');
                }
                i += 1;
            }
            i += 1;
            out.push_str("\"\"");
        } else if ch(&c, i) == '\'' && (ch(&c, i + 1) == '\\' || ch(&c, i + 2) == '\'') {
            // A character literal ('x', '\n', '\u{..}'); a lifetime or
            // label ('a) has no closing quote right after one character.
            i += 1;
            if ch(&c, i) == '\\' {
                i += 1;
            }
            while i < c.len() && c[i] != '\'' {
                i += 1;
            }
            i += 1;
            out.push_str("' '");
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// The character at `c[j]` (NUL past the end).
fn ch(c: &[char], j: usize) -> char {
    c.get(j).copied().unwrap_or('\0')
}

/// Whether the `r` at `c[i]` starts a raw string (`r"`, `br"`), not the
/// end of an identifier.
fn raw_start(c: &[char], i: usize) -> bool {
    let before = |k: usize| i.checked_sub(k).map(|j| c[j]);
    let ident_at = |k: usize| before(k).is_some_and(ident_char);
    !ident_at(1) || (before(1) == Some('b') && !ident_at(2))
}

/// Whether `c` can be part of an identifier.
fn ident_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// The identifier at the start of `s` (empty when there is none).
fn ident(s: &str) -> &str {
    let end = s.find(|c: char| !ident_char(c)).unwrap_or(s.len());
    &s[..end]
}

/// The first segments of the paths at the start of `s`: one identifier, or
/// for `{a, b::c, ...}` the first segment of each item.
fn first_segments(s: &str) -> Vec<String> {
    let s = s.trim_start();
    if let Some(rest) = s.strip_prefix('{') {
        let mut depth = 0;
        let mut items = Vec::new();
        let mut start = 0;
        for (k, ch) in rest.char_indices() {
            match ch {
                '{' => depth += 1,
                '}' if depth == 0 => {
                    items.push(&rest[start..k]);
                    break;
                }
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    items.push(&rest[start..k]);
                    start = k + 1;
                }
                _ => {}
            }
        }
        items
            .into_iter()
            .map(|t| ident(t.trim()).to_string())
            .filter(|t| !t.is_empty() && t != "self")
            .collect()
    } else {
        let id = ident(s);
        if id.is_empty() {
            Vec::new()
        } else {
            vec![id.to_string()]
        }
    }
}

/// What a file uses: the top modules it names (through `crate::` or
/// `super::` paths leaving its top module) and the outside paths of
/// [`SYSTEM`] (as written, up to the next identifier).
#[derive(Debug, Default, PartialEq)]
struct Uses {
    modules: BTreeSet<String>,
    system: BTreeSet<String>,
}

/// The uses of the source `src` of module `path` (its module path, e.g.
/// `["level", "step"]` for `src/level/step.rs`).
fn uses(src: &str, path: &[String]) -> Uses {
    let code = code(src);
    let mut u = Uses::default();
    // Inline modules (`mod tests { ... }`) deepen `super::` paths: the
    // stack of their brace depths at each position.
    let mut inline: Vec<usize> = Vec::new();
    let mut depth = 0usize;
    let b = code.as_bytes();
    let mut i = 0;
    while i < code.len() {
        if !code.is_char_boundary(i) {
            i += 1;
            continue;
        }
        let rest = &code[i..];
        let boundary = i == 0 || !ident_char(b[i - 1] as char);
        match b[i] {
            b'{' => {
                depth += 1;
                i += 1;
                continue;
            }
            b'}' => {
                depth = depth.saturating_sub(1);
                if inline.last() == Some(&depth) {
                    inline.pop();
                }
                i += 1;
                continue;
            }
            _ => {}
        }
        if boundary && rest.starts_with("mod ") {
            let after = rest[4..].trim_start();
            let name = ident(after);
            if !name.is_empty() && after[name.len()..].trim_start().starts_with('{') {
                inline.push(depth);
            }
        }
        if boundary && rest.starts_with("crate::") {
            u.modules.extend(first_segments(&rest[7..]));
            i += 7;
            continue;
        }
        if boundary && rest.starts_with("super::") {
            let mut k = 0;
            let mut r = rest;
            while let Some(t) = r.strip_prefix("super::") {
                k += 1;
                r = t;
            }
            if k >= path.len() + inline.len() {
                u.modules.extend(first_segments(r));
            }
            i += rest.len() - r.len();
            continue;
        }
        if boundary && rest.starts_with("std::{") {
            for seg in first_segments(&rest[5..]) {
                match seg.as_str() {
                    "ffi" => u.system.insert("std::ffi".to_string()),
                    "os" => u.system.insert("std::os::raw".to_string()),
                    _ => false,
                };
            }
            i += 5;
            continue;
        }
        if boundary {
            if let Some(sys) = SYSTEM.iter().find(|s| {
                let s = s.replace("extern \"C\"", "extern_C_abi");
                rest.starts_with(&s) && !rest[s.len()..].starts_with(ident_char)
            }) {
                let s = sys.replace("extern \"C\"", "extern_C_abi");
                let mut used = sys.to_string();
                if let Some(more) = rest[s.len()..].strip_prefix("::") {
                    for seg in first_segments(more) {
                        u.system.insert(format!("{sys}::{seg}"));
                    }
                    used.clear();
                }
                if !used.is_empty() {
                    u.system.insert(used);
                }
                i += s.len();
                continue;
            }
        }
        i += 1;
    }
    u
}

/// Whether `used` (an outside path) is allowed by the prefixes `allowed`.
fn system_allowed(used: &str, allowed: &[String]) -> bool {
    allowed
        .iter()
        .any(|a| used == a || used.starts_with(&format!("{a}::")))
}

/// The violations of `row` by the uses of module `module`'s file `file`;
/// `macros` maps crate-root macros (`#[macro_export]`) to their module.
fn violations(
    file: &str,
    module: &str,
    row: &Row,
    u: &Uses,
    macros: &BTreeMap<String, String>,
) -> Vec<String> {
    let mut v = Vec::new();
    for m in &u.modules {
        let m = macros.get(m).map_or(m.as_str(), String::as_str);
        if m != module && !row.imports.contains(m) {
            v.push(format!(
                "{file}: module `{module}` imports `{m}`, which its row does not allow"
            ));
        }
    }
    for s in &u.system {
        if !system_allowed(s, &row.system) {
            v.push(format!(
                "{file}: module `{module}` uses `{s}`, which its row does not allow"
            ));
        }
    }
    v
}

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("src/ is readable") {
        let p = e.expect("a directory entry").path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a file under `src/` (`src/level/step.rs`:
/// `level::step`; `src/level/mod.rs`: `level`).
fn module_path(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|c| c.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().expect("a file name");
    let stem = last.trim_end_matches(".rs");
    if parts.is_empty() && stem == "lib" {
        return parts; // the crate root
    }
    if stem != "mod" {
        parts.push(stem.to_string());
    }
    parts
}

/// The `#[macro_export]` macros of `src` (they live at the crate root).
fn exported_macros(src: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut lines = src.lines().map(str::trim);
    while let Some(l) = lines.next() {
        if l.starts_with("#[macro_export]") {
            for next in lines.by_ref() {
                if let Some(r) = next.strip_prefix("macro_rules!") {
                    out.push(ident(r.trim()).to_string());
                    break;
                }
            }
        }
    }
    out
}

/// The modules `lib.rs` declares.
fn declared_modules(lib: &str) -> BTreeSet<String> {
    code(lib)
        .lines()
        .map(str::trim)
        .filter_map(|l| {
            l.strip_prefix("pub mod ")
                .or_else(|| l.strip_prefix("mod "))
        })
        .map(|l| ident(l).to_string())
        .collect()
}

/// A cycle of the table, if it has one.
fn cycle(rows: &BTreeMap<String, Row>) -> Option<Vec<String>> {
    fn visit(
        m: &str,
        rows: &BTreeMap<String, Row>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(m) {
            Some(2) => return None,
            Some(1) => {
                let at = stack.iter().position(|s| s == m).unwrap_or(0);
                let mut c = stack[at..].to_vec();
                c.push(m.to_string());
                return Some(c);
            }
            _ => {}
        }
        state.insert(m.to_string(), 1);
        stack.push(m.to_string());
        for d in rows.get(m).map(|r| r.imports.iter()).into_iter().flatten() {
            if let Some(c) = visit(d, rows, state, stack) {
                return Some(c);
            }
        }
        stack.pop();
        state.insert(m.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for m in rows.keys() {
        if let Some(c) = visit(m, rows, &mut state, &mut Vec::new()) {
            return Some(c);
        }
    }
    None
}

#[test]
fn every_file_imports_only_what_its_layer_allows() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let lib = std::fs::read_to_string(root.join("lib.rs")).expect("src/lib.rs");
    let rows = table(&lib);
    // The table names exactly the modules lib.rs declares, and only them.
    let declared = declared_modules(&lib);
    let named: BTreeSet<String> = rows.keys().cloned().collect();
    assert_eq!(
        declared, named,
        "the layer table and lib.rs's modules differ"
    );
    for (m, r) in &rows {
        for d in &r.imports {
            assert!(
                rows.contains_key(d),
                "row `{m}` names `{d}`, which is no module"
            );
        }
    }
    assert_eq!(cycle(&rows), None, "the layer table has a cycle");
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    files.sort();
    let mut macros = BTreeMap::new();
    for f in &files {
        let rel = f.strip_prefix(&root).expect("under src/");
        if let Some(top) = module_path(rel).first() {
            let src = std::fs::read_to_string(f).expect("a source file");
            for m in exported_macros(&src) {
                macros.insert(m, top.clone());
            }
        }
    }
    let mut bad = Vec::new();
    let mut checked = 0;
    for f in &files {
        let rel = f.strip_prefix(&root).expect("under src/");
        let path = module_path(rel);
        let Some(top) = path.first() else {
            continue; // lib.rs
        };
        let row = rows
            .get(top)
            .unwrap_or_else(|| panic!("{} belongs to `{top}`, which has no row", rel.display()));
        let src = std::fs::read_to_string(f).expect("a source file");
        let u = uses(&src, &path);
        bad.extend(violations(
            &rel.display().to_string(),
            top,
            row,
            &u,
            &macros,
        ));
        checked += 1;
    }
    assert!(checked >= rows.len(), "only {checked} files checked");
    assert!(bad.is_empty(), "layer rule broken:\n{}", bad.join("\n"));
}

/// The checker on small sources: what it must find and what it must not.
#[test]
fn the_checker_finds_upward_imports_and_ignores_comments_and_strings() {
    let lib = "//! <!-- layers:begin -->\n//! | module | may import | C |\n//! |---|---|---|\n\
               //! | `error` | | |\n//! | `kernel` | `error` | `libc::clock_gettime` |\n\
               //! | `sim` | `error`, `kernel` | |\n//! | `ffi` | `error`, `kernel`, `sim` | `libc` |\n\
               //! <!-- layers:end -->\n";
    let rows = table(lib);
    assert_eq!(rows.len(), 4);
    assert_eq!(cycle(&rows), None);
    let none = BTreeMap::new();
    let check = |module: &str, path: &[&str], src: &str| {
        let path: Vec<String> = path.iter().map(|s| s.to_string()).collect();
        violations("f.rs", module, &rows[module], &uses(src, &path), &none)
    };
    // Allowed: downward imports, the own module, comments, strings.
    assert!(check(
        "sim",
        &["sim"],
        "use crate::kernel::Grid;\nuse crate::sim::x;"
    )
    .is_empty());
    assert!(check(
        "kernel",
        &["kernel"],
        "// use crate::sim::S;\n/// [`crate::sim`]\nfn f() {}"
    )
    .is_empty());
    assert!(check(
        "kernel",
        &["kernel"],
        "let s = \"crate::sim::S\"; let c = '{'; let r = r#\"crate::ffi\"#;"
    )
    .is_empty());
    assert!(check(
        "kernel",
        &["kernel"],
        "/* crate::sim /* nested */ crate::ffi */ fn f() {}"
    )
    .is_empty());
    assert!(check("kernel", &["kernel", "grid"], "use super::Node;").is_empty());
    assert!(check(
        "kernel",
        &["kernel"],
        "unsafe { libc::clock_gettime(0, p) };"
    )
    .is_empty());
    // Forbidden: upward imports in every spelling, and outside paths.
    assert_eq!(
        check("kernel", &["kernel"], "use crate::sim::Simulation;").len(),
        1
    );
    assert_eq!(
        check("kernel", &["kernel"], "fn f(s: &crate::sim::Simulation) {}").len(),
        1
    );
    assert_eq!(
        check("kernel", &["kernel"], "use crate::{error::E, sim::S, ffi};").len(),
        2
    );
    assert_eq!(
        check("kernel", &["kernel", "grid"], "use super::super::sim::S;").len(),
        1
    );
    assert_eq!(
        check(
            "kernel",
            &["kernel"],
            "mod tests { use super::super::sim; }"
        )
        .len(),
        1
    );
    assert_eq!(
        check("kernel", &["kernel"], "let t: libc::timespec;").len(),
        1
    );
    assert_eq!(
        check("kernel", &["kernel"], "use std::os::raw::c_int;").len(),
        1
    );
    assert_eq!(
        check("kernel", &["kernel"], "use std::{ffi::CStr, os::raw};").len(),
        2
    );
    assert!(check(
        "kernel",
        &["kernel"],
        "let b = br\"crate::sim\"; let v: Vec<u8>;"
    )
    .is_empty());
    assert_eq!(
        check("kernel", &["kernel"], "extern \"C\" { fn f(); }").len(),
        1
    );
    assert_eq!(check("sim", &["sim"], "use mpi_sys as m;").len(), 1);
    assert_eq!(check("error", &["error"], "$crate::kernel::f()").len(), 1);
    assert!(check("ffi", &["ffi"], "use libc::c_int; use crate::sim::S;").is_empty());
    // A lifetime is no character literal: the code after it is read.
    assert_eq!(
        check("kernel", &["kernel"], "fn f<'a>(x: &'a crate::sim::S) {}").len(),
        1
    );
    // Tables with a cycle are refused.
    let cyclic = "//! <!-- layers:begin -->\n//! | m | i | c |\n//! |---|---|---|\n\
                  //! | `a` | `b` | |\n//! | `b` | `a` | |\n//! <!-- layers:end -->\n";
    assert!(cycle(&table(cyclic)).is_some());
}
