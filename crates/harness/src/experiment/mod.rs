//! From a TOML config to result rows: the checked config ([`config`]), the ray batches
//! generated once per scene ([`batches`]), the runner ([`runner`]) that builds each structure
//! and hands every row to a device ([`device`]: CPU or GPU, one interface), which counts in
//! one pass, validates against the brute-force oracle ([`validation`]) and times the trace
//! with counters compiled out ([`timing`]); [`processes`] makes a run in several processes.

pub mod batches;
pub mod config;
pub mod device;
pub mod heap;
pub mod params;
pub mod processes;
pub mod progress;
pub mod runner;
pub mod timing;
pub mod validation;
