//! The shared conformance suite (`tb_scene::conformance`): stress scenes and rays, against the
//! oracle, for the default BVH (binned BVH8), the binary binned BVH and extreme parameter sets.

use tb_bvh::{Bvh, BvhParams};
use tb_core::Accel;

fn run(params: BvhParams) {
    tb_scene::conformance::assert_conforms(&move |tris| {
        let bvh = Bvh::build(tris, &params);
        bvh.validate().expect("valid BVH");
        Box::new(bvh) as Box<dyn Accel>
    });
}

#[test]
fn conforms_default() {
    run(BvhParams::default());
}

#[test]
fn conforms_binary() {
    run(BvhParams::binary());
}

#[test]
fn conforms_bins4_leaf1() {
    run(BvhParams {
        bins: 4,
        max_leaf: 1,
        ..BvhParams::binary()
    });
}

#[test]
fn conforms_bins32_leaf8() {
    run(BvhParams {
        bins: 32,
        max_leaf: 8,
        ..BvhParams::binary()
    });
}

#[test]
fn conforms_bvh4() {
    run(BvhParams {
        width: 4,
        ..BvhParams::binary()
    });
}

#[test]
fn conforms_bvh8() {
    run(BvhParams {
        width: 8,
        ..BvhParams::binary()
    });
}

#[test]
fn conforms_bvh4_scalar_leaf1() {
    run(BvhParams {
        width: 4,
        max_leaf: 1,
        simd: tb_bvh::Simd::Scalar,
        ..BvhParams::binary()
    });
}

#[test]
fn conforms_bvh8_scalar_leaf8() {
    run(BvhParams {
        width: 8,
        max_leaf: 8,
        simd: tb_bvh::Simd::Scalar,
        ..BvhParams::binary()
    });
}

#[test]
fn conforms_sbvh() {
    run(BvhParams {
        builder: tb_bvh::Builder::Sbvh,
        ..BvhParams::binary()
    });
}

/// `alpha = 0`: spatial splits wherever children overlap at all (the most clipping).
#[test]
fn conforms_sbvh_alpha0_bvh4_leaf1() {
    run(BvhParams {
        builder: tb_bvh::Builder::Sbvh,
        alpha: 0.0,
        width: 4,
        max_leaf: 1,
        ..BvhParams::binary()
    });
}

#[test]
fn conforms_sbvh_alpha0_bvh8() {
    run(BvhParams {
        builder: tb_bvh::Builder::Sbvh,
        alpha: 0.0,
        width: 8,
        ..BvhParams::binary()
    });
}

/// The greedy collapse (the SAH one is the default of the rows above).
#[test]
fn conforms_bvh8_greedy_collapse() {
    run(BvhParams {
        width: 8,
        collapse: tb_bvh::Collapse::Greedy,
        ..BvhParams::binary()
    });
}

/// Leaves priced by blocks of four: larger leaves, and the collapse merging subtrees into
/// leaves of up to `max_leaf` triangles.
#[test]
fn conforms_blocks_bvh4_leaf8() {
    run(BvhParams {
        width: 4,
        max_leaf: 8,
        leaf_cost: tb_bvh::LeafCost::Blocks,
        ..BvhParams::binary()
    });
}

/// The SBVH with binned object splits (the sweep is the default) and leaves priced by blocks.
#[test]
fn conforms_sbvh_binned_objects_blocks_bvh8() {
    run(BvhParams {
        builder: tb_bvh::Builder::Sbvh,
        object_split: tb_bvh::ObjectSplit::Binned,
        leaf_cost: tb_bvh::LeafCost::Blocks,
        width: 8,
        max_leaf: 8,
        ..BvhParams::binary()
    });
}
