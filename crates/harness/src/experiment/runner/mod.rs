//! The runner: for each scene, generate the ray batches once ([`crate::experiment::batches`]); for each
//! structure and parameter set, plan the rows still to do ([`plan`]), build (timed, repeated,
//! validated: [`build`]), and hand each row to its device ([`crate::experiment::device`]), which counts in
//! one pass with [`tb_core::TraversalStats`], validates against the brute-force oracle
//! ([`crate::experiment::validation`]) and times the trace with counters compiled out. Each row is written
//! as soon as it is finished.

mod account;
pub mod build;
mod interleave;
mod measure;
pub mod plan;
pub mod table;

pub use table::table;

use crate::error::HarnessError;
use crate::experiment::batches::{generate_batches, RayBatch};
use crate::experiment::config::{
    Device as DeviceKind, Experiment, SceneSpec, StructureSpec, Validate,
};
use crate::experiment::device::cpu::CpuDevice;
use crate::experiment::device::gpu::GpuDevice;
use crate::experiment::device::{Device, Job, Outcome};
use crate::experiment::phases::Phases;
use crate::experiment::progress::Progress;
use crate::experiment::validation::{self, Oracle};
use build::Built;
use plan::Combo;
use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use tb_core::{ParamSet, TraversalInfo, TriTestKind, Triangle};
use tb_results::output::{Row, RowKey, Sink};

/// What the runner does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Time, count and validate; write results files.
    Run,
    /// Oracle comparison only (`trace-bench validate`): no timing, no files.
    Validate,
}

/// Options of a run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Output directory (results.csv, results.json); unused in [`Mode::Validate`].
    pub out: PathBuf,
    /// Continue an interrupted run in `out`, skipping the rows already written.
    pub resume: bool,
    /// No progress output.
    pub quiet: bool,
    /// Run (time and write) or only validate.
    pub mode: Mode,
    /// How many mismatching rays to keep per combination for the report.
    pub max_report: usize,
    /// The build cache ([`crate::experiment::cache`]), `None` to build every structure.
    pub cache: Option<crate::experiment::cache::BuildCache>,
}

impl RunOptions {
    /// A fresh run into `out` ([`Mode::Run`], no progress output, no resume): what a program
    /// or test embedding the runner usually wants.
    pub fn quiet(out: PathBuf) -> Self {
        RunOptions {
            out,
            resume: false,
            quiet: true,
            mode: Mode::Run,
            max_report: 4,
            cache: None,
        }
    }
}

/// What a run did.
#[derive(Debug, Default)]
pub struct RunSummary {
    /// The rows made in this session, in the order they were written.
    pub rows: Vec<Row>,
    /// How many rows were written in this session.
    pub written: usize,
    /// Rows skipped because an earlier session wrote them (`--resume`).
    pub skipped: usize,
    /// Mismatching rays over all rows made.
    pub mismatches: u64,
    /// Combinations that could not be completed (build failure, invalid structure).
    pub failures: Vec<String>,
    /// Human-readable reports of the first mismatching rays.
    pub mismatch_reports: Vec<String>,
    /// The rows with oracle mismatches that must have none ([`must_conform`]), one line each:
    /// `run` names them at its end and exits [`tb_results::EXIT_MISMATCHES`].
    pub wrong_rows: Vec<String>,
    /// Notes about what was left out and why.
    pub notes: Vec<String>,
}

/// Run the experiment. Returns what was done; errors only for I/O (results already written
/// stay written).
pub fn run(exp: &Experiment, opts: &RunOptions) -> Result<RunSummary, HarnessError> {
    let mut r = Run::open(exp, opts)?;
    // Notes are collected in the summary and printed once, after the run (stderr).
    r.summary.notes.extend(exp.skipped_scenes.iter().cloned());
    // A `[dynamic]` run measures frames only ([`crate::experiment::dynamic`]); validation still checks
    // every structure on each scene's first frame as configured.
    if let (Some(_), Mode::Run) = (&exp.dynamic, opts.mode) {
        let progress = &r.progress;
        let notes = crate::experiment::dynamic::run(exp, &opts.out, &|m| progress.step(m))?;
        r.summary.notes.extend(notes);
    } else {
        // The views of one scene table are consecutive specs sharing the scene: one group,
        // loaded once, each structure built once for all of them.
        for views in exp.scenes.chunk_by(|a, b| a.table == b.table) {
            r.scene(views)?;
        }
    }
    r.progress.finish();
    let (phases, cache) = r.account();
    r.cache_notes();
    if r.loaded_rows > 0 {
        r.summary.notes.push(format!(
            "{} rows were timed while other processes kept more than {} CPU cores busy \
             (measured per row; where /proc does not tell, the 1-minute load average above the \
             idle level {:.2} by more than the row's threads): their timings may be disturbed \
             (columns cpu_others, load_avg, noisy)",
            r.loaded_rows,
            crate::experiment::timing::OTHERS_NOISY,
            r.idle_load.unwrap_or(0.0)
        ));
    }
    if let Some(s) = r.sink.as_mut() {
        let status = if r.summary.failures.is_empty() {
            "complete"
        } else {
            "complete-with-failures"
        };
        s.set_meta("phases", phases.to_json());
        s.set_meta("build_cache", cache);
        s.finish(status)?;
    }
    Ok(r.summary)
}

/// The state of a run.
struct Run<'a> {
    exp: &'a Experiment,
    opts: &'a RunOptions,
    summary: RunSummary,
    sink: Option<Sink>,
    /// Rows an interrupted run already wrote.
    done: HashSet<RowKey>,
    progress: Progress,
    conv: Option<crate::experiment::convergence::Runner>,
    /// The devices rows are written for, with their thread counts.
    devices: Vec<(DeviceKind, Vec<usize>)>,
    cpu: CpuDevice,
    gpu: Option<GpuDevice>,
    /// The load average before any work (the machine's idle level).
    idle_load: Option<f64>,
    /// Rows timed while the load average exceeded the idle level by more than their threads.
    loaded_rows: usize,
    /// What the build cache did.
    cache_use: build::CacheUse,
    /// Where the run's time went (the CPU device keeps its own part).
    phases: Phases,
    started: Instant,
    /// Structures built or loaded from the cache.
    builds: usize,
}

impl<'a> Run<'a> {
    fn open(exp: &'a Experiment, opts: &'a RunOptions) -> Result<Self, HarnessError> {
        let mut summary = RunSummary::default();
        let running = opts.mode == Mode::Run;
        // The GPU is opened once, before any work, so results.json names the adapter.
        let gpu = (running && exp.run.devices.contains(&DeviceKind::Gpu))
            .then(|| GpuDevice::open(&exp.run.gpu));
        if let Some(Err(e)) = gpu.as_ref().map(GpuDevice::describe) {
            gpu_failed(&mut summary, gpu.as_ref(), &e);
        }
        if let Some(w) = gpu.as_ref().and_then(GpuDevice::software_warning) {
            summary.notes.push(w);
        }
        let sink = match opts.mode {
            Mode::Run => {
                let mut meta = tb_results::meta::collect(
                    &exp.file.display().to_string(),
                    &exp.text,
                    &exp.run.threads,
                );
                if let Some(g) = &gpu {
                    meta["adapter"] = g.meta();
                }
                meta["config_hash"] = exp.config_hash.clone().into();
                if let Some(v) = &exp.views {
                    // The named views the config read: with `config`, what reruns it.
                    meta["views_file"] = serde_json::json!({
                        "path": v.path.display().to_string(),
                        "text": v.text,
                    });
                }
                if let Some(p) = &exp.shard {
                    meta["shard"] = p.meta();
                }
                if let Some(p) = &exp.process {
                    meta["process"] = p.meta();
                }
                meta["binary_digest"] = crate::experiment::cache::exe_digest().into();
                Some(Sink::open(&opts.out, meta, opts.resume)?)
            }
            Mode::Validate => None,
        };
        let done = sink
            .as_ref()
            .map(|s| s.rows().iter().map(Row::key).collect())
            .unwrap_or_default();
        let devices = match opts.mode {
            Mode::Run => {
                crate::experiment::config::device_threads(&exp.run.devices, &exp.run.threads)
            }
            Mode::Validate => vec![(DeviceKind::Cpu, vec![0])],
        };
        let mut cpu = CpuDevice::new(&exp.run.threads, !running).map_err(HarnessError::other)?;
        if running {
            let first =
                crate::experiment::processes::first_rows(exp.process, &exp.config_hash, &opts.out);
            if let Some(rows) = first {
                cpu.count_once(rows);
            }
        }
        let total = match &exp.shard {
            Some(p) if opts.mode == Mode::Run => p.rows(),
            _ => plan::total_rows(exp, &devices),
        };
        let progress = Progress::new(total as u64, opts.quiet);
        let conv = match opts.mode {
            Mode::Run => crate::experiment::convergence::Runner::open(exp, &opts.out, opts.resume)?,
            Mode::Validate => None,
        };
        Ok(Run {
            exp,
            opts,
            summary,
            sink,
            done,
            progress,
            conv,
            devices,
            cpu,
            gpu,
            idle_load: crate::experiment::timing::load_average(),
            loaded_rows: 0,
            cache_use: build::CacheUse::default(),
            phases: Phases {
                load_s: exp.load_s,
                ..Phases::default()
            },
            started: Instant::now(),
            builds: 0,
        })
    }

    /// Every build and row of one scene table: its views (one spec without `views`) share
    /// the scene and each build; their batches are generated once, up front.
    fn scene(&mut self, views: &[SceneSpec]) -> Result<(), HarnessError> {
        let mut batches: Vec<RayBatch> = Vec::new();
        let mut ranges = Vec::with_capacity(views.len());
        let mut gen = None;
        let rays_started = Instant::now();
        for (i, spec) in views.iter().enumerate() {
            self.progress
                .step(&format!("{}: generating rays", spec.label));
            let start = batches.len();
            batches.extend(generate_batches(
                spec,
                self.exp.run.seed,
                &mut gen,
                i == 0,
                &mut self.summary.notes,
            ));
            ranges.push(start..batches.len());
            if let (Some(_), Mode::Run) = (&self.exp.images, self.opts.mode) {
                let out = &self.opts.out;
                self.summary
                    .notes
                    .extend(crate::experiment::images::write_scene(spec, out)?);
            }
        }
        drop(gen);
        self.phases.rays_s += rays_started.elapsed().as_secs_f64();
        let first = &views[0];
        let tris: Arc<[Triangle]> = first.scene.triangles.as_slice().into();
        // One oracle for the table: its samples are keyed by the batch's index over all views.
        let mut oracle = Oracle::new(tris.clone(), self.opts.cache.clone());
        let group = Group {
            views,
            ranges: &ranges,
            batches: &batches,
        };
        let done = if self.exp.run.interleave && self.opts.mode == Mode::Run {
            self.scene_interleaved(&group, &tris, &mut oracle)
        } else {
            self.scene_builds(&group, &tris, &mut oracle)
        };
        let u = &mut self.cache_use;
        u.oracle_loaded += oracle.loaded;
        u.oracle_computed += oracle.computed;
        u.notes.append(&mut oracle.notes);
        done
    }

    /// Every build of one scene table, one after another, each with its rows.
    fn scene_builds(
        &mut self,
        group: &Group,
        tris: &Arc<[Triangle]>,
        oracle: &mut Oracle,
    ) -> Result<(), HarnessError> {
        let first = &group.views[0];
        for (si, st) in self.exp.structures.iter().enumerate() {
            for (pi, params) in st.param_sets.iter().enumerate() {
                if let Some(p) = &self.exp.shard {
                    if !p.runs(&first.table, si, pi) {
                        continue;
                    }
                }
                self.structure(group, tris, oracle, st, params)?;
            }
        }
        Ok(())
    }

    /// The rows of one build still to do, per view, with batch indices over all views (rows
    /// an interrupted run wrote are counted as skipped).
    fn todo(&mut self, g: &Group, st: &StructureSpec, params_s: &str) -> Vec<Vec<Combo>> {
        let mut todo: Vec<Vec<Combo>> = Vec::with_capacity(g.views.len());
        for (spec, range) in g.views.iter().zip(g.ranges) {
            let rows = plan::BuildRows {
                scene: &spec.label,
                st,
                params: params_s,
                process: self.exp.process.map(|p| p.index as u32),
            };
            let (mut t, skipped) = plan::todo(
                &rows,
                &self.exp.run.triangle_tests,
                &g.batches[range.clone()],
                &self.devices,
                &self.done,
            );
            for c in &mut t {
                c.bi += range.start;
            }
            self.summary.skipped += skipped;
            for _ in 0..skipped {
                self.progress.inc();
            }
            todo.push(t);
        }
        todo
    }

    /// Build one structure x parameter set (timed); on failure write its rows with the error
    /// and give `None`.
    fn build_or_fail(
        &mut self,
        g: &Group,
        tris: &Arc<[Triangle]>,
        st: &StructureSpec,
        params: &ParamSet,
        todo: &[Vec<Combo>],
    ) -> Result<Option<Built>, HarnessError> {
        let params_s = params.to_string();
        let first = &g.views[0];
        self.progress.step(&format!(
            "{}: building {} [{params_s}]",
            first.table, st.family.name
        ));
        let timed = st.builds_timed(&self.exp.run);
        let plan = build::BuildPlan {
            repeat: if timed { self.exp.run.build_repeat } else { 1 },
            timed,
            cache: self.opts.cache.as_ref(),
        };
        let building = Instant::now();
        let made = build::build(
            st.family,
            tris,
            params,
            &st.traversals,
            &plan,
            &mut self.cache_use,
        );
        self.phases.build_s += building.elapsed().as_secs_f64();
        self.builds += 1;
        match made {
            Ok(b) => {
                self.cpu.begin_build();
                if let Some(gpu) = self.gpu.as_mut() {
                    gpu.begin_build();
                }
                Ok(Some(b))
            }
            Err(e) => {
                let msg = format!("{} {} [{params_s}]: {e}", first.table, st.family.name);
                self.progress.line(&format!("error: {msg}"));
                self.summary.failures.push(msg);
                for (spec, t) in g.views.iter().zip(todo) {
                    let base = base_row(spec, tris, st, &params_s);
                    for c in t {
                        let mut row = row_of(&base, st, c, &g.batches[c.bi]);
                        row.note = format!("build failed: {e}");
                        self.emit(row)?;
                    }
                }
                Ok(None)
            }
        }
    }

    /// Build one structure x parameter set and measure its rows on every view.
    fn structure(
        &mut self,
        g: &Group,
        tris: &Arc<[Triangle]>,
        oracle: &mut Oracle,
        st: &StructureSpec,
        params: &ParamSet,
    ) -> Result<(), HarnessError> {
        let params_s = params.to_string();
        let todo = self.todo(g, st, &params_s);
        if todo.iter().all(Vec::is_empty) {
            return Ok(());
        }
        let Some(built) = self.build_or_fail(g, tris, st, params, &todo)? else {
            return Ok(());
        };
        for (spec, t) in g.views.iter().zip(todo) {
            if t.is_empty() {
                continue;
            }
            let src = self.view_source(spec, g.batches, tris, st, &built, &params_s)?;
            for c in t {
                let row = self.measure_row(&src, oracle, c, true)?;
                self.emit(row)?;
            }
        }
        Ok(())
    }

    /// Heat maps and convergence renders of a build, where the config asks for them.
    fn after_build(
        &mut self,
        spec: &SceneSpec,
        st: &StructureSpec,
        built: &Built,
        params_s: &str,
    ) -> Result<(), HarnessError> {
        let done = build::BuildDone {
            scene: spec,
            accel: built.accel.as_ref(),
            params: params_s,
            build_ms: built.build_ms,
            traversals: &st.traversals,
            tests: &self.exp.run.triangle_tests,
        };
        if let (Some(img), Mode::Run) = (&self.exp.images, self.opts.mode) {
            let sweep: Vec<String> = st.param_sets.iter().map(|p| p.to_string()).collect();
            self.progress
                .step(&format!("{}: heat maps {}", spec.label, st.family.name));
            let tag = crate::experiment::images::varying_tag(&sweep, params_s);
            self.summary
                .notes
                .extend(crate::experiment::images::write_build(
                    &done,
                    img,
                    &self.opts.out,
                    &tag,
                )?);
        }
        if let Some(c) = self.conv.as_mut() {
            self.summary.notes.extend(c.build_done(
                &done,
                &self.exp.run.devices,
                self.gpu.as_ref(),
                &self.progress,
            )?);
        }
        Ok(())
    }

    /// A GPU failure `e`: said once (a line, and the summary's failure or note).
    fn gpu_failure(&mut self, e: &str) {
        let first = self.summary.failures.iter().all(|f| !f.contains(e))
            && self.summary.notes.iter().all(|n| !n.contains(e));
        if first {
            self.progress.line(&format!("error: gpu: {e}"));
            gpu_failed(&mut self.summary, self.gpu.as_ref(), e);
        }
    }

    /// Record the load of a timed row; flag it noisy when other work was running: other
    /// processes kept more than [`crate::experiment::timing::OTHERS_NOISY`] cores busy while the row was
    /// measured (`cpu_others`, sampled per row), or, where that cannot be measured, the load
    /// average exceeded the idle level by more than the row's own threads, plus one.
    fn note_load(&mut self, row: &mut Row) {
        row.load_avg = crate::experiment::timing::load_average();
        if let Some(others) = row.cpu_others {
            if others > crate::experiment::timing::OTHERS_NOISY {
                row.noisy = Some(true);
                self.loaded_rows += 1;
            }
        } else if let (Some(idle), Some(load)) = (self.idle_load, row.load_avg) {
            let own = if row.device == "gpu" {
                1.0
            } else {
                row.threads as f64
            };
            if load > idle + own + 1.0 {
                row.noisy = Some(true);
                self.loaded_rows += 1;
            }
        }
    }

    fn emit(&mut self, mut row: Row) -> Result<(), HarnessError> {
        row.process = self.exp.process.map(|p| p.index as u32);
        let params = varying_params(self.exp, &row.structure, &row.params);
        self.progress.row(&format!(
            "done {} {}{} {} {} {} {}t {}: {}",
            row.scene,
            row.structure,
            if params.is_empty() {
                String::new()
            } else {
                format!(" [{params}]")
            },
            row.traversal,
            row.triangle_test,
            row.device,
            row.threads,
            row.ray_kind,
            match (row.mrays_per_s, row.note.is_empty()) {
                (Some(m), _) => format!("{m:.2} MRays/s"),
                (None, false) => row.note.clone(),
                (None, true) => "validated".into(),
            }
        ));
        self.summary.mismatches += row.mismatches.unwrap_or(0);
        if let Some(s) = self.sink.as_mut() {
            s.push(row.clone())?;
            abort_hook(s.rows().len());
        }
        self.summary.written += 1;
        self.summary.rows.push(row);
        self.progress.inc();
        Ok(())
    }
}

/// The views of one scene table (one spec for a table without `views`) with their batches:
/// view `i`'s are `batches[ranges[i]]`.
struct Group<'g> {
    views: &'g [SceneSpec],
    ranges: &'g [std::ops::Range<usize>],
    batches: &'g [RayBatch],
}

/// Fault injection for the tests of `--resume`: with `TRACE_BENCH_ABORT_AFTER_ROWS=N` in the
/// environment, the process aborts (as if killed: no clean-up, results.json says "running")
/// once `results.csv` holds `N` rows.
fn abort_hook(rows: usize) {
    if let Some(n) = std::env::var("TRACE_BENCH_ABORT_AFTER_ROWS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    {
        if rows >= n {
            eprintln!("TRACE_BENCH_ABORT_AFTER_ROWS={n}: aborting after {rows} rows");
            std::process::abort();
        }
    }
}

/// A row's identity columns on top of the build's `base`.
/// A row of an interleaved table, with (build, view, combo) while it awaits its timing.
type PendingRow = (Row, Option<(usize, usize, Combo)>);

/// The columns every row of one view and build shares.
fn base_row(spec: &SceneSpec, tris: &Arc<[Triangle]>, st: &StructureSpec, params_s: &str) -> Row {
    Row {
        scene: spec.label.clone(),
        source: spec.scene.source.clone(),
        triangles: tris.len() as u64,
        structure: st.family.name.to_string(),
        params: params_s.to_owned(),
        method: crate::registry::method_of(st.family, false),
        host: tb_results::meta::host_name(),
        ..Default::default()
    }
}

/// The line naming a row that mismatches the oracle where it must not ([`must_conform`]).
fn wrong_row(row: &Row) -> String {
    format!(
        "{} {} [{}] {} {} {} {}: {} of {} rays mismatch the oracle",
        row.scene,
        row.structure,
        row.params,
        row.traversal,
        row.triangle_test,
        row.device,
        row.ray_kind,
        row.mismatches.unwrap_or(0),
        row.validated_rays.unwrap_or(0)
    )
}

/// Rays aimed at the geometry (primary, random, stress) that all missed: then `0 mismatches`
/// proves nothing (a scene at 1e-30 whose rays pass it by), which the row's note says.
fn note_all_missed(row: &mut Row, batch: &str) {
    let aimed = ["primary", "random", "stress"].contains(&batch);
    if aimed && row.hit_rate == Some(0.0) && row.note.is_empty() {
        row.note = "no ray hit anything: these rays were aimed at the scene, so 0 mismatches \
                    prove nothing here"
            .into();
    }
}

/// Whether a row's mismatches are wrong answers: every structure and traversal
/// answers as the oracle does with the watertight test (the conformance suite's rule), so a
/// mismatch there is a fault, unless the row is documented to differ: Möller–Trumbore (its
/// own misses at shared edges and in-plane rays, and beyond about 1e12: README, "Results
/// columns"), a traversal with a triangle test of its own (a peer's,
/// [`tb_core::TraversalInfo::own_triangle_test`]), or rays ended by a traversal's step cap
/// (`capped_rays`).
pub fn must_conform(info: &TraversalInfo, tri: TriTestKind, row: &Row) -> bool {
    tri == TriTestKind::Watertight
        && info.own_triangle_test.is_none()
        && row.capped_rays.unwrap_or(0) == 0
}

fn row_of(base: &Row, st: &StructureSpec, c: &Combo, b: &RayBatch) -> Row {
    Row {
        traversal: st.infos[c.ti].name.to_string(),
        method: crate::registry::method_of(st.family, c.dev.name() == "gpu"),
        device: c.dev.name().into(),
        threads: c.threads as u32,
        triangle_test: c.tri.name().into(),
        ray_kind: b.name.clone(),
        rays: b.rays.len() as u64,
        ..base.clone()
    }
}

/// Record a GPU failure once: a failure of the run when the GPU was required, else a note.
fn gpu_failed(summary: &mut RunSummary, gpu: Option<&GpuDevice>, e: &str) {
    let msg = format!("gpu: {e}");
    if gpu.is_some_and(|g| g.required) {
        summary.failures.push(msg);
    } else {
        summary.notes.push(format!(
            "{msg} (GPU rows carry the error; gpu_required = false)"
        ));
    }
}

/// The parameters of `params` (`k=v;…`) whose values differ among the config's parameter
/// sets of structure `name` (the progress lines name only those, as the summary does).
fn varying_params(exp: &Experiment, name: &str, params: &str) -> String {
    let sets: Vec<String> = exp
        .structures
        .iter()
        .filter(|s| s.family.name == name)
        .flat_map(|s| s.param_sets.iter().map(|p| p.to_string()))
        .collect();
    crate::experiment::images::varying_tag(&sets, params).replace(',', ";")
}
