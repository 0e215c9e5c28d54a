//! End-to-end tests of the `trace-bench` command line: config errors, malformed scene files,
//! interrupted runs resumed, and the baseline check.

mod common;
use common::*;

use std::fs;
use std::path::{Path, PathBuf};
use tb_harness::experiment::config::{self, Overrides};
use tb_results::output::read_csv;

const GOOD: &str = r#"
[run]
threads = 1
repeat = 1
warmup = 0

[[scene]]
source = "builtin:stress/flat"
rays = ["primary", "random"]
random = { count = 500 }

[[structure]]
name = "bvh"
"#;

#[test]
fn good_config_parses() {
    let exp = config::parse(
        Path::new("t.toml"),
        GOOD,
        &Overrides::default(),
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(exp.scenes.len(), 1);
    assert_eq!(exp.structures[0].param_sets.len(), 1);
}

/// A table without `traversals` runs every traversal but those run on request (the BVH's
/// `while-while`); naming one runs it.
#[test]
fn on_request_traversals_run_only_when_named() {
    let names = |text: &str| -> Vec<&'static str> {
        let exp = config::parse(
            Path::new("t.toml"),
            text,
            &Overrides::default(),
            &mut |_| {},
        )
        .unwrap();
        let s = &exp.structures[0];
        s.traversals.iter().map(|&i| s.infos[i].name).collect()
    };
    assert_eq!(names(GOOD), ["ordered"]);
    let named = GOOD.replace(
        "name = \"bvh\"",
        "name = \"bvh\"\ntraversals = [\"while-while\", \"ordered\"]",
    );
    assert_eq!(names(&named), ["while-while", "ordered"]);
}

#[test]
fn optional_scenes_that_are_absent_are_skipped_with_a_note() {
    let text = format!(
        "{GOOD}\n[[scene]]\nsource = \"no-such-dir/fairy-forest.obj.gz\"\noptional = true\n"
    );
    let ov = Overrides {
        scenes_root: Some(PathBuf::from("/nonexistent-scenes-root")),
        ..Default::default()
    };
    let exp = config::parse(Path::new("t.toml"), &text, &ov, &mut |_| {}).unwrap();
    assert_eq!(exp.scenes.len(), 1);
    assert_eq!(exp.skipped_scenes.len(), 1);
    assert!(
        exp.skipped_scenes[0].contains("fairy-forest") && exp.skipped_scenes[0].contains("skipped"),
        "{:?}",
        exp.skipped_scenes
    );
    // Without `optional`, the same scene is an error naming the line; with only absent
    // optional scenes there is nothing to run, also an error.
    let e = parse_err(&format!(
        "{GOOD}\n[[scene]]\nsource = \"no-such-dir/fairy-forest.obj.gz\"\n"
    ));
    assert!(e.contains("scene.source") && e.contains("not found"), "{e}");
    let only = "[[scene]]\nsource = \"no-such-dir/x.obj\"\noptional = true\n\n[[structure]]\nname = \"bvh\"\n";
    match config::parse(Path::new("t.toml"), only, &ov, &mut |_| {}) {
        Ok(_) => panic!("a config whose scenes are all absent should not parse"),
        Err(e) => assert!(e.to_string().contains("no scene to run"), "{e}"),
    }
}

#[test]
fn config_errors_name_file_line_and_key() {
    // Unknown key (line 3).
    let e = parse_err("[run]\nthreads = 1\nthreds = 2\n");
    assert!(
        e.contains("configs/test.toml:3: run.threds:") && e.contains("unknown field"),
        "{e}"
    );
    // Wrong type, or a wrong value of a one-or-many key: the line and the key, and what was
    // expected.
    let e = parse_err("[run]\nrepeat = \"five\"\n");
    assert!(
        e.contains("configs/test.toml:2: run.repeat:") && e.contains("expected u32"),
        "{e}"
    );
    let e = parse_err("[run]\nthreads = -1\n");
    assert!(
        e.contains("configs/test.toml:2: run.threads:") && e.contains("expected u32"),
        "{e}"
    );
    let e = parse_err("[run]\nthreads = 1\ntriangle_test = [\"watertight\", 3]\n");
    assert!(
        e.contains(":3: run.triangle_test:") && e.contains("expected a string"),
        "{e}"
    );
    // Zero timed runs is an error, not one run.
    let e = parse_err("[run]\nrepeat = 0\n");
    assert!(e.contains(":2: run.repeat: must be at least 1"), "{e}");
    // Unknown structure, on its line.
    let text = GOOD.replace("name = \"bvh\"", "name = \"octree\"");
    let e = parse_err(&text);
    let line = text.lines().position(|l| l.contains("octree")).unwrap() + 1;
    assert!(
        e.contains(&format!(":{line}:")) && e.contains("unknown structure `octree`"),
        "{e}"
    );
    // Unknown traversal.
    let e = parse_err(&GOOD.replace(
        "name = \"bvh\"",
        "name = \"bvh\"\ntraversals = [\"kd-restart\"]",
    ));
    assert!(
        e.contains("structure.traversals") && e.contains("kd-restart"),
        "{e}"
    );
    // Unknown parameter and bad parameter value.
    let e = parse_err(&GOOD.replace("name = \"bvh\"", "name = \"bvh\"\nparams = { leaf = 3 }"));
    assert!(
        e.contains("structure.params.leaf") && e.contains("unknown parameter"),
        "{e}"
    );
    let e = parse_err(&GOOD.replace(
        "name = \"bvh\"",
        "name = \"bvh\"\nparams = { bins = [8, 1] }",
    ));
    assert!(
        e.contains("structure.params.bins") && e.contains("out of range"),
        "{e}"
    );
    // Rules across parameters, declared by the structure, checked with the config (not at
    // build time): BVH width 3 (each of 2..=8 in range), R-tree m > M/2 in one combination of
    // a sweep, kd-tree min-max bins in its own table.
    let text = GOOD.replace("name = \"bvh\"", "name = \"bvh\"\nparams = { width = 3 }");
    let e = parse_err(&text);
    let line = text.lines().position(|l| l.contains("width = 3")).unwrap() + 1;
    assert!(
        e.contains(&format!(":{line}:"))
            && e.contains("structure.params")
            && e.contains("width must be 2, 4 or 8, got 3"),
        "{e}"
    );
    let e = parse_err(&GOOD.replace(
        "name = \"bvh\"",
        "name = \"rtree\"\nparams = { big_m = [4, 8], m = 3 }",
    ));
    assert!(
        e.contains("rtree: m must be in 2..=M/2 = 2, got 3") && e.contains("big_m=4"),
        "{e}"
    );
    // Missing scene file, naming the path.
    let e = parse_err(&GOOD.replace("builtin:stress/flat", "no/such/scene.obj"));
    assert!(
        e.contains("scene.source") && e.contains("no/such/scene.obj") && e.contains("not found"),
        "{e}"
    );
    // A directory where a scene file should be.
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("meshes")).unwrap();
    let text = GOOD.replace(
        "builtin:stress/flat",
        dir.path().join("meshes").to_str().unwrap(),
    );
    let e = parse_err(&text);
    assert!(
        e.contains("scene.source") && e.contains("is a directory, not a scene file"),
        "{e}"
    );
    // Unknown ray kind.
    let e = parse_err(&GOOD.replace("\"random\"]", "\"randm\"]"));
    assert!(e.contains("scene.rays") && e.contains("randm"), "{e}");
    // Unknown built-in scene.
    let e = parse_err(&GOOD.replace("builtin:stress/flat", "builtin:nosuch"));
    assert!(e.contains("scene.source") && e.contains("nosuch"), "{e}");
    // Malformed TOML.
    let e = parse_err("[run\nthreads = 1\n");
    assert!(
        e.contains("configs/test.toml") && e.contains("line 1"),
        "{e}"
    );
}

fn write_config(dir: &Path, scene_source: &str) -> PathBuf {
    let cfg = dir.join("c.toml");
    let text = GOOD
        .replace("builtin:stress/flat", scene_source)
        .replace("rays = [\"primary\", \"random\"]", "rays = [\"random\"]");
    fs::write(&cfg, text).unwrap();
    cfg
}

#[test]
fn malformed_scenes_fail_cleanly_without_results() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    fs::write(d.join("junk.obj"), "v 0 0 zero\nf 1 2 3\n").unwrap();
    // A truncated gzip stream.
    {
        use std::io::Write;
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        e.write_all(
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
                .repeat(200)
                .as_slice(),
        )
        .unwrap();
        let bytes = e.finish().unwrap();
        fs::write(d.join("cut.obj.gz"), &bytes[..bytes.len() / 2]).unwrap();
    }
    fs::write(
        d.join("bad.gltf"),
        "{ \"asset\": { \"version\": \"2.0\" }, \"meshes\": [ {",
    )
    .unwrap();
    for name in ["bad.obj", "junk.obj", "cut.obj.gz", "bad.gltf"] {
        let cfg = write_config(d, &d.join(name).display().to_string());
        let out = d.join(format!("out-{name}"));
        let code = run_quiet(&cfg, &out);
        assert_eq!(code, 1, "{name} must fail");
        assert!(
            !out.join("results.csv").exists(),
            "{name}: no results file may claim success"
        );
        // The error message names the file.
        let e = config::load(&cfg, &Overrides::default(), &mut |_| {})
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains(name), "{name}: {e}");
    }
}

#[test]
fn interrupted_run_resumes_to_the_same_rows() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cfg = d.join("r.toml");
    fs::write(
        &cfg,
        r#"
[run]
threads = [1, 2]
repeat = 1
warmup = 0
triangle_test = ["watertight", "moller-trumbore"]

[[scene]]
source = "builtin:stress/flat"
rays = ["primary", "random", "stress"]
random = { count = 300 }

[[structure]]
name = "bvh"
params = { max_leaf = [2, 4] }
"#,
    )
    .unwrap();
    let full = d.join("full");
    assert_eq!(
        run(&[
            "run",
            cfg.to_str().unwrap(),
            "--out",
            full.to_str().unwrap(),
            "-q"
        ]),
        0
    );
    let all = read_csv(&full.join("results.csv")).unwrap();
    assert_eq!(all.len(), 2 * 2 * 3 * 2, "params x tests x kinds x threads");

    // Simulate an interruption: the first 5 rows and a torn sixth line.
    let part = d.join("part");
    fs::create_dir_all(&part).unwrap();
    let text = fs::read_to_string(full.join("results.csv")).unwrap();
    let mut lines: Vec<&str> = text.lines().take(6).collect();
    let torn = &text.lines().nth(6).unwrap()[..20];
    lines.push(torn);
    fs::write(part.join("results.csv"), lines.join("\n")).unwrap();
    // Without --resume the existing results are protected.
    assert_eq!(
        run(&[
            "run",
            cfg.to_str().unwrap(),
            "--out",
            part.to_str().unwrap(),
            "-q"
        ]),
        1
    );
    assert_eq!(
        run(&[
            "run",
            cfg.to_str().unwrap(),
            "--out",
            part.to_str().unwrap(),
            "-q",
            "--resume"
        ]),
        0
    );
    let resumed = read_csv(&part.join("results.csv")).unwrap();
    let mut a: Vec<_> = all
        .iter()
        .map(|r| (r.key(), r.steps_per_ray, r.mismatches))
        .collect();
    let mut b: Vec<_> = resumed
        .iter()
        .map(|r| (r.key(), r.steps_per_ray, r.mismatches))
        .collect();
    a.sort_by(|x, y| x.0.cmp(&y.0));
    b.sort_by(|x, y| x.0.cmp(&y.0));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.0, y.0);
        assert_eq!(x.1, y.1, "counters are deterministic");
        assert_eq!(x.2, y.2);
    }
    // results.json holds the same rows and says the run completed.
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(part.join("results.json")).unwrap()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), all.len());
    assert_eq!(json["meta"]["status"], "complete");
    // The metadata says what ran, where and when.
    let meta = &json["meta"];
    let commit = meta["build"]["commit"].as_str().unwrap();
    assert!(
        commit == "unknown"
            || (commit.len() == 12 && commit.chars().all(|c| c.is_ascii_hexdigit())),
        "{commit}"
    );
    assert!(meta["build"]["rustc"].is_string());
    assert!(!meta["host"]["name"].as_str().unwrap().is_empty());
    assert!(meta["host"]["cores"].as_u64().unwrap() >= 1);
    assert!(meta["end"].is_string() && meta["start"].is_string());
    assert!(meta["duration_s"].as_f64().unwrap() >= 0.0);
    assert!(json["rows"]
        .as_array()
        .unwrap()
        .iter()
        .all(|r| !r["host"].as_str().unwrap().is_empty()));
}

fn write_rows(path: &Path, rows: &[tb_results::output::Row]) {
    let mut w = csv::Writer::from_path(path).unwrap();
    for r in rows {
        w.serialize(r).unwrap();
    }
    w.flush().unwrap();
}

#[test]
fn check_fails_when_a_counter_grows_and_passes_when_not() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cfg = write_config(d, "builtin:stress/flat");
    let out = d.join("out");
    assert_eq!(
        run(&[
            "run",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q"
        ]),
        0
    );
    let results = out.join("results.csv");
    // Baseline equal to the run: passes.
    assert_eq!(
        run(&[
            "check",
            "--baseline",
            results.to_str().unwrap(),
            results.to_str().unwrap()
        ]),
        0
    );
    // A baseline with fewer steps per ray: the run's counter grew, so it fails.
    let mut rows = read_csv(&results).unwrap();
    for r in &mut rows {
        r.steps_per_ray = r.steps_per_ray.map(|s| s * 0.5);
    }
    let lower = d.join("lower.csv");
    write_rows(&lower, &rows);
    assert_eq!(
        run(&[
            "check",
            "--baseline",
            lower.to_str().unwrap(),
            results.to_str().unwrap()
        ]),
        1
    );
    // A baseline with more steps: the run improved, so it passes.
    for r in &mut rows {
        r.steps_per_ray = r.steps_per_ray.map(|s| s * 4.0);
    }
    let higher = d.join("higher.csv");
    write_rows(&higher, &rows);
    assert_eq!(
        run(&[
            "check",
            "--baseline",
            higher.to_str().unwrap(),
            results.to_str().unwrap()
        ]),
        0
    );
}

#[test]
fn validate_command_passes_on_a_stress_scene() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write_config(dir.path(), "builtin:stress/flat");
    assert_eq!(run(&["validate", cfg.to_str().unwrap(), "-q"]), 0);
}

#[test]
fn overrides_run_one_scene_and_structure_without_editing_the_config() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("o.toml");
    std::fs::write(
        &cfg,
        r#"
[run]
threads = [1]
repeat = 3
[[scene]]
source = "builtin:cornell"
camera = { width = 32, height = 32 }
[[scene]]
source = "builtin:sphereflake"
[[structure]]
name = "bvh"
[[structure]]
name = "kdtree"
"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    let (c, o) = (cfg.to_str().unwrap(), out.to_str().unwrap());
    let args = [
        "run",
        c,
        "--out",
        o,
        "-q",
        "--scene",
        "cornell",
        "--structure",
        "kdtree:ropes",
        "--set",
        "scene.camera.width=16",
        "--set",
        "run.repeat=1",
    ];
    assert_eq!(common::run(&args), 0);
    let rows = tb_results::output::read_csv(&out.join("results.csv")).unwrap();
    assert_eq!(rows.len(), 1, "{rows:?}");
    let r = &rows[0];
    assert_eq!(
        (r.scene.as_str(), r.structure.as_str()),
        ("cornell", "kdtree")
    );
    assert_eq!((r.traversal.as_str(), r.rays), ("ropes", 16 * 32));
    // The effective config is what results.json records.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert!(json["meta"]["config"]
        .as_str()
        .unwrap()
        .contains("repeat = 1"));
    // An existing --out is refused, then replaced with --force.
    assert_eq!(common::run(&args), 1);
    let mut forced = args.to_vec();
    forced.push("--force");
    assert_eq!(common::run(&forced), 0);
    assert_eq!(
        tb_results::output::read_csv(&out.join("results.csv"))
            .unwrap()
            .len(),
        1
    );
    // Unknown names are one-line errors.
    assert_eq!(
        common::run(&["run", c, "--out", o, "--force", "--scene", "nope"]),
        1
    );
    assert_eq!(
        common::run(&["run", c, "--out", o, "--force", "--set", "run.repeat.x=1"]),
        1
    );
}

/// A traversal whose CPU walk is another's (`TraversalInfo::cpu_as`: the BVH's
/// `while-while-speculative`) gets CPU rows with a note naming that walk and no timing, beside
/// the walk's own measured rows.
#[test]
fn cpu_as_traversals_make_no_cpu_rows_of_their_own() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("s.toml");
    std::fs::write(
        &cfg,
        r#"
[run]
threads = [1]
repeat = 1
warmup = 0
[[scene]]
source = "builtin:cornell"
camera = { width = 16, height = 16 }
rays = ["primary"]
[[structure]]
name = "bvh"
traversals = ["while-while", "while-while-speculative"]
params = { builder = "sbvh", width = 2, max_leaf = 8, c_trav = 2.0, leaf_cost = "linear" }
"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    assert_eq!(common::run_quiet(&cfg, &out), 0);
    let rows = tb_results::output::read_csv(&out.join("results.csv")).unwrap();
    let of = |t: &str| rows.iter().find(|r| r.traversal == t).expect(t).clone();
    let (ww, spec) = (of("while-while"), of("while-while-speculative"));
    assert!(
        ww.mrays_per_s.is_some() && ww.steps_per_ray.is_some(),
        "{ww:?}"
    );
    assert!(
        spec.mrays_per_s.is_none() && spec.steps_per_ray.is_none(),
        "{spec:?}"
    );
    assert!(spec.note.contains("`while-while`'s walk"), "{}", spec.note);
}

/// `--structure NAME:traversal` keeps only the tables of that name that run the traversal,
/// each table once with the traversals asked of it (one build per table, no repeated rows).
#[test]
fn structure_filter_keeps_each_table_once_with_its_own_traversals() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("f.toml");
    std::fs::write(
        &cfg,
        r#"
[run]
threads = [1]
repeat = 1
warmup = 0
[[scene]]
source = "builtin:cornell"
camera = { width = 16, height = 16 }
[[structure]]
name = "kdtree"
traversals = ["ropes", "restart"]
params = { c_isect = 1.0 }
[[structure]]
name = "kdtree"
traversals = ["push-down", "restart"]
params = { c_isect = 2.0 }
"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    let (c, o) = (cfg.to_str().unwrap(), out.to_str().unwrap());
    let rows_of = |spec: &str| {
        let args = ["run", c, "--out", o, "--force", "-q", "--structure", spec];
        assert_eq!(common::run(&args), 0, "{spec}");
        let mut rows: Vec<(String, String)> =
            tb_results::output::read_csv(&out.join("results.csv"))
                .unwrap()
                .into_iter()
                .map(|r| {
                    let c = r.params.split(';').find(|p| p.starts_with("c_isect="));
                    (c.unwrap().to_string(), r.traversal)
                })
                .collect();
        rows.sort();
        rows
    };
    let row = |c: &str, t: &str| (format!("c_isect={c}"), t.to_string());
    // ropes: only the first table runs it.
    assert_eq!(rows_of("kdtree:ropes"), vec![row("1", "ropes")]);
    // Two traversals of the first table: one table, not two copies of it.
    assert_eq!(
        rows_of("kdtree:ropes,kdtree:restart"),
        vec![row("1", "restart"), row("1", "ropes"), row("2", "restart")]
    );
    // A traversal that no table of that name runs is a one-line error.
    assert_eq!(
        common::run(&[
            "run",
            c,
            "--out",
            o,
            "--force",
            "-q",
            "--structure",
            "kdtree:havran"
        ]),
        1
    );
}

/// The lines of the repository's file `path` between the line holding `start` and the line
/// holding `end`.
fn generated_part(path: &str, start: &str, end: &str) -> String {
    let text = std::fs::read_to_string(format!("{}/../../{path}", env!("CARGO_MANIFEST_DIR")))
        .unwrap_or_else(|e| panic!("{path}: {e}"));
    let a = text
        .find(start)
        .unwrap_or_else(|| panic!("{path} has the start marker"));
    let a = a + text[a..].find('\n').expect("marker line") + 1;
    let b = text
        .find(end)
        .unwrap_or_else(|| panic!("{path} has the end marker"));
    text[a..b].to_string()
}

/// README.md's structure table is `trace-bench list --markdown`, and docs/structures.md's
/// reference `list --markdown --details`, so neither can drift from the registry (a family's
/// summary and doc, its traversals, GPU programs and parameters).
#[test]
fn readme_structure_table_is_the_registry_listing() {
    let registry = tb_harness::registry::Registry::builtin();
    let generated = registry.markdown().expect("the listing");
    assert!(
        generated_part(
            "README.md",
            "<!-- generated by `trace-bench list --markdown` (default features)",
            "<!-- end of list --markdown -->"
        ) == generated,
        "README.md's structure table differs from the registry: replace the lines between its \
         `list --markdown` markers with the output of `cargo run --release -- list --markdown`"
    );
    let generated = registry.reference().expect("the reference");
    assert!(
        generated_part(
            "docs/structures.md",
            "<!-- generated by `trace-bench list --markdown --details` (default features)",
            "<!-- end of list --markdown --details -->"
        ) == generated,
        "docs/structures.md's reference differs from the registry: replace the lines between \
         its markers with the output of `cargo run --release -- list --markdown --details`"
    );
}

/// A scene scaled to 1e30 is not refused for its AO distance, with or without AO rays: the
/// default, 4 % of the diagonal, is finite now that the diagonal is computed scale-free (it
/// was infinite, and AO rays were refused).
#[test]
fn ao_distance_is_checked_only_for_ao_rays() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(
        dir.path().join("huge.obj"),
        "v 0 0 0\nv 1e30 0 0\nv 0 1e30 0\nf 1 2 3\nv 0 0 1e30\nf 1 2 4\n",
    )
    .unwrap();
    let text = |rays: &str| {
        format!(
            "[[scene]]\nsource = {:?}\nrays = {rays}\nrandom = {{ count = 100 }}\n\
             camera = {{ eye = [0.5, 0.5, 2], target = [0.5, 0.5, 0], fov = 40 }}\n\
             [[structure]]\nname = \"bvh\"\n",
            dir.path().join("huge.obj").to_str().unwrap()
        )
    };
    let ok = config::parse(
        Path::new("t.toml"),
        &text("[\"random\"]"),
        &Overrides::default(),
        &mut |_| {},
    );
    assert!(ok.is_ok(), "{:?}", ok.err().map(|e| e.to_string()));
    let ao = config::parse(
        Path::new("t.toml"),
        &text("[\"random\", \"ao\"]"),
        &Overrides::default(),
        &mut |_| {},
    );
    assert!(ao.is_ok(), "{:?}", ao.err().map(|e| e.to_string()));
}
