//! The rows of the CSVs trace-bench writes beside results.csv: `dynamic.csv` and
//! `dynamic-choice.csv` (written by the harness's `[dynamic]` experiment,
//! `tb_harness::experiment::dynamic`) and the columns of `weights.csv` (`trace-bench weights
//! --csv`), so that what reads them (the claims) knows them without the runner.

use serde::{Deserialize, Serialize};

/// One row of `dynamic.csv`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DynamicRow {
    pub scene: String,
    pub source: String,
    pub structure: String,
    /// The structure's parameters with the chosen densities.
    pub params: String,
    pub threads: u32,
    pub width: u32,
    pub height: u32,
    pub budget_ms: f64,
    pub frame: u32,
    pub triangles: u64,
    pub lambda_1: f64,
    pub lambda_2: f64,
    pub build_ms: f64,
    pub primary_ms: f64,
    /// Trace time of one AO sample per pixel (one ray per primary hit).
    pub ao_ms_per_spp: f64,
    /// AO samples per pixel that fit: `floor((budget − build − primary) / ao)`, at least 0.
    pub spp: u32,
}

/// One candidate of the automatic choice, in `dynamic-choice.csv`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ChoiceRow {
    pub scene: String,
    pub structure: String,
    pub params: String,
    pub frame: u32,
    pub lambda_1: f64,
    pub lambda_2: f64,
    pub build_ms: f64,
    pub primary_ms: f64,
    pub ao_ms_per_spp: f64,
}

/// The columns of `weights.csv` (`trace-bench weights --csv`), in the order of
/// `tb_multikd::measure::weight_rows`' fields, each with whether it holds numbers.
pub const WEIGHTS_COLUMNS: [(&str, bool); 6] = [
    ("table", true),
    ("heuristic", false),
    ("beta", true),
    ("patch", false),
    ("axis", false),
    ("weight_pct", true),
];
