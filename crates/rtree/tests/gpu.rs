//! The R-tree's GPU programs (`shaders/*.wgsl`: stackless, Listing 1; ordered, Listing 2;
//! stack, Table 3's reference; Feldmann 2015) against their CPU traversals: for every
//! insertion strategy and STR bulk loading, several `M` (a power of two and not, the largest)
//! and a sorted child order, every traversal, on every conformance-suite scene and ray kind
//! (an even sample of at most [`MAX_RAYS`] rays per batch, to keep the test short on
//! lavapipe), with the watertight test, the GPU must give the CPU's hits and counters ray for
//! ray (`t`, `u`, `v` bit for bit where the adapter has `SHADER_F64`), and the timed variant
//! (no counters) the counting variant's hits bit for bit. tb-harness's
//! `gpu_oracle` checks the default build against the oracle as well. Without an adapter the
//! tests print a notice and pass, unless `TRACE_BENCH_REQUIRE_GPU=1`. On an adapter without
//! `SHADER_F64` (or where the driver contracts into FMAs) a few grazing rays may differ, as
//! `gpu_oracle` allows: at most 2% of a batch.

use tb_core::{Accel, Query, Structure, TriTestKind};
use tb_gpu::GpuError;
use tb_rtree::{ChildOrder, Rtree, RtreeParams, Strategy, GPU_NODES};
use tb_scene::conformance;

/// Rays per batch checked.
const MAX_RAYS: usize = 256;

/// The builds checked: (strategy, m, M, child order).
fn builds() -> Vec<RtreeParams> {
    let mut out = Vec::new();
    for strategy in [
        Strategy::MinVolume,
        Strategy::MinSurface,
        Strategy::MinOverlap,
        Strategy::MinOverlapEnlargement,
        Strategy::RStar,
        Strategy::RStarSrfc,
        Strategy::Str,
    ] {
        for (m, big_m) in [(2, 4), (2, 5), (8, 16)] {
            out.push(RtreeParams {
                strategy,
                m,
                big_m,
                ..Default::default()
            });
        }
    }
    out.push(RtreeParams {
        child_order: ChildOrder::SortedX,
        reinsert: false,
        ..Default::default()
    });
    out
}

/// One test per traversal, so that their programs compile (lavapipe: most of the time) on
/// two cores at once.
#[test]
fn stackless_programs_match_the_cpu_for_every_strategy_and_m() {
    programs_match_the_cpu_for_every_strategy_and_m("stackless");
}

#[test]
fn ordered_programs_match_the_cpu_for_every_strategy_and_m() {
    programs_match_the_cpu_for_every_strategy_and_m("ordered");
}

#[test]
fn stack_programs_match_the_cpu_for_every_strategy_and_m() {
    programs_match_the_cpu_for_every_strategy_and_m("stack");
}

#[test]
fn stackless_skip_empty_programs_match_the_cpu_for_every_strategy_and_m() {
    programs_match_the_cpu_for_every_strategy_and_m("stackless-skip-empty");
}

#[test]
fn ordered_pop_cull_programs_match_the_cpu_for_every_strategy_and_m() {
    programs_match_the_cpu_for_every_strategy_and_m("ordered-pop-cull");
}

/// A traversal added to the R-tree needs a test above.
#[test]
fn every_traversal_has_a_gpu_test() {
    let names: Vec<_> = Rtree::TRAVERSALS.iter().map(|t| t.info.name).collect();
    assert_eq!(
        names,
        [
            "stackless",
            "ordered",
            "stack",
            "stackless-skip-empty",
            "ordered-pop-cull"
        ]
    );
}

fn programs_match_the_cpu_for_every_strategy_and_m(traversal: &str) {
    let Some(gpu) = tb_gpu::open_or_skip() else {
        return;
    };
    let tri = TriTestKind::Watertight;
    let exact = gpu.adapter().f64;
    let t = Rtree::TRAVERSALS
        .iter()
        .position(|x| x.info.name == traversal)
        .expect("a traversal of that name");
    let mut checked = 0;
    let mut rays_checked = 0;
    for scene in conformance::suite_scenes() {
        let batches = conformance::batches(&scene, tri);
        let batches: Vec<_> = batches
            .into_iter()
            .map(|b| {
                let n = b.rays.len();
                let k = n.min(MAX_RAYS);
                let rays: Vec<_> = (0..k).map(|i| b.rays[i * n / k]).collect();
                (b.kind, rays)
            })
            .collect();
        for p in builds() {
            let rtree = Rtree::build(&scene.triangles, &p);
            {
                let name = Rtree::TRAVERSALS[t].info.name;
                let Some(program) = rtree.gpu_program(t) else {
                    panic!("{name}: no GPU program");
                };
                assert!(program.name.starts_with(&format!("rtree/{name}-m")));
                let s = gpu.upload(&program).expect("upload");
                for (kind, rays) in &batches {
                    let query: Query = kind.query();
                    let (cpu_hits, cpu_stats) = tb_core::par::count(&rtree, t, query, tri, rays);
                    let (hits, stats) = gpu.trace_once(&s, rays, query, tri, true).expect("trace");
                    let stats = stats.expect("counters");
                    let differ = (0..rays.len())
                        .filter(|&i| {
                            let (c, g) = (&cpu_hits[i], &hits[i]);
                            c.prim != g.prim
                                || c.is_hit() != g.is_hit()
                                || cpu_stats[i] != stats[i]
                                || (exact
                                    && c.is_hit()
                                    && (c.t.to_bits(), c.u.to_bits(), c.v.to_bits())
                                        != (g.t.to_bits(), g.u.to_bits(), g.v.to_bits()))
                        })
                        .collect::<Vec<_>>();
                    let allowed = if exact { 0 } else { rays.len() / 50 };
                    assert!(
                        differ.len() <= allowed,
                        "{} {p:?} {name} {}: {} of {} rays differ from the CPU; first: ray {:?} \
                         cpu {:?} {:?} gpu {:?} {:?}",
                        scene.source,
                        kind.name(),
                        differ.len(),
                        rays.len(),
                        rays[differ[0]],
                        cpu_hits[differ[0]],
                        cpu_stats[differ[0]],
                        hits[differ[0]],
                        stats[differ[0]],
                    );
                    assert!(stats.iter().all(|s| s.capped == 0));
                    // The timed variant (COUNT = false) answers as the counting one.
                    let (timed, _) = gpu.trace_once(&s, rays, query, tri, false).expect("trace");
                    let same = |a: &tb_core::HitRecord, b: &tb_core::HitRecord| {
                        (a.prim, a.t.to_bits(), a.u.to_bits(), a.v.to_bits())
                            == (b.prim, b.t.to_bits(), b.u.to_bits(), b.v.to_bits())
                    };
                    assert!(
                        timed.iter().zip(&hits).all(|(a, b)| same(a, b)),
                        "{} {p:?} {name} {}: the timed variant's hits differ",
                        scene.source,
                        kind.name()
                    );
                    checked += 1;
                    rays_checked += rays.len();
                }
            }
        }
    }
    assert!(checked > 0);
    println!(
        "{checked} (scene, build, traversal, batch) cases, {rays_checked} rays checked ({})",
        if exact {
            "hits bit for bit"
        } else {
            "no SHADER_F64: up to 2% of a batch may differ"
        }
    );
}

/// The slot array is bound whole: one over the adapter's `max_storage_buffer_binding_size`
/// (here a limit lowered below it, as Conference with `M = 4` at 695 MiB is over 128 MiB
/// adapters) is refused at upload with one line naming the array and the limit, for every
/// traversal; the triangles, under the limit, pass.
#[test]
fn a_slot_array_over_the_binding_limit_is_refused_in_one_line() {
    let Some(mut gpu) = tb_gpu::open_or_skip() else {
        return;
    };
    // A scene whose slot array (empty slots included) outgrows its triangles, so that only
    // the slot array is over the lowered limit.
    let (scene, rtree) = conformance::suite_scenes()
        .into_iter()
        .map(|s| {
            let r = Rtree::build(&s.triangles, &RtreeParams::default());
            (s, r)
        })
        .find(|(s, r)| r.nodes().len() * 32 > s.triangles.len() * 36)
        .expect("a suite scene whose slot array is larger than its triangles");
    let node_bytes = rtree.nodes().len() as u64 * 32;
    println!("{}: {node_bytes}-byte slot array", scene.source);
    let limit = node_bytes - 4;
    println!(
        "adapter binds {} bytes; limited to {limit} for a {node_bytes}-byte slot array",
        gpu.max_binding()
    );
    gpu.limit_binding(limit);
    for t in 0..Rtree::TRAVERSALS.len() {
        let program = rtree.gpu_program(t).expect("a program");
        match gpu.upload(&program) {
            Err(e @ GpuError::TooLarge { what, bytes, .. }) => {
                assert_eq!(what, GPU_NODES);
                assert_eq!(bytes, node_bytes);
                let msg = e.to_string();
                assert!(!msg.contains('\n'), "{msg}");
                assert!(
                    msg.contains("max_storage_buffer_binding_size")
                        && msg.contains(&limit.to_string()),
                    "{msg}"
                );
                println!("{}: {msg}", program.name);
            }
            Err(e) => panic!("{}: another error: {e}", program.name),
            Ok(_) => panic!("{}: uploaded over the limit", program.name),
        }
    }
}
