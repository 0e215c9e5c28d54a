//! `stress/watertight`: closed meshes; rays aimed exactly at shared vertices and edges (all must
//! hit with the watertight test of Woop, Benthin and Wald 2013).

use super::common::{axis_dir, entering, rng, view_from, Generated};
use super::mesh::{grid_box, icosphere};
use crate::procedural::BuiltinInfo;
use tb_core::{Ray, Vec3};

/// The listing entry of `builtin:stress/watertight`.
pub(super) const INFO: BuiltinInfo = BuiltinInfo {
    name: "stress/watertight",
    doc: "closed meshes (icosphere, tessellated box); rays aimed exactly at shared vertices and edges: with the watertight test every ray hits",
    params: &["seed=1: random seed"],
};

/// Closed meshes: a unit icosphere (3 subdivisions, 1280 triangles) at (-1.5, 0, 0) and a box
/// `[0.5, 2.5] x [-1, 1]²` with 8x8 quads per face (768 triangles); rays aimed exactly at their
/// vertices and edge points (in f32), entering the solid.
///
/// Every own ray starts outside both meshes and enters one of them through a vertex or an
/// edge, at an angle (at least ~50° from the surface), or travels exactly axis-parallel onto a
/// grid vertex or boundary edge of a box face. With the watertight test (Woop, Benthin and
/// Wald 2013) every one of them hits (the `stress_oracle` test asserts it for brute force);
/// Möller–Trumbore lets some slip through shared edges and vertices (the test prints how many).
pub(super) fn generate(seed: u64) -> Generated {
    let mut r = rng(seed, 4);
    let centre = Vec3::new(-1.5, 0.0, 0.0);
    let sphere = icosphere(3).map(|p| p + centre);
    let (blo, bhi) = (Vec3::new(0.5, -1.0, -1.0), Vec3::new(2.5, 1.0, 1.0));
    let boxm = grid_box(blo, bhi, 8);
    let mut rays = Vec::new();

    // Icosphere vertices (all) and edge midpoints (every third edge), from within 40° of the
    // outward normal.
    let mut targets: Vec<(Vec3, Vec3)> = sphere
        .v
        .iter()
        .map(|&p| (p, (p - centre).normalize()))
        .collect();
    for (k, (a, b)) in sphere.edges().into_iter().enumerate() {
        if k % 3 == 0 {
            let p = (sphere.v[a as usize] + sphere.v[b as usize]) * 0.5;
            targets.push((p, (p - centre).normalize()));
        }
    }
    for (t, n) in targets {
        let d = entering(&mut r, n, 0.84);
        rays.push(Ray::new(t - d * 3.0, d));
    }

    // Box: outward normal at a surface point (sum of the faces it lies on).
    let box_normal = |p: Vec3| {
        let mut n = Vec3::ZERO;
        for a in 0..3 {
            if p[a] == blo[a] {
                n[a] = -1.0;
            } else if p[a] == bhi[a] {
                n[a] = 1.0;
            }
        }
        n
    };
    let mut targets: Vec<Vec3> = boxm.v.clone();
    for (k, (a, b)) in boxm.edges().into_iter().enumerate() {
        if k % 3 == 0 {
            targets.push((boxm.v[a as usize] + boxm.v[b as usize]) * 0.5);
        }
    }
    for t in targets {
        let n = box_normal(t);
        if n == Vec3::ZERO {
            continue;
        }
        // Oblique, within ~17° of the (edge/corner-averaged) inward normal.
        let d = entering(&mut r, n.normalize(), 0.3);
        rays.push(Ray::new(t - d * 3.0, d));
        // Exactly axis-parallel onto each face the point lies on (at an edge or corner this
        // ray lies in the other faces' planes and meets this face on its boundary).
        for a in 0..3 {
            if n[a] != 0.0 {
                let d = axis_dir(a, -n[a]);
                rays.push(Ray::new(t - d * 2.0, d));
            }
        }
    }
    let mut m = sphere;
    m.append(&boxm);
    (m.tris(), rays, view_from(Vec3::new(0.4, 0.5, 1.0)))
}
