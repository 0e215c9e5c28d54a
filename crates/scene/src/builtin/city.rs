//! `city`: a procedural stand-in for the 'city' of Havran and Bittner 2007 (0.8M triangles,
//! not public): a grid of blocks separated by streets, each block with four buildings of
//! random height whose facades are split into storeys and window bays, seen from street
//! level down an avenue, so many rays are long.

use super::common::{budget, camera, quad, scene};
use crate::error::SceneError;
use crate::procedural::Params;
use crate::scene::Scene;
use rand::{Rng, SeedableRng};
use tb_core::{Triangle, Vec3};

/// Block edge and street width (m).
const BLOCK: f32 = 60.0;
const STREET: f32 = 20.0;
/// Storey height (m) and window bays per facade and storey.
const STOREY: f32 = 3.5;
const BAYS: u32 = 3;
/// Storeys per building: `MIN_STOREYS..=max_storeys`.
const MIN_STOREYS: u32 = 2;

/// `builtin:city?blocks=B&storeys=H&seed=X`: `B x B` blocks, each a raised sidewalk (top quad,
/// 2 triangles) with four buildings of `2..=H` storeys (uniform, seeded), each facade split
/// into storeys x [`BAYS`] quads and a roof quad: `24·h + 2` triangles per building of `h`
/// storeys, plus the street ground (2); about `2·B² + 4·B²·(12·(H + 2) + 2) + 2` triangles
/// (defaults 28, 18: about 0.8M). The camera stands in an avenue at eye height looking down it.
pub(super) fn city(params: &Params) -> Result<Scene, SceneError> {
    let blocks = params.u32("blocks", 28)?;
    let storeys = params.u32("storeys", 18)?;
    let seed = params.u64("seed", 7)?;
    params.check(
        (1..=2000).contains(&blocks),
        "parameter `blocks` must be in 1..=2000",
    )?;
    params.check(
        (MIN_STOREYS..=1000).contains(&storeys),
        "parameter `storeys` must be in 2..=1000",
    )?;
    let b2 = blocks as u64 * blocks as u64;
    let most = 2 * b2 + 4 * b2 * (24 * storeys as u64 + 2) + 2;
    budget(
        params,
        most,
        &format!("city: at most 2*{blocks}^2 + 4*{blocks}^2*(24*{storeys} + 2) + 2"),
    )?;

    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut tris: Vec<Triangle> = Vec::new();
    let pitch = BLOCK + STREET;
    let size = blocks as f32 * pitch;
    quad(
        &mut tris,
        Vec3::new(-STREET, 0.0, -STREET),
        Vec3::new(-STREET, 0.0, size),
        Vec3::new(size, 0.0, size),
        Vec3::new(size, 0.0, -STREET),
    );
    let half = 0.5 * BLOCK - 2.0;
    for i in 0..blocks {
        for j in 0..blocks {
            let (x0, z0) = (i as f32 * pitch, j as f32 * pitch);
            let curb = 0.2;
            quad(
                &mut tris,
                Vec3::new(x0, curb, z0),
                Vec3::new(x0, curb, z0 + BLOCK),
                Vec3::new(x0 + BLOCK, curb, z0 + BLOCK),
                Vec3::new(x0 + BLOCK, curb, z0),
            );
            for (bx, bz) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
                let h = rng.gen_range(MIN_STOREYS..=storeys);
                let lo = Vec3::new(
                    x0 + 1.5 + bx * (half + 1.0),
                    curb,
                    z0 + 1.5 + bz * (half + 1.0),
                );
                building(&mut tris, lo, half, h);
            }
        }
    }
    let mid = (blocks / 2) as f32 * pitch - 0.5 * STREET;
    let eye = Vec3::new(mid, 1.7, -0.5 * STREET);
    let target = Vec3::new(mid + 3.0, 12.0, size);
    let light = Vec3::new(-0.4 * size, 2.0 * size, 0.3 * size);
    Ok(scene(
        "city",
        tris,
        camera(eye, target, Vec3::Y, 60.0),
        Some(light),
    ))
}

/// A building: a box of footprint `w x w` from `lo`, `h` storeys, its four facades split into
/// storeys x [`BAYS`] quads, and a roof quad (`24·h + 2` triangles).
fn building(out: &mut Vec<Triangle>, lo: Vec3, w: f32, h: u32) {
    let top = lo.y + h as f32 * STOREY;
    let c = [
        Vec3::new(lo.x, 0.0, lo.z),
        Vec3::new(lo.x + w, 0.0, lo.z),
        Vec3::new(lo.x + w, 0.0, lo.z + w),
        Vec3::new(lo.x, 0.0, lo.z + w),
    ];
    for f in 0..4 {
        let (a, b) = (c[f], c[(f + 1) % 4]);
        for s in 0..h {
            let (y0, y1) = (lo.y + s as f32 * STOREY, lo.y + (s + 1) as f32 * STOREY);
            for k in 0..BAYS {
                let (t0, t1) = (k as f32 / BAYS as f32, (k + 1) as f32 / BAYS as f32);
                let (p0, p1) = (a.lerp(b, t0), a.lerp(b, t1));
                quad(
                    out,
                    Vec3::new(p0.x, y0, p0.z),
                    Vec3::new(p1.x, y0, p1.z),
                    Vec3::new(p1.x, y1, p1.z),
                    Vec3::new(p0.x, y1, p0.z),
                );
            }
        }
    }
    let r = |p: Vec3| Vec3::new(p.x, top, p.z);
    quad(out, r(c[0]), r(c[1]), r(c[2]), r(c[3]));
}
