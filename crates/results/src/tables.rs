//! The rows of the CSVs trace-bench writes beside results.csv: `dynamic.csv` and
//! `dynamic-choice.csv` (written by the harness's `[dynamic]` experiment,
//! `tb_harness::experiment::dynamic`) and the columns of `weights.csv` (`trace-bench weights
//! --csv`), so that what reads them (the claims) knows them without the runner.

use serde::{Deserialize, Serialize};

/// One row of `dynamic.csv`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DynamicRow {
    /// Row label (the scene).
    pub scene: String,
    /// The scene's source at this frame (`frame=F` appended).
    pub source: String,
    /// The structure's registry name.
    pub structure: String,
    /// The structure's parameters with the chosen densities.
    pub params: String,
    /// Threads the frame was built and traced with.
    pub threads: u32,
    /// Image width, pixels (one primary ray per pixel).
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The frame budget, ms.
    pub budget_ms: f64,
    /// The animation frame.
    pub frame: u32,
    /// Triangles in the scene at this frame.
    pub triangles: u64,
    /// The chosen top-level density λ_1.
    pub lambda_1: f64,
    /// The second-level density λ_2 (`ratio` · λ_1).
    pub lambda_2: f64,
    /// Build time from scratch, ms (median of `run.build_repeat`).
    pub build_ms: f64,
    /// Trace time of the primary rays (closest hit), ms.
    pub primary_ms: f64,
    /// Trace time of one AO sample per pixel (one ray per primary hit).
    pub ao_ms_per_spp: f64,
    /// AO samples per pixel that fit: `floor((budget − build − primary) / ao)`, at least 0.
    pub spp: u32,
}

/// One candidate of the automatic choice, in `dynamic-choice.csv`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ChoiceRow {
    /// Row label (the scene).
    pub scene: String,
    /// The structure's registry name.
    pub structure: String,
    /// The candidate's parameter set, `k=v;k=v`.
    pub params: String,
    /// The frame the candidates are timed at (the first listed).
    pub frame: u32,
    /// The candidate's top-level density λ_1.
    pub lambda_1: f64,
    /// Its second-level density λ_2 (`ratio` · λ_1).
    pub lambda_2: f64,
    /// Build time with this candidate, ms.
    pub build_ms: f64,
    /// Trace time of the primary rays with this candidate, ms.
    pub primary_ms: f64,
    /// Trace time of one AO sample per pixel with this candidate, ms.
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
