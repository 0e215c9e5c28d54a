//! The papers' figures drawn from `reproduce`'s runs: each claims file's `[[figure]]`s run a
//! plotting script of `scripts/` (`plot.py`, `irregular-figure6.py`) on the runs' folders into
//! the report's `figures/`, linked from REPORT.md. Needs matplotlib: the interpreter is
//! `TRACE_BENCH_PYTHON` (a venv's `python`), else the `.venv` the README's set-up makes
//! (`.venv/bin/python` in the current directory, where it exists), else `python3`; without
//! matplotlib REPORT.md says how to get it, and a script that fails is reported there, never
//! fatal.

use super::schema::{run_refs, FigureSpec};
use crate::runs::Runs;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The variable naming the interpreter that draws the figures.
pub const PYTHON_ENV: &str = "TRACE_BENCH_PYTHON";

/// The virtual environment the README's set-up makes, in the current directory.
pub const VENV_PYTHON: &str = ".venv/bin/python";

/// How to get matplotlib, said where figures are not drawn.
pub const HOW_TO: &str = "python3 -m venv .venv && .venv/bin/pip install -r \
    scripts/requirements.txt, then rerun reproduce from the same directory (it draws with \
    .venv/bin/python; the same --out reuses the runs)";

/// What became of one figure.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub enum Drawn {
    /// Written to this path, relative to the report folder.
    File(String),
    /// Not drawn: a run it needs has no rows (left out, failed).
    NoRows(String),
    /// The script failed: how, and its last lines of output.
    Failed(String),
}

/// One figure's outcome.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Figure {
    /// The paper's key (its claims file's stem).
    pub paper: String,
    /// The figure's name (the PNG is `PAPER-NAME.png`).
    pub name: String,
    /// What the figure shows.
    pub title: String,
    /// Whether and where it was drawn.
    pub drawn: Drawn,
}

/// The interpreter to draw with: `TRACE_BENCH_PYTHON`, else [`VENV_PYTHON`] where it exists,
/// else `python3`.
pub fn python() -> PathBuf {
    python_in(Path::new("."), std::env::var_os(PYTHON_ENV))
}

/// [`python`] from folder `dir` with `TRACE_BENCH_PYTHON` = `env`.
fn python_in(dir: &Path, env: Option<std::ffi::OsString>) -> PathBuf {
    if let Some(p) = env.filter(|p| !p.is_empty()) {
        return PathBuf::from(p);
    }
    let venv = dir.join(VENV_PYTHON);
    if venv.is_file() {
        return venv;
    }
    PathBuf::from("python3")
}

/// `Ok` when `python` imports matplotlib; else why not, in words.
pub fn check(python: &Path) -> Result<(), String> {
    match Command::new(python)
        .args(["-c", "import matplotlib"])
        .output()
    {
        Ok(o) if o.status.success() => Ok(()),
        Ok(_) => Err(format!(
            "matplotlib is not installed for {}",
            python.display()
        )),
        Err(e) => Err(format!("{} did not start: {e}", python.display())),
    }
}

/// Draw `paper`'s figures with `python` into `out/figures/`: `runs` are the paper's runs as
/// (label, folder); a `{run:LABEL}` argument becomes every folder of that label holding a
/// `results.csv` (or the other CSVs a run writes), and a figure none of whose folders has rows
/// is not drawn. `scripts` is the folder of the plotting scripts.
pub fn draw(
    runner: &dyn Runs,
    python: &Path,
    scripts: &Path,
    paper: &str,
    specs: &[FigureSpec],
    runs: &[(String, PathBuf)],
    out: &Path,
) -> Vec<Figure> {
    let dir = out.join("figures");
    let mut done = Vec::new();
    for f in specs {
        let file = format!("{paper}-{}.png", f.name);
        let drawn = match args(f, runs) {
            Err(label) => Drawn::NoRows(format!("the run `{label}` has no rows")),
            Ok(mut a) => {
                a.push("--out".into());
                a.push(dir.join(&file).display().to_string());
                run_script(runner, python, &scripts.join(&f.script), &a, &dir)
                    .map(|()| Drawn::File(format!("figures/{file}")))
                    .unwrap_or_else(Drawn::Failed)
            }
        };
        done.push(Figure {
            paper: paper.to_owned(),
            name: f.name.clone(),
            title: f.title.clone(),
            drawn,
        });
    }
    done
}

/// The figure's arguments with `{run:LABEL}` replaced by the label's folders with rows; the
/// first label without any is the error.
fn args(f: &FigureSpec, runs: &[(String, PathBuf)]) -> Result<Vec<String>, String> {
    let mut out = Vec::new();
    for a in &f.args {
        let labels = run_refs(a);
        if labels.is_empty() {
            out.push(a.clone());
            continue;
        }
        // An argument that is one reference expands to several folders.
        for label in labels {
            let folders: Vec<String> = runs
                .iter()
                .filter(|(l, d)| l == label && has_rows(d))
                .map(|(_, d)| d.display().to_string())
                .collect();
            if folders.is_empty() {
                return Err(label.to_owned());
            }
            out.extend(folders);
        }
    }
    Ok(out)
}

/// A run folder with a CSV of rows.
fn has_rows(d: &Path) -> bool {
    std::fs::read_dir(d).is_ok_and(|rd| {
        rd.filter_map(Result::ok).any(|e| {
            let p = e.path();
            p.extension().is_some_and(|x| x == "csv")
                && p.file_name().is_some_and(|n| n != "params.csv")
                && p.metadata().is_ok_and(|m| m.len() > 0)
        })
    })
}

/// Run one script; `Err` says how it failed, with its last lines of output.
fn run_script(
    runner: &dyn Runs,
    python: &Path,
    script: &Path,
    args: &[String],
    dir: &Path,
) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let o = Command::new(python)
        .arg(script)
        .args(args)
        .output()
        .map_err(|e| format!("{} did not start: {e}", python.display()))?;
    let wrote = args
        .last()
        .is_some_and(|p| Path::new(p).metadata().is_ok_and(|m| m.len() > 0));
    if o.status.success() && wrote {
        return Ok(());
    }
    let text = String::from_utf8_lossy(&o.stderr);
    let tail: Vec<&str> = text
        .lines()
        .rev()
        .filter(|l| !l.trim().is_empty())
        .take(2)
        .collect();
    let tail: Vec<&str> = tail.into_iter().rev().collect();
    let how = if o.status.success() {
        "exited 0 without writing the figure".to_owned()
    } else {
        runner.ended(&o.status)
    };
    Err(if tail.is_empty() {
        how
    } else {
        format!("{how}: {}", tail.join(" / "))
    })
}

/// REPORT.md's figures section: each figure linked, or why it is missing; `notice` (why none
/// were drawn) instead when they were not tried.
pub fn markdown(figs: &[Figure], notice: Option<&str>) -> String {
    let mut s = String::from("\n## Figures\n\n");
    if let Some(n) = notice {
        s.push_str(&format!(
            "Not drawn: {n}. To draw the papers' figures from these runs: {HOW_TO}.\n"
        ));
        return s;
    }
    if figs.is_empty() {
        s.push_str("No claims file names a figure.\n");
        return s;
    }
    s.push_str(
        "Drawn from this report's runs by the scripts of `scripts/` (the claims files' \
         `[[figure]]`s), to read beside the paper's:\n\n",
    );
    for f in figs {
        let what = match &f.drawn {
            Drawn::File(p) => format!("[{p}]({p})"),
            Drawn::NoRows(why) => format!("not drawn: {why}"),
            Drawn::Failed(why) => format!("**failed**: {}", why.replace('\n', " ")),
        };
        s.push_str(&format!("- {} ({}): {what}\n", f.title, f.paper));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The README's set-up makes `.venv`; reproduce then draws with it,
    /// without a variable to set; `TRACE_BENCH_PYTHON` still wins.
    #[test]
    fn the_set_up_venv_draws_the_figures() {
        let d = tempfile::tempdir().unwrap();
        assert_eq!(python_in(d.path(), None), PathBuf::from("python3"));
        std::fs::create_dir_all(d.path().join(".venv/bin")).unwrap();
        std::fs::write(d.path().join(VENV_PYTHON), "").unwrap();
        assert_eq!(python_in(d.path(), None), d.path().join(VENV_PYTHON));
        assert_eq!(
            python_in(d.path(), Some("/x/py".into())),
            PathBuf::from("/x/py")
        );
        assert_eq!(
            python_in(d.path(), Some("".into())),
            d.path().join(VENV_PYTHON)
        );
    }

    fn spec(name: &str, args: &[&str]) -> FigureSpec {
        FigureSpec {
            name: name.into(),
            title: format!("Figure {name}"),
            script: "plot.py".into(),
            args: args.iter().map(|a| a.to_string()).collect(),
        }
    }

    /// A stand-in interpreter: `-c` (the matplotlib probe) succeeds when `ok`; a script run
    /// writes its `--out` unless an argument is `boom`, which fails with a message.
    #[cfg(unix)]
    fn fake_python(dir: &Path, ok: bool) -> PathBuf {
        use std::os::unix::fs::PermissionsExt;
        let p = dir.join(if ok { "python-ok" } else { "python-bare" });
        let probe = if ok { "exit 0" } else { "exit 1" };
        std::fs::write(
            &p,
            format!(
                "#!/bin/sh\nif [ \"$1\" = -c ]; then {probe}; fi\n\
                 for a in \"$@\"; do if [ \"$a\" = boom ]; then echo 'Traceback' >&2; \
                 echo 'ValueError: no rows to plot' >&2; exit 1; fi; done\n\
                 out=; prev=; for a in \"$@\"; do if [ \"$prev\" = --out ]; then out=$a; fi; prev=$a; done\n\
                 echo png > \"$out\"\n"
            ),
        )
        .unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
        p
    }

    /// Only scripts are run here: how one ended is all that is asked of the runner.
    struct Scripts;

    impl crate::reproduce::Runs for Scripts {
        fn apply_sets(&self, _: &str, _: &str, _: &[String]) -> Result<String, crate::Error> {
            unreachable!("figures edit no config")
        }
        fn catch_signals(&self) {}
        fn received(&self) -> Option<i32> {
            None
        }
        fn run(&self, _: &mut Command) -> std::io::Result<(std::process::ExitStatus, Option<i32>)> {
            unreachable!("figures start no run")
        }
        fn ended(&self, st: &std::process::ExitStatus) -> String {
            st.to_string()
        }
        fn signal_name(&self, sig: i32) -> String {
            sig.to_string()
        }
    }

    #[cfg(unix)]
    #[test]
    fn figures_are_drawn_linked_or_reported_never_fatal() {
        let dir = tempfile::tempdir().unwrap();
        let run = dir.path().join("runs/p/0-cfg");
        std::fs::create_dir_all(&run).unwrap();
        std::fs::write(run.join("results.csv"), "scene\nx\n").unwrap();
        let empty = dir.path().join("runs/p/1-heavy");
        std::fs::create_dir_all(&empty).unwrap();
        let runs = vec![("cfg".to_owned(), run.clone()), ("heavy".to_owned(), empty)];
        let specs = [
            spec("a", &["sweep", "{run:cfg}", "--param", "d_min"]),
            spec("b", &["{run:heavy}"]),
            spec("c", &["{run:cfg}", "boom"]),
        ];
        let out = dir.path().join("report");
        let py = fake_python(dir.path(), true);
        assert_eq!(check(&py), Ok(()));
        let figs = draw(
            &Scripts,
            &py,
            Path::new("scripts"),
            "p",
            &specs,
            &runs,
            &out,
        );
        assert_eq!(figs[0].drawn, Drawn::File("figures/p-a.png".into()));
        assert!(out.join("figures/p-a.png").is_file());
        assert!(matches!(&figs[1].drawn, Drawn::NoRows(w) if w.contains("heavy")));
        let Drawn::Failed(why) = &figs[2].drawn else {
            panic!("{:?}", figs[2].drawn)
        };
        assert!(why.contains("no rows to plot"), "{why}");
        let md = markdown(&figs, None);
        assert!(md.contains("[figures/p-a.png](figures/p-a.png)"), "{md}");
        assert!(
            md.contains("not drawn: the run `heavy` has no rows"),
            "{md}"
        );
        assert!(md.contains("**failed**"), "{md}");
        // Without matplotlib: one line saying how to get the figures.
        let bare = fake_python(dir.path(), false);
        let why = check(&bare).unwrap_err();
        let md = markdown(&[], Some(&why));
        assert!(md.contains("matplotlib is not installed"), "{md}");
        assert!(
            md.contains("pip install -r scripts/requirements.txt"),
            "{md}"
        );
        let missing = check(&dir.path().join("no-such-python")).unwrap_err();
        assert!(missing.contains("did not start"), "{missing}");
    }

    #[test]
    fn run_references_expand_to_the_folders_with_rows() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        for d in [&a, &b] {
            std::fs::create_dir_all(d).unwrap();
            std::fs::write(d.join("results.csv"), "x\n1\n").unwrap();
        }
        let runs = vec![("cfg".to_owned(), a.clone()), ("cfg".to_owned(), b.clone())];
        let got = args(
            &spec("x", &["bars", "{run:cfg}", "--ray-kind", "ao"]),
            &runs,
        )
        .unwrap();
        let (a, b) = (a.display().to_string(), b.display().to_string());
        assert_eq!(got, ["bars", a.as_str(), b.as_str(), "--ray-kind", "ao"]);
        assert_eq!(
            args(&spec("y", &["{run:other}"]), &runs),
            Err("other".into())
        );
    }
}
