//! The `gpu` device of the runner: opens the adapter once per run, uploads each build's
//! arrays once and each ray batch once per build, then per row times the timed kernel
//! (warm-up, repeats), reads the hits back (validated against the oracle like CPU rows), and
//! runs the counting kernel for the counter columns.
//!
//! Rules (README, "GPU"): a GPU row has `device = gpu`, `threads = 0` (the column counts CPU
//! worker threads; one host thread drives the GPU), the adapter's `name / backend / driver`,
//! `upload_ms` (structure plus rays, host to device), `trace_ms_*` (kernel time: timestamps
//! or wall time around submit-and-wait) and `readback_ms` (hits, device to host). A
//! structure or traversal without a GPU kernel gets a row whose `note` says so. When the GPU
//! cannot be used (no adapter, a lost device, a validation error) the run prints one error
//! line, writes the GPU rows with the error as `note`, still writes every CPU row, and fails
//! (exit 1) only when the GPU was required ([`crate::config::GpuSpec::required`]).

use crate::config::GpuSpec;
use crate::output::Row;
use std::collections::HashMap;
use tb_bvh::Bvh;
use tb_core::compare::{compare, Mismatch};
use tb_core::{Accel, HitRecord, Query, Ray, StatsSummary, TriTestKind, Triangle};
use tb_gpu::{Gpu, GpuRays, GpuStructure, Structure};

/// The run's GPU, or why there is none.
pub struct GpuDevice {
    gpu: Result<Gpu, String>,
    /// Whether the GPU was demanded (a failure fails the run).
    pub required: bool,
}

/// What one GPU row produced besides its columns.
pub struct GpuOutcome {
    /// The first mismatching rays (at most `max_report`).
    pub first: Vec<Mismatch>,
}

/// Per-build GPU state: the uploaded structure and ray batches.
#[derive(Default)]
pub struct GpuBuild {
    structure: Option<Result<GpuStructure, String>>,
    rays: HashMap<usize, GpuRays>,
}

/// The structures and traversals with a GPU kernel.
pub fn has_kernel(structure: &str, traversal: &str) -> bool {
    matches!(
        (structure, traversal),
        ("brute-force", "linear") | ("bvh", "ordered")
    )
}

impl GpuDevice {
    /// Open the adapter `spec` chooses.
    pub fn open(spec: &GpuSpec) -> GpuDevice {
        GpuDevice {
            gpu: Gpu::new(&spec.choice).map_err(|e| e.to_string()),
            required: spec.required,
        }
    }

    /// The adapter's `name / backend / driver`, or the error that left the run without one.
    pub fn describe(&self) -> Result<String, String> {
        match &self.gpu {
            Ok(g) => Ok(g.adapter().label()),
            Err(e) => Err(e.clone()),
        }
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
                    "timing": if a.timestamps { "timestamp-queries" } else { "wall-clock" },
                    "watertight_fallback": if a.f64 { "f64" } else { "f32" },
                    "max_rays_per_dispatch": g.max_rays_per_dispatch(),
                })
            }
            Err(e) => serde_json::json!({ "error": e }),
        }
    }

    /// Fill a GPU row. `validation` is the oracle sample (indices into `rays`, expected
    /// hits). `Err` is a GPU failure, after which the device is unusable for the run.
    #[allow(clippy::too_many_arguments)]
    pub fn measure(
        &mut self,
        build: &mut GpuBuild,
        accel: &dyn Accel,
        tris: &[Triangle],
        batch_index: usize,
        rays: &[Ray],
        query: Query,
        tri: TriTestKind,
        warmup: usize,
        repeat: usize,
        validation: Option<(&[usize], &[HitRecord])>,
        max_report: usize,
        row: &mut Row,
    ) -> Result<GpuOutcome, String> {
        let gpu = self.gpu.as_ref().map_err(|e| e.clone())?;
        row.adapter = gpu.adapter().label();
        let r = measure_on(
            gpu,
            build,
            accel,
            tris,
            batch_index,
            rays,
            query,
            tri,
            warmup,
            repeat,
            validation,
            max_report,
            row,
        );
        if let Err(e) = &r {
            // A device error leaves the device unusable: later GPU rows name the same cause.
            self.gpu = Err(e.clone());
        }
        r
    }
}

/// The arrays a GPU kernel reads for `accel` (one with a kernel: [`has_kernel`]).
fn structure_of<'a>(accel: &'a dyn Accel, tris: &'a [Triangle]) -> Result<Structure<'a>, String> {
    Ok(match accel.name() {
        "bvh" => Structure::Bvh(
            accel
                .as_any()
                .and_then(|a| a.downcast_ref::<Bvh>())
                .ok_or("the bvh build is not a tb_bvh::Bvh")?,
        ),
        _ => Structure::BruteForce(tris),
    })
}

impl GpuDevice {
    /// A [`tb_render::Tracer`] for the convergence renders of one build: the structure is
    /// uploaded once; each batch of rays is uploaded, traced (timed kernel, no counters) and
    /// read back, so the render's elapsed time includes both copies. `Err` when there is no
    /// adapter, no kernel for this structure and traversal, or the upload fails.
    pub fn tracer<'a>(
        &'a self,
        accel: &dyn Accel,
        traversal: &str,
        tris: &[Triangle],
        tri: TriTestKind,
    ) -> Result<GpuTracer<'a>, String> {
        let gpu = self.gpu.as_ref().map_err(|e| e.clone())?;
        if !has_kernel(accel.name(), traversal) {
            return Err(format!(
                "no GPU kernel for {} {traversal} yet",
                accel.name()
            ));
        }
        let s = gpu
            .upload(structure_of(accel, tris)?)
            .map_err(|e| e.to_string())?;
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

#[allow(clippy::too_many_arguments)]
fn measure_on(
    gpu: &Gpu,
    build: &mut GpuBuild,
    accel: &dyn Accel,
    tris: &[Triangle],
    batch_index: usize,
    rays: &[Ray],
    query: Query,
    tri: TriTestKind,
    warmup: usize,
    repeat: usize,
    validation: Option<(&[usize], &[HitRecord])>,
    max_report: usize,
    row: &mut Row,
) -> Result<GpuOutcome, String> {
    let s = build
        .structure
        .get_or_insert_with(|| {
            gpu.upload(structure_of(accel, tris)?)
                .map_err(|e| e.to_string())
        })
        .as_ref()
        .map_err(|e| e.clone())?;
    if let std::collections::hash_map::Entry::Vacant(v) = build.rays.entry(batch_index) {
        v.insert(gpu.upload_rays(rays).map_err(|e| e.to_string())?);
    }
    let g_rays = &build.rays[&batch_index];
    row.upload_ms = Some(s.upload_ms + g_rays.upload_ms);

    let mut times = Vec::with_capacity(repeat);
    for i in 0..warmup + repeat.max(1) {
        let t = gpu
            .trace(s, g_rays, query, tri, false)
            .map_err(|e| e.to_string())?;
        if i >= warmup {
            times.push(t.kernel_ms);
        }
    }
    let (hits, readback_ms) = gpu.read_hits(g_rays).map_err(|e| e.to_string())?;
    let med = crate::runner::median(&mut times);
    row.trace_ms_min = times.first().copied();
    row.trace_ms_max = times.last().copied();
    row.trace_ms_median = Some(med);
    row.mrays_per_s = Some(rays.len() as f64 / (med * 1e3).max(1e-12));
    row.readback_ms = Some(readback_ms);
    let nhit = hits.iter().filter(|h| h.is_hit()).count();
    row.hit_rate = Some(nhit as f64 / rays.len().max(1) as f64);

    gpu.trace(s, g_rays, query, tri, true)
        .map_err(|e| e.to_string())?;
    let (stats, _) = gpu.read_stats(g_rays).map_err(|e| e.to_string())?;
    let st = StatsSummary::from_stats(&stats);
    row.interior_per_ray = Some(st.mean[0]);
    row.interior_max = Some(st.max[0]);
    row.leaves_per_ray = Some(st.mean[1]);
    row.leaves_max = Some(st.max[1]);
    row.prims_per_ray = Some(st.mean[2]);
    row.prims_max = Some(st.max[2]);
    row.boxes_per_ray = Some(st.mean[3]);
    row.boxes_max = Some(st.max[3]);
    row.planes_per_ray = Some(st.mean[4]);
    row.planes_max = Some(st.max[4]);
    row.restarts_per_ray = Some(st.mean[5]);
    row.restarts_max = Some(st.max[5]);
    row.steps_per_ray = Some(st.mean[6]);
    row.steps_max = Some(st.max[6]);

    let mut first = Vec::new();
    if let Some((idx, expected)) = validation {
        let mut n = 0u64;
        for (&i, e) in idx.iter().zip(expected) {
            if let Some(kind) = compare(query, &rays[i], e, &hits[i]) {
                n += 1;
                if first.len() < max_report {
                    first.push(Mismatch {
                        index: i,
                        ray: rays[i],
                        expected: *e,
                        got: hits[i],
                        kind,
                    });
                }
            }
        }
        row.validated_rays = Some(idx.len() as u64);
        row.mismatches = Some(n);
    }
    Ok(GpuOutcome { first })
}
