//! trace-bench harness: from a TOML config to result rows.
//!
//! Data flow: [`config::load`] parses the raw TOML (serde, `deny_unknown_fields`) and checks it
//! into an [`config::Experiment`] (scenes loaded, structures resolved against the
//! [`registry`], parameter sweeps expanded) before any work starts; [`runner::run`] then, per
//! scene, generates the ray batches once, builds each structure, and per traversal x triangle
//! test x ray batch x thread count times the trace with counters compiled out, counts in a
//! second pass and validates against the brute-force oracle, writing each [`output::Row`] as
//! soon as it is finished. [`check`] compares the deterministic counters of a results file
//! with a baseline.

pub mod check;
pub mod config;
pub mod convergence;
pub mod device;
pub mod error;
pub mod images;
pub mod meta;
pub mod output;
pub mod params;
pub mod progress;
pub mod registry;
pub mod runner;
pub mod timing;
pub mod validation;

pub use error::HarnessError;
