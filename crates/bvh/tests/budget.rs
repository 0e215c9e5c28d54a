//! 2,000 overlapping coplanar triangles: every SBVH node passes the overlap threshold and every
//! spatial split cuts nearly all of them (10.9M references and 120 s without a bound). With the
//! reference allowance the build stays within 32 references per triangle, takes well under a
//! second, says that the bound acted, and answers every ray as brute force does.

use tb_bvh::{Builder, Bvh, BvhParams};
use tb_core::{Accel, Query};

#[test]
fn sbvh_of_coplanar_overlaps_stays_within_the_reference_allowance() {
    let tris = tb_scene::conformance::coplanar_overlaps(2000);
    for width in [2, 8] {
        let params = BvhParams {
            builder: Builder::Sbvh,
            width,
            ..BvhParams::binary()
        };
        let t0 = std::time::Instant::now();
        let bvh = Bvh::try_build(&tris, &params).unwrap();
        let secs = t0.elapsed().as_secs_f64();
        let refs = bvh.prim_ids().len();
        assert!(refs <= 32 * tris.len(), "{refs} references");
        assert!(secs < 10.0, "{secs} s");
        let report = Accel::build_report(&bvh);
        assert!(
            report
                .extra
                .iter()
                .any(|e| e.0 == "ref_budget_splits" && e.1 > 0.0),
            "{:?}",
            report.extra
        );
        let rays = tb_scene::conformance::rays_around(&tris, 3000, 9);
        for query in [Query::Closest, Query::Any] {
            let differ = tb_scene::conformance::differences(&bvh, 0, &tris, &rays, query);
            assert_eq!(differ, 0, "width {width} {query:?}");
        }
    }
}
