//! Helpers shared by the end-to-end tests of `trace-bench` (each test file is its own crate
//! and uses what it needs).
#![allow(dead_code)]

use std::path::Path;
use tb_harness::experiment::config::{self, Overrides};

/// Run `trace-bench ARGS…` in-process; the exit code.
pub fn run(args: &[&str]) -> i32 {
    let mut v: Vec<std::ffi::OsString> = vec!["trace-bench".into()];
    v.extend(args.iter().map(|a| a.into()));
    trace_bench::run(v)
}

/// The error of a config text that must not parse (named `configs/test.toml`).
pub fn parse_err(text: &str) -> String {
    let file = Path::new("configs/test.toml");
    match config::parse(file, text, &Overrides::default(), &mut |_| {}) {
        Ok(_) => panic!("config should not parse:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// `trace-bench run CONFIG --out OUT -q`; the exit code.
pub fn run_quiet(config: &Path, out: &Path) -> i32 {
    run(&[
        "run",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ])
}
