//! `branchless`: the direction-classified walk with a branchless node step (Hapala and
//! Havran 2011 §5.5, Alg. 5).

use super::*;

/// `branchless` (traversal 9): the direction-classified recursive traversal with the
/// interior-node step written without branches (Hapala 2009; Hapala and Havran 2011 §5.5,
/// Algorithm 5 and Table 2; Benthin 2006): the far child is always written to the stack
/// slot of the current node and the stack pointer advanced by `c = (t ≤ t_exit)`, then the
/// near child written to the new top and the pointer moved back by `d = (t < t_entry)`, so
/// "near only", "far only" and "both" need no branch; the next node is the top of the
/// stack. The comparisons carry the rounding slack of [`RecursiveDirection`] (`c` unless
/// `t > t_exit·SLACK`, `d` when `t·SLACK < t_entry`; a NaN `t` gives both children over the
/// whole interval), so it visits exactly the same nodes. Extra memory: the stack, one entry
/// more than `recursive-direction`'s.
pub struct Branchless<'a, L>(pub Tree<'a, L>);

impl<L: Layout> Branchless<'_, L> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let w = &self.0;
        let Some((s, pre, mut best)) = start::<T, C, L>(w, ray, c) else {
            return HitRecord::MISS;
        };
        let nodes = w.v.nodes;
        let mut stack = [(0u32, 0f32, 0f32); STACK_SIZE + 1];
        // `n` entries; the top, `stack[n - 1]`, is the node being processed.
        stack[0] = (w.from.node, s.t0, s.t1);
        let mut n = 1usize;
        loop {
            let (idx, tn, tf) = stack[n - 1];
            let idx = idx as usize;
            // SAFETY: as in `RecursiveDirection::walk`.
            let node = unsafe { *nodes.get_unchecked(idx) };
            if !node.is_leaf() {
                c.interior();
                c.steps(1);
                c.planes(1);
                let a = node.axis();
                let t = (node.split() - s.org[a]) * s.inv[a];
                let neg = s.neg[a] as usize;
                // Near = left unless neg.
                let (left, right) = w.l.children(idx, node);
                let kids = [left, right];
                let (near, far) = (kids[neg], kids[1 - neg]);
                // `t > tf·SLACK` is false for a NaN `t`: both children.
                let near_only = t > tf * SLACK;
                let go_far = (!near_only) as usize;
                let far_only = (t * SLACK < tn) as usize & go_far;
                stack[n - 1] = (far as u32, max_num(tn, t), tf);
                n += go_far;
                stack[n - 1] = (near as u32, tn, min_num(tf, t));
                n -= far_only;
                continue;
            }
            if leaf::<T, C, ANY>(&w.v, node, &pre, ray, &mut best, c) {
                return best.record();
            }
            n -= 1;
            while n > 0 && !ANY && stack[n - 1].1 > best.t {
                n -= 1;
            }
            if n == 0 {
                return best.record();
            }
        }
    }
}

tb_core::kernel_by_query!(walk: [L: Layout] Branchless<'_, L>);
