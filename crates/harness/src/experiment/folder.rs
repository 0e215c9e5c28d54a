//! The run folder: where a run writes and who may write there.
//!
//! - `--out`, else `results/NAME/TIMESTAMP` with `results/NAME/LATEST` pointing at it, else for
//!   a shard `results/NAME/shard-K-of-N`; `--resume` without `--out` takes the newest
//!   `results/NAME/*` that holds a `results.csv`.
//! - One run writes to a folder at a time: an OS lock on `FOLDER/.lock`
//!   ([`tb_results::lock::FolderLock`]), held from before anything is touched until the run
//!   ends.
//! - `--resume` continues the same run only (the same config, shard and process: the
//!   `results.json` it finds says which), and only where there is something to continue.
//! - `--force` removes what an earlier run wrote ([`tb_results::output::RUN_OUTPUTS`]) and
//!   nothing else; without `--resume` or `--force` a folder with a run of several processes in
//!   it is refused, so that no finished work is lost.

use super::config::Experiment;
use super::processes;
use crate::error::HarnessError;
use std::path::{Path, PathBuf};
use tb_results::lock::FolderLock;

/// What the command line asks of a folder holding an earlier run.
#[derive(Clone, Copy, Debug, Default)]
pub struct Policy {
    /// `--resume`: continue the run in the folder.
    pub resume: bool,
    /// `--force`: replace the run in the folder.
    pub force: bool,
}

/// A run's output folder, locked for this process while the value lives.
pub struct RunFolder {
    /// The folder.
    pub path: PathBuf,
    _lock: FolderLock,
}

impl RunFolder {
    /// The folder of a run of one process of `exp` (`out`: `--out`), checked against `policy`
    /// and locked; with `--force` the earlier run's outputs are removed.
    pub fn open(
        out: Option<PathBuf>,
        exp: &Experiment,
        policy: Policy,
    ) -> Result<RunFolder, HarnessError> {
        let path = match (out, exp.shard.as_ref()) {
            (Some(o), _) => o,
            (None, Some(s)) => PathBuf::from("results")
                .join(&exp.name)
                .join(format!("shard-{}-of-{}", s.shard.k, s.shard.n)),
            (None, None) => new_default(&exp.name, policy.resume)?,
        };
        check_out(&path)?;
        if policy.resume
            && !["results.csv", "results.json"]
                .iter()
                .any(|f| path.join(f).is_file())
        {
            return Err(HarnessError::other(format!(
                "{}: nothing to resume (no results.csv or results.json there): run without --resume",
                path.display()
            )));
        }
        // One writer per folder, from here until the run ends (before --force touches it).
        let lock = FolderLock::acquire(&path)?;
        if policy.resume {
            check_resume(&path, exp)?;
        }
        if policy.force {
            remove_outputs(&path)?;
        }
        Ok(RunFolder { path, _lock: lock })
    }

    /// The folder of a run of `n` processes of the experiment `name` (each process locks its
    /// own folder inside it), checked against `policy` and locked.
    pub fn open_processes(
        out: Option<PathBuf>,
        name: &str,
        n: usize,
        policy: Policy,
    ) -> Result<RunFolder, HarnessError> {
        let path = match out {
            Some(o) => o,
            None => new_default(name, policy.resume)?,
        };
        check_out(&path)?;
        let begun = (0..n).any(|i| processes::folder(&path, i).join("results.json").is_file())
            || path.join("results.csv").is_file();
        if policy.resume && !begun {
            return Err(HarnessError::other(format!(
                "{}: nothing to resume (no process folder with results there): run without --resume",
                path.display()
            )));
        }
        if begun && !policy.resume && !policy.force {
            return Err(HarnessError::other(format!(
                "{}: holds the results of a run already: pass --resume to continue that run, --force \
                 to replace it, or choose another --out",
                path.display()
            )));
        }
        let lock = FolderLock::acquire(&path)?;
        Ok(RunFolder { path, _lock: lock })
    }
}

/// The default folder of experiment `name`, with `LATEST` pointed at it when new.
fn new_default(name: &str, resume: bool) -> Result<PathBuf, HarnessError> {
    let o = default_out(name, resume)?;
    if !resume {
        link_latest(&o);
    }
    Ok(o)
}

/// The default folder of experiment `name`: a new `results/NAME/TIMESTAMP`, or with `resume`
/// the newest `results/NAME/*` holding a `results.csv`.
pub fn default_out(name: &str, resume: bool) -> Result<PathBuf, HarnessError> {
    let base = PathBuf::from("results").join(name);
    if resume {
        let none = |e: &dyn std::fmt::Display| {
            HarnessError::other(format!("{}: no earlier run to resume{e}", base.display()))
        };
        let mut dirs: Vec<PathBuf> = std::fs::read_dir(&base)
            .map_err(|e| none(&format_args!(": {e}")))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.join("results.csv").is_file() && !p.is_symlink())
            .collect();
        dirs.sort();
        return dirs.pop().ok_or_else(|| none(&""));
    }
    let stamp = tb_results::meta::now_rfc3339().replace(':', "-");
    Ok(base.join(stamp.trim_end_matches('Z')))
}

/// Point `LATEST` beside a new default run folder at it (`results/NAME/LATEST`), so scripts
/// and docs can name the newest run. Best effort: a failure is a note on stderr.
pub fn link_latest(out: &Path) {
    let (Some(parent), Some(name)) = (out.parent(), out.file_name()) else {
        return;
    };
    let result = std::fs::create_dir_all(out).and_then(|_| {
        let link = parent.join("LATEST");
        if link.is_symlink() || link.exists() {
            std::fs::remove_file(&link)?;
        }
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(name, &link)
        }
        #[cfg(not(unix))]
        {
            let _ = name;
            Ok(())
        }
    });
    if let Err(e) = result {
        eprintln!("note: {}: cannot link LATEST: {e}", parent.display());
    }
}

/// `--out` must be a folder (or not exist yet).
pub fn check_out(out: &Path) -> Result<(), HarnessError> {
    if out.exists() && !out.is_dir() {
        return Err(HarnessError::other(format!(
            "--out {}: is a file, not a folder",
            out.display()
        )));
    }
    Ok(())
}

/// `--force`: remove what an earlier run wrote in `out`; anything else in the folder stays.
fn remove_outputs(out: &Path) -> Result<(), HarnessError> {
    for f in tb_results::output::RUN_OUTPUTS {
        let p = out.join(f);
        let removed = if p.is_file() {
            std::fs::remove_file(&p)
        } else if p.is_dir() {
            std::fs::remove_dir_all(&p)
        } else {
            Ok(())
        };
        removed.map_err(|e| HarnessError::io(&p, e))?;
    }
    Ok(())
}

/// `--resume` continues the same run: the same config, the same shard and the same process.
fn check_resume(out: &Path, exp: &Experiment) -> Result<(), HarnessError> {
    let p = out.join("results.json");
    let Some(meta) = std::fs::read_to_string(&p)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .map(|d| d["meta"].clone())
    else {
        return Ok(());
    };
    let refuse = |m: String| Err(HarnessError::other(format!("{}: {m}", p.display())));
    if let Some(h) = meta["config_hash"].as_str() {
        if h != exp.config_hash {
            return refuse(format!(
                "--resume of a run of another config (hash {h}, this one {}): choose another --out",
                exp.config_hash
            ));
        }
    }
    let was = meta["shard"]["k"]
        .as_u64()
        .map(|k| format!("{k}/{}", meta["shard"]["n"]));
    let now = exp.shard.as_ref().map(|p| p.shard.to_string());
    if was != now {
        return refuse(format!(
            "--resume of {} but this run is {}",
            was.map_or("an unsharded run".into(), |s| format!("shard {s}")),
            now.map_or("unsharded".into(), |s| format!("shard {s}"))
        ));
    }
    let was = meta["process"]["index"]
        .as_u64()
        .map(|i| format!("{i}/{}", meta["process"]["of"]));
    let now = exp.process.map(|p| p.to_string());
    if was != now {
        return refuse(format!(
            "--resume of {} but this run is {}",
            was.map_or("a run of one process".into(), |s| format!("process {s}")),
            now.map_or("a run of one process".into(), |s| format!("process {s}"))
        ));
    }
    Ok(())
}
