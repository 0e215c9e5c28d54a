//! The deviations' texts agree with the code: every `check` of every
//! `claims/deviations/*.toml` holds on this repository's configs, claims files' `[[run]]`s and
//! sources, and each deviations file checks its image sizes, views, heavy runs and GPU stacks.

use std::path::Path;
use tb_claims as claims;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

#[test]
fn every_deviation_check_holds_on_the_repository() {
    let problems = claims::deviations::check(root());
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Every paper's deviations file carries checks (and still renders as its Markdown table).
#[test]
fn every_deviations_file_is_checked() {
    let dir = root().join("claims");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "toml") || p.file_stem().is_some_and(|s| s == "ci") {
            continue;
        }
        let f = claims::load(&p).unwrap_or_else(|e| panic!("{e}"));
        let ds = claims::deviations::load(&p, &f).unwrap_or_else(|e| panic!("{e}"));
        let checks: usize = ds.iter().map(|d| d.deviation.checks.len()).sum();
        assert!(checks >= 3, "{}: {checks} deviation checks", p.display());
        let md = claims::deviations::markdown(&ds);
        assert_eq!(md.lines().count(), ds.len() + 2, "{}", p.display());
        n += 1;
    }
    assert_eq!(n, 5);
}
