//! `crown`: a procedural stand-in for the Crown of Pérard-Gayot et al. 2017 (§6, Tables 2 and
//! 3, Figure 6: a large detailed object of 3.5M triangles; the original model is not ours to
//! ship). One compact object, finely tessellated everywhere, with small separate parts: a
//! band with a carved relief and pointed teeth (inner and outer surfaces, joined at the rims),
//! rows of gems (icospheres) half set into it, and a gem on every tooth tip.

use super::common::{budget, camera, scene};
use super::spd::unit_icosphere;
use crate::error::SceneError;
use crate::procedural::Params;
use crate::scene::Scene;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::TAU;
use tb_core::{Triangle, Vec3};

/// Outer radius of the band, its thickness and its height below the teeth.
const RADIUS: f64 = 1.0;
const THICK: f64 = 0.06;
const HEIGHT: f64 = 0.45;
/// Height of the teeth above the band.
const TOOTH: f64 = 0.35;
/// Depth of the carved relief on the outer surface.
const RELIEF: f64 = 0.012;
/// Gem rows: heights (fractions of the band height) and gem radius.
const GEM_ROWS: [f64; 2] = [0.3, 0.7];
const GEM: f64 = 0.035;

/// `builtin:crown?tess=K&points=P&gems=G&gem_tess=T`: a band of `128·K x 32·K` quads per
/// surface (outer with relief, inner plain) joined by rim strips, `P` teeth, `G` gems (in
/// two rows) and `P` tip gems of `20·4^T` triangles each: `16384·K² + 512·K +
/// 20·4^T·(G + P)` triangles (defaults 13, 16, 128, 4: 3,512,832). Generated in parallel,
/// deterministic.
pub(super) fn crown(params: &Params) -> Result<Scene, SceneError> {
    let tess = params.u32("tess", 13)?;
    let points = params.u32("points", 16)?;
    let gems = params.u32("gems", 128)?;
    let gem_tess = params.u32("gem_tess", 4)?;
    params.check(
        (1..=200).contains(&tess),
        "parameter `tess` must be in 1..=200",
    )?;
    params.check(
        (3..=1000).contains(&points),
        "parameter `points` must be in 3..=1000",
    )?;
    params.check(gems <= 100_000, "parameter `gems` must be in 0..=100000")?;
    params.check(gem_tess <= 8, "parameter `gem_tess` must be in 0..=8")?;
    let k = tess as u64;
    let per_gem = 20 * 4u64.pow(gem_tess);
    let count = 16384 * k * k + 512 * k + per_gem * (gems + points) as u64;
    budget(
        params,
        count,
        &format!("crown: 16384*{tess}^2 + 512*{tess} + 20*4^{gem_tess}*({gems} + {points})"),
    )?;
    let mut tris = band(tess, points);
    // Gems: half set into the outer surface, in rows; one on each tooth tip.
    let unit = unit_icosphere(gem_tess);
    let centres = gem_centres(gems, points);
    let gem_tris: Vec<Triangle> = centres
        .par_iter()
        .flat_map_iter(|&(c, r)| {
            unit.iter()
                .map(move |[a, b, d]| tri(c + r * *a, c + r * *b, c + r * *d))
        })
        .collect();
    tris.extend(gem_tris);
    debug_assert_eq!(tris.len() as u64, count);
    let cam = camera(
        Vec3::new(0.0, 1.5, 2.7),
        Vec3::new(0.0, 0.3, 0.0),
        Vec3::Y,
        45.0,
    );
    Ok(scene("crown", tris, cam, Some(Vec3::new(2.0, 4.0, 3.0))))
}

fn tri(a: DVec3, b: DVec3, c: DVec3) -> Triangle {
    Triangle::new(a.as_vec3(), b.as_vec3(), c.as_vec3())
}

/// The gems' centres and radii: `gems` half set into the outer surface in [`GEM_ROWS`], then
/// one on each of the `points` tooth tips.
fn gem_centres(gems: u32, points: u32) -> Vec<(DVec3, f64)> {
    let mut centres: Vec<(DVec3, f64)> = Vec::new();
    let per_row = (gems as usize).div_ceil(GEM_ROWS.len());
    for g in 0..gems as usize {
        let (row, n) = (g / per_row, g % per_row);
        let u = TAU * (n as f64 + 0.5 * row as f64) / per_row as f64;
        let y = GEM_ROWS[row] * HEIGHT;
        centres.push((DVec3::new(RADIUS * u.cos(), y, RADIUS * u.sin()), GEM));
    }
    for p in 0..points as usize {
        let u = TAU * (p as f64 + 0.5) / points as f64;
        let r = RADIUS - 0.5 * THICK;
        centres.push((
            DVec3::new(r * u.cos(), HEIGHT + TOOTH + 0.6 * GEM, r * u.sin()),
            1.2 * GEM,
        ));
    }
    centres
}

/// The band: `128·tess x 32·tess` quads per surface (outer with relief, inner plain) under
/// the top edge with `points` teeth, then the rim strips joining them (bottom, top).
fn band(tess: u32, points: u32) -> Vec<Triangle> {
    let (nu, nv) = (128 * tess as usize, 32 * tess as usize);
    // Height of the top edge at angle u: the band plus a tooth (a pointed arch).
    let top = |u: f64| {
        let f = (u / TAU * points as f64).fract();
        let tri = 1.0 - (2.0 * f - 1.0).abs();
        HEIGHT + TOOTH * tri * tri
    };
    let relief = |u: f64, v: f64| {
        RELIEF * (0.5 + 0.5 * ((u * 3.0 * points as f64).sin() * (v * 9.0 * TAU).sin()))
    };
    // Surface point: side 0 outer (with relief), 1 inner; (i, j) grid indices.
    let point = |side: usize, i: usize, j: usize| -> DVec3 {
        let u = TAU * (i % nu) as f64 / nu as f64;
        let v = j as f64 / nv as f64;
        let r = if side == 0 {
            RADIUS + relief(u, v)
        } else {
            RADIUS - THICK
        };
        DVec3::new(r * u.cos(), v * top(u), r * u.sin())
    };
    // Rows of quads, in parallel: per surface nv rows of nu quads, then the two rims.
    let rows: Vec<(usize, usize)> = (0..2).flat_map(|s| (0..nv).map(move |j| (s, j))).collect();
    let mut tris: Vec<Triangle> = rows
        .par_iter()
        .flat_map_iter(|&(s, j)| {
            (0..nu).flat_map(move |i| {
                let (a, b, c, d) = (
                    point(s, i, j),
                    point(s, i + 1, j),
                    point(s, i + 1, j + 1),
                    point(s, i, j + 1),
                );
                [tri(a, b, c), tri(a, c, d)]
            })
        })
        .collect();
    for j in [0, nv] {
        for i in 0..nu {
            let (a, b, c, d) = (
                point(0, i, j),
                point(0, i + 1, j),
                point(1, i + 1, j),
                point(1, i, j),
            );
            tris.extend([tri(a, b, c), tri(a, c, d)]);
        }
    }
    tris
}
