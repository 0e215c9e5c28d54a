//! trace-bench harness: from a TOML config to result rows and verdicts, grouped by what it does.
//!
//! Data flow: [`experiment::config::load`] parses the raw TOML (serde, `deny_unknown_fields`)
//! and checks it into an [`experiment::config::Experiment`] (scenes loaded, structures resolved
//! against the [`registry`], parameters checked against each structure's own table and sweeps
//! expanded) before any work starts; [`experiment::runner::run`] then, per scene, generates
//! the ray batches once, builds each structure, and hands every row to a device (CPU or GPU,
//! one interface), which counts in one pass, validates against the brute-force oracle and
//! times the trace with counters compiled out; each [`tb_results::output::Row`] is written as
//! soon as it is finished; beside the runner, [`experiment::images`] draws heat maps and
//! [`experiment::convergence`] and [`experiment::dynamic`] make their own tables; [`tb_results::check`] compares the deterministic counters of a results file with a
//! baseline; [`cluster`] splits a run into shards. The claims (tb-claims) turn rows into verdicts.

#![deny(missing_docs)]

pub mod cluster;
pub mod error;
pub mod experiment;
pub mod registry;

pub use error::HarnessError;
