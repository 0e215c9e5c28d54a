//! Where a claims file's runs may write (the trust model is claims/README.md's
//! "What a claims file may do"). A run is a trace-bench subcommand of the same binary, never
//! another program; each run writes its run folder under the report folder. An `exec` run's
//! written paths (`--out`, `--csv`) must lie in its folder (`{out}`, no `..` climbing out of
//! it), and the subcommands that write a default folder of their own (`run`, `reproduce`,
//! `merge`, `diff`) must be given one there; a config run's `[convergence] cache` must lie in
//! the report folder. `reproduce --write-anywhere` lifts these checks.

use std::path::{Component, Path};

/// Subcommands that write nothing but standard output.
const READ_ONLY: &[&str] = &[
    "list", "scenes", "info", "claims", "check", "compare", "validate",
];

/// Subcommands that write, and the flag naming where (required: their default folder lies
/// outside the run's folder), or `None` where writing is optional (`weights --csv`).
const WRITERS: &[(&str, &str, bool)] = &[
    ("run", "--out", true),
    ("reproduce", "--out", true),
    ("merge", "--out", true),
    ("diff", "--out", true),
    ("weights", "--csv", false),
];

/// Whether `p` lies in `folder`, lexically (`..` may not climb out of it), both taken from
/// the current directory where relative.
pub(super) fn inside(p: &Path, folder: &Path) -> bool {
    let abs = |x: &Path| std::path::absolute(x).unwrap_or_else(|_| x.to_path_buf());
    let (p, folder) = (abs(p), abs(folder));
    let Ok(rest) = p.strip_prefix(&folder) else {
        return false;
    };
    let mut depth = 0i64;
    for c in rest.components() {
        match c {
            Component::ParentDir => depth -= 1,
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
            _ => return false,
        }
        if depth < 0 {
            return false;
        }
    }
    true
}

/// Why the `exec` run `args` (with `{out}` replaced by `folder`) would write outside its
/// folder, or `None`.
pub(super) fn exec_outside(args: &[String], folder: &Path) -> Option<String> {
    let cmd = args.first().map(String::as_str).unwrap_or_default();
    if READ_ONLY.contains(&cmd) {
        return None;
    }
    let Some(&(_, flag, required)) = WRITERS.iter().find(|w| w.0 == cmd) else {
        return Some(format!(
            "`{cmd}` is not a trace-bench subcommand a claims file may run"
        ));
    };
    let mut given = false;
    let mut i = 1;
    while i < args.len() {
        let a = &args[i];
        let value = if a == flag {
            i += 1;
            args.get(i).cloned()
        } else {
            a.strip_prefix(&format!("{flag}=")).map(str::to_owned)
        };
        if let Some(v) = value {
            given = true;
            if !inside(Path::new(&v), folder) {
                return Some(format!(
                    "`{cmd} {flag} {v}` writes outside the run's folder {{out}} ({})",
                    folder.display()
                ));
            }
        }
        i += 1;
    }
    (required && !given).then(|| {
        format!("`{cmd}` without `{flag} {{out}}/…` writes its default folder, outside the run's folder")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn exec_runs_write_only_in_their_folder() {
        let f = Path::new("/r/runs/p/0-weights");
        for ok in [
            args(&["weights", "--csv", "/r/runs/p/0-weights/weights.csv"]),
            args(&["weights"]),
            args(&["run", "c.toml", "--out=/r/runs/p/0-weights/x", "--force"]),
            args(&["list"]),
        ] {
            assert_eq!(exec_outside(&ok, f), None, "{ok:?}");
        }
        for (bad, why) in [
            (
                args(&["weights", "--csv", "/home/u/.bashrc"]),
                "writes outside",
            ),
            (
                args(&["weights", "--csv", "/r/runs/p/0-weights/../../../x.csv"]),
                "writes outside",
            ),
            (
                args(&["run", "c.toml", "--force", "--out", "/tmp/x"]),
                "writes outside",
            ),
            (args(&["run", "c.toml"]), "default folder"),
            (args(&["rm", "-rf"]), "not a trace-bench subcommand"),
        ] {
            let e = exec_outside(&bad, f).unwrap_or_default();
            assert!(e.contains(why), "{bad:?}: {e}");
        }
        assert!(inside(Path::new("/r/a/./b"), Path::new("/r/a")));
        assert!(!inside(Path::new("/r/a/b/../../c"), Path::new("/r/a")));
        assert!(!inside(Path::new("/r/ab"), Path::new("/r/a")));
    }
}
