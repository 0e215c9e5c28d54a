//! The `gpu` device of the runner: opens the adapter once per run, uploads each build's GPU
//! program ([`tb_core::Accel::gpu_program`], the structure's own) once per traversal and each
//! ray batch once per build, then per row times the timed kernel
//! (warm-up, repeats) between two probes of a fixed-work kernel ([`PROBE_MOVED`]), reads the hits back (validated against the oracle like CPU rows), and
//! runs the counting kernel for the counter columns.
//!
//! Rules (docs/GPU.md): a GPU row has `device = gpu`, `threads = 0` (the column counts CPU
//! worker threads; one host thread drives the GPU), the adapter's `name / backend / driver`,
//! `upload_ms` (structure plus rays, host to device), `trace_ms_*` (kernel time: timestamps
//! or wall time around submit-and-wait; for a program that sorts its rays by key, plus the
//! sort's time where [`tb_core::GpuArrange::timed`]), `sort_ms` (that sort's time, whether
//! counted or not), `readback_ms` (hits, device to host) and the note
//! [`CPU_BUILD_NOTE`] (every structure is built on the CPU, then uploaded). A
//! structure or traversal without a GPU kernel gets a row whose `note` says so. When the GPU
//! cannot be used (no adapter, a lost device, a validation error) the run prints one error
//! line, writes the GPU rows with the error as `note`, still writes every CPU row, and fails
//! (exit 1) only when the GPU was required ([`crate::experiment::config::GpuSpec::required`]).

use super::clocks::Clocks;
use super::{Device, Job, Outcome};
use crate::experiment::config::spec::GpuSpec;
use crate::experiment::validation::{self, Sample};
use std::collections::HashMap;
use std::time::Instant;
use tb_core::{Accel, HitRecord, Query, Ray, StatsSummary, TriTestKind};
use tb_gpu::{Gpu, GpuError, GpuRays, GpuStructure};
use tb_results::output::Row;

/// The note of every measured GPU row: no structure is built on the GPU (the built arrays are
/// uploaded; the row's build columns are the CPU build's). The papers of the GPU grids build
/// on the GPU (Pérard-Gayot et al. 2017 §4, Kalojanov et al. 2011), so the rows say so.
pub const CPU_BUILD_NOTE: &str = "built on the CPU";

/// The run's GPU, or why there is none.
pub struct GpuDevice {
    gpu: Result<Gpu, String>,
    /// Whether the GPU was demanded (a failure fails the run).
    pub required: bool,
    /// The current build's uploaded programs (per traversal) and ray batches.
    build: GpuBuild,
    /// The run's first probe time and the clocks' sampler.
    watch: Watch,
    /// Keep every build's programs until [`GpuDevice::keep_builds`] is called again
    /// (`run.interleave`: the builds of a table are timed together after all are made).
    keep: bool,
}

/// What every timed GPU row is watched by: the run's first probe time
/// ([`tb_gpu::Gpu::probe_ms`]), which later rows' probes are compared with, and the adapter's
/// clocks where the driver exposes them ([`Clocks`]).
#[derive(Default)]
struct Watch {
    probe_ref: Option<f64>,
    clocks: Option<Clocks>,
}

/// A GPU row whose probe (timed just before and just after its timed passes) moved by more
/// than this share from the run's first probe is flagged `noisy`, with a note: the GPU's
/// state (clocks, power, other work on it) changed while rows were timed.
pub const PROBE_MOVED: f64 = 0.05;

/// Per-build GPU state: the uploaded program of each traversal and the ray batches. With
/// interleaved timing ([`GpuDevice::keep_builds`]) it holds every kept build's programs,
/// told apart by the build's address.
#[derive(Default)]
struct GpuBuild {
    programs: HashMap<(usize, usize), Result<GpuStructure, UploadError>>,
    rays: HashMap<usize, GpuRays>,
}

/// The key of a job's program: its build's address and its traversal.
fn program_key(job: &Job) -> (usize, usize) {
    (
        job.accel as *const dyn Accel as *const () as usize,
        job.traversal,
    )
}

/// Why a build's program is not on the GPU.
enum UploadError {
    /// The adapter cannot hold or run it (an array over `max_storage_buffer_binding_size`,
    /// too many buffers, a loop too long for llvmpipe): the row's note; the device stays
    /// usable for the next rows.
    Refused(String),
    /// A device or program error: it fails the row and, as any device error, later GPU rows.
    Failed(String),
}

impl GpuDevice {
    /// Open the adapter `spec` chooses.
    pub fn open(spec: &GpuSpec) -> GpuDevice {
        let gpu = Gpu::new(&spec.choice).map_err(|e| e.to_string());
        let clocks = gpu.as_ref().ok().and_then(|g| {
            let (vendor, device) = g.adapter().pci;
            Clocks::start(vendor, device)
        });
        GpuDevice {
            gpu,
            required: spec.required,
            build: GpuBuild::default(),
            watch: Watch {
                probe_ref: None,
                clocks,
            },
            keep: false,
        }
    }

    /// The adapter's `name / backend / driver`, or the error that left the run without one.
    pub fn describe(&self) -> Result<String, String> {
        match &self.gpu {
            Ok(g) => Ok(g.adapter().label()),
            Err(e) => Err(e.clone()),
        }
    }

    /// A one-time warning when the adapter is a software rasterizer (lavapipe, llvmpipe):
    /// its rows measure the CPU, so their times are not GPU figures (`adapter_type` says
    /// `software` in every such row).
    pub fn software_warning(&self) -> Option<String> {
        let a = self.gpu.as_ref().ok()?.adapter();
        (a.kind() == "software").then(|| {
            format!(
                "the GPU adapter `{}` is a software rasterizer running on the CPU: GPU rows' \
                 counters and hits are valid, their times are not GPU figures (adapter_type = software)",
                a.name
            )
        })
    }

    /// Details for results.json `meta.adapter`.
    pub fn meta(&self) -> serde_json::Value {
        match &self.gpu {
            Ok(g) => {
                let a = g.adapter();
                serde_json::json!({
                    "name": a.name,
                    "backend": a.backend,
                    "driver": a.driver,
                    "device_type": a.device_type,
                    "adapter_type": a.kind(),
                    "timing": if a.timestamps { "timestamp-queries" } else { "wall-clock" },
                    "subgroups": a.subgroups.map(|(lo, hi)| format!("{lo}..={hi} invocations")),
                    "clocks": self.watch.clocks.as_ref().map(|_| format!(
                        "nvidia-smi every {} ms (gpu_sm_mhz_min, gpu_sm_mhz_max, gpu_mem_mhz)",
                        super::clocks::EVERY_MS
                    )),
                    "timed_sample": format!(
                        "back-to-back passes lasting at least {} ms (at most {}), trusted build without runtime checks{}",
                        tb_gpu::MIN_SAMPLE_MS,
                        tb_gpu::MAX_PASSES,
                        if tb_gpu::timed_passes_checked() {
                            " (TRACE_BENCH_GPU_CHECKED=1: checked)"
                        } else {
                            ""
                        }
                    ),
                    "probe": format!(
                        "a fixed-work kernel timed before and after each row's timed passes \
                         (probe_ms, probe_drift; beyond ±{} % from the run's first the row is noisy)",
                        PROBE_MOVED * 100.0
                    ),
                    "watertight_fallback": if a.f64 { "f64" } else { "f32" },
                    "max_rays_per_dispatch": g.max_rays_per_dispatch(),
                })
            }
            Err(e) => serde_json::json!({ "error": e }),
        }
    }
}

impl Device for GpuDevice {
    fn name(&self) -> &'static str {
        "gpu"
    }

    fn begin_build(&mut self) {
        if !self.keep {
            self.build = GpuBuild::default();
        }
    }

    fn measure(
        &mut self,
        job: &Job,
        sample: Option<&Sample>,
        row: &mut Row,
    ) -> Result<Outcome, String> {
        if !job.accel.has_gpu_program(job.traversal) {
            return Ok(Outcome::Unsupported(format!(
                "no GPU kernel for {} {} yet",
                job.accel.name(),
                job.info.name
            )));
        }
        let gpu = self.gpu.as_ref().map_err(|e| e.clone())?;
        row.adapter = gpu.adapter().label();
        row.adapter_type = gpu.adapter().kind().to_owned();
        let r = measure_on(gpu, &mut self.build, &mut self.watch, job, sample, row);
        if let Ok(Outcome::Measured(_)) = &r {
            row.note = if row.note.is_empty() {
                CPU_BUILD_NOTE.to_string()
            } else {
                format!("{}; {CPU_BUILD_NOTE}", row.note)
            };
        }
        if let Err(e) = &r {
            // A device error leaves the device unusable: later GPU rows name the same cause.
            self.gpu = Err(e.clone());
        }
        r
    }
}

impl GpuDevice {
    /// Keep every build's uploaded programs (`true`, from the start of a table timed
    /// interleaved until its rows are timed) or one build's at a time (`false`); either call
    /// drops what was kept.
    pub fn keep_builds(&mut self, keep: bool) {
        self.keep = keep;
        self.build = GpuBuild::default();
    }

    /// Time `jobs` (GPU rows of one batch and triangle test, of one or several kept builds,
    /// each already measured with `time: false`) interleaved under `plan`, as the CPU's rows
    /// are ([`crate::experiment::timing::TimingPlan::run_interleaved`]): each round one
    /// sustained sample of each row in turn, so that a change of the GPU's state falls on
    /// every row alike. The probe is timed before and after the group. Fills each row's
    /// timing, `sort_ms` and probe columns.
    pub fn time_interleaved(
        &mut self,
        jobs: &[Job],
        plan: &crate::experiment::timing::TimingPlan,
        rows: &mut [&mut Row],
    ) -> Result<(), String> {
        let gpu = self.gpu.as_ref().map_err(|e| e.clone())?;
        let mut programs = Vec::with_capacity(jobs.len());
        for j in jobs {
            let s = match self.build.programs.get(&program_key(j)) {
                Some(Ok(s)) => s,
                _ => return Err("a row timed interleaved has no uploaded program".into()),
            };
            let rays = self
                .build
                .rays
                .get(&j.batch_index)
                .ok_or("a row timed interleaved has no uploaded rays")?;
            programs.push((s, rays, s.arrange().is_some_and(|a| a.timed)));
        }
        let before = gpu.probe_ms().map_err(|e| e.to_string())?;
        let from = Instant::now();
        let mut sorts = vec![Vec::new(); jobs.len()];
        let times = plan.run_interleaved(jobs.len(), |i| {
            let (s, rays, timed_sort) = programs[i];
            let j = &jobs[i];
            let t = gpu
                .trace(s, rays, j.batch.query, j.tri, false)
                .map_err(|e| e.to_string())?;
            sorts[i].extend(t.sort_ms);
            let sort = if timed_sort { t.sort_ms } else { None };
            Ok::<_, String>(t.kernel_ms + sort.unwrap_or(0.0))
        })?;
        let to = Instant::now();
        let after = gpu.probe_ms().map_err(|e| e.to_string())?;
        for (((row, mut t), s), j) in rows.iter_mut().zip(times).zip(sorts).zip(jobs) {
            let warmups = s.len().saturating_sub(t.len());
            let mut s = s[warmups..].to_vec();
            row.sort_ms = (!s.is_empty()).then(|| crate::experiment::timing::median(&mut s));
            crate::experiment::timing::fill(row, &mut t, j.batch.rays.len(), plan.target_ci);
            self.watch.row(row, before, after, from, to);
        }
        Ok(())
    }

    /// A [`tb_render::Tracer`] for the convergence renders of one build: the structure is
    /// uploaded once; each batch of rays is uploaded, traced (timed kernel, no counters) and
    /// read back, so the render's elapsed time includes both copies. `Err` when there is no
    /// adapter, no kernel for this structure and traversal, or the upload fails.
    pub fn tracer<'a>(
        &'a self,
        accel: &dyn Accel,
        traversal: usize,
        tri: TriTestKind,
    ) -> Result<GpuTracer<'a>, String> {
        let gpu = self.gpu.as_ref().map_err(|e| e.clone())?;
        let program = accel.gpu_program(traversal).ok_or_else(|| {
            let t = accel.traversals()[traversal].name;
            format!("no GPU kernel for {} {t} yet", accel.name())
        })?;
        let s = gpu.upload(&program).map_err(|e| e.to_string())?;
        Ok(GpuTracer {
            gpu,
            s,
            tri,
            error: std::sync::Mutex::new(None),
        })
    }
}

/// Traces batches on the GPU for [`tb_render`]'s integrators ([`GpuDevice::tracer`]).
pub struct GpuTracer<'a> {
    gpu: &'a Gpu,
    s: GpuStructure,
    tri: TriTestKind,
    error: std::sync::Mutex<Option<String>>,
}

impl GpuTracer<'_> {
    /// The first GPU error met while tracing (its batch was answered with misses).
    pub fn error(&self) -> Option<String> {
        self.error.lock().map(|e| e.clone()).unwrap_or(None)
    }
}

impl tb_render::Tracer for GpuTracer<'_> {
    fn trace(&self, query: Query, rays: &[Ray], hits: &mut [HitRecord]) {
        if self.error().is_some() {
            hits.fill(HitRecord::MISS);
            return;
        }
        match self.gpu.trace_once(&self.s, rays, query, self.tri, false) {
            Ok((h, _)) => hits.copy_from_slice(&h),
            Err(e) => {
                if let Ok(mut slot) = self.error.lock() {
                    *slot = Some(e.to_string());
                }
                hits.fill(HitRecord::MISS);
            }
        }
    }
}

/// Upload (once per build and traversal, once per batch), time, read back, validate, count.
fn measure_on(
    gpu: &Gpu,
    build: &mut GpuBuild,
    watch: &mut Watch,
    job: &Job,
    sample: Option<&Sample>,
    row: &mut Row,
) -> Result<Outcome, String> {
    let (b, query, tri) = (job.batch, job.batch.query, job.tri);
    let upload = build.programs.entry(program_key(job)).or_insert_with(|| {
        let program = job
            .accel
            .gpu_program(job.traversal)
            .ok_or_else(|| UploadError::Failed("no GPU program".into()))?;
        gpu.upload(&program).map_err(|e| match e {
            GpuError::TooLarge { .. } | GpuError::Unsupported(_) => {
                UploadError::Refused(e.to_string())
            }
            e => UploadError::Failed(e.to_string()),
        })
    });
    let s = match upload {
        Ok(s) => s,
        Err(UploadError::Refused(note)) => return Ok(Outcome::Unsupported(note.clone())),
        Err(UploadError::Failed(e)) => return Err(e.clone()),
    };
    if let std::collections::hash_map::Entry::Vacant(v) = build.rays.entry(job.batch_index) {
        v.insert(gpu.upload_rays(&b.rays).map_err(|e| e.to_string())?);
    }
    let g_rays = &build.rays[&job.batch_index];
    row.upload_ms = Some(s.upload_ms + g_rays.upload_ms);

    // A program that sorts its rays: the sort's time per run, added to the trace's when the
    // program says the sort is timed ("inc."), kept apart otherwise ("n.inc.").
    if !job.time {
        // Timed later, interleaved (GpuDevice::time_interleaved): one untimed pass's hits.
        gpu.trace_untimed(s, g_rays, query, tri)
            .map_err(|e| e.to_string())?;
        let (hits, readback_ms) = gpu.read_hits(g_rays).map_err(|e| e.to_string())?;
        row.readback_ms = Some(readback_ms);
        return count_and_check(gpu, s, g_rays, job, sample, row, &hits);
    }
    let timed_sort = s.arrange().is_some_and(|a| a.timed);
    let mut sorts = Vec::new();
    let before = gpu.probe_ms().map_err(|e| e.to_string())?;
    let from = Instant::now();
    let mut times = job.timing.run(|| {
        let t = gpu
            .trace(s, g_rays, query, tri, false)
            .map_err(|e| e.to_string())?;
        sorts.extend(t.sort_ms);
        let sort = if timed_sort { t.sort_ms } else { None };
        Ok::<_, String>(t.kernel_ms + sort.unwrap_or(0.0))
    })?;
    // The warm-up runs' sorts are not timed runs.
    let warmups = sorts.len().saturating_sub(times.len());
    let sorts = &mut sorts[warmups..];
    row.sort_ms = (!sorts.is_empty()).then(|| crate::experiment::timing::median(sorts));
    let to = Instant::now();
    let after = gpu.probe_ms().map_err(|e| e.to_string())?;
    let (hits, readback_ms) = gpu.read_hits(g_rays).map_err(|e| e.to_string())?;
    crate::experiment::timing::fill(row, &mut times, b.rays.len(), job.timing.target_ci);
    watch.row(row, before, after, from, to);
    row.readback_ms = Some(readback_ms);
    count_and_check(gpu, s, g_rays, job, sample, row, &hits)
}

/// The hit rate, the counting pass's counter columns, and the validation of `hits`.
fn count_and_check(
    gpu: &Gpu,
    s: &GpuStructure,
    g_rays: &GpuRays,
    job: &Job,
    sample: Option<&Sample>,
    row: &mut Row,
    hits: &[HitRecord],
) -> Result<Outcome, String> {
    let (query, tri) = (job.batch.query, job.tri);
    row.hit_rate = Some(validation::hit_rate(hits));

    gpu.trace(s, g_rays, query, tri, true)
        .map_err(|e| e.to_string())?;
    let (stats, _) = gpu.read_stats(g_rays).map_err(|e| e.to_string())?;
    let summary = StatsSummary::from_stats(&stats);
    row.set_counters(&summary, job.info.counters);
    if let Some(why) = s.own_counts() {
        // Counters that are not the CPU traversal's ray for ray say so.
        let own = format!("counters are the GPU's own: {why}");
        row.note = if row.note.is_empty() {
            own
        } else {
            format!("{}; {own}", row.note)
        };
    }
    // Rays ended by the step cap, as the CPU rows count them (the kernel writes `capped`).
    if job.info.step_cap {
        row.capped_rays = Some(summary.capped);
    }

    let checked = sample.map(|smp| {
        let got: Vec<HitRecord> = smp.idx.iter().map(|&i| hits[i]).collect();
        validation::check(query, smp, &got, job.max_report)
    });
    Ok(Outcome::Measured(checked))
}

/// The row's probe columns: `probe_ms`, the mean of the probes before and after its timed
/// passes; `probe_drift`, the one farther from the run's first probe, relative to it. A drift
/// beyond [`PROBE_MOVED`] flags the row `noisy` (the note stays the row's own).
impl Watch {
    /// A timed row's probes (`before`, `after` its timed passes, [`probe`]) and the clocks
    /// sampled between `from` and `to`, its timed passes.
    fn row(&mut self, row: &mut Row, before: f64, after: f64, from: Instant, to: Instant) {
        probe(row, &mut self.probe_ref, before, after);
        if let Some(w) = self.clocks.as_ref().and_then(|c| c.window(from, to)) {
            row.gpu_sm_mhz_min = Some(w.sm_min);
            row.gpu_sm_mhz_max = Some(w.sm_max);
            row.gpu_mem_mhz = Some(w.mem);
        }
    }
}

fn probe(row: &mut Row, reference: &mut Option<f64>, before: f64, after: f64) {
    let r = *reference.get_or_insert(before);
    let drift = [before / r - 1.0, after / r - 1.0]
        .into_iter()
        .max_by(|a, b| a.abs().total_cmp(&b.abs()))
        .unwrap_or(0.0);
    row.probe_ms = Some((before + after) / 2.0);
    row.probe_drift = Some(drift);
    if drift.abs() > PROBE_MOVED {
        row.noisy = Some(true);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_whose_probe_moved_is_flagged() {
        let mut reference = None;
        let mut a = Row::default();
        probe(&mut a, &mut reference, 2.0, 2.04);
        assert_eq!(reference, Some(2.0));
        assert_eq!(a.noisy, None);
        assert!((a.probe_drift.unwrap() - 0.02).abs() < 1e-12);
        assert!((a.probe_ms.unwrap() - 2.02).abs() < 1e-12);
        let mut b = Row::default();
        probe(&mut b, &mut reference, 1.98, 1.7);
        assert_eq!(b.noisy, Some(true));
        assert!((b.probe_drift.unwrap() + 0.15).abs() < 1e-12);
    }
}
