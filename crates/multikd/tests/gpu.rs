//! The multi-kd-tree's `recursive-direction-sorted` and `-presorted` programs: with the GPU's
//! dispatches cut as the CPU's arrangement blocks, tb-gpu's sort pass gives exactly
//! [`MultiKdTree::arrange`]'s order (a stable sort by the same 2-bit key is unique), and the
//! hits and counters equal the CPU's ray for ray, traced by two persistent workgroups per
//! dispatch. Without an adapter the test prints a notice
//! and passes, unless `TRACE_BENCH_REQUIRE_GPU=1`.

use tb_core::{Accel, Query, TriTestKind};
use tb_multikd::measure::Heuristic;
use tb_multikd::{MultiKdParams, MultiKdTree, ARRANGE_BLOCK, TREE_SHIFT};

/// Rows of the multi-kd-tree's table by name.
fn multi_row(m: &MultiKdTree, name: &str) -> usize {
    Accel::traversals(m)
        .iter()
        .position(|t| t.name == name)
        .unwrap_or_else(|| panic!("no multi-kd traversal {name}"))
}

#[test]
fn multi_kd_sort_pass_is_the_cpu_arrangement() {
    let Some(mut gpu) = tb_gpu::open_or_skip() else {
        return;
    };
    gpu.limit_dispatch(ARRANGE_BLOCK as u64);
    // Persistent threads (the paper's kernel TI): two workgroups fetch every run of rays.
    gpu.set_persistent_groups(2);
    assert_eq!(gpu.max_rays_per_dispatch() as usize, ARRANGE_BLOCK);
    let scene = tb_scene::load("builtin:stress/watertight", std::path::Path::new(".")).unwrap();
    let tri = TriTestKind::Watertight;
    // The cubic rule (tree by the dominant axis) and the spherical one.
    for measure in [Heuristic::CubeObli, Heuristic::SphereOrth] {
        let m = MultiKdTree::build(
            &scene.triangles,
            &MultiKdParams {
                measure,
                ..Default::default()
            },
        );
        let plain = multi_row(&m, "recursive-direction");
        // Sizes not a multiple of the block or of the workgroup.
        for n in [0, 37, 2 * ARRANGE_BLOCK + 300] {
            let rays = tb_scene::rays::random(&scene.bounds, n, 5);
            let mut arranged = Vec::new();
            m.arrange(&rays, &mut arranged);
            let want: Vec<u32> = arranged
                .iter()
                .enumerate()
                .map(|(p, &e)| (p - p % ARRANGE_BLOCK) as u32 + (e & ((1 << TREE_SHIFT) - 1)))
                .collect();
            for name in [
                "recursive-direction-sorted",
                "recursive-direction-presorted",
            ] {
                let row = multi_row(&m, name);
                let program = m.gpu_program(row).expect("a GPU program");
                assert!(program.arrange.is_some(), "{name}");
                let s = gpu.upload(&program).unwrap();
                let r = gpu.upload_rays(&rays).unwrap();
                for query in [Query::Closest, Query::Any] {
                    let (cpu_hits, cpu_stats) = tb_core::par::count(&m, plain, query, tri, &rays);
                    let t = gpu.trace(&s, &r, query, tri, true).unwrap();
                    assert!(t.sort_ms.is_some());
                    assert_eq!(gpu.read_order(&r).unwrap(), want, "{measure:?} {name} {n}");
                    let (hits, _) = gpu.read_hits(&r).unwrap();
                    let (stats, _) = gpu.read_stats(&r).unwrap();
                    let differ = (0..n)
                        .filter(|&i| hits[i] != cpu_hits[i] || stats[i] != cpu_stats[i])
                        .count();
                    let allowed = if gpu.adapter().f64 { 0 } else { n / 50 };
                    assert!(
                        differ <= allowed,
                        "{measure:?} {name} {query:?}: {differ} of {n} rays differ"
                    );
                }
            }
        }
    }
}
