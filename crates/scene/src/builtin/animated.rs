//! Animated scenes for the dynamic-scene experiment of Pérard-Gayot et al. 2017 (§6.3, Table
//! 4: a deforming fairy of 174K triangles, an exploding dragon of 252K, a breaking lion of
//! 1.6M; the models are not ours to ship). Both animate the Utah teapot over `frames` frames
//! and are built at one `frame`: the structure is rebuilt from scratch for every frame, as in
//! the paper.
//!
//! - `explode`: every triangle flies away from the centre along its own seeded direction and
//!   speed while spinning about its centroid (the triangles drift apart: empty space grows
//!   between them, the case a regular grid handles worst);
//! - `deform`: the teapot twists about its vertical axis and bulges with a wave travelling
//!   up it (a smooth per-vertex deformation: the mesh stays closed, its density changes).

use super::common::{camera, scene};
use super::teapot::{check_tess, teapot_camera, teapot_triangles};
use crate::error::SceneError;
use crate::procedural::Params;
use crate::scene::Scene;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::f64::consts::TAU;
use tb_core::{Triangle, Vec3};

/// Centre of the teapot (its bounding box's), the origin of the explosion.
const CENTRE: DVec3 = DVec3::new(0.2, 1.5, 0.0);
/// Height of the teapot, for the deformation's profile.
const HEIGHT: f64 = 3.15;

/// The `frame` and `frames` parameters: `(frame, time in [0, 1))`.
fn frame_time(params: &Params) -> Result<(u32, f64), SceneError> {
    let frame = params.u32("frame", 0)?;
    let frames = params.u32("frames", 60)?;
    params.check(
        (1..=1_000_000).contains(&frames),
        "parameter `frames` must be in 1..=1000000",
    )?;
    params.check(
        frame < frames,
        &format!("parameter `frame` must be in 0..{frames} (frames = {frames})"),
    )?;
    Ok((frame, frame as f64 / frames as f64))
}

/// splitmix64: a per-triangle hash, so that the animation does not depend on the thread count.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Uniform in [0, 1) from a hash.
fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// `builtin:explode?tess=K&frame=F&frames=N&seed=X`: the teapot (`64·K² − 8·K` triangles;
/// default K = 63: 253,512) at frame `F` of `N` (time `t = F/N`). Each triangle moves by
/// `t · 4 · speed` along the direction from the centre to its centroid (plus a seeded jitter;
/// speed uniform in [0.5, 1.5]) and turns by `t · spin · 2π` about a seeded axis through its
/// centroid (spin uniform in [0, 2]). Frame 0 is the intact teapot.
pub(super) fn explode(params: &Params) -> Result<Scene, SceneError> {
    let k = params.u32("tess", 63)?;
    let (_, t) = frame_time(params)?;
    let seed = params.u64("seed", 1)?;
    check_tess(params, "tess", k)?;
    let base = teapot_triangles(k);
    let tris: Vec<Triangle> = base
        .par_iter()
        .enumerate()
        .map(|(i, tri)| {
            let h = |j: u64| unit(mix(seed ^ mix(i as u64 * 8 + j)));
            let v = [tri.v0, tri.v1, tri.v2].map(|p| p.as_dvec3());
            let c = (v[0] + v[1] + v[2]) / 3.0;
            let jitter = DVec3::new(h(0) - 0.5, h(1) - 0.5, h(2) - 0.5);
            let dir = ((c - CENTRE).normalize_or(DVec3::Y) + 0.5 * jitter).normalize_or(DVec3::Y);
            let speed = 0.5 + h(3);
            let axis = DVec3::new(h(4) - 0.5, h(5) - 0.5, h(6) - 0.5).normalize_or(DVec3::X);
            let turn = DMat3::from_axis_angle(axis, t * 2.0 * h(7) * TAU);
            let moved = c + dir * (4.0 * speed * t);
            let [a, b, d] = v.map(|p| (moved + turn * (p - c)).as_vec3());
            Triangle::new(a, b, d)
        })
        .collect();
    let cam = camera(Vec3::new(10.0, 11.0, 20.0), CENTRE.as_vec3(), Vec3::Y, 40.0);
    Ok(scene("explode", tris, cam, Some(Vec3::new(5.0, 10.0, 7.0))))
}

/// `builtin:deform?tess=K&frame=F&frames=N`: the teapot (`64·K² − 8·K` triangles; default
/// K = 160: 1,637,120) at frame `F` of `N` (time `t = F/N`), twisted about the vertical axis
/// by `0.6·sin(2πt)·y/H` radians and scaled radially by `1 + 0.15·sin(4y/H·2π − 2πt)` (a
/// bulge travelling up; `H` its height). Every vertex moves by the same function, so shared
/// vertices stay shared and the mesh stays closed.
pub(super) fn deform(params: &Params) -> Result<Scene, SceneError> {
    let k = params.u32("tess", 160)?;
    let (_, t) = frame_time(params)?;
    check_tess(params, "tess", k)?;
    let base = teapot_triangles(k);
    let warp = |p: Vec3| -> Vec3 {
        let p = p.as_dvec3();
        let y = p.y / HEIGHT;
        let twist = 0.6 * (TAU * t).sin() * y;
        let scale = 1.0 + 0.15 * (4.0 * TAU * y - TAU * t).sin();
        let (s, c) = twist.sin_cos();
        let (x, z) = (p.x * scale, p.z * scale);
        DVec3::new(c * x - s * z, p.y, s * x + c * z).as_vec3()
    };
    let tris: Vec<Triangle> = base
        .par_iter()
        .map(|tri| Triangle::new(warp(tri.v0), warp(tri.v1), warp(tri.v2)))
        .collect();
    Ok(scene(
        "deform",
        tris,
        teapot_camera(),
        Some(Vec3::new(5.0, 10.0, 7.0)),
    ))
}
