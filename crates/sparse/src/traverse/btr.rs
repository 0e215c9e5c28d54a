//! BTR (Havran and Bittner 2007 §5.2, Alg. 2): the stack traversal of the start subtree, then
//! up the parent links to the next augmented node with the finished subtree skipped (the
//! module doc of `traverse` gives the whole rule). The walk state [`BtrWalk`] and its named
//! steps: [`BtrWalk::enter`] an augmented node's subtree, [`BtrWalk::descend`] to a leaf,
//! [`BtrWalk::leaf`], [`BtrWalk::pop`] the stack, [`BtrWalk::climb`] the parent links
//! (`TraverseUp`): the stack traversal of tb-kdtree's `recursive-direction` with the climb of
//! its `backtrack` between subtrees.

use super::*;

impl Ctx<'_> {
    /// BTR (Alg. 2) from record `hint` (see the module doc); without `CLIMB`, HTR (§5.1,
    /// Alg. 1): the same stack traversal from the root, ended when its stack runs dry, so
    /// the two are timed in one kernel.
    #[inline(always)]
    pub(super) fn btr<T: TriTest, C: Counter, const ANY: bool, const CLIMB: bool>(
        &self,
        ray: &Ray,
        hint: u32,
        c: &mut C,
    ) -> HitRecord {
        if self.nodes.is_empty() {
            return HitRecord::MISS;
        }
        let mut k = BtrWalk::new(self, ray, hint);
        let pre = T::prepare(ray);
        let mut best = Best::new(ray.tmax);
        loop {
            if k.enter(ray, c) {
                loop {
                    k.descend(c);
                    if k.leaf::<T, C, ANY>(&pre, ray, &mut best, c) {
                        return best.record();
                    }
                    if !k.pop::<ANY>(best.t) {
                        break;
                    }
                }
            }
            if !CLIMB || !k.climb::<C, ANY>(best.t, c) {
                return best.record();
            }
        }
    }
}

/// One ray's BTR walk: the augmented node whose subtree is walked, the subtree finished
/// before it, and the stack traversal's state.
struct BtrWalk<'c, 'a> {
    cx: &'c Ctx<'a>,
    /// The ray's set-up over its own segment, and its reciprocal direction for box tests.
    s: Setup,
    inv: Vec3,
    /// The record whose subtree is walked.
    sa: usize,
    /// The node whose subtree is finished ([`NONE`] yet), and where the ray leaves it.
    done: u32,
    done_exit: f32,
    /// Pending far children: node (its top bit: on the path to the finished subtree), the
    /// record of the last augmented node above it (Alg. 2's stack entries carry
    /// `lastAugmentedNode`) and interval.
    stack: Stack<(u32, u32, f32, f32), STACK_SIZE>,
    /// The current node, the record of the last augmented node passed on its path
    /// (`lastAugmentedNode`), and its interval.
    idx: usize,
    last: u32,
    tn: f32,
    tf: f32,
    /// Whether `idx` is an ancestor of the finished subtree.
    path: bool,
}

impl<'c, 'a> BtrWalk<'c, 'a> {
    /// A walk of `ray` from the start record for hint `hint`, nothing finished yet.
    #[inline(always)]
    fn new(cx: &'c Ctx<'a>, ray: &Ray, hint: u32) -> Self {
        BtrWalk {
            cx,
            s: setup(ray),
            inv: ray.inv_dir(),
            sa: cx.start(ray, hint),
            done: NONE,
            done_exit: f32::NEG_INFINITY,
            stack: Stack::new(),
            idx: 0,
            last: 0,
            tn: 0.0,
            tf: 0.0,
            path: false,
        }
    }

    /// Enter the subtree of record `sa` over the ray's interval in its box (one box test,
    /// `ComputeMinMaxT`); `false` when the ray misses the box.
    #[inline(always)]
    fn enter<C: Counter>(&mut self, ray: &Ray, c: &mut C) -> bool {
        let a = &self.cx.aug[self.sa];
        c.boxes(1);
        let Some((t0, t1)) = a.cell().intersect(ray.origin, self.inv, ray.tmin, ray.tmax) else {
            return false;
        };
        self.stack.clear();
        (self.idx, self.tn, self.tf) = (a.node as usize, t0, t1);
        self.last = self.sa as u32;
        self.path = self.done != NONE;
        true
    }

    /// Descend to a leaf or to the finished subtree, near child first, far children pushed,
    /// each interior node counted (one node, one plane, one step). On the path toward the
    /// finished subtree, a node whose near child holds it and ends where the ray leaves it
    /// goes to its far child only (Alg. 2's shifted entry `t_exit + eps`, decided here without
    /// the shift). Each augmented node passed becomes `lastAugmentedNode` (`TraverseDown`),
    /// carried by the children pushed below it.
    #[inline(always)]
    fn descend<C: Counter>(&mut self, c: &mut C) {
        let nodes = self.cx.nodes;
        while self.idx as u32 != self.done {
            let n = nodes[self.idx];
            if n.is_leaf() {
                return;
            }
            c.interior();
            c.steps(1);
            c.planes(1);
            if let Some(r) = self.cx.rank.find(self.idx as u32) {
                self.last = r as u32;
            }
            let d = decide(n, self.idx, &self.s, self.tn, self.tf);
            // The child toward the finished subtree.
            let toward = if (self.done as usize) < n.link() {
                self.idx + 1
            } else {
                n.link()
            };
            match d.kind {
                Kind::NearOnly => {
                    self.path &= d.near == toward;
                    self.idx = d.near;
                }
                Kind::FarOnly => {
                    self.path &= d.far == toward;
                    self.idx = d.far;
                }
                Kind::Both if self.path && d.near == toward && d.near_tf <= self.done_exit => {
                    self.path = false;
                    self.idx = d.far;
                    self.tn = d.far_tn;
                }
                Kind::Both => {
                    let far_path = self.path && d.far == toward;
                    let far = (far_path as u32) << 31 | d.far as u32;
                    self.stack.push((far, self.last, d.far_tn, self.tf));
                    self.path &= d.near == toward;
                    self.idx = d.near;
                    self.tf = d.near_tf;
                }
            }
        }
    }

    /// Test the leaf reached (the finished subtree is skipped); `true` when an any-hit query
    /// found its hit.
    #[inline(always)]
    fn leaf<T: TriTest, C: Counter, const ANY: bool>(
        &self,
        pre: &T::Pre,
        ray: &Ray,
        best: &mut Best,
        c: &mut C,
    ) -> bool {
        let (cx, idx) = (self.cx, self.idx);
        idx as u32 != self.done && leaf::<T, C, ANY>(&cx.kd, cx.nodes[idx], pre, ray, best, c)
    }

    /// Continue in the newest pending far child that starts before the closest hit `best_t`
    /// (any-hit queries: the newest); `false` when the stack runs dry.
    #[inline(always)]
    fn pop<const ANY: bool>(&mut self, best_t: f32) -> bool {
        let Some((i, last, tn, tf)) = self.stack.pop_until(|e| ANY || e.2 <= best_t) else {
            return false;
        };
        self.path = i >> 31 == 1;
        (self.idx, self.last, self.tn, self.tf) = ((i & !(1 << 31)) as usize, last, tn, tf);
        true
    }

    /// `TraverseUp` once the subtree of `sa` is finished: the ray is done (closest-hit
    /// queries) with a hit before the box's exit, since every cell not yet visited lies beyond
    /// it (`false`); else from `lastAugmentedNode` (the deepest augmented
    /// node on the last leaf's path, as Alg. 2 climbs) up the parent links, one box test each
    /// (`ComputeMaxT`), the root's included, to the first augmented node whose box extends
    /// beyond that exit, whose subtree is walked next with the finished one skipped (one
    /// restart); none
    /// (the exit is the root box's) ends the ray (`false`). The links between
    /// `lastAugmentedNode` and `sa` lead to boxes inside the finished one: each is tested
    /// and passed, as the paper's loop does.
    #[inline(always)]
    fn climb<C: Counter, const ANY: bool>(&mut self, best_t: f32, c: &mut C) -> bool {
        let (cx, aug) = (self.cx, self.cx.aug);
        let a = &aug[self.sa];
        let exit = cx.exit(&self.s, a);
        if !ANY && best_t * SLACK < exit {
            return false;
        }
        let mut node = self.last as usize;
        let found = loop {
            if node == 0 {
                return false;
            }
            let p = aug[node].parent as usize;
            parent_link(c);
            c.boxes(1);
            if cx.exit(&self.s, &aug[p]) > exit {
                break p;
            }
            node = p;
        };
        c.restart();
        (self.done, self.done_exit, self.sa) = (a.node, exit, found);
        true
    }
}
