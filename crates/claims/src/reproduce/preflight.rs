//! What `reproduce` checks before the first run: every `--with`, every run's config
//! with its edits, where the runs write, and that no other process writes into a run's folder.

use super::{writes, Options, PaperPlan, Runs};
use crate::rows::RowSet;
use crate::Error;
use std::path::Path;

/// Before the first run: every `--with` holds trace-bench results, every run's config exists
/// and passes the checks that need no scene with its edits ([`Runs::check_run`]), and no other
/// process writes into a run's folder.
pub(super) fn preflight(
    opts: &Options,
    planned: &[PaperPlan],
    runner: &dyn Runs,
) -> Result<(), Error> {
    for w in &opts.with {
        RowSet::read_results(std::slice::from_ref(w))
            .map_err(|e| Error::Other(format!("--with {}: {e}", w.display())))?;
    }
    for (path, _, runs) in planned {
        for r in runs.iter().filter(|r| r.args[0] == "run") {
            let cfg = Path::new(&r.args[1]);
            let sets: Vec<String> = r
                .args
                .windows(2)
                .filter(|w| w[0] == "--set")
                .map(|w| w[1].clone())
                .collect();
            let text = std::fs::read_to_string(cfg).map_err(|e| {
                Error::io(cfg, format!("{e} (a [[run]] config of {})", path.display()))
            })?;
            let text = runner.apply_sets(&cfg.display().to_string(), &text, &sets)?;
            toml::from_str::<toml::Table>(&text).map_err(|e| {
                let line = e.span().map(|s| tb_results::error::line_of(&text, s.start));
                Error::io(
                    cfg,
                    format!(
                        "{}{} (a [[run]] config of {})",
                        line.map(|l| format!("{l}: ")).unwrap_or_default(),
                        e.message().trim().replace('\n', " "),
                        path.display()
                    ),
                )
            })?;
            let extra = runner.check_run(&r.args).map_err(|e| {
                Error::Other(format!(
                    "{e} (a [[run]] of {}: checked before the first run)",
                    path.display()
                ))
            })?;
            if let Some(w) = extra.iter().find(|w| !writes::inside(w, &opts.out)) {
                if !opts.write_anywhere && !r.exec {
                    return Err(Error::Other(format!(
                        "{}: run {}: its config writes {} (the convergence cache), outside the \
                         report folder {}: set [convergence] cache inside it, or pass \
                         --write-anywhere",
                        path.display(),
                        r.label,
                        w.display(),
                        opts.out.display()
                    )));
                }
            }
        }
        for r in runs.iter().filter(|r| r.exec && !opts.write_anywhere) {
            if let Some(why) = writes::exec_outside(&r.args, &r.folder) {
                return Err(Error::Other(format!(
                    "{}: run {}: {why}; a claims file's runs write in their run folder (claims/README.md, \
                     \"What a claims file may do\"): pass --write-anywhere to allow it",
                    path.display(),
                    r.label
                )));
            }
        }
        for r in runs.iter().filter(|r| r.folder.is_dir()) {
            tb_results::lock::FolderLock::acquire(&r.folder)?;
        }
    }
    Ok(())
}
