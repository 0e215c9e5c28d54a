//! The `[dynamic]` experiment (Pérard-Gayot et al. 2017 §6.3, Table 4) on a tiny animated
//! scene: one row per structure x budget x frame, samples as the budget rule says, the
//! automatic densities among the candidates at the 1 : 8 ratio; and its config errors.

use std::path::Path;
use tb_harness::experiment::config::{self, Overrides};
use tb_harness::experiment::dynamic::{samples_within, ChoiceRow, DynamicRow};
use tb_harness::experiment::runner::{self, RunOptions};

fn text(scene: &str, structure: &str) -> String {
    format!(
        r#"
name = "dyn"
[run]
threads = [1]
repeat = 1
warmup = 0

[dynamic]
frames = [0, 30]
budget_ms = [1000, 20]
lambda_1 = [0.05, 0.1, 0.2]
resolution = [24, 24]

[[scene]]
source = "{scene}"

{structure}
"#
    )
}

fn parse(t: &str) -> Result<config::Experiment, String> {
    config::parse(Path::new("dyn.toml"), t, &Overrides::default(), &mut |_| {})
        .map_err(|e| e.to_string())
}

fn err(t: &str) -> String {
    match parse(t) {
        Ok(_) => panic!("accepted: {t}"),
        Err(e) => e,
    }
}

fn read<T: serde::de::DeserializeOwned>(p: &Path) -> Vec<T> {
    csv::Reader::from_path(p)
        .unwrap()
        .deserialize()
        .map(|r| r.unwrap())
        .collect()
}

#[test]
fn frames_are_rebuilt_and_samples_fit_the_budget() {
    let t = text(
        "builtin:explode?tess=3",
        "[[structure]]\nname = \"two-level-grid\"\n\n[[structure]]\nname = \"irregular-grid\"\nparams = { expansion = 1 }",
    );
    let exp = parse(&t).unwrap();
    let out = tempfile::tempdir().unwrap();
    let opts = RunOptions::quiet(out.path().join("run"));
    let summary = runner::run(&exp, &opts).unwrap();
    assert!(summary.failures.is_empty(), "{:?}", summary.failures);
    assert!(
        summary.rows.is_empty(),
        "a dynamic run writes no static rows"
    );
    let rows: Vec<DynamicRow> = read(&out.path().join("run/dynamic.csv"));
    assert_eq!(rows.len(), 2 * 2 * 2, "structures x frames x budgets");
    for r in &rows {
        assert_eq!(r.triangles, 64 * 9 - 24);
        assert!([0.05, 0.1, 0.2].contains(&r.lambda_1), "{r:?}");
        assert!((r.lambda_2 - 8.0 * r.lambda_1).abs() < 1e-12);
        assert!(
            r.params.contains(&format!("lambda_1={}", r.lambda_1)),
            "{r:?}"
        );
        assert!(r.build_ms > 0.0 && r.primary_ms > 0.0 && r.ao_ms_per_spp > 0.0);
        assert_eq!(
            r.spp,
            samples_within(r.budget_ms, r.build_ms, r.primary_ms, r.ao_ms_per_spp)
        );
        assert_eq!((r.width, r.height), (24, 24));
        assert!(r.source.ends_with(&format!("&frame={}", r.frame)));
    }
    for s in ["two-level-grid", "irregular-grid"] {
        let frames: Vec<u32> = rows
            .iter()
            .filter(|r| r.structure == s && r.budget_ms == 1000.0)
            .map(|r| r.frame)
            .collect();
        assert_eq!(frames, [0, 30], "{s}");
    }
    let choice: Vec<ChoiceRow> = read(&out.path().join("run/dynamic-choice.csv"));
    assert!(
        choice.len() >= 2,
        "both structures try at least one density"
    );
    assert!(choice.iter().all(|c| c.frame == 0));
    assert!(summary.notes.iter().any(|n| n.starts_with("dynamic: ")));
}

#[test]
fn config_errors_name_the_problem() {
    let grid = "[[structure]]\nname = \"two-level-grid\"";
    let e = err(&text(
        "builtin:explode?tess=2",
        "[[structure]]\nname = \"bvh\"",
    ));
    assert!(e.contains("lambda_1"), "{e}");
    let e = err(&text("builtin:explode?tess=2&frame=3", grid));
    assert!(e.contains("frame"), "{e}");
    let e = err(&text("builtin:explode?tess=2", grid).replace("[1000, 20]", "[0]"));
    assert!(e.contains("budget_ms"), "{e}");
    let e = err(&text("builtin:explode?tess=2", grid).replace("[0.05, 0.1, 0.2]", "[0.2, 0.1]"));
    assert!(e.contains("lambda_1"), "{e}");
    let e = err(&text("builtin:explode?tess=2", grid).replace("frames = [0, 30]", "frames = []"));
    assert!(e.contains("dynamic.frames"), "{e}");
}
