//! The `while-while` traversal: Aila and Laine's GPU trace kernel of that name (Aila and Laine
//! 2009, "Understanding the efficiency of ray traversal on GPUs", HPG '09, the while-while
//! kernel; Aila, Laine and Karras 2012, the Kepler and Fermi addendum, NVR-2012-02), the SBVH
//! baseline the irregular-grid paper's Table 3 (Pérard-Gayot et al. 2017 §6.2, [ALK12]) and
//! the multi-kd paper (Torres et al. 2012 §6, whose kernel TI is a persistent while-while) compare
//! against. Binary nodes only: a build with `width` 4 or 8 is walked through the binary tree
//! its wide nodes were collapsed from (which the row's memory columns do not count).
//!
//! Per ray: an outer loop of two inner loops. The first walks interior nodes: each visit tests
//! the node's two children's boxes against `[tmin, closest t so far]` (the authors' node holds
//! both children's boxes; our sibling pair, `nodes[index]` and `nodes[index + 1]`, is the
//! same 64 bytes), goes to the nearer child hit (the first on a tie), pushes the other's
//! *index* when both are hit, and pops when neither is, until it reaches a leaf. The second
//! tests the leaf's triangles. Then the next node is popped, until the stack is empty.
//!
//! What differs from `ordered` (and shows in the counters):
//! - the root's box is never tested: the walk starts by testing the root's children (a root
//!   that is a leaf has its triangles tested at once);
//! - the stack holds node indices only, so a popped node is visited even when a hit closer
//!   than its entry distance was found since it was pushed (no cull on pop);
//! - both children's boxes are tested even after a hit, against the closest t, as in `ordered`.
//!
//! The slab test is tb-core's robust one (Ize 2013; see [`tb_core::Aabb::intersect`]), not the
//! authors' plain min/max, so that every traversal of the harness agrees with the oracle on
//! the stress scenes; the triangle test is the run's (`triangle_tests`), not the authors'
//! Woop unit-triangle transform.
//!
//! Counters: `interior`, `steps` and 2 `boxes` per interior node visited, `leaves` and
//! `steps` per leaf, `prims` per triangle test; `planes`, `restarts` 0.
//!
//! The GPU program (`shaders/while_while.wgsl`) is the same loops in the same order; with
//! `persistent` it is the authors' persistent-threads form (tb-gpu: a fixed pool of threads
//! fetching rays from a global counter), which changes which thread traces a ray, not the walk.

use crate::traverse::{children, leaf};
use crate::{Bvh, STACK_SIZE};
use tb_core::leaves::Best;
use tb_core::slab::RayBox;
use tb_core::stack::Stack;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// The `while-while` traversal of a [`Bvh`] (traversal index 1).
pub(crate) struct WhileWhile<'a>(pub &'a Bvh);

impl WhileWhile<'_> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool, const OCT: u8>(
        &self,
        ray: &Ray,
        rb: &RayBox,
        c: &mut C,
    ) -> HitRecord {
        let bvh = self.0;
        let nodes = bvh.nodes();
        if nodes.is_empty() {
            return HitRecord::MISS;
        }
        let tmin = ray.tmin;
        let mut best = Best::new(ray.tmax);
        let pre = T::prepare(ray);
        let mut stack = Stack::<u32, STACK_SIZE>::new();
        let mut node = &nodes[0];
        'outer: loop {
            // Interior nodes until a leaf is reached (or the stack runs out).
            while !node.is_leaf() {
                let (l, [a, b], [(an, af), (bn, bf)]) =
                    children::<C, OCT>(nodes, node, rb, tmin, best.t, c);
                node = match (an <= af, bn <= bf) {
                    (true, true) => {
                        let (near, far) = if bn < an { (b, l) } else { (a, l + 1) };
                        // The builder bounds the depth by STACK_SIZE, and at most one entry
                        // per level is pending.
                        stack.push(far as u32);
                        near
                    }
                    (true, false) => a,
                    (false, true) => b,
                    (false, false) => match stack.pop() {
                        Some(n) => &nodes[n as usize],
                        None => break 'outer,
                    },
                };
            }
            // The leaf's triangles.
            if let Some(hit) = leaf::<T, C, ANY>(bvh, node, &pre, ray, &mut best, c) {
                return hit;
            }
            match stack.pop() {
                Some(n) => node = &nodes[n as usize],
                None => break 'outer,
            }
        }
        best.record_mapped(&bvh.prim_ids)
    }
}

tb_core::kernel_by_octant!([] WhileWhile<'_>);
