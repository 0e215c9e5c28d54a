//! Robustness: flat scenes and rays in box-face planes, empty and tiny scenes, coincident and
//! degenerate triangles, pathological depth, counters, and the flat-array invariants.

mod common;

use common::*;
use tb_bvh::{Bvh, BvhNode, BvhParams, STACK_SIZE};
use tb_core::{
    Accel, BruteForce, HitRecord, Query, Ray, TraversalStats, TriTestKind, Triangle, Vec3,
};

fn all_params() -> Vec<BvhParams> {
    let d = BvhParams::binary();
    vec![
        d,
        BvhParams {
            bins: 4,
            max_leaf: 1,
            ..d
        },
        BvhParams {
            bins: 32,
            max_leaf: 8,
            ..d
        },
    ]
}

/// A `n x n` grid of unit squares (two triangles each) in the plane z = 0.
fn flat_grid(n: usize) -> Vec<Triangle> {
    let mut t = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (i as f32, j as f32);
            let p = |dx: f32, dy: f32| Vec3::new(x + dx, y + dy, 0.0);
            t.push(Triangle::new(p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)));
            t.push(Triangle::new(p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)));
        }
    }
    t
}

/// The 12 triangles of the axis-aligned box `[lo, hi]`.
fn cube(lo: Vec3, hi: Vec3) -> Vec<Triangle> {
    let c = |i: usize| {
        Vec3::new(
            if i & 1 != 0 { hi.x } else { lo.x },
            if i & 2 != 0 { hi.y } else { lo.y },
            if i & 4 != 0 { hi.z } else { lo.z },
        )
    };
    let quads = [
        [0, 1, 3, 2],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 3, 7, 5],
    ];
    let mut t = Vec::new();
    for q in quads {
        t.push(Triangle::new(c(q[0]), c(q[1]), c(q[2])));
        t.push(Triangle::new(c(q[0]), c(q[2]), c(q[3])));
    }
    t
}

#[test]
fn flat_scene_with_rays_in_its_plane_and_on_grid_lines() {
    let mut tris = flat_grid(12);
    let flat_len = tris.len();
    // Walls standing on the plane (bottom edge at z = 0) and crossing it.
    for k in 0..6 {
        let x = 1.0 + 2.0 * k as f32;
        let (z0, z1) = if k % 2 == 0 { (0.0, 1.0) } else { (-1.0, 1.0) };
        tris.push(Triangle::new(
            Vec3::new(x, 0.0, z0),
            Vec3::new(x, 12.0, z0),
            Vec3::new(x, 6.0, z1),
        ));
    }
    let mut rays = Vec::new();
    for i in 0..=24 {
        let s = i as f32 * 0.5;
        // In the plane z = 0, along ±x and ±y, origins on grid lines and between them.
        for (o, d) in [
            (Vec3::new(-1.0, s, 0.0), Vec3::new(1.0, 0.0, 0.0)),
            (Vec3::new(13.0, s, 0.0), Vec3::new(-1.0, -0.0, -0.0)),
            (Vec3::new(s, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)),
            (
                Vec3::new(s, -1.0, -0.0),
                Vec3::new(0.3, 1.0, 0.0).normalize(),
            ),
        ] {
            rays.push(Ray::new(o, d));
        }
        // Straight down onto grid lines and vertices (zero x and y direction components).
        for j in 0..=24 {
            let t = j as f32 * 0.5;
            rays.push(Ray::new(Vec3::new(s, t, 5.0), Vec3::new(0.0, 0.0, -1.0)));
            rays.push(Ray::new(Vec3::new(s, t, -5.0), Vec3::new(-0.0, 0.0, 1.0)));
        }
    }
    rays.extend(common::rays(&tris, 500, 1));
    for p in all_params() {
        let hits = check_against_oracle(&tris, &rays, &p);
        assert!(hits > 1000, "{hits} hits");
    }
    // Rays in z = 0 along x must hit the walls standing on the plane (at their bottom edge).
    let bvh = build(&tris, &BvhParams::binary());
    let r = Ray::new(Vec3::new(-1.0, 3.0, 0.0), Vec3::X);
    let h = trace(&bvh, Query::Closest, TriTestKind::Watertight, &[r])[0];
    assert!(
        h.is_hit() && h.prim as usize >= flat_len && h.t == 2.0,
        "{h:?}"
    );
    // A flat-only scene: rays in its plane never hit, rays across it do.
    let flat = flat_grid(8);
    let bvh = build(&flat, &BvhParams::binary());
    let inplane = [
        Ray::new(Vec3::new(-1.0, 2.0, 0.0), Vec3::X),
        Ray::new(Vec3::new(-1.0, 2.5, 0.0), Vec3::X),
    ];
    for tri in TriTestKind::ALL {
        for h in trace(&bvh, Query::Closest, tri, &inplane) {
            assert!(!h.is_hit());
        }
    }
    let down = Ray::new(Vec3::new(2.0, 3.0, 1.0), -Vec3::Z);
    let h = trace(&bvh, Query::Closest, TriTestKind::Watertight, &[down])[0];
    assert!(h.is_hit() && h.t == 1.0);
}

#[test]
fn rays_along_axes_in_box_face_planes() {
    // A 4x4x4 lattice of unit cubes with gaps: every leaf box has faces on the lattice planes.
    let mut tris = Vec::new();
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                let lo = Vec3::new(i as f32, j as f32, k as f32) * 2.0;
                tris.extend(cube(lo, lo + 1.0));
            }
        }
    }
    let mut rays = Vec::new();
    for a in 0..=16 {
        for b in 0..=16 {
            let (y, z) = (a as f32 * 0.5, b as f32 * 0.5);
            // Along ±x with y and z exactly on face planes (and between them).
            rays.push(Ray::new(Vec3::new(-1.0, y, z), Vec3::X));
            rays.push(Ray::new(Vec3::new(9.0, y, z), Vec3::new(-1.0, -0.0, 0.0)));
            rays.push(Ray::new(Vec3::new(y, -1.0, z), Vec3::Y));
            rays.push(Ray::new(Vec3::new(y, z, 9.0), Vec3::new(0.0, -0.0, -1.0)));
            // Starting inside a face plane, on a box corner.
            rays.push(Ray::segment(Vec3::new(0.0, y, z), Vec3::X, 0.0, 5.0));
        }
    }
    let mut n_hits = 0;
    for p in all_params() {
        n_hits = check_against_oracle(&tris, &rays, &p);
    }
    assert!(n_hits > 500, "{n_hits} hits");
    // A ray along the edge line y = 0, z = 0 of the first cube hits it at x = 0.
    let bvh = build(&tris, &BvhParams::binary());
    let h = trace(
        &bvh,
        Query::Closest,
        TriTestKind::Watertight,
        &[Ray::new(Vec3::new(-1.0, 0.0, 0.5), Vec3::X)],
    )[0];
    assert!(h.is_hit() && h.t == 1.0, "{h:?}");
}

#[test]
fn empty_scene_misses_everything() {
    for p in all_params() {
        let bvh = build(&[], &p);
        assert!(bvh.nodes().is_empty());
        assert!(bvh.triangles().is_empty() && bvh.prim_ids().is_empty());
        let rays = common::rays(&[], 50, 2);
        for tri in TriTestKind::ALL {
            for q in [Query::Closest, Query::Any] {
                assert!(trace(&bvh, q, tri, &rays)
                    .iter()
                    .all(|h| *h == HitRecord::MISS));
                let mut hits = vec![HitRecord::MISS; rays.len()];
                let mut stats = vec![TraversalStats::default(); rays.len()];
                bvh.trace(
                    0,
                    tb_core::Batch::new(q, tri, &rays),
                    tb_core::Answers::new(&mut hits, Some(&mut stats)),
                );
                assert!(stats.iter().all(|s| s.steps == 0));
            }
        }
        assert_eq!(bvh.memory().bytes, 0);
        let rep = bvh.build_report();
        assert_eq!(rep.sah_cost, None);
    }
}

#[test]
fn one_triangle() {
    let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
    let bvh = build(&[t], &BvhParams::binary());
    assert_eq!(bvh.nodes().len(), 1);
    assert!(bvh.nodes()[0].is_leaf() && bvh.nodes()[0].count == 1);
    let rays = [
        Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z),
        Ray::new(Vec3::new(0.75, 0.75, 1.0), -Vec3::Z),
        Ray::segment(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z, 0.0, 1.0),
    ];
    for tri in TriTestKind::ALL {
        let h = trace(&bvh, Query::Closest, tri, &rays);
        assert!(h[0].is_hit() && h[0].prim == 0 && (h[0].t - 1.0).abs() < 1e-6);
        assert!(!h[1].is_hit() && !h[2].is_hit());
        let h = trace(&bvh, Query::Any, tri, &rays);
        assert!(h[0].is_hit() && !h[1].is_hit() && !h[2].is_hit());
    }
    let rep = bvh.build_report();
    // A single leaf: SAH cost = C_isect · 1.
    assert_eq!(rep.sah_cost, Some(1.0));
}

#[test]
fn coincident_centroids_stay_within_max_leaf() {
    let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
    let tris = vec![t; 1000];
    let rays = common::rays(&tris, 400, 3);
    for p in all_params() {
        let bvh = build(&tris, &p);
        for n in bvh.nodes() {
            assert!(
                n.count <= p.max_leaf,
                "leaf of {} > {}",
                n.count,
                p.max_leaf
            );
        }
        let depth = figure(&bvh, "depth_max");
        assert!(depth <= 10.0, "depth {depth}");
        check_against_oracle(&tris, &rays, &p);
    }
}

#[test]
fn zero_area_triangles() {
    let mut r = common::rng(4);
    let mut tris = soup(200, 1.0, 0.2, Vec3::ZERO, 5);
    for i in 0..300 {
        let a = common::v3(&mut r);
        let b = common::v3(&mut r);
        tris.push(match i % 3 {
            0 => Triangle::new(a, a, a),             // a point
            1 => Triangle::new(a, b, (a + b) * 0.5), // collinear
            _ => Triangle::new(a, b, a),             // repeated vertex
        });
    }
    let rays = common::rays(&tris, 2000, 6);
    for p in all_params() {
        assert!(check_against_oracle(&tris, &rays, &p) > 100);
    }
    // Scenes of degenerate triangles only: one point repeated, points on a line (zero-area
    // boxes with distinct centroids), segments along a line.
    let point = vec![Triangle::new(Vec3::ONE, Vec3::ONE, Vec3::ONE); 50];
    let line: Vec<Triangle> = (0..100)
        .map(|i| {
            let p = Vec3::new(i as f32 * 0.1, 0.0, 0.0);
            Triangle::new(p, p, p)
        })
        .collect();
    let segs: Vec<Triangle> = (0..100)
        .map(|i| {
            let p = Vec3::new(0.0, i as f32 * 0.1, 1.0);
            Triangle::new(p, p + Vec3::Y * 0.3, p + Vec3::Y * 0.1)
        })
        .collect();
    for scene in [point, line, segs] {
        let rays = common::rays(&scene, 300, 7);
        for p in all_params() {
            let bvh = build(&scene, &p);
            for n in bvh.nodes() {
                assert!(n.count <= p.max_leaf);
            }
            // (Rounding may let the watertight test report hits on collinear triangles; the
            // BVH only has to agree with the oracle.)
            check_against_oracle(&scene, &rays, &p);
        }
    }
}

#[test]
fn depth_is_bounded_for_pathological_scenes() {
    // Exponentially spaced triangles: binned SAH would peel them off one by one.
    let tris: Vec<Triangle> = (0..300)
        .map(|k| {
            let x = 1.3f32.powi(k);
            let s = x * 0.1;
            Triangle::new(
                Vec3::new(x, -s, -s),
                Vec3::new(x, s, -s),
                Vec3::new(x, 0.0, s),
            )
        })
        .collect();
    let mut rays = common::rays(&tris, 1000, 8);
    rays.push(Ray::new(Vec3::new(0.0, 0.0, 0.0), Vec3::X));
    rays.push(Ray::new(Vec3::new(1e30, 0.0, 0.0), -Vec3::X));
    for p in all_params() {
        let bvh = build(&tris, &p);
        assert!(figure(&bvh, "depth_max") <= STACK_SIZE as f64);
        check_against_oracle(&tris, &rays, &p);
    }
}

#[test]
fn counters_do_not_change_results() {
    let tris = soup(2000, 1.0, 0.05, Vec3::ZERO, 11);
    let rays = common::rays(&tris, 3000, 12);
    let bvh = build(&tris, &BvhParams::binary());
    for tri in TriTestKind::ALL {
        for q in [Query::Closest, Query::Any] {
            let plain = trace(&bvh, q, tri, &rays);
            let mut hits = vec![HitRecord::MISS; rays.len()];
            let mut stats = vec![TraversalStats::default(); rays.len()];
            bvh.trace(
                0,
                tb_core::Batch::new(q, tri, &rays),
                tb_core::Answers::new(&mut hits, Some(&mut stats)),
            );
            assert_eq!(plain, hits, "{q:?} {}", tri.name());
            let mut visited = 0;
            for s in &stats {
                assert_eq!(s.steps, s.interior + s.leaves, "{s:?}");
                assert!(s.boxes == 1 + 2 * s.interior, "{s:?}");
                assert_eq!(s.planes + s.restarts, 0);
                if q == Query::Closest {
                    assert!(s.prims <= s.leaves * bvh.params().max_leaf);
                }
                visited += s.steps;
            }
            assert!(visited > rays.len() as u32, "counters count something");
        }
    }
    // Closest hit visits fewer nodes than the whole tree, and far fewer triangles than brute
    // force on average.
    let mut stats = vec![TraversalStats::default(); rays.len()];
    let mut hits = vec![HitRecord::MISS; rays.len()];
    bvh.trace(
        0,
        tb_core::Batch::new(Query::Closest, TriTestKind::Watertight, &rays),
        tb_core::Answers::new(&mut hits, Some(&mut stats)),
    );
    let mean_prims = stats.iter().map(|s| s.prims as f64).sum::<f64>() / rays.len() as f64;
    assert!(mean_prims < 100.0, "{mean_prims}");
}

#[test]
fn flat_arrays_and_reports() {
    assert_eq!(std::mem::size_of::<BvhNode>(), 32);
    let tris = soup(1000, 1.0, 0.05, Vec3::ZERO, 13);
    for p in all_params() {
        let bvh = build(&tris, &p);
        assert_eq!(bvh.triangles().len(), tris.len());
        for (i, &id) in bvh.prim_ids().iter().enumerate() {
            assert_eq!(bvh.triangles()[i], tris[id as usize]);
        }
        let nodes = bvh.nodes();
        // Every leaf within max_leaf; children adjacent and after the parent.
        for (i, n) in nodes.iter().enumerate() {
            if n.is_leaf() {
                assert!(n.count <= p.max_leaf);
            } else {
                assert!(n.index as usize > i && (n.index as usize + 1) < nodes.len());
            }
        }
        let m = bvh.memory();
        assert_eq!(m.node_bytes, 32);
        assert_eq!(m.nodes, nodes.len() as u64);
        assert_eq!(m.prim_refs, 1000);
        assert_eq!(m.bytes, nodes.len() as u64 * 32 + 1000 * 36 + 1000 * 4);
        let rep = bvh.build_report();
        let sah = rep.sah_cost.unwrap();
        assert!(sah > 1.0 && sah < 1000.0, "{sah}");
        assert_eq!(figure(&bvh, "nodes"), nodes.len() as f64);
        assert_eq!(figure(&bvh, "leaves") * 2.0 - 1.0, nodes.len() as f64);
        assert!(figure(&bvh, "leaf_size_max") <= p.max_leaf as f64);
        assert!(figure(&bvh, "prims_per_leaf_mean") >= 1.0);
        assert!(figure(&bvh, "leaf_depth_mean") <= figure(&bvh, "depth_max"));
        assert_eq!(bvh.name(), "bvh");
        assert_eq!(bvh.traversals()[0].name, "ordered");
    }
    // SAH with a larger leaf allowance and cheap triangle tests gives bigger leaves.
    let lazy = build(
        &tris,
        &BvhParams {
            max_leaf: 16,
            c_trav: 4.0,
            ..BvhParams::binary()
        },
    );
    assert!(figure(&lazy, "prims_per_leaf_mean") > 2.0);
}

#[test]
fn params_are_checked() {
    let d = BvhParams::default();
    assert_eq!(d.check(), Ok(()));
    assert_eq!((d.bins, d.max_leaf, d.min_leaf), (16, 4, 1));
    assert_eq!((d.c_trav, d.c_isect), (1.0, 1.0));
    for bad in [
        BvhParams { bins: 1, ..d },
        BvhParams { bins: 257, ..d },
        BvhParams {
            max_leaf: 0,
            min_leaf: 0,
            ..d
        },
        BvhParams { min_leaf: 5, ..d },
        BvhParams { c_trav: 0.0, ..d },
        BvhParams { c_isect: -1.0, ..d },
        BvhParams {
            c_isect: f32::NAN,
            ..d
        },
    ] {
        assert!(bad.check().is_err(), "{bad:?}");
    }
}

#[test]
fn hits_name_scene_indices() {
    // Sanity: the oracle and the BVH agree on a plain hit, and the reported index is the
    // scene's, not the leaf order's.
    let tris: Vec<Triangle> = (0..50)
        .map(|i| {
            let z = -(i as f32);
            Triangle::new(
                Vec3::new(-1.0, -1.0, z),
                Vec3::new(1.0, -1.0, z),
                Vec3::new(0.0, 1.0, z),
            )
        })
        .collect();
    let bvh = build(&tris, &BvhParams::binary());
    let oracle = BruteForce::new(&tris);
    let r = [Ray::new(Vec3::new(0.0, 0.0, -20.5), Vec3::Z)];
    let a = trace(&bvh, Query::Closest, TriTestKind::Watertight, &r)[0];
    let b = trace(&oracle, Query::Closest, TriTestKind::Watertight, &r)[0];
    assert_eq!(a, b);
    assert_eq!(a.prim, 20);
}

fn figure(bvh: &Bvh, name: &str) -> f64 {
    bvh.build_report()
        .extra
        .iter()
        .find(|(k, _)| k == name)
        .unwrap_or_else(|| panic!("no figure {name}"))
        .1
}
