//! The build cache (`tb_harness::experiment::cache`): a loaded structure is the structure a
//! fresh build makes (the same bytes, the same answers and counters on the stress scenes), a
//! second run loads every build, and a corrupt, truncated or swapped entry is rebuilt with a
//! note, never used.

mod common;

use common::deterministic;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tb_core::{Accel, Answers, Batch, HitRecord, ParamSet, Query, TraversalStats, Triangle};
use tb_harness::experiment::cache::{self, BuildCache, Lookup};
use tb_harness::experiment::config::{self, Overrides};
use tb_harness::experiment::runner::{self, RunOptions, RunSummary};
use tb_harness::registry::Registry;

/// Every family that can be saved, with parameter sets that reach each of its layouts.
const STRUCTURES: &str = r#"
[[structure]]
name = "bvh"
params = { builder = ["binned", "sbvh"], width = [2, 8] }

[[structure]]
name = "bvh"
params = { width = 4, leaf_cost = "linear" }

[[structure]]
name = "cwbvh"

[[structure]]
name = "rtree"
params = { strategy = ["r-star", "str"] }

[[structure]]
name = "kdtree"
params = { layout = ["depth-first", "treelet"] }

[[structure]]
name = "sparse-boxes"
params = { d_min = 2 }

[[structure]]
name = "multi-kd"
params = { measure = ["sphere-orth", "sah"] }

[[structure]]
name = "uniform-grid"
params = { macro_regions = [false, true] }

[[structure]]
name = "two-level-grid"

[[structure]]
name = "irregular-grid"
params = { expansion = [0, 2], precision = ["f32", "f64"] }
"#;

fn config() -> String {
    format!(
        "name = \"cache\"\n[run]\nthreads = 1\nrepeat = 1\nwarmup = 0\n\n\
         [[scene]]\nsource = \"builtin:stress/near-surfaces\"\nrays = [\"primary\", \"random\"]\n\
         camera = {{ width = 24, height = 24 }}\nrandom = {{ count = 512 }}\n\n\
         [[scene]]\nsource = \"builtin:soup?count=400&seed=3\"\nrays = [\"random\"]\n\
         random = {{ count = 512 }}\n{STRUCTURES}"
    )
}

fn run(dir: &Path, out: &Path, cache: Option<&Path>) -> RunSummary {
    run_config(dir, out, cache, &config())
}

fn run_config(dir: &Path, out: &Path, cache: Option<&Path>, text: &str) -> RunSummary {
    let exp = config::parse(
        &dir.join("cache.toml"),
        text,
        &Overrides::default(),
        &mut |_| {},
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let mut opts = RunOptions::quiet(out.to_path_buf());
    opts.cache = cache.map(|c| BuildCache::new(c.to_path_buf(), 1024));
    let s = runner::run(&exp, &opts).unwrap();
    assert!(s.failures.is_empty(), "{:?}", s.failures);
    assert!(s.wrong_rows.is_empty(), "{:?}", s.wrong_rows);
    s
}

/// The cache's structure entries (`oracle: false`) or oracle answers (`true`).
fn entries_of(dir: &Path, oracle: bool) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "tbc"))
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("oracle-")
                == oracle
        })
        .collect();
    v.sort();
    v
}

fn entries(dir: &Path) -> Vec<PathBuf> {
    entries_of(dir, false)
}

#[test]
fn a_second_run_loads_every_build_and_counts_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let cache_dir = dir.path().join("cache");
    let first = run(dir.path(), &dir.path().join("a"), Some(&cache_dir));
    let builds = entries(&cache_dir).len();
    assert!(builds >= 20, "{builds} entries");
    // Fresh the first time, but for the sparse boxes: their kd-tree (the first stage) is the
    // kdtree table's depth-first build, loaded from the cache.
    assert!(first
        .rows
        .iter()
        .all(|r| r.build_cached == Some(r.structure == "sparse-boxes")));
    let second = run(dir.path(), &dir.path().join("b"), Some(&cache_dir));
    assert!(
        second.rows.iter().all(|r| r.build_cached == Some(true)),
        "{:?}",
        second.notes
    );
    let note = second
        .notes
        .iter()
        .find(|n| n.starts_with("build cache "))
        .expect("the cache's note");
    assert!(
        note.contains(&format!("{builds} structures loaded, 0 built")),
        "{note} ({builds} entries)"
    );
    // results.json says what the cache did and where the time went (`meta.build_cache`,
    // `meta.phases`): every build loaded the second time, none the first; without the
    // cache every build is made again.
    let meta = |run: &str| -> serde_json::Value {
        let t = std::fs::read_to_string(dir.path().join(run).join("results.json")).unwrap();
        serde_json::from_str::<serde_json::Value>(&t).unwrap()["meta"].clone()
    };
    let cache_of = |run: &str| {
        let c = meta(run)["build_cache"].clone();
        (
            c["used"].as_bool(),
            c["loaded"].as_u64(),
            c["built"].as_u64(),
        )
    };
    let n = builds as u64;
    assert_eq!(cache_of("a"), (Some(true), Some(0), Some(n)));
    assert_eq!(cache_of("b"), (Some(true), Some(n), Some(0)));
    // The oracle's answers too: computed by the first run (one entry per validated batch),
    // loaded by the second.
    let oracle_of = |run: &str| {
        let c = meta(run)["build_cache"].clone();
        (c["oracle_loaded"].as_u64(), c["oracle_computed"].as_u64())
    };
    let samples = entries_of(&cache_dir, true).len() as u64;
    assert!(samples >= 3, "{samples} oracle entries");
    assert_eq!(oracle_of("a"), (Some(0), Some(samples)));
    assert_eq!(oracle_of("b"), (Some(samples), Some(0)));
    for run in ["a", "b"] {
        let p = meta(run)["phases"].clone();
        let f = |k: &str| {
            p[k].as_f64()
                .unwrap_or_else(|| panic!("{run}: no phases.{k}: {p}"))
        };
        let named: f64 = [
            "load_s",
            "rays_s",
            "build_s",
            "oracle_s",
            "count_s",
            "validate_s",
        ]
        .iter()
        .chain(&["trace_s", "gpu_s", "other_s"])
        .map(|k| f(k))
        .sum();
        assert!(
            f("build_s") > 0.0 && f("trace_s") > 0.0 && f("count_s") > 0.0,
            "{p}"
        );
        assert!(
            (named - f("total_s")).abs() < 0.01,
            "{run}: {named} against {p}"
        );
    }
    // Without the cache, the same rows.
    let fresh = run(dir.path(), &dir.path().join("c"), None);
    assert_eq!(cache_of("c"), (Some(false), Some(0), Some(n)));
    assert_eq!(fresh.rows.len(), second.rows.len());
    for (a, b) in fresh.rows.iter().zip(&second.rows) {
        assert_eq!(deterministic(a), deterministic(b));
        assert_eq!(a.build_cached, Some(false));
    }
    // A loaded build replays its build's figures, the structure's memory is the same.
    for (a, b) in first.rows.iter().zip(&second.rows) {
        assert_eq!(a.build_heap_kept_bytes, b.build_heap_kept_bytes);
        assert_eq!(a.memory_bytes, b.memory_bytes);
    }
}

/// A run that times its builds (`run.build_repeat` above 1) builds fresh every time but for
/// the tables that say `time_builds = false`: those are loaded from the cache, built once.
#[test]
fn timed_builds_are_fresh_but_for_the_tables_that_opt_out() {
    let dir = tempfile::tempdir().unwrap();
    let cache_dir = dir.path().join("cache");
    let text = "name = \"timed\"\n[run]\nthreads = 1\nrepeat = 1\nwarmup = 0\nbuild_repeat = 2\n\n\
                [[scene]]\nsource = \"builtin:soup?count=300&seed=5\"\nrays = [\"random\"]\n\
                random = { count = 256 }\n\n\
                [[structure]]\nname = \"bvh\"\ntime_builds = false\n\n\
                [[structure]]\nname = \"rtree\"\nparams = { strategy = \"str\" }\n";
    let cached = |s: &RunSummary, structure: &str| -> Vec<Option<bool>> {
        s.rows
            .iter()
            .filter(|r| r.structure == structure)
            .map(|r| r.build_cached)
            .collect()
    };
    let first = run_config(dir.path(), &dir.path().join("a"), Some(&cache_dir), text);
    // Only the untimed table's build is saved (a timed build is saved too, but never loaded).
    assert!(cached(&first, "bvh").iter().all(|c| *c == Some(false)));
    let second = run_config(dir.path(), &dir.path().join("b"), Some(&cache_dir), text);
    let (bvh, rtree) = (cached(&second, "bvh"), cached(&second, "rtree"));
    assert!(
        !bvh.is_empty() && bvh.iter().all(|c| *c == Some(true)),
        "{bvh:?}"
    );
    assert!(
        !rtree.is_empty() && rtree.iter().all(|c| *c == Some(false)),
        "{rtree:?}"
    );
    // The timed table is built build_repeat times, the untimed one once.
    let runs = |structure: &str| {
        let r = second
            .rows
            .iter()
            .find(|r| r.structure == structure)
            .unwrap();
        r.build_ms_runs.split(';').count()
    };
    assert_eq!((runs("bvh"), runs("rtree")), (1, 2));
}

/// A structure built in two stages ([`tb_core::Stage`]: sparse boxes over a kd-tree) builds
/// its first stage once for every parameter set that shares it, and makes the rows a run
/// without the cache makes.
#[test]
fn a_first_stage_is_built_once_for_the_builds_that_share_it() {
    let dir = tempfile::tempdir().unwrap();
    let cache_dir = dir.path().join("cache");
    let text = "name = \"staged\"\n[run]\nthreads = 1\nrepeat = 1\nwarmup = 0\n\n\
                [[scene]]\nsource = \"builtin:stress/near-surfaces\"\nrays = [\"primary\", \"random\"]\n\
                camera = { width = 16, height = 16 }\nrandom = { count = 256 }\n\n\
                [[structure]]\nname = \"sparse-boxes\"\nparams = { d_min = [1, 3, 6] }\n";
    let staged = run_config(dir.path(), &dir.path().join("a"), Some(&cache_dir), text);
    let meta = |run: &str| -> serde_json::Value {
        let t = std::fs::read_to_string(dir.path().join(run).join("results.json")).unwrap();
        serde_json::from_str::<serde_json::Value>(&t).unwrap()["meta"]["build_cache"].clone()
    };
    // Three sparse-boxes entries and one kd-tree: built for d_min = 1, loaded for 3 and 6.
    let names: Vec<String> = entries(&cache_dir)
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    let count = |f: &str| names.iter().filter(|n| n.starts_with(f)).count();
    assert_eq!(
        (count("sparse-boxes-"), count("kdtree-")),
        (3, 1),
        "{names:?}"
    );
    assert_eq!(meta("a")["stages_loaded"].as_u64(), Some(2));
    let by_d = |s: &RunSummary, d: &str| -> Vec<Option<bool>> {
        s.rows
            .iter()
            .filter(|r| r.params.contains(&format!("d_min={d};")))
            .map(|r| r.build_cached)
            .collect()
    };
    assert!(by_d(&staged, "1").iter().all(|c| *c == Some(false)));
    for d in ["3", "6"] {
        let v = by_d(&staged, d);
        assert!(
            !v.is_empty() && v.iter().all(|c| *c == Some(true)),
            "{d}: {v:?}"
        );
    }
    // Without the cache every build is whole (no stage), and the rows are the same.
    let whole = run_config(dir.path(), &dir.path().join("b"), None, text);
    assert_eq!(meta("b")["stages_loaded"].as_u64(), Some(0));
    assert_eq!(whole.rows.len(), staged.rows.len());
    for (a, b) in whole.rows.iter().zip(&staged.rows) {
        assert_eq!(deterministic(a), deterministic(b));
        assert_eq!(a.build_stats, b.build_stats);
        assert_eq!(a.memory_bytes, b.memory_bytes);
    }
}

#[test]
fn corrupt_truncated_and_swapped_entries_are_rebuilt_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let cache_dir = dir.path().join("cache");
    run(dir.path(), &dir.path().join("a"), Some(&cache_dir));
    let e = entries(&cache_dir);
    assert!(e.len() >= 6);
    // One byte flipped in the middle; cut in half; another build's entry under this name.
    let mut b = std::fs::read(&e[0]).unwrap();
    let mid = b.len() / 2;
    b[mid] ^= 0x10;
    std::fs::write(&e[0], b).unwrap();
    let b = std::fs::read(&e[1]).unwrap();
    std::fs::write(&e[1], &b[..b.len() / 2]).unwrap();
    std::fs::copy(&e[3], &e[2]).unwrap();
    // An oracle entry with a flipped byte, and one holding another sample's answers.
    let o = entries_of(&cache_dir, true);
    assert!(o.len() >= 3);
    let mut b = std::fs::read(&o[0]).unwrap();
    let mid = b.len() / 2;
    b[mid] ^= 0x01;
    std::fs::write(&o[0], b).unwrap();
    std::fs::copy(&o[2], &o[1]).unwrap();
    let s = run(dir.path(), &dir.path().join("b"), Some(&cache_dir));
    for (path, why) in [(&o[0], "checksum mismatch"), (&o[1], "holds another build")] {
        let file = path.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            s.notes
                .iter()
                .any(|n| n.contains(&file) && n.contains(why) && n.ends_with("computed again")),
            "{file}: {why}: {:#?}",
            s.notes
        );
    }
    // Computed again, the rows' validation is what a fresh oracle gives.
    let fresh = run(dir.path(), &dir.path().join("fresh"), None);
    for (a, b) in fresh.rows.iter().zip(&s.rows) {
        assert_eq!(
            (a.validated_rays, a.mismatches),
            (b.validated_rays, b.mismatches)
        );
    }
    let name = |p: &Path| p.file_name().unwrap().to_string_lossy().into_owned();
    for (path, why) in [
        (&e[0], "checksum mismatch"),
        (&e[1], "checksum mismatch"),
        (&e[2], "holds another build"),
    ] {
        assert!(
            s.notes
                .iter()
                .any(|n| n.contains(&name(path)) && n.contains(why) && n.ends_with("rebuilt")),
            "{}: {why}: {:#?}",
            name(path),
            s.notes
        );
    }
    let rebuilt = s
        .rows
        .iter()
        .filter(|r| r.build_cached == Some(false))
        .count();
    assert!(rebuilt > 0 && rebuilt < s.rows.len(), "{rebuilt}");
    // Rebuilt and saved again: a third run loads everything.
    let t = run(dir.path(), &dir.path().join("c"), Some(&cache_dir));
    assert!(t.rows.iter().all(|r| r.build_cached == Some(true)));
    assert!(
        !t.notes.iter().any(|n| n.contains("rebuilt")),
        "{:?}",
        t.notes
    );
}

/// Random rays through the scene's box (a quarter from inside it).
fn rays(tris: &[Triangle], n: usize) -> Vec<tb_core::Ray> {
    let b = tris
        .iter()
        .fold(tb_core::Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|i| {
            let ext = b.max - b.min;
            let grow = if i % 4 == 0 { 0.5 } else { 2.0 };
            let c = (b.min + b.max) * 0.5;
            let o = c + (tb_core::Vec3::new(next(), next(), next()) - 0.5) * ext * grow;
            let t = b.min + tb_core::Vec3::new(next(), next(), next()) * ext;
            tb_core::Ray::new(o, (t - o).normalize_or_zero())
        })
        .collect()
}

fn trace(a: &dyn Accel, ti: usize, rays: &[tb_core::Ray]) -> String {
    let mut hits = vec![HitRecord::MISS; rays.len()];
    let mut stats = vec![TraversalStats::default(); rays.len()];
    let batch = Batch::new(Query::Closest, tb_core::TriTestKind::Watertight, rays);
    let hints = a.batch_hints(ti, Query::Closest, rays);
    a.trace(
        ti,
        batch.with_hints(hints.as_deref()),
        Answers::new(&mut hits, Some(&mut stats)),
    );
    format!("{hits:?}{stats:?}")
}

/// For every family with a codec, on every stress scene: saved and loaded, a build encodes to
/// the same bytes and answers every traversal's rays with the same hits and counters.
#[test]
fn a_loaded_structure_is_the_fresh_build() {
    let registry = Registry::builtin();
    let scenes = tb_scene::conformance::suite_scenes();
    let mut tried = HashMap::new();
    for scene in scenes.iter().filter(|s| s.source.contains("stress/")) {
        let tris: Arc<[Triangle]> = scene.triangles.clone().into();
        let rays = rays(&tris, 256);
        for family in registry.families() {
            let Some(codec) = family.codec else { continue };
            let params: ParamSet = (family.defaults)();
            let built = (family.build)(&tris, &params).unwrap();
            let bytes = (codec.save)(built.as_ref()).unwrap();
            let loaded = (codec.load)(&bytes, &tris, &params).unwrap();
            loaded.validate().unwrap();
            assert_eq!(
                (codec.save)(loaded.as_ref()).unwrap(),
                bytes,
                "{}",
                family.name
            );
            for ti in 0..built.traversals().len() {
                built.prepare(ti);
                loaded.prepare(ti);
                assert_eq!(
                    trace(built.as_ref(), ti, &rays),
                    trace(loaded.as_ref(), ti, &rays),
                    "{} {} on {}",
                    family.name,
                    built.traversals()[ti].name,
                    scene.source
                );
            }
            *tried.entry(family.name).or_insert(0) += 1;
        }
    }
    assert!(tried.len() >= 9, "{tried:?}");
    // Another family's codec refuses the structure.
    let tris: Arc<[Triangle]> = scenes[0].triangles.clone().into();
    let bvh = registry.find("bvh").unwrap();
    let kd = registry.find("kdtree").unwrap();
    let built = (bvh.build)(&tris, &(bvh.defaults)()).unwrap();
    assert!((kd.codec.unwrap().save)(built.as_ref()).is_err());
}

/// The cache's look-up by key: a miss, a hit, and an entry of another scene's triangles never
/// found under this scene's key.
#[test]
fn the_key_is_the_content() {
    let dir = tempfile::tempdir().unwrap();
    let c = BuildCache::new(dir.path().to_path_buf(), 64);
    let registry = Registry::builtin();
    let family = registry.find("kdtree").unwrap();
    let codec = family.codec.unwrap();
    let scenes = tb_scene::conformance::suite_scenes();
    let a: Arc<[Triangle]> = scenes[0].triangles.clone().into();
    let mut moved = scenes[0].triangles.clone();
    moved[0].v0.x = f32::from_bits(moved[0].v0.x.to_bits() ^ 1);
    let b: Arc<[Triangle]> = moved.into();
    let p = (family.defaults)();
    let ka = cache::key(family, &p, &a);
    assert!(matches!(c.load(&ka, &codec, &a, &p), Lookup::Miss));
    let built = (family.build)(&a, &p).unwrap();
    let figures = cache::BuildFigures {
        runs_ms: vec![1.0],
        heap: None,
    };
    c.store(&ka, &codec, built.as_ref(), figures.clone())
        .unwrap();
    match c.load(&ka, &codec, &a, &p) {
        Lookup::Hit(h) => assert_eq!(h.figures, figures),
        _ => panic!("no hit"),
    }
    let kb = cache::key(family, &p, &b);
    assert!(matches!(c.load(&kb, &codec, &b, &p), Lookup::Miss));
}
