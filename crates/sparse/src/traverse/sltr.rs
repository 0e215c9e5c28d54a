//! SLTR (Havran and Bittner 2007 §5.3, Alg. 3) and its variant `sltr-handover`: the
//! sequential walk from leaf to leaf by point location from the last augmented node (the
//! module doc of `traverse` gives the whole rule). Laid out as tb-kdtree's `sequential`: the
//! passes of a ray (tb-kdtree's [`passes`]), one pass ([`crawl`]) composing the named steps of
//! the walk state [`SltrWalk`]: [`SltrWalk::locate`] a leaf from the last augmented node,
//! [`SltrWalk::leaf`], [`SltrWalk::leave`] through the exit face, [`SltrWalk::climb`] the
//! parent links (`TraverseUp`) to a box holding the shifted point. A point that cannot be
//! placed hands the ray to `sltr-mask` ([`super::sltr_mask`]).

use super::sltr_mask::MaskWalk;
use super::*;

impl Ctx<'_> {
    /// SLTR as the paper's Algorithm 3 from record `hint` (see the module doc): point
    /// location of the shifted origin from the last augmented node, climbing parent links
    /// (`ComputeMaxT`, one box each) while the point lies beyond a node's box. A ray lying in
    /// a split plane is walked once per side of it as `seq` walks it (`HAND == false`, `sltr`),
    /// or handed to `sltr-mask` (`HAND == true`, `sltr-handover`); a point the rounding cannot
    /// place is handed to `sltr-mask` in both. Without `AUG`, SEQ (Kaplan's sequential
    /// traversal) in the same kernel: no augmented node but the root is recorded, so every
    /// point is located from the root, and no start node is used.
    #[inline(always)]
    pub(super) fn sltr<
        T: TriTest,
        C: Counter,
        const ANY: bool,
        const HAND: bool,
        const AUG: bool,
    >(
        &self,
        ray: &Ray,
        hint: u32,
        c: &mut C,
    ) -> HitRecord {
        let Some(s) = self.clip_root(ray, c) else {
            return HitRecord::MISS;
        };
        let pre = T::prepare(ray);
        let mut best = Best::new(ray.tmax);
        let st = if AUG { self.start(ray, hint) } else { 0 };
        if st != 0 {
            // ComputeMinMaxT(ray, startNode).
            c.boxes(1);
        }
        // The walk per side of the split planes the ray lies in, as tb-kdtree's `sequential`,
        // the steps carried between the walks for the cap.
        let (mut steps, mut handover) = (0u32, false);
        passes(&s, |mask| {
            let mut w = SltrWalk::new(self, &s, st, mask, steps);
            let done = crawl::<T, C, ANY, HAND, AUG>(&mut w, ray, &pre, &mut best, c);
            steps = w.steps;
            handover = done.is_none();
            (done.unwrap_or(true), w.seen)
        });
        if !handover {
            return best.record();
        }
        // A point the rounding cannot place (or, `HAND`, a ray lying in a split plane): the
        // ray goes to `sltr-mask` from the root, keeping its closest hit (as SEQ hands the
        // former to kd-restart).
        c.restart();
        c.handover();
        if !AUG {
            // SEQ hands it to kd-restart, as the kd-tree's `sequential` does.
            let w = tb_kdtree::traverse::Tree::new(self.kd, DepthFirst, self.kd.root());
            return restart_from::<T, C, DepthFirst, ANY>(&w, &s, ray, &pre, best, steps, c);
        }
        let k = MaskWalk::new(self, &s, 0, steps, c);
        restart_loop::<_, T, C, ANY>(k, ray, &pre, best, c)
    }
}

/// One walk of SLTR (Algorithm 3) from the walk's start record: `Some(true)` when the ray is
/// done (an any-hit found, the step cap reached), `Some(false)` when it left the root or hit
/// before a leaf's exit, `None` where a point could not be placed.
#[inline(always)]
fn crawl<T: TriTest, C: Counter, const ANY: bool, const HAND: bool, const AUG: bool>(
    w: &mut SltrWalk,
    ray: &Ray,
    pre: &T::Pre,
    best: &mut Best,
    c: &mut C,
) -> Option<bool> {
    let (mut idx, mut min, mut max) = w.locate::<C, HAND, AUG>(c);
    loop {
        if w.ambiguous {
            return None;
        }
        if w.leaf::<T, C, ANY>(idx, pre, ray, best, c) {
            return Some(true);
        }
        let face = match w.leave(&min, &max, best, c) {
            Exit::Done => return Some(false),
            Exit::Ambiguous => return None,
            Exit::Face(face, _) => face,
        };
        c.restart();
        w.climb(face, c);
        (idx, min, max) = w.locate::<C, HAND, AUG>(c);
    }
}

/// SLTR's `lastAugmentedNode`: its record ([`NONE`]: not looked up yet), node, depth and cell.
struct Last {
    rec: u32,
    node: usize,
    depth: u32,
    min: [f32; 3],
    max: [f32; 3],
}

impl Last {
    /// The augmented node of record `rec`.
    #[inline(always)]
    fn of(cx: &Ctx, rec: u32) -> Self {
        let a = &cx.aug[rec as usize];
        Last {
            rec,
            node: a.node as usize,
            depth: cx.depth[rec as usize] as u32,
            min: a.min,
            max: a.max,
        }
    }
}

/// One walk of SLTR: the point it locates (Alg. 3's shifted origin, `tentry`) and the last
/// augmented node passed.
struct SltrWalk<'c, 'a> {
    cx: &'c Ctx<'a>,
    s: &'c Setup,
    /// Per axis, the coordinate of the last exit face crossed on that axis (first the root's
    /// entry face): planes at or before it in the direction of travel are behind the point.
    floor: [f32; 3],
    /// The axis of the face just crossed (3 before the first): there the point's coordinate
    /// is `floor` exactly.
    exact: usize,
    /// The point's distance along the ray.
    tn: f32,
    /// Per axis, the side of a split plane holding the ray this walk takes (bit set: the upper
    /// one), as tb-kdtree's `sequential` walks such a ray once per side; and the axes where
    /// such a plane was met.
    mask: u8,
    seen: u8,
    /// Steps taken (the cap's count).
    steps: u32,
    /// A plane the point cannot be placed against was met.
    ambiguous: bool,
    /// `lastAugmentedNode`.
    last: Last,
}

impl<'c, 'a> SltrWalk<'c, 'a> {
    /// A walk over `s`'s root interval from record `st`, split planes holding the ray taken to
    /// the side `mask` gives per axis, `steps` steps already taken.
    #[inline(always)]
    fn new(cx: &'c Ctx<'a>, s: &'c Setup, st: usize, mask: u8, steps: u32) -> Self {
        let r = &cx.root;
        SltrWalk {
            cx,
            s,
            floor: std::array::from_fn(|a| if s.neg[a] { r.max[a] } else { r.min[a] }),
            exact: 3,
            tn: s.t0,
            mask,
            seen: 0,
            steps,
            ambiguous: false,
            last: Last::of(cx, st as u32),
        }
    }

    /// Algorithm 3's down traversal from the last augmented node to the leaf holding the point
    /// at `tn` (Kaplan's point location with the rule of tb-kdtree's `sequential`: on the axis
    /// of the face just crossed the point's coordinate is that face's exactly, other planes
    /// behind it only by more than the rounding [`SLACK`], the origin itself at `tn = 0`; a
    /// plane within rounding sets `ambiguous`; a plane holding the ray is passed on the side
    /// `mask` gives, or, `HAND`, sets `ambiguous`). Every augmented node passed (`AUG`) becomes `last`
    /// (`lastAugmentedNode`, its record looked up only when a climb needs it). Returns the
    /// leaf and its cell.
    ///
    /// The descent of tb-kdtree's `PointWalk::locate` with the same counts, which sparse boxes
    /// cannot call: it also records each augmented node passed, and `sltr-handover` stops at a
    /// plane holding the ray.
    #[inline(always)]
    fn locate<C: Counter, const HAND: bool, const AUG: bool>(&mut self, c: &mut C) -> Cell {
        let (s, nodes, period) = (self.s, self.cx.nodes, self.cx.period);
        let l = &self.last;
        let (mut idx, mut min, mut max, mut depth) = (l.node, l.min, l.max, l.depth);
        let mut phase = depth % period;
        let at = Located::new(self.tn, self.floor, self.exact);
        loop {
            let n = nodes[idx];
            if n.is_leaf() {
                return (idx, min, max);
            }
            if AUG && phase == 0 && idx != self.last.node {
                let rec = NONE;
                self.last = Last {
                    rec,
                    node: idx,
                    depth,
                    min,
                    max,
                };
            }
            c.interior();
            c.steps(1);
            c.planes(1);
            self.steps += 1;
            let (a, sp) = (n.axis(), n.split());
            let t = (sp - s.org[a]) * s.inv[a];
            let left = if t.is_nan() {
                // The ray lies in the plane: no single point decides. `sltr` takes the side
                // the walk's mask gives (as `seq`: one walk per side), `sltr-handover` hands
                // the ray over.
                if HAND {
                    self.ambiguous = true;
                    return (idx, min, max);
                }
                self.seen |= 1 << a;
                self.mask >> a & 1 == 0
            } else {
                let (lower, ambiguous) = at.lower(&s.org, &s.neg, a, sp, t);
                self.ambiguous |= ambiguous;
                lower
            };
            if left {
                max[a] = sp;
                idx += 1;
            } else {
                min[a] = sp;
                idx = n.link();
            }
            depth += 1;
            phase += 1;
            if phase == period {
                phase = 0;
            }
        }
    }

    /// Test leaf `idx` (one step); `true` when the ray is done (an any-hit found, or the step
    /// cap reached).
    #[inline(always)]
    fn leaf<T: TriTest, C: Counter, const ANY: bool>(
        &mut self,
        idx: usize,
        pre: &T::Pre,
        ray: &Ray,
        best: &mut Best,
        c: &mut C,
    ) -> bool {
        let cx = self.cx;
        self.steps += 1;
        leaf::<T, C, ANY>(&cx.kd, cx.nodes[idx], pre, ray, best, c) || capped(self.steps, cx.cap, c)
    }

    /// Leave the leaf's cell `min..max` (one box, its exit `texit`): through its nearest far
    /// plane that is not a root face, which becomes the floor of its axis and the exact axis of
    /// the next point (`tentry = texit + eps`, exact on its axis). Another far plane within
    /// rounding of it (a cell edge or corner) is an ambiguity; a far plane on an axis the ray
    /// does not move along (`0 · inf`: NaN, or `inf`) is none. Done when a hit lies before the
    /// exit (`ComputeIntersections` found one in the leaf, or an earlier walk's lies there),
    /// or when the point leaves the root box: then `TraverseUp` climbs every parent link from
    /// the last augmented node and none holds it.
    ///
    /// tb-kdtree's `PointWalk::leave` but for what ends the walk: that one ends it at
    /// `best.t <= texit` also without a hit (the segment's end) and climbs nothing, so the
    /// counts would differ.
    #[inline(always)]
    fn leave<C: Counter>(
        &mut self,
        min: &[f32; 3],
        max: &[f32; 3],
        best: &Best,
        c: &mut C,
    ) -> Exit {
        let (s, r) = (self.s, &self.cx.root);
        c.boxes(1);
        let x = ExitFaces::of(s, r, min, max);
        let (tf, face) = (x.tf, x.face);
        if best.found() && best.t <= tf {
            return Exit::Done;
        }
        if face == 3 || tf > s.t1 * SLACK {
            for _ in 0..self.last.depth / self.cx.period {
                parent_link(c);
                c.boxes(1);
            }
            return Exit::Done;
        }
        if x.tied() {
            return Exit::Ambiguous;
        }
        self.floor[face] = if s.neg[face] { min[face] } else { max[face] };
        self.exact = face;
        self.tn = max_num(self.tn, tf);
        Exit::Face(face, tf)
    }

    /// Before `RestartTraversal` from the last augmented node: `tentry < tup` holds when its
    /// box extends beyond the exit face just crossed on axis `face` (the point is inside it);
    /// else `TraverseUp`: parent links, `ComputeMaxT` of each (one box), to the first box that
    /// does, which becomes the last augmented node. The root holds the point: the exit face is
    /// not a root face.
    #[inline(always)]
    fn climb<C: Counter>(&mut self, face: usize, c: &mut C) {
        let (s, aug, fc) = (self.s, self.cx.aug, self.floor[face]);
        let beyond =
            |lo: &[f32; 3], hi: &[f32; 3]| (if s.neg[face] { lo[face] } else { hi[face] }) != fc;
        if beyond(&self.last.min, &self.last.max) {
            return;
        }
        let mut rec = self.cx.record(self.last.rec, self.last.node);
        while rec != 0 {
            rec = aug[rec as usize].parent;
            parent_link(c);
            c.boxes(1);
            let r = &aug[rec as usize];
            if beyond(&r.min, &r.max) {
                break;
            }
        }
        self.last = Last::of(self.cx, rec);
    }
}
