//! The runner: for each scene, generate the ray batches once; for each structure and parameter
//! set, build (timed, repeated); for each traversal x triangle test x batch, count in one pass
//! with [`TraversalStats`], validate against the brute-force oracle, and for each device x
//! thread count time the trace with counters compiled out ([`tb_core::NoStats`]): warm-up, then
//! `repeat` runs, reporting min/median/max. Each row is written as soon as it is finished.

use crate::config::{Device, Experiment, RayKindSpec, SceneSpec, Validate};
use crate::error::HarnessError;
use crate::gpu::{GpuBuild, GpuDevice};
use crate::output::{Row, RowKey, Sink};
use crate::progress::Progress;
use rayon::prelude::*;
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::time::Instant;
use tb_core::compare::{compare, hex_f32, Mismatch};
use tb_core::{
    Accel, BruteForce, HitRecord, Query, Ray, StatsSummary, TraversalStats, TriTestKind,
};
use tb_scene::rays::{self, RayKind};

/// Rays per call of [`Accel::trace`] when a batch is split across threads.
pub const CHUNK: usize = 1024;

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
    pub resume: bool,
    pub quiet: bool,
    pub mode: Mode,
    /// How many mismatching rays to keep per combination for the report.
    pub max_report: usize,
}

/// What a run did.
#[derive(Debug, Default)]
pub struct RunSummary {
    pub rows: Vec<Row>,
    pub written: usize,
    pub skipped: usize,
    pub mismatches: u64,
    /// Combinations that could not be completed (build failure, invalid structure).
    pub failures: Vec<String>,
    /// Human-readable reports of the first mismatching rays.
    pub mismatch_reports: Vec<String>,
    /// Notes about what was left out and why.
    pub notes: Vec<String>,
}

/// One ray batch of a scene: a kind and its rays (or why there are none).
pub struct Batch {
    pub name: String,
    pub query: Query,
    pub rays: Vec<Ray>,
    /// Set when the batch was skipped (no rays traced); the row's note.
    pub skipped: Option<String>,
}

fn trace_par(
    accel: &dyn Accel,
    traversal: usize,
    query: Query,
    tri: TriTestKind,
    rays: &[Ray],
) -> Vec<HitRecord> {
    let mut hits = vec![HitRecord::MISS; rays.len()];
    rays.par_chunks(CHUNK)
        .zip(hits.par_chunks_mut(CHUNK))
        .for_each(|(r, h)| accel.trace(traversal, query, tri, r, h, None));
    hits
}

/// Generate the batches a scene asks for, in the order primary, shadow, ao, path1..k, random,
/// stress. Secondary rays start at hits found with the watertight test by the default BVH, so
/// they are the same whatever structures and triangle tests the experiment runs.
pub fn generate_batches(spec: &SceneSpec, seed: u64, notes: &mut Vec<String>) -> Vec<Batch> {
    let tris = &spec.scene.triangles;
    let wants = |k: RayKindSpec| spec.rays.contains(&k);
    let secondary =
        wants(RayKindSpec::Shadow) || wants(RayKindSpec::Ao) || wants(RayKindSpec::Path);
    let mut out = Vec::new();
    let primary = match (&spec.camera, wants(RayKindSpec::Primary) || secondary) {
        (Some(c), true) => rays::primary(c),
        _ => Vec::new(),
    };
    if wants(RayKindSpec::Primary) {
        out.push(Batch {
            name: RayKind::Primary.name(),
            query: Query::Closest,
            rays: primary.clone(),
            skipped: None,
        });
    }
    if secondary {
        notes.push(format!(
            "{}: secondary rays start at primary hits found by bvh (default params, watertight test)",
            spec.label
        ));
        let gen = crate::registry::generator(tris);
        let hits = trace_par(
            gen.as_ref(),
            0,
            Query::Closest,
            TriTestKind::Watertight,
            &primary,
        );
        let nhit = hits.iter().filter(|h| h.is_hit()).count();
        let none = |what: &str| Some(format!("no {what} rays: no primary ray hits the scene"));
        if wants(RayKindSpec::Shadow) {
            match spec.light {
                Some(light) => {
                    let r = rays::shadow(tris, &primary, &hits, light);
                    let skipped = if r.is_empty() { none("shadow") } else { None };
                    out.push(Batch {
                        name: RayKind::Shadow.name(),
                        query: Query::Any,
                        rays: r,
                        skipped,
                    });
                }
                None => {
                    let why = "skipped: the scene has no light (set `light` in the scene table)"
                        .to_string();
                    notes.push(format!("{}: shadow rays {why}", spec.label));
                    out.push(Batch {
                        name: RayKind::Shadow.name(),
                        query: Query::Any,
                        rays: Vec::new(),
                        skipped: Some(why),
                    });
                }
            }
        }
        if wants(RayKindSpec::Ao) {
            let r = rays::ao(
                tris,
                &primary,
                &hits,
                spec.ao_samples,
                spec.ao_distance,
                seed,
            );
            let skipped = if nhit == 0 { none("ao") } else { None };
            out.push(Batch {
                name: RayKind::Ao.name(),
                query: Query::Any,
                rays: r,
                skipped,
            });
        }
        if wants(RayKindSpec::Path) {
            let (mut prev_rays, mut prev_hits) = (primary.clone(), hits);
            for b in 1..=spec.bounces {
                let r = rays::bounce(tris, &prev_rays, &prev_hits, seed.wrapping_add(b as u64));
                let skipped = if r.is_empty() {
                    Some(format!("no rays: no ray of bounce {} hit the scene", b - 1))
                } else {
                    None
                };
                let h = trace_par(gen.as_ref(), 0, Query::Closest, TriTestKind::Watertight, &r);
                out.push(Batch {
                    name: RayKind::Path(b).name(),
                    query: Query::Closest,
                    rays: r.clone(),
                    skipped,
                });
                prev_rays = r;
                prev_hits = h;
            }
        }
    }
    if wants(RayKindSpec::Random) {
        let r = rays::random(&spec.scene.bounds, spec.random_count, seed);
        out.push(Batch {
            name: RayKind::Random.name(),
            query: Query::Closest,
            rays: r,
            skipped: None,
        });
    }
    if wants(RayKindSpec::Stress) {
        out.push(Batch {
            name: RayKind::Own.name(),
            query: Query::Closest,
            rays: spec.scene.own_rays.clone(),
            skipped: None,
        });
    }
    out
}

/// Indices of the rays validated under `v` (all, or an even stride).
fn sample(v: Validate, n: usize) -> Vec<usize> {
    match v {
        Validate::Off => Vec::new(),
        Validate::All => (0..n).collect(),
        Validate::Sample(k) if k >= n => (0..n).collect(),
        Validate::Sample(k) => {
            let step = n.div_ceil(k);
            (0..n).step_by(step).collect()
        }
    }
}

/// The validated sample of batch `bi` under `validate`: the ray indices, the rays, and the
/// oracle's answers for them (computed on first use, then shared by every row of the batch).
fn oracle_sample(
    oracle: &mut HashMap<usize, Vec<HitRecord>>,
    bi: usize,
    brute: &BruteForce,
    b: &Batch,
    validate: Validate,
    label: &str,
    progress: &Progress,
) -> (Vec<usize>, Vec<Ray>, Vec<HitRecord>) {
    let idx = sample(validate, b.rays.len());
    let sub: Vec<Ray> = idx.iter().map(|&i| b.rays[i]).collect();
    let expected = oracle
        .entry(bi)
        .or_insert_with(|| {
            progress.step(&format!(
                "{label}: oracle for {} ({} rays)",
                b.name,
                sub.len()
            ));
            trace_par(brute, 0, b.query, TriTestKind::Watertight, &sub)
        })
        .clone();
    (idx, sub, expected)
}

/// The thread counts rows are written for on `dev`: the run's on the CPU; one row, `threads
/// = 0`, on the GPU (one host thread drives it; the column counts CPU worker threads).
fn threads_of(dev: Device, threads: &[usize]) -> Vec<usize> {
    match dev {
        Device::Cpu => threads.to_vec(),
        Device::Gpu => vec![0],
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

/// Median of `v` (sorted in place).
pub(crate) fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn fmt_mismatch(m: &Mismatch) -> String {
    let r = &m.ray;
    let v = |x: tb_core::Vec3| format!("({}, {}, {})", hex_f32(x.x), hex_f32(x.y), hex_f32(x.z));
    let h = |h: &HitRecord| {
        if h.is_hit() {
            format!("prim {} t {} ({})", h.prim, h.t, hex_f32(h.t))
        } else {
            "miss".to_string()
        }
    };
    format!(
        "ray {}: origin {} dir {} tmin {} tmax {}: expected {}, got {} [{:?}]",
        m.index,
        v(r.origin),
        v(r.dir),
        hex_f32(r.tmin),
        hex_f32(r.tmax),
        h(&m.expected),
        h(&m.got),
        m.kind
    )
}

/// Validation outcome of one structure x traversal x triangle test x batch.
struct Checked {
    validated: u64,
    mismatches: u64,
    first: Vec<Mismatch>,
}

/// Run the experiment. Returns what was done; errors only for I/O (results already written
/// stay written).
pub fn run(exp: &Experiment, opts: &RunOptions) -> Result<RunSummary, HarnessError> {
    let mut summary = RunSummary::default();
    // The GPU is opened once, before any work, so results.json names the adapter.
    let mut gpu = (opts.mode == Mode::Run && exp.devices.contains(&Device::Gpu))
        .then(|| GpuDevice::open(&exp.gpu));
    if let Some(Err(e)) = gpu.as_ref().map(GpuDevice::describe) {
        gpu_failed(&mut summary, gpu.as_ref(), &e);
    }
    let mut sink = match opts.mode {
        Mode::Run => {
            let mut meta =
                crate::meta::collect(&exp.file.display().to_string(), &exp.text, &exp.threads);
            if let Some(g) = &gpu {
                meta["adapter"] = g.meta();
            }
            Some(Sink::open(&opts.out, meta, opts.resume)?)
        }
        Mode::Validate => None,
    };
    let done: HashSet<RowKey> = sink
        .as_ref()
        .map(|s| s.rows().iter().map(Row::key).collect())
        .unwrap_or_default();

    let pools: Vec<(usize, rayon::ThreadPool)> = exp
        .threads
        .iter()
        .map(|&n| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| HarnessError::Other(format!("cannot start {n} threads: {e}")));
            pool.map(|p| (n, p))
        })
        .collect::<Result<_, _>>()?;
    let (threads_for_rows, devices): (Vec<usize>, Vec<Device>) = match opts.mode {
        Mode::Run => (exp.threads.clone(), exp.devices.clone()),
        Mode::Validate => (vec![0], vec![Device::Cpu]),
    };

    let combos_per_batch: usize = exp
        .structures
        .iter()
        .map(|s| s.param_sets.len() * s.traversals.len())
        .sum::<usize>()
        * exp.triangle_tests.len()
        * devices
            .iter()
            .map(|&d| threads_of(d, &threads_for_rows).len())
            .sum::<usize>();
    let total_batches: usize = exp
        .scenes
        .iter()
        .map(|s| {
            s.rays
                .iter()
                .map(|k| {
                    if *k == RayKindSpec::Path {
                        s.bounces as usize
                    } else {
                        1
                    }
                })
                .sum::<usize>()
        })
        .sum();
    let progress = Progress::new((combos_per_batch * total_batches) as u64, opts.quiet);
    let mut conv = match opts.mode {
        Mode::Run => crate::convergence::Runner::open(exp, &opts.out, opts.resume)?,
        Mode::Validate => None,
    };

    for n in &exp.skipped_scenes {
        progress.line(&format!("note: {n}"));
        summary.notes.push(n.clone());
    }
    for spec in &exp.scenes {
        progress.step(&format!("{}: generating rays", spec.label));
        let batches = generate_batches(spec, exp.seed, &mut summary.notes);
        if let (Some(_), Mode::Run) = (&exp.images, opts.mode) {
            summary
                .notes
                .extend(crate::images::write_scene(spec, &opts.out)?);
        }
        for n in summary.notes.iter().filter(|n| n.starts_with(&spec.label)) {
            progress.line(&format!("note: {n}"));
        }
        let tris = &spec.scene.triangles;
        // Oracle answers per batch over the validated sample: brute force with the watertight
        // test, the truth for every row (so a Möller–Trumbore row's mismatches include the
        // rays that test lets slip through edges, reported rather than hidden). Computed on
        // first use with all threads.
        let mut oracle: HashMap<usize, Vec<HitRecord>> = HashMap::new();
        let brute = BruteForce::new(tris);

        for st in &exp.structures {
            for (param_index, params) in st.param_sets.iter().enumerate() {
                let params_s = params.to_string();
                let row_base = Row {
                    scene: spec.label.clone(),
                    source: spec.scene.source.clone(),
                    triangles: tris.len() as u64,
                    structure: st.info.name.to_string(),
                    params: params_s.clone(),
                    ..Default::default()
                };
                // Which rows of this build are still to do?
                let mut todo = Vec::new();
                for &ti in &st.traversals {
                    for &tri in &exp.triangle_tests {
                        for (bi, b) in batches.iter().enumerate() {
                            for &dev in &devices {
                                for th in threads_of(dev, &threads_for_rows) {
                                    let key = RowKey {
                                        scene: spec.label.clone(),
                                        structure: st.info.name.to_string(),
                                        params: params_s.clone(),
                                        traversal: st.info.traversals[ti].name.to_string(),
                                        device: dev.name().to_string(),
                                        threads: th as u32,
                                        triangle_test: tri.name().to_string(),
                                        ray_kind: b.name.clone(),
                                    };
                                    if done.contains(&key) {
                                        summary.skipped += 1;
                                        progress.inc();
                                    } else {
                                        todo.push((ti, tri, bi, dev, th));
                                    }
                                }
                            }
                        }
                    }
                }
                if todo.is_empty() {
                    continue;
                }

                progress.step(&format!(
                    "{}: building {} [{}]",
                    spec.label, st.info.name, params_s
                ));
                let mut build_times = Vec::new();
                let mut built: Option<Result<Box<dyn Accel>, String>> = None;
                for _ in 0..exp.build_repeat {
                    drop(built.take());
                    let t0 = Instant::now();
                    let r = (st.info.build)(tris, params);
                    build_times.push(t0.elapsed().as_secs_f64() * 1e3);
                    let failed = r.is_err();
                    built = Some(r);
                    if failed {
                        break;
                    }
                }
                let accel = match built.expect("at least one build").and_then(|a| {
                    a.validate()
                        .map_err(|e| format!("invalid structure: {e}"))?;
                    Ok(a)
                }) {
                    Ok(a) => a,
                    Err(e) => {
                        let msg = format!("{} {} [{}]: {e}", spec.label, st.info.name, params_s);
                        progress.line(&format!("error: {msg}"));
                        summary.failures.push(msg);
                        for (ti, tri, bi, dev, th) in todo {
                            let row = Row {
                                traversal: st.info.traversals[ti].name.to_string(),
                                device: dev.name().into(),
                                threads: th as u32,
                                triangle_test: tri.name().into(),
                                ray_kind: batches[bi].name.clone(),
                                note: format!("build failed: {e}"),
                                ..row_base.clone()
                            };
                            emit(&mut sink, &mut summary, row, &progress)?;
                        }
                        continue;
                    }
                };
                let build_ms = median(&mut build_times);
                let mem = accel.memory();
                let report = accel.build_report();
                let build_stats = report
                    .extra
                    .iter()
                    .map(|(k, v)| format!("{k}={}", (v * 1000.0).round() / 1000.0))
                    .collect::<Vec<_>>()
                    .join(";");
                if let (Some(img), Mode::Run) = (&exp.images, opts.mode) {
                    progress.step(&format!("{}: heat maps {}", spec.label, st.info.name));
                    summary.notes.extend(crate::images::write_build(
                        spec,
                        img,
                        &opts.out,
                        accel.as_ref(),
                        param_index,
                        &params_s,
                        &st.traversals,
                        &exp.triangle_tests,
                    )?);
                }
                if let Some(c) = conv.as_mut() {
                    summary.notes.extend(c.build_done(
                        spec,
                        accel.as_ref(),
                        &params_s,
                        build_ms,
                        &st.traversals,
                        &exp.triangle_tests,
                        &devices,
                        gpu.as_ref(),
                        &progress,
                    )?);
                }

                // Counting and validation do not depend on device or thread count: do them once
                // per (traversal, test, batch).
                let mut counted: HashMap<(usize, TriTestKind, usize), (StatsSummary, f64)> =
                    HashMap::new();
                let mut checked: HashMap<(usize, TriTestKind, usize), Checked> = HashMap::new();
                let mut gpu_build = GpuBuild::default();

                for (ti, tri, bi, dev, th) in todo {
                    let b = &batches[bi];
                    let tname = st.info.traversals[ti].name;
                    let mut row = Row {
                        traversal: tname.to_string(),
                        device: dev.name().into(),
                        threads: th as u32,
                        triangle_test: tri.name().into(),
                        ray_kind: b.name.clone(),
                        rays: b.rays.len() as u64,
                        build_ms: Some(build_ms),
                        memory_bytes: Some(accel.memory_for(ti).bytes),
                        nodes: Some(mem.nodes),
                        prim_refs: Some(mem.prim_refs),
                        node_bytes: Some(mem.node_bytes),
                        sah_cost: report.sah_cost,
                        build_stats: build_stats.clone(),
                        ..row_base.clone()
                    };
                    if let Some(own) = accel.own_triangle_test() {
                        row.note = format!("uses its own triangle test ({own})");
                    }
                    if let Some(why) = &b.skipped {
                        row.note = why.clone();
                        emit(&mut sink, &mut summary, row, &progress)?;
                        continue;
                    }
                    progress.step(&format!(
                        "{} {} {} {} {} {}t",
                        spec.label,
                        st.info.name,
                        tname,
                        tri.name(),
                        b.name,
                        th
                    ));

                    if dev == Device::Gpu {
                        let g = gpu
                            .as_mut()
                            .expect("the GPU is opened when a device is gpu");
                        if !crate::gpu::has_kernel(st.info.name, tname) {
                            row.note = format!("no GPU kernel for {} {tname} yet", st.info.name);
                            emit(&mut sink, &mut summary, row, &progress)?;
                            continue;
                        }
                        let validation = (spec.validate != Validate::Off).then(|| {
                            let (idx, _, e) = oracle_sample(
                                &mut oracle,
                                bi,
                                &brute,
                                b,
                                spec.validate,
                                &spec.label,
                                &progress,
                            );
                            (idx, e)
                        });
                        let r = g.measure(
                            &mut gpu_build,
                            accel.as_ref(),
                            tris,
                            bi,
                            &b.rays,
                            b.query,
                            tri,
                            exp.warmup,
                            exp.repeat,
                            validation
                                .as_ref()
                                .map(|(i, e)| (i.as_slice(), e.as_slice())),
                            opts.max_report,
                            &mut row,
                        );
                        match r {
                            Ok(out) if !out.first.is_empty() => {
                                let mut rep = format!(
                                    "{} {} [{}] {} {} {} gpu: {} of {} rays mismatch",
                                    spec.label,
                                    st.info.name,
                                    params_s,
                                    tname,
                                    tri.name(),
                                    b.name,
                                    row.mismatches.unwrap_or(0),
                                    row.validated_rays.unwrap_or(0)
                                );
                                for m in &out.first {
                                    rep.push_str("\n    ");
                                    rep.push_str(&fmt_mismatch(m));
                                }
                                summary.mismatch_reports.push(rep);
                            }
                            Ok(_) => {}
                            Err(e) => {
                                let first = summary.failures.iter().all(|f| !f.contains(&e))
                                    && summary.notes.iter().all(|n| !n.contains(&e));
                                if first {
                                    progress.line(&format!("error: gpu: {e}"));
                                    gpu_failed(&mut summary, Some(g), &e);
                                }
                                row = Row {
                                    note: format!("gpu failed: {e}"),
                                    ..row_base.clone()
                                };
                                row.traversal = tname.to_string();
                                row.device = dev.name().into();
                                row.triangle_test = tri.name().into();
                                row.ray_kind = b.name.clone();
                                row.rays = b.rays.len() as u64;
                            }
                        }
                        emit(&mut sink, &mut summary, row, &progress)?;
                        continue;
                    }

                    // Validation against the oracle.
                    if spec.validate != Validate::Off {
                        let c = checked.entry((ti, tri, bi)).or_insert_with(|| {
                            let (idx, sub, expected) = oracle_sample(
                                &mut oracle,
                                bi,
                                &brute,
                                b,
                                spec.validate,
                                &spec.label,
                                &progress,
                            );
                            let got = trace_par(accel.as_ref(), ti, b.query, tri, &sub);
                            let mut first = Vec::new();
                            let mut n = 0u64;
                            for (k, (e, g)) in expected.iter().zip(&got).enumerate() {
                                let m = compare(b.query, &sub[k], e, g);
                                if let Some(kind) = m {
                                    n += 1;
                                    if first.len() < opts.max_report {
                                        first.push(Mismatch {
                                            index: idx[k],
                                            ray: sub[k],
                                            expected: *e,
                                            got: *g,
                                            kind,
                                        });
                                    }
                                }
                            }
                            Checked {
                                validated: sub.len() as u64,
                                mismatches: n,
                                first,
                            }
                        });
                        row.validated_rays = Some(c.validated);
                        row.mismatches = Some(c.mismatches);
                        if c.mismatches > 0 && !c.first.is_empty() {
                            let head = format!(
                                "{} {} [{}] {} {} {}: {} of {} rays mismatch",
                                spec.label,
                                st.info.name,
                                params_s,
                                tname,
                                tri.name(),
                                b.name,
                                c.mismatches,
                                c.validated
                            );
                            let mut rep = head;
                            for m in c.first.drain(..) {
                                rep.push_str("\n    ");
                                rep.push_str(&fmt_mismatch(&m));
                            }
                            summary.mismatch_reports.push(rep);
                        }
                    }

                    if opts.mode == Mode::Run {
                        // Counting pass (a separate pass, never timed).
                        let (stats, hit_rate) =
                            *counted.entry((ti, tri, bi)).or_insert_with(|| {
                                let mut hits = vec![HitRecord::MISS; b.rays.len()];
                                let mut stats = vec![TraversalStats::default(); b.rays.len()];
                                pools
                                    .iter()
                                    .max_by_key(|(n, _)| *n)
                                    .expect("a pool")
                                    .1
                                    .install(|| {
                                        b.rays
                                            .par_chunks(CHUNK)
                                            .zip(hits.par_chunks_mut(CHUNK))
                                            .zip(stats.par_chunks_mut(CHUNK))
                                            .for_each(|((r, h), s)| {
                                                accel.trace(ti, b.query, tri, r, h, Some(s))
                                            });
                                    });
                                let nhit = hits.iter().filter(|h| h.is_hit()).count();
                                (
                                    StatsSummary::from_stats(&stats),
                                    nhit as f64 / b.rays.len().max(1) as f64,
                                )
                            });
                        row.hit_rate = Some(hit_rate);
                        if accel.has_counters() {
                            row.interior_per_ray = Some(stats.mean[0]);
                            row.interior_max = Some(stats.max[0]);
                            row.leaves_per_ray = Some(stats.mean[1]);
                            row.leaves_max = Some(stats.max[1]);
                            row.prims_per_ray = Some(stats.mean[2]);
                            row.prims_max = Some(stats.max[2]);
                            row.boxes_per_ray = Some(stats.mean[3]);
                            row.boxes_max = Some(stats.max[3]);
                            row.planes_per_ray = Some(stats.mean[4]);
                            row.planes_max = Some(stats.max[4]);
                            row.restarts_per_ray = Some(stats.mean[5]);
                            row.restarts_max = Some(stats.max[5]);
                            row.steps_per_ray = Some(stats.mean[6]);
                            row.steps_max = Some(stats.max[6]);
                        }
                        if accel.has_step_cap(ti) {
                            row.capped_rays = Some(stats.capped);
                        }

                        // Timing, counters compiled out.
                        let pool = &pools.iter().find(|(n, _)| *n == th).expect("pool").1;
                        let mut hits = vec![HitRecord::MISS; b.rays.len()];
                        let mut times = Vec::with_capacity(exp.repeat);
                        for i in 0..exp.warmup + exp.repeat {
                            let t0 = Instant::now();
                            pool.install(|| {
                                b.rays
                                    .par_chunks(CHUNK)
                                    .zip(hits.par_chunks_mut(CHUNK))
                                    .for_each(|(r, h)| accel.trace(ti, b.query, tri, r, h, None));
                            });
                            let ms = t0.elapsed().as_secs_f64() * 1e3;
                            if i >= exp.warmup {
                                times.push(ms);
                            }
                        }
                        let med = median(&mut times);
                        row.trace_ms_min = times.first().copied();
                        row.trace_ms_max = times.last().copied();
                        row.trace_ms_median = Some(med);
                        row.mrays_per_s = Some(b.rays.len() as f64 / (med * 1e3).max(1e-12));
                    }
                    emit(&mut sink, &mut summary, row, &progress)?;
                }
            }
        }
    }
    progress.finish();
    if let Some(s) = sink.as_mut() {
        let status = if summary.failures.is_empty() {
            "complete"
        } else {
            "complete-with-failures"
        };
        s.finish(status)?;
    }
    Ok(summary)
}

fn emit(
    sink: &mut Option<Sink>,
    summary: &mut RunSummary,
    row: Row,
    progress: &Progress,
) -> Result<(), HarnessError> {
    summary.mismatches += row.mismatches.unwrap_or(0);
    if let Some(s) = sink.as_mut() {
        s.push(row.clone())?;
    }
    summary.written += 1;
    summary.rows.push(row);
    progress.inc();
    Ok(())
}

/// A plain-text summary table of rows.
pub fn table(rows: &[Row]) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "{:<22} {:<12} {:<10} {:<9} {:>3} {:<8} {:>9} {:>9} {:>8} {:>8} {:>9} {:>10}\n",
        "scene",
        "structure",
        "traversal",
        "test",
        "dev",
        "rays",
        "count",
        "MRays/s",
        "steps",
        "prims",
        "build_ms",
        "mismatch"
    ));
    for r in rows {
        let f =
            |x: Option<f64>, p: usize| x.map(|v| format!("{v:.p$}")).unwrap_or_else(|| "-".into());
        out.push_str(&format!(
            "{:<22} {:<12} {:<10} {:<9} {:>3} {:<8} {:>9} {:>9} {:>8} {:>8} {:>9} {:>10}{}\n",
            truncate(&r.scene, 22),
            truncate(&r.structure, 12),
            truncate(&r.traversal, 10),
            if r.triangle_test == "watertight" {
                "wt"
            } else {
                "mt"
            },
            // CPU rows: the thread count; GPU rows: `gpu`.
            if r.device == "gpu" {
                "gpu".to_string()
            } else {
                r.threads.to_string()
            },
            truncate(&r.ray_kind, 8),
            r.rays,
            f(r.mrays_per_s, 2),
            f(r.steps_per_ray, 1),
            f(r.prims_per_ray, 1),
            f(r.build_ms, 1),
            r.mismatches
                .map(|m| m.to_string())
                .unwrap_or_else(|| "-".into()),
            if r.note.is_empty() {
                String::new()
            } else {
                format!("  ({})", r.note)
            }
        ));
    }
    out
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        let mut t: String = s.chars().take(n - 1).collect();
        t.push('…');
        t
    }
}
