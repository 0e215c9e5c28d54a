//! Times compared between the processes of a run (`run --processes K`, the `process` column):
//! with three processes or more a compared time's interval is the spread of its per-process
//! values (the round-by-round ratio of each process where its rows were timed interleaved),
//! not the floor; with fewer the floor stays and the `why` says so.

use std::path::{Path, PathBuf};
use tb_claims::{self as claims, ClaimResult, RowSet, Verdict};

const HEAD: &str = "scene,structure,params,traversal,device,adapter,threads,triangle_test,ray_kind,rays,trace_ms_min,trace_ms_median,trace_ms_max,timed_runs,trace_ms_ci,noisy,trace_ms_runs,timing_group,process";

/// One timed row of process `p`: its rounds `runs` (the median the middle one), timed
/// interleaved in group `group` (empty: timed alone).
fn line(tr: &str, runs: &[f64], group: &str, p: usize, noisy: bool) -> String {
    let mut s = runs.to_vec();
    s.sort_by(f64::total_cmp);
    let joined: Vec<String> = runs.iter().map(|x| x.to_string()).collect();
    format!(
        "s,kdtree,k=1,{tr},cpu,,1,watertight,primary,100,{},{},{},{},0.01,{noisy},{},{group},{p}",
        s[0],
        s[s.len() / 2],
        s[s.len() - 1],
        runs.len(),
        joined.join(";")
    )
}

/// A results folder of `scales.len()` processes: in process `p` every round of `a` takes
/// `scales[p]` times its base time (a drift within the process), `b` exactly twice `a`'s time
/// round by round, both timed interleaved; `noisy` flags process 1's rows.
fn run(dir: &Path, name: &str, scales: &[f64], noisy: bool) -> PathBuf {
    let d = dir.join(name);
    std::fs::create_dir_all(&d).unwrap();
    let mut text = format!("{HEAD}\n");
    for (p, k) in scales.iter().enumerate() {
        let a: Vec<f64> = (0..7).map(|r| k * (10.0 + 0.5 * r as f64)).collect();
        let b: Vec<f64> = a.iter().map(|x| 2.0 * x).collect();
        let g = format!("s-1-p{p}-0");
        let n = noisy && p == 1;
        text.push_str(&format!(
            "{}\n{}\n",
            line("a", &a, &g, p, n),
            line("b", &b, &g, p, n)
        ));
    }
    std::fs::write(d.join("results.csv"), text).unwrap();
    d
}

fn eval(test: &str, source: &Path) -> Vec<ClaimResult> {
    let c = format!(
        "paper = \"t\"\n[[claim]]\nid = \"c\"\nwhere = \"T1\"\ntext = \"t\"\npaper = \"p\"\nmeasure = \"time\"\nrows.a = {{ traversal = \"a\" }}\nrows.b = {{ traversal = \"b\" }}\ntest = {test}\n"
    );
    let file = claims::parse(Path::new("t.toml"), &c).expect("claims parse");
    claims::evaluate(&file, &RowSet::read(&[source.to_path_buf()]).unwrap())
}

const VALUE: &str = "{ kind = \"value\", of = \"a\", min = 0 }";
const RATIO: &str = "{ kind = \"ratio\", num = \"b\", den = \"a\", min = 1.9, max = 2.1 }";

/// The interval of the group's compared quantity.
fn derived(v: &[ClaimResult]) -> [f64; 3] {
    v[0].groups[0].derived.expect("a band test")
}

/// A slow process widens the interval of an absolute time between processes; the paired ratio
/// (each process's round-by-round ratio) is 2 in every process and its verdict survives, even
/// on the slow process's noisy rows.
#[test]
fn a_slow_process_widens_a_time_but_not_a_paired_ratio() {
    let t = tempfile::tempdir().unwrap();
    let quiet = run(t.path(), "quiet", &[1.0, 1.02, 0.99], false);
    let slowed = run(t.path(), "slowed", &[1.0, 1.6, 0.99], true);
    let width = |d: [f64; 3]| d[2] / d[0];
    let (q, s) = (eval(VALUE, &quiet), eval(VALUE, &slowed));
    assert!(
        q[0].why.contains("interval between 3 processes"),
        "{}",
        q[0].why
    );
    assert_eq!(q[0].groups[0].between, Some(3));
    let (wq, ws) = (width(derived(&q)), width(derived(&s)));
    assert!(ws > 2.0 * wq && ws > 1.5, "quiet {wq}, slowed {ws}");
    for src in [quiet, slowed] {
        let v = eval(RATIO, &src);
        assert_eq!(v[0].verdict, Verdict::Agree, "{v:?}");
        let d = derived(&v);
        assert!(
            (d[0] - 2.0).abs() < 1e-9 && (d[2] - 2.0).abs() < 1e-9,
            "{d:?}"
        );
    }
}

/// With fewer processes than an interval needs the floor stays and says so; a band narrower
/// than the floor allows is undecidable there and decided between three processes; a band of
/// no width stays undecidable.
#[test]
fn fewer_processes_keep_the_floor_and_say_so() {
    let t = tempfile::tempdir().unwrap();
    let two = run(t.path(), "two", &[1.0, 1.1], false);
    let v = eval(RATIO, &two);
    assert!(
        v[0].why.contains("floor ±20 %") && v[0].why.contains("2 processes"),
        "{}",
        v[0].why
    );
    assert_eq!(v[0].groups[0].between, None);
    // 2.1 / 1.9 < 1.2²: no interval at the floor can lie inside.
    assert_eq!(v[0].verdict, Verdict::Undecidable, "{v:?}");
    let three = run(t.path(), "three", &[1.0, 1.1, 0.95], false);
    assert_eq!(eval(RATIO, &three)[0].verdict, Verdict::Agree);
    let point = "{ kind = \"ratio\", num = \"b\", den = \"a\", min = 2, max = 2 }";
    let v = eval(point, &three);
    assert!(
        v[0].undecidable
            .as_deref()
            .is_some_and(|r| r.contains("no width")),
        "{v:?}"
    );
    // Two processes keep their rounds paired: each process's exact 2, widened to the floor.
    let d = derived(&eval(RATIO, &two));
    assert!(
        (d[0] - 2.0 / 1.2).abs() < 1e-9 && (d[2] - 2.4).abs() < 1e-9,
        "{d:?}"
    );
    // One process: as before.
    let one = run(t.path(), "one", &[1.0], false);
    let v = eval(RATIO, &one);
    assert!(v[0].why.contains("1 process"), "{}", v[0].why);
}

/// Rows timed apart (no `timing_group`) compare by each process's ratio of medians; a
/// process without one side's rows (one interrupted) is left out of the comparison.
#[test]
fn unpaired_rows_compare_per_process_and_partial_processes_are_left_out() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path().join("apart");
    std::fs::create_dir_all(&d).unwrap();
    let mut text = format!("{HEAD}\n");
    for (p, k) in [1.0, 1.3, 0.9, 1.1].iter().enumerate() {
        let a: Vec<f64> = (0..5).map(|r| k * (10.0 + r as f64)).collect();
        let b: Vec<f64> = a.iter().map(|x| 3.0 * x).collect();
        text.push_str(&format!("{}\n", line("a", &a, "", p, false)));
        // Process 3 was interrupted before its `b` row.
        if p < 3 {
            text.push_str(&format!("{}\n", line("b", &b, "", p, false)));
        }
    }
    std::fs::write(d.join("results.csv"), text).unwrap();
    let v = eval(
        "{ kind = \"speedup\", of = \"a\", base = \"b\", min = 2.5, max = 3.5 }",
        &d,
    );
    assert_eq!(v[0].verdict, Verdict::Agree, "{v:?}");
    assert!(v[0].why.contains("between 3 processes"), "{}", v[0].why);
    let x = derived(&v);
    assert!((x[1] - 3.0).abs() < 1e-9, "{x:?}");
}

/// Build times timed once in each process (`build_repeat = 1`, `run --processes 3`): a row
/// alone gives no interval, three processes' builds do, and the claim is decided between
/// them; with two processes the rows' too few builds leave it inconclusive.
#[test]
fn one_build_per_process_is_decided_between_three_processes() {
    const BHEAD: &str = "scene,structure,params,traversal,device,adapter,threads,triangle_test,ray_kind,rays,build_ms,build_ms_runs,process";
    let t = tempfile::tempdir().unwrap();
    let folder = |name: &str, scales: &[f64]| {
        let d = t.path().join(name);
        std::fs::create_dir_all(&d).unwrap();
        let mut text = format!("{BHEAD}\n");
        for (p, k) in scales.iter().enumerate() {
            for (tr, ms) in [("a", 10.0 * k), ("b", 40.0 * k)] {
                text.push_str(&format!(
                    "s,{tr}tree,k=1,{tr},cpu,,1,watertight,primary,100,{ms},{ms},{p}\n"
                ));
            }
        }
        std::fs::write(d.join("results.csv"), text).unwrap();
        d
    };
    let test = "{ kind = \"ratio\", num = \"b\", den = \"a\", min = 3, max = 5 }";
    let c = format!(
        "paper = \"t\"\n[[claim]]\nid = \"c\"\nwhere = \"T5\"\ntext = \"t\"\npaper = \"p\"\nmeasure = \"build_ms\"\nrows.a = {{ structure = \"atree\" }}\nrows.b = {{ structure = \"btree\" }}\ntest = {test}\n"
    );
    let file = claims::parse(Path::new("t.toml"), &c).expect("claims parse");
    let eval = |d: &Path| claims::evaluate(&file, &RowSet::read(&[d.to_path_buf()]).unwrap());
    let three = eval(&folder("three", &[1.0, 1.1, 0.95]));
    assert_eq!(three[0].verdict, Verdict::Agree, "{three:?}");
    assert!(
        three[0].why.contains("interval between 3 processes")
            && !three[0].why.contains("fewer than"),
        "{}",
        three[0].why
    );
    // Rows whose builds were not timed (untimed on all cores, or loaded from the cache) are
    // refused by a build-time claim.
    let untimed = folder("untimed", &[1.0, 1.1, 0.95]);
    let csv = untimed.join("results.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let text: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| format!("{l},{}", if i == 0 { "build_timed" } else { "false" }))
        .collect();
    std::fs::write(&csv, text.join("\n") + "\n").unwrap();
    let v = eval(&untimed);
    assert_eq!(v[0].verdict, Verdict::Inconclusive, "{v:?}");
    assert!(v[0].why.contains("build_timed = false"), "{}", v[0].why);
    let two = eval(&folder("two", &[1.0, 1.1]));
    assert_eq!(two[0].verdict, Verdict::Inconclusive, "{two:?}");
    assert!(
        two[0].why.contains("fewer than 3 timed runs"),
        "{}",
        two[0].why
    );
}
