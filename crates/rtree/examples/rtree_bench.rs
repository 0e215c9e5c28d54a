//! Build time and single-thread primary-ray throughput of the R-tree, per traversal.
//!
//! ```text
//! cargo run --release -p tb-rtree --example rtree_bench -- [SCENE.obj[.gz]] [--reps R]
//!     [--strategy NAME] [--no-reinsert] [--m m] [--big-m M] [--order NAME] [--random]
//! ```
//!
//! Default scene: `../shared/scenes/conference/conference.obj.gz` with the standard conference
//! view (eye (1450,400,450), target (-400,150,-900), up Y, fov 60, 1024x1024, row order).
//! Prints the best of `R` (default 3) build times, the build report, memory including empty
//! slots, and per traversal the best-of-`R` MRays/s for primary rays (closest hit, watertight
//! test) with the mean per-ray counters; with `--random`, also 2^20 random rays in the scene
//! bounds (closest and any hit).

use rand::{Rng, SeedableRng};
use std::path::Path;
use std::time::Instant;
use tb_core::{
    Aabb, Accel, HitRecord, Query, Ray, StatsSummary, TraversalStats, TriTestKind, Vec3,
};
use tb_rtree::{ChildOrder, Rtree, RtreeParams, Strategy};
use tb_scene::camera::{Camera, PixelOrder};

const CHUNK: usize = 4096;

fn arg<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    args.iter()
        .position(|a| a == name)
        .map(|i| args[i + 1].as_str())
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let reps: usize = arg(&args, "--reps").map_or(3, |s| s.parse().unwrap());
    let mut params = RtreeParams::default();
    if let Some(s) = arg(&args, "--strategy") {
        params.strategy = Strategy::from_name(s).expect("unknown strategy");
    }
    if let Some(s) = arg(&args, "--order") {
        params.child_order = ChildOrder::from_name(s).expect("unknown child order");
    }
    if let Some(s) = arg(&args, "--m") {
        params.m = s.parse().unwrap();
    }
    if let Some(s) = arg(&args, "--big-m") {
        params.big_m = s.parse().unwrap();
    }
    if args.iter().any(|a| a == "--no-reinsert") {
        params.reinsert = false;
    }
    params.check().expect("valid parameters");
    let src = args
        .iter()
        .enumerate()
        .find(|(i, a)| !a.starts_with("--") && (*i == 0 || !args[*i - 1].starts_with("--")))
        .map(|(_, a)| a.clone())
        .unwrap_or_else(|| {
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../shared/scenes/conference/conference.obj.gz"
            )
            .to_string()
        });
    let t0 = Instant::now();
    let tris = tb_scene::load(&src, Path::new("."))
        .unwrap_or_else(|e| panic!("{src}: {e}"))
        .triangles;
    println!(
        "scene {src}: {} triangles (loaded in {:.2} s)",
        tris.len(),
        t0.elapsed().as_secs_f64()
    );
    println!("params {params:?}");

    let mut tree = None;
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        drop(tree.take());
        let t0 = Instant::now();
        let t = Rtree::build(&tris, &params);
        best = best.min(t0.elapsed().as_secs_f64());
        tree = Some(t);
    }
    let tree = tree.unwrap();
    println!("build: {best:.3} s (best of {reps}, single thread, packing included)");
    tree.validate().expect("valid R-tree");
    let rep = tree.build_report();
    println!("sah_cost {:.2}", rep.sah_cost.unwrap_or(f64::NAN));
    for (k, v) in &rep.extra {
        println!("  {k} {v:.3}");
    }
    let mem = tree.memory();
    println!(
        "memory {:.1} MiB ({} slots of {} bytes, empty slots included)",
        mem.bytes as f64 / (1 << 20) as f64,
        mem.nodes,
        mem.node_bytes
    );

    let cam = Camera {
        eye: Vec3::new(1450.0, 400.0, 450.0),
        target: Vec3::new(-400.0, 150.0, -900.0),
        up: Vec3::Y,
        fov: 60.0,
        width: 1024,
        height: 1024,
        order: PixelOrder::Row,
    };
    let rays: Vec<Ray> = cam
        .pixels()
        .into_iter()
        .map(|(x, y)| cam.ray(x, y))
        .collect();
    let tri = TriTestKind::Watertight;
    run(&tree, "primary", &rays, Query::Closest, tri, reps);
    if args.iter().any(|a| a == "--random") {
        let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
        let rays = random_rays(&bounds, 1 << 20, 7);
        run(&tree, "random", &rays, Query::Closest, tri, reps);
        run(&tree, "random", &rays, Query::Any, tri, reps);
    }
}

fn random_rays(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let o = b.min + b.extent() * Vec3::new(rng.gen(), rng.gen(), rng.gen());
            let d = loop {
                let d = Vec3::new(rng.gen(), rng.gen(), rng.gen()) * 2.0 - 1.0;
                let l = d.length_squared();
                if l > 1e-4 && l <= 1.0 {
                    break d.normalize();
                }
            };
            Ray::new(o, d)
        })
        .collect()
}

/// Best-of-`reps` MRays/s of every traversal over `rays`, with mean per-ray counters.
fn run(tree: &Rtree, label: &str, rays: &[Ray], q: Query, tri: TriTestKind, reps: usize) {
    for (ti, info) in tree.traversals().iter().enumerate() {
        let mut hits = vec![HitRecord::MISS; rays.len()];
        let mut best = f64::INFINITY;
        for _ in 0..reps {
            let t0 = Instant::now();
            for (r, h) in rays.chunks(CHUNK).zip(hits.chunks_mut(CHUNK)) {
                tree.trace(ti, q, tri, r, h, None);
            }
            best = best.min(t0.elapsed().as_secs_f64());
        }
        let n_hit = hits.iter().filter(|h| h.is_hit()).count();
        let mut stats = vec![TraversalStats::default(); rays.len()];
        tree.trace(ti, q, tri, rays, &mut hits, Some(&mut stats));
        let s = StatsSummary::from_stats(&stats);
        let per_ray = StatsSummary::NAMES
            .iter()
            .zip(s.mean)
            .filter(|(_, m)| *m > 0.0)
            .map(|(n, m)| format!("{n} {m:.1}"))
            .collect::<Vec<_>>()
            .join(", ");
        println!(
            "{label} {q:?} {:<9} {:.2} MRays/s, {:.1}% hit; per ray: {per_ray}",
            info.name,
            rays.len() as f64 / best / 1e6,
            100.0 * n_hit as f64 / rays.len() as f64
        );
    }
}
