//! Every registered structure's GPU programs against the CPU: for every family of the registry
//! (built with its default parameters) and every traversal whose build hands a GPU program
//! ([`tb_core::Accel::gpu_program`]), on every conformance-suite scene (the stress scenes and
//! the small procedural ones) and every ray kind, the GPU must answer as the CPU oracle does
//! (`tb_core::compare`), and its hits and per-ray counters must equal the same traversal's on
//! the CPU ray for ray. The Stanford Bunny (paper scenes) is checked the same way on random
//! rays. Each suite prints the (family, traversal) pairs it checked and fails when there were
//! none, so it cannot pass by finding no program. Without an adapter the tests print a notice
//! and pass, unless `TRACE_BENCH_REQUIRE_GPU=1`, which makes them fail.
//!
//! Tolerance: with the watertight test on an adapter with `SHADER_F64` (its exact-zero
//! fallback in f64 as on the CPU) the GPU must repeat the CPU bit for bit (hits and counters
//! of every ray); lavapipe on Vulkan does. Otherwise it may not: Vulkan and GL let a driver
//! contract `a*b + c` into one FMA (naga emits no `NoContraction`), and lavapipe does in the
//! Möller–Trumbore test's cross and dot products on Vulkan (a CPU emulation with
//! `f32::mul_add` reproduces the GPU's answers) and in both tests on GL, which also lacks
//! f64; a ray grazing an edge may then hit or miss a triangle the CPU missed or hit. Those
//! rays are counted and printed, and may be at most [`DIFF_SHARE`] of a batch, with no more
//! oracle mismatches than the CPU's own plus that share. Programs that compute in f64
//! ([`tb_core::GpuProgram::needs_f64`], the grids' with `precision = "f64"`; the default
//! grid walks are f32) are refused on such an adapter and printed as not checked, as are
//! programs using subgroups on an adapter without them. A program whose counters are its own
//! ([`tb_core::GpuProgram::own_counts`]: the BVH's speculative `while-while`, whose walk
//! depends on the other rays of its subgroup; the compressed wide BVH's triangle postponing)
//! must answer as the oracle does and give the CPU walk's answers within the oracle's tolerance
//! (`tb_core::compare`: its triangles are tested in another order); its counters are not
//! compared.

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::sync::Arc;
use tb_core::{compare, Accel, BruteForce, Family, HitRecord, Query, Ray, TriTestKind, Triangle};
use tb_gpu::{open_or_skip, Gpu, GpuStructure};
use tb_scene::conformance;

/// The oracle (brute force on the CPU) costs `rays x triangles` tests, and so does a program
/// whose loop runs over every triangle ([`tb_core::GpuProgram::unrolled_triangle_loop`]):
/// their batches are sampled evenly down to this budget so the suite stays fast on lavapipe.
/// Every other program runs on every ray (compared with its CPU traversal on every ray, with
/// the oracle on the sample).
const BRUTE_BUDGET: usize = 20_000_000;

/// Where the GPU cannot repeat the CPU bit for bit (see the module doc): the share of a batch
/// whose GPU answer (primitive hit) or counters may differ from the CPU's; `t`, `u`, `v` may
/// then differ in their last bits on any ray. The most seen on lavapipe: 1.3%
/// (Möller–Trumbore, stress scene `watertight`, whose rays all aim at shared edges; Vulkan).
const DIFF_SHARE: f64 = 0.02;

/// The families checked: every registered one.
fn families() -> Vec<&'static Family> {
    tb_harness::registry::families().to_vec()
}

use tb_core::par::count as cpu_trace;

/// Indices of an even sample of at most `max` of `n` rays.
fn sample(n: usize, max: usize) -> Vec<usize> {
    if n <= max {
        return (0..n).collect();
    }
    (0..max).map(|i| i * n / max).collect()
}

/// One traversal with a GPU program, uploaded for one scene.
struct Program<'a> {
    /// `family/traversal`.
    label: String,
    accel: &'a dyn Accel,
    traversal: usize,
    gpu: GpuStructure,
    /// Runs on the sample only (its loop runs over every triangle).
    sampled: bool,
    /// Its counters are its own (`GpuProgram::own_counts`): not compared.
    own_counts: bool,
}

/// Differences of one (program, batch) case.
#[derive(Default)]
struct Diff {
    rays: usize,
    /// Rays compared with the oracle.
    validated: usize,
    /// Rays whose GPU answer mismatches the oracle.
    mismatches: usize,
    /// Rays whose CPU answer (same traversal and test) mismatches the oracle.
    cpu_mismatches: usize,
    /// Rays whose answer (primitive, or hit vs miss) or counters differ between GPU and CPU.
    differing: usize,
    /// Rays whose GPU counters differ from the CPU's.
    counter_diffs: usize,
    /// Rays whose GPU hit record is not bit-identical to the CPU traversal's.
    hit_diffs: usize,
    /// The first rays that differ (at most 3), oracle mismatches first.
    first: Vec<String>,
    /// How many of `first` mismatch the oracle.
    shown_mismatches: usize,
}

fn check_case(
    gpu: &Gpu,
    p: &Program<'_>,
    oracle: &[Option<HitRecord>],
    query: Query,
    tri: TriTestKind,
    rays: &[Ray],
) -> Diff {
    let (want_hits, want_stats) = cpu_trace(p.accel, p.traversal, query, tri, rays);
    let (hits, stats) = gpu
        .trace_once(&p.gpu, rays, query, tri, true)
        .unwrap_or_else(|e| panic!("{}: {e}", p.label));
    let (timed_hits, _) = gpu
        .trace_once(&p.gpu, rays, query, tri, false)
        .unwrap_or_else(|e| panic!("{}: {e}", p.label));
    let stats = stats.expect("counting pass returns counters");
    let mut d = Diff {
        rays: rays.len(),
        ..Default::default()
    };
    for i in 0..rays.len() {
        assert_eq!(
            hits[i], timed_hits[i],
            "{} ray {i}: the timed and counting variants disagree",
            p.label
        );
        let mut bad_oracle = false;
        if let Some(o) = &oracle[i] {
            d.validated += 1;
            bad_oracle = compare(query, &rays[i], o, &hits[i]).is_some();
            d.cpu_mismatches += compare(query, &rays[i], o, &want_hits[i]).is_some() as usize;
        }
        // A program with counters of its own (speculative traversal, triangle postponing): the
        // CPU walk's answer within the oracle's tolerance, as its triangles are tested in
        // another order (of two at one distance, or a vertex's two a hair apart, the first
        // tested is kept; an any-hit walk may meet another hit first).
        let (bad_stats, bad_hit) = if p.own_counts {
            (
                false,
                compare(query, &rays[i], &want_hits[i], &hits[i]).is_some(),
            )
        } else {
            (stats[i] != want_stats[i], hits[i] != want_hits[i])
        };
        d.mismatches += bad_oracle as usize;
        d.counter_diffs += bad_stats as usize;
        d.hit_diffs += bad_hit as usize;
        d.differing += (bad_stats || (!p.own_counts && hits[i].prim != want_hits[i].prim)) as usize;
        // Oracle mismatches first (before rays that only differ from the CPU in their bits).
        let shown = d.first.len() < 3 || (bad_oracle && d.shown_mismatches < 3);
        if (bad_oracle || bad_stats || bad_hit) && shown {
            let line = format!(
                "ray {i} {}: oracle {} cpu {:?} gpu {:?} cpu stats {:?} gpu stats {:?}",
                conformance::format_ray(&rays[i]),
                oracle[i].map_or("-".to_string(), |o| format!("{o:?}")),
                want_hits[i],
                hits[i],
                want_stats[i],
                stats[i]
            );
            if bad_oracle {
                d.first.insert(d.shown_mismatches, line);
                d.shown_mismatches += 1;
            } else {
                d.first.push(line);
            }
            d.first.truncate(3);
        }
    }
    d
}

/// Build every family on a scene and check each GPU program on every batch of `batches`;
/// adds the programs checked to `checked` and returns failure lines.
fn check_scene(
    gpu: &Gpu,
    name: &str,
    tris: &[Triangle],
    batches: &[(String, Query, Vec<Ray>)],
    tri: TriTestKind,
    checked: &mut BTreeSet<String>,
) -> Vec<String> {
    check_scene_of(gpu, name, tris, batches, tri, checked, &|_| true)
}

/// [`check_scene`] for the programs whose label (`family/traversal`) `keep` accepts.
fn check_scene_of(
    gpu: &Gpu,
    name: &str,
    tris: &[Triangle],
    batches: &[(String, Query, Vec<Ray>)],
    tri: TriTestKind,
    checked: &mut BTreeSet<String>,
    keep: &dyn Fn(&str) -> bool,
) -> Vec<String> {
    let shared: Arc<[Triangle]> = tris.into();
    let builds: Vec<(&str, Box<dyn Accel>)> = families()
        .into_iter()
        .map(|f| {
            let accel = (f.build)(&shared, &(f.defaults)())
                .unwrap_or_else(|e| panic!("{name}: building {}: {e}", f.name));
            (f.name, accel)
        })
        .collect();
    let mut programs = Vec::new();
    for (family, accel) in &builds {
        for (i, t) in accel.traversals().into_iter().enumerate() {
            let Some(p) = accel.gpu_program(i) else {
                continue;
            };
            let label = format!("{family}/{}", t.name);
            if !keep(&label) {
                continue;
            }
            accel.prepare(i);
            let gs = match gpu.upload(&p) {
                Ok(gs) => gs,
                // Refused, as it must be, where it needs f64 and the adapter lacks it.
                Err(e) if p.needs_f64 && !gpu.adapter().f64 => {
                    println!("{name} {label}: not checked: {e}");
                    continue;
                }
                Err(e) if p.needs_subgroups && gpu.adapter().subgroups.is_none() => {
                    println!("{name} {label}: not checked: {e}");
                    continue;
                }
                Err(e) => panic!("{name} {label}: {e}"),
            };
            checked.insert(label.clone());
            programs.push(Program {
                label,
                accel: accel.as_ref(),
                traversal: i,
                gpu: gs,
                sampled: p.unrolled_triangle_loop.is_some(),
                own_counts: p.own_counts.is_some(),
            });
        }
    }
    let oracle = BruteForce::new(tris);
    let max_rays = (BRUTE_BUDGET / tris.len().max(1)).max(64);
    let mut failures = Vec::new();
    for (kind, query, all) in batches {
        // The oracle on an even sample; programs on every ray, or on the sample.
        let idx = sample(all.len(), max_rays);
        let sub: Vec<Ray> = idx.iter().map(|&i| all[i]).collect();
        let (expected, _) = cpu_trace(&oracle, 0, *query, TriTestKind::Watertight, &sub);
        let sub_oracle: Vec<_> = expected.iter().copied().map(Some).collect();
        let mut all_oracle = vec![None; all.len()];
        for (&i, e) in idx.iter().zip(&expected) {
            all_oracle[i] = Some(*e);
        }
        for p in &programs {
            let (rays, oracle) = if p.sampled {
                (&sub, &sub_oracle)
            } else {
                (all, &all_oracle)
            };
            let d = check_case(gpu, p, oracle, *query, tri, rays);
            println!(
                "{name:<28} {kind:<8} {:<20} {:<16} {:>6} rays ({:>6} validated)  mismatches gpu {:>3} cpu {:>3}  counter diffs {:>3}  hit diffs {:>3}",
                p.label,
                tri.name(),
                d.rays,
                d.validated,
                d.mismatches,
                d.cpu_mismatches,
                d.counter_diffs,
                d.hit_diffs
            );
            // Exact where the kernel can repeat the CPU (see the module doc); else bounded.
            let exact = tri == TriTestKind::Watertight && gpu.adapter().f64;
            let share = (DIFF_SHARE * d.rays as f64) as usize;
            // The watertight test's answers are the oracle's wherever the CPU's are, whatever
            // the adapter (no lost hit at extreme scales without f64 either).
            let robust = tri == TriTestKind::Watertight && d.mismatches > d.cpu_mismatches;
            let bad = robust
                || if exact {
                    d.mismatches > 0 || d.differing > 0 || d.hit_diffs > 0
                } else {
                    d.differing > share || d.mismatches > d.cpu_mismatches + share
                };
            if bad {
                failures.push(format!(
                    "{name} {kind} {} {}: {} mismatches, {} counter diffs, {} hit diffs of {} rays\n  {}",
                    p.label,
                    tri.name(),
                    d.mismatches,
                    d.counter_diffs,
                    d.hit_diffs,
                    d.rays,
                    d.first.join("\n  ")
                ));
            }
        }
    }
    failures
}

/// Print the programs checked; fail when there were none.
fn report(checked: &BTreeSet<String>) {
    println!(
        "GPU programs checked: {}",
        checked.iter().cloned().collect::<Vec<_>>().join(", ")
    );
    assert!(
        !checked.is_empty(),
        "no registered traversal has a GPU program: nothing was checked"
    );
}

/// The suite's scenes: the watertight test's are the CPU oracle suite's, `near-surfaces` at
/// 1e-30 and 1e30 included (its f64 finish, `watertight_wide`, as the CPU's);
/// Möller–Trumbore has no such finish on either device (docs/results.md).
fn scenes(tri: TriTestKind) -> Vec<tb_scene::Scene> {
    match tri {
        TriTestKind::Watertight => conformance::oracle_scenes(),
        TriTestKind::MollerTrumbore => conformance::suite_scenes(),
    }
}

/// The suite's scenes under `tri` on `gpu`: the failures, and the (family, traversal) pairs
/// checked added to `checked`.
fn suite_on(gpu: &Gpu, tri: TriTestKind, checked: &mut BTreeSet<String>) -> Vec<String> {
    let mut failures = Vec::new();
    for scene in scenes(tri) {
        let batches: Vec<_> = conformance::batches(&scene, tri)
            .into_iter()
            .map(|b| (b.kind.name(), b.kind.query(), b.rays))
            .collect();
        let name = scene.source.trim_start_matches("builtin:").to_string();
        failures.extend(check_scene(
            gpu,
            &name,
            &scene.triangles,
            &batches,
            tri,
            checked,
        ));
    }
    failures
}

fn suite(tri: TriTestKind) {
    let Some(gpu) = open_or_skip() else { return };
    let mut checked = BTreeSet::new();
    let failures = suite_on(&gpu, tri, &mut checked);
    report(&checked);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The watertight suite, then the Stanford Bunny (paper scenes) on the same device: the
/// Bunny's programs are the suite's (every family's default build, the watertight test), so
/// that each pipeline is compiled once for both (lavapipe spends most of a GPU test's time
/// compiling them). The two suites' names sort first, so that the test harness starts them
/// (the longest tests) together.
#[test]
fn all_programs_watertight_and_on_the_bunny_match_cpu() {
    let Some(gpu) = open_or_skip() else { return };
    let mut checked = BTreeSet::new();
    let mut failures = suite_on(&gpu, TriTestKind::Watertight, &mut checked);
    report(&checked);
    let mut on_bunny = BTreeSet::new();
    match bunny_on(&gpu, &mut on_bunny) {
        Some(f) => {
            report(&on_bunny);
            failures.extend(f);
        }
        None => println!(
            "skipped the Bunny: {} not found (set TRACE_BENCH_SCENES)",
            scenes_root().join(BUNNY).display()
        ),
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// On an adapter without `SHADER_F64` (acted by [`Gpu::forgo_f64`]): the
/// watertight test's finish in f32 scaled by a power of two (`shaders/edge_f32.wgsl`) answers
/// as the oracle does on `near-surfaces` at 1e-30, 1e-20, 1e15, 1e20 and 1e30, through the
/// brute-force program (the test alone) and the binary BVH's and uniform grid's walks (each
/// pipeline compiles again without f64, so the other programs, whose triangle test is the
/// same prelude function, are left to the f64 suite above).
#[test]
fn extreme_scales_without_f64() {
    let Some(mut gpu) = open_or_skip() else {
        return;
    };
    gpu.forgo_f64();
    let keep = |l: &str| {
        ["brute-force/", "bvh/ordered", "uniform-grid/"]
            .iter()
            .any(|p| l.starts_with(p))
    };
    let mut failures = Vec::new();
    let mut checked = BTreeSet::new();
    for scale in ["1e-30", "1e-20", "1e15", "1e20", "1e30"] {
        let src = format!("builtin:stress/near-surfaces?scale={scale}");
        let scene = tb_scene::load(&src, std::path::Path::new(".")).unwrap();
        let batches: Vec<_> = conformance::batches(&scene, TriTestKind::Watertight)
            .into_iter()
            .map(|b| (b.kind.name(), b.kind.query(), b.rays))
            .collect();
        failures.extend(check_scene_of(
            &gpu,
            &format!("near-surfaces@{scale}"),
            &scene.triangles,
            &batches,
            TriTestKind::Watertight,
            &mut checked,
            &keep,
        ));
    }
    report(&checked);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn all_programs_moller_trumbore_match_cpu() {
    suite(TriTestKind::MollerTrumbore);
}

fn scenes_root() -> PathBuf {
    std::env::var_os("TRACE_BENCH_SCENES")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes"))
}

const BUNNY: &str = "stanford-bunny/stanford-bunny.obj.gz";

/// The Bunny's random rays and shadow-like segments on `gpu`: its failures, `None` without
/// the paper scenes.
fn bunny_on(gpu: &Gpu, checked: &mut BTreeSet<String>) -> Option<Vec<String>> {
    let root = scenes_root();
    if !root.join(BUNNY).exists() {
        return None;
    }
    let scene = tb_scene::load(BUNNY, &root).unwrap();
    let b = tb_core::Aabb::from_points(scene.triangles.iter().flat_map(|t| [t.v0, t.v1, t.v2]));
    let random = tb_scene::rays::random(&b, 20_000, 7);
    // Shadow-like segments: the same rays cut to a tenth of the diagonal, any hit.
    let segments: Vec<Ray> = random
        .iter()
        .map(|r| Ray::segment(r.origin, r.dir, 0.0, 0.1 * b.diagonal()))
        .collect();
    let batches = vec![
        ("random".to_string(), Query::Closest, random),
        ("segments".to_string(), Query::Any, segments),
    ];
    Some(check_scene(
        gpu,
        "stanford-bunny",
        &scene.triangles,
        &batches,
        TriTestKind::Watertight,
        checked,
    ))
}
