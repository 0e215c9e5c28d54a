//! The grids' GPU programs (`shaders/grid.wgsl` with `uniform.wgsl`, `two_level.wgsl`,
//! `irregular.wgsl`) against their CPU traversals, beyond the default builds that tb-harness's
//! `gpu_oracle` checks: the uniform grid with and without macro regions, two two-level
//! densities, and the irregular grid after each phase combination of Tables 1 and 5 (initial
//! subdivision only, merged, expanded, merged and expanded; two-level and uniform initial
//! subdivisions), on every conformance-suite scene and ray kind (an even sample of at most
//! [`MAX_RAYS`] rays per batch, to keep the test short on lavapipe), closest or any hit as the
//! batch asks, watertight test: every ray must get the oracle's answer (no mismatch), the
//! CPU's hit bit for bit and the CPU's counters, in both the counting and the timed variant.
//! On an adapter without `SHADER_F64` the programs must be refused with one line. Without an
//! adapter the tests print a notice and pass, unless `TRACE_BENCH_REQUIRE_GPU=1`.

use std::collections::BTreeSet;
use std::sync::Arc;
use tb_core::{compare, Accel, BruteForce, Query, Ray, TriTestKind, Triangle};
use tb_grid::{
    Densities, Initial, IrregularGrid, IrregularParams, TwoLevelGrid, TwoLevelParams, UniformGrid,
    UniformParams,
};
use tb_scene::conformance;

/// Rays per batch checked.
const MAX_RAYS: usize = 400;

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
        assert!(
            program.needs_f64,
            "{case}: the grid programs compute in f64"
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
            if let Some(&i) = differ.first() {
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
    if !gpu.adapter().f64 {
        println!("skipped: the adapter lacks SHADER_F64, which the grid programs need");
        return;
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
    assert_eq!(checked.len(), 3, "{checked:?}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn without_f64_the_programs_are_refused_in_one_line() {
    let Some(mut gpu) = tb_gpu::open_or_skip() else {
        return;
    };
    gpu.forgo_f64();
    let scene = &conformance::suite_scenes()[0];
    let tris: Arc<[Triangle]> = scene.triangles.clone().into();
    for (label, build) in cases() {
        let accel = build(&tris);
        let program = accel.gpu_program(0).expect("a GPU program");
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
}
