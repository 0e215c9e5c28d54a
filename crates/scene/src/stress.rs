//! Stiff and extreme scenes for numerical checks, `builtin:stress/NAME`, each with its own rays.
//!
//! Every scene is small (at most a few thousand triangles) so that brute force over all its
//! rays is fast in tests, comes with a default [`View`] (a 32x32 camera, a point light and an
//! AO distance, so that the ordinary ray kinds can be generated for it too) and with its own
//! closest-hit rays ([`Scene::own_rays`], traced as kind `stress`), built to provoke the case
//! the scene is about. Own rays always have finite origins, a finite non-zero direction and
//! `0 <= tmin <= tmax`; most directions are normalised, but some are deliberately not (exact
//! axis-aligned and diagonal directions, scaled directions, denormal components).
//!
//! All generation is deterministic: parameter `seed` (default 1) seeds a `Pcg64`.
//!
//! | name | case |
//! |------|------|
//! | `axis-planes` | axis-aligned walls and boxes; rays lying in their planes and in future split planes, axis-parallel rays through box edges and corners |
//! | `flat` | a scene of zero thickness (all triangles in `z = 0`); head-on, grazing and in-plane rays |
//! | `slivers` | aspect-ratio-1e6 slivers and needles, zero-area triangles, a fan of thin triangles |
//! | `watertight` | closed meshes; rays aimed exactly at shared vertices and edges (all must hit with the watertight test) |
//! | `translated` | a small mesh translated by `offset` (1e6) |
//! | `scaled-tiny`, `scaled-huge` | the same mesh scaled by `scale` (1e-6, 1e6) |
//! | `nested` | a cluster nested inside copies of itself scaled by 1000 and 1e6 |
//! | `ray-limits` | origins on surfaces with `tmin = 0`, `tmax` exactly at a hit, huge and empty intervals, denormal, signed-zero and scaled directions |
//! | `duplicates` | identical, permuted, coplanar-overlapping and co-centred triangles (ties, unsplittable clusters) |
//! | `plane-origins` | a lattice of boxes whose faces are split planes; origins exactly in those planes, on their edges and corners, directions with and without a normal component |
//! | `thin-layers` | coplanar layers one ulp apart at coordinates ~1e6; rays crossing many one-ulp cells, grazing them and lying in them |

use crate::builtin::{BuiltinInfo, Params};
use crate::rays::ray_rng;
use crate::{Camera, PixelOrder, Scene, SceneError, View};
use rand::Rng;
use rand_pcg::Pcg64;
use std::collections::HashMap;
use tb_core::{Aabb, Ray, Triangle, Vec3};

/// The stress scenes.
pub const LIST: &[BuiltinInfo] = &[
    BuiltinInfo {
        name: "stress/axis-planes",
        doc: "axis-aligned walls and boxes; rays lying exactly in their planes and in future split planes (vertex coordinates, box faces, bin boundaries), axis-parallel rays through box edges and corners, signed-zero directions",
        params: &["seed=1: random seed"],
    },
    BuiltinInfo {
        name: "stress/flat",
        doc: "zero thickness on one axis: random triangles and a grid mesh all in z = 0; head-on, grazing (dir.z down to 1e-8) and in-plane rays",
        params: &[
            "seed=1: random seed",
            "count=1500: number of random triangles",
        ],
    },
    BuiltinInfo {
        name: "stress/slivers",
        doc: "slivers and needles of aspect ratio 1e6, zero-area triangles (collinear, repeated vertices), a fan of 1000 thin triangles, over a ground grid; rays aimed at them",
        params: &["seed=1: random seed"],
    },
    BuiltinInfo {
        name: "stress/watertight",
        doc: "closed meshes (icosphere, tessellated box); rays aimed exactly at shared vertices and edges: with the watertight test every ray hits",
        params: &["seed=1: random seed"],
    },
    BuiltinInfo {
        name: "stress/translated",
        doc: "a small mesh (icosphere, boxes, ground) translated by `offset` on all axes, with its rays",
        params: &[
            "seed=1: random seed",
            "offset=1000000: translation on x, y and z",
        ],
    },
    BuiltinInfo {
        name: "stress/scaled-tiny",
        doc: "the mesh of stress/translated scaled by `scale` about the origin",
        params: &["seed=1: random seed", "scale=0.000001: scale factor"],
    },
    BuiltinInfo {
        name: "stress/scaled-huge",
        doc: "the mesh of stress/translated scaled by `scale` about the origin",
        params: &["seed=1: random seed", "scale=1000000: scale factor"],
    },
    BuiltinInfo {
        name: "stress/nested",
        doc: "a cluster nested in copies of itself scaled by `ratio` (San Miguel inside San Miguel); rays from inside the smallest copy, between copies and from outside",
        params: &[
            "seed=1: random seed",
            "levels=3: number of copies (1..=4)",
            "ratio=1000: scale between copies (ratio^(levels-1) <= 1e12)",
        ],
    },
    BuiltinInfo {
        name: "stress/ray-limits",
        doc: "ray intervals and directions: origins exactly on surfaces with tmin = 0, tmax exactly at the hit distance, tmin = tmax, huge tmin/tmax, denormal, signed-zero and scaled (1e-20..1e20) directions, far origins",
        params: &["seed=1: random seed"],
    },
    BuiltinInfo {
        name: "stress/duplicates",
        doc: "64 identical copies of a quad, permuted-vertex copies, 200 overlapping coplanar triangles, 400 triangles sharing one centroid: ties and unsplittable clusters",
        params: &["seed=1: random seed"],
    },
    BuiltinInfo {
        name: "stress/plane-origins",
        doc: "a 3x3x3 lattice of unit boxes whose faces become split planes; ray origins exactly in those planes (on faces and in the gaps, on edges and corners) with tmin = 0, directions with a non-zero, a signed-zero and an axis-parallel normal component",
        params: &["seed=1: random seed"],
    },
    BuiltinInfo {
        name: "stress/thin-layers",
        doc: "16 coplanar layers of quads one ulp apart (0.0625) at coordinates ~`offset` (1e6) with strips in each layer; rays crossing all the one-ulp cells steeply and at grazing angles, lying in the layers, from origins on them",
        params: &[
            "seed=1: random seed",
            "offset=1000000: position of the layers on x, y and z (1000..=1e7)",
        ],
    },
];

/// Load stress scene `name` (the part after `stress/`).
pub fn load(name: &str, params: &Params) -> Result<Scene, SceneError> {
    let seed = params.u64("seed", 1)?;
    let (tris, mut rays, view) = match name {
        "axis-planes" => axis_planes(seed),
        "flat" => {
            let count = params.u32("count", 1500)?;
            params.check(count <= 100_000, "count must be at most 100000")?;
            flat(seed, count as usize)
        }
        "slivers" => slivers(seed),
        "watertight" => watertight(seed),
        "translated" => {
            let offset = params.f32("offset", 1e6)?;
            params.check(offset.abs() <= 1e30, "offset must be at most 1e30")?;
            transformed(seed, 1.0, Vec3::splat(offset))
        }
        "scaled-tiny" | "scaled-huge" => {
            let default = if name == "scaled-tiny" { 1e-6 } else { 1e6 };
            let scale = params.f32("scale", default)?;
            params.check(
                scale > 0.0 && (1e-30..=1e30).contains(&scale),
                "scale must be in [1e-30, 1e30]",
            )?;
            transformed(seed, scale, Vec3::ZERO)
        }
        "nested" => {
            let levels = params.u32("levels", 3)?;
            let ratio = params.f32("ratio", 1000.0)?;
            params.check((1..=4).contains(&levels), "levels must be in 1..=4")?;
            params.check(
                ratio >= 4.0 && (ratio as f64).powi(levels as i32 - 1) <= 1e12,
                "ratio must be at least 4 and ratio^(levels-1) at most 1e12",
            )?;
            nested(seed, levels, ratio)
        }
        "ray-limits" => ray_limits(seed),
        "duplicates" => duplicates(seed),
        "plane-origins" => plane_origins(seed),
        "thin-layers" => {
            let offset = params.f32("offset", 1e6)?;
            params.check(
                (1e3..=1e7).contains(&offset),
                "offset must be in [1000, 1e7]",
            )?;
            thin_layers(seed, offset)
        }
        _ => {
            return Err(SceneError::Builtin {
                spec: format!("stress/{name}"),
                message: format!(
                    "unknown stress scene `{name}` (run `trace-bench scenes` for the list)"
                ),
            })
        }
    };
    rays.retain(valid_ray);
    let mut scene = Scene::from_triangles(format!("builtin:stress/{name}"), tris);
    scene.own_rays = rays;
    scene.view = Some(view(&scene.bounds));
    Ok(scene)
}

/// Finite origin and direction, non-zero direction, `0 <= tmin <= tmax` (tmax may be inf).
pub fn valid_ray(r: &Ray) -> bool {
    r.origin.is_finite()
        && r.dir.is_finite()
        && r.dir != Vec3::ZERO
        && r.tmin.is_finite()
        && r.tmin >= 0.0
        && !r.tmax.is_nan()
        && r.tmin <= r.tmax
}

// ---------------------------------------------------------------------------------------------
// Building blocks.

/// The view every stress scene gets: given the bounds, a camera looking at the centre from
/// `from` (a direction), a light and an AO distance proportional to the diagonal.
type ViewFn = Box<dyn Fn(&Aabb) -> View>;

fn view_from(from: Vec3) -> ViewFn {
    Box::new(move |b: &Aabb| {
        let c = b.center();
        let d = b.diagonal().max(f32::MIN_POSITIVE);
        let eye = c + from.normalize() * (0.8 * d);
        camera_view(
            eye,
            c,
            c + Vec3::new(0.35, 1.0, 0.6).normalize() * d,
            0.05 * d,
        )
    })
}

fn camera_view(eye: Vec3, target: Vec3, light: Vec3, ao_distance: f32) -> View {
    let f = (target - eye).normalize();
    let up = if f.dot(Vec3::Y).abs() > 0.95 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    View {
        camera: Camera {
            eye,
            target,
            up,
            fov: 50.0,
            width: 32,
            height: 32,
            order: PixelOrder::Row,
        },
        light: Some(light),
        ao_distance,
    }
}

fn rng(seed: u64, tag: u64) -> Pcg64 {
    ray_rng(seed, 0x5354_5245_5353 ^ tag, 0)
}

fn range(r: &mut Pcg64, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * r.gen::<f32>()
}

/// Uniform on the unit sphere.
fn unit(r: &mut Pcg64) -> Vec3 {
    let z = 1.0 - 2.0 * r.gen::<f32>();
    let phi = std::f32::consts::TAU * r.gen::<f32>();
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// Uniform in the box.
fn in_box(r: &mut Pcg64, lo: Vec3, hi: Vec3) -> Vec3 {
    Vec3::new(
        range(r, lo.x, hi.x),
        range(r, lo.y, hi.y),
        range(r, lo.z, hi.z),
    )
}

/// A ray from `origin` through `target` (normalised direction), or `None` if they coincide.
fn aim(origin: Vec3, target: Vec3) -> Option<Ray> {
    let d = (target - origin).normalize_or_zero();
    (d != Vec3::ZERO && d.is_finite()).then(|| Ray::new(origin, d))
}

/// A unit direction entering a surface with outward unit normal `n`: `-n` tilted by at most
/// `atan(tilt)`.
fn entering(r: &mut Pcg64, n: Vec3, tilt: f32) -> Vec3 {
    let w = unit(r);
    let w = (w - n * w.dot(n)) * (tilt * r.gen::<f32>());
    (-n + w).normalize()
}

/// An indexed triangle mesh; shared vertices are stored once so that neighbouring triangles
/// use bit-identical coordinates.
#[derive(Clone, Default)]
struct Mesh {
    v: Vec<Vec3>,
    f: Vec<[u32; 3]>,
}

impl Mesh {
    fn tris(&self) -> Vec<Triangle> {
        self.f
            .iter()
            .map(|t| {
                Triangle::new(
                    self.v[t[0] as usize],
                    self.v[t[1] as usize],
                    self.v[t[2] as usize],
                )
            })
            .collect()
    }

    /// Unique undirected edges, in first-seen order.
    fn edges(&self) -> Vec<(u32, u32)> {
        let mut seen = HashMap::new();
        let mut out = Vec::new();
        for t in &self.f {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                if seen.insert(key, ()).is_none() {
                    out.push(key);
                }
            }
        }
        out
    }

    fn map(&self, f: impl Fn(Vec3) -> Vec3) -> Mesh {
        Mesh {
            v: self.v.iter().map(|&p| f(p)).collect(),
            f: self.f.clone(),
        }
    }

    fn append(&mut self, o: &Mesh) {
        let base = self.v.len() as u32;
        self.v.extend_from_slice(&o.v);
        self.f
            .extend(o.f.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]));
    }
}

/// Unit icosphere about the origin, `sub` subdivisions (20·4^sub triangles), closed.
fn icosphere(sub: u32) -> Mesh {
    let mut m = Mesh {
        v: crate::builtin::common::icosahedron_vertices()
            .iter()
            .map(|v| v.as_vec3())
            .collect(),
        f: crate::builtin::common::ICOSAHEDRON_FACES
            .iter()
            .map(|f| f.map(|i| i as u32))
            .collect(),
    };
    for _ in 0..sub {
        let mut cache: HashMap<(u32, u32), u32> = HashMap::new();
        let mut f = Vec::with_capacity(m.f.len() * 4);
        let mut mid = |a: u32, b: u32, v: &mut Vec<Vec3>| -> u32 {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((v[a as usize] + v[b as usize]).normalize());
                v.len() as u32 - 1
            })
        };
        for t in m.f.clone() {
            let ab = mid(t[0], t[1], &mut m.v);
            let bc = mid(t[1], t[2], &mut m.v);
            let ca = mid(t[2], t[0], &mut m.v);
            f.extend([[t[0], ab, ca], [t[1], bc, ab], [t[2], ca, bc], [ab, bc, ca]]);
        }
        m.f = f;
    }
    m
}

/// Coordinate `i` of `n` steps from `lo` to `hi`, with both ends exact.
fn lerp_steps(lo: f32, hi: f32, i: u32, n: u32) -> f32 {
    if i == 0 {
        lo
    } else if i == n {
        hi
    } else {
        lo + (hi - lo) * (i as f32 / n as f32)
    }
}

/// Closed axis-aligned box, each face an `n`x`n` grid of quads (12·n² triangles); vertices
/// shared across faces.
fn grid_box(lo: Vec3, hi: Vec3, n: u32) -> Mesh {
    let mut m = Mesh::default();
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    let mut vid = |l: [u32; 3], m: &mut Mesh| -> u32 {
        *index.entry(l).or_insert_with(|| {
            m.v.push(Vec3::new(
                lerp_steps(lo.x, hi.x, l[0], n),
                lerp_steps(lo.y, hi.y, l[1], n),
                lerp_steps(lo.z, hi.z, l[2], n),
            ));
            m.v.len() as u32 - 1
        })
    };
    for a in 0..3 {
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        for side in [0, n] {
            for i in 0..n {
                for j in 0..n {
                    let mut l = [[0u32; 3]; 4];
                    for (k, (di, dj)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
                        l[k][a] = side;
                        l[k][u] = i + di;
                        l[k][v] = j + dj;
                    }
                    let q = l.map(|x| vid(x, &mut m));
                    // Alternate the diagonal so that both directions occur.
                    if (i + j) % 2 == 0 {
                        m.f.push([q[0], q[1], q[2]]);
                        m.f.push([q[0], q[2], q[3]]);
                    } else {
                        m.f.push([q[0], q[1], q[3]]);
                        m.f.push([q[1], q[2], q[3]]);
                    }
                }
            }
        }
    }
    m
}

/// A grid of `n`x`n` quads in the plane `p[axis] = c`, spanning `lo..hi` on the two other
/// axes (in the order `(axis+1)%3`, `(axis+2)%3`).
fn quad_grid(axis: usize, c: f32, lo: (f32, f32), hi: (f32, f32), n: u32) -> Mesh {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut m = Mesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let mut p = Vec3::ZERO;
            p[axis] = c;
            p[u] = lerp_steps(lo.0, hi.0, i, n);
            p[v] = lerp_steps(lo.1, hi.1, j, n);
            m.v.push(p);
        }
    }
    let id = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            m.f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            m.f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    m
}

/// The unit vector along `axis` with sign `s` (a signed zero on the others when `s < 0` is
/// not wanted: plain zeros).
fn axis_dir(axis: usize, s: f32) -> Vec3 {
    let mut d = Vec3::ZERO;
    d[axis] = s;
    d
}

/// A random direction with component `axis` exactly `+0.0` or `-0.0`.
fn in_plane_dir(r: &mut Pcg64, axis: usize) -> Vec3 {
    let mut d = unit(r);
    d[axis] = 0.0;
    let mut d = d.normalize_or_zero();
    if d == Vec3::ZERO {
        d = axis_dir((axis + 1) % 3, 1.0);
    }
    if r.gen::<bool>() {
        d[axis] = -0.0;
    }
    d
}

// ---------------------------------------------------------------------------------------------
// The scenes. Each returns triangles, own rays and the view (a function of the bounds).

/// Axis-aligned walls (9 planes, 8x8 grids of half-unit quads) and 8 unit boxes in `[0, 8]³`.
fn axis_planes(seed: u64) -> (Vec<Triangle>, Vec<Ray>, ViewFn) {
    let mut r = rng(seed, 1);
    let mut m = Mesh::default();
    let mut walls = Vec::new();
    for a in 0..3 {
        for c in [2.0f32, 4.0, 6.0] {
            m.append(&quad_grid(a, c, (c - 2.0, c - 2.0), (c + 2.0, c + 2.0), 8));
            walls.push((a, c));
        }
    }
    let mut boxes = Vec::new();
    for k in 0..8u32 {
        let lo = Vec3::new(
            0.5 + 4.0 * (k & 1) as f32,
            0.5 + 4.0 * ((k >> 1) & 1) as f32,
            0.5 + 4.0 * ((k >> 2) & 1) as f32,
        );
        let hi = lo + Vec3::splat(if k == 7 { 1.25 } else { 1.0 });
        m.append(&grid_box(lo, hi, 1));
        boxes.push((lo, hi));
    }
    let tris = m.tris();
    let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(9.0));
    let mut rays = Vec::new();

    // 1. Rays lying exactly in the wall planes (origin on the plane, that component of the
    //    direction ±0), and exact axis-parallel rays through the walls' grid vertices.
    for &(a, c) in &walls {
        for k in 0..24 {
            let mut o = in_box(&mut r, lo, hi);
            o[a] = c;
            let d = if k < 4 {
                axis_dir((a + 1 + k % 2) % 3, if k < 2 { 1.0 } else { -1.0 })
            } else {
                in_plane_dir(&mut r, a)
            };
            rays.push(Ray::new(o, d));
        }
        for _ in 0..16 {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            let mut o = Vec3::ZERO;
            o[u] = c - 2.0 + 0.5 * r.gen_range(0..=8) as f32;
            o[v] = c - 2.0 + 0.5 * r.gen_range(0..=8) as f32;
            let s = if r.gen::<bool>() { 1.0 } else { -1.0 };
            o[a] = c - 3.0 * s;
            rays.push(Ray::new(o, axis_dir(a, s)));
        }
    }

    // 2. Future split planes: every distinct vertex coordinate (where SAH builders split), the
    //    centre (spatial median) and bin boundaries of 8, 16 and 32 bins (binned builders).
    let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    for a in 0..3 {
        let mut planes: Vec<f32> = tris
            .iter()
            .flat_map(|t| [t.v0[a], t.v1[a], t.v2[a]])
            .collect();
        planes.push(bounds.center()[a]);
        for bins in [8u32, 16, 32] {
            let w = bounds.extent()[a] / bins as f32;
            planes.extend((1..bins).map(|k| bounds.min[a] + w * k as f32));
        }
        planes.sort_by(f32::total_cmp);
        planes.dedup();
        for c in planes {
            for _ in 0..3 {
                let mut o = in_box(&mut r, lo, hi);
                o[a] = c;
                rays.push(Ray::new(o, in_plane_dir(&mut r, a)));
            }
        }
    }

    // 3. Axis-parallel rays through box edges and corners.
    for &(blo, bhi) in &boxes {
        let corner = |bits: u32| {
            Vec3::new(
                if bits & 1 == 0 { blo.x } else { bhi.x },
                if bits & 2 == 0 { blo.y } else { bhi.y },
                if bits & 4 == 0 { blo.z } else { bhi.z },
            )
        };
        for bits in 0..8u32 {
            let p = corner(bits);
            // Outward signs at this corner.
            let s = Vec3::new(
                if bits & 1 == 0 { -1.0 } else { 1.0 },
                if bits & 2 == 0 { -1.0 } else { 1.0 },
                if bits & 4 == 0 { -1.0 } else { 1.0 },
            );
            // Along each edge line through the corner, from outside: lies in two face planes,
            // meets the third face exactly at the corner.
            for a in 0..3 {
                let d = axis_dir(a, -s[a]);
                let mut o = p;
                o[a] += 2.0 * s[a];
                rays.push(Ray::new(o, d));
                // Perpendicular to the edge along axis `a`, through its midpoint: lies in one
                // face plane, meets the other face exactly on the edge.
                for b in [(a + 1) % 3, (a + 2) % 3] {
                    let mut o = p;
                    o[a] = 0.5 * (blo[a] + bhi[a]);
                    o[b] += 2.0 * s[b];
                    rays.push(Ray::new(o, axis_dir(b, -s[b])));
                }
            }
            // Diagonal, exact (unnormalised) direction into the corner.
            rays.push(Ray::new(p + 2.0 * s, -s));
        }
    }
    (tris, rays, view_from(Vec3::new(-0.6, 0.45, 1.0)))
}

/// Zero thickness in z: `count` random triangles in `[0, 10]²` and a 10x10 grid mesh in
/// `[-5, 0] x [0, 5]`, all in `z = 0` (a few vertices with `z = -0.0`).
fn flat(seed: u64, count: usize) -> (Vec<Triangle>, Vec<Ray>, ViewFn) {
    let mut r = rng(seed, 2);
    let mut tris = quad_grid(2, 0.0, (-5.0, 0.0), (0.0, 5.0), 10).tris();
    for i in 0..count {
        let c = Vec3::new(range(&mut r, 0.0, 10.0), range(&mut r, 0.0, 10.0), 0.0);
        let size = range(&mut r, 0.05, 0.6);
        let mut v = [0; 3]
            .map(|_| c + Vec3::new(range(&mut r, -size, size), range(&mut r, -size, size), 0.0));
        if i % 17 == 0 {
            v[0].z = -0.0;
        }
        tris.push(Triangle::new(v[0], v[1], v[2]));
    }
    let lo = Vec3::new(-5.0, 0.0, 0.0);
    let hi = Vec3::new(10.0, 10.0, 0.0);
    let mut rays = Vec::new();
    let on_plane = |r: &mut Pcg64| in_box(r, lo, hi);
    // Head-on, exactly along ±z and tilted.
    for k in 0..400 {
        let t = on_plane(&mut r);
        let s = if k % 2 == 0 { 1.0 } else { -1.0 };
        if k < 250 {
            rays.push(Ray::new(
                t + Vec3::new(0.0, 0.0, 3.0 * s),
                Vec3::new(0.0, 0.0, -s),
            ));
        } else {
            rays.extend(aim(
                t + Vec3::new(range(&mut r, -1.0, 1.0), range(&mut r, -1.0, 1.0), 3.0 * s),
                t,
            ));
        }
    }
    // Grazing: dir.z from 1e-2 down to 1e-8, arriving at a point of the plane.
    for k in 0..400 {
        let t = on_plane(&mut r);
        let g = [1e-2f32, 1e-4, 1e-6, 1e-8][k % 4];
        let s = if k % 8 < 4 { 1.0 } else { -1.0 };
        let h = in_plane_dir(&mut r, 2);
        let d = Vec3::new(h.x, h.y, -s * g).normalize();
        let len = range(&mut r, 0.5, 8.0);
        rays.push(Ray::new(t - d * len, d));
    }
    // In the plane: origin z = ±0, direction z = ±0 (parallel: never hit).
    for k in 0..200 {
        let mut o = on_plane(&mut r);
        if k % 2 == 0 {
            o.z = -0.0;
        }
        rays.push(Ray::new(o, in_plane_dir(&mut r, 2)));
    }
    // Starting on the plane with tmin = 0, leaving it (hit at t = 0 where inside a triangle).
    for k in 0..150 {
        let o = on_plane(&mut r);
        let mut d = unit(&mut r);
        if k % 3 == 0 {
            d = Vec3::new(0.0, 0.0, if k % 2 == 0 { 1.0 } else { -1.0 });
        }
        rays.push(Ray::new(o, d));
    }
    // Just above the plane, parallel to it (denormal and tiny heights).
    for k in 0..100 {
        let mut o = on_plane(&mut r);
        o.z = [1e-30f32, 1e-40, -1e-40, 1e-7][k % 4];
        rays.push(Ray::new(o, in_plane_dir(&mut r, 2)));
    }
    (tris, rays, view_from(Vec3::new(0.25, -0.6, 1.0)))
}

/// Slivers (aspect ratio 1e6), needles, zero-area triangles and a fan of thin triangles over a
/// ground grid.
fn slivers(seed: u64) -> (Vec<Triangle>, Vec<Ray>, ViewFn) {
    let mut r = rng(seed, 3);
    let mut tris = quad_grid(2, -1.0, (-4.0, -4.0), (4.0, 4.0), 12).tris();
    let mut rays = Vec::new();
    let region = (Vec3::new(-3.0, -3.0, 0.0), Vec3::new(3.0, 3.0, 2.0));
    let from = |r: &mut Pcg64, t: Vec3| t + unit(r) * range(r, 2.0, 6.0);
    // Slivers: base L, height L·1e-6, random orientation.
    for k in 0..400 {
        let c = in_box(&mut r, region.0, region.1);
        let a = unit(&mut r);
        let b = (unit(&mut r).cross(a)).normalize();
        let l = range(&mut r, 0.3, 2.0);
        let tri = if k % 2 == 0 {
            // Sliver: apex at the middle of the base.
            Triangle::new(c - a * (0.5 * l), c + a * (0.5 * l), c + b * (l * 1e-6))
        } else {
            // Needle: apex near one end.
            Triangle::new(c, c + a * l, c + a * l + b * (l * 1e-6))
        };
        let target = tri.v0 * 0.4 + tri.v1 * 0.3 + tri.v2 * 0.3;
        tris.push(tri);
        rays.extend(aim(from(&mut r, target), target));
        // A second ray at an edge point of the sliver.
        let e = tri.v0 * 0.5 + tri.v1 * 0.5;
        rays.extend(aim(from(&mut r, e), e));
    }
    // Zero-area triangles: collinear (exactly, on axis-aligned lines), repeated vertices, a
    // single point, and "collinear" in f32 rounding (midpoint of a general segment).
    for k in 0..160 {
        let p = in_box(&mut r, region.0, region.1);
        let q = p + unit(&mut r);
        let tri = match k % 4 {
            0 => {
                let mut q = p;
                q[k / 4 % 3] += 1.0;
                Triangle::new(p, q, p + (q - p) * 2.0)
            }
            1 => Triangle::new(p, p, q),
            2 => Triangle::new(p, p, p),
            _ => Triangle::new(p, q, (p + q) * 0.5),
        };
        let target = (tri.v0 + tri.v1 + tri.v2) * (1.0 / 3.0);
        tris.push(tri);
        rays.extend(aim(from(&mut r, target), target));
    }
    // A fan of 1000 thin triangles (2π/1000 at the apex) sharing edges, in a tilted plane; rays
    // at the shared spokes and the apex.
    let centre = Vec3::new(0.0, 0.0, 3.0);
    let nrm = Vec3::new(0.2, -0.3, 1.0).normalize();
    let (bx, by) = crate::rays::orthonormal_basis(nrm);
    let rim: Vec<Vec3> = (0..1000)
        .map(|i| {
            let phi = std::f32::consts::TAU * i as f32 / 1000.0;
            centre + (bx * phi.cos() + by * phi.sin()) * 1.5
        })
        .collect();
    for i in 0..1000 {
        tris.push(Triangle::new(centre, rim[i], rim[(i + 1) % 1000]));
    }
    for i in (0..1000).step_by(3) {
        let t = centre + (rim[i] - centre) * range(&mut r, 0.05, 0.95);
        let d = entering(&mut r, nrm * if i % 2 == 0 { 1.0 } else { -1.0 }, 0.8);
        rays.push(Ray::new(t - d * 2.0, d));
    }
    for _ in 0..20 {
        let d = entering(&mut r, nrm, 0.8);
        rays.push(Ray::new(centre - d * 2.0, d));
    }
    (tris, rays, view_from(Vec3::new(0.3, -0.7, 0.8)))
}

/// Closed meshes: a unit icosphere (3 subdivisions, 1280 triangles) at (-1.5, 0, 0) and a box
/// `[0.5, 2.5] x [-1, 1]²` with 8x8 quads per face (768 triangles); rays aimed exactly at their
/// vertices and edge points (in f32), entering the solid.
///
/// Every own ray starts outside both meshes and enters one of them through a vertex or an
/// edge, at an angle (at least ~50° from the surface), or travels exactly axis-parallel onto a
/// grid vertex or boundary edge of a box face. With the watertight test (Woop, Benthin and
/// Wald 2013) every one of them hits (the `stress_oracle` test asserts it for brute force);
/// Möller–Trumbore lets some slip through shared edges and vertices (the test prints how many).
fn watertight(seed: u64) -> (Vec<Triangle>, Vec<Ray>, ViewFn) {
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

/// The mesh of `translated`/`scaled-*` in its own frame: an icosphere, three boxes and a
/// ground grid, about 600 triangles in `[-2, 2]³`.
fn small_mesh() -> Mesh {
    let mut m = icosphere(2).map(|p| p * 0.8 + Vec3::new(0.3, 0.0, -0.2));
    m.append(&grid_box(
        Vec3::new(-1.8, -1.0, -1.5),
        Vec3::new(-0.9, 0.5, -0.4),
        2,
    ));
    m.append(&grid_box(
        Vec3::new(1.2, -1.0, 0.6),
        Vec3::new(1.9, 1.7, 1.3),
        1,
    ));
    m.append(&grid_box(
        Vec3::new(-1.5, -1.0, 0.9),
        Vec3::new(-0.2, -0.6, 1.8),
        1,
    ));
    m.append(&quad_grid(1, -1.0, (-2.0, -2.0), (2.0, 2.0), 8));
    m
}

/// Rays for `small_mesh` in its frame: (origin, target) pairs at vertices and random surface
/// points, and random rays from inside the bounds.
fn small_mesh_rays(r: &mut Pcg64, m: &Mesh) -> Vec<(Vec3, Vec3)> {
    let mut out = Vec::new();
    for i in (0..m.v.len()).step_by(2) {
        let t = m.v[i];
        out.push((t + unit(r) * range(r, 1.0, 5.0), t));
    }
    for _ in 0..400 {
        let f = m.f[r.gen_range(0..m.f.len())];
        let (mut u, mut v) = (r.gen::<f32>(), r.gen::<f32>());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let t =
            m.v[f[0] as usize] * (1.0 - u - v) + m.v[f[1] as usize] * u + m.v[f[2] as usize] * v;
        out.push((t + unit(r) * range(r, 1.0, 5.0), t));
    }
    for _ in 0..200 {
        let o = in_box(r, Vec3::splat(-2.0), Vec3::splat(2.0));
        out.push((o, o + unit(r)));
    }
    out
}

/// `small_mesh` mapped by `p·scale + offset`; rays aimed at the mapped targets.
fn transformed(seed: u64, scale: f32, offset: Vec3) -> (Vec<Triangle>, Vec<Ray>, ViewFn) {
    let mut r = rng(seed, 5);
    let base = small_mesh();
    let pairs = small_mesh_rays(&mut r, &base);
    let f = |p: Vec3| p * scale + offset;
    let m = base.map(f);
    let rays = pairs
        .into_iter()
        .filter_map(|(o, t)| aim(f(o), f(t)))
        .collect();
    (m.tris(), rays, view_from(Vec3::new(0.5, 0.6, 1.0)))
}

/// A cluster with an empty centre (radius 0.3), nested in copies scaled by `ratio^k`.
fn nested(seed: u64, levels: u32, ratio: f32) -> (Vec<Triangle>, Vec<Ray>, ViewFn) {
    let mut r = rng(seed, 6);
    let mut cluster = icosphere(2).map(|p| p * 0.25 + Vec3::new(0.5, 0.1, -0.2));
    cluster.append(&grid_box(
        Vec3::new(-0.8, -0.2, 0.1),
        Vec3::new(-0.4, 0.3, 0.5),
        2,
    ));
    cluster.append(&grid_box(
        Vec3::new(-0.6, -0.9, -0.6),
        Vec3::new(0.6, -0.85, 0.6),
        1,
    ));
    cluster.append(&quad_grid(2, -0.7, (-0.7, -0.7), (0.7, 0.7), 4));
    let scales: Vec<f32> = (0..levels).map(|k| ratio.powi(k as i32)).collect();
    let mut m = Mesh::default();
    for &s in &scales {
        m.append(&cluster.map(|p| p * s));
    }
    let mut rays = Vec::new();
    // From inside the smallest copy's empty centre, and from each gap between copies.
    for _ in 0..300 {
        let o = in_box(&mut r, Vec3::splat(-0.2), Vec3::splat(0.2));
        rays.push(Ray::new(o, unit(&mut r)));
    }
    for w in scales.windows(2) {
        for _ in 0..200 {
            let o = unit(&mut r) * range(&mut r, 1.5 * w[0], 0.25 * w[1]);
            rays.push(Ray::new(o, unit(&mut r)));
        }
    }
    // From outside the largest copy, and from each gap, aimed at vertices of every copy.
    let smax = *scales.last().unwrap();
    for k in 0..500 {
        let level = k % scales.len();
        let t = cluster.v[r.gen_range(0..cluster.v.len())] * scales[level];
        let from = if k % 2 == 0 {
            3.0 * smax
        } else {
            range(&mut r, 1.5, 4.0) * scales[level]
        };
        rays.extend(aim(t + unit(&mut r) * from, t));
    }
    // The camera sits in the gap around the middle copy.
    let mid = scales[scales.len() / 2];
    let view: ViewFn = Box::new(move |_b: &Aabb| {
        camera_view(
            Vec3::new(0.35, 0.2, 1.2) * mid,
            Vec3::ZERO,
            Vec3::new(0.2, 1.5, 0.4) * mid,
            0.1 * mid,
        )
    });
    (m.tris(), rays, view)
}

/// Ray intervals and directions on simple exact geometry: the ground grid `z = 0` over
/// `[-4, 4]²`, an icosphere of radius 1 at (0, 0, 2) and a box `[2, 3]² x [0, 1]`.
fn ray_limits(seed: u64) -> (Vec<Triangle>, Vec<Ray>, ViewFn) {
    let mut r = rng(seed, 7);
    let mut m = quad_grid(2, 0.0, (-4.0, -4.0), (4.0, 4.0), 8);
    m.append(&icosphere(2).map(|p| p + Vec3::new(0.0, 0.0, 2.0)));
    m.append(&grid_box(
        Vec3::new(2.0, 2.0, 0.0),
        Vec3::new(3.0, 3.0, 1.0),
        1,
    ));
    let mut rays = Vec::new();
    // A dyadic point of the ground in the free quadrant x, y in [-4, -1].
    let ground = |r: &mut Pcg64| {
        Vec3::new(
            -1.0 - r.gen_range(0..=192) as f32 / 64.0,
            -1.0 - r.gen_range(0..=192) as f32 / 64.0,
            0.0,
        )
    };
    // Origins exactly on the ground, tmin = 0: leaving, entering, in the plane, and along ±z.
    for k in 0..120 {
        let o = ground(&mut r);
        let d = match k % 4 {
            0 => unit(&mut r),
            1 => in_plane_dir(&mut r, 2),
            2 => Vec3::new(0.0, 0.0, 1.0),
            _ => Vec3::new(-0.0, 0.0, -1.0),
        };
        rays.push(Ray::new(o, d));
    }
    // tmax exactly at the hit distance: along -z from a power-of-two height h the hit is at
    // t = h exactly. [0, h) misses, [0, next_up(h)) and [h, inf) hit, [next_up(h), inf) and
    // the empty [h, h) miss.
    for k in 0..60 {
        let h = [0.25f32, 0.5, 1.0, 2.0, 4.0, 1024.0][k % 6];
        let o = ground(&mut r) + Vec3::new(0.0, 0.0, h);
        let d = -Vec3::Z;
        let up = f32::from_bits(h.to_bits() + 1);
        for (tmin, tmax) in [
            (0.0, h),
            (0.0, up),
            (h, f32::INFINITY),
            (up, f32::INFINITY),
            (h, h),
        ] {
            rays.push(Ray::segment(o, d, tmin, tmax));
        }
    }
    // Huge intervals: tmax = f32::MAX, tmin = 1e30 (misses), tmin = tmax = f32::MAX.
    for _ in 0..40 {
        let t = ground(&mut r);
        let o = t + unit(&mut r).abs() * 3.0;
        let Some(ray) = aim(o, t) else { continue };
        rays.push(Ray::segment(ray.origin, ray.dir, 0.0, f32::MAX));
        rays.push(Ray::segment(ray.origin, ray.dir, 1e30, f32::INFINITY));
        rays.push(Ray::segment(ray.origin, ray.dir, f32::MAX, f32::MAX));
    }
    // Denormal and tiny direction components.
    let tiny = [1e-40f32, -1e-40, 1e-45, -1e-45, 1e-38, 1e-30];
    for k in 0..120 {
        let o = in_box(&mut r, Vec3::new(-4.0, -4.0, 0.1), Vec3::new(4.0, 4.0, 3.5));
        let mut d = unit(&mut r);
        let a = k % 3;
        d[a] = tiny[k % tiny.len()];
        if k % 5 == 0 {
            // Two tiny components: almost exactly axis-parallel.
            d[(a + 1) % 3] = tiny[(k + 1) % tiny.len()];
        }
        rays.push(Ray::new(o, d));
    }
    // Signed zeros: every axis direction with ±0 on the others, through the sphere and box.
    for k in 0..96 {
        let a = k % 3;
        let s = if (k / 3) % 2 == 0 { 1.0 } else { -1.0 };
        let mut d = Vec3::ZERO;
        d[a] = s;
        for b in 0..3 {
            if b != a && (k / 6) & (1 << b) != 0 {
                d[b] = -0.0;
            }
        }
        let mut o = if k % 2 == 0 {
            in_box(&mut r, Vec3::new(-0.8, -0.8, 1.2), Vec3::new(0.8, 0.8, 2.8))
        } else {
            Vec3::new(
                2.0 + r.gen_range(0..=4) as f32 * 0.25,
                2.0 + r.gen_range(0..=4) as f32 * 0.25,
                r.gen_range(0..=4) as f32 * 0.25,
            )
        };
        o[a] -= 6.0 * s;
        rays.push(Ray::new(o, d));
    }
    // Unnormalised directions scaled by 1e-20 .. 1e20 (t scales inversely).
    for k in 0..100 {
        let t = in_box(&mut r, Vec3::new(-0.5, -0.5, 1.5), Vec3::new(0.5, 0.5, 2.5));
        let o = t + unit(&mut r) * 4.0;
        let Some(ray) = aim(o, t) else { continue };
        let s = [1e-20f32, 1e-10, 1e10, 1e20][k % 4];
        rays.push(Ray::new(ray.origin, ray.dir * s));
    }
    // Origins inside the sphere and on sphere vertices (t = 0 hits).
    let sph = icosphere(2);
    for k in 0..80 {
        let o = if k % 2 == 0 {
            in_box(&mut r, Vec3::splat(-0.5), Vec3::splat(0.5)) + Vec3::new(0.0, 0.0, 2.0)
        } else {
            sph.v[r.gen_range(0..sph.v.len())] + Vec3::new(0.0, 0.0, 2.0)
        };
        rays.push(Ray::new(o, unit(&mut r)));
    }
    // Far origins (1e8 .. 1e20) aimed at the scene: positions lose all precision.
    for k in 0..40 {
        let dist = [1e8f32, 1e12, 1e16, 1e20][k % 4];
        let t = in_box(&mut r, Vec3::new(-1.0, -1.0, 1.0), Vec3::new(1.0, 1.0, 3.0));
        rays.extend(aim(t + unit(&mut r) * dist, t));
    }
    (m.tris(), rays, view_from(Vec3::new(-0.8, -0.5, 0.7)))
}

/// Ties and unsplittable clusters.
fn duplicates(seed: u64) -> (Vec<Triangle>, Vec<Ray>, ViewFn) {
    let mut r = rng(seed, 8);
    let mut tris = Vec::new();
    let mut rays = Vec::new();
    // 64 identical copies of a unit quad in z = 0, then 16 copies with permuted vertices.
    let q = quad_grid(2, 0.0, (0.0, 0.0), (1.0, 1.0), 1).tris();
    for _ in 0..64 {
        tris.extend_from_slice(&q);
    }
    for k in 0..16 {
        for t in &q {
            tris.push(match k % 3 {
                0 => Triangle::new(t.v1, t.v2, t.v0),
                1 => Triangle::new(t.v2, t.v0, t.v1),
                _ => Triangle::new(t.v0, t.v2, t.v1),
            });
        }
    }
    for k in 0..300 {
        let mut t = Vec3::new(r.gen(), r.gen(), 0.0);
        if k % 3 == 0 {
            // On the shared diagonal.
            t.y = t.x;
        }
        let d = entering(&mut r, if k % 2 == 0 { Vec3::Z } else { -Vec3::Z }, 1.0);
        rays.push(Ray::new(t - d * 2.0, d));
    }
    // 200 overlapping coplanar triangles in the plane y = 3.
    for _ in 0..200 {
        let v = [0; 3].map(|_| Vec3::new(range(&mut r, 0.0, 2.0), 3.0, range(&mut r, 0.0, 2.0)));
        tris.push(Triangle::new(v[0], v[1], v[2]));
    }
    for k in 0..300 {
        let t = Vec3::new(range(&mut r, 0.0, 2.0), 3.0, range(&mut r, 0.0, 2.0));
        let d = if k % 4 == 0 {
            // Grazing.
            let h = in_plane_dir(&mut r, 1);
            Vec3::new(h.x, 1e-3, h.z).normalize()
        } else {
            entering(&mut r, Vec3::Y, 1.0)
        };
        rays.push(Ray::new(t - d * 2.0, d));
    }
    // 400 triangles with the same centroid (every bounding box contains it).
    let c = Vec3::new(4.0, 1.0, 1.0);
    for _ in 0..400 {
        let a = unit(&mut r) * range(&mut r, 0.1, 0.8);
        let b = unit(&mut r) * range(&mut r, 0.1, 0.8);
        tris.push(Triangle::new(c + a, c + b, c - a - b));
    }
    for _ in 0..300 {
        let t = c + unit(&mut r) * range(&mut r, 0.0, 0.3);
        rays.extend(aim(t + unit(&mut r) * 3.0, t));
    }
    (tris, rays, view_from(Vec3::new(0.3, 0.8, 1.0)))
}

/// Review §3.1 (Hapala and Havran 2011: a ray origin embedded in a splitting plane) and §3.2
/// (the origin-classified traversal fails there, Havran et al. 1997): a 3x3x3 lattice of unit
/// boxes `[2i, 2i + 1]³` (faces in 2x2 quads), so the integer coordinates 0..=5 become split
/// planes, and every ray starts (`tmin = 0`) exactly in one of them: on a box face (a hit at
/// `t = 0`), in the gap between boxes, on a cell edge or corner (two or three planes), with a
/// random direction whose normal component is non-zero (either sign, also tiny), exactly `±0`
/// (the ray lies in the plane: review §3.1's zero-extent case), or axis-parallel along the
/// normal or along the plane (along cell faces and edges).
fn plane_origins(seed: u64) -> (Vec<Triangle>, Vec<Ray>, ViewFn) {
    let mut r = rng(seed, 9);
    let mut m = Mesh::default();
    for k in 0..27u32 {
        let lo = Vec3::new(
            2.0 * (k % 3) as f32,
            2.0 * (k / 3 % 3) as f32,
            2.0 * (k / 9) as f32,
        );
        m.append(&grid_box(lo, lo + Vec3::ONE, 2));
    }
    let tris = m.tris();
    let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(6.0));
    let mut rays = Vec::new();
    for a in 0..3 {
        for c in 0..=5 {
            for k in 0..48u32 {
                let mut o = in_box(&mut r, lo, hi);
                o[a] = c as f32;
                // In one plane, on a cell edge (two planes) or on a corner (three): the other
                // coordinates snapped onto planes too.
                let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                if k / 16 >= 1 {
                    o[u] = r.gen_range(0..=5) as f32;
                }
                if k / 16 == 2 {
                    o[v] = r.gen_range(0..=5) as f32;
                }
                let s = if k / 8 % 2 == 0 { 1.0 } else { -1.0 };
                let d = match k % 8 {
                    // The normal component non-zero, of either sign.
                    0..=2 => {
                        let mut d = unit(&mut r);
                        d[a] = s * d[a].abs().max(0.05);
                        d
                    }
                    // A tiny normal component: leaves the plane at a grazing angle.
                    3 => {
                        let mut d = in_plane_dir(&mut r, a);
                        d[a] = s * 1e-6;
                        d
                    }
                    // Lying in the plane.
                    4 | 5 => in_plane_dir(&mut r, a),
                    // Axis-parallel along the normal.
                    6 => axis_dir(a, s),
                    // Axis-parallel along the plane: along a cell face (or edge when snapped).
                    _ => axis_dir(if r.gen::<bool>() { u } else { v }, s),
                };
                rays.push(Ray::new(o, d));
            }
        }
    }
    (tris, rays, view_from(Vec3::new(-0.7, 0.5, 1.0)))
}

/// Review §3.1: "for scenes with very large models and/or ones that lead to kd-trees with
/// cells having one extent equal to zero a choice of a wrong epsilon can lead to an endless
/// loop". 16 layers `z = offset + k·ulp` (`ulp` = the spacing of f32 at `offset`: 0.0625 at
/// 1e6), each a 4x4 grid of quads over a staircase `offset + [k/2, 8] x [0, 8]` plus, in the
/// same plane, a strip shifted per layer (coplanar pieces), so the builder cuts cells one to
/// a few ulps thick between the layers; rays cross all layers steeply and at grazing angles (a step
/// `ε·t` far smaller than an ulp of the coordinates), lie exactly in a layer (`d.z = ±0`), and
/// start on a layer (`tmin = 0`) going up, down or along it.
fn thin_layers(seed: u64, offset: f32) -> (Vec<Triangle>, Vec<Ray>, ViewFn) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meshes_are_closed_and_shared() {
        for m in [
            icosphere(2),
            grid_box(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0), 3),
        ] {
            // Every edge is used by exactly two triangles.
            let mut count: HashMap<(u32, u32), u32> = HashMap::new();
            for t in &m.f {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    *count.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
            assert!(count.values().all(|&c| c == 2));
            // No two vertex indices with the same position.
            let mut v: Vec<[u32; 3]> = m.v.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
            v.sort();
            let n = v.len();
            v.dedup();
            assert_eq!(v.len(), n);
        }
        assert_eq!(icosphere(3).f.len(), 1280);
        assert_eq!(grid_box(Vec3::ZERO, Vec3::ONE, 8).f.len(), 768);
    }

    #[test]
    fn unknown_scene_is_an_error() {
        let (_, p) = Params::parse("stress/nope").unwrap();
        assert!(load("nope", &p).is_err());
    }
}
