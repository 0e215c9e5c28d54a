//! An untimed build ([`tb_core::par::as_untimed_build`]) splits the kd-tree builder's subtrees
//! over the rayon pool: the tree is the serial build's, node for node and reference for
//! reference, for every builder, and where the reference budget acts (the parallel build then
//! gives way to the serial one).

use tb_kdtree::{KdBuilder, KdParams, KdTree};

/// The tree's nodes and references as plain words, to compare two builds.
fn words(kd: &KdTree) -> (Vec<(u32, u32)>, Vec<u32>) {
    let nodes = kd.nodes().iter().map(|n| (n.bits, n.data)).collect();
    (nodes, kd.prim_refs().to_vec())
}

fn both(tris: &[tb_core::Triangle], p: &KdParams) -> (KdTree, KdTree) {
    let serial = KdTree::build(tris, p);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    let parallel = pool.install(|| tb_core::par::as_untimed_build(|| KdTree::build(tris, p)));
    (serial, parallel)
}

#[test]
fn an_untimed_parallel_build_is_the_serial_tree() {
    for source in ["builtin:teapot?tess=24", "builtin:arena?rows=12&seats=400"] {
        let scene = tb_scene::load(source, std::path::Path::new(".")).unwrap();
        assert!(
            scene.triangles.len() > 8192,
            "{source}: too small to split in parallel"
        );
        for builder in [KdBuilder::Sweep, KdBuilder::SweepNlog2n, KdBuilder::Binned] {
            let mut p = KdParams::default();
            p.sah.builder = builder;
            let (serial, parallel) = both(&scene.triangles, &p);
            assert!(serial.nodes().len() > 1000, "{source}");
            assert!(
                words(&serial) == words(&parallel),
                "{source} {builder:?}: the parallel build differs"
            );
            assert_eq!(serial.budget_leaves(), 0);
        }
    }
}

#[test]
fn where_the_reference_budget_acts_the_serial_tree_is_built() {
    let tris = tb_scene::conformance::coplanar_overlaps(6000);
    let (serial, parallel) = both(&tris, &KdParams::default());
    assert!(serial.budget_leaves() > 0);
    assert_eq!(serial.budget_leaves(), parallel.budget_leaves());
    assert!(words(&serial) == words(&parallel));
}
