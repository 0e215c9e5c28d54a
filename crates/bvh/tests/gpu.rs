//! The wide BVHs' GPU programs (`shaders/wide.wgsl`) against their CPU traversal: on every
//! conformance-suite scene and ray kind (an even sample of at most [`MAX_RAYS`] rays per batch,
//! to keep the test short on lavapipe), with the watertight test, a binned BVH4 and an SBVH8
//! must each give the CPU's hits and counters ray for ray (the binary program is checked by
//! tb-harness's `gpu_oracle` with the default parameters). Without an adapter the test prints
//! a notice and passes, unless `TRACE_BENCH_REQUIRE_GPU=1`. On an adapter without
//! `SHADER_F64` (or where the driver contracts into FMAs) a few grazing rays may differ, as
//! `gpu_oracle` allows: at most 2% of a batch.

use tb_bvh::{Builder, Bvh, BvhParams};
use tb_core::{Accel, Query, TriTestKind};
use tb_scene::conformance;

/// Rays per batch checked.
const MAX_RAYS: usize = 1500;

/// One test per build, so that the two compile (lavapipe: most of the test's time) on two
/// cores at once.
#[test]
fn binned_bvh4_program_matches_the_cpu() {
    wide_program_matches_the_cpu(Builder::Binned, 4);
}

#[test]
fn sbvh8_program_matches_the_cpu() {
    wide_program_matches_the_cpu(Builder::Sbvh, 8);
}

fn wide_program_matches_the_cpu(builder: Builder, width: u32) {
    let Some(gpu) = tb_gpu::open_or_skip() else {
        return;
    };
    let tri = TriTestKind::Watertight;
    let mut checked = 0;
    for scene in conformance::suite_scenes() {
        let batches = conformance::batches(&scene, tri);
        {
            let p = BvhParams {
                builder,
                width,
                ..BvhParams::binary()
            };
            let bvh = Bvh::build(&scene.triangles, &p);
            let Some(program) = bvh.gpu_program(0) else {
                panic!("no GPU program");
            };
            if scene.triangles.is_empty() {
                continue;
            }
            let s = gpu.upload(&program).expect("upload");
            for b in &batches {
                let query: Query = b.kind.query();
                let n = b.rays.len();
                let rays: Vec<_> = (0..n.min(MAX_RAYS))
                    .map(|i| b.rays[i * n / n.min(MAX_RAYS)])
                    .collect();
                let (cpu_hits, cpu_stats) = tb_core::par::count(&bvh, 0, query, tri, &rays);
                let (hits, stats) = gpu.trace_once(&s, &rays, query, tri, true).expect("trace");
                let stats = stats.expect("counters");
                let differ = (0..rays.len())
                    .filter(|&i| {
                        cpu_hits[i].prim != hits[i].prim
                            || cpu_hits[i].is_hit() != hits[i].is_hit()
                            || cpu_stats[i] != stats[i]
                    })
                    .count();
                let allowed = if gpu.adapter().f64 {
                    0
                } else {
                    rays.len() / 50
                };
                assert!(
                    differ <= allowed,
                    "{} {builder:?} width {width} {}: {differ} of {} rays differ from the CPU",
                    scene.source,
                    b.kind.name(),
                    rays.len()
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 0);
    println!("{checked} (scene, build, batch) cases checked");
}
