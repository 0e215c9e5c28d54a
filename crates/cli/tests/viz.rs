//! End-to-end tests of the pictures and convergence outputs: `[run] images = true`,
//! `[convergence]`, `trace-bench diff`, and the errors of their config keys.

mod common;
use common::*;

use std::fs;
use tb_harness::experiment::convergence::ConvergenceRow;
use tb_render::Channels;

const SCENE: &str = "[[scene]]\nsource = \"builtin:cornell\"\n\n[[structure]]\nname = \"bvh\"\n";

#[test]
fn image_and_convergence_keys_are_checked() {
    let cases = [
        (
            "[run]\nimages = true\nheatmap_max = -3\n",
            "3",
            "run.heatmap_max",
        ),
        ("[run]\nheatmap_max = 100\n", "2", "no effect without"),
        (
            "[convergence]\nintegrators = [\"ao\", \"bdpt\"]\n",
            "2",
            "unknown integrator `bdpt`",
        ),
        ("[convergence]\npasses = 0\n", "2", "convergence.passes"),
        (
            "[convergence]\nschedule = \"random\"\n",
            "2",
            "convergence.schedule",
        ),
        ("[convergence]\nalbedo = 1.5\n", "2", "convergence.albedo"),
        (
            "[convergence]\nframe_budget_ms = [10, -1]\n",
            "2",
            "convergence.frame_budget_ms",
        ),
        ("[convergence]\npasses = 40\n", "1", "at most 2^20"),
    ];
    for (head, line, what) in cases {
        let e = parse_err(&format!("{head}\n{SCENE}"));
        assert!(
            e.starts_with(&format!("configs/test.toml:{line}:")) && e.contains(what),
            "{head}: {e}"
        );
    }
    // A scene file without a camera cannot be rendered.
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("t.obj");
    fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let e = parse_err(&format!(
        "[convergence]\n\n[[scene]]\nsource = \"{}\"\nrays = [\"random\"]\n\n[[structure]]\nname = \"bvh\"\n",
        obj.display()
    ));
    assert!(e.contains("has no camera"), "{e}");
}

#[test]
fn images_convergence_and_diff_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let cfg = dir.path().join("viz.toml");
    fs::write(
        &cfg,
        format!(
            r#"
[run]
threads = 1
repeat = 1
warmup = 0
validate = "off"
images = true
heatmap_max = 64

[convergence]
integrators = ["ao"]
passes = 4
reference_spp = 256
frame_budget_ms = [200]
cache = "{}"

[[scene]]
source = "builtin:cornell"
camera = {{ width = 24, height = 20, order = "morton" }}
ao = {{ distance = 150 }}

[[structure]]
name = "bvh"

[[structure]]
name = "kdtree"
traversals = ["havran", "restart"]

[[structure]]
name = "bvh"
params = {{ max_leaf = [2, 8] }}
"#,
            cache.display()
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    assert_eq!(run(&["run", cfg.to_str().unwrap(), "--out", o, "-q"]), 0);

    let img = out.join("images/cornell");
    for f in [
        "render.png",
        "render.exr",
        "bvh-ordered-watertight.exr",
        "bvh-ordered-watertight-steps.png",
        "kdtree-restart-watertight-prims.png",
        // A swept structure's files name the swept parameter.
        "bvh-max_leaf=2-ordered-watertight-steps.png",
        "bvh-max_leaf=8-ordered-watertight.exr",
        // Two kd traversals on the same rays, side by side on one scale (Figure 5 of the
        // sparse-boxes paper).
        "kdtree-watertight-steps-side-by-side.png",
    ] {
        let p = img.join(f);
        assert!(p.is_file(), "{} missing", p.display());
    }
    let bvh = Channels::read_exr(&img.join("bvh-ordered-watertight.exr")).unwrap();
    assert_eq!((bvh.width, bvh.height), (24, 20));
    let steps = bvh.get("steps").unwrap();
    assert!(
        steps.iter().any(|&s| s > 1.0),
        "rays into the box descend the tree"
    );
    // The mean of the heat map is the steps_per_ray of the results row (Morton order mapped back
    // to pixels loses nothing).
    let rows = tb_results::output::read_csv(&out.join("results.csv")).unwrap();
    let row = rows
        .iter()
        .find(|r| {
            r.structure == "bvh" && r.ray_kind == "primary" && r.params.contains("max_leaf=4")
        })
        .unwrap();
    let mean = steps.iter().map(|&s| s as f64).sum::<f64>() / steps.len() as f64;
    assert!((mean - row.steps_per_ray.unwrap()).abs() < 1e-9);
    let index = fs::read_to_string(out.join("images/index.csv")).unwrap();
    assert!(index.contains("images/cornell/kdtree-havran-watertight-steps.png,cornell,kdtree"));
    assert!(index.lines().any(|l| l
        .starts_with("images/cornell/kdtree-watertight-steps-side-by-side.png,cornell,kdtree,")
        && l.contains(",havran|restart,watertight,steps,")));

    // Convergence: 4 passes x 5 combinations in convergence.csv, one budget row each in
    // convergence-budget.csv; RMSE falls.
    let read = |f: &str| -> Vec<ConvergenceRow> {
        let mut r = csv::Reader::from_path(out.join(f)).unwrap();
        r.deserialize().map(|x| x.unwrap()).collect()
    };
    let (passes, budgets) = (read("convergence.csv"), read("convergence-budget.csv"));
    assert_eq!((passes.len(), budgets.len()), (5 * 4, 5));
    assert!(passes.iter().all(|c| c.budget_ms.is_none()));
    assert!(budgets.iter().all(|c| c.budget_ms.is_some()));
    let conv: Vec<ConvergenceRow> = passes.into_iter().chain(budgets).collect();
    let conv: Vec<ConvergenceRow> = conv
        .into_iter()
        .filter(|c| c.structure != "bvh" || c.params.contains("max_leaf=4"))
        .collect();
    for t in ["ordered", "havran", "restart"] {
        let prog: Vec<&ConvergenceRow> = conv
            .iter()
            .filter(|c| c.traversal == t && c.budget_ms.is_none())
            .collect();
        let spp: Vec<u32> = prog.iter().map(|c| c.spp).collect();
        assert_eq!(spp, [1, 2, 4, 8]);
        assert!(prog.windows(2).all(|w| w[1].rmse < w[0].rmse), "{prog:?}");
        assert!(prog.windows(2).all(|w| w[1].elapsed_ms > w[0].elapsed_ms));
        let budget = conv
            .iter()
            .find(|c| c.traversal == t && c.budget_ms.is_some())
            .unwrap();
        assert!(budget.spp >= 1 && budget.rmse.is_some());
        // The budget row never exceeds its budget (a pass ending over it is not counted).
        assert!(budget.elapsed_ms <= budget.budget_ms.unwrap(), "{budget:?}");
    }
    let cached: Vec<_> = fs::read_dir(&cache).unwrap().collect();
    assert_eq!(
        cached.len(),
        1,
        "one reference for one scene and integrator"
    );

    // A second run reuses the reference: same key, same errors.
    let out2 = dir.path().join("out2");
    assert_eq!(
        run(&[
            "run",
            cfg.to_str().unwrap(),
            "--out",
            out2.to_str().unwrap(),
            "-q"
        ]),
        0
    );
    let mut r = csv::Reader::from_path(out2.join("convergence.csv")).unwrap();
    let conv2: Vec<ConvergenceRow> = r.deserialize().map(|x| x.unwrap()).collect();
    assert_eq!(conv2[0].reference_key, conv[0].reference_key);
    assert_eq!(conv2[0].rmse, conv[0].rmse);
    assert_eq!(fs::read_dir(&cache).unwrap().count(), 1);

    // Difference map of two traversals on the same rays.
    let a = img.join("kdtree-havran-watertight.exr");
    let b = img.join("kdtree-restart-watertight.exr");
    let d = dir.path().join("d.png");
    let args = |ch: &str| {
        vec![
            "diff".to_string(),
            a.display().to_string(),
            b.display().to_string(),
            "--channel".into(),
            ch.into(),
            "--out".into(),
            d.display().to_string(),
        ]
    };
    let call = |v: Vec<String>| run(&v.iter().map(|s| s.as_str()).collect::<Vec<_>>());
    assert_eq!(call(args("steps")), 0);
    assert!(d.is_file());
    assert_eq!(call(args("nope")), 1);
    // Split by a channel (the rays where it is nonzero in A or B, and the rest); an unknown
    // channel is refused.
    let split = |ch: &str| {
        let mut v = args("leaves");
        v.extend(["--split".to_string(), ch.to_string()]);
        v
    };
    assert_eq!(call(split("restarts")), 0);
    assert_eq!(call(split("nope")), 1);
}
