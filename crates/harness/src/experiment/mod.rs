//! From a TOML config to result rows: the checked config ([`config`]), the ray batches
//! generated once per scene ([`batches`]), the runner ([`runner`]) that builds each structure
//! and hands every row to a device ([`device`]: CPU or GPU, one interface), which counts in
//! one pass, validates against the brute-force oracle ([`validation`]) and times the trace
//! with counters compiled out ([`timing`]); [`processes`] makes a run in several processes
//! ([`child`]: a run as a child process that ends with its parent). Beside the main runner,
//! each with its own config section: heat maps of primary rays ([`images`], `[run] images`),
//! image error against run time ([`convergence`], `[convergence]`) and the dynamic-scene
//! experiment ([`dynamic`], `[dynamic]`). Where a run's time went: [`phases`].

pub mod batches;
pub mod cache;
pub mod child;
pub mod config;
pub mod convergence;
pub mod device;
pub mod dynamic;
pub mod folder;
pub mod heap;
pub mod images;
pub mod params;
pub mod phases;
pub mod processes;
pub mod progress;
pub mod runner;
pub mod timing;
pub mod validation;
