//! trace-bench harness: from a TOML config to result rows.
//!
//! Data flow: [`config::load`] parses the raw TOML (serde, `deny_unknown_fields`) and checks it
//! into an [`config::Experiment`] (scenes loaded, structures resolved against the
//! [`registry`], parameters checked against each structure's own table and sweeps expanded)
//! before any work starts; [`runner::run`] then, per scene, generates the ray batches once
//! ([`batches`]), builds each structure, and hands every row to a [`device`] (CPU or GPU,
//! one interface), which counts in one pass, validates against the brute-force oracle
//! ([`validation`]) and times the trace with counters compiled out ([`timing`]); each
//! [`output::Row`] is written as soon as it is finished. [`check`] compares the deterministic
//! counters of a results file with a baseline.

pub mod batches;
pub mod check;
pub mod claims;
pub mod config;
pub mod convergence;
pub mod device;
pub mod dynamic;
pub mod error;
pub mod heap;
pub mod images;
pub mod merge;
pub mod meta;
pub mod output;
pub mod params;
pub mod progress;
pub mod registry;
pub mod runner;
pub mod shard;
pub mod timing;
pub mod validation;

pub use error::HarnessError;

/// Tables 1 and 2 of Torres et al. 2012 (the multi-kd-trees' normalised weights), computed by
/// numerical integration (`trace-bench weights`).
pub use tb_kdtree::measure::{weight_rows, weight_tables, TABLE2_BETAS};
