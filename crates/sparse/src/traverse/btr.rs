//! BTR (Havran and Bittner 2007 §5.2, Alg. 2): the stack traversal of the start subtree, then
//! up the parent links to the next augmented node with the finished subtree skipped (the
//! module doc of `traverse` gives the whole rule).

use super::*;

impl Ctx<'_> {
    /// BTR (Alg. 2) from record `hint` (see the module doc).
    #[inline(always)]
    pub(super) fn btr<T: TriTest, C: Counter, const ANY: bool>(
        &self,
        ray: &Ray,
        hint: u32,
        c: &mut C,
    ) -> HitRecord {
        if self.nodes.is_empty() {
            return HitRecord::MISS;
        }
        let s = setup(ray);
        let inv = ray.inv_dir();
        let pre = T::prepare(ray);
        let mut best = Best::new(ray.tmax);
        let nodes = self.nodes;
        let mut sa = self.start(ray, hint);
        // The node whose subtree is finished (none yet).
        let mut done = NONE;
        // Where the ray leaves the finished subtree.
        let mut done_exit = f32::NEG_INFINITY;
        let mut stack = Stack::<(u32, f32, f32), STACK_SIZE>::new();
        loop {
            let a = &self.aug[sa];
            c.boxes(1);
            if let Some((t0, t1)) = a.cell().intersect(ray.origin, inv, ray.tmin, ray.tmax) {
                stack.clear();
                let (mut idx, mut tn, mut tf) = (a.node as usize, t0, t1);
                // Whether `idx` is an ancestor of the finished subtree (stack entries carry
                // it in the top bit of the node index).
                let mut path = done != NONE;
                loop {
                    let n = nodes[idx];
                    if idx as u32 != done {
                        if !n.is_leaf() {
                            c.interior();
                            c.steps(1);
                            c.planes(1);
                            let d = decide(n, idx, &s, tn, tf);
                            // The child toward the finished subtree.
                            let toward = if (done as usize) < n.link() {
                                idx + 1
                            } else {
                                n.link()
                            };
                            match d.kind {
                                Kind::NearOnly => {
                                    path &= d.near == toward;
                                    idx = d.near;
                                }
                                Kind::FarOnly => {
                                    path &= d.far == toward;
                                    idx = d.far;
                                }
                                Kind::Both => {
                                    // The near child holds the finished subtree and ends
                                    // where the ray leaves that: nothing of it is left
                                    // (Alg. 2's shifted entry `t_exit + eps`, decided here
                                    // without the shift).
                                    if path && d.near == toward && d.near_tf <= done_exit {
                                        path = false;
                                        idx = d.far;
                                        tn = d.far_tn;
                                        continue;
                                    }
                                    let far_path = path && d.far == toward;
                                    let far = (far_path as u32) << 31 | d.far as u32;
                                    stack.push((far, d.far_tn, tf));
                                    path &= d.near == toward;
                                    idx = d.near;
                                    tf = d.near_tf;
                                }
                            }
                            continue;
                        }
                        if leaf::<T, C, ANY>(&self.kd, n, &pre, ray, &mut best, c) {
                            return best.record();
                        }
                    }
                    let Some((i, x, y)) = stack.pop_until(|e| ANY || e.1 <= best.t) else {
                        break;
                    };
                    path = i >> 31 == 1;
                    (idx, tn, tf) = ((i & !(1 << 31)) as usize, x, y);
                }
            }
            if sa == 0 {
                return best.record();
            }
            // Every cell not yet visited lies beyond the finished box's exit.
            let exit = self.exit(&s, ray.tmax, a);
            if !ANY && best.t * SLACK < exit {
                return best.record();
            }
            // TraverseUp: the first parent augmented node extending beyond the exit.
            c.restart();
            let mut p = a.parent as usize;
            climb(c);
            while p != 0 {
                c.boxes(1);
                if self.exit(&s, ray.tmax, &self.aug[p]) > exit {
                    break;
                }
                p = self.aug[p].parent as usize;
                climb(c);
            }
            done = a.node;
            done_exit = exit;
            sa = p;
        }
    }
}
