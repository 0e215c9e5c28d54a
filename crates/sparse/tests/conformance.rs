//! The shared conformance suite (`tb_scene::conformance`) for every traversal of the table,
//! start nodes in use (the kernels find them per ray when no hints are given, as the hints
//! would), and the identities between the traversals.

use tb_core::{
    Accel, Answers, Batch, HitRecord, Query, Ray, Structure, TraversalStats, TriTestKind,
};
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

/// The arena and city stand-ins, small: every traversal, every ray kind, zero mismatches.
#[test]
fn conforms_on_the_stand_ins() {
    let scenes: Vec<tb_scene::Scene> = [
        "builtin:arena?rows=3&seats=24&roof=6",
        "builtin:city?blocks=3&storeys=4",
    ]
    .iter()
    .map(|s| {
        let mut s = tb_scene::load(s, std::path::Path::new(".")).unwrap();
        let c = &mut s.view.as_mut().unwrap().camera;
        (c.width, c.height) = (40, 30);
        s
    })
    .collect();
    let res = tb_scene::conformance::check_scenes(
        &scenes,
        &|tris| {
            Box::new(SparseBoxes::build(
                tris,
                &SparseParams {
                    d_min: 1,
                    ..Default::default()
                },
            ))
        },
        TriTestKind::Watertight,
    );
    let bad: Vec<_> = res.iter().filter(|r| r.mismatches > 0).collect();
    assert!(bad.is_empty(), "{bad:?}");
    assert!(res.len() >= 2 * 6 * 6, "{}", res.len());
}

#[test]
fn conforms_dense_and_sparse_boxes() {
    for d_min in [1, 5] {
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

/// The hits and counters of the kd-tree's traversal `name` over the tree below `s`.
fn kd_traced(
    s: &SparseBoxes,
    name: &str,
    q: Query,
    rays: &[Ray],
) -> (Vec<HitRecord>, Vec<TraversalStats>) {
    let ti = <tb_kdtree::KdTree as Structure>::TRAVERSALS
        .iter()
        .position(|t| t.info.name == name)
        .unwrap();
    let mut stats = vec![TraversalStats::default(); rays.len()];
    let mut hits = vec![HitRecord::MISS; rays.len()];
    let batch = Batch::new(q, TriTestKind::Watertight, rays);
    Accel::trace(s.kd(), ti, batch, Answers::new(&mut hits, Some(&mut stats)));
    (hits, stats)
}

/// HTR, run in BTR's kernel, is the kd-tree's `recursive-direction` over the same tree (same
/// hits, nodes, planes, steps, leaves and tests, ray by ray); BTR from the root is HTR and
/// then its climb to the root from the last augmented node (Alg. 2's `TraverseUp`: the same
/// nodes but the parent links, the same leaves and tests);
/// `sltr-mask` from the root visits HTR's leaves in HTR's order (same leaves and triangle
/// tests, more interior nodes), closest hit, on the suite's scenes and every ray kind; no ray
/// of SLTR, `sltr-mask` or SEQ ends on the step cap; the start-node variants give the same
/// answers with hints as without.
#[test]
fn root_walks_visit_htr_leaves() {
    let (htr, btr_root, sltr_root) = (index("htr"), index("btr-root"), index("sltr-mask-root"));
    let mut compared = 0;
    for scene in tb_scene::conformance::suite_scenes() {
        let s = SparseBoxes::build(&scene.triangles, &SparseParams::default());
        for b in tb_scene::conformance::batches(&scene, TriTestKind::Watertight) {
            let q = b.kind.query();
            let (h0, s0) = traced(&s, htr, q, &b.rays);
            let (kd_hits, kd_stats) = kd_traced(&s, "recursive-direction", q, &b.rays);
            assert_eq!(h0, kd_hits, "{}", scene.source);
            for (a, k) in s0.iter().zip(&kd_stats) {
                let of = |x: &TraversalStats| (x.interior, x.planes, x.steps, x.leaves, x.prims);
                assert_eq!(of(a), of(k), "{}", scene.source);
            }
            let (h1, s1) = traced(&s, btr_root, q, &b.rays);
            assert_eq!(h0, h1, "{}", scene.source);
            for (a, c) in s0.iter().zip(&s1) {
                assert_eq!(
                    (a.interior, a.leaves, a.prims),
                    (c.interior - c.ups, c.leaves, c.prims),
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
            for name in [
                "sltr",
                "sltr-handover",
                "sltr-root",
                "sltr-mask",
                "sltr-mask-root",
                "seq",
                "btr",
            ] {
                let (h, st) = traced(&s, index(name), q, &b.rays);
                assert!(
                    st.iter().all(|x| x.capped == 0),
                    "{}: {name} capped",
                    scene.source
                );
                let mut plain = vec![HitRecord::MISS; b.rays.len()];
                let batch = Batch::new(q, TriTestKind::Watertight, &b.rays);
                s.trace(index(name), batch, Answers::hits(&mut plain));
                assert_eq!(h, plain, "{}: {name}", scene.source);
            }
            compared += b.rays.len();
        }
    }
    assert!(compared > 100_000, "{compared}");
}

/// Start nodes are in use: on the suite's scenes with a view, primary rays get the eye's start
/// node (one for all), and secondary rays one per origin, below the root for most.
#[test]
fn start_nodes_are_used() {
    let (mut deep, mut total) = (0usize, 0usize);
    for scene in tb_scene::conformance::suite_scenes() {
        if scene.view.is_none() {
            continue;
        }
        let s = SparseBoxes::build(
            &scene.triangles,
            &SparseParams {
                d_min: 1,
                ..Default::default()
            },
        );
        for b in tb_scene::conformance::batches(&scene, TriTestKind::Watertight) {
            let h = s
                .batch_hints(index("sltr"), b.kind.query(), &b.rays)
                .unwrap();
            assert_eq!(h.len(), b.rays.len());
            if b.kind == tb_scene::rays::RayKind::Primary {
                assert!(h.iter().all(|&x| x == h[0]), "{}", scene.source);
            }
            deep += h.iter().filter(|&&x| x != 0).count();
            total += h.len();
        }
    }
    println!("{deep} of {total} rays start below the root");
    assert!(deep * 2 > total, "{deep} of {total}");
    assert!(s_no_hints());
}

/// Traversals without start nodes take no hints.
fn s_no_hints() -> bool {
    let tris = tb_scene::load("builtin:cornell", std::path::Path::new("."))
        .unwrap()
        .triangles;
    let s = SparseBoxes::build(&tris, &SparseParams::default());
    let rays = [Ray::new(
        tb_core::Vec3::new(0.0, 1.0, 3.0),
        -tb_core::Vec3::Z,
    )];
    ["htr", "btr-root", "sltr-root", "sltr-mask-root", "seq"]
        .iter()
        .all(|n| s.batch_hints(index(n), Query::Closest, &rays).is_none())
}

/// The start node of a secondary ray, located from its origin (the generating hit point
/// offset off the surface toward the incoming ray), is the augmented node where the generating
/// ray terminated (the deepest augmented ancestor of the leaf holding the hit point, a point
/// on a split plane counted on the side the ray came from) on nearly every ray: they differ
/// only where the offset crosses an augmented cell's face. Measured on the teapot in its
/// stadium, shadow rays.
#[test]
fn secondary_start_is_where_the_generating_ray_ended() {
    let scene = tb_scene::load(
        "builtin:teapot-stadium?teapot_tess=3&segments=8",
        std::path::Path::new("."),
    )
    .unwrap();
    let view = scene.view.clone().unwrap();
    let p = SparseParams {
        d_min: 1,
        ..Default::default()
    };
    let s = SparseBoxes::build(&scene.triangles, &p);
    let v = s.kd().view();
    // The augmented ancestor of the leaf holding `q`, ties to the side `d` comes from.
    let ended = |q: tb_core::Vec3, d: tb_core::Vec3| -> u32 {
        let (mut i, mut depth, mut last) = (0usize, 0u32, 0usize);
        loop {
            let n = v.nodes()[i];
            if n.is_leaf() {
                break;
            }
            if depth % p.period() == 0 {
                last = i;
            }
            let (a, sp) = (n.axis(), n.split());
            let left = q[a] < sp || (q[a] == sp && d[a] > 0.0);
            i = if left { i + 1 } else { n.link() };
            depth += 1;
        }
        s.aug_of(last).unwrap() as u32
    };
    let prim = tb_scene::rays::primary(&view.camera);
    let hits = tb_core::par::trace(
        &s,
        index("htr"),
        Query::Closest,
        TriTestKind::Watertight,
        &prim,
    );
    let light = view.light.unwrap();
    let (mut same, mut n) = (0, 0);
    for (r, h) in prim.iter().zip(&hits) {
        if !h.is_hit() {
            continue;
        }
        let sh = tb_scene::rays::shadow(&scene.triangles, &[*r], &[*h], light);
        let Some(sr) = sh.first() else { continue };
        same += (s.start_node(sr.origin) == ended(r.at(h.t), r.dir)) as usize;
        n += 1;
    }
    println!("{same} of {n} secondary rays start where the generating ray ended");
    assert!(n > 100 && same * 100 >= n * 95, "{same} of {n}");
}

/// `validate` finds broken records; the figures are those of the records.
#[test]
fn validate_and_figures() {
    let tris = tb_scene::load("builtin:teapot?tess=4", std::path::Path::new("."))
        .unwrap()
        .triangles;
    for d_min in [1, 3, 16] {
        let p = SparseParams {
            d_min,
            ..Default::default()
        };
        let s = SparseBoxes::build(&tris, &p);
        Accel::validate(&s).unwrap();
        let a = s.augmented();
        assert_eq!(a[0].node, 0);
        // Every record sits d_min + 1 levels below its parent's, every interior node at such a
        // depth has one.
        for (k, r) in a.iter().enumerate().skip(1) {
            assert_eq!(s.aug_depths()[k] % (d_min as u8 + 1), 0);
            assert!(a[r.parent as usize].cell().contains_box(&r.cell()));
            assert_eq!(s.aug_of(r.node as usize), Some(k));
        }
        let rep = Accel::build_report(&s);
        let get = |k: &str| rep.extra.iter().find(|e| e.0 == k).unwrap().1;
        assert_eq!(get("n_b") as usize, a.len());
        assert_eq!(
            get("m_kd_bytes") - get("m_kd_htr_bytes"),
            28.0 * a.len() as f64
        );
        let (htr, btr) = (
            s.memory_for(index("htr")).bytes,
            s.memory_for(index("btr")).bytes,
        );
        // 32 bytes per record, 1 per depth, and the records' rank (one bit per kd-tree node
        // and a 4-byte count per 64 nodes).
        let rank = s.kd().nodes().len().div_ceil(64) as u64 * 12;
        assert_eq!(btr - htr, 33 * a.len() as u64 + rank);
        // The structure alone (M_KD): the kd-tree's lines of nodes and its references, plus the
        // boxes for BTR; the rest is the triangle array, whatever the traversal.
        let kd = 64 * s.kd().nodes().len().div_ceil(8) as u64 + 4 * s.kd().prim_refs().len() as u64;
        let tri_bytes = std::mem::size_of_val(&tris[..]) as u64;
        for (name, boxes) in [
            ("htr", 0),
            ("seq", 0),
            ("btr", btr - htr),
            ("sltr", btr - htr),
        ] {
            let m = s.memory_for(index(name));
            assert_eq!(m.structure_bytes, kd + boxes, "{name}");
            assert_eq!(m.bytes - m.structure_bytes, tri_bytes, "{name}");
        }
        assert_eq!(
            s.memory_for(index("btr")).structure_bytes,
            get("aug_bytes") as u64 + kd,
            "aug_bytes"
        );
    }
    // Denser boxes: more of them.
    let n = |d_min| {
        SparseBoxes::build(
            &tris,
            &SparseParams {
                d_min,
                ..Default::default()
            },
        )
        .augmented()
        .len()
    };
    assert!(n(1) > n(3) && n(3) > n(16));
    // Corruption is found.
    let s = SparseBoxes::build(&tris, &SparseParams::default());
    let bad = |f: fn(&mut Vec<tb_sparse::AugNode>)| {
        let mut v = s.augmented().to_vec();
        f(&mut v);
        s.with_records(v)
    };
    assert!(Accel::validate(&bad(|v| v[3].parent = 3)).is_err());
    assert!(Accel::validate(&bad(|v| v[3].node += 1)).is_err());
    assert!(Accel::validate(&bad(|v| v[2].max[0] += 1.0)).is_err());
    assert!(Accel::validate(&bad(|v| {
        v.pop();
    }))
    .is_err());
    // Bad parameters are errors.
    let e = SparseBoxes::try_build(
        tris.into(),
        &SparseParams {
            d_min: 0,
            ..Default::default()
        },
    );
    assert!(matches!(e, Err(tb_core::AccelError::Params(_))));
}

/// The harness's path: hints computed once for a batch, split into chunks with the rays by
/// `tb_core::par::trace_hinted_into` (more rays than one chunk), give the answers and counters
/// of the kernels that find their start nodes themselves.
#[test]
fn chunked_hints_match() {
    let scene = tb_scene::load(
        "builtin:teapot-stadium?teapot_tess=3&segments=8",
        std::path::Path::new("."),
    )
    .unwrap();
    let mut cam = scene.view.clone().unwrap().camera;
    (cam.width, cam.height) = (64, 48);
    let rays = tb_scene::rays::primary(&cam);
    assert!(rays.len() > tb_core::par::CHUNK);
    let s = SparseBoxes::build(&scene.triangles, &SparseParams::default());
    for name in ["btr", "sltr", "sltr-handover", "sltr-mask"] {
        let ti = index(name);
        let hints = s.batch_hints(ti, Query::Closest, &rays).unwrap();
        assert!(hints.iter().all(|&h| h == hints[0] && h != 0), "{name}");
        let mut a = vec![HitRecord::MISS; rays.len()];
        let mut sa = vec![TraversalStats::default(); rays.len()];
        let batch = Batch::new(Query::Closest, TriTestKind::Watertight, &rays);
        let out = Answers::new(&mut a, Some(&mut sa));
        tb_core::par::trace_into(&s, ti, batch.with_hints(Some(&hints)), out);
        let (b, sb) = tb_core::par::count(&s, ti, Query::Closest, TriTestKind::Watertight, &rays);
        assert_eq!(a, b, "{name}");
        assert_eq!(sa, sb, "{name}");
    }
}

/// Figure 3's nested reading (claims/havran-bittner-sparse-boxes.toml, fig3-nested-*): with
/// d_min + 1 a power of two (d_min = 1, 3, 7, 15) each sparser tree's augmented nodes are a
/// subset of each denser one's, and the start node of a point is at least as deep the denser
/// the boxes; the non-nested d_min = 1, 3, 6, 11 of the other reading have pairs that are not
/// (3 and 6, 6 and 11).
#[test]
fn nested_dmin_boxes_are_subsets() {
    let tris = tb_scene::load("builtin:teapot?tess=8", std::path::Path::new("."))
        .unwrap()
        .triangles;
    let build = |d_min| {
        SparseBoxes::build(
            &tris,
            &SparseParams {
                d_min,
                ..Default::default()
            },
        )
    };
    let nodes = |s: &SparseBoxes| -> std::collections::BTreeSet<u32> {
        s.augmented().iter().map(|a| a.node).collect()
    };
    let report = Accel::build_report(build(1).kd());
    let depth_max = report.extra.iter().find(|e| e.0 == "depth_max").unwrap().1;
    assert!(
        depth_max >= 16.0,
        "a tree deep enough for d_min = 15: {depth_max}"
    );
    let trees: Vec<(u32, SparseBoxes)> = [1, 3, 6, 7, 11, 15]
        .into_iter()
        .map(|d| (d, build(d)))
        .collect();
    let get = |d: u32| &trees.iter().find(|t| t.0 == d).unwrap().1;
    let bounds = tb_core::Aabb::from_points(tris.iter().flat_map(|t| [t.v0, t.v1, t.v2]));
    let points: Vec<tb_core::Vec3> = tb_scene::rays::random(&bounds, 500, 3)
        .iter()
        .map(|r| r.origin)
        .collect();
    let start_depth = |s: &SparseBoxes, p| s.aug_depths()[s.start_node(p) as usize];
    for w in [1, 3, 7, 15].windows(2) {
        let (dense, sparse) = (get(w[0]), get(w[1]));
        assert!(nodes(sparse).is_subset(&nodes(dense)), "{w:?}");
        assert!(nodes(sparse).len() < nodes(dense).len(), "{w:?}");
        for &p in &points {
            assert!(
                start_depth(dense, p) >= start_depth(sparse, p),
                "{w:?} {p:?}"
            );
        }
    }
    for (d, e) in [(3, 6), (6, 11)] {
        assert!(!nodes(get(e)).is_subset(&nodes(get(d))), "{d}, {e}");
    }
}

/// SEQ, run in SLTR's kernel with no augmented node but the root, is the kd-tree's
/// `sequential` over the same tree: the same hits on every ray of the suite, and the same
/// leaves, triangle tests, interior nodes, restarts and hand-overs (a point that rounding
/// cannot place goes to kd-restart in both), no parent link followed; the rays handed over
/// are few.
#[test]
fn seq_is_the_kd_trees_sequential() {
    let seq = index("seq");
    let (mut n, mut handed, mut differ) = (0usize, 0usize, 0usize);
    for scene in tb_scene::conformance::suite_scenes() {
        let s = SparseBoxes::build(&scene.triangles, &SparseParams::default());
        for b in tb_scene::conformance::batches(&scene, TriTestKind::Watertight) {
            let q = b.kind.query();
            let (h0, s0) = traced(&s, seq, q, &b.rays);
            let (kd_hits, kd_stats) = kd_traced(&s, "sequential", q, &b.rays);
            for i in 0..b.rays.len() {
                assert_eq!(
                    h0[i].is_hit(),
                    kd_hits[i].is_hit(),
                    "{} ray {i}",
                    scene.source
                );
                if q == Query::Closest {
                    assert_eq!(h0[i].t, kd_hits[i].t, "{} ray {i}", scene.source);
                }
                let (a, k) = (&s0[i], &kd_stats[i]);
                handed += (a.handovers + k.handovers > 0) as usize;
                let of = |x: &TraversalStats| {
                    (
                        x.leaves,
                        x.prims,
                        x.interior,
                        x.restarts,
                        x.handovers,
                        x.ups,
                    )
                };
                if of(a) != of(k) {
                    differ += 1;
                    if differ < 5 {
                        println!("{} ray {i}: {a:?} vs {k:?}", scene.source);
                    }
                }
                n += 1;
            }
        }
    }
    println!("{n} rays, {handed} handed over, {differ} differ");
    assert_eq!(differ, 0);
    assert!(handed * 20 < n, "{handed} of {n}");
}
