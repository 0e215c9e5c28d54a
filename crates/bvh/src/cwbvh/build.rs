//! Building the compressed wide BVH (Ylitie, Karras and Laine 2017 §3): the binary tree, the
//! SAH-optimal collapse, each node's children placed in octant slots, the boxes quantized.

use super::{CwNode, Cwbvh, CwbvhParams, MAX_LEAF};
use crate::wide::{collapse, sah, CostModel};
use crate::{Bvh, Collapse, LeafCost, WideNode};
use std::collections::VecDeque;
use tb_core::{Aabb, AccelError, Triangle};

pub(super) fn build(tris: &[Triangle], p: &CwbvhParams) -> Result<Cwbvh, AccelError> {
    let bin = Bvh::try_build(tris, &p.binary())?;
    let cm = CostModel {
        c_trav: p.c_trav as f64,
        c_isect: p.c_isect as f64,
        leaf: LeafCost::Linear,
        max_leaf: p.max_leaf,
    };
    let wide = collapse::<8>(bin.nodes(), Collapse::Sah, &cm);
    let sah = bin
        .nodes()
        .first()
        .and_then(|r| sah(&wide, &r.bounds(), &cm));
    let (nodes, order) = compress(&wide)?;
    Ok(Cwbvh {
        nodes,
        triangles: order.iter().map(|&i| bin.triangles()[i as usize]).collect(),
        prim_ids: order.iter().map(|&i| bin.prim_ids()[i as usize]).collect(),
        n_scene: tris.len(),
        params: *p,
        sah,
        binary_nodes: bin.nodes().len(),
    })
}

/// The compressed nodes of the wide tree `wide` (root first, breadth first, so that each
/// node's interior children are consecutive) and, per triangle slot of the result, the slot
/// of the binary tree's leaf-ordered triangles it copies.
fn compress(wide: &[WideNode<8>]) -> Result<(Vec<CwNode>, Vec<u32>), AccelError> {
    let mut out = Vec::with_capacity(wide.len());
    let mut order = Vec::new();
    if wide.is_empty() {
        return Ok((out, order));
    }
    out.push(bytemuck::Zeroable::zeroed());
    let mut queue = VecDeque::from([(0usize, 0usize)]);
    while let Some((w, me)) = queue.pop_front() {
        let node = &wide[w];
        let boxes: Vec<Aabb> = (0..node.children()).map(|i| node.child_bounds(i)).collect();
        let parent = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let slot = assign(&octant_costs(&boxes, &parent));
        let mut cw = header(&parent);
        cw.child_base = out.len() as u32;
        cw.tri_base = order.len() as u32;
        let mut at = [usize::MAX; 8];
        for (i, &s) in slot.iter().enumerate() {
            at[s] = i;
        }
        for (s, &i) in at.iter().enumerate() {
            if i == usize::MAX {
                continue;
            }
            quantize(&mut cw, s, &boxes[i])?;
            let (child, count) = (node.child[i], node.count[i]);
            if count == 0 {
                cw.imask |= 1 << s;
                cw.meta[s] = (1 << 5) | (24 + s as u8);
                queue.push_back((child as usize, out.len()));
                out.push(bytemuck::Zeroable::zeroed());
            } else {
                if count > MAX_LEAF {
                    return Err(AccelError::Invalid(format!(
                        "cwbvh: a leaf of {count} triangles (at most {MAX_LEAF})"
                    )));
                }
                let offset = order.len() as u32 - cw.tri_base;
                // At most 8 leaves of at most 3 triangles: offsets stay below 24.
                cw.meta[s] = ((((1u32 << count) - 1) << 5) | offset) as u8;
                order.extend(child..child + count);
            }
        }
        out[me] = cw;
    }
    if out.len() >= u32::MAX as usize || order.len() >= u32::MAX as usize {
        return Err(AccelError::TooLarge {
            what: "CWBVH nodes or triangle references",
            count: out.len().max(order.len()) as u64,
            limit: u32::MAX as u64 - 1,
        });
    }
    Ok((out, order))
}

/// `cost[i][s]`: child `i`'s centre minus the node's, along octant `s`'s diagonal direction
/// (component `a` negative where bit `a` of `s` is set, the octant of a ray as
/// [`tb_core::slab::RayBox::new`] numbers it): small for the child a ray of that octant meets
/// first (Ylitie, Karras and Laine 2017 §3.2).
fn octant_costs(boxes: &[Aabb], parent: &Aabb) -> Vec<[f64; 8]> {
    let c = parent.center();
    boxes
        .iter()
        .map(|b| {
            let d = b.center() - c;
            std::array::from_fn(|s| {
                let sign = |a: usize| if s & (1 << a) != 0 { -1.0 } else { 1.0 };
                sign(0) * d.x as f64 + sign(1) * d.y as f64 + sign(2) * d.z as f64
            })
        })
        .collect()
}

/// The assignment of rows (children, at most 8) to distinct columns (slots) of least total
/// cost, by the Hungarian method with potentials (Kuhn 1955; Munkres 1957), `O(n²·8)`: the
/// optimum Ylitie et al.'s auction algorithm approximates. Returns each row's column.
pub(crate) fn assign(cost: &[[f64; 8]]) -> Vec<usize> {
    const M: usize = 8;
    let n = cost.len();
    assert!(n <= M, "at most 8 children");
    // 1-based rows and columns; `p[j]`: the row in column j (0: none); `way`: the path.
    let (mut u, mut v) = (vec![0.0f64; n + 1], [0.0f64; M + 1]);
    let (mut p, mut way) = ([0usize; M + 1], [0usize; M + 1]);
    for i in 1..=n {
        p[0] = i;
        let mut j0 = 0;
        let mut minv = [f64::INFINITY; M + 1];
        let mut used = [false; M + 1];
        loop {
            used[j0] = true;
            let i0 = p[j0];
            let (mut delta, mut j1) = (f64::INFINITY, 0);
            for j in 1..=M {
                if used[j] {
                    continue;
                }
                let cur = cost[i0 - 1][j - 1] - u[i0] - v[j];
                if cur < minv[j] {
                    minv[j] = cur;
                    way[j] = j0;
                }
                if minv[j] < delta {
                    delta = minv[j];
                    j1 = j;
                }
            }
            for j in 0..=M {
                if used[j] {
                    u[p[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if p[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = way[j0];
            p[j0] = p[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut col = vec![0; n];
    for j in 1..=M {
        if p[j] != 0 {
            col[p[j] - 1] = j - 1;
        }
    }
    col
}

/// The node's origin (its box's minimum) and per axis the least power-of-two scale with
/// `p + 255·scale ≥ max` in `f32` (the biased exponent kept in 1..=254; an axis of zero
/// extent gets the smallest normal scale).
fn header(b: &Aabb) -> CwNode {
    let mut n: CwNode = bytemuck::Zeroable::zeroed();
    let (lo, hi) = (b.min.to_array(), b.max.to_array());
    for a in 0..3 {
        n.p[a] = lo[a];
        let ext = hi[a] as f64 - lo[a] as f64;
        let mut e = if ext > 0.0 {
            ((ext / 255.0).log2().ceil() as i32 + 127).clamp(1, 254)
        } else {
            1
        };
        while e < 254 && lo[a] + 255.0 * f32::from_bits((e as u32) << 23) < hi[a] {
            e += 1;
        }
        n.e[a] = e as u8;
    }
    n
}

/// Slot `s`'s box `b` quantized outwards in node `n`: the largest `q_lo` and the least `q_hi`
/// whose decoded planes (`p + q·scale` in `f32`, as the walks compute them) contain `b`.
fn quantize(n: &mut CwNode, s: usize, b: &Aabb) -> Result<(), AccelError> {
    let (lo, hi) = (b.min.to_array(), b.max.to_array());
    for a in 0..3 {
        let scale = n.scale(a);
        let dec = |q: u32| n.p[a] + q as f32 * scale;
        let rel = |x: f32| (x as f64 - n.p[a] as f64) / scale as f64;
        let mut ql = rel(lo[a]).floor().clamp(0.0, 255.0) as u32;
        while ql > 0 && dec(ql) > lo[a] {
            ql -= 1;
        }
        while ql < 255 && dec(ql + 1) <= lo[a] {
            ql += 1;
        }
        let mut qh = rel(hi[a]).ceil().clamp(0.0, 255.0) as u32;
        while qh < 255 && dec(qh) < hi[a] {
            qh += 1;
        }
        while qh > ql && dec(qh - 1) >= hi[a] {
            qh -= 1;
        }
        if !(dec(ql) <= lo[a] && dec(qh) >= hi[a]) {
            return Err(AccelError::Invalid(format!(
                "cwbvh: child box [{}, {}] on axis {a} not representable from origin {} at scale {scale}",
                lo[a], hi[a], n.p[a]
            )));
        }
        n.q_lo[a][s] = ql as u8;
        n.q_hi[a][s] = qh as u8;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use tb_core::Vec3;

    /// All injective maps of `n` rows into 8 columns, the least total by brute force.
    fn brute(cost: &[[f64; 8]]) -> f64 {
        fn go(cost: &[[f64; 8]], i: usize, used: u8, acc: f64, best: &mut f64) {
            if i == cost.len() {
                *best = best.min(acc);
                return;
            }
            for j in 0..8 {
                if used & (1 << j) == 0 {
                    go(cost, i + 1, used | (1 << j), acc + cost[i][j], best);
                }
            }
        }
        let mut best = f64::INFINITY;
        go(cost, 0, 0, 0.0, &mut best);
        best
    }

    /// The Hungarian method finds the least total of the brute force, on random tables of 1
    /// to 8 rows, with distinct columns.
    #[test]
    fn assignment_is_optimal() {
        let mut x = 12345u64;
        let mut rnd = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((x >> 33) % 1000) as f64 / 100.0 - 5.0
        };
        for n in 1..=8 {
            for _ in 0..if n > 6 { 3 } else { 20 } {
                let cost: Vec<[f64; 8]> = (0..n).map(|_| std::array::from_fn(|_| rnd())).collect();
                let col = assign(&cost);
                let mut seen = [false; 8];
                for &c in &col {
                    assert!(!std::mem::replace(&mut seen[c], true), "column used twice");
                }
                let total: f64 = col.iter().enumerate().map(|(i, &c)| cost[i][c]).sum();
                assert!((total - brute(&cost)).abs() < 1e-9, "n = {n}");
            }
        }
    }

    /// Eight children at the corners of a cube: the child at the corner a ray of octant `s`
    /// meets first (the corner opposite its direction) gets slot `s`.
    #[test]
    fn corners_go_to_their_octants() {
        let boxes: Vec<Aabb> = (0..8)
            .map(|k| {
                let c = Vec3::new(
                    (k & 1) as f32 * 2.0,
                    ((k >> 1) & 1) as f32 * 2.0,
                    ((k >> 2) & 1) as f32 * 2.0,
                );
                Aabb::new(c, c + Vec3::ONE)
            })
            .collect();
        let parent = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let slot = assign(&octant_costs(&boxes, &parent));
        for (k, &s) in slot.iter().enumerate() {
            // Box k lies at the positive end of axis a where bit a of k is set; a ray
            // travelling along −a (octant bit a set) meets it first.
            let d = Vec3::new(
                if k & 1 != 0 { -1.0 } else { 1.0 },
                if k & 2 != 0 { -1.0 } else { 1.0 },
                if k & 4 != 0 { -1.0 } else { 1.0 },
            );
            let (_, octant) = tb_core::slab::RayBox::new(&tb_core::Ray::new(Vec3::ZERO, d));
            assert_eq!(s, octant as usize, "box {k}");
        }
    }

    /// Quantized boxes contain the original ones, on ordinary, flat, tiny and huge extents
    /// far from the origin.
    #[test]
    fn quantization_rounds_outwards() {
        let cases = [
            (Vec3::ZERO, Vec3::ONE),
            (Vec3::splat(1e6), Vec3::splat(1e6 + 0.25)),
            (Vec3::new(-3.0, 5.0, 5.0), Vec3::new(7.0, 5.0, 5.0)),
            (Vec3::splat(1e-30), Vec3::splat(3e-30)),
            (Vec3::splat(-1e37), Vec3::splat(2e38)),
        ];
        for (lo, hi) in cases {
            let parent = Aabb::new(lo, hi);
            let mut n = header(&parent);
            let ext = hi - lo;
            let kids = [
                parent,
                Aabb::new(lo + ext * 0.1, lo + ext * 0.37),
                Aabb::new(lo + ext * 0.999, hi),
                Aabb::new(lo, lo + ext * 1e-7),
            ];
            for (s, b) in kids.iter().enumerate() {
                quantize(&mut n, s, b).unwrap();
                let (qlo, qhi) = n.child_box(s);
                for a in 0..3 {
                    assert!(
                        qlo[a] <= b.min[a] && qhi[a] >= b.max[a],
                        "{lo} {hi} slot {s}"
                    );
                }
            }
        }
    }
}
