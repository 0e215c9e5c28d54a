//! The `ordered` traversal: depth-first with a fixed-size stack, nearer child first
//! (pbrt-v3 §4.3.5), with both children's boxes tested at their parent.
//!
//! Per ray: `1/dir` and, per axis, which of the node's two planes is the near one (pbrt's
//! `dirIsNeg`; here the ray's octant, a const parameter of the walk, so the choice costs
//! nothing per node), and the slab test needs no min/max of plane pairs. The slab test is the one of
//! [`tb_core::Aabb::intersect`]: a zero direction component gives `±inf`, and the `NaN` of
//! `0·inf` (origin in a slab's plane) is ignored by the max/min folds, so a ray lying in a box
//! face enters the box; the exit distance is scaled by `1 + 2·gamma(3)` (Ize 2013) so rounding
//! never culls a box the ray touches. The root box is tested first; a ray missing it is done.
//!
//! Closest hit: children are tested against `[tmin, closest t so far]`; the farther child of a
//! pair is pushed with its entry distance, and discarded on pop when a hit closer than that
//! entry has been found meanwhile. Any hit: the same walk, returning at the first hit.

use crate::{Bvh, BvhNode};
use tb_core::leaves::{test_range, Best};
use tb_core::slab::{RayBox, EXIT_SCALE};
use tb_core::stack::Stack;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// Entries of the traversal stack. The builder bounds the leaf depth by this (only median
/// splits below depth 32), and a walk never holds more entries than the depth of its node.
pub const STACK_SIZE: usize = 64;

/// The `ordered` traversal of a [`Bvh`] (traversal index 0).
pub(crate) struct Ordered<'a>(pub &'a Bvh);

impl Ordered<'_> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool, const OCT: u8>(
        &self,
        ray: &Ray,
        rb: &RayBox,
        c: &mut C,
    ) -> HitRecord {
        let bvh = self.0;
        let nodes = bvh.nodes();
        let Some(root) = nodes.first() else {
            return HitRecord::MISS;
        };
        let tmin = ray.tmin;
        let mut best = Best::new(ray.tmax);
        c.boxes(1);
        let (tn, tf) = rb.slab::<OCT>(&root.min, &root.max, tmin, best.t);
        let root_hit = tn <= tf;
        if !root_hit {
            return HitRecord::MISS;
        }
        let pre = T::prepare(ray);
        // Far children still to visit, with their entry distances.
        let mut stack = Stack::<(u32, f32), STACK_SIZE>::new();
        let mut node = root;
        'walk: loop {
            if !node.is_leaf() {
                let (l, [a, b], [(an, af), (bn, bf)]) =
                    children::<C, OCT>(nodes, node, rb, tmin, best.t, c);
                let hit_a = an <= af;
                let hit_b = bn <= bf;
                if hit_a {
                    if hit_b {
                        let (near, far, far_t) = if an <= bn { (a, l + 1, bn) } else { (b, l, an) };
                        // The builder bounds the depth by STACK_SIZE, and at most one entry
                        // per level is pending, so the stack holds it (checked anyway).
                        stack.push((far as u32, far_t));
                        node = near;
                    } else {
                        node = a;
                    }
                    continue 'walk;
                } else if hit_b {
                    node = b;
                    continue 'walk;
                }
            } else if let Some(hit) = leaf::<T, C, ANY>(bvh, node, &pre, ray, &mut best, c) {
                return hit;
            }
            // Pop the next pending subtree, skipping those entered beyond the closest hit.
            let Some((idx, _)) = stack.pop_until(|e| ANY || e.1 <= best.t * EXIT_SCALE) else {
                break 'walk;
            };
            // SAFETY: pushed indices are children of interior nodes (see above).
            node = unsafe { nodes.get_unchecked(idx as usize) };
        }
        best.record_mapped(&bvh.prim_ids)
    }
}

/// The sibling pair of interior node `node` (its first child's index, the two children, their
/// slab entries and exits against `[tmin, tmax]`), counted as the binary walks count an
/// interior node: one interior node, one step, two boxes.
#[inline(always)]
#[allow(clippy::type_complexity)]
pub(crate) fn children<'a, C: Counter, const OCT: u8>(
    nodes: &'a [BvhNode],
    node: &BvhNode,
    rb: &RayBox,
    tmin: f32,
    tmax: f32,
    c: &mut C,
) -> (usize, [&'a BvhNode; 2], [(f32, f32); 2]) {
    c.interior();
    c.steps(1);
    c.boxes(2);
    let l = node.index as usize;
    // SAFETY: a `Bvh` is only made by `Bvh::build`, whose interior nodes have
    // `index + 1 < nodes.len()` (checked by `validate`).
    let (a, b) = unsafe { (nodes.get_unchecked(l), nodes.get_unchecked(l + 1)) };
    let sa = rb.slab::<OCT>(&a.min, &a.max, tmin, tmax);
    let sb = rb.slab::<OCT>(&b.min, &b.max, tmin, tmax);
    (l, [a, b], [sa, sb])
}

/// The triangles of leaf `node`, tested as the binary walks test them: one leaf and one step,
/// then [`test_range`] (`Some` with an any-hit query's first hit).
#[inline(always)]
pub(crate) fn leaf<T: TriTest, C: Counter, const ANY: bool>(
    bvh: &Bvh,
    node: &BvhNode,
    pre: &T::Pre,
    ray: &Ray,
    best: &mut Best,
    c: &mut C,
) -> Option<HitRecord> {
    c.leaf();
    c.steps(1);
    let (tris, ids) = (bvh.triangles.as_slice(), bvh.prim_ids.as_slice());
    // SAFETY: `Bvh::build` makes leaves whose ranges lie inside `triangles`, each slot with its
    // primitive id (checked by `validate`).
    unsafe {
        test_range::<T, C, ANY>(
            tris,
            ids,
            {
                let first = node.index as usize;
                first..first + node.count as usize
            },
            pre,
            ray,
            best,
            c,
        )
    }
}

tb_core::kernel_by_octant!([] Ordered<'_>);
