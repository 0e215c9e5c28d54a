//! The SIMD paths of the wide BVHs (SIMD child-box tests, leaves tested four triangles at a
//! time) against the scalar reference (`simd = "scalar"`): the same hit records bit for bit
//! and the same counters on every ray, closest and any hit, both triangle tests.

mod common;

use tb_bvh::{Builder, Bvh, BvhParams, LeafCost, Simd};
use tb_core::{Accel, HitRecord, Query, TraversalStats, TriTestKind, Vec3};

fn trace(
    b: &Bvh,
    q: Query,
    t: TriTestKind,
    rays: &[tb_core::Ray],
) -> Vec<(u32, u32, u32, u32, TraversalStats)> {
    let mut hits = vec![HitRecord::MISS; rays.len()];
    let mut stats = vec![TraversalStats::default(); rays.len()];
    b.trace(
        0,
        tb_core::Batch::new(q, t, rays),
        tb_core::Answers::new(&mut hits, Some(&mut stats)),
    );
    hits.iter()
        .zip(stats)
        .map(|(h, s)| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits(), s))
        .collect()
}

#[test]
fn simd_equals_scalar_bit_for_bit() {
    // Leaves of up to 8 triangles (two blocks), large overlapping triangles (many hits per
    // leaf, resolved in order) and small ones.
    let scenes = [
        common::soup(3000, 1.0, 0.08, Vec3::ZERO, 21),
        common::soup(600, 1.0, 0.9, Vec3::ZERO, 22),
    ];
    for tris in &scenes {
        let rays = common::rays(tris, 3000, 23);
        for (builder, width, max_leaf, leaf_cost) in [
            (Builder::Binned, 4, 4, LeafCost::Linear),
            (Builder::Binned, 8, 8, LeafCost::Linear),
            (Builder::Sbvh, 8, 4, LeafCost::Linear),
            (Builder::Sbvh, 8, 8, LeafCost::Blocks),
        ] {
            let p = |simd| BvhParams {
                builder,
                width,
                max_leaf,
                leaf_cost,
                c_isect: 0.5,
                simd,
                ..BvhParams::binary()
            };
            let auto = common::build(tris, &p(Simd::Auto));
            let scalar = common::build(tris, &p(Simd::Scalar));
            for q in [Query::Closest, Query::Any] {
                for t in TriTestKind::ALL {
                    let (a, s) = (trace(&auto, q, t, &rays), trace(&scalar, q, t, &rays));
                    for (i, (a, s)) in a.iter().zip(&s).enumerate() {
                        assert_eq!(
                            a, s,
                            "ray {i} {:?}, {builder:?} w{width} {q:?} {t:?}",
                            rays[i]
                        );
                    }
                    let hit = a.iter().filter(|h| h.1 != HitRecord::MISS.prim).count();
                    assert!(hit > 300, "too few hits ({hit}) to mean anything");
                }
            }
        }
    }
}
