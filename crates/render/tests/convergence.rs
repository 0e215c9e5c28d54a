//! Monte Carlo convergence on the Cornell box: the RMSE against a high-sample reference falls
//! as `1/sqrt(spp)`, so quadrupling the samples halves it (the band allows for the noise of a
//! small image and for the reference's own error).

use tb_core::TriTestKind;
use tb_render::integrate::{render, Integrator, Progressive};
use tb_render::metrics::{rel_mse, rmse};
use tb_render::AccelTracer;

fn check(integrator: Integrator) {
    let scene = tb_scene::load("builtin:cornell", std::path::Path::new(".")).unwrap();
    let tris = &scene.triangles;
    let mut camera = scene.view.unwrap().camera;
    camera.width = 32;
    camera.height = 32;
    let bvh = tb_bvh::Bvh::build(tris, &tb_bvh::BvhParams::default());
    let tracer = AccelTracer {
        accel: &bvh,
        traversal: 0,
        tri: TriTestKind::Watertight,
    };
    // The reference uses another seed than the measured render: with the same seed the first
    // samples would be shared and the error underestimated.
    let reference = render(tris, camera, integrator, 99, 2048, &tracer, 1 << 20);
    let mut r = Progressive::new(tris, camera, integrator, 1);
    let mut errors = Vec::new();
    for spp in [4u32, 16, 64] {
        r.pass(&tracer, spp - r.spp());
        let img = r.image();
        errors.push((spp, rmse(&img, &reference), rel_mse(&img, &reference)));
    }
    println!("{}: (spp, rmse, rel_mse) {errors:?}", integrator.name());
    for w in errors.windows(2) {
        let ratio = w[1].1 / w[0].1;
        assert!(
            (0.35..=0.7).contains(&ratio),
            "{}: RMSE({}) / RMSE({}) = {ratio:.3}, expected about 0.5",
            integrator.name(),
            w[1].0,
            w[0].0
        );
        assert!(w[1].2 < w[0].2, "relative MSE falls too");
    }
}

#[test]
fn ao_rmse_falls_as_one_over_sqrt_spp() {
    check(Integrator::Ao { distance: 150.0 });
}

#[test]
fn path_rmse_falls_as_one_over_sqrt_spp() {
    check(Integrator::Path {
        bounces: 3,
        albedo: 0.7,
    });
}
