//! The restart-type traversals (Hapala and Havran 2011 §3.1, §3.3, §5.1, §5.2): `restart`,
//! `push-down`, `short-stack`, `backtrack`, `sequential` and `ropes`.
//!
//! Robustness (review §3.1 and §8): no epsilon step along the ray. `restart`, `push-down`,
//! `short-stack` and `backtrack` visit exactly the leaves of `recursive-direction`, in the same
//! order, with the same decisions ([`decide`]: rounding slack at cell edges and corners, both
//! children for rays in a split plane): the state kept between leaves is the *last leaf
//! visited* (its index) instead of a distance. A restart descends from the root (or the
//! pushed-down node) toward that leaf (the depth-first layout tells which child holds it:
//! the left subtree of node `i` is `i + 1 .. right`), recomputing each node's decision and
//! interval, and continues in the far child of the deepest node where the ray went both ways
//! and the last leaf lies in the near child: the next subtree the stack traversal would pop.
//! A node's interval is the slab interval of its cell whatever the path (see [`decide`]), so
//! `backtrack` recomputes it from the cell stored with the parent links. Every restart moves
//! strictly forward in the depth-first order, so a walk ends; [`STEP_CAP`] steps end a ray
//! anyway (defensive; the ray keeps its closest hit so far).
//!
//! `sequential` (and `ropes`, which locates leaves the same way below a rope) is Kaplan's
//! leaf location at the entry distance, by distances with exact comparisons (a leaf's exit is
//! strictly beyond its entry, so it progresses without an epsilon), and without the slack: a
//! ray passing (up to rounding) through a cell edge or corner may skip a cell it only touches
//! there, which is inherent to locating one leaf per step; the mismatches are reported by the
//! tests, not hidden. Rays lying in a split plane
//! (`t = NaN`) need both children, which no single front-to-back walk can do: such a walk
//! takes the left child and records the axis, and the walk is repeated for each combination
//! of sides on the zero-direction axes where that happened (at most 4 walks).

use crate::traverse::{decide, leaf, setup, Best, Kind, Setup};
use crate::{BackNode, KdNode, KdTree};
use tb_core::slab::{max_num, min_num};
use tb_core::{Counter, HitRecord, Kernel, Ray, TriTest};

/// Steps (nodes visited, backtracking steps included) after which a ray is ended.
pub const STEP_CAP: u32 = 100_000;

/// Largest short stack of the `short-stack` traversal.
pub const MAX_SHORT_STACK: usize = 32;

/// The child holding the ray point at distance `tn` below interior node `idx` (exact
/// comparisons: a plane at `t <= tn` is behind); for a ray in the split plane the side chosen
/// by `mask`, the axis recorded in `seen`.
#[inline(always)]
fn classify(n: KdNode, idx: usize, s: &Setup, tn: f32, mask: u8, seen: &mut u8) -> usize {
    let a = n.axis();
    let t = (n.split() - s.org[a]) * s.inv[a];
    let (left, right) = (idx + 1, n.right());
    if t.is_nan() {
        *seen |= 1 << a;
        return if mask >> a & 1 != 0 { right } else { left };
    }
    let (near, far) = if s.neg[a] {
        (right, left)
    } else {
        (left, right)
    };
    if t <= tn {
        far
    } else {
        near
    }
}

/// The exit distance of the ray from `cell`: the smallest distance to its far planes, the
/// root cell's faces counting as the ray's root exit `s.t1` (see the module doc).
#[inline(always)]
fn cell_exit(kd: &KdTree, s: &Setup, min: &[f32; 3], max: &[f32; 3]) -> f32 {
    let b = &kd.bounds;
    let mut tf = s.t1;
    for a in 0..3 {
        let (far, root) = if s.neg[a] {
            (min[a], b.min[a])
        } else {
            (max[a], b.max[a])
        };
        if far != root {
            let t = (far - s.org[a]) * s.inv[a];
            if t < tf {
                tf = t;
            }
        }
    }
    tf
}

/// Run `pass(mask)` (returns `(stop, seen)`) for mask 0, then, if some walk met a split plane
/// containing the ray, for every other combination of sides on the zero-direction axes.
#[inline(always)]
fn passes(s: &Setup, mut pass: impl FnMut(u8) -> (bool, u8)) {
    let (stop, seen) = pass(0);
    if stop || seen == 0 {
        return;
    }
    let zero =
        (s.dir[0] == 0.0) as u8 | ((s.dir[1] == 0.0) as u8) << 1 | ((s.dir[2] == 0.0) as u8) << 2;
    for m in 1..8u8 {
        if m & !zero == 0 && pass(m).0 {
            return;
        }
    }
}

/// The interval of the node with cell `b`: the slab interval with the plane distances of
/// [`decide`], the root cell's faces counting as the root interval `[t0, t1]`.
#[inline(always)]
fn cell_interval(kd: &KdTree, s: &Setup, b: &BackNode) -> (f32, f32) {
    let r = &kd.bounds;
    let (mut tn, mut tf) = (s.t0, s.t1);
    for a in 0..3 {
        let (np, fp, rn, rf) = if s.neg[a] {
            (b.max[a], b.min[a], r.max[a], r.min[a])
        } else {
            (b.min[a], b.max[a], r.min[a], r.max[a])
        };
        if np != rn {
            tn = max_num(tn, (np - s.org[a]) * s.inv[a]);
        }
        if fp != rf {
            tf = min_num(tf, (fp - s.org[a]) * s.inv[a]);
        }
    }
    (tn, tf)
}

pub(crate) const RESTART: u8 = 0;
pub(crate) const PUSH_DOWN: u8 = 1;
pub(crate) const SHORT_STACK: u8 = 2;
pub(crate) const SEQUENTIAL: u8 = 3;
pub(crate) const BACKTRACK: u8 = 4;
pub(crate) const ROPES: u8 = 5;

/// "No neighbour": a rope leaving the root cell.
pub(crate) const NO_ROPE: u32 = u32::MAX;

/// The ropes of every node (review §3.3; Havran et al. 1998, Popov et al. 2007): for face
/// `2·axis + side` (side 0: the min face, 1: the max face) the deepest node whose cell holds
/// the whole face on the other side, pushed down from the parent's ropes (Popov et al.'s
/// rope optimisation): through a split parallel to the face to the adjacent child, through a
/// split missing the face to the child holding it. Meaningful for leaves; interior nodes keep
/// their (pushed-down) ropes too.
pub(crate) fn build_ropes(kd: &KdTree) -> Vec<[u32; 6]> {
    let nodes = kd.nodes.as_slice();
    let mut out = vec![[NO_ROPE; 6]; nodes.len()];
    if nodes.is_empty() {
        return out;
    }
    let push = |mut t: u32, f: usize, min: &[f32; 3], max: &[f32; 3]| -> u32 {
        while t != NO_ROPE {
            let n = nodes[t as usize];
            if n.is_leaf() {
                break;
            }
            let (a, s) = (n.axis(), n.split());
            let (left, right) = (t + 1, n.right() as u32);
            t = if a == f / 2 {
                if f % 2 == 1 {
                    left
                } else {
                    right
                }
            } else if s <= min[a] {
                right
            } else if s >= max[a] {
                left
            } else {
                break;
            };
        }
        t
    };
    let mut stack = vec![(0usize, [NO_ROPE; 6])];
    while let Some((i, mut r)) = stack.pop() {
        let b = &kd.back[i];
        for (f, rope) in r.iter_mut().enumerate() {
            *rope = push(*rope, f, &b.min, &b.max);
        }
        out[i] = r;
        let n = nodes[i];
        if !n.is_leaf() {
            let a = n.axis();
            let (mut rl, mut rr) = (r, r);
            rl[2 * a + 1] = n.right() as u32;
            rr[2 * a] = i as u32 + 1;
            stack.push((n.right(), rr));
            stack.push((i + 1, rl));
        }
    }
    out
}

/// The restart-type kernels, one struct with the walk chosen by the const parameter `M`.
///
/// - `restart` (Foley and Sugerman 2005, kd-restart; review §5.1): after each leaf, restart at
///   the root (see the module doc for what is kept between leaves);
/// - `push-down` (Horn et al. 2007; review §5.2, Alg. 4): restart at the pushed-down node, the
///   deepest node above every subtree still to visit (pushed down while the walk visits only
///   one child, and to the next subtree when no other one is pending);
/// - `short-stack` (Horn et al. 2007; review §5.2): push-down with a circular stack of
///   `short_stack` far children (the oldest overwritten when full); a restart from the
///   pushed-down node only when it runs dry;
/// - `backtrack` (Foley and Sugerman 2005, kd-backtrack; review §5.1.1, Alg. 3): from a leaf
///   climb the parent links, recomputing each node's interval from its cell (both stored in
///   the auxiliary array [`KdTree::back_nodes`]), up to the first node where the walk went
///   both ways from the near child, then descend into its far child;
/// - `sequential` (Kaplan 1985; review §3.1, Alg. 1): see the module doc;
/// - `ropes` (MacDonald and Booth 1990, Havran et al. 1998, Popov et al. 2007; review §3.3):
///   from a leaf, follow the pushed-down rope of its exit face and locate the next leaf
///   below it, by distances as `sequential` (and like it, not robust at cell edges and
///   corners, where the exit face is a tie).
///
/// Counters: `interior`, `leaves`, `planes` as the stack traversals, nodes revisited by a
/// restart or climbed by `backtrack` included; `restarts`: restarts (from the root or the
/// pushed-down node, or `backtrack` climbs; short-stack pops are not restarts); `boxes`: 1
/// for the root plus one per cell interval or exit computed (`sequential`, `backtrack`,
/// `ropes`); `steps`:
/// nodes visited, `interior + leaves`.
pub(crate) struct Stackless<'a, const M: u8>(pub &'a KdTree);

impl<const M: u8> Stackless<'_, M> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let kd = self.0;
        c.boxes(1);
        let Some(s) = setup(kd, ray) else {
            return HitRecord::MISS;
        };
        let pre = T::prepare(ray);
        let mut best = Best::new(ray.tmax);
        if M == SEQUENTIAL || M == ROPES {
            let mut steps = 0u32;
            passes(&s, |mask| {
                let mut seen = 0u8;
                let stop = if M == ROPES {
                    self.ropes::<T, C, ANY>(
                        &s, ray, &pre, &mut best, c, mask, &mut seen, &mut steps,
                    )
                } else {
                    self.sequential::<T, C, ANY>(
                        &s, ray, &pre, &mut best, c, mask, &mut seen, &mut steps,
                    )
                };
                (stop, seen)
            });
            return best.record();
        }
        let nodes = kd.nodes.as_slice();
        let back = kd.back.as_slice();
        let size = kd.params.short_stack as usize;
        let mut stack = [(0u32, 0f32, 0f32); MAX_SHORT_STACK];
        // Circular short stack: `count` entries, the newest at `top - 1` (mod `size`).
        let (mut top, mut count) = (0usize, 0usize);
        let mut steps = 0u32;
        // The pushed-down node and its interval, and whether it may still be pushed down.
        let (mut pd, mut pd_tn, mut pd_tf) = (0usize, s.t0, s.t1);
        let mut push = M == PUSH_DOWN || M == SHORT_STACK;
        let (mut idx, mut tn, mut tf) = (0usize, s.t0, s.t1);
        loop {
            // Descend to the first leaf of the subtree, near first.
            loop {
                let n = nodes[idx];
                if n.is_leaf() {
                    break;
                }
                c.interior();
                c.steps(1);
                c.planes(1);
                steps += 1;
                let d = decide(n, idx, &s, tn, tf);
                match d.kind {
                    Kind::NearOnly => idx = d.near,
                    Kind::FarOnly => idx = d.far,
                    Kind::Both => {
                        if M == SHORT_STACK {
                            stack[top] = (d.far as u32, d.far_tn, tf);
                            top = if top + 1 == size { 0 } else { top + 1 };
                            count = (count + 1).min(size);
                        }
                        push = false;
                        idx = d.near;
                        tf = d.near_tf;
                    }
                }
                if push {
                    (pd, pd_tn, pd_tf) = (idx, tn, tf);
                }
            }
            steps += 1;
            if leaf::<T, C, ANY>(kd, nodes[idx], &pre, ray, &mut best, c) {
                return best.record();
            }
            if steps >= STEP_CAP {
                return best.record();
            }
            let last = idx;
            if M == SHORT_STACK {
                let mut popped = false;
                while count > 0 {
                    top = if top == 0 { size - 1 } else { top - 1 };
                    count -= 1;
                    let (i, a, b) = stack[top];
                    if ANY || a <= best.t {
                        (idx, tn, tf) = (i as usize, a, b);
                        popped = true;
                        break;
                    }
                }
                if popped {
                    continue;
                }
            }
            c.restart();
            let next = if M == BACKTRACK {
                // Climb from the leaf.
                let mut child = last;
                let mut x = back[last].parent as usize;
                loop {
                    c.interior();
                    c.steps(1);
                    c.planes(1);
                    c.boxes(1);
                    steps += 1;
                    let (xn, xf) = cell_interval(kd, &s, &back[x]);
                    let d = decide(nodes[x], x, &s, xn, xf);
                    if d.kind == Kind::Both && child == d.near && (ANY || d.far_tn <= best.t) {
                        break Some((d.far, d.far_tn, xf, false));
                    }
                    if x == 0 {
                        break None;
                    }
                    child = x;
                    x = back[x].parent as usize;
                }
            } else {
                // Descend from the pushed-down node toward the last leaf.
                let (mut x, mut xn, mut xf) = (pd, pd_tn, pd_tf);
                let mut cand = None;
                let mut pending = 0u32;
                while x != last {
                    let n = nodes[x];
                    c.interior();
                    c.steps(1);
                    c.planes(1);
                    steps += 1;
                    let d = decide(n, x, &s, xn, xf);
                    let toward = if last < n.right() { x + 1 } else { n.right() };
                    if d.kind == Kind::Both {
                        if toward == d.near {
                            if ANY || d.far_tn <= best.t {
                                cand = Some((d.far, d.far_tn, xf));
                                pending += 1;
                            }
                            xf = d.near_tf;
                        } else {
                            xn = d.far_tn;
                        }
                    }
                    x = toward;
                }
                cand.map(|(f, a, b)| (f, a, b, pending == 1))
            };
            let Some((f, a, b, alone)) = next else {
                return best.record();
            };
            (idx, tn, tf) = (f, a, b);
            push = alone && (M == PUSH_DOWN || M == SHORT_STACK);
            if push {
                (pd, pd_tn, pd_tf) = (idx, tn, tf);
            }
        }
    }

    /// One walk of `ropes`: locate the entry leaf from the root, then from each leaf follow
    /// the rope of its exit face and locate the next leaf below the rope's node.
    #[inline(always)]
    fn ropes<T: TriTest, C: Counter, const ANY: bool>(
        &self,
        s: &Setup,
        ray: &Ray,
        pre: &T::Pre,
        best: &mut Best,
        c: &mut C,
        mask: u8,
        seen: &mut u8,
        steps: &mut u32,
    ) -> bool {
        let kd = self.0;
        let nodes = kd.nodes.as_slice();
        let r = &kd.bounds;
        let mut tn = s.t0;
        let mut idx = 0usize;
        loop {
            // Leaf location of the ray point at `tn` below `idx`.
            loop {
                let n = nodes[idx];
                if n.is_leaf() {
                    break;
                }
                c.interior();
                c.steps(1);
                c.planes(1);
                *steps += 1;
                idx = classify(n, idx, s, tn, mask, seen);
            }
            *steps += 1;
            if leaf::<T, C, ANY>(kd, nodes[idx], pre, ray, best, c) {
                return true;
            }
            // The exit face: the nearest far plane that is not a root face.
            c.boxes(1);
            let b = &kd.back[idx];
            let (mut tf, mut face) = (s.t1, usize::MAX);
            for a in 0..3 {
                let (far, root, side) = if s.neg[a] {
                    (b.min[a], r.min[a], 0)
                } else {
                    (b.max[a], r.max[a], 1)
                };
                if far != root {
                    let t = (far - s.org[a]) * s.inv[a];
                    if t < tf {
                        tf = t;
                        face = 2 * a + side;
                    }
                }
            }
            if best.t <= tf || face == usize::MAX || *steps >= STEP_CAP {
                return *steps >= STEP_CAP;
            }
            let rope = kd.ropes[idx][face];
            if rope == NO_ROPE {
                return false;
            }
            tn = tn.max(tf);
            idx = rope as usize;
        }
    }

    /// One walk of `sequential`.
    #[inline(always)]
    fn sequential<T: TriTest, C: Counter, const ANY: bool>(
        &self,
        s: &Setup,
        ray: &Ray,
        pre: &T::Pre,
        best: &mut Best,
        c: &mut C,
        mask: u8,
        seen: &mut u8,
        steps: &mut u32,
    ) -> bool {
        let kd = self.0;
        let nodes = kd.nodes.as_slice();
        let mut tn = s.t0;
        loop {
            // Leaf location of the ray point at `tn`, keeping the cell.
            let mut idx = 0usize;
            let (mut min, mut max) = (kd.bounds.min.to_array(), kd.bounds.max.to_array());
            loop {
                let n = nodes[idx];
                if n.is_leaf() {
                    break;
                }
                c.interior();
                c.steps(1);
                c.planes(1);
                *steps += 1;
                let child = classify(n, idx, s, tn, mask, seen);
                if child == idx + 1 {
                    max[n.axis()] = n.split();
                } else {
                    min[n.axis()] = n.split();
                }
                idx = child;
            }
            *steps += 1;
            if leaf::<T, C, ANY>(kd, nodes[idx], pre, ray, best, c) {
                return true;
            }
            c.boxes(1);
            let tf = cell_exit(kd, s, &min, &max);
            if best.t <= tf || tf >= s.t1 || tf <= tn {
                return false;
            }
            if *steps >= STEP_CAP {
                return true;
            }
            tn = tf;
            c.restart();
        }
    }
}

impl<const M: u8> Kernel for Stackless<'_, M> {
    #[inline]
    fn closest<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        self.walk::<T, C, false>(ray, c)
    }

    #[inline]
    fn any<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        self.walk::<T, C, true>(ray, c)
    }
}
