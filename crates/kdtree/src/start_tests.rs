//! Walks from a start node below the root ([`KdTree::subtree`], [`crate::KdStart`]), every
//! traversal, both layouts: they stay in the start node's subtree (nodes outside it poisoned),
//! and they answer what the subtree holds in its cell.
//!
//! The answers' check ([`check`]), for a ray `r` traced from node `N` with cell `C` (`R`: the
//! triangles referenced by the leaves under `N`; `[t0, t1]`: `r` clipped to `C` by the slab
//! test the kernels use; `e`: brute force over `R` on `r` restricted to `[t0, t1)`; `g`: the
//! traversal's answer for the whole `r`):
//! - `r` misses `C`: `g` misses;
//! - `g` hits: its triangle is in `R`;
//! - `e` hits: `g` hits;
//! - `g` claims to be the cell's closest hit (`e` hits and `g.t >= t0`, or `g.t` in
//!   `[t0, t1)`; `g.t < t0` is a triangle of `R` hit before the ray enters the cell, tested
//!   because its leaf is on the segment): closest hit, it is `e` by the oracle's rule, or the
//!   answer of brute force over `R` on `[t0, t1)` widened by a few ulps (the triangle test
//!   rounds at `tmin` and `tmax` too: a hit on a wall that is also a face of the cell); any
//!   hit, one of those hits.
//!
//! `recursive-origin`, inherently not robust for origins in split planes (see the conformance
//! tests), must meet the first two; its answers are compared as the others' but only counted,
//! and must match on nearly every ray.
//!
//! Sound because a walk from `N` visits exactly the leaves under `N` that the segment crosses,
//! and tests their triangles over `[tmin, closest)` (never only the leaf's interval): every
//! hit of `R` inside the segment lies in such a leaf (references are conservative), and every
//! answer is a hit of a triangle of such a leaf. A walk that ignored the start (from the root,
//! or restarting, backtracking, following ropes or locating points above `N`, or clipping to
//! the root cell) reports triangles outside `R` or hits on rays missing `C`.

use crate::*;
use tb_core::{compare_closest, Accel, BruteForce, HitRecord, Query, Ray, TriTestKind};

/// Which triangles the leaves under `sub`'s start reference.
fn referenced(sub: &KdTree) -> Vec<bool> {
    let v = sub.view();
    let mut r = vec![false; v.triangles().len()];
    v.walk(sub.start(), |i, _, _| {
        let n = v.nodes()[i];
        if n.is_leaf() {
            for &id in &v.refs()[n.offset()..n.offset() + n.count() as usize] {
                r[id as usize] = true;
            }
        }
    });
    r
}

/// Subtrees to walk from, per layout (a short stack of 2 entries): the first interior node at
/// depths 1, 2, 4 and 7, and the first leaf below depth 1; their auxiliary arrays built.
fn subtrees(scene: &str) -> (tb_scene::Scene, Vec<KdTree>) {
    let scene = tb_scene::load(scene, std::path::Path::new(".")).unwrap();
    let mut out = Vec::new();
    for layout in [KdLayout::DepthFirst, KdLayout::Treelet] {
        let params = KdParams {
            layout,
            short_stack: 2,
            ..Default::default()
        };
        let kd = KdTree::build(&scene.triangles, &params);
        for t in 0..KdTree::TRAVERSALS.len() {
            kd.prepare(t);
        }
        let v = kd.view();
        let first = |leaf: bool, depth: &dyn Fn(u32) -> bool| {
            let mut found = None;
            v.walk(v.root(), |i, _, d| {
                if found.is_none() && depth(d) && v.nodes()[i].is_leaf() == leaf {
                    found = Some(i);
                }
            });
            found
        };
        let mut nodes: Vec<usize> = [1, 2, 4, 7]
            .iter()
            .filter_map(|&want| first(false, &|d| d == want))
            .collect();
        assert!(nodes.len() >= 2, "{}: {nodes:?}", scene.source);
        nodes.extend(first(true, &|d| d > 1));
        out.extend(nodes.into_iter().map(|n| kd.subtree(n).unwrap()));
    }
    (scene, out)
}

/// Walks from a start node visit only its subtree: every node outside it (its ancestors and
/// their other subtrees) is replaced by a poisoned leaf of `POISON` references, so a visit
/// shows in `prims` (the auxiliary arrays stay those of the intact tree). Every traversal,
/// both queries, rays over the scene and inside the start cell.
#[test]
fn walks_from_a_start_node_stay_in_its_subtree() {
    const POISON: u32 = 1 << 16;
    let (scene, subs) = subtrees("builtin:teapot?tess=4");
    for sub in subs {
        let mut inside = vec![false; sub.nodes().len()];
        sub.view().walk(sub.start(), |i, _, _| inside[i] = true);
        let mut p = sub.clone();
        let offset = p.prim_refs.len() as u32;
        let mut refs = p.prim_refs.to_vec();
        refs.resize(refs.len() + POISON as usize, 0);
        p.prim_refs = refs.into();
        for (i, n) in Arc::make_mut(&mut p.nodes).iter_mut().enumerate() {
            if !inside[i] {
                *n = KdNode::leaf(offset, POISON);
            }
        }
        let mut rays = tb_scene::rays::random(&scene.bounds, 400, 51);
        rays.extend(tb_scene::rays::random(&p.start().cell(), 400, 53));
        for (t, row) in KdTree::TRAVERSALS.iter().enumerate() {
            for q in [Query::Closest, Query::Any] {
                let mut hits = vec![HitRecord::MISS; rays.len()];
                let mut stats = vec![tb_core::TraversalStats::default(); rays.len()];
                let tri = TriTestKind::Watertight;
                p.trace(
                    t,
                    tb_core::Batch::new(q, tri, &rays),
                    tb_core::Answers::new(&mut hits, Some(&mut stats)),
                );
                let visits = stats.iter().filter(|s| s.prims >= POISON).count();
                let at = format!("{:?} {:?}", p.params.layout, p.start());
                assert_eq!(visits, 0, "{at}: {} {q:?}", row.info.name);
                assert!(stats.iter().any(|s| s.leaves > 0), "{}", row.info.name);
            }
        }
    }
}

/// Tallies of the checked cases (to make sure the rays exercise them).
#[derive(Default, Debug)]
struct Tally {
    rays_in_cell: usize,
    rays_missing_cell: usize,
    in_cell_hits: usize,
    hits_before_cell: usize,
    not_robust_mismatches: usize,
}

/// Check every traversal of `sub` on `rays` (see the module doc).
fn check(sub: &KdTree, rays: &[Ray], tally: &mut Tally, what: &str) {
    let cell = sub.start().cell();
    let inside = referenced(sub);
    let ids: Vec<u32> = (0..inside.len() as u32)
        .filter(|&k| inside[k as usize])
        .collect();
    let tris: Vec<_> = ids.iter().map(|&k| sub.triangles()[k as usize]).collect();
    let oracle = BruteForce::new(&tris);
    let clip: Vec<Option<(f32, f32)>> = rays
        .iter()
        .map(|r| cell.intersect(r.origin, r.inv_dir(), r.tmin, r.tmax))
        .collect();
    let tri = TriTestKind::Watertight;
    // Brute force over `R` on the clipped rays, their intervals scaled by `1 ∓ widen`.
    let oracle_on = |widen: f32| {
        let clipped: Vec<Ray> = rays
            .iter()
            .zip(&clip)
            .map(|(r, c)| {
                let (t0, t1) = c.unwrap_or((0.0, 0.0));
                Ray::segment(r.origin, r.dir, t0 * (1.0 - widen), t1 * (1.0 + widen))
            })
            .collect();
        let mut hits = vec![HitRecord::MISS; rays.len()];
        oracle.trace(
            0,
            tb_core::Batch::new(Query::Closest, tri, &clipped),
            tb_core::Answers::hits(&mut hits),
        );
        for e in hits.iter_mut().filter(|e| e.is_hit()) {
            e.prim = ids[e.prim as usize];
        }
        (clipped, hits)
    };
    let (clipped, expected) = oracle_on(0.0);
    let (wide, expected_wide) = oracle_on(8.0 * f32::EPSILON);
    for (ti, info) in sub.traversals().iter().enumerate() {
        for q in [Query::Closest, Query::Any] {
            let mut got = vec![HitRecord::MISS; rays.len()];
            sub.trace(
                ti,
                tb_core::Batch::new(q, tri, rays),
                tb_core::Answers::hits(&mut got),
            );
            for (k, (g, e)) in got.iter().zip(&expected).enumerate() {
                let at = || format!("{what}: {} {q:?}, ray {k}: {:?}", info.name, rays[k]);
                let Some((t0, t1)) = clip[k] else {
                    assert!(!g.is_hit(), "{}: hit {g:?} missing the cell", at());
                    continue;
                };
                if g.is_hit() {
                    assert!(inside[g.prim as usize], "{}: {g:?} not under", at());
                }
                let in_cell = g.is_hit() && g.t >= t0 && g.t < t1;
                let ew = &expected_wide[k];
                let ok = if (e.is_hit() && g.t >= t0) || in_cell {
                    match q {
                        Query::Closest => {
                            let narrow = compare_closest(&clipped[k], e, g).is_none();
                            narrow || compare_closest(&wide[k], ew, g).is_none()
                        }
                        Query::Any => e.is_hit() || ew.is_hit(),
                    }
                } else {
                    g.is_hit() || !e.is_hit()
                };
                if info.name == "recursive-origin" {
                    tally.not_robust_mismatches += !ok as usize;
                } else {
                    assert!(ok, "{}: {g:?}, expected {e:?} or {ew:?}", at());
                }
                if ti == 0 && q == Query::Closest {
                    tally.rays_in_cell += 1;
                    tally.in_cell_hits += e.is_hit() as usize;
                    tally.hits_before_cell += (g.is_hit() && g.t < t0) as usize;
                }
            }
            if ti == 0 && q == Query::Closest {
                tally.rays_missing_cell += clip.iter().filter(|c| c.is_none()).count();
            }
        }
    }
}

/// Every traversal from a start node answers what the subtree holds in its cell (module doc).
#[test]
fn every_traversal_answers_from_a_start_node() {
    let mut tally = Tally::default();
    let scenes = [
        "builtin:teapot?tess=4",
        "builtin:cornell",
        "builtin:sphereflake?size=1&tess=1",
        "builtin:stress/plane-origins",
        "builtin:stress/thin-layers",
        "builtin:stress/duplicates",
    ];
    for src in scenes {
        let (scene, subs) = subtrees(src);
        for sub in subs {
            let cell = sub.start().cell();
            let mut rays = tb_scene::rays::random(&scene.bounds, 1500, 31);
            rays.extend(tb_scene::rays::random(&cell, 1500, 37));
            rays.extend(scene.own_rays.iter().copied());
            if let Some(view) = &scene.view {
                let mut cam = view.camera;
                (cam.width, cam.height) = (40, 30);
                rays.extend(tb_scene::rays::primary(&cam));
            }
            let what = format!("{src} {:?} {:?}", sub.params.layout, sub.start());
            check(&sub, &rays, &mut tally, &what);
        }
    }
    println!("{tally:?}");
    assert!(tally.rays_in_cell > 100_000, "{tally:?}");
    assert!(tally.in_cell_hits * 10 > tally.rays_in_cell, "{tally:?}");
    assert!(
        tally.rays_missing_cell * 10 > tally.rays_in_cell,
        "{tally:?}"
    );
    assert!(tally.hits_before_cell > 100, "{tally:?}");
    // Per ray and query of `recursive-origin`.
    assert!(
        tally.not_robust_mismatches * 100 <= tally.rays_in_cell,
        "{tally:?}"
    );
}

/// The whole tree is the subtree of its root: the same answers and counters.
#[test]
fn the_root_subtree_is_the_tree() {
    let scene = tb_scene::load("builtin:teapot?tess=4", std::path::Path::new(".")).unwrap();
    let kd = KdTree::build(&scene.triangles, &KdParams::default());
    let sub = kd.subtree(0).unwrap();
    assert_eq!(sub.start(), kd.start());
    assert!(kd.subtree(kd.nodes().len()).is_none());
    let rays = tb_scene::rays::random(&scene.bounds, 500, 41);
    for ti in 0..kd.traversals().len() {
        let run = |t: &KdTree| {
            let mut h = vec![HitRecord::MISS; rays.len()];
            let mut s = vec![tb_core::TraversalStats::default(); rays.len()];
            t.trace(
                ti,
                tb_core::Batch::new(Query::Closest, TriTestKind::Watertight, &rays),
                tb_core::Answers::new(&mut h, Some(&mut s)),
            );
            (h, s)
        };
        assert_eq!(run(&kd), run(&sub));
    }
}

/// Two trees over one shared triangle array (multi-kd-trees): no copy, each answers alone.
#[test]
fn trees_share_one_triangle_array() {
    let scene = tb_scene::load("builtin:cornell", std::path::Path::new(".")).unwrap();
    let tris: std::sync::Arc<[tb_core::Triangle]> = scene.triangles.clone().into();
    let a = KdTree::build_shared(tris.clone(), &KdParams::default());
    let b = KdTree::build_shared(
        tris.clone(),
        &KdParams {
            layout: KdLayout::Treelet,
            ..Default::default()
        },
    );
    assert!(std::ptr::eq(a.triangles(), b.triangles()));
    assert!(std::sync::Arc::ptr_eq(a.shared_triangles(), &tris));
    let rays = tb_scene::rays::random(&scene.bounds, 300, 43);
    let run = |t: &KdTree| {
        let mut h = vec![HitRecord::MISS; rays.len()];
        t.trace(
            0,
            tb_core::Batch::new(Query::Closest, TriTestKind::Watertight, &rays),
            tb_core::Answers::hits(&mut h),
        );
        h
    };
    assert_eq!(run(&a), run(&b));
}
