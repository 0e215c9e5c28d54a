//! The wide BVHs' GPU programs (`shaders/wide.wgsl`) and `while-while`'s persistent program
//! (`shaders/while_while.wgsl`) against their CPU traversals: on every conformance-suite
//! scene and ray kind (an even sample of at most [`MAX_RAYS`] rays per batch, to keep the test
//! short on lavapipe), with the watertight test, a binned BVH4 and an SBVH8 (`ordered`) and the
//! papers' binary SBVH (`while-while`, node cost 2, leaves up to 8; few workgroups, so that
//! each fetches many runs of rays) must each give the CPU's hits and counters ray for ray (the
//! binary `ordered` program is checked by tb-harness's `gpu_oracle` with the default
//! parameters), as must the compressed wide BVH's `node-groups` (both builders); the programs
//! whose counters are their own (`while-while-speculative`, `node-groups-postponing`) must give
//! the CPU's answers within the oracle's tolerance (`tb_core::compare`). Without an adapter the test prints
//! a notice and passes, unless `TRACE_BENCH_REQUIRE_GPU=1`. On an adapter without
//! `SHADER_F64` (or where the driver contracts into FMAs) a few grazing rays may differ, as
//! `gpu_oracle` allows: at most 2% of a batch.

use tb_bvh::{Builder, Bvh, BvhParams, Cwbvh, CwbvhParams};
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

/// `while-while-speculative` (traversal 2): the same hits as the CPU walk, and at least its
/// steps in total, more on some batch (the subgroup vote keeps lanes walking: lavapipe's
/// subgroups have 8 lanes). Refused with a notice on an adapter without subgroups.
#[test]
fn speculative_program_finds_the_cpus_hits() {
    program_matches_the_cpu(Builder::Sbvh, 2, 2);
}

/// Traversal `traversal` of a build by `builder` of `width` (the SBVH binary as Aila, Laine and
/// Karras build it: node cost 2, leaves up to 8).
fn program_matches_the_cpu(builder: Builder, width: u32, traversal: usize) {
    let p = BvhParams {
        builder,
        width,
        max_leaf: if width == 2 { 8 } else { 4 },
        c_trav: if width == 2 { 2.0 } else { 1.0 },
        ..BvhParams::binary()
    };
    accel_program_matches_the_cpu(
        &format!("{builder:?} width {width}"),
        &|tris| Box::new(Bvh::build(tris, &p)),
        traversal,
    );
}

/// The compressed wide BVH's `node-groups` program (`shaders/cwbvh.wgsl`, persistent), the
/// default build (a binary SBVH of one triangle per leaf, leaves up to 3), and the binned one.
#[test]
fn cwbvh_program_matches_the_cpu() {
    for builder in [Builder::Sbvh, Builder::Binned] {
        let p = CwbvhParams {
            builder,
            ..CwbvhParams::default()
        };
        accel_program_matches_the_cpu(
            &format!("cwbvh {builder:?}"),
            &|tris| Box::new(Cwbvh::build(tris, &p)),
            0,
        );
    }
}

/// `node-groups-postponing` (traversal 1): the same hits as the CPU walk, and at least its
/// steps in total, more on some batch (postponed triangles are tested after more nodes are
/// visited against a farther closest hit: lavapipe's subgroups have 8 lanes). Refused with a
/// notice on an adapter without subgroups.
#[test]
fn cwbvh_postponing_program_finds_the_cpus_hits() {
    accel_program_matches_the_cpu(
        "cwbvh postponing",
        &|tris| Box::new(Cwbvh::build(tris, &CwbvhParams::default())),
        1,
    );
}

/// Traversal `traversal` of the structure `make` builds (named `label`) on the GPU against
/// the CPU.
fn accel_program_matches_the_cpu(
    label: &str,
    make: &dyn Fn(&[tb_core::Triangle]) -> Box<dyn Accel>,
    traversal: usize,
) {
    let Some(mut gpu) = tb_gpu::open_or_skip() else {
        return;
    };
    gpu.set_persistent_groups(4);
    gpu.limit_dispatch(1024);
    let tri = TriTestKind::Watertight;
    let mut checked = 0;
    // Speculative traversal: the counters' totals, CPU and GPU, and batches with more GPU steps.
    let (mut cpu_steps, mut gpu_steps, mut more) = (0u64, 0u64, 0);
    let mut own = false;
    for scene in conformance::suite_scenes() {
        let batches = conformance::batches(&scene, tri);
        {
            let bvh = make(&scene.triangles);
            let bvh = bvh.as_ref();
            let Some(program) = bvh.gpu_program(traversal) else {
                panic!("no GPU program");
            };
            if scene.triangles.is_empty() {
                continue;
            }
            own = program.own_counts.is_some();
            let s = match gpu.upload(&program) {
                Ok(s) => s,
                Err(e) if program.needs_subgroups && gpu.adapter().subgroups.is_none() => {
                    println!("{}: not checked: {e}", program.name);
                    return;
                }
                Err(e) => panic!("upload: {e}"),
            };
            for b in &batches {
                let query: Query = b.kind.query();
                let n = b.rays.len();
                let rays: Vec<_> = (0..n.min(MAX_RAYS))
                    .map(|i| b.rays[i * n / n.min(MAX_RAYS)])
                    .collect();
                let (cpu_hits, cpu_stats) = tb_core::par::count(bvh, traversal, query, tri, &rays);
                let (hits, stats) = gpu.trace_once(&s, &rays, query, tri, true).expect("trace");
                let stats = stats.expect("counters");
                let differ = (0..rays.len())
                    .filter(|&i| {
                        // Counters of their own: the CPU walk's answer within the oracle's
                        // tolerance (`tb_core::compare`): the order of the triangle tests differs,
                        // and of two triangles at one distance, or a vertex's two at a hair
                        // apart (the watertight test's answer depends on the closest t so far),
                        // the one tested first is kept; an any-hit query's walk may meet
                        // another hit first.
                        let prim = if own {
                            tb_core::compare(query, &rays[i], &cpu_hits[i], &hits[i]).is_some()
                        } else {
                            cpu_hits[i].prim != hits[i].prim
                        };
                        prim || cpu_hits[i].is_hit() != hits[i].is_hit()
                            || (!own && cpu_stats[i] != stats[i])
                    })
                    .count();
                let (c, g) = (
                    cpu_stats.iter().map(|s| s.steps as u64).sum::<u64>(),
                    stats.iter().map(|s| s.steps as u64).sum::<u64>(),
                );
                cpu_steps += c;
                gpu_steps += g;
                more += (g > c) as u32;
                let allowed = if gpu.adapter().f64 {
                    0
                } else {
                    rays.len() / 50
                };
                assert!(
                    differ <= allowed,
                    "{} {label} traversal {traversal} {}: {differ} of {} rays differ from the CPU",
                    scene.source,
                    b.kind.name(),
                    rays.len()
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 0);
    println!(
        "{checked} (scene, build, batch) cases checked; steps: CPU {cpu_steps}, GPU {gpu_steps}"
    );
    if own {
        assert!(
            gpu_steps >= cpu_steps && more > 0,
            "speculation: CPU {cpu_steps} steps, GPU {gpu_steps}, {more} batches with more"
        );
    } else if gpu.adapter().f64 {
        assert_eq!(gpu_steps, cpu_steps);
    }
}
