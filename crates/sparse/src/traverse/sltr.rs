//! SLTR (Havran and Bittner 2007 §5.3, Alg. 3) and its variants `sltr-handover` and
//! `sltr-mask`: the sequential walk from leaf to leaf by point location from the last augmented
//! node (the module doc of `traverse` gives the whole rule).

use super::*;

impl Ctx<'_> {
    /// SLTR as the paper's Algorithm 3 from record `hint` (see the module doc): point
    /// location of the shifted origin from the last augmented node, climbing parent links
    /// (`ComputeMaxT`, one box each) while the point lies beyond a node's box. A ray lying in
    /// a split plane is walked once per side of it as `seq` walks it (`HAND == false`, `sltr`),
    /// or handed to `sltr-mask` (`HAND == true`, `sltr-handover`); a point the rounding cannot
    /// place is handed to `sltr-mask` in both.
    #[inline(always)]
    pub(super) fn sltr<T: TriTest, C: Counter, const ANY: bool, const HAND: bool>(
        &self,
        ray: &Ray,
        hint: u32,
        c: &mut C,
    ) -> HitRecord {
        let Some((s, (r0, r1))) = self.clip_root(ray, c) else {
            return HitRecord::MISS;
        };
        let pre = T::prepare(ray);
        let mut best = Best::new(ray.tmax);
        let st = self.start(ray, hint);
        if st != 0 {
            // ComputeMinMaxT(ray, startNode).
            c.boxes(1);
        }
        let mut steps = 0u32;
        // The walk per side of the split planes the ray lies in, as tb-kdtree's `sequential`
        // (its `passes`): first every such plane's lower side; when one was met, every other
        // combination of sides on the axes where the direction is zero (1/d infinite).
        let zero = (0..3).fold(0u8, |m, a| m | ((!s.inv[a].is_finite()) as u8) << a);
        for mask in 0..8u8 {
            if mask != 0 && mask & !zero != 0 {
                continue;
            }
            match self.sltr_pass::<T, C, ANY, HAND>(
                ray,
                &s,
                (r0, r1),
                &pre,
                &mut best,
                st,
                mask,
                &mut steps,
                c,
            ) {
                Pass::Done { stop, seen } => {
                    if stop || (mask == 0 && seen == 0) {
                        break;
                    }
                }
                Pass::Ambiguous => {
                    // A point the rounding cannot place (or, `HAND`, a ray lying in a split
                    // plane): the ray goes to `sltr-mask` from the root, keeping its closest
                    // hit (as SEQ hands the former to kd-restart).
                    c.restart();
                    c.handover();
                    return self.mask_walk::<T, C, ANY>(ray, &s, (r0, r1), &pre, best, 0, steps, c);
                }
            }
        }
        best.record()
    }

    /// One walk of SLTR (Algorithm 3) from record `st`, split planes holding the ray taken to
    /// the side `mask` gives per axis (bit set: the upper side); `steps` carried between the
    /// walks for the cap.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn sltr_pass<T: TriTest, C: Counter, const ANY: bool, const HAND: bool>(
        &self,
        ray: &Ray,
        s: &Setup,
        (r0, r1): (f32, f32),
        pre: &T::Pre,
        best: &mut Best,
        st: usize,
        mask: u8,
        steps: &mut u32,
        c: &mut C,
    ) -> Pass {
        let aug = self.aug;
        let (rmin, rmax) = (self.root.min.to_array(), self.root.max.to_array());
        let mut w = Point {
            floor: std::array::from_fn(|a| if s.neg[a] { rmax[a] } else { rmin[a] }),
            exact: 3,
            tn: r0,
            steps: *steps,
            ambiguous: false,
            mask,
            seen: 0,
        };
        let a = &aug[st];
        let mut last = Last {
            rec: st as u32,
            node: a.node as usize,
            depth: self.depth[st] as u32,
            min: a.min,
            max: a.max,
        };
        let (mut idx, mut min, mut max) = self.locate::<C, HAND>(s, &mut w, &mut last, c);
        let done = |w: &Point, steps: &mut u32, stop: bool| {
            *steps = w.steps;
            Pass::Done { stop, seen: w.seen }
        };
        loop {
            if w.ambiguous {
                *steps = w.steps;
                return Pass::Ambiguous;
            }
            w.steps += 1;
            if leaf::<T, C, ANY>(&self.kd, self.nodes[idx], pre, ray, best, c) {
                return done(&w, steps, true);
            }
            if w.steps >= self.cap {
                c.capped();
                return done(&w, steps, true);
            }
            // The leaf's exit `texit`: its nearest far plane that is not a root face; another
            // far plane within rounding of it (a cell edge or corner) is an ambiguity. A far
            // plane on an axis the ray does not move along (`0 · inf`: NaN, or `inf`) is none.
            c.boxes(1);
            let mut ts = [f32::INFINITY; 3];
            let (mut tf, mut face) = (f32::INFINITY, 3usize);
            for a in 0..3 {
                let (far, root) = if s.neg[a] {
                    (min[a], rmin[a])
                } else {
                    (max[a], rmax[a])
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
            // ComputeIntersections found a hit in the leaf (or an earlier walk's lies before
            // its exit).
            if best.prim != u32::MAX && best.t <= tf {
                return done(&w, steps, false);
            }
            if face == 3 || tf > r1 * SLACK {
                // The shifted origin leaves the root box: TraverseUp climbs every parent link
                // from the last augmented node, none holds it, and the walk is done.
                for _ in 0..last.depth / self.period {
                    climb(c);
                    c.boxes(1);
                }
                return done(&w, steps, false);
            }
            let reach = tf + (SLACK - 1.0) * tf.abs();
            if (0..3).any(|a| a != face && ts[a] <= reach) {
                w.ambiguous = true;
                continue;
            }
            // `tentry = texit + eps`: the point just past the exit face, exact on its axis.
            let fc = if s.neg[face] { min[face] } else { max[face] };
            w.floor[face] = fc;
            w.exact = face;
            w.tn = max_num(w.tn, tf);
            c.restart();
            // RestartTraversal: `tentry < tup` holds when the last augmented node's box
            // extends beyond the exit face on its axis (the point is inside it); else
            // TraverseUp: parent links, `ComputeMaxT` of each, to the first box that does.
            let beyond = |lo: &[f32; 3], hi: &[f32; 3]| {
                (if s.neg[face] { lo[face] } else { hi[face] }) != fc
            };
            if !beyond(&last.min, &last.max) {
                let mut rec = if last.rec == NONE {
                    self.rank.find(last.node as u32).expect("augmented node") as u32
                } else {
                    last.rec
                };
                // The root holds the point: the exit face is not a root face.
                while rec != 0 {
                    rec = aug[rec as usize].parent;
                    climb(c);
                    c.boxes(1);
                    let r = &aug[rec as usize];
                    if beyond(&r.min, &r.max) {
                        break;
                    }
                }
                let r = &aug[rec as usize];
                last = Last {
                    rec,
                    node: r.node as usize,
                    depth: self.depth[rec as usize] as u32,
                    min: r.min,
                    max: r.max,
                };
            }
            (idx, min, max) = self.locate::<C, HAND>(s, &mut w, &mut last, c);
        }
    }

    /// Algorithm 3's down traversal from the last augmented node `last` to the leaf holding
    /// the point at `w.tn` (Kaplan's point location with the rule of tb-kdtree's `sequential`:
    /// on the axis of the face just crossed the point's coordinate is that face's exactly,
    /// other planes behind it only by more than the rounding [`SLACK`], the origin itself at
    /// `tn = 0`; a plane within rounding sets `w.ambiguous`; a plane holding the ray is
    /// passed on the side `w.mask` gives, or, `HAND`, sets `w.ambiguous`). Every augmented
    /// node passed becomes `last` (`lastAugmentedNode`, its record looked up only when a climb
    /// needs it). Returns the leaf and its cell.
    #[inline(always)]
    pub(super) fn locate<C: Counter, const HAND: bool>(
        &self,
        s: &Setup,
        w: &mut Point,
        last: &mut Last,
        c: &mut C,
    ) -> (usize, [f32; 3], [f32; 3]) {
        let nodes = self.nodes;
        let (mut idx, mut min, mut max, mut depth) = (last.node, last.min, last.max, last.depth);
        let mut phase = depth % self.period;
        let at = Located::new(w.tn, w.floor, w.exact);
        loop {
            let n = nodes[idx];
            if n.is_leaf() {
                return (idx, min, max);
            }
            if phase == 0 && idx != last.node {
                *last = Last {
                    rec: NONE,
                    node: idx,
                    depth,
                    min,
                    max,
                };
            }
            c.interior();
            c.steps(1);
            c.planes(1);
            w.steps += 1;
            let a = n.axis();
            let sp = n.split();
            let t = (sp - s.org[a]) * s.inv[a];
            let left = if t.is_nan() {
                // The ray lies in the plane: no single point decides. `sltr` takes the side
                // the walk's mask gives (as `seq`: one walk per side), `sltr-handover` hands
                // the ray over.
                if HAND {
                    w.ambiguous = true;
                    return (idx, min, max);
                }
                w.seen |= 1 << a;
                w.mask >> a & 1 == 0
            } else {
                let (lower, ambiguous) = at.lower(&s.org, &s.neg, a, sp, t);
                w.ambiguous |= ambiguous;
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
            if phase == self.period {
                phase = 0;
            }
        }
    }

    /// The set-up both SLTR walks share: the ray's precomputed set-up and its interval in the
    /// root box (one box test counted), `None` for an empty tree or a ray missing the root.
    #[inline(always)]
    pub(super) fn clip_root<C: Counter>(
        &self,
        ray: &Ray,
        c: &mut C,
    ) -> Option<(Setup, (f32, f32))> {
        if self.nodes.is_empty() {
            return None;
        }
        let s = setup(ray);
        c.boxes(1);
        let r = self
            .root
            .intersect(ray.origin, ray.inv_dir(), ray.tmin, ray.tmax)?;
        Some((s, r))
    }

    /// `sltr-mask` from record `hint` (see the module doc).
    #[inline(always)]
    pub(super) fn sltr_mask<T: TriTest, C: Counter, const ANY: bool>(
        &self,
        ray: &Ray,
        hint: u32,
        c: &mut C,
    ) -> HitRecord {
        let Some((s, (r0, r1))) = self.clip_root(ray, c) else {
            return HitRecord::MISS;
        };
        let pre = T::prepare(ray);
        let st = self.start(ray, hint);
        self.mask_walk::<T, C, ANY>(ray, &s, (r0, r1), &pre, Best::new(ray.tmax), st, 0, c)
    }

    /// The walk of `sltr-mask` from record `st`, with the closest hit so far `best` and `steps`
    /// steps already taken (the paper's `sltr` hands it a ray whose point location cannot
    /// decide, from the root).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn mask_walk<T: TriTest, C: Counter, const ANY: bool>(
        &self,
        ray: &Ray,
        s: &Setup,
        (r0, r1): (f32, f32),
        pre: &T::Pre,
        mut best: Best,
        st: usize,
        mut steps: u32,
        c: &mut C,
    ) -> HitRecord {
        let (nodes, aug, p) = (self.nodes, self.aug, self.period);
        // The record whose subtree the walk knows: the bits are valid at depths >= `dtop`.
        let mut top = st;
        let mut dtop = self.depth[st] as u32;
        let (sn, sf) = if st == 0 {
            (r0, r1)
        } else {
            c.boxes(1);
            self.interval(s, r0, r1, &aug[st])
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
                let d = decide(n, idx, s, tn, tf);
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
            if leaf::<T, C, ANY>(&self.kd, nodes[idx], pre, ray, &mut best, c) {
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
                            climb(c);
                        }
                        c.boxes(1);
                        let r = &aug[rec as usize];
                        let (an, af) = self.interval(s, r0, r1, r);
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
                        let d = decide(n, x, s, xn, xf);
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
                climb(c);
                c.boxes(1);
                let dp = dtop - p;
                let (pn, pf) = self.interval(s, r0, r1, &aug[pr]);
                let (mut x, mut xn, mut xf, mut xd) = (aug[pr].node as usize, pn, pf, dp);
                let mut cand = None;
                while xd < dtop {
                    let n = nodes[x];
                    c.interior();
                    c.steps(1);
                    c.planes(1);
                    steps += 1;
                    let d = decide(n, x, s, xn, xf);
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
