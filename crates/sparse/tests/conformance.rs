//! The shared conformance suite (`tb_scene::conformance`) for every traversal of the table,
//! start nodes in use (the kernels find them per ray when no hints are given, as the hints
//! would), and the identities between the traversals.

use tb_core::{Accel, HitRecord, Query, Ray, Structure, TraversalStats, TriTestKind};
use tb_sparse::{SparseBoxes, SparseParams};

fn index(name: &str) -> usize {
    SparseBoxes::TRAVERSALS
        .iter()
        .position(|t| t.info.name == name)
        .unwrap()
}

fn run(params: SparseParams) {
    tb_scene::conformance::assert_conforms(&move |tris| {
        let s = SparseBoxes::build(tris, &params);
        Accel::validate(&s).expect("valid sparse boxes");
        Box::new(s) as Box<dyn Accel>
    });
}

#[test]
fn conforms_default() {
    run(SparseParams::default());
}

#[test]
fn conforms_dense_and_sparse_boxes() {
    for d_min in [1, 6] {
        run(SparseParams {
            d_min,
            ..Default::default()
        });
    }
}

/// Trace with the hints of the batch (as the harness does), with counters.
fn traced(
    s: &SparseBoxes,
    ti: usize,
    q: Query,
    rays: &[Ray],
) -> (Vec<HitRecord>, Vec<TraversalStats>) {
    let mut stats = vec![TraversalStats::default(); rays.len()];
    let hits = tb_sparse::trace_hinted(s, ti, q, TriTestKind::Watertight, rays, Some(&mut stats));
    (hits, stats)
}

/// BTR from the root is HTR (the same stack walk: same nodes, leaves and tests, ray by ray);
/// SLTR from the root visits HTR's leaves in HTR's order (same leaves and triangle tests,
/// more interior nodes), closest hit, on the suite's scenes and every ray kind; no ray of
/// SLTR or SEQ ends on the step cap; the start-node variants give the same answers with hints
/// as without.
#[test]
fn root_walks_visit_htr_leaves() {
    let (htr, btr_root, sltr_root) = (index("htr"), index("btr-root"), index("sltr-root"));
    let mut compared = 0;
    for scene in tb_scene::conformance::suite_scenes() {
        let s = SparseBoxes::build(&scene.triangles, &SparseParams::default());
        for b in tb_scene::conformance::batches(&scene, TriTestKind::Watertight) {
            let q = b.kind.query();
            let (h0, s0) = traced(&s, htr, q, &b.rays);
            let (h1, s1) = traced(&s, btr_root, q, &b.rays);
            assert_eq!(h0, h1, "{}", scene.source);
            for (a, c) in s0.iter().zip(&s1) {
                assert_eq!(
                    (a.interior, a.leaves, a.prims),
                    (c.interior, c.leaves, c.prims),
                    "{}",
                    scene.source
                );
            }
            if q == Query::Closest {
                let (h2, s2) = traced(&s, sltr_root, q, &b.rays);
                assert_eq!(h0, h2, "{}", scene.source);
                for (a, c) in s0.iter().zip(&s2) {
                    assert_eq!((a.leaves, a.prims), (c.leaves, c.prims), "{}", scene.source);
                    assert!(c.interior >= a.interior);
                }
            }
            for name in ["sltr", "sltr-root", "seq", "btr"] {
                let (h, st) = traced(&s, index(name), q, &b.rays);
                assert!(
                    st.iter().all(|x| x.capped == 0),
                    "{}: {name} capped",
                    scene.source
                );
                let mut plain = vec![HitRecord::MISS; b.rays.len()];
                s.trace(
                    index(name),
                    q,
                    TriTestKind::Watertight,
                    &b.rays,
                    &mut plain,
                    None,
                );
                assert_eq!(h, plain, "{}: {name}", scene.source);
            }
            compared += b.rays.len();
        }
    }
    assert!(compared > 100_000, "{compared}");
}
