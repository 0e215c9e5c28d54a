//! Several views per scene table (`views = [...]`): one load and one build per
//! structure for all the views, rows per view labelled `TABLE@VIEW` with the counters a table
//! of that one camera gives; sharding keeps a table's views in one unit and merges them back;
//! bad views are refused with one line naming the key.

mod common;
use common::*;

use std::fs;
use std::path::Path;
use tb_results::output::{read_csv, Row};

/// The Cornell box seen from its default view and with a wider field of view, as two views of
/// one table, and the wide view again as a table of its own.
const CONFIG: &str = r#"
name = "views"
[run]
threads = [1]
repeat = 1
warmup = 0
validate = "all"

[[scene]]
source = "builtin:cornell"
rays = ["primary", "shadow", "random"]
camera = { width = 24, height = 24 }
random = { count = 256 }
views = [{ name = "default" }, { name = "wide", fov = 75, light = [0.1, 0.9, 0.1] }]

[[scene]]
source = "builtin:cornell"
name = "cornell-wide"
rays = ["primary", "shadow"]
camera = { width = 24, height = 24, fov = 75 }
light = [0.1, 0.9, 0.1]

[[structure]]
name = "bvh"
params = { width = [2, 8] }

[[structure]]
name = "kdtree"
traversals = ["recursive-direction"]
"#;

fn rows(dir: &Path) -> Vec<Row> {
    read_csv(&dir.join("results.csv")).unwrap()
}

/// The deterministic columns of a row: counters, hits, validation.
fn counters(r: &Row) -> String {
    let mut v: Vec<String> = tb_results::check::counter_columns()
        .iter()
        .map(|c| format!("{c}={:?}", r.counter(c)))
        .collect();
    v.push(format!(
        "rays={} hit_rate={:?} validated={:?} mismatches={:?}",
        r.rays, r.hit_rate, r.validated_rays, r.mismatches
    ));
    v.join(" ")
}

fn key(r: &Row) -> (String, String, String, String, String) {
    (
        r.structure.clone(),
        r.params.clone(),
        r.traversal.clone(),
        r.triangle_test.clone(),
        r.ray_kind.clone(),
    )
}

#[test]
fn views_share_one_build_and_trace_their_own_cameras() {
    let t = tempfile::tempdir().unwrap();
    let cfg = t.path().join("views.toml");
    fs::write(&cfg, CONFIG).unwrap();
    let out = t.path().join("out");
    assert_eq!(run_quiet(&cfg, &out), 0);
    let all = rows(&out);
    let of = |scene: &str| -> Vec<&Row> { all.iter().filter(|r| r.scene == scene).collect() };
    let (a, b, alone) = (
        of("cornell@default"),
        of("cornell@wide"),
        of("cornell-wide"),
    );
    assert!(
        all.iter().all(|r| r.mismatches == Some(0)),
        "oracle mismatches"
    );
    // Random rays do not depend on the camera: the first view traces them, once.
    assert!(a.iter().any(|r| r.ray_kind == "random"));
    assert!(b.iter().all(|r| r.ray_kind != "random"));
    let a: Vec<&Row> = a.into_iter().filter(|r| r.ray_kind != "random").collect();
    assert!(!a.is_empty() && a.len() == b.len() && b.len() == alone.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(key(x), key(y));
        // One build for both views: the same build, so the same build time to the nanosecond.
        assert_eq!(x.build_ms, y.build_ms, "{:?}: built once per view", key(x));
        assert_eq!(x.memory_bytes, y.memory_bytes);
    }
    for (y, z) in b.iter().zip(&alone) {
        // The wide view traces what a table of that camera and light traces.
        assert_eq!(key(y), key(z));
        assert_eq!(counters(y), counters(z), "{:?}", key(y));
    }
    // ... and not what the default view traces.
    assert!(a.iter().zip(&b).any(|(x, y)| counters(x) != counters(y)));
}

#[test]
fn a_table_with_views_is_one_shard_unit_and_merges_back() {
    let t = tempfile::tempdir().unwrap();
    let cfg = t.path().join("views.toml");
    fs::write(&cfg, CONFIG).unwrap();
    let whole = t.path().join("whole");
    assert_eq!(run_quiet(&cfg, &whole), 0);
    let mut dirs = Vec::new();
    for k in 1..=2 {
        let d = t.path().join(format!("s{k}"));
        let shard = format!("{k}/2");
        let args = [
            "run",
            cfg.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "-q",
            "--shard",
            &shard,
        ];
        assert_eq!(run(&args), 0);
        dirs.push(d.to_str().unwrap().to_string());
    }
    // No build of the table runs in two shards: a (table, structure, params) unit's rows,
    // every view's, come from one shard.
    let w = rows(&whole);
    let mut units: Vec<(String, String)> = w
        .iter()
        .filter(|r| r.scene.starts_with("cornell@"))
        .map(|r| (r.structure.clone(), r.params.clone()))
        .collect();
    units.sort();
    units.dedup();
    assert_eq!(units.len(), 3);
    for (st, p) in &units {
        let holders: Vec<&String> = dirs
            .iter()
            .filter(|d| {
                rows(Path::new(d)).iter().any(|r| {
                    r.scene.starts_with("cornell@") && &r.structure == st && &r.params == p
                })
            })
            .collect();
        assert_eq!(holders.len(), 1, "{st} [{p}]");
        let there = rows(Path::new(holders[0]));
        for v in ["cornell@default", "cornell@wide"] {
            assert!(
                there
                    .iter()
                    .any(|r| r.scene == v && &r.structure == st && &r.params == p),
                "{v} {st} [{p}] with the other view"
            );
        }
    }
    let merged = t.path().join("merged");
    let mut a = vec!["merge"];
    a.extend(dirs.iter().map(String::as_str));
    a.extend(["--out", merged.to_str().unwrap()]);
    assert_eq!(run(&a), 0, "merge: every unit present");
    let m = rows(&merged);
    assert_eq!(m.len(), w.len());
    for (x, y) in m.iter().zip(&w) {
        assert_eq!(
            (&x.scene, key(x)),
            (&y.scene, key(y)),
            "merged in run order"
        );
        assert_eq!(counters(x), counters(y));
    }
}

#[test]
fn bad_views_are_refused_with_one_line() {
    let base = |views: &str| {
        format!(
            "name = \"v\"\n[[scene]]\nsource = \"builtin:cornell\"\nviews = {views}\n\
             [[structure]]\nname = \"bvh\"\n"
        )
    };
    for (views, want) in [
        ("[]", "scene.views: needs at least one view"),
        (
            "[{ name = \"a\" }, { name = \"a\", fov = 30 }]",
            "two views are named `a`",
        ),
        ("[{ name = \"a@b\" }]", "scene.views.name"),
        ("[{ fov = 0 }]", "scene.views"),
        ("[{ eye = [0, 0] }]", ":4: scene.views:"),
        ("[{ colour = 1 }]", "colour"),
    ] {
        let e = parse_err(&base(views));
        assert!(e.contains(want), "{views}: {e}");
        assert!(
            e.contains("configs/test.toml"),
            "{views}: names the file: {e}"
        );
        assert_eq!(e.trim().lines().count(), 1, "{views}: one line: {e}");
    }
    // A view of a scene without a default view must give its eye, target and fov.
    let t = tempfile::tempdir().unwrap();
    let obj = t.path().join("tri.obj");
    fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let text = format!(
        "name = \"v\"\n[[scene]]\nsource = {:?}\nviews = [{{ eye = [0, 0, 5], target = [0, 0, 0] }}]\n\
         [[structure]]\nname = \"bvh\"\n",
        obj.to_str().unwrap()
    );
    let e = parse_err(&text);
    assert!(
        e.contains("scene.views.fov") && e.contains("view `1`"),
        "{e}"
    );
}

/// Named views (`views_file`, `view = NAME`): a table or a `views` entry naming a view gets
/// its eye, target, up, fov and light, under what the table or entry gives itself; the
/// project's configs read `configs/views.toml`; unknown names, a missing file, a view
/// without `views_file`, an unknown key and a NaN or infinite number in the views file are
/// refused with one line naming the key.
#[test]
fn named_views_fill_the_camera_under_the_tables_own_keys() {
    use tb_harness::experiment::config::{self, Overrides};
    let t = tempfile::tempdir().unwrap();
    fs::write(
        t.path().join("v.toml"),
        "[far]\neye = [0, 1, 9]\ntarget = [0, 1, 0]\nfov = 30\nlight = [1, 2, 3]\n\
         [near]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\nup = [1, 0, 0]\nfov = 50\n",
    )
    .unwrap();
    let cfg = t.path().join("c.toml");
    let text = "name = \"v\"\nviews_file = \"v.toml\"\n[[scene]]\nsource = \"builtin:cornell\"\n\
                view = \"far\"\ncamera = { width = 8, height = 6, fov = 40 }\n\
                views = [{ view = \"near\" }, { name = \"b\", view = \"near\", light = [4, 5, 6] }, { name = \"c\" }]\n\
                [[structure]]\nname = \"bvh\"\n";
    let exp = config::parse(&cfg, text, &Overrides::default(), &mut |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    let got: Vec<_> = exp
        .scenes
        .iter()
        .map(|s| {
            let c = s.camera.unwrap();
            let l = s.light.map(|l| l.to_array());
            (
                s.label.clone(),
                c.eye.to_array(),
                c.up.to_array(),
                c.fov,
                c.width,
                c.height,
                l,
            )
        })
        .collect();
    assert_eq!(
        got,
        vec![
            (
                "cornell@near".into(),
                [0.0, 1.0, 3.0],
                [1.0, 0.0, 0.0],
                50.0,
                8,
                6,
                Some([1.0, 2.0, 3.0])
            ),
            (
                "cornell@b".into(),
                [0.0, 1.0, 3.0],
                [1.0, 0.0, 0.0],
                50.0,
                8,
                6,
                Some([4.0, 5.0, 6.0])
            ),
            // An entry without a view: the table's camera, its view `far` under the table's fov.
            (
                "cornell@c".into(),
                [0.0, 1.0, 9.0],
                [0.0, 1.0, 0.0],
                40.0,
                8,
                6,
                Some([1.0, 2.0, 3.0])
            ),
        ]
    );
    assert!(exp
        .views
        .as_ref()
        .is_some_and(|v| v.text.contains("[near]")));
    for (edit, want) in [
        (
            ("view = \"far\"", "view = \"nowhere\""),
            "scene.view: no view `nowhere` in the views file (it has: far, near)",
        ),
        (
            ("{ view = \"near\" }", "{ view = \"x\" }"),
            "scene.views.view: no view `x`",
        ),
        (
            ("views_file = \"v.toml\"", "views_file = \"none.toml\""),
            "views_file: cannot read",
        ),
        (
            ("views_file = \"v.toml\"", ""),
            "scene.view: names a view, but the config has no `views_file`",
        ),
    ] {
        let e = config::parse(
            &cfg,
            &text.replace(edit.0, edit.1),
            &Overrides::default(),
            &mut |_| {},
        )
        .err()
        .unwrap_or_else(|| panic!("{edit:?} should be refused"))
        .to_string();
        assert!(e.contains(want), "{edit:?}: {e}");
        assert_eq!(e.trim().lines().count(), 1, "{edit:?}: one line: {e}");
    }
    // A views file with an unknown key names that file and its line.
    fs::write(
        t.path().join("v.toml"),
        "[far]\neye = [0, 1, 9]\ntarget = [0, 1, 0]\nfov = 30\nzoom = 2\n",
    )
    .unwrap();
    let e = config::parse(&cfg, text, &Overrides::default(), &mut |_| {})
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("v.toml") && e.contains("zoom"), "{e}");
    // A NaN or infinite number in the views file is refused naming that file and its key.
    for bad in ["nan", "inf", "-inf"] {
        fs::write(
            t.path().join("v.toml"),
            format!("[far]\neye = [0, 1, 9]\ntarget = [0, 1, 0]\nfov = {bad}\n[near]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\n"),
        )
        .unwrap();
        let e = config::parse(&cfg, text, &Overrides::default(), &mut |_| {})
            .err()
            .unwrap_or_else(|| panic!("fov = {bad} should be refused"))
            .to_string();
        assert!(e.contains("v.toml") && e.contains("fov"), "{bad}: {e}");
        assert_eq!(e.trim().lines().count(), 1, "{bad}: one line: {e}");
    }
    // The project's configs name their paper scenes' views from configs/views.toml.
    let views = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/views.toml");
    let named: toml::Table = toml::from_str(&fs::read_to_string(views).unwrap()).unwrap();
    assert!(["bunny", "sibenik", "conference", "sponza"]
        .iter()
        .all(|v| named.contains_key(*v)));
}
