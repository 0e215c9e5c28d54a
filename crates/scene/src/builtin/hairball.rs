//! `hairball`: a procedural stand-in for the Hairball of Pérard-Gayot et al. 2017 (§6, Tables
//! 2 and 3: 2.9M triangles, "very irregular primitive distribution, especially in the center
//! of the hairball, where a lot of the geometry is intertwined"; the original model is not
//! ours to ship). Long, thin, open tubes follow random wandering curves that are steered back
//! into a ball, so they cross and overlap everywhere, densest towards the centre.

use super::common::{budget, camera, scene};
use crate::error::SceneError;
use crate::procedural::Params;
use crate::scene::Scene;
use glam::DVec3;
use rand::Rng;
use rayon::prelude::*;
use tb_core::{Triangle, Vec3};

/// Radius of the ball the strands stay in (their centre lines start within 0.9 of it).
const BALL: f64 = 1.0;
/// Length of every strand's centre line, in ball radii (1.5 diameters).
const LENGTH: f64 = 3.0;
/// Random turn added to the direction at every step (relative to the unit direction).
const WANDER: f64 = 0.35;
/// Radius from which a strand is pulled back towards the centre.
const PULL_FROM: f64 = 0.8;

/// `builtin:hairball?strands=S&segments=N&sides=K&radius=R&seed=X`: `S` strands of `N`
/// segments, each a tube of `K` sides and radius `R` (ball radii): `2·K·N·S` triangles
/// (defaults 2400, 100, 6: 2,880,000). Strands are generated in parallel, each from its own
/// seeded stream, so the scene does not depend on the thread count. Camera outside the ball.
pub(super) fn hairball(params: &Params) -> Result<Scene, SceneError> {
    let strands = params.u32("strands", 2400)?;
    let segments = params.u32("segments", 100)?;
    let sides = params.u32("sides", 6)?;
    let radius = params.f32("radius", 0.006)? as f64;
    let seed = params.u64("seed", 1)?;
    params.check(
        (1..=10_000_000).contains(&strands),
        "parameter `strands` must be in 1..=10000000",
    )?;
    params.check(
        (1..=100_000).contains(&segments),
        "parameter `segments` must be in 1..=100000",
    )?;
    params.check(
        (3..=64).contains(&sides),
        "parameter `sides` must be in 3..=64",
    )?;
    params.check(
        radius > 0.0 && radius <= 0.1,
        "parameter `radius` must be in (0, 0.1] (ball radii)",
    )?;
    let per_strand = 2 * sides as u64 * segments as u64;
    budget(
        params,
        per_strand * strands as u64,
        &format!("hairball: 2*{sides}*{segments}*{strands}"),
    )?;
    let per_strand = per_strand as usize;
    let mut tris =
        vec![Triangle::new(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO); per_strand * strands as usize];
    tris.par_chunks_mut(per_strand)
        .enumerate()
        .for_each(|(i, out)| {
            let line = centre_line(seed, i as u64, segments as usize);
            tube(&line, radius, sides as usize, out);
        });
    let cam = camera(Vec3::new(0.4, 0.9, 3.2), Vec3::ZERO, Vec3::Y, 45.0);
    Ok(scene("hairball", tris, cam, Some(Vec3::new(3.0, 4.0, 5.0))))
}

/// The `segments + 1` points of strand `i`: a random walk with momentum from a random point in
/// the ball, pulled back towards the centre beyond [`PULL_FROM`].
fn centre_line(seed: u64, i: u64, segments: usize) -> Vec<DVec3> {
    let mut rng = rand_pcg::Pcg64::new(seed as u128 ^ 0xcafe_f00d_d15e_a5e5, 2 * i as u128 + 1);
    let unit = |rng: &mut rand_pcg::Pcg64| loop {
        let v = DVec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        let l = v.length_squared();
        if l > 1e-6 && l <= 1.0 {
            break v;
        }
    };
    let mut p = unit(&mut rng) * 0.9 * BALL;
    let mut d = unit(&mut rng).normalize();
    let step = LENGTH * BALL / segments as f64;
    let mut out = Vec::with_capacity(segments + 1);
    out.push(p);
    for _ in 0..segments {
        let r = p.length();
        let mut nd = d + unit(&mut rng) * WANDER;
        if r > PULL_FROM * BALL {
            nd -= p / r * (2.0 * (r - PULL_FROM * BALL) / BALL + 0.2);
        }
        d = nd.normalize_or_zero();
        if d == DVec3::ZERO {
            d = -p.normalize_or(DVec3::X);
        }
        p += d * step;
        out.push(p);
    }
    out
}

/// An open tube of `sides` sides around `line` (rotation-minimising frames), `2·sides` triangles
/// per segment written to `out`.
fn tube(line: &[DVec3], radius: f64, sides: usize, out: &mut [Triangle]) {
    let n = line.len();
    let tangent =
        |k: usize| (line[(k + 1).min(n - 1)] - line[k.saturating_sub(1)]).normalize_or(DVec3::Z);
    let t0 = tangent(0);
    let mut normal = t0.any_orthonormal_vector();
    let mut rings: Vec<Vec<Vec3>> = Vec::with_capacity(n);
    for (k, &c) in line.iter().enumerate() {
        let t = tangent(k);
        normal = (normal - t * normal.dot(t)).normalize_or(t.any_orthonormal_vector());
        let binormal = t.cross(normal);
        rings.push(
            (0..sides)
                .map(|s| {
                    let a = std::f64::consts::TAU * s as f64 / sides as f64;
                    (c + radius * (a.cos() * normal + a.sin() * binormal)).as_vec3()
                })
                .collect(),
        );
    }
    let mut o = 0;
    for k in 0..n - 1 {
        for s in 0..sides {
            let s1 = (s + 1) % sides;
            let (a, b, c, d) = (rings[k][s], rings[k][s1], rings[k + 1][s1], rings[k + 1][s]);
            out[o] = Triangle::new(a, b, c);
            out[o + 1] = Triangle::new(a, c, d);
            o += 2;
        }
    }
}
