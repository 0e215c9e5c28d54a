//! The walk state the restart-type traversals share (`restart`, `push-down`, `short-stack`,
//! `backtrack`; see the module doc above for what is kept between leaves) and its named
//! steps: [`Restarts::descend`] to the next leaf, [`Restarts::leaf`], [`Restarts::pop`] (the
//! short stack), [`Restarts::restart`] (from the pushed-down node toward the last leaf),
//! [`Restarts::climb`] (the parent links) and [`Restarts::enter`] (the next subtree). Each
//! algorithm's file composes them; `K` (one of [`RESTART`], [`PUSH_DOWN`], [`SHORT_STACK`],
//! [`BACKTRACK`]) decides at compile time what the shared steps keep.

use super::{
    below, cell_interval, RestartSteps, BACKTRACK, MAX_SHORT_STACK, PUSH_DOWN, SHORT_STACK,
};
use crate::traverse::{capped, decide, leaf, Best, Kind, Setup, Tree};
use crate::view::BackNode;
use crate::Layout;
use tb_core::{Counter, Ray, TriTest};

/// The next subtree of a walk: its node and interval, whether it is the only pending one
/// (`push-down` may push down to it) and its parent's depth `<< 1 |` 1 for a right child.
#[derive(Clone, Copy)]
pub(super) struct Next {
    node: usize,
    tn: f32,
    tf: f32,
    alone: bool,
    at: u32,
}

/// One ray's restart-type walk from the start node.
///
/// The restarts find the last leaf again: in the depth-first layout by its index (the subtree
/// of a node is a range of indices), otherwise by its *path* from the start (bit `k` set when
/// the walk went to the right child at depth `k`; the depth limit is at most 64).
pub(super) struct Restarts<'t, 'a, L, const K: u8> {
    w: &'t Tree<'a, L>,
    s: Setup,
    /// Steps taken (nodes visited), against the step cap.
    pub(super) steps: u32,
    /// The current node and its interval.
    idx: usize,
    tn: f32,
    tf: f32,
    /// Depth of `idx`; `both`: bit `k` set when the node at depth `k` on the way to `idx` sent
    /// the ray both ways and the walk went to the near child (the candidates of the next
    /// restart); `path`: bit `k` set when the walk went to the right child at depth `k`
    /// (treelet layout only: in the depth-first one, indices tell the subtree). Bits at and
    /// beyond `depth` are zero. `backtrack` climbs parent links and keeps none.
    depth: u32,
    both: u64,
    path: u64,
    /// The ray lies in a split plane it met (its children overlap in `t`).
    in_plane: bool,
    /// The pushed-down node, its interval and depth, and whether it may still be pushed down
    /// (`push-down`, `short-stack`; the start node for the others).
    pd: usize,
    pd_tn: f32,
    pd_tf: f32,
    pd_depth: u32,
    push: bool,
    /// `short-stack`'s circular stack of far children (node, interval, the parent's depth
    /// `<< 1 |` right-child bit): `count` entries, the newest at `top - 1` (mod `size`).
    stack: [(u32, f32, f32, u32); MAX_SHORT_STACK],
    top: usize,
    count: usize,
    size: usize,
}

impl<'t, 'a, L: Layout, const K: u8> Restarts<'t, 'a, L, K> {
    /// Keeps the depth and path bits (all but `backtrack`).
    const TRACK: bool = K != BACKTRACK;
    /// Pushes the restart node down (`push-down`, `short-stack`).
    const PUSHES: bool = K == PUSH_DOWN || K == SHORT_STACK;

    /// A walk over `s`'s start interval from the start node, `steps` steps already taken.
    #[inline(always)]
    pub(super) fn new(w: &'t Tree<'a, L>, s: &Setup, steps: u32) -> Self {
        let root = w.from.node as usize;
        Restarts {
            w,
            s: *s,
            steps,
            idx: root,
            tn: s.t0,
            tf: s.t1,
            depth: 0,
            both: 0,
            path: 0,
            in_plane: false,
            pd: root,
            pd_tn: s.t0,
            pd_tf: s.t1,
            pd_depth: 0,
            push: Self::PUSHES,
            stack: [(0, 0.0, 0.0, 0); MAX_SHORT_STACK],
            top: 0,
            count: 0,
            size: w.v.short_stack as usize,
        }
    }

    /// `short-stack`: continue in the newest kept far child that starts before the closest hit
    /// `best_t` (any-hit queries: the newest); `false` when the stack runs dry.
    #[inline(always)]
    pub(super) fn pop<const ANY: bool>(&mut self, best_t: f32) -> bool {
        while self.count > 0 {
            self.top = if self.top == 0 {
                self.size - 1
            } else {
                self.top - 1
            };
            self.count -= 1;
            let (i, a, b, at) = self.stack[self.top];
            if ANY || a <= best_t {
                (self.idx, self.tn, self.tf) = (i as usize, a, b);
                (self.depth, self.both, self.path) = below(self.both, self.path, at);
                return true;
            }
        }
        false
    }

    /// The current node is the start node (a leaf start: nothing to climb to).
    #[inline(always)]
    pub(super) fn at_start(&self) -> bool {
        self.idx == self.w.from.node as usize
    }

    /// `backtrack`: climb the parent links `back` from the leaf, recomputing each node's
    /// interval from its cell (one node, plane, box and step each), up to the first node where
    /// the walk went both ways from the near child and whose far side starts before the
    /// closest hit `best_t`: its far child is next. `None` above the start node.
    #[inline(always)]
    pub(super) fn climb<C: Counter, const ANY: bool>(
        &mut self,
        back: &[BackNode],
        best_t: f32,
        c: &mut C,
    ) -> Option<Next> {
        let (nodes, root) = (self.w.v.nodes, self.w.from.node as usize);
        let mut child = self.idx;
        let mut x = back[child].parent as usize;
        loop {
            c.interior();
            c.steps(1);
            c.planes(1);
            c.boxes(1);
            self.steps += 1;
            let (xn, xf) = cell_interval(&self.w.from.cell, &self.s, &back[x]);
            let d = decide(self.w.l, nodes[x], x, &self.s, xn, xf);
            if d.kind == Kind::Both && child == d.near && (ANY || d.far_tn <= best_t) {
                return Some(Next {
                    node: d.far,
                    tn: d.far_tn,
                    tf: xf,
                    alone: false,
                    at: 0,
                });
            }
            if x == root {
                return None;
            }
            child = x;
            x = back[x].parent as usize;
        }
    }
}

impl<L: Layout, const K: u8> RestartSteps for Restarts<'_, '_, L, K> {
    type Next = Next;

    /// Descend to the first leaf of the current subtree, near child first, each interior node
    /// counted (one node, one plane, one step); `short-stack` keeps the far children, and the
    /// pushed-down node follows while the walk visits one child only.
    #[inline(always)]
    fn descend<C: Counter>(&mut self, c: &mut C) {
        let nodes = self.w.v.nodes;
        loop {
            let n = nodes[self.idx];
            if n.is_leaf() {
                return;
            }
            c.interior();
            c.steps(1);
            c.planes(1);
            self.steps += 1;
            let d = decide(self.w.l, n, self.idx, &self.s, self.tn, self.tf);
            let near_right = self.s.neg[n.axis()];
            let go_right = match d.kind {
                Kind::NearOnly => {
                    self.idx = d.near;
                    near_right
                }
                Kind::FarOnly => {
                    self.idx = d.far;
                    !near_right
                }
                Kind::Both => {
                    // `far_tn < near_tf` only for `t = NaN` (see `decide`).
                    self.in_plane |= d.far_tn < d.near_tf;
                    if K == SHORT_STACK {
                        let at = self.depth << 1 | !near_right as u32;
                        self.stack[self.top] = (d.far as u32, d.far_tn, self.tf, at);
                        self.top = if self.top + 1 == self.size {
                            0
                        } else {
                            self.top + 1
                        };
                        self.count = (self.count + 1).min(self.size);
                    }
                    self.push = false;
                    self.idx = d.near;
                    self.tf = d.near_tf;
                    if Self::TRACK {
                        self.both |= 1 << self.depth;
                    }
                    near_right
                }
            };
            if Self::TRACK {
                if !L::DEPTH_FIRST {
                    self.path |= (go_right as u64) << self.depth;
                }
                self.depth += 1;
            }
            if self.push {
                (self.pd, self.pd_tn, self.pd_tf, self.pd_depth) =
                    (self.idx, self.tn, self.tf, self.depth);
            }
        }
    }

    /// Test the leaf reached (one step); `true` when the ray is done: an any-hit found, a hit
    /// before the end of the leaf's interval (Foley and Sugerman's early exit: every pending
    /// subtree starts at or beyond that end, `tf`, the near interval of the deepest node that
    /// sent the ray both ways; not for a ray lying in a split plane, whose children both span
    /// that node's whole interval), or the step cap reached.
    #[inline(always)]
    fn leaf<T: TriTest, C: Counter, const ANY: bool>(
        &mut self,
        pre: &T::Pre,
        ray: &Ray,
        best: &mut Best,
        c: &mut C,
    ) -> bool {
        self.steps += 1;
        let n = self.w.v.nodes[self.idx];
        leaf::<T, C, ANY>(&self.w.v, n, pre, ray, best, c)
            || (best.t < self.tf && !self.in_plane)
            || capped(self.steps, self.w.v.step_cap, c)
    }

    /// Restart: descend from the pushed-down node toward the last leaf, down to the deepest
    /// node that sent the ray both ways (no further: Foley and Sugerman's restart visits the
    /// nodes above the next subtree, not those above the last leaf), and continue in the far
    /// child of the deepest one whose far side starts before the closest hit `best_t`. `None`
    /// when there is none below the pushed-down node: the ray is done.
    #[inline(always)]
    fn restart<C: Counter, const ANY: bool>(&mut self, best_t: f32, c: &mut C) -> Option<Next> {
        let (nodes, l, last) = (self.w.v.nodes, self.w.l, self.idx);
        let live = if self.pd_depth >= 64 {
            0
        } else {
            self.both >> self.pd_depth << self.pd_depth
        };
        let deepest = 63u32.saturating_sub(live.leading_zeros());
        let (mut x, mut xn, mut xf, mut xd) = (self.pd, self.pd_tn, self.pd_tf, self.pd_depth);
        let mut cand = None;
        let mut pending = 0u32;
        while live != 0 && xd <= deepest {
            let n = nodes[x];
            c.interior();
            c.steps(1);
            c.planes(1);
            self.steps += 1;
            let d = decide(l, n, x, &self.s, xn, xf);
            let toward = if L::DEPTH_FIRST {
                // The left subtree of `x` is `x + 1 .. link`.
                if last < n.link() {
                    x + 1
                } else {
                    n.link()
                }
            } else {
                let (left, right) = l.children(x, n);
                if self.path >> xd & 1 == 1 {
                    right
                } else {
                    left
                }
            };
            if d.kind == Kind::Both {
                if toward == d.near {
                    if ANY || d.far_tn <= best_t {
                        let far_right = !self.s.neg[n.axis()];
                        cand = Some((d.far, d.far_tn, xf, xd << 1 | far_right as u32));
                        pending += 1;
                    }
                    xf = d.near_tf;
                } else {
                    xn = d.far_tn;
                }
            }
            x = toward;
            xd += 1;
        }
        cand.map(|(node, tn, tf, at)| Next {
            node,
            tn,
            tf,
            alone: pending == 1,
            at,
        })
    }

    /// Continue in `next`: its depth and path bits from its parent's, and the pushed-down node
    /// there where it is the only subtree pending (`push-down`, `short-stack`).
    #[inline(always)]
    fn enter(&mut self, next: Next) {
        (self.idx, self.tn, self.tf) = (next.node, next.tn, next.tf);
        if Self::TRACK {
            (self.depth, self.both, self.path) = below(self.both, self.path, next.at);
        }
        self.push = next.alone && Self::PUSHES;
        if self.push {
            (self.pd, self.pd_tn, self.pd_tf, self.pd_depth) =
                (self.idx, self.tn, self.tf, self.depth);
        }
    }
}
