//! How a reproduce stops early: a signal (no report; the same `--out` resumes) or the
//! `--deadline` (runs ended or left out, the report made from what is there).

use super::{Options, PlannedRun, Runs};
use crate::Error;
use std::time::Instant;

/// Whether `deadline` has passed before run `r` starts: then `r` is left out, and said so.
pub(super) fn past_deadline(r: &mut PlannedRun, opts: &Options, deadline: Option<Instant>) -> bool {
    if deadline.is_none_or(|d| Instant::now() < d) {
        return false;
    }
    let why = format!(
        "not made: the --deadline of {:.0} s had passed",
        opts.deadline_s.unwrap_or(0.0)
    );
    eprintln!("reproduce: {} {}: {why}", r.paper, r.label);
    r.left_out = Some(why);
    true
}

/// The error of a reproduce ended by signal `sig` (in run `r`, which was ended).
pub(super) fn interrupted(
    sig: i32,
    r: Option<&PlannedRun>,
    opts: &Options,
    runner: &dyn Runs,
) -> Error {
    let run = r
        .map(|r| {
            format!(
                "ended the run {} {} (its finished rows stay in {}); ",
                r.paper,
                r.label,
                r.folder.display()
            )
        })
        .unwrap_or_default();
    Error::Other(format!(
        "reproduce: interrupted by {}: {run}no report written; rerun with --out {} to resume",
        runner.signal_name(sig),
        opts.out.display()
    ))
}
