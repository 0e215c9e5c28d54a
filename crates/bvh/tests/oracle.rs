//! The BVH against the brute-force oracle on random triangle soups and random rays: closest and
//! any hit, both triangle tests, several build parameters. Zero mismatches allowed.

mod common;

use common::*;
use tb_bvh::BvhParams;
use tb_core::Vec3;

fn param_sets() -> Vec<BvhParams> {
    let d = BvhParams::binary();
    vec![
        BvhParams::default(),
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
        BvhParams {
            bins: 2,
            max_leaf: 2,
            min_leaf: 2,
            ..d
        },
        BvhParams {
            bins: 256,
            c_trav: 10.0,
            max_leaf: 16,
            min_leaf: 3,
            ..d
        },
    ]
}

#[test]
fn random_soups_match_the_oracle() {
    for (k, p) in param_sets().iter().enumerate() {
        for_random_soups(k, &|tris, rays| check_against_oracle(tris, rays, p));
    }
}

#[test]
fn large_triangles_overlapping_boxes() {
    // Big, heavily overlapping triangles: many boxes overlap, ordering matters.
    let tris = soup(400, 1.0, 1.5, Vec3::ZERO, 3);
    let rays = common::rays(&tris, 3000, 4);
    for p in param_sets() {
        assert!(check_against_oracle(&tris, &rays, &p) > 1000);
    }
}

#[test]
fn far_from_the_origin_and_tiny_scale() {
    // 1e6 translation: coordinates with few bits of fraction left.
    let tris = soup(500, 1.0, 0.1, Vec3::splat(1.0e6), 5);
    let rays = common::rays(&tris, 2000, 6);
    for p in [BvhParams::default(), BvhParams::binary()] {
        check_against_oracle(&tris, &rays, &p);
    }
    // Tiny scale.
    let tris = soup(500, 1e-5, 1e-6, Vec3::ZERO, 7);
    let rays = common::rays(&tris, 2000, 8);
    for p in [BvhParams::default(), BvhParams::binary()] {
        assert!(check_against_oracle(&tris, &rays, &p) > 100);
    }
    // Huge scale.
    let tris = soup(500, 1e7, 1e6, Vec3::splat(-5e6), 9);
    let rays = common::rays(&tris, 2000, 10);
    for p in [BvhParams::default(), BvhParams::binary()] {
        assert!(check_against_oracle(&tris, &rays, &p) > 100);
    }
}

/// The parallel builds (binned, SBVH) make the same tree as one thread, and the wide trees
/// collapsed from them agree too.
#[test]
fn parallel_builds_equal_sequential() {
    let tris = common::soup(30_000, 100.0, 2.0, Vec3::ZERO, 11);
    for builder in [tb_bvh::Builder::Binned, tb_bvh::Builder::Sbvh] {
        let p = |threads| BvhParams {
            builder,
            build_threads: threads,
            width: 8,
            ..BvhParams::binary()
        };
        let one = tb_bvh::Bvh::build(&tris, &p(1));
        let two = tb_bvh::Bvh::build(&tris, &p(2));
        assert_eq!(one.nodes(), two.nodes(), "{builder:?}");
        assert_eq!(one.prim_ids(), two.prim_ids(), "{builder:?}");
        use tb_core::Accel;
        assert!(one.validate().is_ok() && two.validate().is_ok());
        let (tb_bvh::WideNodes::W8(a), tb_bvh::WideNodes::W8(b)) =
            (one.wide_nodes(), two.wide_nodes())
        else {
            panic!("width 8 expected");
        };
        assert_eq!(a, b);
    }
}
