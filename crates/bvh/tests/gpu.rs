//! The wide BVHs' GPU programs (`shaders/wide.wgsl`) and `while-while`'s persistent program
//! (`shaders/while_while.wgsl`) against their CPU traversals: on every conformance-suite
//! scene and ray kind (an even sample of at most [`MAX_RAYS`] rays per batch, to keep the test
//! short on lavapipe), with the watertight test, a binned BVH4 and an SBVH8 (`ordered`) and the
//! papers' binary SBVH (`while-while`, node cost 2, leaves up to 8; few workgroups, so that
//! each fetches many runs of rays) must each give the CPU's hits and counters ray for ray (the
//! binary `ordered` program is checked by tb-harness's `gpu_oracle` with the default
//! parameters). Without an adapter the test prints
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
    program_matches_the_cpu(Builder::Binned, 4, 0);
}

#[test]
fn sbvh8_program_matches_the_cpu() {
    program_matches_the_cpu(Builder::Sbvh, 8, 0);
}

#[test]
fn while_while_program_matches_the_cpu() {
    program_matches_the_cpu(Builder::Sbvh, 2, 1);
}

/// Traversal `traversal` of a build by `builder` of `width` (the SBVH binary as Aila, Laine and
/// Karras build it: node cost 2, leaves up to 8).
fn program_matches_the_cpu(builder: Builder, width: u32, traversal: usize) {
    let Some(mut gpu) = tb_gpu::open_or_skip() else {
        return;
    };
    gpu.set_persistent_groups(4);
    gpu.limit_dispatch(1024);
    let tri = TriTestKind::Watertight;
    let mut checked = 0;
    for scene in conformance::suite_scenes() {
        let batches = conformance::batches(&scene, tri);
        {
            let p = BvhParams {
                builder,
                width,
                max_leaf: if width == 2 { 8 } else { 4 },
                c_trav: if width == 2 { 2.0 } else { 1.0 },
                ..BvhParams::binary()
            };
            let bvh = Bvh::build(&scene.triangles, &p);
            let Some(program) = bvh.gpu_program(traversal) else {
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
                let (cpu_hits, cpu_stats) = tb_core::par::count(&bvh, traversal, query, tri, &rays);
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
                    "{} {builder:?} width {width} traversal {traversal} {}: {differ} of {} rays differ from the CPU",
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
