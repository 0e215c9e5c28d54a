//! The compressed wide BVH (`cwbvh`, Ylitie, Karras and Laine 2017) against the brute-force
//! oracle: random soups (small and large triangles, far from the origin, tiny and huge
//! scales) and the shared conformance suite, for both builders and leaf sizes 1 to 3. Zero
//! watertight mismatches allowed; every build validated (its quantized boxes contain their
//! triangles).

mod common;

use common::*;
use tb_bvh::{Builder, Cwbvh, CwbvhParams};
use tb_core::{Accel, Vec3};

fn param_sets() -> Vec<CwbvhParams> {
    let d = CwbvhParams::default();
    vec![
        d,
        CwbvhParams {
            builder: Builder::Binned,
            ..d
        },
        CwbvhParams {
            max_leaf: 1,
            c_isect: 1.0,
            ..d
        },
        CwbvhParams {
            builder: Builder::Binned,
            max_leaf: 2,
            c_trav: 10.0,
            bins: 4,
            ..d
        },
    ]
}

fn build(tris: &[tb_core::Triangle], p: &CwbvhParams) -> Cwbvh {
    let cw = Cwbvh::build(tris, p);
    cw.validate()
        .unwrap_or_else(|e| panic!("invalid CWBVH ({p:?}): {e}"));
    cw
}

fn check(tris: &[tb_core::Triangle], rays: &[tb_core::Ray], p: &CwbvhParams) -> usize {
    check_accel_against_oracle(tris, rays, &build(tris, p), &format!("{p:?}"))
}

#[test]
fn random_soups_match_the_oracle() {
    for (k, p) in param_sets().iter().enumerate() {
        for_random_soups(k, &|tris, rays| check(tris, rays, p));
    }
}

#[test]
fn large_overlapping_and_extreme_scales() {
    let tris = soup(400, 1.0, 1.5, Vec3::ZERO, 3);
    let r = rays(&tris, 3000, 4);
    for p in param_sets() {
        assert!(check(&tris, &r, &p) > 1000);
    }
    for (tris, seed) in [
        (soup(500, 1.0, 0.1, Vec3::splat(1.0e6), 5), 6),
        (soup(500, 1e-5, 1e-6, Vec3::ZERO, 7), 8),
        (soup(500, 1e7, 1e6, Vec3::splat(-5e6), 9), 10),
    ] {
        let r = rays(&tris, 2000, seed);
        check(&tris, &r, &CwbvhParams::default());
    }
}

/// The layout's rules hold on a real-sized soup: leaves of at most `max_leaf` triangles, the
/// node 80 bytes, nearly full nodes (the SAH collapse fills the slots), and the octant
/// order changes which child a ray visits first (the same node group popped in different
/// orders for opposite octants gives the same hits: checked by the oracle tests).
#[test]
fn layout_figures() {
    let tris = soup(20_000, 50.0, 1.0, Vec3::ZERO, 21);
    let cw = build(&tris, &CwbvhParams::default());
    let m = cw.memory();
    assert_eq!(m.node_bytes, 80);
    assert_eq!(m.nodes as usize, cw.nodes().len());
    let r = cw.build_report();
    let get = |k: &str| r.extra.iter().find(|e| e.0 == k).map(|e| e.1).unwrap();
    assert!(get("wide_fill") > 5.0, "fill {}", get("wide_fill"));
    assert!(get("prims_per_leaf_mean") > 1.0 && get("prims_per_leaf_mean") <= 3.0);
    for n in cw.nodes() {
        for s in 0..8 {
            if n.meta[s] != 0 && !n.is_interior(s) {
                assert!(n.leaf(s).1 <= 3);
            }
        }
    }
    assert!(r.sah_cost.is_some_and(|c| c > 0.0));
}

#[test]
fn conforms() {
    for p in [
        CwbvhParams::default(),
        CwbvhParams {
            builder: Builder::Binned,
            max_leaf: 1,
            ..CwbvhParams::default()
        },
    ] {
        tb_scene::conformance::assert_conforms(&move |tris| {
            Box::new(build(tris, &p)) as Box<dyn Accel>
        });
    }
}

/// An empty scene builds an empty tree that misses every ray.
#[test]
fn empty_scene() {
    let cw = build(&[], &CwbvhParams::default());
    assert!(cw.nodes().is_empty());
    let r = rays(&soup(10, 1.0, 0.5, Vec3::ZERO, 1), 50, 2);
    for h in trace(
        &cw,
        tb_core::Query::Closest,
        tb_core::TriTestKind::Watertight,
        &r,
    ) {
        assert!(!h.is_hit());
    }
}
