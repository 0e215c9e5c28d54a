//! The restart-type traversals (Hapala and Havran 2011 §3.1, §3.3, §5.1, §5.2): `restart`,
//! `push-down`, `short-stack`, `backtrack`, `sequential` and `ropes`.
//!
//! Robustness (review §3.1 and §8): no epsilon step along the ray. `restart`, `push-down`,
//! `short-stack` and `backtrack` visit exactly the leaves of `recursive-direction`, in the same
//! order, with the same decisions ([`decide`](crate::traverse::decide): rounding slack at cell edges and corners, both
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
//! [`decide`](crate::traverse::decide)), so `backtrack` recomputes it from the cell stored with the parent links. Every
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
//! coordinate exactly (`PointWalk`'s floor: planes at or before it are behind, compared
//! as coordinates), and every other plane is behind only when its distance is below `t` by more
//! than the rounding [`SLACK`](crate::SLACK). Each step crosses one exit face strictly beyond the last on
//! its axis, so a walk ends. The point at `t = 0` is the ray origin itself, exact on every
//! axis (review §3.1's ray origin in a splitting plane, e.g. a camera eye at `z = 0`): there
//! planes are compared with the origin's coordinates, and a plane through the origin puts the
//! origin in the near cell (which the ray touches there: a hit at `t = 0` counts), whose exit
//! is that plane at `t = 0`; the next point location finds the plane at the floor, so the ray
//! leaves it to the side its direction points to, without the fallback. Where a single point
//! cannot decide (a plane distance within [`SLACK`](crate::SLACK) of a located point other than the origin,
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

//!
//! One file per algorithm, each composing the named steps of a shared walk state:
//! `restarts` for `restart` (`restart`), `push-down` (`push_down`), `short-stack`
//! (`short_stack`) and `backtrack` (`backtrack`); `locate` for `sequential`
//! (`sequential`) and `ropes` (`ropes`).

mod backtrack;
mod locate;
mod push_down;
mod restart;
mod restarts;
mod ropes;
mod sequential;
mod short_stack;

pub use locate::{passes, Cell, Exit, ExitFaces, Located};
pub use restart::{restart_loop, RestartSteps};

use crate::traverse::{start, Setup, Tree};
use crate::view::{Aux, BackNode};
use crate::Layout;
use tb_core::slab::{max_num, min_num};
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// kd-restart (review §5.1) from `w`'s start node over `s`, keeping the closest hit `best` and
/// the `steps` already taken: the walk `sequential` hands a ray to when rounding cannot place
/// its point, and sparse boxes' SEQ hands it to the same way.
#[inline(always)]
pub fn restart_from<T: TriTest, C: Counter, L: Layout, const ANY: bool>(
    w: &Tree<'_, L>,
    s: &Setup,
    ray: &Ray,
    pre: &T::Pre,
    best: crate::Best,
    steps: u32,
    c: &mut C,
) -> HitRecord {
    restart::walk::<T, C, L, ANY, RESTART>(w, s, ray, pre, best, steps, c)
}

/// The default per-ray step cap ([`crate::KdParams::step_cap`]): steps (nodes visited,
/// backtracking steps included) after which a restart-type walk ends a ray.
pub const STEP_CAP: u32 = 100_000;

/// Largest short stack of the `short-stack` traversal.
pub const MAX_SHORT_STACK: usize = 32;

/// The interval of the node with cell `b`: the slab interval with the plane distances of
/// [`decide`](crate::traverse::decide), the faces of the start cell `r` counting as the start interval `[t0, t1]`.
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

/// The depth, `both` and `path` bits (see [`restarts::Restarts`]) of the far child of a node
/// on the way to the last leaf: `at` is that node's depth `<< 1 |` 1 for the right child;
/// bits from the node's depth on are cleared (it no longer sends the walk both ways ahead).
#[inline(always)]
fn below(both: u64, path: u64, at: u32) -> (u32, u64, u64) {
    let pd = at >> 1;
    let keep = (1u64 << pd) - 1;
    (pd + 1, both & keep, path & keep | ((at & 1) as u64) << pd)
}

/// The walks of [`StacklessKernel`]: its const parameter.
/// `restart`.
pub const RESTART: u8 = 0;
/// `push-down`.
pub const PUSH_DOWN: u8 = 1;
/// `short-stack`.
pub const SHORT_STACK: u8 = 2;
/// `sequential`.
pub const SEQUENTIAL: u8 = 3;
/// `backtrack`.
pub const BACKTRACK: u8 = 4;
/// `ropes`.
pub const ROPES: u8 = 5;

/// The restart-type kernels, one struct with the walk chosen by the const parameter `M`
/// (each walk in its file: `restart`, `push_down`, `short_stack`, `backtrack`,
/// `sequential`, `ropes`); the auxiliary arrays it reads (`backtrack`: cells and parents;
/// `ropes`: those and the ropes) are given with it, empty for the others.
///
/// Counters: `interior`, `leaves`, `planes` as the stack traversals, nodes revisited by a
/// restart or climbed by `backtrack` included; `restarts`: restarts (from the root or the
/// pushed-down node, or `backtrack` climbs; short-stack pops are not restarts; `sequential`
/// and `ropes` count a hand-over to `restart` as one restart and in `handovers`); `boxes`: 1
/// for the root plus one per cell interval or exit computed (`sequential`, `backtrack`,
/// `ropes`); `steps`:
/// nodes visited, `interior + leaves`.
pub struct StacklessKernel<'a, L, const M: u8>(pub Tree<'a, L>, pub Aux<'a>);

impl<L: Layout, const M: u8> StacklessKernel<'_, L, M> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let w = &self.0;
        match M {
            SEQUENTIAL => return sequential::walk::<T, C, L, ANY>(w, ray, c),
            ROPES => {
                let ropes = self
                    .1
                    .ropes
                    .expect("the ropes kernel is given the ropes array");
                return ropes::walk::<T, C, L, ANY>(w, ropes, ray, c);
            }
            _ => {}
        }
        let Some((s, pre, best)) = start::<T, C, L>(w, ray, c) else {
            return HitRecord::MISS;
        };
        match M {
            PUSH_DOWN => push_down::walk::<T, C, L, ANY>(w, &s, ray, &pre, best, c),
            SHORT_STACK => short_stack::walk::<T, C, L, ANY>(w, &s, ray, &pre, best, c),
            BACKTRACK => backtrack::walk::<T, C, L, ANY>(w, self.1.back, &s, ray, &pre, best, c),
            _ => restart::walk::<T, C, L, ANY, RESTART>(w, &s, ray, &pre, best, 0, c),
        }
    }
}

tb_core::kernel_by_query!(walk: [L: Layout, const M: u8] StacklessKernel<'_, L, M>);
