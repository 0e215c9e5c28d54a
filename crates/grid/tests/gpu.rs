//! The grids' GPU programs (`shaders/grid.wgsl` with `uniform.wgsl`, `two_level.wgsl`,
//! `irregular.wgsl`) against their CPU traversals (the irregular grid's `walk` and
//! `walk-hagrid`), beyond the default builds that tb-harness's `gpu_oracle` checks: the
//! uniform grid with and without macro regions, two two-level densities, and the irregular
//! grid after each phase combination of Tables 1 and 5 (initial
//! subdivision only, merged, expanded, merged and expanded; two-level and uniform initial
//! subdivisions), on every conformance-suite scene and ray kind (an even sample of at most
//! [`MAX_RAYS`] rays per batch, to keep the test short on lavapipe), closest or any hit as the
//! batch asks, watertight test: every ray must get the oracle's answer (no mismatch), the
//! CPU's hit bit for bit and the CPU's counters, in both the counting and the timed variant.
//! The default walks compute in `f32` and run on every adapter; three builds walk in `f64`
//! (`precision = "f64"`), whose programs must be refused with one line on an adapter without
//! `SHADER_F64`. In `f32` a driver that contracts into FMAs may move a boundary crossing by an
//! ulp (the reference margin keeps the hit exact): there at most [`F32_COUNTER_SHARE`] of a
//! batch's rays may differ from the CPU in counters or hit bits, never from the oracle.
//! Without an adapter the tests print a notice and pass, unless `TRACE_BENCH_REQUIRE_GPU=1`.

use std::collections::BTreeSet;
use std::sync::Arc;
use tb_core::{compare, Accel, BruteForce, Query, Ray, TriTestKind, Triangle};
use tb_grid::{
    Densities, Initial, IrregularGrid, IrregularParams, Precision, TwoLevelGrid, TwoLevelParams,
    UniformGrid, UniformParams, Walk,
};
use tb_scene::conformance;

/// Rays per batch checked.
const MAX_RAYS: usize = 400;

/// The share of a batch's rays whose counters or hit bits an `f32` program may differ in
/// from the CPU's (FMA contraction; never from the oracle).
const F32_COUNTER_SHARE: f64 = 0.02;

type Builder = Box<dyn Fn(&Arc<[Triangle]>) -> Box<dyn Accel>>;

/// The builds checked: a label and the build.
fn cases() -> Vec<(&'static str, Builder)> {
    fn uniform(p: UniformParams) -> Builder {
        Box::new(move |t| Box::new(UniformGrid::build(t, &p).expect("uniform grid")))
    }
    fn two_level(p: TwoLevelParams) -> Builder {
        Box::new(move |t| Box::new(TwoLevelGrid::build(t, &p).expect("two-level grid")))
    }
    fn irregular(p: IrregularParams) -> Builder {
        Box::new(move |t| Box::new(IrregularGrid::build(t, &p).expect("irregular grid")))
    }
    let ir = IrregularParams::default();
    let f64_walk = Walk {
        precision: Precision::F64,
    };
    let uni = IrregularParams {
        initial: Initial::Uniform,
        densities: Densities {
            lambda_1: 5.0,
            ..ir.densities
        },
        ..ir
    };
    vec![
        ("uniform", uniform(UniformParams::default())),
        (
            "uniform, macro regions",
            uniform(UniformParams {
                macro_regions: true,
                ..Default::default()
            }),
        ),
        ("two-level", two_level(TwoLevelParams::default())),
        (
            "two-level, lambda_1=1 lambda_2=8",
            two_level(TwoLevelParams {
                densities: Densities {
                    lambda_1: 1.0,
                    lambda_2: 8.0,
                    ..Default::default()
                },
                ..Default::default()
            }),
        ),
        (
            "irregular, initial",
            irregular(IrregularParams {
                merge: false,
                expansion: 0,
                ..ir
            }),
        ),
        (
            "irregular, merged",
            irregular(IrregularParams { expansion: 0, ..ir }),
        ),
        (
            "irregular, expanded",
            irregular(IrregularParams { merge: false, ..ir }),
        ),
        ("irregular, merged and expanded", irregular(ir)),
        ("uniform M+E", irregular(uni)),
        (
            "uniform E",
            irregular(IrregularParams {
                merge: false,
                ..uni
            }),
        ),
        (
            "uniform, macro regions, f64",
            uniform(UniformParams {
                macro_regions: true,
                walk: f64_walk,
                ..Default::default()
            }),
        ),
        (
            "two-level, f64",
            two_level(TwoLevelParams {
                walk: f64_walk,
                ..Default::default()
            }),
        ),
        (
            "irregular, merged and expanded, f64",
            irregular(IrregularParams {
                walk: f64_walk,
                ..ir
            }),
        ),
    ]
}

/// Check every GPU program of one build on one scene; returns failure lines.
fn check(
    gpu: &tb_gpu::Gpu,
    case: &str,
    accel: &dyn Accel,
    batches: &[(Query, String, Vec<Ray>, Vec<tb_core::HitRecord>)],
    checked: &mut BTreeSet<String>,
    totals: &mut [usize; 3],
) -> Vec<String> {
    let tri = TriTestKind::Watertight;
    let mut failures = Vec::new();
    for (ti, info) in accel.traversals().into_iter().enumerate() {
        let program = accel
            .gpu_program(ti)
            .unwrap_or_else(|| panic!("{case} {}: no GPU program", info.name));
        let f64_walk = case.ends_with("f64");
        assert_eq!(
            program.needs_f64, f64_walk,
            "{case}: only the f64 walks' programs compute in f64"
        );
        let s = gpu
            .upload(&program)
            .unwrap_or_else(|e| panic!("{case} {}: {e}", info.name));
        for (query, kind, rays, oracle) in batches {
            let (cpu_hits, cpu_stats) = tb_core::par::count(accel, ti, *query, tri, rays);
            let (hits, stats) = gpu
                .trace_once(&s, rays, *query, tri, true)
                .unwrap_or_else(|e| panic!("{case} {}: {e}", info.name));
            let (timed, _) = gpu
                .trace_once(&s, rays, *query, tri, false)
                .unwrap_or_else(|e| panic!("{case} {}: {e}", info.name));
            let stats = stats.expect("counters");
            let mut differ = Vec::new();
            for i in 0..rays.len() {
                let mismatch = compare(*query, &rays[i], &oracle[i], &hits[i]).is_some();
                let counters = cpu_stats[i] != stats[i];
                totals[0] += 1;
                totals[1] += mismatch as usize;
                totals[2] += counters as usize;
                if mismatch || counters || cpu_hits[i] != hits[i] || timed[i] != hits[i] {
                    differ.push(i);
                }
            }
            let exact = differ.iter().all(|&i| {
                compare(*query, &rays[i], &oracle[i], &hits[i]).is_none() && timed[i] == hits[i]
            });
            let allowed = if f64_walk {
                0
            } else {
                (F32_COUNTER_SHARE * rays.len() as f64) as usize
            };
            if !differ.is_empty() && (!exact || differ.len() > allowed) {
                let i = differ[0];
                failures.push(format!(
                    "{case} {} {kind}: {} of {} rays differ; ray {i} {}: oracle {:?} cpu {:?} {:?} gpu {:?} {:?} timed {:?}",
                    info.name,
                    differ.len(),
                    rays.len(),
                    conformance::format_ray(&rays[i]),
                    oracle[i],
                    cpu_hits[i],
                    cpu_stats[i],
                    hits[i],
                    stats[i],
                    timed[i]
                ));
            }
        }
        checked.insert(format!("{} {}", accel.name(), info.name));
    }
    failures
}

#[test]
fn every_grid_and_phase_matches_the_cpu_ray_for_ray() {
    let Some(gpu) = tb_gpu::open_or_skip() else {
        return;
    };
    let f64_ok = gpu.adapter().f64;
    if !f64_ok {
        println!("the adapter lacks SHADER_F64: the f64 walks' programs are left out");
    }
    let tri = TriTestKind::Watertight;
    let mut checked = BTreeSet::new();
    let mut failures = Vec::new();
    let mut totals = [0usize; 3];
    for scene in conformance::suite_scenes() {
        let tris: Arc<[Triangle]> = scene.triangles.clone().into();
        let brute = BruteForce::new(&tris);
        let batches: Vec<_> = conformance::batches(&scene, tri)
            .into_iter()
            .map(|b| {
                let query = b.kind.query();
                let n = b.rays.len();
                let k = n.min(MAX_RAYS);
                let rays: Vec<Ray> = (0..k).map(|i| b.rays[i * n / k]).collect();
                let (oracle, _) = tb_core::par::count(&brute, 0, query, tri, &rays);
                (query, b.kind.name(), rays, oracle)
            })
            .collect();
        for (label, build) in cases() {
            if label.ends_with("f64") && !f64_ok {
                continue;
            }
            let accel = build(&tris);
            let case = format!("{} {label}", scene.source);
            failures.extend(check(
                &gpu,
                &case,
                accel.as_ref(),
                &batches,
                &mut checked,
                &mut totals,
            ));
        }
    }
    println!(
        "checked {}: {} rays, {} oracle mismatches, {} counter diffs",
        checked.iter().cloned().collect::<Vec<_>>().join(", "),
        totals[0],
        totals[1],
        totals[2]
    );
    assert_eq!(checked.len(), 4, "{checked:?}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn without_f64_the_f32_walks_run_and_the_f64_walks_are_refused_in_one_line() {
    let Some(mut gpu) = tb_gpu::open_or_skip() else {
        return;
    };
    gpu.forgo_f64();
    let scene = &conformance::suite_scenes()[0];
    let tris: Arc<[Triangle]> = scene.triangles.clone().into();
    let tri = TriTestKind::Watertight;
    let brute = BruteForce::new(&tris);
    let mut traced = 0;
    for (label, build) in cases() {
        let accel = build(&tris);
        let program = accel.gpu_program(0).expect("a GPU program");
        if !label.ends_with("f64") {
            // The f32 walks run there, every ray with the oracle's answer.
            let s = gpu
                .upload(&program)
                .unwrap_or_else(|e| panic!("{label}: an f32 walk refused without f64: {e}"));
            for b in conformance::batches(scene, tri) {
                let query = b.kind.query();
                let rays = &b.rays[..b.rays.len().min(MAX_RAYS)];
                let (oracle, _) = tb_core::par::count(&brute, 0, query, tri, rays);
                let (hits, _) = gpu
                    .trace_once(&s, rays, query, tri, false)
                    .unwrap_or_else(|e| panic!("{label}: {e}"));
                for i in 0..rays.len() {
                    if let Some(k) = compare(query, &rays[i], &oracle[i], &hits[i]) {
                        panic!("{label} {}: ray {i} {k:?} without f64", b.kind.name());
                    }
                }
                traced += rays.len();
            }
            continue;
        }
        let e = match gpu.upload(&program) {
            Err(e @ tb_gpu::GpuError::Unsupported(_)) => e.to_string(),
            Err(e) => panic!("{label}: refused otherwise: {e}"),
            Ok(_) => panic!("{label}: uploaded without f64"),
        };
        assert!(
            e.contains("SHADER_F64") && e.contains(program.name) && !e.contains('\n'),
            "{e}"
        );
    }
    assert!(traced > 0);
}
