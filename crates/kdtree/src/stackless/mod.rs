//! The restart-type traversals (Hapala and Havran 2011 §3.1, §3.3, §5.1, §5.2): `restart`,
//! `push-down`, `short-stack`, `backtrack`, `sequential` and `ropes`.
//!
//! Robustness (review §3.1 and §8): no epsilon step along the ray. `restart`, `push-down`,
//! `short-stack` and `backtrack` visit exactly the leaves of `recursive-direction`, in the same
//! order, with the same decisions ([`decide`]: rounding slack at cell edges and corners, both
//! children for rays in a split plane): the state kept between leaves is the *last leaf
//! visited* instead of a distance: the depth of each node on its path that sent the ray both
//! ways with the walk in the near child (one bit per depth), and which child the path takes
//! (the index in the depth-first layout, whose subtrees are index ranges; one bit per depth in
//! the treelet layout). A restart descends from the root (or the pushed-down node) along that
//! path, recomputing each node's decision and interval, down to the deepest such node, and
//! continues in the far child of the deepest one whose far side starts before the closest hit:
//! the next subtree the stack traversal would pop. So per leaf it visits the nodes on the
//! root's path to the *next* leaf, as Foley and Sugerman's restart with `t_min` set to the
//! exit does, not those above the last one (a test checks `restart` and `sequential` visit the
//! same nodes). A node's interval is the slab interval of its cell whatever the path (see
//! [`decide`]), so `backtrack` recomputes it from the cell stored with the parent links. Every
//! restart moves strictly forward in the depth-first order of the tree, so a walk ends;
//! [`STEP_CAP`] steps end a ray anyway (defensive; the ray keeps its closest hit so far).
//!
//! `sequential` and `ropes` are Kaplan's point location (review §3.1, Alg. 1) of the ray
//! point at the entry distance, from the root or below a rope, without an epsilon step: the
//! root cause of their failures was a point that rounds back: the plane distances of the exit
//! face and of a plane one ulp beyond it (a one-ulp-thin cell, Sibenik) round to the same
//! `t`, and locating "the point at `t`" skipped the thin cell; likewise a ray far from a
//! small cluster (`t` ulps coarser than its cells) cannot be located by distances at all. So
//! the located point's coordinate on each axis whose exit face was crossed is that face's
//! coordinate exactly (`Walk::floor`: planes at or before it are behind, compared as
//! coordinates), and every other plane is behind only when its distance is below `t` by more
//! than the rounding [`SLACK`]. Each step crosses one exit face strictly beyond the last on
//! its axis, so a walk ends. The point at `t = 0` is the ray origin itself, exact on every
//! axis (review §3.1's ray origin in a splitting plane, e.g. a camera eye at `z = 0`): there
//! planes are compared with the origin's coordinates, and a plane through the origin puts the
//! origin in the near cell (which the ray touches there: a hit at `t = 0` counts), whose exit
//! is that plane at `t = 0`; the next point location finds the plane at the floor, so the ray
//! leaves it to the side its direction points to, without the fallback. Where a single point
//! cannot decide (a plane distance within [`SLACK`] of a located point other than the origin,
//! or two exit faces tied: a ray through a cell edge or corner), the walk stops and the ray is
//! handed to `restart` from the root, keeping its closest hit (counted as one restart and in
//! `handovers`): the answer is then exactly the robust one. Rays lying in a split plane (`t = NaN`) take the
//! left child and record the axis, and the walk is repeated for each combination of sides on
//! the zero-direction axes where that happened (at most 4 walks); an axis whose component is
//! below `1/f32::MAX` (subnormal: `1/d` overflows to `±inf`, and a plane through the origin
//! gives NaN) counts as zero-direction.
//!
//! "The root" above is the start of the walk ([`crate::KdStart`]): the tree's root, or a node
//! below it whose cell the ray was clipped to. Restarts begin again there, `backtrack` climbs
//! no higher, the faces of its cell play the root faces (a rope or exit face on them ends the
//! walk), and point location descends from it.

use crate::traverse::{decide, leaf, start, Best, Kind, Setup, Tree, SLACK};
use crate::view::{Aux, BackNode, NO_ROPE};
use crate::Layout;
use tb_core::slab::{max_num, min_num};
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// The default per-ray step cap ([`crate::KdParams::step_cap`]): steps (nodes visited,
/// backtracking steps included) after which a restart-type walk ends a ray.
pub const STEP_CAP: u32 = 100_000;

/// Largest short stack of the `short-stack` traversal.
pub const MAX_SHORT_STACK: usize = 32;

/// Run `pass(mask)` (returns `(stop, seen)`) for mask 0, then, if some walk met a split plane
/// containing the ray, for every other combination of sides on the zero-direction axes.
#[inline(always)]
fn passes(s: &Setup, mut pass: impl FnMut(u8) -> (bool, u8)) {
    let (stop, seen) = pass(0);
    if stop || seen == 0 {
        return;
    }
    // Axes whose reciprocal is infinite: a zero component, or one below `1/f32::MAX` (a
    // subnormal: `1/d` overflows, so a plane through the origin gives `0 · inf = NaN` as for
    // a zero component; issue 46). The ray's offset from that plane, `|d|·t`, stays below what
    // the triangle test resolves, so both sides are walked, as for a ray lying in the plane.
    let zero = (!s.inv[0].is_finite()) as u8
        | ((!s.inv[1].is_finite()) as u8) << 1
        | ((!s.inv[2].is_finite()) as u8) << 2;
    for m in 1..8u8 {
        if m & !zero == 0 && pass(m).0 {
            return;
        }
    }
}

/// The interval of the node with cell `b`: the slab interval with the plane distances of
/// [`decide`], the faces of the start cell `r` counting as the start interval `[t0, t1]`.
#[inline(always)]
fn cell_interval(r: &tb_core::Aabb, s: &Setup, b: &BackNode) -> (f32, f32) {
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

/// The depth, `both` and `path` bits (see `Stackless::stackless`) of the far child of a node
/// on the way to the last leaf: `at` is that node's depth `<< 1 |` 1 for the right child;
/// bits from the node's depth on are cleared (it no longer sends the walk both ways ahead).
#[inline(always)]
fn below(both: u64, path: u64, at: u32) -> (u32, u64, u64) {
    let pd = at >> 1;
    let keep = (1u64 << pd) - 1;
    (pd + 1, both & keep, path & keep | ((at & 1) as u64) << pd)
}

pub const RESTART: u8 = 0;
pub const PUSH_DOWN: u8 = 1;
pub const SHORT_STACK: u8 = 2;
pub const SEQUENTIAL: u8 = 3;
pub const BACKTRACK: u8 = 4;
pub const ROPES: u8 = 5;

/// The restart-type kernels, one struct with the walk chosen by the const parameter `M`; the
/// auxiliary arrays it reads (`backtrack`: cells and parents; `ropes`: those and the ropes)
/// are given with it, empty for the others. "The root" below is the walk's start node.
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
///   the auxiliary array [`crate::KdTree::back_nodes`]), up to the first node where the walk
///   went both ways from the near child, then descend into its far child (none above a leaf
///   start node: the walk is done);
/// - `sequential` (Kaplan 1985; review §3.1, Alg. 1): see the module doc;
/// - `ropes` (MacDonald and Booth 1990, Havran et al. 1998, Popov et al. 2007; review §3.3):
///   from a leaf, follow the pushed-down rope of its exit face and locate the next leaf
///   below it as `sequential` does (the same hand-over to `restart` where a point cannot
///   decide).
///
/// Counters: `interior`, `leaves`, `planes` as the stack traversals, nodes revisited by a
/// restart or climbed by `backtrack` included; `restarts`: restarts (from the root or the
/// pushed-down node, or `backtrack` climbs; short-stack pops are not restarts; `sequential`
/// and `ropes` count a hand-over to `restart` as one restart and in `handovers`); `boxes`: 1
/// for the root plus one per cell interval or exit computed (`sequential`, `backtrack`,
/// `ropes`); `steps`:
/// nodes visited, `interior + leaves`.
pub struct Stackless<'a, L, const M: u8>(pub Tree<'a, L>, pub Aux<'a>);

impl<L: Layout, const M: u8> Stackless<'_, L, M> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let w = &self.0;
        let Some((s, pre, mut best)) = start::<T, C, L>(w, ray, c) else {
            return HitRecord::MISS;
        };
        if M == SEQUENTIAL || M == ROPES {
            let root = &w.from.cell;
            let floor: [f32; 3] =
                std::array::from_fn(|a| if s.neg[a] { root.max[a] } else { root.min[a] });
            let mut steps = 0u32;
            let mut ambiguous = false;
            passes(&s, |mask| {
                let mut walk = Walk {
                    w,
                    s: &s,
                    floor,
                    exact: 3,
                    mask,
                    seen: 0,
                    steps,
                    cap: w.v.step_cap,
                    ambiguous: false,
                };
                let stop = if M == ROPES {
                    self.crawl::<T, C, ANY, true>(&mut walk, ray, &pre, &mut best, c)
                } else {
                    self.crawl::<T, C, ANY, false>(&mut walk, ray, &pre, &mut best, c)
                };
                steps = walk.steps;
                ambiguous = stop.is_none();
                (stop.unwrap_or(true), walk.seen)
            });
            if !ambiguous {
                return best.record();
            }
            // Point location was ambiguous within rounding: hand the ray to kd-restart.
            c.restart();
            c.handover();
            return self.stackless::<T, C, ANY, RESTART>(&s, ray, &pre, best, steps, c);
        }
        self.stackless::<T, C, ANY, M>(&s, ray, &pre, best, 0, c)
    }

    /// The restart-type walk `K` (`RESTART`, `PUSH_DOWN`, `SHORT_STACK`, `BACKTRACK`) of one
    /// ray from the start node, starting with the closest hit `best` and `steps` steps taken.
    ///
    /// The restarts find the last leaf again: in the depth-first layout by its index (the
    /// subtree of a node is a range of indices), otherwise by its *path* from the start (bit
    /// `k` set when the walk went to the right child at depth `k`; the depth limit is at most
    /// 64).
    #[inline(always)]
    fn stackless<T: TriTest, C: Counter, const ANY: bool, const K: u8>(
        &self,
        s: &Setup,
        ray: &Ray,
        pre: &T::Pre,
        mut best: Best,
        mut steps: u32,
        c: &mut C,
    ) -> HitRecord {
        let (w, l) = (&self.0, self.0.l);
        let s = *s;
        let nodes = w.v.nodes;
        let back = self.1.back;
        let size = w.v.short_stack as usize;
        let root = w.from.node as usize;
        // Far child, its interval, and its parent's depth `<< 1 |` whether it is the right child.
        let mut stack = [(0u32, 0f32, 0f32, 0u32); MAX_SHORT_STACK];
        // Circular short stack: `count` entries, the newest at `top - 1` (mod `size`).
        let (mut top, mut count) = (0usize, 0usize);
        // The pushed-down node, its interval and depth, and whether it may still be pushed down.
        let (mut pd, mut pd_tn, mut pd_tf, mut pd_depth) = (root, s.t0, s.t1, 0u32);
        let mut push = K == PUSH_DOWN || K == SHORT_STACK;
        let (mut idx, mut tn, mut tf) = (root, s.t0, s.t1);
        // Depth of `idx`; `both`: bit `k` set when the node at depth `k` on the way to `idx`
        // sent the ray both ways and the walk went to the near child (the candidates of the
        // next restart); `path`: bit `k` set when the walk went to the right child at depth
        // `k` (treelet layout only: in the depth-first one, indices tell the subtree). Bits at
        // and beyond `depth` are zero. `backtrack` climbs parent links and keeps none.
        let track = K != BACKTRACK;
        let (mut depth, mut both, mut path) = (0u32, 0u64, 0u64);
        // The ray lies in a split plane it met (its children overlap in `t`).
        let mut in_plane = false;
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
                let d = decide(l, n, idx, &s, tn, tf);
                let near_right = s.neg[n.axis()];
                let go_right = match d.kind {
                    Kind::NearOnly => {
                        idx = d.near;
                        near_right
                    }
                    Kind::FarOnly => {
                        idx = d.far;
                        !near_right
                    }
                    Kind::Both => {
                        // `far_tn < near_tf` only for `t = NaN` (see `decide`).
                        in_plane |= d.far_tn < d.near_tf;
                        if K == SHORT_STACK {
                            stack[top] =
                                (d.far as u32, d.far_tn, tf, depth << 1 | !near_right as u32);
                            top = if top + 1 == size { 0 } else { top + 1 };
                            count = (count + 1).min(size);
                        }
                        push = false;
                        idx = d.near;
                        tf = d.near_tf;
                        if track {
                            both |= 1 << depth;
                        }
                        near_right
                    }
                };
                if track {
                    if !L::DEPTH_FIRST {
                        path |= (go_right as u64) << depth;
                    }
                    depth += 1;
                }
                if push {
                    (pd, pd_tn, pd_tf, pd_depth) = (idx, tn, tf, depth);
                }
            }
            steps += 1;
            if leaf::<T, C, ANY>(&w.v, nodes[idx], pre, ray, &mut best, c) {
                return best.record();
            }
            // A hit before the end of the leaf's interval ends the ray (Foley and Sugerman's
            // early exit): every pending subtree starts at or beyond that end (`tf`, the near
            // interval of the deepest node that sent the ray both ways), so the stack
            // traversal would skip them all and a restart would find none. Not for a ray
            // lying in a split plane: both of that node's children span its whole interval.
            if best.t < tf && !in_plane {
                return best.record();
            }
            if steps >= w.v.step_cap {
                c.capped();
                return best.record();
            }
            let last = idx;
            if K == SHORT_STACK {
                let mut popped = false;
                while count > 0 {
                    top = if top == 0 { size - 1 } else { top - 1 };
                    count -= 1;
                    let (i, a, b, at) = stack[top];
                    if ANY || a <= best.t {
                        (idx, tn, tf) = (i as usize, a, b);
                        (depth, both, path) = below(both, path, at);
                        popped = true;
                        break;
                    }
                }
                if popped {
                    continue;
                }
            }
            if K == BACKTRACK && last == root {
                // The start node is a leaf: there is nothing to climb to.
                return best.record();
            }
            c.restart();
            let next = if K == BACKTRACK {
                // Climb from the leaf.
                let mut child = last;
                let mut x = back[last].parent as usize;
                loop {
                    c.interior();
                    c.steps(1);
                    c.planes(1);
                    c.boxes(1);
                    steps += 1;
                    let (xn, xf) = cell_interval(&w.from.cell, &s, &back[x]);
                    let d = decide(l, nodes[x], x, &s, xn, xf);
                    if d.kind == Kind::Both && child == d.near && (ANY || d.far_tn <= best.t) {
                        break Some((d.far, d.far_tn, xf, false, 0));
                    }
                    if x == root {
                        break None;
                    }
                    child = x;
                    x = back[x].parent as usize;
                }
            } else {
                // Descend from the pushed-down node toward the last leaf, down to the deepest
                // node that sent the ray both ways (no further: Foley and Sugerman's restart
                // visits the nodes above the next subtree, not those above the last leaf),
                // and continue in the far child of the deepest one whose far side starts
                // before the closest hit. None below the pushed-down node: the ray is done.
                let live = if pd_depth >= 64 {
                    0
                } else {
                    both >> pd_depth << pd_depth
                };
                let deepest = 63u32.saturating_sub(live.leading_zeros());
                let (mut x, mut xn, mut xf, mut xd) = (pd, pd_tn, pd_tf, pd_depth);
                let mut cand = None;
                let mut pending = 0u32;
                while live != 0 && xd <= deepest {
                    let n = nodes[x];
                    c.interior();
                    c.steps(1);
                    c.planes(1);
                    steps += 1;
                    let d = decide(l, n, x, &s, xn, xf);
                    let toward = if L::DEPTH_FIRST {
                        // The left subtree of `x` is `x + 1 .. link`.
                        if last < n.link() {
                            x + 1
                        } else {
                            n.link()
                        }
                    } else {
                        let (left, right) = l.children(x, n);
                        if path >> xd & 1 == 1 {
                            right
                        } else {
                            left
                        }
                    };
                    let toward_near = toward == d.near;
                    if d.kind == Kind::Both {
                        if toward_near {
                            if ANY || d.far_tn <= best.t {
                                let far_right = !s.neg[n.axis()];
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
                cand.map(|(f, a, b, at)| (f, a, b, pending == 1, at))
            };
            let Some((f, a, b, alone, at)) = next else {
                return best.record();
            };
            (idx, tn, tf) = (f, a, b);
            if track {
                (depth, both, path) = below(both, path, at);
            }
            push = alone && (K == PUSH_DOWN || K == SHORT_STACK);
            if push {
                (pd, pd_tn, pd_tf, pd_depth) = (idx, tn, tf, depth);
            }
        }
    }

    /// One walk of `sequential` (`ROPE == false`) or `ropes` (`ROPE == true`): locate the
    /// entry leaf from the root, then repeatedly leave the leaf through its exit face and
    /// locate the next leaf, from the root (`sequential`) or below the exit face's rope
    /// (`ropes`), with [`Walk::locate`]. Returns `true` when the ray is done (any-hit found, or
    /// the step cap reached).
    #[inline(always)]
    fn crawl<T: TriTest, C: Counter, const ANY: bool, const ROPE: bool>(
        &self,
        w: &mut Walk<'_, L>,
        ray: &Ray,
        pre: &T::Pre,
        best: &mut Best,
        c: &mut C,
    ) -> Option<bool> {
        let (v, aux) = (&self.0.v, &self.1);
        let s = w.s;
        let r = &self.0.from.cell;
        let (mut idx, mut min, mut max) = w.locate_start(s.t0, w.floor, c);
        let mut tn = s.t0;
        loop {
            if w.ambiguous {
                return None;
            }
            // `ropes`: the leaf's record, its cell (the one located) and its ropes.
            let rec = ROPE.then(|| {
                aux.ropes
                    .expect("the ropes kernel is given the ropes array")
                    .leaf(idx)
            });
            if let Some(rec) = rec {
                (min, max) = (rec.min, rec.max);
            }
            w.steps += 1;
            if leaf::<T, C, ANY>(v, v.nodes[idx], pre, ray, best, c) {
                return Some(true);
            }
            if w.steps >= w.cap {
                c.capped();
                return Some(true);
            }
            // The exit: the nearest far plane that is not a start-cell face. Another far plane
            // within rounding of it (a ray through a cell edge or corner) is an ambiguity.
            c.boxes(1);
            let mut ts = [f32::INFINITY; 3];
            let (mut tf, mut face) = (f32::INFINITY, 3usize);
            for a in 0..3 {
                let (far, root) = if s.neg[a] {
                    (min[a], r.min[a])
                } else {
                    (max[a], r.max[a])
                };
                if far != root {
                    let t = (far - s.org[a]) * s.inv[a];
                    ts[a] = t;
                    if t < tf {
                        tf = t;
                        face = a;
                    }
                }
            }
            if face == 3 || best.t <= tf || tf > s.t1 * SLACK {
                return Some(false);
            }
            let reach = tf + (SLACK - 1.0) * tf.abs();
            if (0..3).any(|a| a != face && ts[a] <= reach) {
                return None;
            }
            w.floor[face] = if s.neg[face] { min[face] } else { max[face] };
            w.exact = face;
            tn = max_num(tn, tf);
            if let Some(rec) = rec {
                let side = if s.neg[face] { 0 } else { 1 };
                let rope = rec.ropes[2 * face + side];
                if rope == NO_ROPE {
                    return Some(false);
                }
                // The cell the location tracks below the rope is not needed: the next leaf's
                // record has its cell.
                (idx, min, max) = w.locate(rope as usize, min, max, tn, w.floor, c);
            } else {
                c.restart();
                (idx, min, max) = w.locate_start(tn, w.floor, c);
            }
        }
    }
}

/// The point of Kaplan's point location (review §3.1) as `sequential` and `ropes` place it
/// (see `Walk::locate`), and sparse boxes' SLTR after them: the point at distance `tn`,
/// whose coordinate on an axis whose exit face was crossed is that face's (`floor`) exactly.
#[derive(Clone, Copy, Debug)]
pub struct Located {
    floor: [f32; 3],
    /// The axis of the exit face just crossed (3 before the first).
    exact: usize,
    /// `tn = 0`: the point is the ray origin itself, exact on every axis.
    origin: bool,
    /// `tn` less and plus the rounding [`SLACK`].
    below: f32,
    above: f32,
}

impl Located {
    /// The point at distance `tn`, on the face `floor[exact]` crossed last.
    #[inline(always)]
    pub fn new(tn: f32, floor: [f32; 3], exact: usize) -> Self {
        Located {
            floor,
            exact,
            origin: tn == 0.0,
            below: tn - (SLACK - 1.0) * tn.abs(),
            above: tn + (SLACK - 1.0) * tn.abs(),
        }
    }

    /// At the split plane `sp` on axis `a`, met at distance `t` (not `NaN`) by the ray from
    /// `org` with direction signs `neg`: whether the point lies in the lower child (the near
    /// one for a positive direction, unless the plane is behind the point), and whether the
    /// plane lies within rounding of the point (the walk cannot place it). A plane at or
    /// before `floor[a]` in the direction of travel is behind; one beyond it on the `exact`
    /// axis is ahead; any other plane is behind only when `t` is below `tn` by more than the
    /// rounding. At the origin a plane through it is not behind: the ray leaves it toward
    /// the far side, but touches the near cell at the origin (a hit at `t = 0` there counts),
    /// so the near cell is visited first and its exit is that plane at `t = 0`.
    #[inline(always)]
    pub fn lower(
        &self,
        org: &[f32; 3],
        neg: &[bool; 3],
        a: usize,
        sp: f32,
        t: f32,
    ) -> (bool, bool) {
        let behind = if neg[a] {
            sp >= self.floor[a]
        } else {
            sp <= self.floor[a]
        };
        let (behind, ambiguous) = if self.origin {
            let through = if neg[a] { sp > org[a] } else { sp < org[a] };
            (behind || through, false)
        } else if a == self.exact {
            (behind, false)
        } else {
            (
                behind || t < self.below,
                !behind && t >= self.below && t <= self.above,
            )
        };
        (behind == neg[a], ambiguous)
    }
}

/// The state of one `sequential` or `ropes` walk (see the module doc).
struct Walk<'a, L> {
    w: &'a Tree<'a, L>,
    s: &'a Setup,
    /// Per axis, the coordinate of the last exit face crossed on that axis (initially the
    /// start cell's entry face): every plane at or before it in the direction of travel is behind.
    floor: [f32; 3],
    /// The axis of the exit face just crossed (3 before the first): the located point lies on
    /// that face, so on this axis its coordinate is `floor` exactly and planes beyond it are
    /// ahead, however close their distance.
    exact: usize,
    /// For rays lying in a split plane: the side to take per axis, and the axes met.
    mask: u8,
    seen: u8,
    steps: u32,
    cap: u32,
    /// A plane distance within rounding of the located point was met.
    ambiguous: bool,
}

impl<L: Layout> Walk<'_, L> {
    /// [`Walk::locate`] from the start node.
    #[inline(always)]
    fn locate_start<C: Counter>(
        &mut self,
        tn: f32,
        floor: [f32; 3],
        c: &mut C,
    ) -> (usize, [f32; 3], [f32; 3]) {
        let f = self.w.from;
        let (min, max) = (f.cell.min.to_array(), f.cell.max.to_array());
        self.locate(f.node as usize, min, max, tn, floor, c)
    }

    /// Kaplan's point location (review §3.1) below node `idx` with cell `min..max` of the ray
    /// point at distance `tn`, the point's coordinate on an axis whose exit face was crossed
    /// being that face's coordinate *exactly* (`floor`), not `o + tn·d` rounded: a plane at
    /// or before `floor[a]` in the direction of travel is behind, one beyond it on the axis of
    /// the face just crossed (`exact`) is ahead; any other plane is behind
    /// only when its distance is below `tn` by more than the rounding [`SLACK`], so a cell
    /// that a plane distance rounded onto `tn` would skip (one-ulp-thin cells, planes crossed
    /// at the same rounded distance) is visited. Returns the leaf and its cell.
    #[inline(always)]
    fn locate<C: Counter>(
        &mut self,
        mut idx: usize,
        mut min: [f32; 3],
        mut max: [f32; 3],
        tn: f32,
        floor: [f32; 3],
        c: &mut C,
    ) -> (usize, [f32; 3], [f32; 3]) {
        let s = self.s;
        let nodes = self.w.v.nodes;
        let at = Located::new(tn, floor, self.exact);
        loop {
            let n = nodes[idx];
            if n.is_leaf() {
                return (idx, min, max);
            }
            c.interior();
            c.steps(1);
            c.planes(1);
            self.steps += 1;
            let a = n.axis();
            let sp = n.split();
            let t = (sp - s.org[a]) * s.inv[a];
            let left = if t.is_nan() {
                // The ray lies in the plane: the side chosen by the pass (see `passes`).
                self.seen |= 1 << a;
                self.mask >> a & 1 == 0
            } else {
                let (lower, ambiguous) = at.lower(&s.org, &s.neg, a, sp, t);
                self.ambiguous |= ambiguous;
                lower
            };
            let (l, r) = self.w.l.children(idx, n);
            if left {
                max[a] = sp;
                idx = l;
            } else {
                min[a] = sp;
                idx = r;
            }
        }
    }
}

tb_core::kernel_by_query!(walk: [L: Layout, const M: u8] Stackless<'_, L, M>);
