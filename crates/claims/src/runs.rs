//! How reproduce makes its runs, handed in by whoever calls it: reproduce plans the runs,
//! says what to run and reads what they leave, but starting a child `trace-bench`, ending it
//! with reproduce on a signal, and applying a run's `--set` edits to its config are the
//! runner's (the CLI passes tb-harness's `experiment::child` and
//! `experiment::config::overrides`). Nothing here depends on the runner.

use crate::Error;
use std::process::{Command, ExitStatus};

/// The runner's side of reproduce: config edits, child processes and signals.
pub trait Runs {
    /// Config `text` (of `file`) with `key=value` edits applied as `trace-bench run --set`
    /// applies them (the effective config text), or the error `run` would give.
    fn apply_sets(&self, file: &str, text: &str, sets: &[String]) -> Result<String, Error>;
    /// Check a `trace-bench run` command line (`args` from `run` on) as far as it can be
    /// without loading a scene: its config with every edit and filter, the values a run reads
    /// (reproduce does so for every run before the first starts); the error `run` would give.
    /// `Ok`: the paths the run writes besides its `--out` folder (a config's convergence
    /// cache).
    fn check_run(&self, args: &[String]) -> Result<Vec<std::path::PathBuf>, Error> {
        let _ = args;
        Ok(Vec::new())
    }
    /// From here on catch SIGINT, SIGTERM and SIGHUP: [`Runs::received`] says which came.
    fn catch_signals(&self);
    /// The signal received since [`Runs::catch_signals`], if any.
    fn received(&self) -> Option<i32>;
    /// Run `cmd` in its own process group to its end, or until a signal reaches this process:
    /// then end the group, wait for it, and return the signal beside the run's status.
    fn run(&self, cmd: &mut Command) -> std::io::Result<(ExitStatus, Option<i32>)>;
    /// [`Runs::run`] ended at `deadline` too, if it is still running then (the third value
    /// says it was); without a deadline of its own a runner runs `cmd` to its end.
    fn run_until(
        &self,
        cmd: &mut Command,
        deadline: Option<std::time::Instant>,
    ) -> std::io::Result<(ExitStatus, Option<i32>, bool)> {
        let _ = deadline;
        self.run(cmd).map(|(st, sig)| (st, sig, false))
    }
    /// How a process ended, in words (`exit status 1`, `killed by signal 15`).
    fn ended(&self, st: &ExitStatus) -> String;
    /// A signal's name (`SIGTERM`).
    fn signal_name(&self, sig: i32) -> String;
}
