//! Every collective call of `include/gimlet.h` has a case in the 2-rank
//! mismatch test (`tests/c/test_mismatch.c`, ctest `mismatch_np2`): the
//! ranks pass different arguments, or an argument valid on one rank only,
//! or make different calls, and both must fail with the same status and
//! message. A call is collective unless its documentation says "Local"
//! (the C ABI's convention); `gimlet_destroy`, which documents that it
//! makes no agreement, is the one call without a case. A new collective
//! call without a case fails here, so the table stays complete.

use std::collections::BTreeSet;
use std::path::PathBuf;

/// The header's functions, each with its documentation comment.
fn documented_functions(header: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut doc = String::new();
    let mut in_doc = false;
    for line in header.lines() {
        let t = line.trim();
        if t.starts_with("/*") {
            in_doc = true;
            doc.clear();
        }
        if in_doc {
            doc.push_str(t);
            doc.push('\n');
            if t.ends_with("*/") {
                in_doc = false;
            }
            continue;
        }
        if let Some(start) = t.find("gimlet_").filter(|_| t.starts_with("int ")) {
            let name: String = t[start..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if t[start + name.len()..].starts_with('(') {
                out.push((name, std::mem::take(&mut doc)));
            }
        }
    }
    out
}

/// The calls documented as collective that need a mismatch case.
fn collective_calls(header: &str) -> BTreeSet<String> {
    documented_functions(header)
        .into_iter()
        .filter(|(_, doc)| !doc.contains("Local") && !doc.contains("makes no agreement"))
        .map(|(name, _)| name)
        .collect()
}

/// The calls the mismatch test's cases exercise: the call named first in
/// each `CASE(sim, stepable, "call", ...)` and `report("call", ...)`.
fn mismatch_cases(test: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for (i, _) in test.match_indices('"') {
        let before = test[..i].trim_end();
        let opens_case = before.ends_with("report(")
            || before.rfind("CASE(").is_some_and(|k| {
                let args = &before[k + 5..];
                args.matches(',').count() == 2 && !args.contains(')') && !args.contains('"')
            });
        let rest = &test[i + 1..];
        if opens_case && rest.starts_with("gimlet_") {
            if let Some(end) = rest.find('"') {
                out.insert(rest[..end].to_string());
            }
        }
    }
    out
}

/// Collective calls without a case, and cases that name no function of the
/// header.
fn gaps(header: &str, test: &str) -> (Vec<String>, Vec<String>) {
    let collective = collective_calls(header);
    let all: BTreeSet<String> = documented_functions(header)
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    let cases = mismatch_cases(test);
    let uncovered = collective.difference(&cases).cloned().collect();
    let unknown = cases.difference(&all).cloned().collect();
    (uncovered, unknown)
}

fn read(rel: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(rel);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn every_collective_call_has_a_mismatch_case() {
    let header = read("include/gimlet.h");
    let test = read("tests/c/test_mismatch.c");
    let collective = collective_calls(&header);
    // The header's functions were found (a parse that finds none would
    // make the check pass vacuously).
    assert!(
        collective.len() >= 40 && collective.contains("gimlet_step"),
        "found only {} collective calls in include/gimlet.h: {collective:?}",
        collective.len()
    );
    let (uncovered, unknown) = gaps(&header, &test);
    assert!(
        uncovered.is_empty(),
        "collective calls of include/gimlet.h without a case in tests/c/test_mismatch.c: {uncovered:?}"
    );
    assert!(
        unknown.is_empty(),
        "cases of tests/c/test_mismatch.c naming no function of include/gimlet.h: {unknown:?}"
    );
    println!(
        "{} collective calls, each with a case in tests/c/test_mismatch.c",
        collective.len()
    );
}

#[test]
fn a_call_without_a_case_is_found() {
    let header = "/*\n Sets a. Collective.\n */\nint gimlet_set_a(struct GimletSim *sim, int a);\n\n\
                  /*\n Gets b. Local.\n */\nint gimlet_get_b(struct GimletSim *sim, int *b);\n\n\
                  /*\n Sets c (nothing said).\n */\nint gimlet_set_c(struct GimletSim *sim, int c);\n\n\
                  /*\n Frees. It makes no agreement.\n */\nint gimlet_free(struct GimletSim **sim);\n";
    let test = "  CASE(sim, 0, \"gimlet_set_a\", \"different a\", \"a\", gimlet_set_a(sim, r));\n\
                report(\"gimlet_gone\", \"different x\", rc, \"x\");\n";
    let (uncovered, unknown) = gaps(header, test);
    assert_eq!(uncovered, ["gimlet_set_c"]);
    assert_eq!(unknown, ["gimlet_gone"]);
}
