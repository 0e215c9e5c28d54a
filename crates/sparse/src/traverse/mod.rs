//! The kernels: BTR (Havran and Bittner 2007 §5.2, Alg. 2), SLTR (§5.3, Alg. 3) and our
//! variant of it, `sltr-mask`, over a borrowed kd-tree ([`tb_kdtree::KdView`], depth-first
//! layout) and its augmented nodes.
//!
//! Shared with the kd-tree's stack traversal (`recursive-direction`): the near/far decision at
//! an interior node (`t = (split − o_a)·(1/d_a)`; near only when `t > t_exit·SLACK`, far only
//! when `t·SLACK < t_entry`, both otherwise, so rays through cell edges visit every cell
//! there; a ray lying in a split plane (`t = NaN`) visits both children), triangle tests over
//! `[tmin, closest hit)` (never only a leaf's interval), pending subtrees skipped only when
//! they start beyond the closest hit.
//!
//! **Start nodes.** A start node is used only when the ray's segment begins at its origin
//! (`tmin = 0`) and the origin lies *strictly* inside the start cell on every face that is not
//! a root face (checked per ray; otherwise the root): then the ray is inside the start cell
//! until it leaves it, and every other cell it meets lies at or beyond the start cell's exit
//! (a ray lying in one of its faces, which would meet the neighbour cells along the way, is
//! excluded by strictness). What the origin shifts of Algorithms 2 and 3 do with an epsilon
//! is done by BTR and `sltr-mask` by the *identity* of what is finished, and by SLTR with the
//! shifted point held exactly on the face it crossed, so no epsilon is needed and no cell,
//! however thin, is skipped:
//!
//! - **BTR**: the stack traversal of the start subtree (Alg. 2, inner loop; each stack entry
//!   carries the last augmented node above it, `lastAugmentedNode`). When the stack runs dry
//!   with no hit before the subtree's exit, climb the parent links from `lastAugmentedNode`
//!   (the deepest augmented node on the last leaf's path, Alg. 2's `node =
//!   lastAugmentedNode`; one box test each, `ComputeMaxT`, the root's included) to the first
//!   augmented node whose box extends beyond the finished box's exit (Alg. 2's `TraverseUp`;
//!   none: the ray leaves the root box, and ends) and run the stack traversal of its subtree over its
//!   whole clipped interval with the finished subtree *skipped* by its node index, instead of
//!   from the shifted entry `t_exit + eps`. On the way down toward the finished subtree
//!   (tracked by node index ranges), a node whose near child holds it and ends where the ray
//!   leaves it (`near exit <= finished exit`: the split plane is the finished box's exit face)
//!   goes to its far child only, as the shifted entry would make it; the other nodes on that
//!   path are visited again (and counted).
//! - **SLTR** (`sltr`, the paper's Algorithm 3; the traversal the paper's configs and claims
//!   read): down from the start node to the leaf holding the ray origin (`TraverseDown`:
//!   the child holding the point); after each leaf, `tentry = texit + eps` shifts the point
//!   just past the leaf's exit face, `RestartTraversal` descends again from the last augmented
//!   node passed (`lastAugmentedNode`) when its box still holds the point (`tentry < tup`),
//!   else `TraverseUp` follows parent links, `ComputeMaxT` of each parent's box (one box
//!   test, and one interior node, each), to the first box holding it; none (the point leaves
//!   the root) ends the ray. The epsilon is exact rather than a fixed amount: the point's
//!   coordinate on the crossed face's axis is that face's coordinate and planes at it are
//!   behind (tb-kdtree's `sequential`, Kaplan's point location, made robust the same way), so
//!   no cell thinner than an epsilon is skipped and no point rounds back into the leaf it
//!   left; "the box holds the point" is decided on that coordinate too (the box's far face on
//!   that axis lies beyond it). Each descent is the point location of `sequential` below the
//!   augmented node (other planes behind only by more than the rounding [`SLACK`], the origin
//!   itself at `t = 0`), so SLTR visits `seq`'s leaves, as Table 1 has them (N_L 10.80 and
//!   10.81, r_ITM equal), not HTR's. A ray lying in a split plane (`t = NaN`: a zero
//!   direction component, the origin in the plane) cannot be placed by one point on that
//!   axis: as `sequential` does, the walk takes the plane's lower side and records the axis,
//!   and is repeated for every other combination of sides on the zero-direction axes (the
//!   closest hit kept between the walks, the step count carried), so those rays visit SEQ's
//!   leaves too. A ray through a cell edge or corner within rounding cannot be placed by one
//!   point either, and is handed to `sltr-mask` from the root keeping its closest hit (one
//!   restart, one `handovers`), as `sequential` hands it to kd-restart; on those rays the two
//!   can differ (the share is the `handovers` column). `sltr-handover` is `sltr`'s
//!   earlier reading: a ray lying in a split plane handed over as well. Where the paper is silent:
//!   the start node's `tentry` is the ray's entry into the root box (the origin for a start
//!   node below the root), a climb stops at the root, the step cap is a guard.
//! - **`sltr-mask`** (our variant; the GPU kernel's walk): down to a leaf choosing the first
//!   intersected child (Alg. 3, `TraverseDown`,
//!   the near child when both are), then on to the *next* leaf: the walk keeps, per depth, one
//!   bit telling that the node there sent the ray both ways with the walk in the near child
//!   (the nodes it would come back to) and, as Alg. 3, the last augmented node passed with its
//!   interval (`lastAugmentedNode`, `tup`). The next leaf lies below the far child of the
//!   deepest such node: when that node is below the last augmented node, the walk restarts
//!   there (Alg. 3's `tentry < tup`); otherwise it follows parent links to the augmented node
//!   above it (`TraverseUp`, one box per climb: the node's interval) and restarts there. From
//!   the restart node it descends toward the last leaf (found by node index: in the
//!   depth-first layout a subtree is an index range) to that node and takes its far child:
//!   the nodes Alg. 3 visits on its way down from the restart node to the leaf holding the
//!   shifted origin, without the shift. Intervals are the slab intervals of the cells, with
//!   the root cell's faces standing for the root interval, so a node's decision is the same on
//!   every visit (as in the kd-tree's restart-type walks). A walk from a start node knows the
//!   bits only below it: when none is left there, it climbs to the parent augmented node and
//!   descends from it toward the start node, recording the bits of those levels. Each restart
//!   moves strictly forward in the depth-first order, so a walk ends; the step cap is a guard.
//!
//! Counters: `interior`, `leaves`, `prims`, `planes`, `steps` as the kd-tree's (nodes revisited
//! counted again), and every parent link followed counted in `interior` too ([`parent_link`]: the
//! paper's N_I; `interior - ups` is N_I without the climbs); `boxes`: the start or root cell,
//! every stored box read and (SLTR) every leaf exit computed; `ups`: parent links followed;
//! `restarts`: continuations after a dry stack (BTR) or a leaf (SLTR), and a hand-over to
//! `sltr-mask`, which `handovers` counts alone (0 or 1 a ray).
//!
//! One file per algorithm, each composing the named steps of its walk state, laid out as
//! tb-kdtree's `stackless` walks so they read side by side: `btr` ([`btr`]'s `BtrWalk`:
//! `enter`, `descend`, `leaf`, `pop`, `climb`; beside `recursive-direction` and `backtrack`),
//! `sltr` for `sltr` and `sltr-handover` (`SltrWalk`: `locate`, `leaf`, `leave`, `climb`, the
//! passes by tb-kdtree's [`passes`]; beside `sequential`) and `sltr_mask` (`MaskWalk`:
//! `descend`, `leaf`, `restart`, `climb`, `enter`; beside `restart`).

use crate::{AugNode, SparseBoxes};
use tb_core::slab::{max_num, min_num};
use tb_core::stack::Stack;
use tb_core::{
    Aabb, Answers, Batch, Counter, HitRecord, MollerTrumbore, NoStats, Query, Ray, TraversalStats,
    TriTest, TriTestKind, Vec3, Watertight,
};
use tb_kdtree::stackless::{
    passes, restart_from, restart_loop, Cell, Exit, ExitFaces, RestartSteps,
};
use tb_kdtree::traverse::{capped, leaf, Setup};
use tb_kdtree::NodeRank;
use tb_kdtree::{
    split_decision, Best, Decision, DepthFirst, KdNode, KdView, Kind, Located, SLACK, STACK_SIZE,
};

mod btr;
mod sltr;
mod sltr_mask;

pub(crate) const BTR: u8 = 0;
pub(crate) const SLTR: u8 = 1;
pub(crate) const SLTR_MASK: u8 = 2;
pub(crate) const SLTR_HANDOVER: u8 = 3;
/// HTR in BTR's kernel: its stack traversal from the root, no climb.
pub(crate) const HTR: u8 = 4;
/// SEQ in SLTR's kernel: every point located from the root.
pub(crate) const SEQ: u8 = 5;

/// "Not looked up yet" for a record index.
const NONE: u32 = u32::MAX;

/// Point location of `o` (see [`SparseBoxes::start_node`]): down from the root while `o` is
/// strictly on one side of the split, remembering the last augmented node.
pub(crate) fn locate(v: &KdView, rank: &NodeRank, period: u32, o: Vec3) -> u32 {
    let nodes = v.nodes();
    let b = v.bounds();
    if nodes.is_empty() || (0..3).any(|a| !(o[a] >= b.min[a] && o[a] <= b.max[a])) {
        return 0;
    }
    let (mut idx, mut d, mut last) = (0usize, 0u32, 0usize);
    loop {
        let n = nodes[idx];
        if n.is_leaf() {
            break;
        }
        if d % period == 0 {
            last = idx;
        }
        let (a, s) = (n.axis(), n.split());
        if o[a] < s {
            idx += 1;
        } else if o[a] > s {
            idx = n.link();
        } else {
            break;
        }
        d += 1;
    }
    rank.find(last as u32).unwrap_or(0) as u32
}

/// What a kernel reads.
struct Ctx<'a> {
    /// The kd-tree's view: its leaves are tested by the kd-tree's own leaf loop.
    kd: KdView<'a>,
    nodes: &'a [KdNode],
    aug: &'a [AugNode],
    rank: &'a NodeRank,
    depth: &'a [u8],
    period: u32,
    root: Aabb,
    cap: u32,
}

/// The decision at an interior node: the kd-tree's own rule ([`split_decision`], that of
/// `recursive-direction`), children in the depth-first layout.
#[inline(always)]
fn decide(n: KdNode, idx: usize, s: &Setup, tn: f32, tf: f32) -> Decision {
    split_decision(DepthFirst, n, idx, s, tn, tf)
}

impl<'a> Ctx<'a> {
    fn new(s: &'a SparseBoxes) -> Self {
        let v = s.kd.view();
        Ctx {
            kd: v,
            nodes: v.nodes(),
            aug: &s.aug,
            rank: &s.rank,
            depth: &s.depth,
            period: s.params.period(),
            root: v.bounds(),
            cap: s.params.step_cap,
        }
    }

    /// The start record to use for `ray` with hint `h` (see the module doc): `h` when the
    /// segment begins at the origin and the origin lies strictly inside its cell (root faces
    /// excepted), else 0.
    #[inline(always)]
    fn start(&self, ray: &Ray, h: u32) -> usize {
        if h == 0 || ray.tmin != 0.0 || h as usize >= self.aug.len() {
            return 0;
        }
        let a = &self.aug[h as usize];
        let o = ray.origin.to_array();
        let (rmin, rmax) = (self.root.min.to_array(), self.root.max.to_array());
        for ax in 0..3 {
            let lo = o[ax] > a.min[ax] || (a.min[ax] == rmin[ax] && o[ax] >= a.min[ax]);
            let hi = o[ax] < a.max[ax] || (a.max[ax] == rmax[ax] && o[ax] <= a.max[ax]);
            if !(lo && hi) {
                return 0;
            }
        }
        h as usize
    }

    /// The slab interval of augmented node `a`'s cell with the plane distances of [`decide`]
    /// and the root cell's faces standing for the root interval `[s.t0, s.t1]`: the interval
    /// a descent from the root computes at that node.
    #[inline(always)]
    fn interval(&self, s: &Setup, a: &AugNode) -> (f32, f32) {
        let (mut tn, mut tf) = (s.t0, s.t1);
        let (rmin, rmax) = (self.root.min.to_array(), self.root.max.to_array());
        for ax in 0..3 {
            let (np, fp, rn, rf) = if s.neg[ax] {
                (a.max[ax], a.min[ax], rmax[ax], rmin[ax])
            } else {
                (a.min[ax], a.max[ax], rmin[ax], rmax[ax])
            };
            if np != rn {
                tn = max_num(tn, (np - s.org[ax]) * s.inv[ax]);
            }
            if fp != rf {
                tf = min_num(tf, (fp - s.org[ax]) * s.inv[ax]);
            }
        }
        (tn, tf)
    }

    /// The distance at which the ray leaves box `a` (its far planes, unscaled, and the end of
    /// `s`'s segment).
    #[inline(always)]
    fn exit(&self, s: &Setup, a: &AugNode) -> f32 {
        let mut tf = s.t1;
        for ax in 0..3 {
            let fp = if s.neg[ax] { a.min[ax] } else { a.max[ax] };
            tf = min_num(tf, (fp - s.org[ax]) * s.inv[ax]);
        }
        tf
    }

    /// The record of augmented node `node`: `rec`, or looked up by rank where it is [`NONE`]
    /// (a walk records an augmented node passed on the way down by its node only).
    #[inline(always)]
    fn record(&self, rec: u32, node: usize) -> u32 {
        if rec == NONE {
            self.rank.find(node as u32).expect("augmented node") as u32
        } else {
            rec
        }
    }

    /// The set-up both SLTR walks share: the ray's set-up clipped to the root box (one box
    /// test counted), `None` for an empty tree or a ray missing the root.
    #[inline(always)]
    fn clip_root<C: Counter>(&self, ray: &Ray, c: &mut C) -> Option<Setup> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut s = setup(ray);
        c.boxes(1);
        (s.t0, s.t1) = self
            .root
            .intersect(ray.origin, ray.inv_dir(), ray.tmin, ray.tmax)?;
        Some(s)
    }
}

/// A parent link followed (Alg. 2's and Alg. 3's `TraverseUp`): the walk enters the parent
/// augmented node, one interior node traversed. Counted in `interior` (N_I, as the paper's
/// "number of traversed interior nodes" counts it: Figure 2, "traverses the hierarchy using
/// only the down-links between nodes and parent links between augmented nodes") and in `ups`,
/// so N_I without the climbs is `interior - ups`.
#[inline(always)]
fn parent_link<C: Counter>(c: &mut C) {
    c.up();
    c.interior();
}

/// The ray's set-up as the kd-tree's kernels have it, over the ray's own segment
/// (`t0 = tmin`, `t1 = tmax`): BTR clips the ray to each augmented node's box, SLTR's walks
/// to the root box ([`Ctx::clip_root`]).
#[inline(always)]
fn setup(ray: &Ray) -> Setup {
    let inv = ray.inv_dir().to_array();
    Setup {
        org: ray.origin.to_array(),
        dir: ray.dir.to_array(),
        inv,
        neg: [inv[0] < 0.0, inv[1] < 0.0, inv[2] < 0.0],
        t0: ray.tmin,
        t1: ray.tmax,
    }
}

#[inline(always)]
fn run<T: TriTest, C: Counter, const ALG: u8>(
    cx: &Ctx,
    q: Query,
    ray: &Ray,
    h: u32,
    c: &mut C,
) -> HitRecord {
    match (ALG, q) {
        (BTR, Query::Closest) => cx.btr::<T, C, false, true>(ray, h, c),
        (BTR, Query::Any) => cx.btr::<T, C, true, true>(ray, h, c),
        (HTR, Query::Closest) => cx.btr::<T, C, false, false>(ray, 0, c),
        (HTR, Query::Any) => cx.btr::<T, C, true, false>(ray, 0, c),
        (SLTR, Query::Closest) => cx.sltr::<T, C, false, false, true>(ray, h, c),
        (SLTR, Query::Any) => cx.sltr::<T, C, true, false, true>(ray, h, c),
        (SLTR_HANDOVER, Query::Closest) => cx.sltr::<T, C, false, true, true>(ray, h, c),
        (SLTR_HANDOVER, Query::Any) => cx.sltr::<T, C, true, true, true>(ray, h, c),
        (SEQ, Query::Closest) => cx.sltr::<T, C, false, false, false>(ray, 0, c),
        (SEQ, Query::Any) => cx.sltr::<T, C, true, false, false>(ray, 0, c),
        (_, Query::Closest) => cx.sltr_mask::<T, C, false>(ray, h, c),
        (_, Query::Any) => cx.sltr_mask::<T, C, true>(ray, h, c),
    }
}

/// Trace a batch with kernel `ALG`: start records from the batch's hints, or found per ray
/// here when `start_nodes` (the same point location as the hints), or the root.
pub(crate) fn trace<const ALG: u8>(
    s: &SparseBoxes,
    b: Batch<'_>,
    start_nodes: bool,
    out: Answers<'_>,
) {
    assert_eq!(b.rays.len(), out.hits.len(), "one hit record per ray");
    let own;
    let starts: Option<&[u32]> = match b.hints {
        Some(h) => Some(h),
        None if start_nodes => {
            own = s.start_nodes(b.rays);
            Some(&own)
        }
        None => None,
    };
    match b.tri {
        TriTestKind::Watertight => batch::<Watertight, ALG>(s, b.query, b.rays, starts, out),
        TriTestKind::MollerTrumbore => {
            batch::<MollerTrumbore, ALG>(s, b.query, b.rays, starts, out)
        }
    }
}

fn batch<T: TriTest, const ALG: u8>(
    s: &SparseBoxes,
    q: Query,
    rays: &[Ray],
    starts: Option<&[u32]>,
    out: Answers<'_>,
) {
    let cx = Ctx::new(s);
    let h = |i: usize| starts.map_or(0, |h| h[i]);
    let hits = out.hits;
    match out.stats {
        None => {
            for (i, (r, hit)) in rays.iter().zip(hits.iter_mut()).enumerate() {
                *hit = run::<T, NoStats, ALG>(&cx, q, r, h(i), &mut NoStats);
            }
        }
        Some(st) => {
            assert_eq!(rays.len(), st.len(), "one stats record per ray");
            for (i, ((r, hit), out)) in rays.iter().zip(hits.iter_mut()).zip(st).enumerate() {
                let mut local = TraversalStats::default();
                *hit = run::<T, TraversalStats, ALG>(&cx, q, r, h(i), &mut local);
                *out = local;
            }
        }
    }
}
