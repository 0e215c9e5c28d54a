//! Indexed meshes for the stress scenes, built so that neighbouring triangles share
//! bit-identical vertices: an icosphere, a closed box and a flat grid of quads.

use crate::procedural::{icosahedron_vertices, ICOSAHEDRON_FACES};
use std::collections::HashMap;
use tb_core::{Triangle, Vec3};

/// An indexed triangle mesh; shared vertices are stored once so that neighbouring triangles
/// use bit-identical coordinates.
#[derive(Clone, Default)]
pub(super) struct Mesh {
    /// Vertex positions, each stored once.
    pub(super) v: Vec<Vec3>,
    /// Triangles as indices into `v`.
    pub(super) f: Vec<[u32; 3]>,
}

impl Mesh {
    pub(super) fn tris(&self) -> Vec<Triangle> {
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
    pub(super) fn edges(&self) -> Vec<(u32, u32)> {
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

    pub(super) fn map(&self, f: impl Fn(Vec3) -> Vec3) -> Mesh {
        Mesh {
            v: self.v.iter().map(|&p| f(p)).collect(),
            f: self.f.clone(),
        }
    }

    pub(super) fn append(&mut self, o: &Mesh) {
        let base = self.v.len() as u32;
        self.v.extend_from_slice(&o.v);
        self.f
            .extend(o.f.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]));
    }
}

/// Unit icosphere about the origin, `sub` subdivisions (20·4^sub triangles), closed.
pub(super) fn icosphere(sub: u32) -> Mesh {
    let mut m = Mesh {
        v: icosahedron_vertices().iter().map(|v| v.as_vec3()).collect(),
        f: ICOSAHEDRON_FACES
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
pub(super) fn lerp_steps(lo: f32, hi: f32, i: u32, n: u32) -> f32 {
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
pub(super) fn grid_box(lo: Vec3, hi: Vec3, n: u32) -> Mesh {
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
pub(super) fn quad_grid(axis: usize, c: f32, lo: (f32, f32), hi: (f32, f32), n: u32) -> Mesh {
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
}
