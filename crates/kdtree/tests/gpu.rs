//! The kd-tree's GPU programs (`shaders/kd.wgsl`, `shaders/kdtree.wgsl`) against their CPU
//! traversals, beyond the default build that tb-harness's `gpu_oracle` checks: both node
//! layouts (depth-first, treelets of 2 and 3 levels), short stacks of 1 and 8 entries (in
//! registers, as the default 4), 16 (on chip, in workgroup memory) and 32 (in the invocation's
//! memory), and a
//! step cap of a few steps, on every conformance-suite scene and ray kind (an even sample of at
//! most [`MAX_RAYS`] rays per batch, to keep the test short on lavapipe), closest and any hit as
//! the batch asks, watertight test: every traversal with a GPU program must give the CPU's hits
//! and counters (`capped` included) ray for ray. Without an adapter the test prints a notice and
//! passes, unless `TRACE_BENCH_REQUIRE_GPU=1`. On an adapter without `SHADER_F64` (or where the
//! driver contracts into FMAs) a few grazing rays may differ, as `gpu_oracle` allows: at most 2%
//! of a batch.
//! (The multi-kd-tree's programs: crate tb-multikd's `tests/gpu.rs`.)

use std::collections::BTreeSet;
use tb_core::{Accel, Query, Ray, TriTestKind};
use tb_kdtree::{KdLayout, KdParams, KdTree};
use tb_scene::conformance;

/// Rays per batch checked.
const MAX_RAYS: usize = 600;

/// Check every GPU program of a build with `params` on every suite scene; returns failures and
/// adds the (traversal, case) pairs checked to `checked`.
fn check(
    gpu: &tb_gpu::Gpu,
    case: &str,
    params: &KdParams,
    only: Option<&str>,
    checked: &mut BTreeSet<String>,
) -> Vec<String> {
    let tri = TriTestKind::Watertight;
    let mut failures = Vec::new();
    for scene in conformance::suite_scenes() {
        let batches = conformance::batches(&scene, tri);
        let kd = KdTree::build(&scene.triangles, params);
        for (ti, info) in Accel::traversals(&kd).into_iter().enumerate() {
            if only.is_some_and(|o| o != info.name) {
                continue;
            }
            let Some(program) = kd.gpu_program(ti) else {
                continue;
            };
            kd.prepare(ti);
            let s = gpu
                .upload(&program)
                .unwrap_or_else(|e| panic!("{case} {}: {e}", info.name));
            for b in &batches {
                let query: Query = b.kind.query();
                let n = b.rays.len();
                let k = n.min(MAX_RAYS);
                let rays: Vec<Ray> = (0..k).map(|i| b.rays[i * n / k]).collect();
                let (cpu_hits, cpu_stats) = tb_core::par::count(&kd, ti, query, tri, &rays);
                let (hits, stats) = gpu
                    .trace_once(&s, &rays, query, tri, true)
                    .unwrap_or_else(|e| panic!("{case} {}: {e}", info.name));
                let stats = stats.expect("counters");
                let differ: Vec<usize> = (0..rays.len())
                    .filter(|&i| cpu_hits[i] != hits[i] || cpu_stats[i] != stats[i])
                    .collect();
                let allowed = if gpu.adapter().f64 { 0 } else { k / 50 };
                if differ.len() > allowed {
                    let i = differ[0];
                    failures.push(format!(
                        "{case} {} {} {}: {} of {k} rays differ; ray {i} {}: cpu {:?} {:?} gpu {:?} {:?}",
                        info.name,
                        scene.source,
                        b.kind.name(),
                        differ.len(),
                        conformance::format_ray(&rays[i]),
                        cpu_hits[i],
                        cpu_stats[i],
                        hits[i],
                        stats[i]
                    ));
                }
                checked.insert(format!("{case}: {}", info.name));
            }
        }
    }
    failures
}

#[test]
fn layouts_short_stacks_and_caps_match_the_cpu() {
    let Some(gpu) = tb_gpu::open_or_skip() else {
        return;
    };
    let mut checked = BTreeSet::new();
    let mut failures = Vec::new();
    for (case, h) in [("depth-first", 0), ("treelet h=2", 2), ("treelet h=3", 3)] {
        let params = KdParams {
            layout: if h == 0 {
                KdLayout::DepthFirst
            } else {
                KdLayout::Treelet
            },
            treelet_height: h.max(2),
            ..Default::default()
        };
        failures.extend(check(&gpu, case, &params, None, &mut checked));
    }
    for size in [1, 8, 16, 32] {
        for layout in [KdLayout::DepthFirst, KdLayout::Treelet] {
            let params = KdParams {
                short_stack: size,
                layout,
                ..Default::default()
            };
            let case = format!("short_stack={size} {layout:?}");
            failures.extend(check(
                &gpu,
                &case,
                &params,
                Some("short-stack"),
                &mut checked,
            ));
        }
    }
    let params = KdParams {
        step_cap: 3,
        ..Default::default()
    };
    failures.extend(check(&gpu, "step_cap=3", &params, None, &mut checked));
    println!(
        "checked: {}",
        checked.iter().cloned().collect::<Vec<_>>().join(", ")
    );
    // Seven traversals with a GPU program in three layouts and with the cap, short-stack six
    // more (1 and 8 entries in registers, 16 on chip, 32 in the invocation's memory).
    assert!(checked.len() >= 7 * 4 + 6, "{} cases", checked.len());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
