//! Devices behind one interface: the runner hands each row's job to a [`Device`], which
//! fills the row's timing, hit-rate and counter columns and validates its answers against
//! the oracle's sample, so CPU and GPU rows go through the same code in the runner.
//!
//! - [`cpu::CpuDevice`]: rayon pools per thread count; counts once per traversal x test x
//!   batch over the whole batch (a separate pass with [`tb_core::TraversalStats`]), validates
//!   that pass's hits against the oracle, times per thread count with counters compiled out
//!   ([`tb_core::NoStats`]) on the timed rays (`run.timed_rays`, all by default), and checks
//!   that every timed pass gives the counting pass's answers.
//! - [`gpu::GpuDevice`]: wgpu through `tb-gpu`; uploads each build's GPU program once and
//!   each batch once per build, times the timed kernel, validates the hits it read back, then
//!   runs the counting kernel.

pub mod clocks;
pub mod cpu;
pub mod gpu;

use crate::experiment::batches::RayBatch;
use crate::experiment::validation::{Checked, Sample};
use tb_core::{Accel, TraversalInfo, TriTestKind};
use tb_results::output::Row;

/// One row's work: which build, traversal, test and batch, with how many threads and
/// repeats.
pub struct Job<'a> {
    /// The build traced.
    pub accel: &'a dyn Accel,
    /// Index of the traversal in the build's table.
    pub traversal: usize,
    /// The traversal's facts (name, counters, step cap, …).
    pub info: &'static TraversalInfo,
    /// The ray-triangle test.
    pub tri: TriTestKind,
    /// Index of the batch in the scene's batches (device caches are keyed by it).
    pub batch_index: usize,
    /// The ray batch traced.
    pub batch: &'a RayBatch,
    /// Worker threads of the row (CPU), 0 on the GPU.
    pub threads: usize,
    /// How to time it.
    pub timing: crate::experiment::timing::TimingPlan,
    /// Time it here; `false` when the runner times it later, interleaved with the rows of
    /// the same batch (`run.interleave`, CPU): the device then counts and validates only.
    pub time: bool,
    /// How many mismatching rays to keep for the report.
    pub max_report: usize,
}

/// What a device did with a job.
pub enum Outcome {
    /// The row is measured; the validation, when a sample was given.
    Measured(Option<Checked>),
    /// The device cannot run this job (no GPU kernel for the traversal, or a program the
    /// adapter refuses, e.g. an array over its binding size): the row's note.
    Unsupported(String),
}

/// A device that measures rows.
pub trait Device {
    /// `cpu` or `gpu` (the `device` column).
    fn name(&self) -> &'static str;

    /// A new build starts: drop what belonged to the previous one.
    fn begin_build(&mut self);

    /// Measure `job` into `row` (timing, hit rate, counters; `adapter`, `upload_ms`,
    /// `readback_ms` on the GPU) and validate against `sample`. `Err` is a device failure,
    /// after which the device answers every job with that error.
    fn measure(
        &mut self,
        job: &Job,
        sample: Option<&Sample>,
        row: &mut Row,
    ) -> Result<Outcome, String>;
}
