//! Fitting a paper's runs into reproduce's budget, and planning each run's command.
//!
//! A run's declared cost (`cost_s`, one process, measured on the 2-core reference machine) is
//! three parts: `fixed_s` (loading, builds) does not shrink; `trace_s` (its CPU rows' timed
//! tracing) shrinks with the share of each batch the rows are timed on (`run.timed_share`)
//! and with the image; the rest (counting, validation, the oracle) shrinks with the image
//! only ([`RunSpec::planned_s`]). When the runs do not fit, the timed share shrinks first,
//! down to [`MIN_SHARE`], since the counters and the validation then still cover the
//! declared images; only then do the images of `scalable` runs shrink, by one factor for
//! all of them, down to [`MIN_SCALE`] of their pixels.
//!
//! The declared costs are of builds made from nothing; a warm build cache (or a faster
//! machine) makes runs cheaper than declared, a busy machine dearer. So before each paper the
//! share is fitted again ([`refit`]) to what is left of the budget for the runs still to be
//! made, their images as first planned: what the cache saves goes to timed rays, and a run
//! slower than declared costs the later papers' timed share, not the budget.

use super::{run_args, stem, Options, PlannedRun, RUNS_SHARE};
use crate::schema::{ClaimsFile, RunSpec};
use crate::Error;
use std::path::{Path, PathBuf};

/// The smallest pixel scale reproduce applies (1/64 of the pixels: 1024² → 128²).
pub const MIN_SCALE: f64 = 1.0 / 64.0;

/// The smallest share of each batch reproduce times the CPU rows on before it shrinks the
/// images (1/16: of a 256² view, 4,096 rays, four image rows' worth of runs of neighbours).
pub const MIN_SHARE: f64 = 1.0 / 16.0;

/// How the runs are fitted into the budget: the share of each batch their CPU rows are timed
/// on, the pixel scale of the scalable runs' images, and the estimate at both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// The share of each batch the CPU rows are timed on (1 = all).
    pub share: f64,
    /// The pixel scale of the scalable runs' images (1 = as declared).
    pub scale: f64,
    /// The runs' estimated wall seconds at that share and scale.
    pub estimate_s: f64,
}

/// The fit of `runs` into `budget_s` ([`Fit`]): as declared when they fit; otherwise the
/// timed share that fits (not below [`MIN_SHARE`]); otherwise [`MIN_SHARE`] and the image
/// scale that fits (not below [`MIN_SCALE`]). A run of several processes costs each of them.
pub fn fit(runs: &[&RunSpec], budget_s: f64) -> Fit {
    let at =
        |share: f64, scale: f64| -> f64 { runs.iter().map(|r| r.planned_s(share, scale)).sum() };
    let full = at(1.0, 1.0);
    if full <= budget_s {
        return Fit {
            share: 1.0,
            scale: 1.0,
            estimate_s: full,
        };
    }
    // The estimate is linear in the share: `full - trace + share * trace`.
    let trace = full - at(0.0, 1.0);
    let share = if trace > 0.0 {
        let s = (budget_s - (full - trace)) / trace;
        if s >= MIN_SHARE {
            // Rounded down to a thousandth, so that the run's `--set` reads well.
            let s = ((s * 1e3).floor() / 1e3).max(MIN_SHARE);
            return Fit {
                share: s,
                scale: 1.0,
                estimate_s: full - trace + s * trace,
            };
        }
        MIN_SHARE
    } else {
        1.0
    };
    // Then linear in the scale: `fixed + scale * var`.
    let fixed = at(share, 0.0);
    let var = at(share, 1.0) - fixed;
    let scale = if var > 0.0 {
        ((budget_s - fixed) / var).clamp(MIN_SCALE, 1.0)
    } else {
        1.0
    };
    Fit {
        share,
        scale,
        estimate_s: fixed + scale * var,
    }
}

/// Whether the `heavy` runs among `runs` are made: with `--heavy`, or when every run fits the
/// budget as declared (heavy runs are never shrunk: their cost is their builds).
pub fn heavy_included(runs: &[&RunSpec], budget_s: f64, heavy: bool) -> bool {
    heavy || runs.iter().map(|r| r.total_s()).sum::<f64>() <= budget_s
}

/// Whether the run is made on these devices: a run naming `gpu` only when `gpu` is asked
/// for, one naming no device (the CPU) only when `cpu` is.
pub(super) fn wanted(r: &RunSpec, devices: &[String]) -> bool {
    let gpu = r
        .device
        .as_ref()
        .is_some_and(|d| d.iter().any(|x| x == "gpu"));
    if gpu {
        devices.iter().any(|d| d == "gpu")
    } else {
        devices.iter().any(|d| d == "cpu")
    }
}

/// The run's `--set` edits at the fit: width and height scaled by `sqrt(scale)` (multiples of
/// 8, at least 32 pixels) and `run.timed_share` where the run's CPU rows are timed on a share
/// (it declares `trace_s`), with what changed in words; the scale and share applied.
fn fitted_sets(r: &RunSpec, fit: &Fit) -> (Vec<String>, Option<String>, f64, f64) {
    let mut notes = Vec::new();
    let (mut sets, scale) = match scaled_sets(r, fit.scale) {
        (sets, Some(note)) => {
            let applied = !note.starts_with("not");
            notes.push(note);
            (sets, if applied { fit.scale } else { 1.0 })
        }
        (sets, None) => (sets, 1.0),
    };
    let share = if r.trace_s > 0.0 && fit.share < 1.0 && r.exec.is_none() {
        sets.push(format!("run.timed_share={}", fit.share));
        notes.push(format!(
            "CPU rows timed on {} % of each batch (counters on all of it)",
            (fit.share * 1e4).round() / 1e2
        ));
        fit.share
    } else {
        1.0
    };
    let note = (!notes.is_empty()).then(|| notes.join("; "));
    (sets, note, scale, share)
}

/// The run's `--set` edits with width and height scaled by `sqrt(f)` (multiples of 8, at
/// least 32 pixels), and what was scaled.
fn scaled_sets(r: &RunSpec, f: f64) -> (Vec<String>, Option<String>) {
    if f >= 1.0 || !r.scalable {
        return (r.set.clone(), None);
    }
    let k = f.sqrt();
    let mut changed = Vec::new();
    let sets = r
        .set
        .iter()
        .map(|s| {
            let Some((key, val)) = s.split_once('=') else {
                return s.clone();
            };
            let is_size = key.ends_with(".width") || key.ends_with(".height");
            match (is_size, val.trim().parse::<f64>()) {
                (true, Ok(v)) => {
                    let n = (((v * k) / 8.0).round() * 8.0).max(32.0) as u64;
                    changed.push(format!("{key} {v} → {n}"));
                    format!("{key}={n}")
                }
                _ => s.clone(),
            }
        })
        .collect();
    let note = if changed.is_empty() {
        Some("not scaled: the run sets no width/height".to_owned())
    } else {
        Some(changed.join(", "))
    };
    (sets, note)
}

/// Plan every paper's runs within the budget.
pub fn plan(opts: &Options) -> Result<Vec<(PathBuf, ClaimsFile, Vec<PlannedRun>)>, Error> {
    let mut files = Vec::new();
    for p in &opts.papers {
        files.push((p.clone(), super::super::load(p)?));
    }
    let all: Vec<&RunSpec> = files
        .iter()
        .flat_map(|(_, f)| f.runs.iter())
        .filter(|r| wanted(r, &opts.devices))
        .collect();
    let with_heavy = heavy_included(&all, opts.budget_s, opts.heavy);
    let made: Vec<&RunSpec> = all
        .iter()
        .copied()
        .filter(|r| with_heavy || !r.heavy)
        .collect();
    let fitted = fit(&made, opts.budget_s);
    let all_cost: f64 = all.iter().map(|r| r.total_s()).sum();
    let mut out = Vec::new();
    for (path, file) in files {
        let key = stem(&path);
        let mut runs = Vec::new();
        for (i, r) in file.runs.iter().enumerate() {
            if !wanted(r, &opts.devices) {
                continue;
            }
            let label = match (&r.config, &r.exec) {
                (Some(c), _) => stem(Path::new(c)),
                (None, Some(e)) => e.first().cloned().unwrap_or_default(),
                _ => String::new(),
            };
            let folder = opts
                .out
                .join("runs")
                .join(&key)
                .join(format!("{i}-{label}"));
            let left_out = (r.heavy && !with_heavy).then(|| {
                format!(
                    "left out (heavy, {:.0} s): --heavy or a budget of {:.0} s makes it",
                    r.total_s(),
                    (all_cost / RUNS_SHARE).ceil()
                )
            });
            // Heavy runs are made as declared: their cost is their builds.
            let this_fit = if r.heavy {
                Fit {
                    share: 1.0,
                    scale: 1.0,
                    estimate_s: 0.0,
                }
            } else {
                fitted
            };
            let (sets, scaled, scale, share) = fitted_sets(r, &this_fit);
            runs.push(PlannedRun {
                spec: i,
                paper: key.clone(),
                label,
                args: run_args(r, &sets, &folder, opts),
                exec: r.exec.is_some(),
                folder,
                cost_s: r.planned_s(share, scale),
                scale,
                timed_share: share,
                scaled,
                wall_s: None,
                exit: None,
                failed: None,
                reused: false,
                reused_from: None,
                left_out,
                processes: r.processes,
                spread: None,
            });
        }
        out.push((path, file, runs));
    }
    Ok(out)
}

/// A paper's planned runs, in order, with its claims file.
pub type PaperPlan = (PathBuf, ClaimsFile, Vec<PlannedRun>);

/// Fit the timed share again for the runs of `rest` still to be made, with `left_s` seconds
/// of the budget left ([`Fit`] at the images as planned, the share within [`MIN_SHARE`] and
/// 1, a thousandth down as [`fit`] rounds it): their `--set`, cost and note follow. Runs
/// complete in their folders (reused), left out, heavy or `exec` keep theirs (heavy and
/// `exec` runs' costs are taken from the budget first). Returns the old and the new share
/// where it changed; `None` where no run still to be made is timed on a share of its batch.
pub(super) fn refit(rest: &mut [PaperPlan], opts: &Options, left_s: f64) -> Option<(f64, f64)> {
    let mut fixed = 0.0;
    let mut trace = 0.0;
    let mut old = None;
    for (_, file, runs) in rest.iter() {
        for r in runs.iter().filter(|r| to_make(r)) {
            let spec = &file.runs[r.spec];
            if spec.heavy || r.exec {
                fixed += r.cost_s;
                continue;
            }
            let at0 = spec.planned_s(0.0, r.scale);
            fixed += at0;
            let t = spec.planned_s(1.0, r.scale) - at0;
            if t > 0.0 {
                trace += t;
                old.get_or_insert(r.timed_share);
            }
        }
    }
    let old = old?;
    let share = (((left_s - fixed) / trace * 1e3).floor() / 1e3).clamp(MIN_SHARE, 1.0);
    if share == old {
        return None;
    }
    for (_, file, runs) in rest.iter_mut() {
        for r in runs.iter_mut().filter(|r| to_make(r)) {
            let spec = &file.runs[r.spec];
            if spec.heavy || r.exec {
                continue;
            }
            let this = Fit {
                share,
                scale: r.scale,
                estimate_s: 0.0,
            };
            let (sets, note, scale, applied) = fitted_sets(spec, &this);
            r.args = run_args(spec, &sets, &r.folder, opts);
            r.cost_s = spec.planned_s(applied, scale);
            r.timed_share = applied;
            r.scaled = note;
        }
    }
    Some((old, share))
}

/// Whether a planned run is still to be made: not left out, not complete in its folder.
fn to_make(r: &PlannedRun) -> bool {
    r.left_out.is_none() && super::status(&r.folder).as_deref() != Some("complete")
}

#[cfg(test)]
mod tests {
    use super::super::tests::{options, spec};
    use super::*;

    /// Heavy runs are made with `--heavy`, or when the budget covers every run as declared.
    #[test]
    fn heavy_runs_need_the_flag_or_the_whole_budget() {
        let light = spec(100.0, 20.0, true);
        let heavy = RunSpec {
            heavy: true,
            ..spec(300.0, 300.0, false)
        };
        let runs = [&light, &heavy];
        assert!(!heavy_included(&runs, 399.0, false));
        assert!(heavy_included(&runs, 400.0, false));
        assert!(heavy_included(&runs, 10.0, true));
    }

    /// A left-out heavy run is planned (and reported) but not made, and the light runs are
    /// fitted without it.
    #[test]
    fn plans_leave_heavy_runs_out_within_small_budgets() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("p.toml");
        std::fs::write(
            &file,
            "paper = \"P\"\n\
             [[run]]\nconfig = \"configs/a.toml\"\nset = [\"scene.camera.width=256\", \"scene.camera.height=256\"]\ncost_s = 100\nfixed_s = 20\nscalable = true\n\
             [[run]]\nconfig = \"configs/b.toml\"\ncost_s = 300\nfixed_s = 300\nheavy = true\n",
        )
        .unwrap();
        let opts = |budget_s: f64, heavy: bool| Options {
            papers: vec![file.clone()],
            budget_s,
            out: dir.path().join("out"),
            heavy,
            ..options()
        };
        let runs = |o: &Options| plan(o).unwrap().remove(0).2;
        let small = runs(&opts(100.0, false));
        assert!(small[0].left_out.is_none() && small[0].scaled.is_none());
        let why = small[1].left_out.as_deref().expect("left out");
        assert!(why.contains("--heavy") && why.contains("300 s"), "{why}");
        // With the flag the heavy run is made and the light one shrinks to make room.
        let flagged = runs(&opts(100.0, true));
        assert!(flagged[1].left_out.is_none());
        assert!(flagged[0].scale < 1.0 && flagged[1].scale == 1.0);
        assert!(runs(&opts(400.0, false))[1].left_out.is_none());
    }

    /// Before each paper the timed share is fitted again to the budget left: up when runs
    /// came in under their estimates, down when over, never below MIN_SHARE; the runs' edits,
    /// costs and notes follow, and complete runs are not counted.
    #[test]
    fn the_share_is_refitted_to_the_budget_left() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("p.toml");
        std::fs::write(
            &file,
            "paper = \"P\"\n\
             [[run]]\nconfig = \"configs/a.toml\"\ncost_s = 100\nfixed_s = 20\ntrace_s = 60\n\
             [[run]]\nconfig = \"configs/b.toml\"\ncost_s = 50\nfixed_s = 50\n",
        )
        .unwrap();
        let opts = Options {
            papers: vec![file.clone()],
            budget_s: 120.0,
            out: dir.path().join("out"),
            ..options()
        };
        let mut planned = plan(&opts).unwrap();
        let share_of = |p: &[PaperPlan]| p[0].2[0].timed_share;
        assert!((share_of(&planned) - 0.5).abs() < 1e-12);
        let sets = |p: &[PaperPlan]| -> Vec<String> {
            p[0].2[0]
                .args
                .iter()
                .filter(|a| a.starts_with("run.timed_share"))
                .cloned()
                .collect()
        };
        assert_eq!(sets(&planned), ["run.timed_share=0.5"]);
        // 150 s left: everything as declared.
        assert_eq!(refit(&mut planned, &opts, 150.0), Some((0.5, 1.0)));
        assert!(sets(&planned).is_empty() && planned[0].2[0].scaled.is_none());
        assert_eq!(planned[0].2[0].cost_s, 100.0);
        assert_eq!(refit(&mut planned, &opts, 150.0), None);
        // 105 s left: 15 of the 60 s of timed tracing, a quarter.
        assert_eq!(refit(&mut planned, &opts, 105.0), Some((1.0, 0.25)));
        assert_eq!(sets(&planned), ["run.timed_share=0.25"]);
        assert_eq!(planned[0].2[0].cost_s, 20.0 + 15.0 + 20.0);
        let note = planned[0].2[0].scaled.clone().unwrap();
        assert!(note.contains("25 % of each batch"), "{note}");
        // Less than the rest costs: the smallest share.
        assert_eq!(refit(&mut planned, &opts, 10.0), Some((0.25, MIN_SHARE)));
        // A run complete in its folder is not made again: nothing left to refit.
        let folder = &planned[0].2[0].folder;
        std::fs::create_dir_all(folder).unwrap();
        std::fs::write(
            folder.join("results.json"),
            r#"{"meta": {"status": "complete"}, "rows": []}"#,
        )
        .unwrap();
        assert_eq!(refit(&mut planned, &opts, 150.0), None);
    }

    #[test]
    fn fitting_scales_only_the_variable_part() {
        let (a, b) = (spec(100.0, 20.0, true), spec(50.0, 50.0, false));
        let f = fit(&[&a, &b], 200.0);
        assert_eq!((f.share, f.scale, f.estimate_s), (1.0, 1.0, 150.0));
        // 20 + 50 fixed, 80 variable: 110 s leaves 40 s, half the pixels; no run declares a
        // timed part, so the share stays whole.
        let f = fit(&[&a, &b], 110.0);
        assert_eq!(f.share, 1.0);
        assert!((f.scale - 0.5).abs() < 1e-12 && (f.estimate_s - 110.0).abs() < 1e-9);
        // Never below the smallest scale.
        assert_eq!(fit(&[&a, &b], 10.0).scale, MIN_SCALE);
    }

    /// The timed share shrinks before the images, down to MIN_SHARE; then the images shrink
    /// with the timed part at that share.
    #[test]
    fn fitting_shrinks_the_timed_share_before_the_images() {
        // 100 s: 20 fixed, 60 timed tracing, 20 counting and validation.
        let a = RunSpec {
            trace_s: 60.0,
            ..spec(100.0, 20.0, true)
        };
        let b = spec(50.0, 50.0, false);
        // 150 s as declared; 120 s: the share that drops 30 of the 60 s, images whole.
        let f = fit(&[&a, &b], 120.0);
        assert!((f.share - 0.5).abs() < 1e-12 && f.scale == 1.0, "{f:?}");
        assert!((f.estimate_s - 120.0).abs() < 1e-9);
        // At MIN_SHARE the run costs 20 + 60/16 + 20 = 43.75 s, both runs 93.75 s: the
        // smallest estimate at the declared images.
        let f = fit(&[&a, &b], 93.75);
        assert!(
            (f.share - MIN_SHARE).abs() < 1e-12 && f.scale == 1.0,
            "{f:?}"
        );
        // Below that the images shrink: 70 + 0.5 * 23.75.
        let f = fit(&[&a, &b], 70.0 + 0.5 * 23.75);
        assert_eq!(f.share, MIN_SHARE);
        assert!((f.scale - 0.5).abs() < 1e-12, "{f:?}");
        // The planned run says both, and passes the share to the run.
        let (sets, note, scale, share) = fitted_sets(&a, &f);
        assert!(
            sets.contains(&"run.timed_share=0.0625".to_owned()),
            "{sets:?}"
        );
        let note = note.unwrap();
        assert!(
            note.contains("6.25 % of each batch") && note.contains("256 →"),
            "{note}"
        );
        assert_eq!((scale, share), (f.scale, MIN_SHARE));
        assert!((a.planned_s(share, scale) - (20.0 + 0.5 * 23.75)).abs() < 1e-9);
        // A run without a timed part gets no share.
        let (sets, _, _, share) = fitted_sets(&b, &f);
        assert!(!sets.iter().any(|s| s.starts_with("run.timed_share")) && share == 1.0);
    }

    /// A run of three processes costs three times its declared process, fixed part too.
    #[test]
    fn fitting_counts_every_process() {
        let a = RunSpec {
            processes: 3,
            ..spec(100.0, 20.0, true)
        };
        let b = spec(50.0, 50.0, false);
        let f = fit(&[&a, &b], 350.0);
        assert_eq!((f.scale, f.estimate_s), (1.0, 350.0));
        // 60 + 50 fixed, 240 variable: 230 s leaves 120 s, half the pixels.
        let f = fit(&[&a, &b], 230.0);
        assert!((f.scale - 0.5).abs() < 1e-12 && (f.estimate_s - 230.0).abs() < 1e-9);
        assert!(!heavy_included(&[&a, &b], 349.0, false));
        let opts = options();
        let args = run_args(&a, &a.set, Path::new("o/r"), &opts);
        assert!(
            args.windows(2).any(|w| w == ["--processes", "3"]),
            "{args:?}"
        );
        assert!(!run_args(&b, &b.set, Path::new("o/r"), &opts).contains(&"--processes".into()));
    }

    #[test]
    fn scaled_sizes_keep_multiples_of_eight() {
        let (sets, note) = scaled_sets(&spec(1.0, 0.0, true), 0.25);
        assert_eq!(sets, ["scene.camera.width=128", "scene.camera.height=96"]);
        assert!(note.unwrap().contains("256 → 128"));
        let (sets, note) = scaled_sets(&spec(1.0, 0.0, false), 0.25);
        assert_eq!(sets[0], "scene.camera.width=256");
        assert!(note.is_none());
    }
}
