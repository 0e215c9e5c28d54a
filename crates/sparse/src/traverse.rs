//! The kernels: BTR (Havran and Bittner 2007 §5.2, Alg. 2) and SLTR (§5.3, Alg. 3) over a
//! borrowed kd-tree ([`tb_kdtree::KdView`], depth-first layout) and its augmented nodes.
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
//! is done here by the *identity* of what is finished, so no epsilon is needed and no cell,
//! however thin, is skipped:
//!
//! - **BTR**: the stack traversal of the start subtree (Alg. 2, inner loop). When the stack
//!   runs dry with no hit before the subtree's exit, climb the parent links (one box test
//!   each, `ComputeMaxT`) to the first augmented node whose box extends beyond the finished
//!   box's exit (Alg. 2's `TraverseUp`) and run the stack traversal of its subtree over its
//!   whole clipped interval with the finished subtree *skipped* by its node index, instead of
//!   from the shifted entry `t_exit + eps`. On the way down toward the finished subtree
//!   (tracked by node index ranges), a node whose near child holds it and ends where the ray
//!   leaves it (`near exit <= finished exit`: the split plane is the finished box's exit face)
//!   goes to its far child only, as the shifted entry would make it; the other nodes on that
//!   path are visited again (and counted). The root ends the walk.
//! - **SLTR**: down to a leaf choosing the first intersected child (Alg. 3, `TraverseDown`,
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
//! counted again); `boxes`: the start or root cell and every stored box read; `ups`: parent
//! links followed; `restarts`: continuations after a dry stack (BTR) or a leaf (SLTR).

use crate::{AugNode, SparseBoxes};
use tb_core::slab::{max_num, min_num};
use tb_core::{
    Aabb, Counter, HitRecord, MollerTrumbore, NoStats, Query, Ray, TraversalStats, TriTest,
    TriTestKind, Vec3, Watertight,
};
use tb_kdtree::traverse::leaf;
use tb_kdtree::NodeRank;
use tb_kdtree::{
    split_decision, Best, Decision, DepthFirst, KdNode, KdView, Kind, SLACK, STACK_SIZE,
};

pub(crate) const BTR: u8 = 0;
pub(crate) const SLTR: u8 = 1;

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

/// Per-ray data.
struct Setup {
    org: [f32; 3],
    inv: [f32; 3],
    neg: [bool; 3],
}

/// The decision at an interior node: the kd-tree's own rule ([`split_decision`], that of
/// `recursive-direction`), children in the depth-first layout.
#[inline(always)]
fn decide(n: KdNode, idx: usize, s: &Setup, tn: f32, tf: f32) -> Decision {
    split_decision(DepthFirst, n, idx, &s.org, &s.inv, &s.neg, tn, tf)
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
    /// and the root cell's faces standing for the root interval `[r0, r1]`: the interval a
    /// descent from the root computes at that node.
    #[inline(always)]
    fn interval(&self, s: &Setup, r0: f32, r1: f32, a: &AugNode) -> (f32, f32) {
        let (mut tn, mut tf) = (r0, r1);
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

    /// The distance at which the ray leaves box `a` (its far planes, unscaled, and `tmax`).
    #[inline(always)]
    fn exit(&self, s: &Setup, tmax: f32, a: &AugNode) -> f32 {
        let mut tf = tmax;
        for ax in 0..3 {
            let fp = if s.neg[ax] { a.min[ax] } else { a.max[ax] };
            tf = min_num(tf, (fp - s.org[ax]) * s.inv[ax]);
        }
        tf
    }

    /// BTR (Alg. 2) from record `hint` (see the module doc).
    #[inline(always)]
    fn btr<T: TriTest, C: Counter, const ANY: bool>(
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
        let mut stack = [(0u32, 0f32, 0f32); STACK_SIZE];
        loop {
            let a = &self.aug[sa];
            c.boxes(1);
            if let Some((t0, t1)) = a.cell().intersect(ray.origin, inv, ray.tmin, ray.tmax) {
                let mut sp = 0usize;
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
                                    stack[sp] =
                                        ((far_path as u32) << 31 | d.far as u32, d.far_tn, tf);
                                    sp += 1;
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
                    let mut next = None;
                    while sp > 0 {
                        sp -= 1;
                        let e = stack[sp];
                        if ANY || e.1 <= best.t {
                            next = Some(e);
                            break;
                        }
                    }
                    let Some((i, x, y)) = next else { break };
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
            c.up();
            while p != 0 {
                c.boxes(1);
                if self.exit(&s, ray.tmax, &self.aug[p]) > exit {
                    break;
                }
                p = self.aug[p].parent as usize;
                c.up();
            }
            done = a.node;
            done_exit = exit;
            sa = p;
        }
    }

    /// SLTR (Alg. 3) from record `hint` (see the module doc).
    #[inline(always)]
    fn sltr<T: TriTest, C: Counter, const ANY: bool>(
        &self,
        ray: &Ray,
        hint: u32,
        c: &mut C,
    ) -> HitRecord {
        if self.nodes.is_empty() {
            return HitRecord::MISS;
        }
        let s = setup(ray);
        c.boxes(1);
        let Some((r0, r1)) = self
            .root
            .intersect(ray.origin, ray.inv_dir(), ray.tmin, ray.tmax)
        else {
            return HitRecord::MISS;
        };
        let pre = T::prepare(ray);
        let mut best = Best::new(ray.tmax);
        let (nodes, aug, p) = (self.nodes, self.aug, self.period);
        let st = self.start(ray, hint);
        // The record whose subtree the walk knows: the bits are valid at depths >= `dtop`.
        let mut top = st;
        let mut dtop = self.depth[st] as u32;
        let (sn, sf) = if st == 0 {
            (r0, r1)
        } else {
            c.boxes(1);
            self.interval(&s, r0, r1, &aug[st])
        };
        // The last augmented node passed: node, record (NONE: not looked up), depth, interval.
        let mut last = (aug[st].node as usize, st as u32, dtop, sn, sf);
        let (mut idx, mut tn, mut tf, mut depth) = (aug[st].node as usize, sn, sf, dtop);
        // `depth % p`, kept by the descent (a division per step was the walk's costliest
        // instruction: 20 % slower than SEQ on Sponza before; one per restart remains).
        let mut phase = depth % p;
        // Bit `k`: the node at depth `k` on the way to the current leaf sent the ray both ways
        // and the walk is in its near child.
        let mut both = 0u64;
        // The ray lies in a split plane it met (children's intervals overlap).
        let mut in_plane = false;
        let mut steps = 0u32;
        loop {
            // TraverseDown to a leaf.
            loop {
                let n = nodes[idx];
                if n.is_leaf() {
                    break;
                }
                if phase == 0 && idx != last.0 {
                    last = (idx, NONE, depth, tn, tf);
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
                        in_plane |= d.far_tn < d.near_tf;
                        both |= 1 << depth;
                        idx = d.near;
                        tf = d.near_tf;
                    }
                }
                depth += 1;
                phase += 1;
                if phase == p {
                    phase = 0;
                }
            }
            steps += 1;
            if leaf::<T, C, ANY>(&self.kd, nodes[idx], &pre, ray, &mut best, c) {
                return best.record();
            }
            // A hit before the leaf's exit: every cell still to visit starts at or beyond it
            // (not for a ray lying in a split plane, whose both children span the interval).
            if best.t < tf && !in_plane {
                return best.record();
            }
            if steps >= self.cap {
                c.capped();
                return best.record();
            }
            let lf = idx;
            c.restart();
            // RestartTraversal: the far child of the deepest node still to come back to.
            let (next, at) = loop {
                let live = if dtop >= 64 { 0 } else { both >> dtop << dtop };
                if live != 0 {
                    let k = 63 - live.leading_zeros();
                    both &= (1u64 << k) - 1;
                    let dr = k / p * p;
                    if dr != last.2 {
                        // TraverseUp from the last augmented node to the one above depth `k`.
                        let mut rec = if last.1 == NONE {
                            self.rank.find(last.0 as u32).expect("augmented node") as u32
                        } else {
                            last.1
                        };
                        let mut dd = last.2;
                        while dd > dr {
                            rec = aug[rec as usize].parent;
                            dd -= p;
                            c.up();
                        }
                        c.boxes(1);
                        let r = &aug[rec as usize];
                        let (an, af) = self.interval(&s, r0, r1, r);
                        last = (r.node as usize, rec, dr, an, af);
                    }
                    // Down toward the last leaf to depth `k`.
                    let (mut x, mut xn, mut xf, mut xd) = (last.0, last.3, last.4, last.2);
                    let found = loop {
                        let n = nodes[x];
                        c.interior();
                        c.steps(1);
                        c.planes(1);
                        steps += 1;
                        let d = decide(n, x, &s, xn, xf);
                        let toward = if lf < n.link() { x + 1 } else { n.link() };
                        if xd == k {
                            break (d.kind == Kind::Both && toward == d.near)
                                .then_some((d.far, d.far_tn, xf));
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
                    };
                    match found {
                        Some(f) if ANY || f.1 <= best.t => break (f, k + 1),
                        _ => continue,
                    }
                }
                if top == 0 {
                    return best.record();
                }
                // TraverseUp above the known part: the parent augmented node, then down from
                // it toward the last leaf to the known depth, recording the bits.
                let pr = aug[top].parent as usize;
                c.up();
                c.boxes(1);
                let dp = dtop - p;
                let (pn, pf) = self.interval(&s, r0, r1, &aug[pr]);
                let (mut x, mut xn, mut xf, mut xd) = (aug[pr].node as usize, pn, pf, dp);
                let mut cand = None;
                while xd < dtop {
                    let n = nodes[x];
                    c.interior();
                    c.steps(1);
                    c.planes(1);
                    steps += 1;
                    let d = decide(n, x, &s, xn, xf);
                    let toward = if lf < n.link() { x + 1 } else { n.link() };
                    if d.kind == Kind::Both {
                        in_plane |= d.far_tn < d.near_tf;
                        if toward == d.near {
                            both |= 1 << xd;
                            cand = Some((d.far, d.far_tn, xf, xd));
                            xf = d.near_tf;
                        } else {
                            xn = d.far_tn;
                        }
                    }
                    x = toward;
                    xd += 1;
                }
                top = pr;
                dtop = dp;
                last = (aug[pr].node as usize, pr as u32, dp, pn, pf);
                if let Some((f, fa, fb, k)) = cand {
                    if ANY || fa <= best.t {
                        both &= (1u64 << k) - 1;
                        break ((f, fa, fb), k + 1);
                    }
                }
            };
            (idx, tn, tf) = next;
            depth = at;
            phase = depth % p;
        }
    }
}

#[inline(always)]
fn setup(ray: &Ray) -> Setup {
    let inv = ray.inv_dir().to_array();
    Setup {
        org: ray.origin.to_array(),
        inv,
        neg: [inv[0] < 0.0, inv[1] < 0.0, inv[2] < 0.0],
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
        (BTR, Query::Closest) => cx.btr::<T, C, false>(ray, h, c),
        (BTR, Query::Any) => cx.btr::<T, C, true>(ray, h, c),
        (_, Query::Closest) => cx.sltr::<T, C, false>(ray, h, c),
        (_, Query::Any) => cx.sltr::<T, C, true>(ray, h, c),
    }
}

/// Trace a batch with kernel `ALG`: start records from `hints`, or found per ray here when
/// `start_nodes` (the same point location as the hints), or the root.
pub(crate) fn trace<const ALG: u8>(
    s: &SparseBoxes,
    q: Query,
    tri: TriTestKind,
    rays: &[Ray],
    hints: Option<&[u32]>,
    start_nodes: bool,
    hits: &mut [HitRecord],
    stats: Option<&mut [TraversalStats]>,
) {
    assert_eq!(rays.len(), hits.len(), "one hit record per ray");
    let own;
    let starts: Option<&[u32]> = match hints {
        Some(h) => Some(h),
        None if start_nodes => {
            own = s.start_nodes(rays);
            Some(&own)
        }
        None => None,
    };
    match tri {
        TriTestKind::Watertight => batch::<Watertight, ALG>(s, q, rays, starts, hits, stats),
        TriTestKind::MollerTrumbore => {
            batch::<MollerTrumbore, ALG>(s, q, rays, starts, hits, stats)
        }
    }
}

fn batch<T: TriTest, const ALG: u8>(
    s: &SparseBoxes,
    q: Query,
    rays: &[Ray],
    starts: Option<&[u32]>,
    hits: &mut [HitRecord],
    stats: Option<&mut [TraversalStats]>,
) {
    let cx = Ctx::new(s);
    let h = |i: usize| starts.map_or(0, |h| h[i]);
    match stats {
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
