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
//!
//! One file per stack walk (`recursive_direction`, `havran`, `recursive_origin`,
//! `branchless`, `stack_spilling`); this module holds what they share: [`Tree`], [`start`],
//! [`Best`], [`leaf`] and [`capped`], the node decision ([`decide`]) and the stack walk itself.

use crate::{KdNode, KdStart, KdView, Layout};
pub use tb_core::leaves::Best;
use tb_core::slab::{max_num, min_num};
pub(crate) use tb_core::stack::Stack;
use tb_core::{Counter, HitRecord, Ray, TriTest};

mod branchless;
mod havran;
mod recursive_direction;
mod recursive_origin;
mod stack_spilling;

pub use branchless::Branchless;
pub use havran::Havran;
pub use recursive_direction::RecursiveDirection;
pub use recursive_origin::RecursiveOrigin;
pub use stack_spilling::StackSpilling;

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
    /// The tree's nodes, references, triangles and walk parameters.
    pub v: KdView<'a>,
    /// The node layout, giving the children of a node.
    pub l: L,
    /// Where every walk begins: the start node and its cell.
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
    /// The ray's origin.
    pub org: [f32; 3],
    /// The ray's direction.
    pub dir: [f32; 3],
    /// Per axis `1 / dir`: plane distances are `(split − org)·inv`.
    pub inv: [f32; 3],
    /// `inv[a] < 0` (a negative direction, or −0 giving −inf): the upper child is near.
    pub neg: [bool; 3],
    /// Entry distance of the ray's interval in the start cell.
    pub t0: f32,
    /// Exit distance of the ray's interval in the start cell.
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

/// Whether a walk of `steps` steps has reached the step cap `cap`: then the ray is counted as
/// capped and its walk ends (the stackless walks' guard against an endless loop).
#[inline(always)]
pub fn capped<C: Counter>(steps: u32, cap: u32, c: &mut C) -> bool {
    let done = steps >= cap;
    if done {
        c.capped();
    }
    done
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
            best.hit(t, id, u, v);
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
    /// The split lies beyond the interval's exit: only the near child.
    NearOnly,
    /// The split lies before the interval's entry: only the far child.
    FarOnly,
    /// The interval crosses the split: the near child, then the far one.
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
    /// Which children the ray visits.
    pub kind: Kind,
    /// Index of the child the ray crosses first (by its direction's sign on the split axis).
    pub near: usize,
    /// Index of the other child, entered after the near one.
    pub far: usize,
    /// End of the near child's interval.
    pub near_tf: f32,
    /// Start of the far child's interval.
    pub far_tn: f32,
}

/// [`split_decision`] for the ray of `s` at interior node `n` (index `idx`) over `[tn, tf]`.
#[inline(always)]
pub fn decide<L: Layout>(l: L, n: KdNode, idx: usize, s: &Setup, tn: f32, tf: f32) -> Decision {
    split_decision(l, n, idx, s, tn, tf)
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
pub fn split_decision<L: Layout>(
    l: L,
    n: KdNode,
    idx: usize,
    s: &Setup,
    tn: f32,
    tf: f32,
) -> Decision {
    let (org, inv, neg) = (&s.org, &s.inv, &s.neg);
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
