//! `arena`: a procedural stand-in for the 'arena' of Havran and Bittner 2007 (a sports stadium
//! of 1.4M triangles, not public): a tiered elliptical bowl of stands around a pitch, a seat
//! on every step, and a roof of trusses and panels over the stands. Seen from the stands, rays
//! are short and the depth complexity is very high (row behind row of seats).

use super::common::{budget, camera, quad, scene};
use crate::error::SceneError;
use crate::procedural::Params;
use crate::scene::Scene;
use tb_core::{Triangle, Vec3};

/// Pitch semi-axes (m) along x and z.
const PITCH: (f32, f32) = (45.0, 30.0);
/// Depth (m) and rise (m) of one tier.
const TIER: (f32, f32) = (0.8, 0.45);
/// Pieces per roof truss (each a box and a brace, 24 triangles, and a roof panel, 2).
const PIECES: u32 = 8;

/// An axis-free box given by its 8 corners `c[0..4]` (bottom, in order around) and `c[4..8]`
/// (top, same order): its 6 faces, 12 triangles.
fn block(out: &mut Vec<Triangle>, c: [Vec3; 8]) {
    quad(out, c[0], c[1], c[2], c[3]);
    quad(out, c[4], c[5], c[6], c[7]);
    for i in 0..4 {
        let j = (i + 1) % 4;
        quad(out, c[i], c[j], c[j + 4], c[i + 4]);
    }
}

/// `builtin:arena?rows=R&seats=S&roof=T`: `R` tiers of `S` steps each around an elliptical
/// pitch (riser and tread: 4 triangles per step), a seat on every step (pan and backrest: 5
/// quads, 10 triangles), `T` roof trusses of [`PIECES`] pieces (a beam box and a brace box, 24
/// triangles, and a roof panel, 2 triangles, per piece), and the pitch (2 triangles):
/// `14·R·S + 208·T + 2` triangles (defaults 60, 1650, 64: 1,399,314). The camera sits in the
/// stands looking along the rows.
pub(super) fn arena(params: &Params) -> Result<Scene, SceneError> {
    let rows = params.u32("rows", 60)?;
    let seats = params.u32("seats", 1650)?;
    let roof = params.u32("roof", 64)?;
    params.check(
        (1..=1000).contains(&rows),
        "parameter `rows` must be in 1..=1000",
    )?;
    params.check(
        (8..=1_000_000).contains(&seats),
        "parameter `seats` must be in 8..=1000000",
    )?;
    params.check(
        (3..=10_000).contains(&roof),
        "parameter `roof` must be in 3..=10000",
    )?;
    let count = 14 * rows as u64 * seats as u64 + 208 * roof as u64 + 2;
    budget(
        params,
        count,
        &format!("arena: 14*{rows}*{seats} + 208*{roof} + 2"),
    )?;

    let mut tris = Vec::with_capacity(count as usize);
    let (pa, pb) = (PITCH.0, PITCH.1);
    quad(
        &mut tris,
        Vec3::new(-pa, 0.0, -pb),
        Vec3::new(-pa, 0.0, pb),
        Vec3::new(pa, 0.0, pb),
        Vec3::new(pa, 0.0, -pb),
    );
    stands(&mut tris, rows, seats);
    let top = rows as f32 * TIER.1 + 6.0;
    roof_trusses(&mut tris, rows, roof, top);
    debug_assert_eq!(tris.len() as u64, count);
    // In the stands, a third of the way up, looking along the rows and across the bowl.
    let k = rows as f32 / 3.0;
    let eye = ring(k + 0.4, 0.3, k * TIER.1 + 1.6);
    let target = ring(k - 2.0, 1.2, k * TIER.1 - 2.0);
    let light = Vec3::new(0.0, top + 40.0, 0.0);
    Ok(scene(
        "arena",
        tris,
        camera(eye, target, Vec3::Y, 60.0),
        Some(light),
    ))
}

/// The ellipse of tier `k` (its front edge), at angle `a`, at height `y`.
fn ring(k: f32, a: f32, y: f32) -> Vec3 {
    let (sn, cs) = a.sin_cos();
    Vec3::new((PITCH.0 + k * TIER.0) * cs, y, (PITCH.1 + k * TIER.0) * sn)
}

/// The stands: `rows` tiers of `seats` steps (riser and tread), a seat on every step.
fn stands(tris: &mut Vec<Triangle>, rows: u32, seats: u32) {
    let step = std::f32::consts::TAU / seats as f32;
    for k in 0..rows {
        let (kf, y0, y1) = (k as f32, k as f32 * TIER.1, (k + 1) as f32 * TIER.1);
        for j in 0..seats {
            let (a0, a1) = (j as f32 * step, ((j + 1) % seats) as f32 * step);
            // Riser (front of the tier) and tread.
            quad(
                tris,
                ring(kf, a0, y0),
                ring(kf, a1, y0),
                ring(kf, a1, y1),
                ring(kf, a0, y1),
            );
            quad(
                tris,
                ring(kf, a0, y1),
                ring(kf, a1, y1),
                ring(kf + 1.0, a1, y1),
                ring(kf + 1.0, a0, y1),
            );
            seat(tris, kf, a0, step, y1);
        }
    }
}

/// The seat on the step of tier `kf` from angle `a0` (`step` wide) whose tread is at height
/// `y1`: 80 % of the step's width, pan 0.45 m up and 0.4 deep, backrest behind (5 quads).
fn seat(tris: &mut Vec<Triangle>, kf: f32, a0: f32, step: f32, y1: f32) {
    let (s0, s1) = (a0 + 0.1 * step, a0 + 0.9 * step);
    let (yp, yb) = (y1 + 0.45, y1 + 0.95);
    let (f, m, b) = (kf + 0.15, kf + 0.65, kf + 0.75);
    let p = |d: f32, a: f32, y: f32| ring(d, a, y);
    quad(tris, p(f, s0, yp), p(f, s1, yp), p(m, s1, yp), p(m, s0, yp));
    quad(tris, p(f, s0, y1), p(f, s1, y1), p(f, s1, yp), p(f, s0, yp));
    quad(tris, p(m, s0, yp), p(m, s1, yp), p(m, s1, yb), p(m, s0, yb));
    quad(tris, p(b, s0, y1), p(b, s1, y1), p(b, s1, yb), p(b, s0, yb));
    quad(tris, p(m, s0, yb), p(m, s1, yb), p(b, s1, yb), p(b, s0, yb));
}

/// Roof: `roof` trusses from the top of the stands (height `top`) inward over the stands,
/// rising, with braces and a panel between each truss and the next.
fn roof_trusses(tris: &mut Vec<Triangle>, rows: u32, roof: u32, top: f32) {
    let (outer, inner) = (rows as f32 + 1.0, -0.3 * rows as f32);
    let rstep = std::f32::consts::TAU / roof as f32;
    for i in 0..roof {
        let (a, an) = (i as f32 * rstep, (i + 1) as f32 * rstep);
        let w = 0.004 * rstep.min(1.0);
        for piece in 0..PIECES {
            let (t0, t1) = (
                piece as f32 / PIECES as f32,
                (piece + 1) as f32 / PIECES as f32,
            );
            let (d0, d1) = (outer + (inner - outer) * t0, outer + (inner - outer) * t1);
            let (y0, y1) = (top + 4.0 * t0, top + 4.0 * t1);
            let beam = |h: f32, dy: f32| {
                [
                    ring(d0, a - w, y0 + dy),
                    ring(d0, a + w, y0 + dy),
                    ring(d1, a + w, y1 + dy),
                    ring(d1, a - w, y1 + dy),
                    ring(d0, a - w, y0 + dy + h),
                    ring(d0, a + w, y0 + dy + h),
                    ring(d1, a + w, y1 + dy + h),
                    ring(d1, a - w, y1 + dy + h),
                ]
            };
            block(tris, beam(0.6, 0.0));
            block(tris, beam(0.3, -1.5));
            quad(
                tris,
                ring(d0, a, y0 + 0.7),
                ring(d0, an, y0 + 0.7),
                ring(d1, an, y1 + 0.7),
                ring(d1, a, y1 + 0.7),
            );
        }
    }
}
