//! tb-results: what a run leaves behind, readable without the runner. The rows and their
//! writers ([`output`]: results.csv, results.json, flushed row by row), the rows of the other
//! CSVs trace-bench writes ([`tables`]: dynamic.csv, dynamic-choice.csv, weights.csv), the
//! `k=v;k=v` of the params and build statistics columns ([`pairs`]), the run's provenance
//! ([`meta`]), the statistics a row carries ([`stats`]: the median and its
//! interval), the counter regression check against a baseline ([`check`]), the merge of
//! shards' folders ([`merge`]) and the folder lock that keeps one writer per folder
//! ([`lock`]). The harness (tb-harness) writes results with it, the claims (tb-claims) read
//! them; errors are one line each ([`Error`]).

#![deny(missing_docs)]

pub mod check;
pub mod error;
pub mod finite;
pub mod lock;
pub mod merge;
pub mod meta;
pub mod output;
pub mod pairs;
pub mod stats;
pub mod tables;

pub use error::Error;

/// The exit status of a `trace-bench run` that completed every row (all written) but found
/// rows with oracle mismatches where the traversal must have none: named at the
/// run's end. `run --processes` and `reproduce` take it from a child as a completed run,
/// not a failed one, and pass it on (`run`) or say so in the report (`reproduce`).
pub const EXIT_MISMATCHES: i32 = 3;
