//! The traversal kernels (Hapala and Havran 2011, "Review: Kd-tree traversal algorithms for ray
//! tracing", CGF 30(1); sections cited per kernel).
//!
//! Every kernel reads a [`Tree`]: a [`KdView`] of the tree, its layout as a type (so each
//! layout gets its own compiled kernel) and the start of every walk ([`KdStart`]: the root, or
//! a node below it that then plays the root's part). Common to all: the ray is first clipped
//! to the start cell with the robust slab test ([`tb_core::Aabb::intersect`]: zero direction
//! components and origins in face planes handled, exit scaled by `1 + 2·gamma(3)`); a ray
//! missing it is done. Triangle tests accept any `t` in `[tmin, closest so far)`, never only
//! the leaf's interval, and a closest-hit walk skips only pending subtrees that start beyond
//! the closest hit: a hit found in a leaf but beyond the leaf's exit does not end the walk.
//! Each node is visited at most once, so no step cap is needed.

use crate::{KdNode, KdStart, KdView, Layout};
use tb_core::slab::{max_num, min_num};
pub(crate) use tb_core::stack::Stack;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// Entries of the traversal stacks; the depth limit of the builder is at most this.
pub const STACK_SIZE: usize = 64;

/// Relative rounding allowance of plane distances: `t = (split − o)·(1/d)` is within
/// `2·2^-24` of the exact distance relative to `t` (two roundings), so two planes through one
/// point (a vertex at a cell corner) give distances within `4·2^-24·t`; decisions "near only"
/// and "far only" are taken only when the distance clears the interval by this factor, and both
/// children are visited otherwise (the split distance then clamped to the interval).
pub const SLACK: f32 = 1.0 + 8.0 * f32::EPSILON;

/// A pending subtree of the stack walks: node, entry and exit of its interval (distances, or
/// points for `havran`).
type Entry<E> = (u32, E, E);

/// Where a stack walk keeps its pending subtrees: the full stack ([`Stack`]) or
/// `stack-spilling`'s short stack with its memory stack ([`Spilling`]).
trait Pending<E: Copy> {
    /// Keep `e` to visit later.
    fn defer<C: Counter>(&mut self, e: Entry<E>, c: &mut C);

    /// The next pending subtree `keep` accepts, the ones popped before it dropped; `None`
    /// when none is left.
    fn resume<C: Counter>(
        &mut self,
        keep: impl Fn(&Entry<E>) -> bool,
        c: &mut C,
    ) -> Option<Entry<E>>;
}

impl<E: Copy> Pending<E> for Stack<Entry<E>, STACK_SIZE> {
    #[inline(always)]
    fn defer<C: Counter>(&mut self, e: Entry<E>, _: &mut C) {
        self.push(e)
    }

    #[inline(always)]
    fn resume<C: Counter>(
        &mut self,
        keep: impl Fn(&Entry<E>) -> bool,
        _: &mut C,
    ) -> Option<Entry<E>> {
        self.pop_until(keep)
    }
}

/// The walk the stack-based kernels share (review §3.2, Alg. 2; §5.2 for `stack-spilling`):
/// from the start node over the start interval, each interior node counted (one node, one
/// step) and handed to `step`, which counts its planes, returns the next node and pushes the
/// far child where both are visited (narrowing the current interval); each leaf tested; then
/// the next pending subtree popped, those whose entry (`entry_t`) lies beyond the closest hit
/// skipped (any-hit queries skip nothing). A skipped entry does not end the walk: a subtree
/// pushed to be visited over its parent's whole interval may lie below entries that start
/// later. `begin` gives the walk's per-ray data and the start interval's two ends.
#[inline(always)]
fn stack_walk<T, C, L, E, R, P, const ANY: bool>(
    w: &Tree<'_, L>,
    ray: &Ray,
    c: &mut C,
    mut pending: P,
    begin: impl FnOnce(&Setup) -> (R, E, E),
    entry_t: impl Fn(&E) -> f32,
    mut step: impl FnMut(&Setup, &R, usize, KdNode, &mut (E, E), &mut P, &mut C) -> usize,
) -> HitRecord
where
    T: TriTest,
    C: Counter,
    L: Layout,
    E: Copy,
    P: Pending<E>,
{
    let Some((s, pre, mut best)) = start::<T, C, L>(w, ray, c) else {
        return HitRecord::MISS;
    };
    let nodes = w.v.nodes;
    let (r, en, ex) = begin(&s);
    let (mut idx, mut at) = (w.from.node as usize, (en, ex));
    loop {
        // SAFETY: indices are the start node (checked against the node count in
        // `Tree::new`) and children written by the builder (checked by `validate`).
        let n = unsafe { *nodes.get_unchecked(idx) };
        if !n.is_leaf() {
            c.interior();
            c.steps(1);
            idx = step(&s, &r, idx, n, &mut at, &mut pending, c);
            continue;
        }
        if leaf::<T, C, ANY>(&w.v, n, &pre, ray, &mut best, c) {
            return best.record();
        }
        let keep = |e: &Entry<E>| ANY || entry_t(&e.1) <= best.t;
        let Some((i, a, b)) = pending.resume(keep, c) else {
            return best.record();
        };
        (idx, at) = (i as usize, (a, b));
    }
}

/// What a kernel reads: the view, its layout `L` (the kernels are compiled per layout) and the
/// start of every walk.
#[derive(Clone, Copy)]
pub struct Tree<'a, L> {
    pub v: KdView<'a>,
    pub l: L,
    pub from: KdStart,
}

impl<'a, L> Tree<'a, L> {
    /// Panics if `from` is no node of `v` (the kernels index nodes unchecked).
    pub fn new(v: KdView<'a>, l: L, from: KdStart) -> Self {
        assert!(
            v.nodes.is_empty() || (from.node as usize) < v.nodes.len(),
            "kd-tree: start node {} of {} nodes",
            from.node,
            v.nodes.len()
        );
        Tree { v, l, from }
    }
}

/// Per-ray data: origin, direction, reciprocal direction, and the ray's interval in the start
/// cell.
#[derive(Clone, Copy)]
pub struct Setup {
    pub org: [f32; 3],
    pub dir: [f32; 3],
    pub inv: [f32; 3],
    /// `inv[a] < 0` (a negative direction, or −0 giving −inf): the upper child is near.
    pub neg: [bool; 3],
    pub t0: f32,
    pub t1: f32,
}

/// The start of every kernel: count the start cell's test, clip the ray to it (`None`: the ray
/// misses the tree), prepare the triangle test, and no hit yet (closest so far `ray.tmax`).
#[inline(always)]
pub fn start<T: TriTest, C: Counter, L>(
    w: &Tree<'_, L>,
    ray: &Ray,
    c: &mut C,
) -> Option<(Setup, T::Pre, Best)> {
    c.boxes(1);
    let s = setup(w, ray)?;
    Some((s, T::prepare(ray), Best::new(ray.tmax)))
}

#[inline(always)]
fn setup<L>(w: &Tree<'_, L>, ray: &Ray) -> Option<Setup> {
    if w.v.nodes.is_empty() {
        return None;
    }
    let inv = ray.inv_dir();
    let (t0, t1) = w.from.cell.intersect(ray.origin, inv, ray.tmin, ray.tmax)?;
    let inv = inv.to_array();
    Some(Setup {
        org: ray.origin.to_array(),
        dir: ray.dir.to_array(),
        inv,
        neg: [inv[0] < 0.0, inv[1] < 0.0, inv[2] < 0.0],
        t0,
        t1,
    })
}

/// The closest hit so far of one ray: distance, primitive (`u32::MAX`: none yet) and
/// barycentrics; shared with the kernels built on the kd-tree (sparse boxes).
pub struct Best {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

impl Best {
    #[inline(always)]
    pub fn new(tmax: f32) -> Self {
        Best {
            t: tmax,
            prim: u32::MAX,
            u: 0.0,
            v: 0.0,
        }
    }

    #[inline(always)]
    pub fn record(&self) -> HitRecord {
        if self.prim == u32::MAX {
            HitRecord::MISS
        } else {
            HitRecord {
                t: self.t,
                prim: self.prim,
                u: self.u,
                v: self.v,
            }
        }
    }
}

/// Test the triangles of leaf `n` against `[ray.tmin, best.t)`, updating `best`; with `ANY`,
/// returns `true` at the first hit.
#[inline(always)]
pub fn leaf<T: TriTest, C: Counter, const ANY: bool>(
    v: &KdView,
    n: KdNode,
    pre: &T::Pre,
    ray: &Ray,
    best: &mut Best,
    c: &mut C,
) -> bool {
    c.leaf();
    c.steps(1);
    let (o, k) = (n.offset(), n.count() as usize);
    let refs = &v.refs[o..o + k];
    if !ANY {
        c.prims(k as u32);
    }
    for &id in refs {
        if ANY {
            c.prims(1);
        }
        // SAFETY: `KdTree::build` only makes references to existing triangles (checked by
        // `validate`), and a view's triangles are those of its tree.
        let tri = unsafe { v.tris.get_unchecked(id as usize) };
        if let Some((t, u, v)) = T::intersect(pre, ray, tri, best.t) {
            *best = Best { t, prim: id, u, v };
            if ANY {
                return true;
            }
        }
    }
    false
}

/// What to visit at an interior node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    NearOnly,
    FarOnly,
    Both,
}

/// The decision of the direction-classified recursive traversal at interior node `idx` for the
/// interval `[tn, tf]` (see [`RecursiveDirection`]). The children's intervals are always
/// `[tn, min(tf, t)]` and `[max(tn, t), tf]` (a NaN `t` ignored), so the interval of a node is
/// the slab interval of its cell whatever path led there (plane distances computed by the one
/// formula, start-cell faces counting as the start interval): the stackless traversals
/// recompute it from a cell and reproduce exactly these decisions.
#[derive(Clone, Copy, Debug)]
pub struct Decision {
    pub kind: Kind,
    pub near: usize,
    pub far: usize,
    /// End of the near child's interval.
    pub near_tf: f32,
    /// Start of the far child's interval.
    pub far_tn: f32,
}

#[inline(always)]
pub fn decide<L: Layout>(l: L, n: KdNode, idx: usize, s: &Setup, tn: f32, tf: f32) -> Decision {
    split_decision(l, n, idx, &s.org, &s.inv, &s.neg, tn, tf)
}

/// [`Decision`] at interior node `n` (index `idx`, children by layout `l`) for a ray with
/// origin `org`, reciprocal direction `inv` and direction signs `neg` over `[tn, tf]`: the one
/// rule every kd traversal shares, exported so that structures walking a borrowed kd-tree
/// (sparse boxes) take exactly the kd-tree's decisions (their counters then compare ray for
/// ray with `recursive-direction`).
///
/// The near and far children are chosen with `select_unpredictable` (conditional moves), the
/// same machine code in every kernel. Left to itself the compiler chose moves in some kernels
/// and a branch in others (`stack-spilling`): with equal counters, the branch ran coherent
/// rays (predicted: the next node's load issues early) 20-28 % faster and random rays 5-9 %
/// slower, so the time column compared code generation rather than algorithms.
#[inline(always)]
// Over clippy's seven: the interior step's scalars, inlined into every kd kernel: a struct would be one more thing between the compiler and its registers.
#[allow(clippy::too_many_arguments)]
pub fn split_decision<L: Layout>(
    l: L,
    n: KdNode,
    idx: usize,
    org: &[f32; 3],
    inv: &[f32; 3],
    neg: &[bool; 3],
    tn: f32,
    tf: f32,
) -> Decision {
    let a = n.axis();
    let t = (n.split() - org[a]) * inv[a];
    let (left, right) = l.children(idx, n);
    let near = std::hint::select_unpredictable(neg[a], right, left);
    let far = std::hint::select_unpredictable(neg[a], left, right);
    let kind = if t > tf * SLACK {
        Kind::NearOnly
    } else if t * SLACK < tn {
        Kind::FarOnly
    } else {
        Kind::Both
    };
    Decision {
        kind,
        near,
        far,
        near_tf: min_num(tf, t),
        far_tn: max_num(tn, t),
    }
}

/// `recursive-direction` (traversal 0): the stack-based algorithm with near/far children
/// classified by the sign of the ray direction (Keller 1997, Wald 2004; review §3.2, Alg. 2
/// with the direction-based classification). The stack holds the far child with its entry and
/// exit distances. Per interior node: `t = (split − o_a)·(1/d_a)`; `t > t_exit·SLACK`: near
/// child only; `t·SLACK < t_entry`: far child only; otherwise both, near first, so rays
/// through cell edges and corners (up to rounding) visit every cell there ([`SLACK`]).
///
/// Zero direction components (the review's robustness fix, done without an epsilon): `1/±0`
/// is `±inf` with the sign of the zero, which also decides near/far, so `t = ±inf` selects the
/// half-space holding the ray; an origin exactly in the plane gives `t = NaN`, which fails both
/// comparisons, and both children are visited over the whole interval (the NaN is ignored by
/// the interval updates).
pub struct RecursiveDirection<'a, L>(pub Tree<'a, L>);

impl<L: Layout> RecursiveDirection<'_, L> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let stack = Stack::<Entry<f32>, STACK_SIZE>::new();
        by_direction::<T, C, L, _, ANY>(&self.0, ray, c, stack)
    }
}

/// The direction-classified stack walk of [`RecursiveDirection`] with its pending subtrees
/// kept in `pending` (the full stack, or `stack-spilling`'s short stack).
#[inline(always)]
fn by_direction<T, C, L, P, const ANY: bool>(
    w: &Tree<'_, L>,
    ray: &Ray,
    c: &mut C,
    pending: P,
) -> HitRecord
where
    T: TriTest,
    C: Counter,
    L: Layout,
    P: Pending<f32>,
{
    let begin = |s: &Setup| ((), s.t0, s.t1);
    stack_walk::<T, C, L, f32, (), _, ANY>(w, ray, c, pending, begin, |t| *t, {
        |s, _, idx, n, (tn, tf), pending, c| {
            c.planes(1);
            let d = decide(w.l, n, idx, s, *tn, *tf);
            match d.kind {
                Kind::NearOnly => d.near,
                Kind::FarOnly => d.far,
                Kind::Both => {
                    pending.defer((d.far as u32, d.far_tn, *tf), c);
                    *tf = d.near_tf;
                    d.near
                }
            }
        }
    })
}

tb_core::kernel_by_query!(walk: [L: Layout] RecursiveDirection<'_, L>);

/// A point on the ray: its parameter and coordinates.
#[derive(Clone, Copy)]
struct Pt {
    t: f32,
    p: [f32; 3],
}

/// The point at `t`, exact on axes of zero direction, clamped into the start cell `b`.
#[inline(always)]
fn point(b: &tb_core::Aabb, s: &Setup, t: f32) -> [f32; 3] {
    let mut p = [0.0; 3];
    for a in 0..3 {
        let x = if s.dir[a] == 0.0 {
            s.org[a]
        } else {
            s.org[a] + t * s.dir[a]
        };
        p[a] = min_num(max_num(b.min[a], x), b.max[a]);
    }
    p
}

/// `havran` (traversal 1): Havran's robust recursive traversal TA^B_rec (Havran 2000, Appendix
/// C; review §3.2). Entry and exit *points* (coordinates and distance) are kept for the
/// current node and on the stack, and the children to visit are decided by comparing the
/// entry and exit coordinates on the split axis with the split position (cases N1–N5, P1–P5,
/// Z), without division; the distance to the plane is computed only when the ray crosses it
/// (cases N4, P4), and the crossing point gets the split coordinate exactly. Case Z (the ray
/// lies in the split plane) visits both children, so triangles touching the plane from either
/// side are tested. The stored points are rounded (`o + t·d`), so a coordinate within
/// `8·2^-24·(|o_a| + max |start cell|_a)` of the split counts as possibly on either side:
/// an entry and exit both within it is case Z, one of them within it a crossing (near child by
/// the direction's sign); points on axes of zero direction are exactly `o_a`.
pub struct Havran<'a, L>(pub Tree<'a, L>);

impl<L: Layout> Havran<'_, L> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let w = &self.0;
        let b = &w.from.cell;
        let stack = Stack::<Entry<Pt>, STACK_SIZE>::new();
        let begin = |s: &Setup| {
            // Rounding allowance of point coordinates on each axis.
            let err: [f32; 3] = std::array::from_fn(|a| {
                8.0 * f32::EPSILON * (s.org[a].abs() + b.min[a].abs().max(b.max[a].abs()))
            });
            let en = Pt {
                t: s.t0,
                p: point(b, s, s.t0),
            };
            let ex = Pt {
                t: s.t1,
                p: point(b, s, s.t1),
            };
            (err, en, ex)
        };
        stack_walk::<T, C, L, Pt, [f32; 3], _, ANY>(w, ray, c, stack, begin, |p| p.t, {
            |s, err, idx, n, (en, ex), stack, c| {
                let a = n.axis();
                let split = n.split();
                let (left, right) = w.l.children(idx, n);
                let (ea, xa) = (en.p[a], ex.p[a]);
                let (lo, hi) = (split - err[a], split + err[a]);
                // Entry/exit possibly on the left (at most `split` up to rounding), possibly
                // on the right.
                let (el, er) = (ea <= hi, ea >= lo);
                let (xl, xr) = (xa <= hi, xa >= lo);
                // A direction component of 0 gives ea == xa: only the first three cases.
                let (near, far) = if !er && !xr {
                    return left; // N1, N2, N3 (and P5 beyond rounding)
                } else if !el && !xl {
                    return right; // P1, P2, P3 (and N5 beyond rounding)
                } else if el && er && xl && xr {
                    // Z: the ray lies in the plane (up to rounding): both children over the
                    // whole interval.
                    stack.defer((right as u32, *en, *ex), c);
                    return left;
                } else if !s.neg[a] {
                    // N4 (or a crossing within rounding): the ray runs left to right.
                    (left, right)
                } else {
                    (right, left) // P4
                };
                c.planes(1);
                let tp = (split - s.org[a]) * s.inv[a];
                let tp = min_num(max_num(en.t, tp), ex.t);
                let mut p = point(b, s, tp);
                p[a] = split;
                let mid = Pt { t: tp, p };
                stack.defer((far as u32, mid, *ex), c);
                *ex = mid;
                near
            }
        })
    }
}

tb_core::kernel_by_query!(walk: [L: Layout] Havran<'_, L>);

/// `recursive-origin` (traversal 2): the stack-based algorithm with near/far children
/// classified by the side of the split plane holding the ray origin (Jansen 1986, Arvo 1988;
/// review §3.2, Alg. 2 as printed): `t = (split − o_a)/d_a`; `t < 0` or `t > t_exit`: near
/// only; `t < t_entry`: far only; otherwise both. An origin lying in a split plane (`o_a =
/// split`, near = the upper child) gives `t = 0` and may send the ray to the wrong child: the
/// algorithm is inherently not robust there (Havran et al. 1997), and kept as published.
pub struct RecursiveOrigin<'a, L>(pub Tree<'a, L>);

impl<L: Layout> RecursiveOrigin<'_, L> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let w = &self.0;
        let stack = Stack::<Entry<f32>, STACK_SIZE>::new();
        let begin = |s: &Setup| ((), s.t0, s.t1);
        stack_walk::<T, C, L, f32, (), _, ANY>(w, ray, c, stack, begin, |t| *t, {
            |s, _, idx, n, (tn, tf), stack, c| {
                c.planes(1);
                let a = n.axis();
                let split = n.split();
                let t = (split - s.org[a]) * s.inv[a];
                let (left, right) = w.l.children(idx, n);
                let (near, far) = if s.org[a] < split {
                    (left, right)
                } else {
                    (right, left)
                };
                if t < 0.0 || t > *tf * SLACK {
                    near
                } else if t * SLACK < *tn {
                    far
                } else {
                    // Clamped into the interval; a NaN `t` (origin in the plane, direction
                    // 0 on this axis) leaves both children the whole interval.
                    stack.defer((far as u32, max_num(*tn, t).min(*tf), *tf), c);
                    *tf = min_num(*tf, t).max(*tn);
                    near
                }
            }
        })
    }
}

tb_core::kernel_by_query!(walk: [L: Layout] RecursiveOrigin<'_, L>);

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

/// `stack-spilling` (traversal 10): `recursive-direction` with a short circular stack of
/// [`crate::KdParams::short_stack`] entries whose oldest entry, on overflow, is *spilled* to a
/// full stack in memory instead of being discarded; on underflow the full stack is popped
/// before the walk ends, so no restart is ever needed (Novák 2009; Hapala and Havran 2011
/// §5.2, Figure 8, Table 3 "stack spilling"). Visits exactly the nodes of
/// `recursive-direction`; `boxes` counts 1 plus one per entry spilled or refilled (the
/// traffic to the memory stack). Extra memory: the short stack and a full stack per ray.
pub struct StackSpilling<'a, L>(pub Tree<'a, L>);

/// `stack-spilling`'s pending subtrees: a circular short stack of `size` entries whose oldest
/// entry is spilled to the memory stack on overflow, the memory stack popped when the short
/// one runs empty; `boxes` counts each entry spilled or refilled.
struct Spilling {
    short: [Entry<f32>; crate::MAX_SHORT_STACK],
    size: usize,
    /// `count` entries, the newest at `top - 1` (mod `size`).
    top: usize,
    count: usize,
    spill: Stack<Entry<f32>, STACK_SIZE>,
}

impl Pending<f32> for Spilling {
    #[inline(always)]
    fn defer<C: Counter>(&mut self, e: Entry<f32>, c: &mut C) {
        let size = self.size;
        if self.count == size {
            // Overflow: spill the oldest entry.
            let oldest = (self.top + size - self.count) % size;
            self.spill.push(self.short[oldest]);
            self.count -= 1;
            c.boxes(1);
        }
        self.short[self.top] = e;
        self.top = if self.top + 1 == size {
            0
        } else {
            self.top + 1
        };
        self.count += 1;
    }

    #[inline(always)]
    fn resume<C: Counter>(
        &mut self,
        keep: impl Fn(&Entry<f32>) -> bool,
        c: &mut C,
    ) -> Option<Entry<f32>> {
        loop {
            let e = if self.count > 0 {
                self.top = if self.top == 0 {
                    self.size - 1
                } else {
                    self.top - 1
                };
                self.count -= 1;
                self.short[self.top]
            } else {
                // Underflow: refill from the memory stack.
                let e = self.spill.pop()?;
                c.boxes(1);
                e
            };
            if keep(&e) {
                return Some(e);
            }
        }
    }
}

impl<L: Layout> StackSpilling<'_, L> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let w = &self.0;
        let pending = Spilling {
            short: [(0, 0.0, 0.0); crate::MAX_SHORT_STACK],
            size: w.v.short_stack as usize,
            top: 0,
            count: 0,
            spill: Stack::new(),
        };
        by_direction::<T, C, L, _, ANY>(w, ray, c, pending)
    }
}

tb_core::kernel_by_query!(walk: [L: Layout] StackSpilling<'_, L>);
