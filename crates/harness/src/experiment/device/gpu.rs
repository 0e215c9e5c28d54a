//! The `gpu` device of the runner: opens the adapter once per run, uploads each build's GPU
//! program ([`tb_core::Accel::gpu_program`], the structure's own) once per traversal and each
//! ray batch once per build, then per row times the timed kernel
//! (warm-up, repeats), reads the hits back (validated against the oracle like CPU rows), and
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

use super::{Device, Job, Outcome};
use crate::experiment::config::spec::GpuSpec;
use crate::experiment::validation::{self, Sample};
use crate::results::output::Row;
use std::collections::HashMap;
use tb_core::{Accel, HitRecord, Query, Ray, StatsSummary, TriTestKind};
use tb_gpu::{Gpu, GpuError, GpuRays, GpuStructure};

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
}

/// Per-build GPU state: the uploaded program of each traversal and the ray batches.
#[derive(Default)]
struct GpuBuild {
    programs: HashMap<usize, Result<GpuStructure, UploadError>>,
    rays: HashMap<usize, GpuRays>,
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
        GpuDevice {
            gpu: Gpu::new(&spec.choice).map_err(|e| e.to_string()),
            required: spec.required,
            build: GpuBuild::default(),
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
        self.build = GpuBuild::default();
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
        let r = measure_on(gpu, &mut self.build, job, sample, row);
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
    job: &Job,
    sample: Option<&Sample>,
    row: &mut Row,
) -> Result<Outcome, String> {
    let (b, query, tri) = (job.batch, job.batch.query, job.tri);
    let upload = build.programs.entry(job.traversal).or_insert_with(|| {
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
    let timed_sort = s.arrange().is_some_and(|a| a.timed);
    let mut sorts = Vec::new();
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
    let (hits, readback_ms) = gpu.read_hits(g_rays).map_err(|e| e.to_string())?;
    crate::experiment::timing::fill(row, &mut times, b.rays.len(), job.timing.target_ci);
    row.readback_ms = Some(readback_ms);
    row.hit_rate = Some(validation::hit_rate(&hits));

    gpu.trace(s, g_rays, query, tri, true)
        .map_err(|e| e.to_string())?;
    let (stats, _) = gpu.read_stats(g_rays).map_err(|e| e.to_string())?;
    let summary = StatsSummary::from_stats(&stats);
    row.set_counters(&summary, job.info.counters);
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
