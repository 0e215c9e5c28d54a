//! The stress scenes and the conformance suite itself: scenes load with valid own rays, brute
//! force conforms (plumbing), a broken structure is caught, and the watertight scene's rays
//! all hit with the watertight test.

use std::path::Path;
use tb_core::{
    compare_closest, Accel, AccelError, Answers, Batch, BruteForce, HitRecord, MemoryReport, Query,
    Structure, Traversal, TraversalInfo, TriTestKind, Triangle,
};
use tb_scene::conformance::{self, assert_conforms, check};
use tb_scene::rays::trace_all;
use tb_scene::stress::{self, valid_ray};

fn load(name: &str) -> tb_scene::Scene {
    tb_scene::load(&format!("builtin:{name}"), Path::new("."))
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn every_stress_scene_loads_with_valid_own_rays() {
    assert!(stress::LIST.len() >= 9);
    for info in stress::LIST {
        let s = load(info.name);
        assert_eq!(s.source, format!("builtin:{}", info.name));
        assert!(!s.triangles.is_empty(), "{}", info.name);
        assert!(s.triangles.len() <= 20_000, "{}", info.name);
        assert!(!s.own_rays.is_empty(), "{}: no own rays", info.name);
        assert!(s.own_rays.iter().all(valid_ray), "{}", info.name);
        assert!(s
            .own_rays
            .iter()
            .all(|r| r.origin.is_finite() && r.dir.is_finite()));
        let view = s.view.as_ref().expect("stress scenes have a view");
        view.camera.check().unwrap();
        assert!(view.ao_distance > 0.0 && view.ao_distance.is_finite());
        println!(
            "{:<28} {:>6} triangles ({:>3} degenerate) {:>6} own rays",
            info.name,
            s.triangles.len(),
            s.degenerate_count(),
            s.own_rays.len()
        );
        // Deterministic.
        assert_eq!(load(info.name).own_rays, s.own_rays);
    }
    // Parameters.
    let a = load("stress/translated?offset=1000&seed=2");
    assert!(a.bounds.min.x > 990.0);
    let b = load("stress/scaled-huge?scale=1000");
    assert!(b.bounds.max.x > 900.0 && b.bounds.max.x < 3000.0);
    assert!(tb_scene::load("builtin:stress/nested?levels=9", Path::new(".")).is_err());
    assert!(tb_scene::load("builtin:stress/flat?bogus=1", Path::new(".")).is_err());
    assert!(tb_scene::load("builtin:stress/nope", Path::new(".")).is_err());
}

#[test]
fn brute_force_conforms() {
    assert_conforms(&|t| Box::new(BruteForce::new(t)));
}

/// Brute force that ignores every 7th triangle and misses rays with `dir.x == 0`.
struct Broken(BruteForce);

/// Brute force, then every ray with `dir.x == 0` turned into a miss.
fn broken_trace(b: &Broken, batch: Batch<'_>, mut out: Answers<'_>) {
    b.0.trace(0, batch, out.reborrow());
    for (r, h) in batch.rays.iter().zip(out.hits.iter_mut()) {
        if r.dir.x == 0.0 {
            *h = HitRecord::MISS;
        }
    }
}

impl Structure for Broken {
    const NAME: &'static str = "broken";
    const TRAVERSALS: &'static [Traversal<Self>] = &[
        Traversal::cpu(
            TraversalInfo::new("broken-a", "none", "drops triangles"),
            broken_trace,
        ),
        Traversal::cpu(
            TraversalInfo::new("broken-b", "none", "the same"),
            broken_trace,
        ),
    ];
    fn own_memory(&self) -> MemoryReport {
        MemoryReport::default()
    }
}

fn broken(t: &[Triangle]) -> Box<dyn Accel> {
    let kept: Vec<Triangle> = t
        .iter()
        .enumerate()
        .map(|(i, &tri)| {
            if i % 7 == 3 {
                Triangle::new(tri.v0, tri.v0, tri.v0)
            } else {
                tri
            }
        })
        .collect();
    Box::new(Broken(BruteForce::new(&kept)))
}

#[test]
fn a_broken_structure_is_caught() {
    let results = check(&broken, TriTestKind::Watertight);
    let total: usize = results.iter().map(|r| r.mismatches).sum();
    assert!(total > 0);
    // Every traversal is checked, and the failure report names rays exactly.
    assert!(results
        .iter()
        .any(|r| r.traversal == "broken-b" && r.mismatches > 0));
    let report = conformance::format_failures(&results);
    assert!(report.contains("0x") && report.contains("expected"));
    // Zero-x directions only occur in the stress rays of the axis-aligned scenes.
    assert!(results
        .iter()
        .any(|r| r.scene == "stress/axis-planes" && r.ray_kind == "stress" && r.mismatches > 0));
    println!("{}", conformance::format_table(&results));
    let one = vec![load("stress/axis-planes")];
    let caught = std::panic::catch_unwind(|| conformance::assert_conforms_scenes(&one, &broken));
    assert!(caught.is_err(), "assert_conforms must panic");
}

struct Invalid(BruteForce);

impl Structure for Invalid {
    const NAME: &'static str = "invalid";
    const TRAVERSALS: &'static [Traversal<Self>] = &[Traversal::cpu(
        TraversalInfo::new("linear", "none", "brute force"),
        tb_core::kernel!(|v: &Invalid, batch, out| v.0.trace(0, batch, out)),
    )];
    fn own_memory(&self) -> MemoryReport {
        MemoryReport::default()
    }
    fn check(&self) -> Result<(), AccelError> {
        Err(AccelError::Invalid("node 3 out of bounds".into()))
    }
}

#[test]
#[should_panic(expected = "node 3 out of bounds")]
fn validate_errors_panic() {
    let scenes = vec![load("stress/duplicates")];
    conformance::check_scenes(
        &scenes,
        &|t| Box::new(Invalid(BruteForce::new(t))),
        TriTestKind::Watertight,
    );
}

#[test]
fn watertight_scene_every_ray_hits() {
    let s = load("stress/watertight");
    let bf = BruteForce::new(&s.triangles);
    let wt = trace_all(&bf, Query::Closest, TriTestKind::Watertight, &s.own_rays);
    let missed: Vec<usize> = (0..wt.len()).filter(|&i| !wt[i].is_hit()).collect();
    assert!(
        missed.is_empty(),
        "{} of {} rays slipped through with the watertight test, first {}",
        missed.len(),
        wt.len(),
        conformance::format_ray(&s.own_rays[missed[0]])
    );
    // Möller–Trumbore: rays that miss entirely, and rays that slip through the entry edge or
    // vertex to a farther triangle (the back of the mesh or the other mesh).
    let mt = trace_all(
        &bf,
        Query::Closest,
        TriTestKind::MollerTrumbore,
        &s.own_rays,
    );
    let mt_missed = mt.iter().filter(|h| !h.is_hit()).count();
    let mt_slipped = wt
        .iter()
        .zip(&mt)
        .zip(&s.own_rays)
        .filter(|((w, m), r)| compare_closest(r, w, m).is_some())
        .count();
    println!(
        "stress/watertight: {} own rays, watertight misses 0; moller-trumbore misses {mt_missed}, \
         slips through the entry hit on {mt_slipped}",
        s.own_rays.len()
    );
}

/// Reported, not asserted: how often Möller–Trumbore's answer differs from the watertight
/// test's on each stress scene's own rays.
#[test]
fn moller_trumbore_differences_reported() {
    for info in stress::LIST {
        let s = load(info.name);
        let bf = BruteForce::new(&s.triangles);
        let wt = trace_all(&bf, Query::Closest, TriTestKind::Watertight, &s.own_rays);
        let mt = trace_all(
            &bf,
            Query::Closest,
            TriTestKind::MollerTrumbore,
            &s.own_rays,
        );
        let differ = wt
            .iter()
            .zip(&mt)
            .zip(&s.own_rays)
            .filter(|((w, m), r)| compare_closest(r, w, m).is_some())
            .count();
        let mt_miss = wt
            .iter()
            .zip(&mt)
            .filter(|(w, m)| w.is_hit() && !m.is_hit())
            .count();
        let hits = wt.iter().filter(|h| h.is_hit()).count();
        println!(
            "{:<28} {:>6} own rays, {:>6} hit (watertight); moller-trumbore differs on {differ} ({mt_miss} missed)",
            info.name,
            s.own_rays.len(),
            hits
        );
    }
}
