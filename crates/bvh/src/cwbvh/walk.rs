//! The `node-groups` traversal of the compressed wide BVH (Ylitie, Karras and Laine 2017 §4,
//! Algorithm 1), the walk its GPU program (`shaders/cwbvh.wgsl`) repeats step for step.
//!
//! A *node group* is a node's interior children still to visit: their first index
//! (`child_base`), the node's `imask` (bits 0..8) and one bit per child hit in bits 24..32,
//! child `s`'s bit at `24 + (s ^ oct_inv)` with `oct_inv = 7 ^ octant`, so that the highest
//! bit is the child in the slot of the ray's own octant (the one built to be met first) and
//! the order is the octant's. Per step:
//! 1. the group's highest child bit is taken; the group, if it has others, is pushed;
//! 2. that child node is intersected: each used slot's decoded box is tested against
//!    `[tmin, closest t]`, interior hits forming the next node group, leaf hits a *triangle
//!    group* (one bit per triangle, from the node's `tri_base`);
//! 3. the triangle group is tested, lowest bit first;
//! 4. the walk goes on with the new node group, or, if it is empty, pops one; it ends when the
//!    stack is empty.
//!
//! The root is the only child of a starting group (no box test). Entries carry no distance,
//! so nothing is culled on pop. An any-hit query ends at the first hit.

use super::{Cwbvh, CW_STACK_SIZE};
use tb_core::leaves::{test_range, Best};
use tb_core::slab::RayBox;
use tb_core::stack::Stack;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// The `node-groups` traversal of a [`Cwbvh`].
pub(crate) struct NodeGroups<'a>(pub &'a Cwbvh);

/// The node-group bits (interior children hit).
const CHILD_BITS: u32 = 0xff00_0000;

impl NodeGroups<'_> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool, const OCT: u8>(
        &self,
        ray: &Ray,
        rb: &RayBox,
        c: &mut C,
    ) -> HitRecord {
        let cw = self.0;
        let nodes = cw.nodes.as_slice();
        if nodes.is_empty() {
            return HitRecord::MISS;
        }
        let tmin = ray.tmin;
        let mut best = Best::new(ray.tmax);
        let pre = T::prepare(ray);
        let oct_inv = 7 ^ OCT as u32;
        let mut stack = Stack::<(u32, u32), CW_STACK_SIZE>::new();
        // (child base, child bits | imask): the root alone, imask 0.
        let mut group = (0u32, 0x8000_0000u32);
        loop {
            let hits = group.1;
            let b = 31 - (hits & CHILD_BITS).leading_zeros();
            let rest = hits & !(1 << b);
            if rest & CHILD_BITS != 0 {
                // At most one group a level is pending, and the depth is bounded by the
                // stack's size (checked by `validate`).
                stack.push((group.0, rest));
            }
            let s = (b - 24) ^ oct_inv;
            let index = group.0 + (hits & 0xff & ((1 << s) - 1)).count_ones();
            // SAFETY: a `Cwbvh` is only made by its builder, whose child indices are in range
            // (checked by `validate`).
            let node = unsafe { nodes.get_unchecked(index as usize) };
            c.interior();
            c.steps(1);
            let (mut child_hits, mut tri_hits) = (0u32, 0u32);
            for s in 0..8 {
                let m = node.meta[s] as u32;
                if m == 0 {
                    continue;
                }
                c.boxes(1);
                let (lo, hi) = node.child_box(s);
                let (tn, tf) = rb.slab::<OCT>(&lo, &hi, tmin, best.t);
                if tn <= tf {
                    if node.is_interior(s) {
                        child_hits |= 1 << ((m & 31) ^ oct_inv);
                    } else {
                        c.leaf();
                        c.steps(1);
                        tri_hits |= (m >> 5) << (m & 31);
                    }
                }
            }
            while tri_hits != 0 {
                let k = tri_hits.trailing_zeros();
                tri_hits &= tri_hits - 1;
                // SAFETY: leaf slots lie inside the triangle array, each with its primitive
                // id (checked by `validate`).
                let hit = unsafe {
                    test_range::<T, C, ANY>(
                        &cw.triangles,
                        &cw.prim_ids,
                        {
                            let first = (node.tri_base + k) as usize;
                            first..first + 1
                        },
                        &pre,
                        ray,
                        &mut best,
                        c,
                    )
                };
                if let Some(hit) = hit {
                    return hit;
                }
            }
            group = if child_hits != 0 {
                (node.child_base, child_hits | node.imask as u32)
            } else {
                match stack.pop() {
                    Some(g) => g,
                    None => break,
                }
            };
        }
        best.record_mapped(&cw.prim_ids)
    }
}

tb_core::kernel_by_octant!([] NodeGroups<'_>);
