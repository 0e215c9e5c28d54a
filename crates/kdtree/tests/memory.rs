//! Each traversal's memory figure counts what it reads (review Table 3, "additional memory").

use tb_core::Accel;
use tb_kdtree::{KdParams, KdTree, TRAVERSALS};

#[test]
fn traversal_memory_counts_only_the_auxiliary_arrays_read() {
    let scene = tb_scene::load("builtin:teapot?tess=4", std::path::Path::new(".")).unwrap();
    let kd = KdTree::build(&scene.triangles, &KdParams::default());
    let all = kd.memory().bytes;
    let of = |name: &str| {
        let i = TRAVERSALS.iter().position(|t| t.name == name).unwrap();
        kd.memory_for(i).bytes
    };
    let base = of("recursive-direction");
    let report = kd.build_report();
    let extra = |k: &str| report.extra.iter().find(|e| e.0 == k).unwrap().1 as u64;
    assert!(base > 0);
    for t in TRAVERSALS {
        match t.name {
            "ropes" => assert_eq!(of(t.name), all),
            "backtrack" => assert_eq!(of(t.name), base + extra("backtrack_aux_bytes")),
            name => assert_eq!(of(name), base, "{name}"),
        }
    }
    assert_eq!(
        all,
        base + extra("backtrack_aux_bytes") + extra("ropes_aux_bytes")
    );
}
