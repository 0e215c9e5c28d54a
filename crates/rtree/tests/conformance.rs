//! The shared conformance suite (`tb_scene::conformance`): stress scenes and rays against the
//! oracle, every traversal, for each ChooseSubtree strategy with default parameters and a
//! few parameter extremes.

use tb_core::Accel;
use tb_rtree::{ChildOrder, Rtree, RtreeParams, Strategy};

fn run(params: RtreeParams) {
    tb_scene::conformance::assert_conforms(&move |tris| {
        let t = Rtree::build(tris, &params);
        t.validate().expect("valid R-tree");
        Box::new(t) as Box<dyn Accel>
    });
}

fn strategy(strategy: Strategy) -> RtreeParams {
    RtreeParams {
        strategy,
        ..Default::default()
    }
}

#[test]
fn conforms_r_star_srfc() {
    run(strategy(Strategy::RStarSrfc));
}

#[test]
fn conforms_r_star() {
    run(strategy(Strategy::RStar));
}

#[test]
fn conforms_min_volume() {
    run(strategy(Strategy::MinVolume));
}

#[test]
fn conforms_min_surface() {
    run(strategy(Strategy::MinSurface));
}

#[test]
fn conforms_min_overlap() {
    run(strategy(Strategy::MinOverlap));
}

#[test]
fn conforms_min_overlap_enlargement() {
    run(strategy(Strategy::MinOverlapEnlargement));
}

#[test]
fn conforms_surface_ties_variants() {
    run(strategy(Strategy::MinVolumeSurfaceTies));
    run(strategy(Strategy::RStarSurfaceTies));
}

#[test]
fn conforms_r_star_overlap_after_variants() {
    run(strategy(Strategy::RStarOverlapAfter));
    run(strategy(Strategy::RStarSrfcOverlapAfter));
}

#[test]
fn conforms_no_reinsert_sorted_m16() {
    run(RtreeParams {
        m: 3,
        big_m: 16,
        reinsert: false,
        child_order: ChildOrder::SortedX,
        ..Default::default()
    });
}

#[test]
fn conforms_no_reinsert() {
    run(RtreeParams {
        reinsert: false,
        ..Default::default()
    });
}

#[test]
fn conforms_str_bulk_load() {
    run(RtreeParams {
        strategy: Strategy::Str,
        child_order: ChildOrder::SortedZ,
        ..Default::default()
    });
}
