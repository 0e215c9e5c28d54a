//! Eric Haines' Standard Procedural Databases (SPD, 1987), tessellated to triangles.
//!
//! Each scene keeps SPD's own coordinates (Z up), view (eye, target, up, 45° field of view) and
//! first light, so images compare with the SPD reference renderings. Geometry is computed in
//! `f64` and rounded to `f32` once.

use super::common::{budget, camera, pow, quad, scene};
use crate::error::SceneError;
use crate::procedural::Params;
use crate::scene::Scene;
use glam::{DMat3, DVec3};
use rand::{Rng, SeedableRng};
use tb_core::{Triangle, Vec3};

fn v32(p: DVec3) -> Vec3 {
    p.as_vec3()
}

// ---------------------------------------------------------------------------------------------
// sphereflake (SPD "balls")

/// The 20 faces of a unit icosphere subdivided `tess` times (20·4^tess triangles). Shared
/// edges are split with the same arithmetic on both sides, so the mesh is watertight.
pub(super) fn unit_icosphere(tess: u32) -> Vec<[DVec3; 3]> {
    let v = crate::procedural::icosahedron_vertices();
    let faces = &crate::procedural::ICOSAHEDRON_FACES;
    let mut tris: Vec<[DVec3; 3]> = faces.iter().map(|f| [v[f[0]], v[f[1]], v[f[2]]]).collect();
    for _ in 0..tess {
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let ab = (a + b).normalize();
            let bc = (b + c).normalize();
            let ca = (c + a).normalize();
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    tris
}

/// SPD's 9 child directions: a trio (one above the equator, two on it) rotated three times by
/// 120° about Z; 6 children end up on the equator and 3 at 54.7° above it.
fn child_directions() -> [DVec3; 9] {
    let d = 1.0 / 2f64.sqrt();
    let tilt = DMat3::from_axis_angle(
        DVec3::new(1.0, -1.0, 0.0).normalize(),
        (2.0 / 6f64.sqrt()).asin(),
    );
    let trio = [
        DVec3::new(d, d, 0.0),
        DVec3::new(d, 0.0, -d),
        DVec3::new(0.0, d, -d),
    ]
    .map(|v| tilt * v);
    let mut out = [DVec3::ZERO; 9];
    for set in 0..3 {
        let rz = DMat3::from_rotation_z(set as f64 * 2.0 * std::f64::consts::PI / 3.0);
        for k in 0..3 {
            out[set * 3 + k] = rz * trio[k];
        }
    }
    out
}

/// Rotation taking +Z to the unit vector `dir`.
fn rotation_to(dir: DVec3) -> DMat3 {
    if dir.z >= 1.0 {
        DMat3::IDENTITY
    } else if dir.z <= -1.0 {
        DMat3::from_rotation_y(std::f64::consts::PI)
    } else {
        let axis = DVec3::Z.cross(dir).normalize();
        DMat3::from_axis_angle(axis, dir.z.clamp(-1.0, 1.0).acos())
    }
}

/// Sphere centres and radii of the flake, parent before children (SPD's order).
fn flake(
    depth: u32,
    centre: DVec3,
    radius: f64,
    dir: DVec3,
    set: &[DVec3; 9],
    out: &mut Vec<(DVec3, f64)>,
) {
    out.push((centre, radius));
    if depth == 0 {
        return;
    }
    let m = rotation_to(dir);
    let scale = radius * (1.0 + 1.0 / 3.0);
    for o in set {
        let child = m * *o * scale + centre;
        let child_dir = (child - centre) / scale;
        flake(depth - 1, child, radius / 3.0, child_dir, set, out);
    }
}

/// `builtin:sphereflake?size=N&tess=K`.
pub(super) fn sphereflake(params: &Params) -> Result<Scene, SceneError> {
    let size = params.u32("size", 3)?;
    let tess = params.u32("tess", 1)?;
    params.check(size <= 10, "parameter `size` must be in 0..=10")?;
    params.check(tess <= 12, "parameter `tess` must be in 0..=12")?;
    let spheres = (pow(9, size + 1) - 1) / 8;
    let per_sphere = 20 * pow(4, tess);
    let count = spheres.saturating_mul(per_sphere).saturating_add(2);
    budget(
        params,
        count,
        &format!("sphereflake size={size} tess={tess}: {spheres} spheres x {per_sphere} + 2"),
    )?;

    let mut balls = Vec::with_capacity(spheres as usize);
    flake(
        size,
        DVec3::ZERO,
        0.5,
        DVec3::Z,
        &child_directions(),
        &mut balls,
    );
    let unit = unit_icosphere(tess);
    let mut tris = Vec::with_capacity(count as usize);
    for (c, r) in balls {
        tris.extend(
            unit.iter()
                .map(|t| Triangle::new(v32(t[0] * r + c), v32(t[1] * r + c), v32(t[2] * r + c))),
        );
    }
    // SPD's floor: a square of half-size 12 at z = -0.5, under the flake.
    let f = |x: f32, y: f32| Vec3::new(x, y, -0.5);
    quad(
        &mut tris,
        f(12.0, 12.0),
        f(-12.0, 12.0),
        f(-12.0, -12.0),
        f(12.0, -12.0),
    );

    let cam = camera(Vec3::new(2.1, 1.3, 1.7), Vec3::ZERO, Vec3::Z, 45.0);
    Ok(scene(
        "sphereflake",
        tris,
        cam,
        Some(Vec3::new(4.0, 3.0, 2.0)),
    ))
}

// ---------------------------------------------------------------------------------------------
// mount (SPD "mount", terrain only)

/// `builtin:mount?size=N&seed=S`: heights on a (2^N+1)² grid over [-1,1]² by diamond-square
/// midpoint displacement (displacement amplitude 0.5 at the first level, scaled by 2^-0.8 per
/// level, i.e. fractal dimension 2.2 as in SPD), 2·4^N triangles.
pub(super) fn mount(params: &Params) -> Result<Scene, SceneError> {
    let size = params.u32("size", 6)?;
    let seed = params.u64("seed", 1)?;
    params.check(size <= 12, "parameter `size` must be in 0..=12")?;
    let count = 2 * pow(4, size);
    budget(params, count, &format!("mount size={size}: 2*4^{size}"))?;

    let n = 1usize << size;
    let w = n + 1;
    let mut h = vec![0f32; w * w];
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let roughness = 2f32.powf(-0.8);
    let mut amp = 0.5f32;
    let mut step = n;
    while step > 1 {
        let half = step / 2;
        // Diamond step: square centres.
        for y in (half..n).step_by(step) {
            for x in (half..n).step_by(step) {
                let avg = 0.25
                    * (h[(y - half) * w + x - half]
                        + h[(y - half) * w + x + half]
                        + h[(y + half) * w + x - half]
                        + h[(y + half) * w + x + half]);
                h[y * w + x] = avg + amp * (2.0 * rng.gen::<f32>() - 1.0);
            }
        }
        // Square step: edge midpoints, averaging the neighbours inside the grid.
        for y in (0..=n).step_by(half) {
            let x0 = if (y / half) & 1 == 0 { half } else { 0 };
            for x in (x0..=n).step_by(step) {
                let mut sum = 0.0;
                let mut k = 0.0;
                if x >= half {
                    sum += h[y * w + x - half];
                    k += 1.0;
                }
                if x + half <= n {
                    sum += h[y * w + x + half];
                    k += 1.0;
                }
                if y >= half {
                    sum += h[(y - half) * w + x];
                    k += 1.0;
                }
                if y + half <= n {
                    sum += h[(y + half) * w + x];
                    k += 1.0;
                }
                h[y * w + x] = sum / k + amp * (2.0 * rng.gen::<f32>() - 1.0);
            }
        }
        amp *= roughness;
        step = half;
    }

    let p = |x: usize, y: usize| {
        Vec3::new(
            -1.0 + 2.0 * x as f32 / n as f32,
            -1.0 + 2.0 * y as f32 / n as f32,
            h[y * w + x],
        )
    };
    let mut tris = Vec::with_capacity(count as usize);
    for y in 0..n {
        for x in 0..n {
            quad(
                &mut tris,
                p(x, y),
                p(x + 1, y),
                p(x + 1, y + 1),
                p(x, y + 1),
            );
        }
    }
    let cam = camera(Vec3::new(2.2, -2.6, 1.9), Vec3::ZERO, Vec3::Z, 45.0);
    Ok(scene("mount", tris, cam, Some(Vec3::new(-1.5, -2.0, 5.0))))
}

// ---------------------------------------------------------------------------------------------
// tetra (SPD "tetra")

/// Corners of the tetrahedron inscribed in the cube `centre ± half` (SPD's sign pattern
/// x·y·z = +1).
fn tetra_corners(centre: DVec3, half: f64) -> [DVec3; 4] {
    [(-1., -1., 1.), (-1., 1., -1.), (1., -1., -1.), (1., 1., 1.)]
        .map(|(x, y, z)| centre + DVec3::new(x, y, z) * half)
}

fn tetra_rec(depth: u32, centre: DVec3, half: f64, out: &mut Vec<Triangle>) {
    if depth == 0 {
        let p = tetra_corners(centre, half).map(v32);
        // SPD's face order: 0 1 2, 3 2 1, 2 3 0, 1 0 3 (consistent outward winding).
        out.extend([
            Triangle::new(p[0], p[1], p[2]),
            Triangle::new(p[3], p[2], p[1]),
            Triangle::new(p[2], p[3], p[0]),
            Triangle::new(p[1], p[0], p[3]),
        ]);
    } else {
        for c in tetra_corners(centre, half / 2.0) {
            tetra_rec(depth - 1, c, half / 2.0, out);
        }
    }
}

/// `builtin:tetra?size=N`: 4^N tetrahedra (SPD size factor N+1), 4^(N+1) triangles.
pub(super) fn tetra(params: &Params) -> Result<Scene, SceneError> {
    let size = params.u32("size", 5)?;
    params.check(size <= 11, "parameter `size` must be in 0..=11")?;
    let count = pow(4, size + 1);
    budget(params, count, &format!("tetra size={size}: 4^({size}+1)"))?;
    let mut tris = Vec::with_capacity(count as usize);
    tetra_rec(size, DVec3::ZERO, 1.0, &mut tris);
    let cam = camera(
        Vec3::new(1.022846, -3.177154, -2.174512),
        Vec3::new(-0.004103, -0.004103, 0.216539),
        Vec3::new(-0.816497, -0.816497, 0.816497),
        45.0,
    );
    Ok(scene("tetra", tris, cam, Some(Vec3::new(2.0, -18.0, -5.0))))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn child_directions_are_unit_and_upper_half() {
        let d = child_directions();
        let mut equator = 0;
        for v in d {
            assert!((v.length() - 1.0).abs() < 1e-12);
            assert!(v.z > -1e-12, "{v}");
            if v.z.abs() < 1e-9 {
                equator += 1;
            }
        }
        assert_eq!(equator, 6);
    }

    #[test]
    fn icosphere_counts() {
        assert_eq!(unit_icosphere(0).len(), 20);
        assert_eq!(unit_icosphere(2).len(), 320);
    }
}
