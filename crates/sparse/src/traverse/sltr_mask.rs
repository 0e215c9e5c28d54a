//! `sltr-mask` (our variant of Havran and Bittner 2007 §5.3, Alg. 3; the GPU kernel's walk):
//! down to a leaf choosing the first intersected child, then on to the next leaf from a
//! per-depth mask of the nodes that sent the ray both ways, restarting from the last augmented
//! node or, up the parent links, from the one above it (the module doc of `traverse` gives the
//! whole rule). Laid out as tb-kdtree's `restart`: the walk state [`MaskWalk`] and its named
//! steps [`MaskWalk::descend`] to the next leaf, [`MaskWalk::leaf`], [`MaskWalk::restart`]
//! (from the last augmented node toward the last leaf, after [`MaskWalk::climb`]ing the parent
//! links to it; [`MaskWalk::widen`] above the part of the tree the walk knows) and
//! [`MaskWalk::enter`] the next subtree ([`RestartSteps`]); tb-kdtree's [`restart_loop`]
//! composes them.

use super::*;

impl Ctx<'_> {
    /// `sltr-mask` from record `hint` (see the module doc).
    #[inline(always)]
    pub(super) fn sltr_mask<T: TriTest, C: Counter, const ANY: bool>(
        &self,
        ray: &Ray,
        hint: u32,
        c: &mut C,
    ) -> HitRecord {
        let Some(s) = self.clip_root(ray, c) else {
            return HitRecord::MISS;
        };
        let pre = T::prepare(ray);
        let st = self.start(ray, hint);
        let k = MaskWalk::new(self, &s, st, 0, c);
        restart_loop::<_, T, C, ANY>(k, ray, &pre, Best::new(ray.tmax), c)
    }
}

/// `lastAugmentedNode` of `sltr-mask`: node, record ([`NONE`]: not looked up yet), depth and
/// interval.
#[derive(Clone, Copy)]
struct LastBox {
    node: usize,
    rec: u32,
    depth: u32,
    tn: f32,
    tf: f32,
}

/// The next subtree of a walk: its node, interval and depth.
pub(super) struct Next {
    node: usize,
    tn: f32,
    tf: f32,
    depth: u32,
}

/// One ray's `sltr-mask` walk.
pub(super) struct MaskWalk<'c, 'a> {
    cx: &'c Ctx<'a>,
    s: &'c Setup,
    /// Steps taken (the cap's count).
    steps: u32,
    /// The record whose subtree the walk knows, and its depth: the bits are valid at depths
    /// `>= dtop`.
    top: usize,
    dtop: u32,
    /// The last augmented node passed (`lastAugmentedNode`, with `tup`).
    last: LastBox,
    /// The current node, its interval and depth, and `depth % period` (kept by the descent:
    /// a division per step was the walk's costliest instruction, 20 % slower than SEQ on
    /// Sponza; one per restart remains).
    idx: usize,
    tn: f32,
    tf: f32,
    depth: u32,
    phase: u32,
    /// Bit `k`: the node at depth `k` on the way to the current leaf sent the ray both ways
    /// and the walk is in its near child.
    both: u64,
    /// The ray lies in a split plane it met (children's intervals overlap).
    in_plane: bool,
}

impl<'c, 'a> MaskWalk<'c, 'a> {
    /// A walk over `s`'s root interval from record `st` (its interval one box), `steps` steps
    /// already taken.
    #[inline(always)]
    pub(super) fn new<C: Counter>(
        cx: &'c Ctx<'a>,
        s: &'c Setup,
        st: usize,
        steps: u32,
        c: &mut C,
    ) -> Self {
        let depth = cx.depth[st] as u32;
        let (tn, tf) = if st == 0 {
            (s.t0, s.t1)
        } else {
            c.boxes(1);
            cx.interval(s, &cx.aug[st])
        };
        let node = cx.aug[st].node as usize;
        MaskWalk {
            cx,
            s,
            steps,
            top: st,
            dtop: depth,
            last: LastBox {
                node,
                rec: st as u32,
                depth,
                tn,
                tf,
            },
            idx: node,
            tn,
            tf,
            depth,
            phase: depth % cx.period,
            both: 0,
            in_plane: false,
        }
    }

    /// `TraverseUp` from the last augmented node to the one at depth `dr` above it (one
    /// parent link each, one box for its interval), which becomes the last augmented node.
    #[inline(always)]
    fn climb<C: Counter>(&mut self, dr: u32, c: &mut C) {
        if dr == self.last.depth {
            return;
        }
        let (aug, p) = (self.cx.aug, self.cx.period);
        let mut rec = self.cx.record(self.last.rec, self.last.node);
        let mut dd = self.last.depth;
        while dd > dr {
            rec = aug[rec as usize].parent;
            dd -= p;
            parent_link(c);
        }
        c.boxes(1);
        let r = &aug[rec as usize];
        let (tn, tf) = self.cx.interval(self.s, r);
        self.last = LastBox {
            node: r.node as usize,
            rec,
            depth: dr,
            tn,
            tf,
        };
    }

    /// Down from the last augmented node toward the last leaf `lf` to depth `k`: the far child
    /// there when that node sends the ray both ways with the leaf in its near child.
    #[inline(always)]
    fn retrace<C: Counter>(&mut self, lf: usize, k: u32, c: &mut C) -> Option<Next> {
        let l = self.last;
        let (mut x, mut xn, mut xf, mut xd) = (l.node, l.tn, l.tf, l.depth);
        loop {
            let (d, toward) = self.step_toward(x, lf, xn, xf, c);
            if xd == k {
                let (node, tn, tf, depth) = (d.far, d.far_tn, xf, k + 1);
                return (d.kind == Kind::Both && toward == d.near).then_some(Next {
                    node,
                    tn,
                    tf,
                    depth,
                });
            }
            if d.kind == Kind::Both {
                if toward == d.near {
                    xf = d.near_tf;
                } else {
                    xn = d.far_tn;
                }
            }
            x = toward;
            xd += 1;
        }
    }

    /// `TraverseUp` above the known part: the parent augmented node of `top` (one parent link,
    /// one box), then down from it toward the last leaf `lf` to the known depth, recording the
    /// bits of those levels; the parent becomes `top` and the last augmented node. Returns the
    /// far child of the deepest node there that sends the ray both ways with the leaf in its
    /// near child, and that node's depth.
    #[inline(always)]
    fn widen<C: Counter>(&mut self, lf: usize, c: &mut C) -> Option<(Next, u32)> {
        let aug = self.cx.aug;
        let pr = aug[self.top].parent as usize;
        parent_link(c);
        c.boxes(1);
        let dp = self.dtop - self.cx.period;
        let (pn, pf) = self.cx.interval(self.s, &aug[pr]);
        let (mut x, mut xn, mut xf, mut xd) = (aug[pr].node as usize, pn, pf, dp);
        let mut cand = None;
        while xd < self.dtop {
            let (d, toward) = self.step_toward(x, lf, xn, xf, c);
            if d.kind == Kind::Both {
                self.in_plane |= d.far_tn < d.near_tf;
                if toward == d.near {
                    self.both |= 1 << xd;
                    let (node, tn, tf, depth) = (d.far, d.far_tn, xf, xd + 1);
                    cand = Some((
                        Next {
                            node,
                            tn,
                            tf,
                            depth,
                        },
                        xd,
                    ));
                    xf = d.near_tf;
                } else {
                    xn = d.far_tn;
                }
            }
            x = toward;
            xd += 1;
        }
        (self.top, self.dtop) = (pr, dp);
        let (node, rec) = (aug[pr].node as usize, pr as u32);
        self.last = LastBox {
            node,
            rec,
            depth: dp,
            tn: pn,
            tf: pf,
        };
        cand
    }

    /// One node on the way toward the last leaf `lf` (one node, one plane, one step): node
    /// `x`'s decision over `[xn, xf]`, and its child holding `lf`.
    #[inline(always)]
    fn step_toward<C: Counter>(
        &mut self,
        x: usize,
        lf: usize,
        xn: f32,
        xf: f32,
        c: &mut C,
    ) -> (Decision, usize) {
        let n = self.cx.nodes[x];
        c.interior();
        c.steps(1);
        c.planes(1);
        self.steps += 1;
        let d = decide(n, x, self.s, xn, xf);
        let toward = if lf < n.link() { x + 1 } else { n.link() };
        (d, toward)
    }
}

impl RestartSteps for MaskWalk<'_, '_> {
    type Next = Next;

    /// `TraverseDown` to a leaf, the near child first where the ray goes both ways (its bit
    /// set), each interior node counted (one node, one plane, one step); every augmented node
    /// passed becomes `last`.
    #[inline(always)]
    fn descend<C: Counter>(&mut self, c: &mut C) {
        let (nodes, p) = (self.cx.nodes, self.cx.period);
        loop {
            let n = nodes[self.idx];
            if n.is_leaf() {
                return;
            }
            if self.phase == 0 && self.idx != self.last.node {
                self.last = LastBox {
                    node: self.idx,
                    rec: NONE,
                    depth: self.depth,
                    tn: self.tn,
                    tf: self.tf,
                };
            }
            c.interior();
            c.steps(1);
            c.planes(1);
            self.steps += 1;
            let d = decide(n, self.idx, self.s, self.tn, self.tf);
            match d.kind {
                Kind::NearOnly => self.idx = d.near,
                Kind::FarOnly => self.idx = d.far,
                Kind::Both => {
                    self.in_plane |= d.far_tn < d.near_tf;
                    self.both |= 1 << self.depth;
                    self.idx = d.near;
                    self.tf = d.near_tf;
                }
            }
            self.depth += 1;
            self.phase += 1;
            if self.phase == p {
                self.phase = 0;
            }
        }
    }

    /// Test the leaf reached (one step); `true` when the ray is done: an any-hit found, a hit
    /// before the leaf's exit (every cell still to visit starts at or beyond it; not for a ray
    /// lying in a split plane, whose both children span the interval), or the step cap reached.
    #[inline(always)]
    fn leaf<T: TriTest, C: Counter, const ANY: bool>(
        &mut self,
        pre: &T::Pre,
        ray: &Ray,
        best: &mut Best,
        c: &mut C,
    ) -> bool {
        let cx = self.cx;
        self.steps += 1;
        leaf::<T, C, ANY>(&cx.kd, cx.nodes[self.idx], pre, ray, best, c)
            || (best.t < self.tf && !self.in_plane)
            || capped(self.steps, cx.cap, c)
    }

    /// `RestartTraversal` after the leaf reached: the far child of the deepest node still to
    /// come back to, found from the augmented node above it ([`Self::climb`],
    /// [`Self::retrace`]), or above the known part ([`Self::widen`]) when no such node is left
    /// there; one whose far side starts beyond the closest hit `best_t` is passed over. `None`:
    /// none is left below the root, the ray is done.
    #[inline(always)]
    fn restart<C: Counter, const ANY: bool>(&mut self, best_t: f32, c: &mut C) -> Option<Next> {
        let (lf, p) = (self.idx, self.cx.period);
        loop {
            let live = if self.dtop >= 64 {
                0
            } else {
                self.both >> self.dtop << self.dtop
            };
            if live != 0 {
                let k = 63 - live.leading_zeros();
                self.both &= (1u64 << k) - 1;
                self.climb(k / p * p, c);
                match self.retrace(lf, k, c) {
                    Some(next) if ANY || next.tn <= best_t => return Some(next),
                    _ => continue,
                }
            }
            if self.top == 0 {
                return None;
            }
            if let Some((next, k)) = self.widen(lf, c) {
                if ANY || next.tn <= best_t {
                    self.both &= (1u64 << k) - 1;
                    return Some(next);
                }
            }
        }
    }

    /// Continue in `next` (its depth's phase computed).
    #[inline(always)]
    fn enter(&mut self, next: Next) {
        (self.idx, self.tn, self.tf) = (next.node, next.tn, next.tf);
        self.depth = next.depth;
        self.phase = self.depth % self.cx.period;
    }
}
