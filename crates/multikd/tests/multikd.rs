//! Multi-kd-trees (Torres et al. 2012) against the oracle: the shared conformance suite
//! (`tb_scene::conformance`) for every heuristic, the single-tree controls and the treelet
//! layout, every robust kd traversal (the inherently non-robust `recursive-origin` is left out
//! here as in the kd-tree's own suite). The `-sorted` and `-presorted` rows (the latter with
//! the arrangement of its hint pass) run for one heuristic: the unit tests show they answer
//! and count exactly as the plain rows, ray for ray, so the other variants run the plain rows
//! only (CI time).

use std::sync::Arc;
use tb_core::{
    Accel, AccelError, Answers, Batch, BuildReport, GpuProgram, MemoryReport, Structure,
    TraversalInfo,
};
use tb_kdtree::KdLayout;
use tb_multikd::measure::Heuristic;
use tb_multikd::{MultiKdParams, MultiKdTree, Trees};

/// A multi-kd-tree exposing only its robust traversals (all but the `recursive-origin` rows),
/// with or without the `-sorted` and `-presorted` rows; a traced `-presorted` row walks the
/// arrangement of its hint pass over the traced rays.
struct Robust(MultiKdTree, Vec<usize>);

impl Robust {
    fn new(m: MultiKdTree, sorted: bool) -> Self {
        let all = MultiKdTree::TRAVERSALS;
        let arranged = |n: &str| n.ends_with("-sorted") || n.ends_with("-presorted");
        let which = (0..all.len())
            .filter(|&i| !all[i].info.name.starts_with("recursive-origin"))
            .filter(|&i| sorted || !arranged(all[i].info.name))
            .collect::<Vec<_>>();
        assert_eq!(
            which.len(),
            if sorted {
                all.len() - 3
            } else {
                all.len() / 3 - 1
            }
        );
        Robust(m, which)
    }
}

impl Accel for Robust {
    fn name(&self) -> &'static str {
        self.0.name()
    }
    fn traversals(&self) -> Vec<&'static TraversalInfo> {
        self.1
            .iter()
            .map(|&i| &MultiKdTree::TRAVERSALS[i].info)
            .collect()
    }
    fn memory(&self) -> MemoryReport {
        Accel::memory(&self.0)
    }
    fn memory_for(&self, t: usize) -> MemoryReport {
        self.0.memory_for(self.1[t])
    }
    fn build_report(&self) -> BuildReport {
        Accel::build_report(&self.0)
    }
    fn validate(&self) -> Result<(), AccelError> {
        Accel::validate(&self.0)
    }
    fn prepare(&self, t: usize) {
        self.0.prepare(self.1[t])
    }
    fn has_gpu_program(&self, t: usize) -> bool {
        self.0.has_gpu_program(self.1[t])
    }
    fn gpu_program(&self, t: usize) -> Option<GpuProgram<'_>> {
        self.0.gpu_program(self.1[t])
    }
    fn trace(&self, t: usize, batch: Batch<'_>, out: Answers<'_>) {
        let t = self.1[t];
        let hints = self.0.batch_hints(t, batch.query, batch.rays);
        self.0.trace(t, batch.with_hints(hints.as_deref()), out)
    }
}

fn run(p: MultiKdParams, sorted: bool) {
    tb_scene::conformance::assert_conforms(&move |tris| {
        let m = MultiKdTree::try_build(Arc::from(tris), &p).unwrap();
        Box::new(Robust::new(m, sorted))
    });
}

#[test]
fn sphere_orth_conforms_plain_sorted_and_presorted() {
    run(MultiKdParams::default(), true);
}

/// One of each kind (spherical, cubic, cosine) beside `sphere-orth`: `sah` is the kd-tree
/// itself and `cube-obli` answers ray for ray as kd-trees built alone with its measures (unit
/// tests); the measures differ only in their weights.
#[test]
fn other_heuristics_conform() {
    for measure in [
        Heuristic::SphereObli,
        Heuristic::CubeOrth,
        Heuristic::CosObli,
    ] {
        println!("measure {}", measure.name());
        let p = MultiKdParams {
            measure,
            beta: 2.5,
            ..Default::default()
        };
        run(p, false);
    }
}

#[test]
fn controls_and_treelets_conform() {
    run(
        MultiKdParams {
            measure: Heuristic::CosObli,
            beta: 0.5,
            trees: Trees::Y,
            ..Default::default()
        },
        false,
    );
    let mut treelets = MultiKdParams {
        measure: Heuristic::SphereObli,
        ..Default::default()
    };
    treelets.kd.layout = KdLayout::Treelet;
    run(treelets, false);
}
