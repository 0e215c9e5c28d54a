//! The claims evaluator on small hand-written results: selectors, pooling, groups, every
//! test kind, time intervals and the rows it must not give a time verdict on.

use std::path::{Path, PathBuf};
use tb_claims::{self as claims, ClaimResult, RowSet, Verdict};

const HEAD: &str = "scene,structure,params,traversal,device,adapter,threads,triangle_test,ray_kind,rays,trace_ms_min,trace_ms_median,trace_ms_max,timed_runs,trace_ms_ci,noisy,interior_per_ray,build_heap_peak_bytes,build_heap_kept_bytes,build_stats";

/// One results row: scene, traversal, params, ray kind, rays, time (median, ci, runs, noisy),
/// interior nodes per ray.
#[allow(clippy::too_many_arguments)]
fn row(
    scene: &str,
    traversal: &str,
    params: &str,
    kind: &str,
    rays: u32,
    ms: f64,
    ci: f64,
    runs: u32,
    noisy: bool,
    interior: f64,
) -> String {
    format!(
        "{scene},kdtree,{params},{traversal},cpu,,1,watertight,{kind},{rays},{},{ms},{},{runs},{ci},{noisy},{interior},3000,1000,nodes=7;paper_bytes=64",
        ms * (1.0 - ci),
        ms * (1.0 + ci)
    )
}

fn write(dir: &Path, name: &str, lines: &[String]) -> PathBuf {
    let p = dir.join(name);
    let mut text = String::new();
    for l in lines {
        text.push_str(l);
        text.push('\n');
    }
    std::fs::write(&p, text).unwrap();
    p
}

fn eval(claims_toml: &str, sources: &[PathBuf]) -> Vec<ClaimResult> {
    let file = claims::parse(Path::new("t.toml"), claims_toml).expect("claims parse");
    claims::evaluate(&file, &RowSet::read(sources).unwrap())
}

/// Two scenes (one with two views), two traversals; `a` visits fewer nodes everywhere.
fn results(dir: &Path) -> PathBuf {
    let d = dir.join("run");
    std::fs::create_dir_all(&d).unwrap();
    write(
        &d,
        "results.csv",
        &[
            HEAD.to_string(),
            row(
                "s1@v1", "a", "k=1", "primary", 100, 10.0, 0.01, 9, false, 10.0,
            ),
            row(
                "s1@v2", "a", "k=1", "primary", 300, 30.0, 0.01, 9, false, 20.0,
            ),
            row(
                "s1@v1", "b", "k=1", "primary", 100, 20.0, 0.01, 9, false, 20.0,
            ),
            row(
                "s1@v2", "b", "k=1", "primary", 300, 60.0, 0.01, 9, false, 20.0,
            ),
            row("s2", "a", "k=1", "primary", 100, 10.0, 0.3, 9, false, 5.0),
            row("s2", "b", "k=1", "primary", 100, 11.0, 0.3, 9, false, 6.0),
            row("s2", "a", "k=2", "primary", 100, 10.0, 0.01, 9, false, 4.0),
            row("s2", "a", "k=1", "shadow", 100, 10.0, 0.01, 9, true, 1.0),
            row("s2", "b", "k=1", "shadow", 100, 30.0, 0.01, 9, true, 9.0),
        ],
    );
    d
}

const BASE: &str = "paper = \"t\"\n";

fn claim(body: &str) -> String {
    format!("{BASE}[[claim]]\nid = \"c\"\nwhere = \"T1\"\ntext = \"t\"\npaper = \"p\"\n{body}\n")
}

#[test]
fn views_pool_by_rays_and_groups_decide_together() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    // s1: a = (10·100 + 20·300) / 400 = 17.5 against b = 20: ratio 0.875; s2: 5/6.
    let c = claim(
        "measure = \"interior_per_ray\"\nfilter = { ray_kind = \"primary\", params = { k = 1 } }\nper = [\"scene\"]\nrows.a = { traversal = \"a\" }\nrows.b = { traversal = \"b\" }\ntest = { kind = \"ratio\", num = \"a\", den = \"b\", max = 0.9 }",
    );
    let v = eval(&c, std::slice::from_ref(&r));
    assert_eq!(v.len(), 1);
    assert_eq!(v[0].verdict, Verdict::Agree, "{v:?}");
    let g: Vec<f64> = v[0].groups.iter().map(|g| g.derived.unwrap()[1]).collect();
    assert!((g[0] - 0.875).abs() < 1e-12 && (g[1] - 5.0 / 6.0).abs() < 1e-12);
    // A tighter band fails in s1 only: `all` disagrees, `any` agrees, `most` disagrees (1 of 2).
    let tight = c.replace("max = 0.9", "max = 0.85");
    assert_eq!(
        eval(&tight, std::slice::from_ref(&r))[0].verdict,
        Verdict::Disagree
    );
    let any = tight.replace("per = [\"scene\"]", "per = [\"scene\"]\nneed = \"any\"");
    assert_eq!(
        eval(&any, std::slice::from_ref(&r))[0].verdict,
        Verdict::Agree
    );
    let most = tight.replace("per = [\"scene\"]", "per = [\"scene\"]\nneed = \"most\"");
    assert_eq!(
        eval(&most, std::slice::from_ref(&r))[0].verdict,
        Verdict::Disagree
    );
    // Per view: three groups.
    let views = c.replace("per = [\"scene\"]", "per = [\"view\"]");
    assert_eq!(eval(&views, &[r])[0].groups.len(), 3);
}

#[test]
fn every_test_kind_decides_counters() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    let f = "measure = \"interior_per_ray\"\nfilter = { ray_kind = \"primary\", scene = \"s2\", params = { k = 1 } }\nrows.a = { traversal = \"a\" }\nrows.b = { traversal = \"b\" }\n";
    let cases = [
        // gain = 100 (1 − 5/6) = 16.7 %
        (
            "test = { kind = \"gain\", of = \"a\", base = \"b\", min = 10, max = 20 }",
            Verdict::Agree,
        ),
        (
            "test = { kind = \"gain\", of = \"a\", base = \"b\", min = 20 }",
            Verdict::Disagree,
        ),
        (
            "test = { kind = \"speedup\", of = \"a\", base = \"b\", min = 1.2 }",
            Verdict::Agree,
        ),
        (
            "test = { kind = \"value\", of = \"a\", min = 5, max = 5 }",
            Verdict::Agree,
        ),
        (
            "test = { kind = \"order\", rows = [\"a\", \"b\"], strict = true }",
            Verdict::Agree,
        ),
        (
            "test = { kind = \"order\", rows = [\"b\", \"a\"] }",
            Verdict::Disagree,
        ),
        (
            "test = { kind = \"order\", rows = [\"a\", \"b\"], strict = true, margin = 0.2 }",
            Verdict::Disagree,
        ),
        (
            "test = { kind = \"least\", best = \"a\", of = [\"b\"] }",
            Verdict::Agree,
        ),
        (
            "test = { kind = \"least\", best = \"a\", of = [\"b\"], direction = \"highest\" }",
            Verdict::Disagree,
        ),
        (
            "test = { kind = \"equal\", a = \"a\", b = \"b\", tolerance = 0.2 }",
            Verdict::Agree,
        ),
        (
            "test = { kind = \"equal\", a = \"a\", b = \"b\", tolerance = 0.1 }",
            Verdict::Disagree,
        ),
    ];
    for (test, want) in cases {
        let v = eval(&claim(&format!("{f}{test}")), std::slice::from_ref(&r));
        assert_eq!(v[0].verdict, want, "{test}: {v:?}");
    }
}

/// Counters for the gap rule: in scene `s6`, `a` is 6 % below `b`; in `s2`, 2 % below.
fn gap_results(dir: &Path) -> PathBuf {
    let d = dir.join("gap");
    std::fs::create_dir_all(&d).unwrap();
    let r = |scene: &str, tr: &str, v: f64| {
        row(scene, tr, "k=1", "primary", 100, 10.0, 0.01, 9, false, v)
    };
    write(
        &d,
        "results.csv",
        &[
            HEAD.to_string(),
            r("s6", "a", 94.0),
            r("s6", "b", 100.0),
            r("s2", "a", 98.0),
            r("s2", "b", 100.0),
        ],
    );
    d
}

/// An ordering whose paper prints a gap holds by `GAP_SHARE` of it: with `gap = 0.1` (the
/// margin 5 %) `a` 6 % below `b` agrees and 2 % below disagrees, for `order` (strict without
/// saying so) and `least`, lowest and highest; without the gap both agree.
#[test]
fn an_ordering_holds_by_half_the_papers_gap() {
    assert_eq!(claims::GAP_SHARE, 0.5);
    let t = tempfile::tempdir().unwrap();
    let r = gap_results(t.path());
    let f = |scene: &str, test: &str| {
        claim(&format!(
            "measure = \"interior_per_ray\"\nfilter = {{ scene = \"{scene}\" }}\nrows.a = {{ traversal = \"a\" }}\nrows.b = {{ traversal = \"b\" }}\n{test}"
        ))
    };
    let order = "test = { kind = \"order\", rows = [\"a\", \"b\"], gap = 0.1 }";
    let least = "test = { kind = \"least\", best = \"a\", of = [\"b\"], gap = 0.1 }";
    let highest =
        "test = { kind = \"least\", best = \"b\", of = [\"a\"], direction = \"highest\", gap = 0.1 }";
    for test in [order, least, highest] {
        let six = eval(&f("s6", test), std::slice::from_ref(&r));
        assert_eq!(six[0].verdict, claims::Verdict::Agree, "{test}: {six:?}");
        assert!(six[0].why.contains("by 5 %"), "{}", six[0].why);
        let two = eval(&f("s2", test), std::slice::from_ref(&r));
        assert_eq!(two[0].verdict, claims::Verdict::Disagree, "{test}: {two:?}");
        // Without the paper's gap the 2 % passes.
        let bare = test.replace(", gap = 0.1", "");
        let two = eval(&f("s2", &bare), std::slice::from_ref(&r));
        assert_eq!(two[0].verdict, claims::Verdict::Agree, "{bare}: {two:?}");
    }
    // The margin is the one rule's: the test reads GAP_SHARE · gap.
    let file = claims::parse(Path::new("t.toml"), &f("s6", order)).unwrap();
    let t = &file.claims[0].test;
    assert!((t.margin() - claims::GAP_SHARE * 0.1).abs() < 1e-15 && t.is_strict());
}

/// A `gap` beside a `margin` is refused (the margin comes from the one rule), and so is a gap
/// that is not a relative one (0 < gap < 1); one line naming the file, the claim and the key.
#[test]
fn a_gap_with_a_margin_or_out_of_range_is_refused() {
    let body = |test: &str| {
        claim(&format!(
            "measure = \"interior_per_ray\"\nrows.a = {{ traversal = \"a\" }}\nrows.b = {{ traversal = \"b\" }}\n{test}"
        ))
    };
    let order = |extra: &str| {
        body(&format!(
            "test = {{ kind = \"order\", rows = [\"a\", \"b\"]{extra} }}"
        ))
    };
    let least = |extra: &str| {
        body(&format!(
            "test = {{ kind = \"least\", best = \"a\", of = [\"b\"]{extra} }}"
        ))
    };
    claims::parse(Path::new("x.toml"), &order(", gap = 0.5")).expect("a gap alone loads");
    claims::parse(Path::new("x.toml"), &order(", strict = true, margin = 0.2"))
        .expect("a margin alone loads");
    let cases = [
        (
            order(", strict = true, margin = 0.05, gap = 0.1"),
            "x.toml:3: claim c: test.gap: give gap or margin, not both",
        ),
        (
            least(", margin = 0, gap = 0.1"),
            "x.toml:3: claim c: test.gap: give gap or margin, not both",
        ),
        (
            order(", gap = 0"),
            "x.toml:3: claim c: test.gap: 0 is not a relative gap",
        ),
        (
            order(", gap = 1"),
            "x.toml:3: claim c: test.gap: 1 is not a relative gap",
        ),
        (
            least(", gap = -0.1"),
            "x.toml:3: claim c: test.gap: -0.1 is not a relative gap",
        ),
        (
            least(", gap = 12"),
            "x.toml:3: claim c: test.gap: 12 is not a relative gap",
        ),
    ];
    for (text, want) in cases {
        let e = claims::parse(Path::new("x.toml"), &text)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with(want), "{e}\nwanted: {want}");
        assert!(!e.contains('\n'), "{e}");
    }
}

#[test]
fn time_needs_a_clear_interval_and_quiet_rows() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    let time = "measure = \"time\"\nrows.a = { traversal = \"a\" }\nrows.b = { traversal = \"b\" }\ntest = { kind = \"speedup\", of = \"a\", base = \"b\", min = 1.05 }\n";
    // s1: 40 vs 80 ms, 1 % intervals: clearly 2x.
    let v = eval(
        &claim(&format!(
            "{time}filter = {{ scene = \"s1\", ray_kind = \"primary\", params = {{ k = 1 }} }}"
        )),
        std::slice::from_ref(&r),
    );
    assert_eq!(v[0].verdict, Verdict::Agree, "{v:?}");
    // s2: 10 vs 11 ms with ±30 %: the interval of 1.1 straddles 1.05.
    let v = eval(
        &claim(&format!(
            "{time}filter = {{ scene = \"s2\", ray_kind = \"primary\", params = {{ k = 1 }} }}"
        )),
        std::slice::from_ref(&r),
    );
    assert_eq!(v[0].verdict, Verdict::Inconclusive, "{v:?}");
    assert!(v[0].why.contains("straddles"), "{}", v[0].why);
    // Shadow rows are 3x apart but flagged noisy: never a verdict.
    let v = eval(
        &claim(&format!(
            "{time}filter = {{ scene = \"s2\", ray_kind = \"shadow\", params = {{ k = 1 }} }}"
        )),
        std::slice::from_ref(&r),
    );
    assert_eq!(v[0].verdict, Verdict::Inconclusive);
    assert!(v[0].why.contains("noisy"), "{}", v[0].why);
}

#[test]
fn too_few_runs_and_software_adapters_give_no_time_verdict() {
    let t = tempfile::tempdir().unwrap();
    let one_run = write(
        t.path(),
        "one.csv",
        &[
            HEAD.into(),
            row("s", "a", "k=1", "primary", 100, 10.0, 0.0, 1, false, 1.0),
            row("s", "b", "k=1", "primary", 100, 50.0, 0.0, 1, false, 1.0),
        ],
    );
    let c = claim("measure = \"time\"\nrows.a = { traversal = \"a\" }\nrows.b = { traversal = \"b\" }\ntest = { kind = \"speedup\", of = \"a\", base = \"b\", min = 1.5 }");
    let v = eval(&c, &[one_run]);
    assert_eq!(v[0].verdict, Verdict::Inconclusive);
    assert!(v[0].why.contains("fewer than 3 timed runs"), "{}", v[0].why);
    let gpu = |s: &str| {
        s.replacen(",cpu,,", ",gpu,llvmpipe (LLVM 15) / Vulkan,", 1)
            .replacen(",1,watertight", ",0,watertight", 1)
    };
    let lavapipe = write(
        t.path(),
        "gpu.csv",
        &[
            HEAD.into(),
            gpu(&row(
                "s", "a", "k=1", "primary", 100, 10.0, 0.01, 9, false, 1.0,
            )),
            gpu(&row(
                "s", "b", "k=1", "primary", 100, 50.0, 0.01, 9, false, 1.0,
            )),
        ],
    );
    let g = c.replace(
        "measure = \"time\"",
        "measure = \"time\"\ndevices = [\"gpu\"]",
    );
    let v = eval(&g, std::slice::from_ref(&lavapipe));
    assert_eq!(v[0].verdict, Verdict::Inconclusive);
    assert!(v[0].why.contains("software GPU adapter"), "{}", v[0].why);
    // Counters on the same rows are fine.
    let counters = g
        .replace("measure = \"time\"", "measure = \"interior_per_ray\"")
        .replace("min = 1.5", "min = 1");
    assert_eq!(eval(&counters, &[lavapipe])[0].verdict, Verdict::Agree);
}

#[test]
fn missing_and_ambiguous_rows_are_inconclusive_with_their_reason() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    let c = claim("measure = \"interior_per_ray\"\nfilter = { ray_kind = \"primary\" }\nrows.a = { traversal = \"a\", scene = \"s2\" }\nrows.b = { traversal = \"zzz\" }\ntest = { kind = \"ratio\", num = \"a\", den = \"b\", max = 1 }");
    let v = eval(&c, std::slice::from_ref(&r));
    assert_eq!(v[0].verdict, Verdict::Inconclusive);
    assert!(v[0].why.contains("no rows for `b`"), "{}", v[0].why);
    // `a` in s2 matches k=1 and k=2: ambiguous, named by the parameter that differs.
    let c = claim("measure = \"interior_per_ray\"\nfilter = { ray_kind = \"primary\", scene = \"s2\" }\nrows.a = { traversal = \"a\" }\ntest = { kind = \"value\", of = \"a\", min = 0 }");
    let v = eval(&c, std::slice::from_ref(&r));
    assert_eq!(v[0].verdict, Verdict::Inconclusive);
    assert!(
        v[0].why.contains("ambiguous selector `a`") && v[0].why.contains("k 1 / 2"),
        "{}",
        v[0].why
    );
    // A GPU evaluation of CPU rows: rows missing.
    let g = c.replace("measure", "devices = [\"gpu\"]\nmeasure");
    let v = eval(&g, &[r]);
    assert!(v[0].why.starts_with("rows missing"), "{}", v[0].why);
}

#[test]
fn per_build_measures_and_other_files() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    // Heap ratio 3000 / 1000 and a build_stats entry, once per build whatever the views.
    let c = claim("measure = \"heap_ratio\"\nfilter = { scene = \"s1\" }\nrows.a = { traversal = \"a\" }\ntest = { kind = \"value\", of = \"a\", min = 2.5, max = 3 }");
    assert_eq!(
        eval(&c, std::slice::from_ref(&r))[0].verdict,
        Verdict::Agree
    );
    let c = claim("measure = \"build:paper_bytes\"\nfilter = { scene = \"s1\" }\nrows.a = { traversal = \"a\" }\ntest = { kind = \"value\", of = \"a\", min = 64, max = 64 }");
    assert_eq!(
        eval(&c, std::slice::from_ref(&r))[0].verdict,
        Verdict::Agree
    );
    // A weights.csv beside the results: only claims that ask for its file see it.
    write(
        &r,
        "weights.csv",
        &[
            "table,heuristic,beta,patch,axis,weight_pct".into(),
            "1,sphere-orth,1,X,X,55.0443".into(),
            "2,cos-orth,3,X,X,54.0884".into(),
        ],
    );
    let c = claim("measure = \"weight_pct\"\nfilter = { file = \"weights\" }\nrows.w = { table = 2, beta = 3, axis = \"X\" }\ntest = { kind = \"value\", of = \"w\", min = 54.08, max = 54.09 }");
    assert_eq!(
        eval(&c, std::slice::from_ref(&r))[0].verdict,
        Verdict::Agree
    );
    let c = claim("measure = \"weight_pct\"\nrows.w = { table = 2 }\ntest = { kind = \"value\", of = \"w\", min = 0 }");
    assert_eq!(eval(&c, &[r])[0].verdict, Verdict::Inconclusive);
}

/// A reproduce or reference folder as committed (its rows in `runs/*/*`) is
/// read whole; a folder with CSVs of its own is not entered further.
#[test]
fn a_report_folder_is_read_from_its_runs() {
    let t = tempfile::tempdir().unwrap();
    let report = t.path().join("report");
    let run = results(&report.join("runs/paper"));
    std::fs::write(report.join("REPORT.md"), "# report\n").unwrap();
    let set = RowSet::read_results(std::slice::from_ref(&report)).unwrap();
    assert_eq!(set.rows.len(), 9);
    // The run folder's own rows only, not a nested copy under it.
    let nested = run.join("process-0");
    std::fs::create_dir_all(&nested).unwrap();
    std::fs::copy(run.join("results.csv"), nested.join("copy.csv")).unwrap();
    let set = RowSet::read(std::slice::from_ref(&run)).unwrap();
    assert_eq!((set.rows.len(), set.replaced), (9, 0));
    // An empty report folder is refused naming it.
    let empty = t.path().join("empty/runs/paper");
    std::fs::create_dir_all(&empty).unwrap();
    let e = RowSet::read(&[t.path().join("empty")])
        .unwrap_err()
        .to_string();
    assert!(e.contains("empty") && e.contains("no CSV file"), "{e}");
    // The committed reference folder REPRODUCTION.md's GPU columns come from.
    let reference =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../results/reference/2026-11-27-677306e");
    if reference.is_dir() {
        let set = RowSet::read_results(&[reference]).unwrap();
        assert!(set.rows.len() > 100, "{} rows", set.rows.len());
    }
}

#[test]
fn a_later_source_replaces_the_same_row() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    let newer = write(
        t.path(),
        "newer.csv",
        &[
            HEAD.into(),
            row("s2", "a", "k=1", "primary", 100, 10.0, 0.01, 9, false, 7.0),
        ],
    );
    let set = RowSet::read(&[r.clone(), newer]).unwrap();
    assert_eq!(set.replaced, 1);
    assert_eq!(set.rows.len(), 9);
}

#[test]
fn bad_files_name_the_line_and_key() {
    let e = claims::parse(
        Path::new("x.toml"),
        "paper = \"t\"\n[[claim]]\nid = \"a\"\nbogus = 1\n",
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("x.toml: 4: unknown field `bogus`"), "{e}");
    let bad = claim("measure = \"interior_per_ray\"\nrows.a = { traversal = \"a\" }\ntest = { kind = \"ratio\", num = \"a\", den = \"zz\", max = 1 }");
    let e = claims::parse(Path::new("x.toml"), &bad)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("x.toml:3: claim c: test: names rows `zz`"),
        "{e}"
    );
    let bad = claim("measure = \"interior per ray\"\nrows.a = { traversal = \"a\" }\ntest = { kind = \"value\", of = \"a\", min = 1 }");
    let e = claims::parse(Path::new("x.toml"), &bad)
        .unwrap_err()
        .to_string();
    assert!(e.contains("claim c: measure:"), "{e}");
    let bad = claim("measure = \"interior_per_ray\"\nrows.a = { traversal = \"a\" }\ntest = { kind = \"value\", of = \"a\" }");
    let e = claims::parse(Path::new("x.toml"), &bad)
        .unwrap_err()
        .to_string();
    assert!(e.contains("give min, max or both"), "{e}");
}

/// A claim's note reads its own note, then the shared notes it names, in its order; a name
/// missing from `[notes]` is an error naming the claim's line; the project's files keep no
/// note pasted into three claims or more.
#[test]
fn shared_notes_are_written_once() {
    let test = "measure = \"interior_per_ray\"\nrows.a = { traversal = \"a\" }\ntest = { kind = \"value\", of = \"a\", min = 1 }";
    let text = format!(
        "{BASE}[notes]\nx = \"shared x\"\ny = \"shared y\"\n[[claim]]\nid = \"c\"\nwhere = \"T1\"\ntext = \"t\"\npaper = \"p\"\nnote = \"own\"\nnotes = [\"y\", \"x\"]\n{test}\n[[claim]]\nid = \"d\"\nwhere = \"T1\"\ntext = \"t\"\npaper = \"p\"\nnotes = [\"x\"]\n{test}\n"
    );
    let f = claims::parse(Path::new("x.toml"), &text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(f.claims[0].note.as_deref(), Some("own; shared y; shared x"));
    assert_eq!(f.claims[1].note.as_deref(), Some("shared x"));
    let bad = claim(&format!("notes = [\"z\"]\n{test}"));
    let e = claims::parse(Path::new("x.toml"), &bad)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("x.toml:3: claim c: notes: no shared note `z`"),
        "{e}"
    );
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../claims");
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "toml") {
            continue;
        }
        let text = std::fs::read_to_string(&p).unwrap();
        let mut seen = std::collections::BTreeMap::<&str, usize>::new();
        for line in text.lines().filter(|l| l.starts_with("note = ")) {
            *seen.entry(line).or_default() += 1;
        }
        for (line, n) in seen {
            assert!(
                n < 3,
                "{}: {n} claims paste {line}: write it once in [notes]",
                p.display()
            );
        }
    }
}

/// Every claims file of the project parses and checks, and so do its deviations.
#[test]
fn the_projects_claims_files_load() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../claims");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            let f = claims::load(&p).unwrap_or_else(|e| panic!("{e}"));
            assert!(!f.claims.is_empty(), "{}: no claims", p.display());
            // Its deviations (claims/deviations/STEM.toml) name only claims it has.
            claims::deviations::load(&p, &f).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(n >= 1);
}

/// Rows timed interleaved pair round by round: a steady 2x ratio under a drift that moves
/// both rows' medians is decided even on rows flagged noisy, while the same times without
/// `timing_group` (timed apart) are not.
#[test]
fn interleaved_rows_pair_round_by_round() {
    let t = tempfile::tempdir().unwrap();
    let head = "scene,structure,params,traversal,device,adapter,threads,triangle_test,ray_kind,rays,trace_ms_min,trace_ms_median,trace_ms_max,timed_runs,trace_ms_ci,noisy,trace_ms_runs,timing_group";
    // Rounds drift from 10 to 40 ms; b takes exactly twice a's time in each round.
    let a: Vec<f64> = (0..9).map(|k| 10.0 + 4.0 * k as f64).collect();
    let line = |tr: &str, runs: &[f64], group: &str| {
        let joined: Vec<String> = runs.iter().map(|x| x.to_string()).collect();
        format!(
            "s,kdtree,k=1,{tr},cpu,,1,watertight,primary,100,{},{},{},9,0.4,true,{},{group}",
            runs[0],
            runs[4],
            runs[8],
            joined.join(";")
        )
    };
    let b: Vec<f64> = a.iter().map(|x| 2.0 * x).collect();
    let together = write(
        t.path(),
        "together.csv",
        &[head.into(), line("a", &a, "s-1-0"), line("b", &b, "s-1-0")],
    );
    let apart = write(
        t.path(),
        "apart.csv",
        &[head.into(), line("a", &a, ""), line("b", &b, "")],
    );
    let c = claim("measure = \"time\"\nrows.a = { traversal = \"a\" }\nrows.b = { traversal = \"b\" }\ntest = { kind = \"speedup\", of = \"a\", base = \"b\", min = 1.6, max = 2.5 }");
    let v = eval(&c, &[together]);
    assert_eq!(v[0].verdict, Verdict::Agree, "{v:?}");
    assert!(v[0].why.contains("round by round"), "{}", v[0].why);
    // The exact round-by-round 2x, widened to the floor between runs (±20 %).
    let d = v[0].groups[0].derived.unwrap();
    assert!(
        (d[0] - 2.0 / 1.2).abs() < 1e-12 && d[1] == 2.0 && (d[2] - 2.4).abs() < 1e-12,
        "{d:?}"
    );
    let v = eval(&c, &[apart]);
    assert_eq!(v[0].verdict, Verdict::Inconclusive, "{v:?}");
}

/// A skipped batch (no rays, empty counters) adds nothing to a pool and does not spoil it.
#[test]
fn batches_without_rays_are_left_out() {
    let t = tempfile::tempdir().unwrap();
    let mut lines = vec![
        HEAD.to_string(),
        row("s", "a", "k=1", "primary", 100, 10.0, 0.01, 9, false, 2.0),
    ];
    lines.push(
        row("s", "a", "k=1", "path2", 0, 10.0, 0.01, 9, false, 0.0)
            .replace(",false,0,3000", ",false,,3000"),
    );
    let f = write(t.path(), "r.csv", &lines);
    let c = claim("measure = \"interior_per_ray\"\nrows.a = { traversal = \"a\" }\ntest = { kind = \"value\", of = \"a\", min = 2, max = 2 }");
    let v = eval(&c, &[f]);
    assert_eq!(v[0].verdict, Verdict::Agree, "{v:?}");
}

/// Build times are timings: the range of three builds or more is their interval, and one build
/// gives none.
#[test]
fn build_times_need_three_builds() {
    let t = tempfile::tempdir().unwrap();
    let head = "scene,structure,params,traversal,device,threads,triangle_test,ray_kind,rays,build_ms,build_ms_runs";
    let f = write(
        t.path(),
        "b.csv",
        &[
            head.into(),
            "s,a,k=1,x,cpu,1,watertight,primary,10,100,50;100;150".into(),
            "s,a,k=1,x,cpu,1,watertight,shadow,10,100,50;100;150".into(),
            "s,b,k=1,x,cpu,1,watertight,primary,10,300,290;300;310".into(),
            "s,c,k=1,x,cpu,1,watertight,primary,10,300,300".into(),
        ],
    );
    let c = |other: &str| {
        claim(&format!("measure = \"build_ms\"\nrows.a = {{ structure = \"a\" }}\nrows.o = {{ structure = \"{other}\" }}\ntest = {{ kind = \"speedup\", of = \"a\", base = \"o\", min = 1.5 }}"))
    };
    let v = eval(&c("b"), std::slice::from_ref(&f));
    assert_eq!(v[0].verdict, Verdict::Agree, "{v:?}");
    // 290 / 150 .. 310 / 50: the interval is the builds' range (wider than the floor).
    let d = v[0].groups[0].derived.unwrap();
    assert!(
        (d[0] - 290.0 / 150.0).abs() < 1e-9 && (d[2] - 310.0 / 50.0).abs() < 1e-9,
        "{d:?}"
    );
    let v = eval(&c("c"), &[f]);
    assert_eq!(v[0].verdict, Verdict::Inconclusive, "{v:?}");
}

/// Columns computed from time (the dynamic table's samples per pixel) get the floor between
/// runs: a 10 % lead is not decided, a 2x one is.
#[test]
fn time_derived_columns_get_the_floor() {
    let t = tempfile::tempdir().unwrap();
    let f = write(
        t.path(),
        "dynamic.csv",
        &[
            "scene,structure,params,budget_ms,frame,spp".into(),
            "s,a,k=1,100,0,11".into(),
            "s,b,k=1,100,0,10".into(),
            "s,c,k=1,100,0,22".into(),
        ],
    );
    let c = |other: &str| {
        claim(&format!("measure = \"spp\"\nfilter = {{ file = \"dynamic\" }}\nrows.x = {{ structure = \"{other}\" }}\nrows.b = {{ structure = \"b\" }}\ntest = {{ kind = \"order\", rows = [\"b\", \"x\"], strict = true }}"))
    };
    assert_eq!(
        eval(&c("a"), std::slice::from_ref(&f))[0].verdict,
        Verdict::Inconclusive
    );
    assert_eq!(eval(&c("c"), &[f])[0].verdict, Verdict::Agree);
}

/// A `build_stats` entry in milliseconds (the R-tree's `insert_ms`) is a timing too: a 10 %
/// lead is not decided, a 2x one is; a counter entry (`splits`) is decided on any gap.
#[test]
fn build_stats_timings_get_the_floor() {
    let t = tempfile::tempdir().unwrap();
    let f = write(
        t.path(),
        "b.csv",
        &[
            "scene,structure,params,traversal,device,threads,triangle_test,ray_kind,rays,build_stats".into(),
            "s,a,k=1,x,cpu,1,watertight,primary,10,insert_ms=110;splits=11".into(),
            "s,b,k=1,x,cpu,1,watertight,primary,10,insert_ms=100;splits=10".into(),
            "s,c,k=1,x,cpu,1,watertight,primary,10,insert_ms=220;splits=22".into(),
        ],
    );
    let c = |key: &str, other: &str| {
        claim(&format!("measure = \"build:{key}\"\nrows.x = {{ structure = \"{other}\" }}\nrows.b = {{ structure = \"b\" }}\ntest = {{ kind = \"order\", rows = [\"b\", \"x\"], strict = true }}"))
    };
    let v = |key: &str, other: &str| eval(&c(key, other), std::slice::from_ref(&f))[0].verdict;
    assert_eq!(v("insert_ms", "a"), Verdict::Inconclusive);
    assert_eq!(v("insert_ms", "c"), Verdict::Agree);
    assert_eq!(v("splits", "a"), Verdict::Agree);
}

/// A value the filter names for a `per` key without rows is a group of its own, inconclusive
/// and named: the claim does not agree on the groups that happen to be there.
#[test]
fn a_filtered_value_without_rows_is_an_inconclusive_group() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    let body = "measure = \"interior_per_ray\"\nfilter = { ray_kind = \"primary\", params = { k = 1 }, scene = [\"s1\", \"s2\"] }\nper = [\"scene\"]\nrows.a = { traversal = \"a\" }\nrows.b = { traversal = \"b\" }\ntest = { kind = \"order\", rows = [\"a\", \"b\"] }";
    let all = eval(&claim(body), std::slice::from_ref(&r));
    assert_eq!(all[0].verdict, Verdict::Agree, "{all:?}");
    assert_eq!(all[0].groups.len(), 2);
    let missing = body.replace("\"s2\"]", "\"s2\", \"conference\"]");
    let v = eval(&claim(&missing), std::slice::from_ref(&r));
    assert_eq!(v[0].verdict, Verdict::Inconclusive, "{v:?}");
    assert_eq!(v[0].groups.len(), 3);
    assert!(
        v[0].why
            .contains("rows missing: no rows for scene = conference"),
        "{}",
        v[0].why
    );
    // `most` counts the missing group too (2 of 3 agree), `any` is met by one group.
    let most = missing.replace("per = [\"scene\"]", "per = [\"scene\"]\nneed = \"most\"");
    assert_eq!(
        eval(&claim(&most), std::slice::from_ref(&r))[0].verdict,
        Verdict::Agree
    );
    // With two group keys the missing value stands with `*` for the other; a glob names no
    // particular value.
    let two = missing.replace("per = [\"scene\"]", "per = [\"scene\", \"ray_kind\"]");
    let v = eval(&claim(&two), std::slice::from_ref(&r));
    assert_eq!(v[0].verdict, Verdict::Inconclusive);
    assert!(
        v[0].groups.iter().any(|g| g.group == "conference · *"),
        "{v:?}"
    );
    let glob = body.replace("\"s2\"]", "\"s2\", \"conf*\"]");
    assert_eq!(eval(&claim(&glob), &[r])[0].verdict, Verdict::Agree);
}

/// Typos in a claims file are refused at load, one line naming the file, the claim and the
/// key: an unknown measure, an unknown selector, filter or group key, a text value for a
/// numeric column.
#[test]
fn typos_are_refused_at_load() {
    let ok = "measure = \"interior_per_ray\"\nfilter = { ray_kind = \"primary\", threads = [1, 2] }\nrows.a = { traversal = \"a\" }\ntest = { kind = \"value\", of = \"a\", min = 1 }";
    claims::parse(Path::new("x.toml"), &claim(ok)).expect("the correct claim loads");
    let cases = [
        (
            ok.replace("interior_per_ray", "bogus_per_ray"),
            "x.toml:3: claim c: measure: `bogus_per_ray` is not a column",
        ),
        (
            ok.replace("interior_per_ray", "prims_per_ray + bogus_per_ray"),
            "x.toml:3: claim c: measure: `bogus_per_ray` is not a column",
        ),
        (
            ok.replace("interior_per_ray", "structure"),
            "x.toml:3: claim c: measure: `structure` is not a numeric column",
        ),
        (
            ok.replace("{ traversal", "{ structur = \"kdtree\", traversal"),
            "x.toml:3: claim c: rows.a: unknown field `structur`",
        ),
        (
            ok.replace("ray_kind", "raykind"),
            "x.toml:3: claim c: filter: unknown field `raykind`",
        ),
        (
            ok.replace("[1, 2]", "\"many\""),
            "x.toml:3: claim c: filter: threads: \"many\" is not a whole number at least 0",
        ),
        (
            ok.replace("[1, 2]", "[1, \"two\"]"),
            "x.toml:3: claim c: filter: threads: \"two\" is not a whole number at least 0",
        ),
        // Values no row can hold are refused, not inconclusive for ever.
        (
            ok.replace("[1, 2]", "-1"),
            "x.toml:3: claim c: filter: threads: -1 is not a whole number at least 0",
        ),
        (
            ok.replace("[1, 2]", "1.5"),
            "x.toml:3: claim c: filter: threads: 1.5 is not a whole number at least 0",
        ),
        (
            ok.replace("filter", "devices = [\"tpu\"]\nfilter"),
            "x.toml:3: claim c: devices: unknown device `tpu` (known: cpu, gpu)",
        ),
        (
            ok.replace("min = 1", "min = nan"),
            "x.toml:10: claim.test.min: NaN is not a finite number",
        ),
        (
            ok.replace("filter", "per = [\"scen\"]\nfilter"),
            "x.toml:3: claim c: per: unknown group key `scen`",
        ),
    ];
    for (body, want) in cases {
        let e = claims::parse(Path::new("x.toml"), &claim(&body))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with(want), "{e}\nwanted: {want}");
        assert!(!e.contains('\n'), "{e}");
    }
    // The near column is named; columns of the other CSVs (dynamic, weights), counter
    // columns, quoted numbers and free-form params are fine.
    let e = claims::parse(
        Path::new("x.toml"),
        &claim(&ok.replace("ray_kind", "raykind")),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("did you mean `ray_kind`?"), "{e}");
    let fine = ok
        .replace("interior_per_ray", "boxes_max + spp + weight_pct")
        .replace(
            "threads = [1, 2]",
            "beta = \"1\", budget_ms = [16, 33], noisy = false, params = { anything = 1 }",
        )
        .replace(
            "min = 1 }",
            "min = 1 }\nper = [\"param:whatever\", \"lambda_1\"]",
        );
    claims::parse(Path::new("x.toml"), &claim(&fine)).expect("known columns load");
}

/// Rows of one group from sources made with different configs (another image size: another
/// ray count for the same view and ray kind) are not pooled into a verdict.
#[test]
fn rows_of_different_configs_are_not_pooled() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    let c = claim("measure = \"interior_per_ray\"\nfilter = { ray_kind = \"primary\", scene = \"s2\", params = { k = 1 } }\nrows.a = { traversal = \"a\" }\nrows.b = { traversal = \"b\" }\ntest = { kind = \"ratio\", num = \"a\", den = \"b\", max = 0.9 }");
    let other = |rays: u32| {
        write(
            t.path(),
            &format!("other-{rays}.csv"),
            &[
                HEAD.into(),
                row("s2", "b", "k=1", "primary", rays, 11.0, 0.3, 9, false, 6.0),
            ],
        )
    };
    // The same config elsewhere: the verdict it gives alone.
    let same = eval(&c, &[r.clone(), other(100)]);
    assert_eq!(same[0].verdict, Verdict::Agree, "{same:?}");
    let mixed = eval(&c, &[r, other(10)]);
    assert_eq!(mixed[0].verdict, Verdict::Inconclusive, "{mixed:?}");
    assert!(
        mixed[0]
            .why
            .contains("rows of different configs pooled: s2 primary has 100 rays in")
            && mixed[0].why.contains("other-10.csv"),
        "{}",
        mixed[0].why
    );
}

/// Three claims of each kind on the same rows: only `claim`s are tallied; observations and
/// invariants are counted and shown apart (text, Markdown, JSON, REPRODUCTION.md), and a claim
/// without a `kind` is a `claim`.
#[test]
fn kinds_are_shown_apart_and_only_claims_tallied() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    let one = |id: &str, kind: &str, max: f64| {
        format!(
            "[[claim]]\nid = \"{id}\"\n{kind}where = \"T1\"\ntext = \"t\"\npaper = \"p\"\nmeasure = \"interior_per_ray\"\nfilter = {{ ray_kind = \"primary\", params = {{ k = 1 }}, scene = \"s1\" }}\nrows.a = {{ traversal = \"a\" }}\nrows.b = {{ traversal = \"b\" }}\ntest = {{ kind = \"ratio\", num = \"a\", den = \"b\", max = {max} }}\n"
        )
    };
    // s1: a / b = 0.875.
    let text = format!(
        "{BASE}{}{}{}{}",
        one("plain", "", 0.9),
        one("stated", "kind = \"claim\"\n", 0.5),
        one("tried", "kind = \"observation\"\n", 0.5),
        one("built", "kind = \"invariant\"\n", 0.9)
    );
    let v = eval(&text, &[r]);
    let kind = |id: &str| v.iter().find(|c| c.id == id).unwrap().kind;
    assert_eq!(kind("plain"), claims::ClaimKind::Claim);
    assert_eq!(kind("tried"), claims::ClaimKind::Observation);
    assert_eq!(kind("built"), claims::ClaimKind::Invariant);
    let tally = claims::render::Tally::of(&v);
    assert_eq!((tally.agree, tally.disagree, tally.inconclusive), (1, 1, 0));
    let k = claims::render::Kinds::of(&v);
    assert_eq!((k.observations.disagree, k.observations.total()), (1, 1));
    assert_eq!((k.invariants.agree, k.invariants.total()), (1, 1));
    // Markdown: the claims' table and tally, then each kind under its own heading and count.
    let md = claims::render::markdown(&v);
    let at = |s: &str| md.find(s).unwrap_or_else(|| panic!("{s} not in {md}"));
    assert!(at("| `plain` |") < at("1 agree, 1 disagree, 0 inconclusive"));
    assert!(at("1 agree, 1 disagree, 0 inconclusive") < at("**Observations**"));
    assert!(at("**Observations**") < at("| `tried` |"));
    assert!(at("| `tried` |") < at("Observations (not tallied, 1): 0 agree, 1 disagree"));
    assert!(at("**Invariants**") < at("| `built` |"));
    let txt = claims::render::text(&v, 120);
    assert!(
        txt.contains("Observations (not tallied")
            && txt.contains("Invariants (not tallied, 1): 1 agree"),
        "{txt}"
    );
    // JSON carries each result's kind, the claims' tally and every kind's counts.
    let j = claims::render::json("t", &[], &v);
    assert_eq!(j["tally"]["agree"], 1);
    assert_eq!(j["kinds"]["observations"]["disagree"], 1);
    assert_eq!(j["claims"][2]["kind"], "observation");
    // REPRODUCTION.md: observations and invariants in their own sections after the claims.
    let report = claims::reproduce::PaperReport {
        key: "t".into(),
        paper: "A paper".into(),
        runs: Vec::new(),
        tally,
        kinds: k,
        claims: v.clone(),
        deviations: Vec::new(),
        adapters: Vec::new(),
        figures: Vec::new(),
    };
    let repro = claims::reproduce::reproduction(&[report], "");
    let at = |s: &str| {
        repro
            .find(s)
            .unwrap_or_else(|| panic!("{s} not in {repro}"))
    };
    assert!(repro.contains("claims 1 agree, 1 disagree, 0 inconclusive; observations (not tallied) 0 agree, 1 disagree"));
    assert!(at("| [`stated`]") < at("### Observations"));
    assert!(at("### Observations") < at("| [`tried`]"));
    assert!(at("| [`tried`]") < at("### Invariants"));
    assert!(at("### Invariants") < at("| [`built`]"));
    // The reasons keep the kinds apart too, after every short table and before the deviations.
    assert!(at("| [`built`]") < at("## Reasons"));
    assert!(at("## Reasons") < at("#### Observations"));
    assert!(at("#### Observations") < at("`tried` |"));
    assert!(at("#### Invariants") < at("## Deviations"));
}

/// REPRODUCTION.md opens each paper with a short table (claim, the paper's figure, ours,
/// verdict) and keeps the long reasons below: the claim's `paper_figure` where given, else its
/// `paper` shortened; an ordering's intervals reduced to its relations; each id linking to its
/// reasons, where the full `paper`, the measured why and the note stand.
#[test]
fn short_tables_open_each_paper_and_the_reasons_follow() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    let long = "a 10 / 20 / 30 ms vs b 20 / 40 / 60 ms (s1 views one and two; s2 not printed); a long printed figure";
    let text = format!(
        "{BASE}[[claim]]\nid = \"figured\"\nwhere = \"Table 9\"\ntext = \"t\"\npaper = \"{long}\"\npaper_figure = \"10 vs 20 ms\"\nnote = \"the note\"\nmeasure = \"time\"\nfilter = {{ ray_kind = \"primary\", params = {{ k = 1 }}, scene = \"s1\" }}\nrows.first_traversal = {{ traversal = \"a\" }}\nrows.second_traversal = {{ traversal = \"b\" }}\ntest = {{ kind = \"order\", rows = [\"first_traversal\", \"second_traversal\"], strict = true }}\n\
         [[claim]]\nid = \"cut\"\nwhere = \"Table 9\"\ntext = \"t\"\npaper = \"{long}\"\nmeasure = \"interior_per_ray\"\nfilter = {{ ray_kind = \"primary\", params = {{ k = 1 }}, scene = \"s1\" }}\nrows.a = {{ traversal = \"a\" }}\nrows.b = {{ traversal = \"b\" }}\ntest = {{ kind = \"ratio\", num = \"a\", den = \"b\", max = 0.9 }}\n"
    );
    let v = eval(&text, &[r]);
    assert_eq!(v[0].paper_figure.as_deref(), Some("10 vs 20 ms"));
    // The ordering's full `ours` (values with intervals) is long; the short cell its relation.
    assert!(v[0].ours.len() > claims::render::SHORT, "{}", v[0].ours);
    assert_eq!(
        claims::render::short_ours(&v[0]),
        "first_traversal < second_traversal"
    );
    assert_eq!(
        claims::render::short_paper(&v[1]),
        "a 10 / 20 / 30 ms vs b 20 / 40 / 60 ms …"
    );
    let report = claims::reproduce::PaperReport {
        key: "t".into(),
        paper: "A paper".into(),
        runs: Vec::new(),
        tally: claims::render::Tally::of(&v),
        kinds: claims::render::Kinds::of(&v),
        claims: v.clone(),
        deviations: Vec::new(),
        adapters: Vec::new(),
        figures: Vec::new(),
    };
    let repro = claims::reproduce::reproduction(&[report], "");
    let at = |s: &str| {
        repro
            .find(s)
            .unwrap_or_else(|| panic!("{s} not in {repro}"))
    };
    assert!(repro.contains(
        "| [`figured`](#r-t-figured) | 10 vs 20 ms | first_traversal < second_traversal | agree |  |  |"
    ));
    assert!(repro.contains(
        "| [`cut`](#r-t-cut) | a 10 / 20 / 30 ms vs b 20 / 40 / 60 ms … | 0.875 | agree |"
    ));
    // The long texts only below the short tables.
    let reasons = at("## Reasons");
    assert!(at("<a id=\"r-t-figured\"></a>") > reasons);
    assert!(at(long) > reasons);
    assert!(at("note: the note") > reasons);
    assert!(at("in order (2 rows)") > reasons);
}

/// Every timed group states the smallest effect its intervals decide (the relative half-width
/// of the compared interval, here the floor's ±20 %), the claim beside the effect its band asks
/// for; REPORT.md's list takes the claims asking for less, with the processes that would decide
/// them, and leaves counters and wide bands out.
#[test]
fn timed_claims_state_the_smallest_effect_they_decide() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    // s1: speedup of a over b 2 (80 / 40 ms, ±1 %), widened to [1.67, 2.4] by the ±20 % floor.
    let c = |id: &str, measure: &str, test: &str| {
        format!(
            "[[claim]]\nid = \"{id}\"\nwhere = \"T1\"\ntext = \"t\"\npaper = \"1.8\"\nmeasure = \"{measure}\"\nfilter = {{ ray_kind = \"primary\", params = {{ k = 1 }}, scene = \"s1\" }}\nrows.a = {{ traversal = \"a\" }}\nrows.b = {{ traversal = \"b\" }}\ntest = {test}\n"
        )
    };
    let speedup =
        |band: &str| format!("{{ kind = \"speedup\", of = \"a\", base = \"b\", {band} }}");
    let text = format!(
        "{BASE}{}{}{}{}",
        c("narrow", "time", &speedup("min = 1.7, max = 2.0")),
        c("wide", "time", &speedup("min = 1.5, max = 2.2")),
        c(
            "direction",
            "time",
            "{ kind = \"order\", rows = [\"a\", \"b\"], strict = true }"
        ),
        c(
            "counter",
            "interior_per_ray",
            &speedup("min = 1.7, max = 2.0")
        ),
    );
    let v = eval(&text, &[r]);
    let get = |id: &str| v.iter().find(|c| c.id == id).unwrap();
    let e = get("narrow").effect.clone().expect("timed");
    assert!((e.smallest - 0.2).abs() < 1e-9, "{e:?}");
    let g = get("narrow").groups[0].effect.clone().expect("timed group");
    assert!((g.smallest - 0.2).abs() < 1e-9 && g.processes == 1, "{g:?}");
    // The band [1.7, 2.0] asks for ±8.5 %: below ±20 %, (ln 1.2 / ln 1.0847)² = 5.03 → 6.
    assert!((e.paper - ((2.0f64 / 1.7).sqrt() - 1.0)).abs() < 1e-12 && e.paper_from == "band");
    assert!(e.below());
    assert_eq!(e.processes_for_paper, Some(6));
    assert!(
        get("narrow")
            .why
            .contains("smallest decidable effect ±20 % (1 process)")
            && get("narrow").why.contains("6 processes would decide it"),
        "{}",
        get("narrow").why
    );
    // [1.5, 2.2] asks for ±21 %: decidable.
    assert!(!get("wide").effect.as_ref().unwrap().below());
    // An ordering asks for a direction only: listed, decided where our value clears 1 (2x).
    let d = get("direction").effect.clone().unwrap();
    assert_eq!(
        (d.paper, d.paper_from, d.processes_for_paper),
        (0.0, "direction", None)
    );
    // Counters have no interval to speak of.
    assert!(get("counter").effect.is_none());
    // verdicts.json carries the effects.
    let j = claims::render::json("t", &[], &v);
    assert_eq!(j["claims"][0]["effect"]["paper_from"], "band");
    assert!(j["claims"][0]["groups"][0]["effect"]["smallest"]
        .as_f64()
        .is_some());
    let report = claims::reproduce::PaperReport {
        key: "t".into(),
        paper: "A paper".into(),
        runs: Vec::new(),
        tally: claims::render::Tally::of(&v),
        kinds: claims::render::Kinds::of(&v),
        claims: v.clone(),
        deviations: Vec::new(),
        adapters: Vec::new(),
        figures: Vec::new(),
    };
    let md = claims::reproduce::below_markdown(&[report]);
    assert!(md.contains("1/√processes"), "{md}");
    assert!(
        md.contains("| `narrow` | *undecidable* | ±8.5 % (band) | ±20 % (1 process) | 6 |"),
        "{md}"
    );
    assert!(
        md.contains("| `direction` | agree | a direction (paper: 1.8) |"),
        "{md}"
    );
    assert!(!md.contains("`wide`") && !md.contains("`counter`"), "{md}");
}

/// A time band narrower than the floor between runs can never hold a time's interval: the
/// claim reads `undecidable` (with the reason) where it would read `inconclusive`, and is not
/// counted among the inconclusive; a band as wide as the floor stays decidable, a result
/// clearly outside the band still disagrees, and a claim may give its own reason.
#[test]
fn a_claim_undecidable_by_construction_says_so() {
    let t = tempfile::tempdir().unwrap();
    let r = results(t.path());
    // s1: speedup of a over b 2 (80 / 40 ms, ±1 %), widened to [1.67, 2.4] by the ±20 % floor.
    let c = |band: &str| {
        claim(&format!(
            "measure = \"time\"\nfilter = {{ ray_kind = \"primary\", params = {{ k = 1 }}, scene = \"s1\" }}\nrows.a = {{ traversal = \"a\" }}\nrows.b = {{ traversal = \"b\" }}\ntest = {{ kind = \"speedup\", of = \"a\", base = \"b\", {band} }}"
        ))
    };
    // [1.7, 2.0] spans a factor 1.18 < 1.2²: undecidable, whatever the rows.
    let v = eval(&c("min = 1.7, max = 2.0"), std::slice::from_ref(&r));
    assert_eq!(v[0].verdict, Verdict::Undecidable, "{v:?}");
    assert!(
        v[0].why.starts_with("undecidable: the band [1.7, 2]"),
        "{}",
        v[0].why
    );
    assert!(v[0].undecidable.is_some());
    let tally = claims::render::Tally::of(&v);
    assert_eq!((tally.inconclusive, tally.undecidable), (0, 1));
    assert!(claims::render::markdown(&v).contains("*undecidable*"));
    assert!(tally.to_string().ends_with(", 1 undecidable"));
    // [1.5, 2.2] spans 1.47 >= 1.44: decidable, and this interval straddles 2.2.
    let v = eval(&c("min = 1.5, max = 2.2"), std::slice::from_ref(&r));
    assert_eq!(v[0].verdict, Verdict::Inconclusive, "{v:?}");
    assert!(v[0].undecidable.is_none());
    // Below the band by more than the floor: a verdict all the same.
    let v = eval(&c("min = 1.021, max = 1.206"), std::slice::from_ref(&r));
    assert_eq!(v[0].verdict, Verdict::Disagree, "{v:?}");
    assert!(
        v[0].why.contains("; undecidable by construction: the band"),
        "{}",
        v[0].why
    );
    // The floor decides: at ±5 % the same band [1.7, 2.0] can hold an interval.
    let file = claims::parse(Path::new("t.toml"), &c("min = 1.7, max = 2.0")).unwrap();
    let rows = RowSet::read(std::slice::from_ref(&r)).unwrap();
    let v = claims::evaluate_with(
        &file,
        &rows,
        &claims::Options {
            time_floor: 0.05,
            ..Default::default()
        },
    );
    assert_eq!(v[0].verdict, Verdict::Inconclusive, "{v:?}");
    // Counters have no floor: the same band on a counter is decided.
    let counter = c("min = 1.7, max = 2.0").replace("\"time\"", "\"interior_per_ray\"");
    assert_ne!(
        eval(&counter, std::slice::from_ref(&r))[0].verdict,
        Verdict::Undecidable
    );
    // A reason given in the file: a GPU claim no GPU row can decide.
    let gpu = claim(
        "undecidable = \"no GPU kernel\"\ndevices = [\"gpu\"]\nmeasure = \"time\"\nrows.a = { traversal = \"a\" }\ntest = { kind = \"value\", of = \"a\", min = 0 }",
    );
    let v = eval(&gpu, &[r]);
    assert_eq!(v[0].verdict, Verdict::Undecidable, "{v:?}");
    assert!(
        v[0].why.starts_with("undecidable: no GPU kernel"),
        "{}",
        v[0].why
    );
}

/// A deviation names the claims it touches (ids, globs, `measure:`, `device:`): each must name
/// a claim of the paper's file, or the file is refused with the line and the name.
#[test]
fn a_deviation_naming_an_unknown_claim_is_refused() {
    let text = format!(
        "{BASE}[[claim]]\nid = \"fast\"\nwhere = \"T1\"\ntext = \"t\"\npaper = \"p\"\nmeasure = \"time\"\nrows.a = {{ traversal = \"a\" }}\ntest = {{ kind = \"value\", of = \"a\", min = 0 }}\n[[claim]]\nid = \"few\"\nwhere = \"T1\"\ntext = \"t\"\npaper = \"p\"\ndevices = [\"gpu\"]\nmeasure = \"interior_per_ray\"\nrows.a = {{ traversal = \"a\" }}\ntest = {{ kind = \"value\", of = \"a\", min = 0 }}\n"
    );
    let file = claims::parse(Path::new("claims/t.toml"), &text).unwrap();
    let dev = |claims: &str| {
        format!("[[deviation]]\nkind = \"view\"\nwhat = \"w\"\nwhy = \"y\"\nclaims = [\"fast\"]\n\n[[deviation]]\nkind = \"hardware\"\nwhat = \"our GPU\"\nwhy = \"the only one\"\nclaims = {claims}\n")
    };
    let p = Path::new("claims/deviations/t.toml");
    assert_eq!(claims::deviations::path_for(Path::new("claims/t.toml")), p);
    let ok =
        claims::deviations::parse(p, &dev("[\"device:gpu\", \"measure:time\", \"f*\"]"), &file)
            .unwrap();
    assert_eq!(ok[1].ids, ["fast", "few"]);
    // `&` joins patterns: claims matching all of them.
    let both = claims::deviations::parse(
        p,
        &dev("[\"measure:interior_per_ray & device:gpu\"]"),
        &file,
    )
    .unwrap();
    assert_eq!(both[1].ids, ["few"]);
    assert!(claims::deviations::parse(p, &dev("[\"measure:time & device:gpu\"]"), &file).is_err());
    assert!(claims::deviations::markdown(&ok).contains("| hardware | our GPU | the only one |"));
    for bad in [
        "[\"fats\"]",
        "[\"x*\"]",
        "[\"measure:steps_per_ray\"]",
        "[\"device:tpu\"]",
        "[]",
    ] {
        let e = claims::deviations::parse(p, &dev(bad), &file)
            .err()
            .unwrap_or_else(|| panic!("{bad} accepted"))
            .to_string();
        assert!(
            e.contains("claims/deviations/t.toml:7") && e.contains("deviation[1].claims"),
            "{e}"
        );
        if bad != "[]" {
            assert!(e.contains(&bad[2..bad.len() - 2]), "{e}");
        }
    }
    // Unknown keys and kinds are refused too.
    assert!(claims::deviations::parse(
        p,
        &dev("[\"fast\"]").replace("kind = \"view\"", "kind = \"scenery\""),
        &file
    )
    .is_err());
    assert!(
        claims::deviations::parse(p, &format!("{}claim = 1\n", dev("[\"fast\"]")), &file).is_err()
    );
}

/// A measure may divide two measures of the same rows; each side pools as it would
/// alone. Counter ratios are points; a ratio with a time side is a timing (the floor between
/// runs widens it); trace times and ambiguous sums are refused at load.
#[test]
fn ratio_measures_divide_the_same_rows() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path().join("run");
    std::fs::create_dir_all(&d).unwrap();
    let line = |scene: &str, params: &str, stats: &str, interior: f64| {
        row(
            scene, "a", params, "primary", 100, 10.0, 0.01, 9, false, interior,
        )
        .replace("nodes=7;paper_bytes=64", stats)
    };
    write(
        &d,
        "results.csv",
        &[
            HEAD.to_string(),
            line("s1", "k=1", "a_ms=2;total_ms=10;nodes=7", 4.0),
            line("s2", "k=1", "a_ms=1;total_ms=20;nodes=8", 2.0),
        ],
    );
    let c = |measure: &str, filter: &str, min: f64, max: f64| {
        claim(&format!(
            "measure = \"{measure}\"\nfilter = {{ {filter} }}\nper = [\"scene\"]\nrows.a = {{ traversal = \"a\" }}\ntest = {{ kind = \"value\", of = \"a\", min = {min}, max = {max} }}"
        ))
    };
    let run = |toml: String| eval(&toml, std::slice::from_ref(&d)).remove(0);
    // One build: 1 / 20, a timing (`_ms` keys): ±20 % makes [0.0417, 0.06].
    let share = "build:a_ms / build:total_ms";
    let v = run(c(share, "scene = \"s2\"", 0.04, 0.0625));
    assert_eq!(v.verdict, Verdict::Agree, "{v:?}");
    let g = &v.groups[0];
    assert!((g.values["a"].v - 0.05).abs() < 1e-12 && g.values["a"].timed);
    // A band narrower than the floor allows (0.055 / 0.045 < 1.2²): undecidable by
    // construction, not merely inconclusive.
    assert_eq!(
        run(c(share, "scene = \"s2\"", 0.045, 0.055)).verdict,
        Verdict::Undecidable
    );
    assert_eq!(
        run(c(share, "scene = \"s2\"", 0.07, 0.1)).verdict,
        Verdict::Disagree
    );
    // Two builds in one group: each side's mean over the builds, then the ratio
    // ((2 + 1) / 2 over (10 + 20) / 2 = 0.1, not the mean of the shares, 0.125).
    let v = run(c(share, "scene = [\"s1\", \"s2\"]", 0.0, 1.0).replace("per = [\"scene\"]\n", ""));
    assert!((v.groups[0].values["a"].v - 0.1).abs() < 1e-12, "{v:?}");
    assert_eq!(v.groups[0].values["a"].rows, 2);
    // A `_ms` side makes a timing: a point band cannot be decided under the floor
    // (undecidable by construction).
    let v = run(c(
        "build:nodes / build:total_ms",
        "scene = \"s2\"",
        0.4,
        0.4,
    ));
    assert_eq!(v.verdict, Verdict::Undecidable, "a _ms side makes a timing");
    let v = run(c(
        "(interior_per_ray + interior_per_ray) / interior_per_ray",
        "scene = \"s1\"",
        2.0,
        2.0,
    ));
    assert_eq!(v.verdict, Verdict::Agree, "{v:?}");
    assert!(!v.groups[0].values["a"].timed);
    // Counters: a point, no floor; per-ray sums in parentheses pool by rays first.
    let v = run(c(
        "interior_per_ray / build:nodes",
        "scene = \"s1\"",
        4.0 / 7.0,
        4.0 / 7.0,
    ));
    assert_eq!(v.verdict, Verdict::Agree, "{v:?}");
    // A key a build does not report: the group says which.
    let v = run(c("build:a_ms / build:bogus", "scene = \"s2\"", 0.0, 1.0));
    assert_eq!(v.verdict, Verdict::Inconclusive);
    assert!(v.why.contains("bogus"), "{}", v.why);
    // Refused at load, naming the claim's line.
    for (measure, says) in [
        ("time / build_ms", "trace times"),
        ("build:a_ms / build:b + build:c", "needs parentheses"),
        (
            "interior_per_ray / bogus_per_ray",
            "`bogus_per_ray` is not a column",
        ),
        ("a / b / c", "one `/` at most"),
    ] {
        let e = claims::parse(Path::new("x.toml"), &c(measure, "scene = \"s2\"", 0.0, 1.0))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("x.toml:3: claim c: measure") && e.contains(says),
            "{measure}: {e}"
        );
    }
}

/// `pick = "max"` / `"min"` lets a selector span a sweep's variants and stand for
/// its extreme (Table 2's strong form: the slowest of one sweep before the fastest of another).
#[test]
fn picking_selectors_stand_for_a_sweeps_extreme() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path().join("run");
    std::fs::create_dir_all(&d).unwrap();
    let r = |traversal: &str, k: u32, interior: f64| {
        row(
            "s",
            traversal,
            &format!("k={k}"),
            "primary",
            100,
            10.0,
            0.01,
            9,
            false,
            interior,
        )
    };
    write(
        &d,
        "results.csv",
        &[
            HEAD.to_string(),
            r("a", 1, 3.0),
            r("a", 2, 5.0),
            r("a", 3, 4.0),
            r("b", 1, 9.0),
            r("b", 2, 6.0),
        ],
    );
    let c = |hi: &str, lo: &str| {
        claim(&format!(
            "measure = \"interior_per_ray\"\nper = [\"scene\"]\nrows.hi = {{ traversal = \"a\"{hi} }}\nrows.lo = {{ traversal = \"b\"{lo} }}\ntest = {{ kind = \"order\", rows = [\"hi\", \"lo\"], strict = true }}"
        ))
    };
    let run = |toml: String| eval(&toml, std::slice::from_ref(&d)).remove(0);
    // Without a pick the sweep is ambiguous.
    let v = run(c("", ""));
    assert_eq!(v.verdict, Verdict::Inconclusive);
    assert!(v.why.contains("ambiguous"), "{}", v.why);
    // a's largest (5, k = 2) before b's smallest (6, k = 2).
    let v = run(c(", pick = \"max\"", ", pick = \"min\""));
    assert_eq!(v.verdict, Verdict::Agree, "{v:?}");
    assert_eq!(v.groups[0].values["hi"].v, 5.0);
    assert_eq!(v.groups[0].values["lo"].v, 6.0);
    assert!(
        v.why.contains("`hi` = the largest of 3 variants: k=2")
            && v.why.contains("`lo` = the smallest of 2 variants: k=2"),
        "{}",
        v.why
    );
    // Picked the other way round the order holds no more: b's largest (9) is not what is
    // compared, a's smallest (3) against b's largest (9) holds, a's largest against b's
    // largest holds; a's largest against a 4-valued b would not.
    assert_eq!(
        run(c(", pick = \"min\"", ", pick = \"max\"")).groups[0].values["lo"].v,
        9.0
    );
    let strict = c(", pick = \"max\"", ", pick = \"min\"")
        .replace("strict = true", "strict = true, margin = 0.2");
    assert_eq!(run(strict).verdict, Verdict::Disagree);
    // Refused at load: another word, or a pick in the filter.
    let e = claims::parse(Path::new("x.toml"), &c(", pick = \"median\"", ""))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("rows.hi: pick") && e.contains("\"max\" or \"min\""),
        "{e}"
    );
    let in_filter = c("", "").replace("\nper = ", "\nfilter = { pick = \"max\" }\nper = ");
    let e = claims::parse(Path::new("x.toml"), &in_filter)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("filter: pick belongs in a named selector"),
        "{e}"
    );
}

/// A named selector may name its own `measure` (one reading of a claim whose sides
/// are measured differently: Feldmann's Table 5 as the kd-tree's whole build against the
/// R-tree's insertion alone). Its rows pool by it, the others by the claim's; a timing on
/// either side gets the floor; reports show both; a bad measure, a measure in the filter or
/// a column no run writes are refused at load; `measure:KEY` deviations name such claims.
#[test]
fn a_selector_may_name_its_own_measure() {
    let t = tempfile::tempdir().unwrap();
    let f = write(
        t.path(),
        "b.csv",
        &[
            "scene,structure,params,traversal,device,threads,triangle_test,ray_kind,rays,build_ms,build_ms_runs,build_stats".into(),
            "s,kd,k=1,x,cpu,1,watertight,primary,10,700,690;700;710,nodes=7".into(),
            "s,rt,k=1,x,cpu,1,watertight,primary,10,100,99;100;101,insert_ms=60;pack_ms=40".into(),
        ],
    );
    let c = |own: &str, min: f64| {
        claim(&format!(
            "measure = \"build_ms\"\nrows.kd = {{ structure = \"kd\" }}\nrows.rt = {{ structure = \"rt\"{own} }}\ntest = {{ kind = \"ratio\", num = \"kd\", den = \"rt\", min = {min} }}"
        ))
    };
    let run = |toml: String| eval(&toml, std::slice::from_ref(&f)).remove(0);
    // The whole build: 700 / 100 = 7; insertion alone: 700 / 60 = 11.7.
    let whole = run(c("", 10.0));
    assert_eq!(whole.groups[0].values["rt"].v, 100.0);
    assert_eq!(whole.verdict, Verdict::Disagree, "{whole:?}");
    let insert = run(c(", measure = \"build:insert_ms\"", 10.0));
    assert_eq!(insert.groups[0].values["rt"].v, 60.0);
    assert_eq!(insert.groups[0].values["kd"].v, 700.0);
    assert!(insert.groups[0].values["rt"].timed);
    // 11.7 with the floor: 700 / (60 · 1.2) = 9.7 is below 10, so not decided; at 5 it is.
    assert_eq!(insert.verdict, Verdict::Inconclusive, "{insert:?}");
    let at5 = run(c(", measure = \"build:insert_ms\"", 5.0));
    assert_eq!(at5.verdict, Verdict::Agree, "{at5:?}");
    assert_eq!(at5.measure, "build_ms (rt: build:insert_ms)");
    // Refused at load.
    for (bad, says) in [
        (", measure = 3", "rows.rt: measure: a measure is a string"),
        (", measure = \"bogus_per_ray\"", "rows.rt: measure"),
        (", measure = \"a / b + c\"", "rows.rt: measure"),
    ] {
        let e = claims::parse(Path::new("x.toml"), &c(bad, 5.0))
            .unwrap_err()
            .to_string();
        assert!(e.contains(says), "{bad}: {e}");
    }
    let in_filter = c("", 5.0).replace(
        "\nrows.kd",
        "\nfilter = { measure = \"build_ms\" }\nrows.kd",
    );
    let e = claims::parse(Path::new("x.toml"), &in_filter)
        .unwrap_err()
        .to_string();
    assert!(e.contains("filter: measure belongs in the claim"), "{e}");
    // A deviation on `measure:build:insert_ms` names the claim whose selector reads it.
    let file = claims::parse(
        Path::new("t.toml"),
        &c(", measure = \"build:insert_ms\"", 5.0),
    )
    .unwrap();
    assert!(file.claims[0].measures().any(|m| m == "build:insert_ms"));
}
