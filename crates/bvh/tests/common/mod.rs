//! Shared helpers of the BVH tests: random scenes and rays, oracle comparison.
#![allow(dead_code)]

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use tb_bvh::{Bvh, BvhParams};
use tb_core::{
    compare, Aabb, Accel, BruteForce, HitRecord, Query, Ray, TriTestKind, Triangle, Vec3,
};

pub fn rng(seed: u64) -> Pcg64 {
    Pcg64::seed_from_u64(seed)
}

pub fn v3(rng: &mut Pcg64) -> Vec3 {
    Vec3::new(rng.gen(), rng.gen(), rng.gen())
}

/// `n` random triangles of size about `size` in the box `[0, extent]^3` moved by `offset`.
pub fn soup(n: usize, extent: f32, size: f32, offset: Vec3, seed: u64) -> Vec<Triangle> {
    let mut r = rng(seed);
    (0..n)
        .map(|_| {
            let c = offset + v3(&mut r) * extent;
            let a = c + (v3(&mut r) - 0.5) * size;
            let b = c + (v3(&mut r) - 0.5) * size;
            let d = c + (v3(&mut r) - 0.5) * size;
            Triangle::new(a, b, d)
        })
        .collect()
}

pub fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()))
}

fn unit_dir(r: &mut Pcg64) -> Vec3 {
    loop {
        let d = v3(r) * 2.0 - 1.0;
        let l = d.length_squared();
        if l > 1e-4 && l <= 1.0 {
            return d.normalize();
        }
    }
}

/// A mix of rays: random origins (inside and around the scene) and directions, rays aimed at
/// triangle vertices and edge points, axis-parallel rays, and finite segments.
pub fn rays(tris: &[Triangle], n: usize, seed: u64) -> Vec<Ray> {
    let mut r = rng(seed);
    let b = bounds(tris);
    let (lo, ext) = if b.is_empty() {
        (Vec3::splat(-1.0), Vec3::splat(2.0))
    } else {
        (b.min - b.extent() * 0.2, b.extent() * 1.4)
    };
    (0..n)
        .map(|i| {
            let o = lo + ext * v3(&mut r);
            match i % 5 {
                // Random.
                0 | 1 => Ray::new(o, unit_dir(&mut r)),
                // Aimed at a vertex or an edge point of a random triangle.
                2 if !tris.is_empty() => {
                    let t = &tris[r.gen_range(0..tris.len())];
                    let s: f32 = r.gen();
                    let k = r.gen_range(0..3);
                    let target = if r.gen_bool(0.3) {
                        t.vertex(k)
                    } else {
                        t.vertex(k) * (1.0 - s) + t.vertex((k + 1) % 3) * s
                    };
                    let d = target - o;
                    if d.length_squared() > 0.0 {
                        Ray::new(o, d.normalize())
                    } else {
                        Ray::new(o, Vec3::X)
                    }
                }
                // Axis-parallel (zero direction components, both signs of zero).
                3 => {
                    let axis = r.gen_range(0..3);
                    let mut d = Vec3::splat(if r.gen_bool(0.5) { 0.0 } else { -0.0 });
                    d[axis] = if r.gen_bool(0.5) { 1.0 } else { -1.0 };
                    Ray::new(o, d)
                }
                // Finite segment.
                _ => {
                    let tmin = r.gen::<f32>() * ext.length() * 0.3;
                    let tmax = tmin + r.gen::<f32>() * ext.length() * 0.5;
                    Ray::segment(o, unit_dir(&mut r), tmin, tmax)
                }
            }
        })
        .collect()
}

/// Trace `rays` with `accel` (traversal 0).
pub fn trace(accel: &dyn Accel, q: Query, tri: TriTestKind, rays: &[Ray]) -> Vec<HitRecord> {
    let mut hits = vec![HitRecord::MISS; rays.len()];
    for (r, h) in rays.chunks(97).zip(hits.chunks_mut(97)) {
        accel.trace(0, tb_core::Batch::new(q, tri, r), tb_core::Answers::hits(h));
    }
    hits
}

/// Build and validate.
pub fn build(tris: &[Triangle], params: &BvhParams) -> Bvh {
    let bvh = Bvh::build(tris, params);
    bvh.validate()
        .unwrap_or_else(|e| panic!("invalid BVH ({params:?}): {e}"));
    bvh
}

/// Compare closest and any hits with the oracle for both triangle tests; returns the number of
/// oracle hits (closest, watertight) so callers can check the test is not vacuous. Panics on
/// the first watertight mismatch; Möller–Trumbore may differ on at most 1% of the rays.
pub fn check_against_oracle(tris: &[Triangle], rays: &[Ray], params: &BvhParams) -> usize {
    let bvh = build(tris, params);
    check_accel_against_oracle(tris, rays, &bvh, &format!("{params:?}"))
}

/// [`check_against_oracle`] for any built structure `accel` (traversal 0), named `label` in
/// the failure message.
pub fn check_accel_against_oracle(
    tris: &[Triangle],
    rays: &[Ray],
    accel: &dyn Accel,
    label: &str,
) -> usize {
    let bvh = accel;
    let oracle = BruteForce::new(tris);
    let mut hits = 0;
    let mut mt_mismatches = 0;
    for tri in TriTestKind::ALL {
        for q in [Query::Closest, Query::Any] {
            let want = trace(&oracle, q, tri, rays);
            let got = trace(bvh, q, tri, rays);
            for (i, (w, g)) in want.iter().zip(&got).enumerate() {
                let m = compare(q, &rays[i], w, g);
                if let Some(kind) = m {
                    if tri == TriTestKind::MollerTrumbore {
                        // Möller–Trumbore is not conservative (e.g. t = 0 from cancellation
                        // far from the origin, outside the triangle's box): a hit the box
                        // test rightly culls may differ. Counted, not failed.
                        mt_mismatches += 1;
                        continue;
                    }
                    panic!(
                        "{label} {q:?} {}: ray {i} {:?}: {kind:?}, expected {w:?}, got {g:?}",
                        tri.name(),
                        rays[i]
                    );
                }
                if q == Query::Closest && g.is_hit() && g.prim == w.prim {
                    // Same triangle, same arithmetic: bit-identical answers.
                    assert_eq!(
                        (g.t.to_bits(), g.u.to_bits(), g.v.to_bits()),
                        (w.t.to_bits(), w.u.to_bits(), w.v.to_bits()),
                        "ray {i}: same triangle, different t/u/v"
                    );
                }
            }
            if q == Query::Closest && tri == TriTestKind::Watertight {
                hits = want.iter().filter(|h| h.is_hit()).count();
            }
        }
    }
    assert!(
        mt_mismatches * 100 <= rays.len(),
        "{mt_mismatches} Möller–Trumbore mismatches for {} rays",
        rays.len()
    );
    hits
}

/// Random soups of 1, 7, 300 and 1500 triangles (seeds from `k`, the parameter set's index)
/// with their rays, each given to `check` (the oracle's hit count back): the soups of 300 and
/// more must give over 100 hits, so the comparison is not vacuous.
pub fn for_random_soups(k: usize, check: &dyn Fn(&[Triangle], &[Ray]) -> usize) {
    for (n, size) in [(1usize, 0.5f32), (7, 0.5), (300, 0.1), (1500, 0.05)] {
        let tris = soup(n, 1.0, size, Vec3::ZERO, 10 + k as u64 + n as u64);
        let rays = rays(&tris, 1500, 99 + n as u64);
        let hits = check(&tris, &rays);
        if n >= 300 {
            assert!(hits > 100, "too few hits ({hits}) to mean anything");
        }
    }
}
