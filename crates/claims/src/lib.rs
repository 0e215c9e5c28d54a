//! tb-claims: the papers' claims as data, one generic evaluator (`trace-bench claims`) and
//! reproduce (`trace-bench reproduce`: a paper's runs, its verdicts, the report).
//!
//! A claims file (`claims/PAPER.toml`, format in `claims/README.md`) lists a paper's headline
//! claims: where each stands in the paper, the paper's figure, the rows of a results CSV it
//! compares (named [`Selector`]s), the measure, how rows pool and group, and a [`Test`] with a
//! band fixed from the paper's figure. [`evaluate`] turns rows into one [`Verdict`] per claim
//! and device: `agree`, `disagree` or `inconclusive` (rows missing, a time interval across a
//! bound, noisy or software-rendered timings), or `undecidable` where it cannot be decided by
//! construction. A claim is a statement of the paper (tallied), an observation or an invariant
//! ([`ClaimKind`], shown apart); [`deviations`] lists where our implementation differs from the
//! paper. Nothing here knows a paper or a structure: the files name columns, and any CSV a run
//! writes (`results.csv`, `dynamic.csv`, `weights.csv`) can be read ([`rows::RowSet`]).
//!
//! It reads results through tb-results and knows nothing of the runner: [`reproduce`] makes
//! its runs through [`reproduce::Runs`], which the CLI hands in (the runner's child processes
//! and config edits, from tb-harness). Errors are tb-results' ([`Error`]), one line each.

#![deny(missing_docs)]

mod columns;
pub mod deviations;
pub mod effect;
mod eval;
pub mod figures;
mod kinds;
mod measure;
mod pick;
pub mod render;
pub mod reproduce;
pub mod rows;
mod runs;
mod schema;
mod selector;
pub mod stability;

pub use eval::{
    evaluate, evaluate_with, ClaimResult, GroupResult, Options, Value, Verdict, TIME_FLOOR,
};
pub use rows::RowSet;
pub use schema::{
    Claim, ClaimKind, ClaimsFile, Direction, FigureSpec, Need, Pool, RunSpec, Selector, Test,
    GAP_SHARE,
};

use std::path::Path;
pub use tb_results::Error;

/// Read and check a claims file: TOML syntax and types (one line naming the line), then every
/// claim's ids, selectors, measure and test (one line naming the line of the claim's `id`).
pub fn load(path: &Path) -> Result<ClaimsFile, Error> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse(path, &text)
}

/// [`load`] on text already read.
pub fn parse(path: &Path, text: &str) -> Result<ClaimsFile, Error> {
    let mut file: ClaimsFile = toml::from_str(text).map_err(|e| syntax_error(path, text, &e))?;
    file.share_notes(path, text)?;
    // No bound, margin, cost or selector value is NaN or infinite.
    tb_results::finite::check_toml(path, text)?;
    file.check(path, text)?;
    Ok(file)
}

/// A TOML syntax or type error of the file at `path` in one line, naming the line.
pub(crate) fn syntax_error(path: &Path, text: &str, e: &toml::de::Error) -> Error {
    let line = e
        .span()
        .map(|s| format!("{}: ", tb_results::error::line_of(text, s.start)));
    Error::ConfigSyntax {
        file: path.into(),
        message: format!(
            "{}{}",
            line.unwrap_or_default(),
            e.message().trim().replace('\n', " ")
        ),
    }
}
