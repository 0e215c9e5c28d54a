//! `stress/thin-layers`: coplanar layers one ulp apart at coordinates ~1e6; rays crossing many
//! one-ulp cells, grazing them and lying in them (review §3.1).

use super::common::{axis_dir, in_plane_dir, range, rng, unit, view_from, Generated};
use super::mesh::{quad_grid, Mesh};
use crate::error::SceneError;
use crate::procedural::{BuiltinInfo, Params};
use rand::Rng;
use rand_pcg::Pcg64;
use tb_core::{Ray, Vec3};

/// The listing entry of `builtin:stress/thin-layers`.
pub(super) const INFO: BuiltinInfo = BuiltinInfo {
    name: "stress/thin-layers",
    doc: "16 coplanar layers of quads one ulp apart (0.0625) at coordinates ~`offset` (1e6) with strips in each layer; rays crossing all the one-ulp cells steeply and at grazing angles, lying in the layers, from origins on them",
    params: &[
        "seed=1: random seed",
        "offset=1000000: position of the layers on x, y and z (1000..=1e7)",
    ],
};

/// Read `offset` (in `[1000, 1e7]`) and generate.
pub(super) fn load(seed: u64, params: &Params) -> Result<Generated, SceneError> {
    let offset = params.f32("offset", 1e6)?;
    params.check(
        (1e3..=1e7).contains(&offset),
        "offset must be in [1000, 1e7]",
    )?;
    Ok(generate(seed, offset))
}

/// Review §3.1: "for scenes with very large models and/or ones that lead to kd-trees with
/// cells having one extent equal to zero a choice of a wrong epsilon can lead to an endless
/// loop". 16 layers `z = offset + k·ulp` (`ulp` = the spacing of f32 at `offset`: 0.0625 at
/// 1e6), each a 4x4 grid of quads over a staircase `offset + [k/2, 8] x [0, 8]` plus, in the
/// same plane, a strip shifted per layer (coplanar pieces), so the builder cuts cells one to
/// a few ulps thick between the layers; rays cross all layers steeply and at grazing angles (a step
/// `ε·t` far smaller than an ulp of the coordinates), lie exactly in a layer (`d.z = ±0`), and
/// start on a layer (`tmin = 0`) going up, down or along it.
pub(super) fn generate(seed: u64, offset: f32) -> Generated {
    let mut r = rng(seed, 10);
    let ulp = f32::from_bits(offset.to_bits() + 1) - offset;
    let z = |k: u32| offset + ulp * k as f32;
    let (x0, x1) = (offset, offset + 8.0);
    let mut m = Mesh::default();
    for k in 0..16u32 {
        // A staircase: layer `k` starts at `x0 + k/2`, so above the column `x0 + [j, j + 1]/2`
        // only layers `0..=j` lie: the SAH cuts off the empty space above layer `j` (empty
        // bonus), leaving cells `j` ulps thick (one ulp at `j = 1`).
        m.append(&quad_grid(2, z(k), (x0 + 0.5 * k as f32, x0), (x1, x1), 4));
        let s = x0 + 0.5 * k as f32;
        m.append(&quad_grid(2, z(k), (s, x1 + 1.0), (s + 0.5, x1 + 2.0), 1));
    }
    let tris = m.tris();
    let mut rays = Vec::new();
    let at = |r: &mut Pcg64, zc: f32| Vec3::new(range(r, x0, x1 + 2.0), range(r, x0, x1 + 2.0), zc);
    for k in 0..1600u32 {
        let s = if k % 2 == 0 { 1.0 } else { -1.0 };
        let layer = r.gen_range(0..16u32);
        let (o, d) = match k % 5 {
            // Steep, from below or above every layer.
            0 => {
                let o = at(&mut r, if s > 0.0 { z(0) - 4.0 } else { z(15) + 4.0 });
                let mut d = unit(&mut r);
                d.z = s * d.z.abs().max(0.3);
                (o, d)
            }
            // Grazing: from far outside, crossing the stack over a long stretch.
            1 => {
                let o = at(&mut r, if s > 0.0 { z(0) - 0.1 } else { z(15) + 0.1 });
                let mut d = in_plane_dir(&mut r, 2);
                d.z = s * range(&mut r, 1e-4, 2e-2);
                (o - Vec3::new(d.x, d.y, 0.0) * 4.0, d)
            }
            // Lying exactly in a layer.
            2 => (at(&mut r, z(layer)), in_plane_dir(&mut r, 2)),
            // Starting on a layer, leaving it up or down.
            3 => {
                let mut d = unit(&mut r);
                d.z = s * d.z.abs().max(1e-3);
                (at(&mut r, z(layer)), d)
            }
            // Axis-parallel through the stack.
            _ => (at(&mut r, z(layer)), axis_dir(2, s)),
        };
        rays.push(Ray::new(o, d));
    }
    (tris, rays, view_from(Vec3::new(0.6, 0.4, 1.0)))
}
