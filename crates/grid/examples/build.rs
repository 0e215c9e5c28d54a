//! Build an irregular grid over a scene `N` times (default 2) and print each build's time and
//! figures (phase times, memory per part): `TRACE_BENCH_SCENES=../shared/scenes cargo run
//! --release -p tb-grid --example build -- conference/conference.obj.gz [lambda_1 lambda_2]`.
use std::sync::Arc;
use tb_core::Structure;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let root = std::env::var("TRACE_BENCH_SCENES").unwrap_or_else(|_| "../shared/scenes".into());
    let scene = tb_scene::source::load(&args[1], std::path::Path::new(&root)).unwrap();
    let mut p = tb_grid::IrregularParams::default();
    if args.len() > 3 {
        p.densities.lambda_1 = args[2].parse().unwrap();
        p.densities.lambda_2 = args[3].parse().unwrap();
    }
    let tris: Arc<[tb_core::Triangle]> = scene.triangles.clone().into();
    let n: usize = std::env::var("N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2);
    for _ in 0..n {
        let t = std::time::Instant::now();
        let g = tb_grid::IrregularGrid::build(&tris, &p).unwrap();
        println!(
            "{:.1} ms {:?}",
            t.elapsed().as_secs_f64() * 1e3,
            g.report().extra
        );
    }
}
