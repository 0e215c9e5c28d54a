//! Build time and single-thread throughput of the BVH.
//!
//! ```text
//! cargo run --release -p tb-bvh --example bvh_bench -- [SCENE.obj[.gz] | soup:N] [--reps R]
//! ```
//!
//! Default scene: `../shared/scenes/conference/conference.obj.gz` with the standard conference
//! view (eye (1450,400,450), target (-400,150,-900), up Y, fov 60, 1024x1024). Prints the best
//! of `R` (default 3) build times and trace passes, in MRays/s, for primary rays (closest hit,
//! row and Morton order), random rays (closest and any hit), with the watertight test unless
//! `--mt` is given.

use rand::{Rng, SeedableRng};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::time::Instant;
use tb_bvh::{Bvh, BvhParams};
use tb_core::{
    Aabb, Accel, HitRecord, Query, Ray, StatsSummary, TraversalStats, TriTestKind, Triangle, Vec3,
};
use tb_scene::camera::{Camera, PixelOrder};

const CHUNK: usize = 4096;

/// A minimal `v`/`f` OBJ reader (polygons fan-triangulated, negative indices allowed), used
/// when `tb_scene::load` cannot read the file.
fn read_obj(path: &Path) -> Vec<Triangle> {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let reader: Box<dyn BufRead> = if path.extension().is_some_and(|e| e == "gz") {
        Box::new(BufReader::new(flate2::read::GzDecoder::new(file)))
    } else {
        Box::new(BufReader::new(file))
    };
    let mut verts: Vec<Vec3> = Vec::new();
    let mut tris = Vec::new();
    for line in reader.lines() {
        let line = line.expect("read error");
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f32> = it.take(3).map(|s| s.parse().unwrap()).collect();
                verts.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let idx: Vec<usize> = it
                    .map(|s| {
                        let i: i64 = s.split('/').next().unwrap().parse().unwrap();
                        if i < 0 {
                            (verts.len() as i64 + i) as usize
                        } else {
                            (i - 1) as usize
                        }
                    })
                    .collect();
                for k in 1..idx.len().saturating_sub(1) {
                    tris.push(Triangle::new(
                        verts[idx[0]],
                        verts[idx[k]],
                        verts[idx[k + 1]],
                    ));
                }
            }
            _ => {}
        }
    }
    tris
}

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

/// Best-of-`reps` MRays/s tracing `rays` in chunks, and the hit count.
fn throughput(bvh: &Bvh, rays: &[Ray], q: Query, tri: TriTestKind, reps: usize) -> (f64, usize) {
    let mut hits = vec![HitRecord::MISS; rays.len()];
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t0 = Instant::now();
        for (r, h) in rays.chunks(CHUNK).zip(hits.chunks_mut(CHUNK)) {
            bvh.trace(0, q, tri, r, h, None);
        }
        best = best.min(t0.elapsed().as_secs_f64());
    }
    let n_hit = hits.iter().filter(|h| h.is_hit()).count();
    (rays.len() as f64 / best / 1e6, n_hit)
}

/// Mean per-ray counters, as `name mean` pairs.
fn counters(bvh: &Bvh, rays: &[Ray], q: Query, tri: TriTestKind) -> String {
    let mut hits = vec![HitRecord::MISS; rays.len()];
    let mut stats = vec![TraversalStats::default(); rays.len()];
    bvh.trace(0, q, tri, rays, &mut hits, Some(&mut stats));
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
    let reps = args
        .iter()
        .position(|a| a == "--reps")
        .map_or(3, |i| args[i + 1].parse().unwrap());
    let tri = if args.iter().any(|a| a == "--mt") {
        TriTestKind::MollerTrumbore
    } else {
        TriTestKind::Watertight
    };
    let src = args
        .iter()
        .find(|a| !a.starts_with("--") && a.parse::<usize>().is_err())
        .cloned()
        .unwrap_or_else(|| {
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../shared/scenes/conference/conference.obj.gz"
            )
            .to_string()
        });
    let is_conference = src.contains("conference");
    // `--primary-only`: one build, then only primary rays (row order) `reps` times, for
    // differential `perf stat` measurements on a busy machine.
    let primary_only = args.iter().any(|a| a == "--primary-only");
    let t0 = Instant::now();
    let tris = if let Some(n) = src.strip_prefix("soup:") {
        soup(n.parse().unwrap(), 1)
    } else {
        match tb_scene::load(&src, Path::new(".")) {
            Ok(s) => s.triangles,
            Err(e) => {
                eprintln!("tb_scene::load: {e}; using the example's OBJ reader");
                read_obj(Path::new(&src))
            }
        }
    };
    println!(
        "scene {src}: {} triangles (loaded in {:.2} s)",
        tris.len(),
        t0.elapsed().as_secs_f64()
    );

    let params = BvhParams::default();
    let mut bvh = None;
    let mut best = f64::INFINITY;
    for _ in 0..if primary_only { 1 } else { reps } {
        let t0 = Instant::now();
        let b = Bvh::build(&tris, &params);
        best = best.min(t0.elapsed().as_secs_f64());
        bvh = Some(b);
    }
    let bvh = bvh.unwrap();
    println!("build: {:.3} s (best of {reps}, single thread)", best);
    bvh.validate().expect("valid BVH");
    let rep = bvh.build_report();
    println!("sah_cost {:.2}", rep.sah_cost.unwrap_or(f64::NAN));
    for (k, v) in &rep.extra {
        println!("  {k} {v:.2}");
    }
    let mem = bvh.memory();
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
    if primary_only {
        let rays: Vec<Ray> = cam
            .pixels()
            .into_iter()
            .map(|(x, y)| cam.ray(x, y))
            .collect();
        let (mrays, _) = throughput(&bvh, &rays, Query::Closest, tri, reps);
        println!("primary Row closest ({}): {mrays:.2} MRays/s", tri.name());
        return;
    }
    for order in [PixelOrder::Row, PixelOrder::Morton] {
        let cam = Camera { order, ..cam };
        let rays: Vec<Ray> = cam
            .pixels()
            .into_iter()
            .map(|(x, y)| cam.ray(x, y))
            .collect();
        let (mrays, n_hit) = throughput(&bvh, &rays, Query::Closest, tri, reps);
        println!(
            "primary {order:?} closest ({}): {mrays:.2} MRays/s, {:.1}% hit",
            tri.name(),
            100.0 * n_hit as f64 / rays.len() as f64
        );
        if order == PixelOrder::Row {
            println!("  per ray: {}", counters(&bvh, &rays, Query::Closest, tri));
        }
    }
    let rays = random_rays(&bounds, 1 << 20, 7);
    for q in [Query::Closest, Query::Any] {
        let (mrays, n_hit) = throughput(&bvh, &rays, q, tri, reps);
        println!(
            "random {q:?} ({}): {mrays:.2} MRays/s, {:.1}% hit",
            tri.name(),
            100.0 * n_hit as f64 / rays.len() as f64
        );
        println!("  per ray: {}", counters(&bvh, &rays, q, tri));
    }
}
