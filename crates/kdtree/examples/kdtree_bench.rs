//! Build time and single-thread throughput of the kd-tree, per traversal.
//!
//! ```text
//! cargo run --release -p tb-kdtree --example kdtree_bench -- [SCENE.obj[.gz] | soup:N] [--reps R]
//!     [--mt] [--traversal NAME] [--builder sweep|sweep-nlog2n|binned] [--primary-only]
//! ```
//!
//! Default scene: `../shared/scenes/conference/conference.obj.gz` with the standard conference
//! view of the BVH bench (eye (1450,400,450), target (-400,150,-900), up Y, fov 60, 1024x1024).
//! Prints the best of `R` (default 3) build times, then for each traversal (or only `NAME`)
//! the best of `R` trace passes in MRays/s for primary rays (closest hit, row order) and random
//! rays (closest and any hit), with the watertight test unless `--mt` is given, and the mean
//! per-ray counters.

use rand::{Rng, SeedableRng};
use std::path::Path;
use std::time::Instant;
use tb_core::{
    Aabb, Accel, HitRecord, Query, Ray, StatsSummary, TraversalStats, TriTestKind, Triangle, Vec3,
};
use tb_kdtree::{KdBuilder, KdParams, KdTree, TRAVERSALS};
use tb_scene::camera::{Camera, PixelOrder};

const CHUNK: usize = 4096;

fn soup(n: usize, seed: u64) -> Vec<Triangle> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let c = Vec3::new(rng.gen(), rng.gen(), rng.gen()) * 100.0;
            let mut v = || c + Vec3::new(rng.gen(), rng.gen(), rng.gen()) - 0.5;
            Triangle::new(v(), v(), v())
        })
        .collect()
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

/// Best-of-`reps` MRays/s tracing `rays` in chunks with traversal `ti`, and the hit count.
fn throughput(
    kd: &KdTree,
    ti: usize,
    rays: &[Ray],
    q: Query,
    tri: TriTestKind,
    reps: usize,
) -> (f64, usize) {
    let mut hits = vec![HitRecord::MISS; rays.len()];
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t0 = Instant::now();
        for (r, h) in rays.chunks(CHUNK).zip(hits.chunks_mut(CHUNK)) {
            kd.trace(ti, q, tri, r, h, None);
        }
        best = best.min(t0.elapsed().as_secs_f64());
    }
    let n_hit = hits.iter().filter(|h| h.is_hit()).count();
    (rays.len() as f64 / best / 1e6, n_hit)
}

/// Mean per-ray counters, as `name mean` pairs.
fn counters(kd: &KdTree, ti: usize, rays: &[Ray], q: Query, tri: TriTestKind) -> String {
    let mut hits = vec![HitRecord::MISS; rays.len()];
    let mut stats = vec![TraversalStats::default(); rays.len()];
    kd.trace(ti, q, tri, rays, &mut hits, Some(&mut stats));
    let s = StatsSummary::from_stats(&stats);
    StatsSummary::NAMES
        .iter()
        .zip(s.mean)
        .filter(|(_, m)| *m > 0.0)
        .map(|(n, m)| format!("{n} {m:.1}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .map(|i| args[i + 1].clone())
    };
    let reps = value("--reps").map_or(3, |v| v.parse().unwrap());
    let only = value("--traversal");
    let tri = if args.iter().any(|a| a == "--mt") {
        TriTestKind::MollerTrumbore
    } else {
        TriTestKind::Watertight
    };
    let primary_only = args.iter().any(|a| a == "--primary-only");
    let src = args
        .iter()
        .enumerate()
        .find(|(i, a)| {
            !a.starts_with("--")
                && (*i == 0
                    || !["--reps", "--traversal", "--builder"].contains(&args[i - 1].as_str()))
        })
        .map(|(_, a)| a.clone())
        .unwrap_or_else(|| {
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../shared/scenes/conference/conference.obj.gz"
            )
            .to_string()
        });
    let is_conference = src.contains("conference");
    let t0 = Instant::now();
    let tris = if let Some(n) = src.strip_prefix("soup:") {
        soup(n.parse().unwrap(), 1)
    } else {
        tb_scene::load(&src, Path::new("."))
            .unwrap_or_else(|e| panic!("{src}: {e}"))
            .triangles
    };
    println!(
        "scene {src}: {} triangles (loaded in {:.2} s)",
        tris.len(),
        t0.elapsed().as_secs_f64()
    );

    let builder = match value("--builder").as_deref() {
        None | Some("sweep") => KdBuilder::Sweep,
        Some("sweep-nlog2n") => KdBuilder::SweepNlog2n,
        Some("binned") => KdBuilder::Binned,
        Some(b) => panic!("unknown builder {b}"),
    };
    let params = KdParams {
        builder,
        ..Default::default()
    };
    let mut kd = None;
    let mut best = f64::INFINITY;
    let builds = if primary_only { 1 } else { reps };
    for _ in 0..builds {
        let t0 = Instant::now();
        let k = KdTree::build(&tris, &params);
        best = best.min(t0.elapsed().as_secs_f64());
        kd = Some(k);
    }
    let kd = kd.unwrap();
    println!("build: {best:.3} s (best of {builds}, single thread)");
    kd.validate().expect("valid kd-tree");
    let rep = kd.build_report();
    println!("sah_cost {:.2}", rep.sah_cost.unwrap_or(f64::NAN));
    for (k, v) in &rep.extra {
        println!("  {k} {v:.2}");
    }
    let mem = kd.memory();
    println!("memory {:.1} MiB", mem.bytes as f64 / (1 << 20) as f64);

    let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    let cam = if is_conference {
        Camera {
            eye: Vec3::new(1450.0, 400.0, 450.0),
            target: Vec3::new(-400.0, 150.0, -900.0),
            up: Vec3::Y,
            fov: 60.0,
            width: 1024,
            height: 1024,
            order: PixelOrder::Row,
        }
    } else {
        let c = bounds.center();
        Camera {
            eye: c + bounds.extent() * Vec3::new(0.1, 0.2, 1.5),
            target: c,
            up: Vec3::Y,
            fov: 60.0,
            width: 1024,
            height: 1024,
            order: PixelOrder::Row,
        }
    };
    let primary: Vec<Ray> = cam
        .pixels()
        .into_iter()
        .map(|(x, y)| cam.ray(x, y))
        .collect();
    let random = random_rays(&bounds, 1 << 20, 7);
    for (ti, info) in TRAVERSALS.iter().enumerate() {
        if only.as_deref().is_some_and(|n| n != info.name) {
            continue;
        }
        let (mrays, n_hit) = throughput(&kd, ti, &primary, Query::Closest, tri, reps);
        println!(
            "{}: primary Row closest ({}): {mrays:.2} MRays/s, {:.1}% hit",
            info.name,
            tri.name(),
            100.0 * n_hit as f64 / primary.len() as f64
        );
        if primary_only {
            continue;
        }
        println!(
            "  per ray: {}",
            counters(&kd, ti, &primary, Query::Closest, tri)
        );
        for q in [Query::Closest, Query::Any] {
            let (mrays, n_hit) = throughput(&kd, ti, &random, q, tri, reps);
            println!(
                "{}: random {q:?} ({}): {mrays:.2} MRays/s, {:.1}% hit",
                info.name,
                tri.name(),
                100.0 * n_hit as f64 / random.len() as f64
            );
            println!("  per ray: {}", counters(&kd, ti, &random, q, tri));
        }
    }
}
