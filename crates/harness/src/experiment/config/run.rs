//! The `[run]` table with the command-line overrides.

use super::{parse_validate, Ctx, Device, GpuSpec, OneOrMany, Overrides, RawRun, Validate};
use crate::error::HarnessError;
use tb_core::TriTestKind;
use toml::Spanned;

/// The checked `[run]` settings (with the command-line overrides).
pub struct RunSettings {
    /// Thread counts, each ≥ 1 (0 in the config means all cores).
    pub threads: Vec<usize>,
    /// How rows are timed (warmup, repeat, max_repeat, target_ci, max_row_seconds).
    pub timing: crate::experiment::timing::TimingPlan,
    /// Builds per structure (`run.build_repeat`; the median is reported).
    pub build_repeat: usize,
    /// Every build timed fresh in each process, never loaded from the build cache
    /// (`run.time_builds`; a `build_repeat` above 1 does the same).
    pub time_builds: bool,
    /// The triangle tests every row is run with (`run.triangle_test`).
    pub triangle_tests: Vec<TriTestKind>,
    /// The devices rows run on (`run.devices`, `--device`).
    pub devices: Vec<Device>,
    /// The GPU adapter to use and whether the GPU is required.
    pub gpu: GpuSpec,
    /// Default oracle validation of every scene (`run.validate`).
    pub validate: Validate,
    /// Seed of every random ray batch (`run.seed`, default 1).
    pub seed: u64,
    /// Time the rows of a scene view that trace the same batch (triangle test, thread count,
    /// device: CPU rows together, GPU rows together) interleaved, round by round, over every
    /// build of the table (`run.interleave`).
    pub interleave: bool,
    /// Processes `trace-bench run` makes the run in (`run.processes`, `--processes`; default
    /// 1): see [`crate::experiment::processes`].
    pub processes: usize,
}

/// Check `[run]` with the overrides `ov`.
pub(super) fn check_run(
    cx: &Ctx,
    run: &RawRun,
    ov: &Overrides,
) -> Result<RunSettings, HarnessError> {
    let threads = check_threads(cx, run, ov)?;
    let at_least_one = |v: &Option<Spanned<u32>>, key: &str, default: u32| match v {
        Some(x) if *x.get_ref() == 0 => Err(cx.err(
            x.span(),
            key,
            "must be at least 1 (a row needs one timed run)",
        )),
        Some(x) => Ok(*x.get_ref() as usize),
        None => Ok(default as usize),
    };
    let repeat = match ov.repeat {
        Some(0) => {
            return Err(HarnessError::other(
                "--repeat 0: must be at least 1 (a row needs one timed run)",
            ))
        }
        Some(r) => r,
        None => at_least_one(&run.repeat, "run.repeat", 5)?,
    };
    let warmup = run.warmup.unwrap_or(1) as usize;
    let timing = timing_plan(cx, run, repeat, warmup)?;
    let build_repeat = at_least_one(&run.build_repeat, "run.build_repeat", 1)?;
    let triangle_tests = check_triangle_tests(cx, run)?;
    let devices = check_devices(cx, run)?;
    let devices = ov.devices.clone().unwrap_or(devices);
    let gpu = check_gpu(cx, run, ov)?;
    let validate = match &run.validate {
        None => Validate::All,
        Some(v) => parse_validate(cx, v, "run.validate")?,
    };
    let seed = run.seed.unwrap_or(1);
    Ok(RunSettings {
        threads,
        timing,
        build_repeat,
        time_builds: run.time_builds.unwrap_or(false),
        triangle_tests,
        devices,
        gpu,
        validate,
        seed,
        interleave: run.interleave.unwrap_or(false),
        processes: check_processes(cx, run)?,
    })
}

/// `run.processes`: 1 to [`crate::experiment::processes::MAX`] (1 when absent).
pub(super) fn check_processes(cx: &Ctx, run: &RawRun) -> Result<usize, HarnessError> {
    let max = crate::experiment::processes::MAX;
    match &run.processes {
        None => Ok(1),
        Some(p) if (1..=max as u32).contains(p.get_ref()) => Ok(*p.get_ref() as usize),
        Some(p) => Err(cx.err(
            p.span(),
            "run.processes",
            format!("must be 1 to {max} (each process repeats the whole run)"),
        )),
    }
}

/// The most threads a row may be timed with (`run.threads`, `--threads`).
pub const MAX_THREADS: usize = 1024;

/// The thread counts: `--threads` (0 = all cores), else `run.threads`, else all cores; each
/// at most [`MAX_THREADS`], duplicates dropped.
fn check_threads(cx: &Ctx, run: &RawRun, ov: &Overrides) -> Result<Vec<usize>, HarnessError> {
    let all = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let counts = |list: Vec<usize>, bad: &dyn Fn(String) -> HarnessError| {
        let mut out: Vec<usize> = Vec::new();
        for n in list {
            let n = if n == 0 { all } else { n };
            if n > MAX_THREADS {
                return Err(bad(format!(
                    "{n} threads is too many (at most {MAX_THREADS})"
                )));
            }
            if !out.contains(&n) {
                out.push(n);
            }
        }
        Ok(out)
    };
    match (&ov.threads, &run.threads) {
        (Some(t), _) => {
            if t.is_empty() {
                return Err(HarnessError::other(
                    "--threads: needs at least one thread count",
                ));
            }
            counts(t.clone(), &|m| {
                HarnessError::other(format!("--threads: {m}"))
            })
        }
        (None, Some(t)) => {
            let span = t.span();
            let list: Vec<usize> = match t.get_ref() {
                OneOrMany::One(n) => vec![*n as usize],
                OneOrMany::Many(v) => v.iter().map(|&n| n as usize).collect(),
            };
            if list.is_empty() {
                return Err(cx.err(span, "run.threads", "needs at least one thread count"));
            }
            counts(list, &|m| cx.err(span.clone(), "run.threads", m))
        }
        (None, None) => Ok(vec![all]),
    }
}

/// `run.triangle_test`: one or more triangle tests (watertight when absent).
fn check_triangle_tests(cx: &Ctx, run: &RawRun) -> Result<Vec<TriTestKind>, HarnessError> {
    Ok(match &run.triangle_test {
        None => vec![TriTestKind::Watertight],
        Some(t) => {
            let span = t.span();
            let names = match t.get_ref() {
                OneOrMany::One(s) => vec![s.clone()],
                OneOrMany::Many(v) => v.clone(),
            };
            let mut out = Vec::new();
            for n in names {
                let k = TriTestKind::from_name(&n).ok_or_else(|| {
                    cx.err(
                        span.clone(),
                        "run.triangle_test",
                        format!("unknown triangle test `{n}` (known: watertight, moller-trumbore)"),
                    )
                })?;
                if !out.contains(&k) {
                    out.push(k);
                }
            }
            if out.is_empty() {
                return Err(cx.err(span, "run.triangle_test", "needs at least one test"));
            }
            out
        }
    })
}

/// `run.devices`: one or more devices (the CPU when absent).
fn check_devices(cx: &Ctx, run: &RawRun) -> Result<Vec<Device>, HarnessError> {
    Ok(match &run.devices {
        None => vec![Device::Cpu],
        Some(d) => {
            let span = d.span();
            let names = match d.get_ref() {
                OneOrMany::One(s) => vec![s.clone()],
                OneOrMany::Many(v) => v.clone(),
            };
            let mut out = Vec::new();
            for n in names {
                match Device::from_name(&n) {
                    Some(d) if !out.contains(&d) => out.push(d),
                    Some(_) => {}
                    None => {
                        return Err(cx.err(
                            span.clone(),
                            "run.devices",
                            format!("unknown device `{n}` (known: cpu, gpu)"),
                        ))
                    }
                }
            }
            if out.is_empty() {
                return Err(cx.err(span, "run.devices", "needs at least one device"));
            }
            out
        }
    })
}

/// The GPU adapter choice (`--adapter`, `--backend` over `run.gpu_adapter`,
/// `run.gpu_backend`) and whether a GPU failure fails the run.
fn check_gpu(cx: &Ctx, run: &RawRun, ov: &Overrides) -> Result<GpuSpec, HarnessError> {
    let backend = match (&ov.backend, &run.gpu_backend) {
        (Some(b), _) => Some(*b),
        (None, None) => None,
        (None, Some(b)) => Some(tb_gpu::Backend::from_name(b.get_ref()).ok_or_else(|| {
            cx.err(
                b.span(),
                "run.gpu_backend",
                format!(
                    "unknown backend `{}` (known: vulkan, gl, metal, dx12)",
                    b.get_ref()
                ),
            )
        })?),
    };
    Ok(GpuSpec {
        choice: tb_gpu::AdapterChoice {
            name: ov.adapter.clone().or_else(|| run.gpu_adapter.clone()),
            backend,
        },
        required: run.gpu_required.unwrap_or(true)
            || ov
                .devices
                .as_ref()
                .is_some_and(|d| d.contains(&Device::Gpu)),
    })
}

/// `run.max_repeat`, `run.target_ci`, `run.max_row_seconds`, `run.timed_rays`,
/// `run.timed_share` and `run.clock` with `repeat` and `warmup`.
fn timing_plan(
    cx: &Ctx,
    run: &RawRun,
    repeat: usize,
    warmup: usize,
) -> Result<crate::experiment::timing::TimingPlan, HarnessError> {
    let positive = |v: &Option<Spanned<f64>>, key: &str, default: f64| match v {
        None => Ok(default),
        Some(x) if *x.get_ref() > 0.0 && x.get_ref().is_finite() => Ok(*x.get_ref()),
        Some(x) => Err(cx.err(x.span(), key, "must be positive and finite")),
    };
    Ok(crate::experiment::timing::TimingPlan {
        warmup,
        repeat,
        max_repeat: (run.max_repeat.unwrap_or(0) as usize).max(repeat),
        target_ci: positive(&run.target_ci, "run.target_ci", 0.05)?,
        max_row_seconds: positive(&run.max_row_seconds, "run.max_row_seconds", 60.0)?,
        timed_rays: match &run.timed_rays {
            None => None,
            Some(n) if *n.get_ref() == 0 => {
                return Err(cx.err(
                    n.span(),
                    "run.timed_rays",
                    "must be at least 1 (a timed run traces at least one ray)",
                ))
            }
            Some(n) => Some(usize::try_from(*n.get_ref()).unwrap_or(usize::MAX)),
        },
        timed_share: match &run.timed_share {
            None => None,
            Some(s) if *s.get_ref() > 0.0 && *s.get_ref() <= 1.0 => Some(*s.get_ref()),
            Some(s) => {
                return Err(cx.err(
                    s.span(),
                    "run.timed_share",
                    "must be in (0, 1] (the share of each batch a CPU row is timed on)",
                ))
            }
        },
        clock: match &run.clock {
            None => crate::experiment::timing::Clock::Wall,
            Some(c) => {
                crate::experiment::timing::Clock::from_name(c.get_ref()).ok_or_else(|| {
                    cx.err(
                        c.span(),
                        "run.clock",
                        format!("unknown clock `{}` (known: wall, thread)", c.get_ref()),
                    )
                })?
            }
        },
    })
}
