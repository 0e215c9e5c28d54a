//! Kaplan's point location (review §3.1) as `sequential` and `ropes` walk with it (see the
//! module doc above): the located point ([`Located`], also sparse boxes' SLTR), the walk state
//! ([`PointWalk`]) and its named steps: `PointWalk::locate` a leaf, [`PointWalk::leaf`],
//! [`PointWalk::leave`] through the exit face; [`point_walk`] runs the passes of a ray and
//! hands it to `restart` where a point cannot decide.

use super::{restart, RESTART};
use crate::traverse::{capped, leaf, start, Best, Setup, Tree, SLACK};
use crate::Layout;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// Run `pass(mask)` (returns `(stop, seen)`) for mask 0, then, if some walk met a split plane
/// containing the ray, for every other combination of sides on the zero-direction axes.
#[inline(always)]
pub fn passes(s: &Setup, mut pass: impl FnMut(u8) -> (bool, u8)) {
    let (stop, seen) = pass(0);
    if stop || seen == 0 {
        return;
    }
    // Axes whose reciprocal is infinite: a zero component, or one below `1/f32::MAX` (a
    // subnormal: `1/d` overflows, so a plane through the origin gives `0 · inf = NaN` as for
    // a zero component). The ray's offset from that plane, `|d|·t`, stays below what the
    // triangle test resolves, so both sides are walked, as for a ray lying in the plane.
    let zero = (!s.inv[0].is_finite()) as u8
        | ((!s.inv[1].is_finite()) as u8) << 1
        | ((!s.inv[2].is_finite()) as u8) << 2;
    for m in 1..8u8 {
        if m & !zero == 0 && pass(m).0 {
            return;
        }
    }
}

/// A `sequential` or `ropes` walk of one ray: `crawl` walks one pass (returns `Some(true)`
/// when the ray is done, `Some(false)` when it left the start cell, `None` where a point
/// could not be placed within rounding); a pass that could not decide hands the ray, with its
/// closest hit and steps, to `restart` from the start node (one restart, one hand-over).
#[inline(always)]
pub(super) fn point_walk<T, C, L, const ANY: bool>(
    w: &Tree<'_, L>,
    ray: &Ray,
    c: &mut C,
    mut crawl: impl FnMut(&mut PointWalk<'_, '_, L>, &T::Pre, &mut Best, &mut C) -> Option<bool>,
) -> HitRecord
where
    T: TriTest,
    C: Counter,
    L: Layout,
{
    let Some((s, pre, mut best)) = start::<T, C, L>(w, ray, c) else {
        return HitRecord::MISS;
    };
    let root = &w.from.cell;
    let floor: [f32; 3] = std::array::from_fn(|a| if s.neg[a] { root.max[a] } else { root.min[a] });
    let (mut steps, mut ambiguous) = (0u32, false);
    passes(&s, |mask| {
        let mut walk = PointWalk {
            w,
            s: &s,
            floor,
            exact: 3,
            mask,
            seen: 0,
            steps,
            ambiguous: false,
        };
        let stop = crawl(&mut walk, &pre, &mut best, c);
        steps = walk.steps;
        ambiguous = stop.is_none();
        (stop.unwrap_or(true), walk.seen)
    });
    if !ambiguous {
        return best.record();
    }
    c.restart();
    c.handover();
    restart::walk::<T, C, L, ANY, RESTART>(w, &s, ray, &pre, best, steps, c)
}

/// The point of Kaplan's point location (review §3.1) as `sequential` and `ropes` place it
/// (see `PointWalk::locate`), and sparse boxes' SLTR after them: the point at distance `tn`,
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

/// A leaf and its cell, as point location finds them.
pub type Cell = (usize, [f32; 3], [f32; 3]);

/// Where a walk goes from a leaf's cell ([`PointWalk::leave`]).
pub enum Exit {
    /// The ray is done here: it leaves the start cell, or the closest hit lies before the
    /// exit.
    Done,
    /// Two exit faces tied within rounding (a ray through a cell edge or corner).
    Ambiguous,
    /// Through the face on this axis, at this distance.
    Face(usize, f32),
}

/// The exit faces of a cell `min..max` inside the start cell `root`, for the ray of `s`: per
/// axis the distance of the far plane (infinite where it is a start-cell face), the nearest of
/// them and its axis (3: none, the ray leaves the start cell). Shared by the point walks here
/// and sparse boxes' SLTR, which end a walk by other rules.
#[derive(Clone, Copy, Debug)]
pub struct ExitFaces {
    /// Per axis, the far plane's distance (infinite for a start-cell face).
    pub ts: [f32; 3],
    /// The nearest far plane's distance.
    pub tf: f32,
    /// The nearest far plane's axis (3: none).
    pub face: usize,
}

impl ExitFaces {
    /// The exit faces of `min..max` (see the type).
    #[inline(always)]
    pub fn of(s: &Setup, root: &tb_core::Aabb, min: &[f32; 3], max: &[f32; 3]) -> Self {
        let mut x = ExitFaces {
            ts: [f32::INFINITY; 3],
            tf: f32::INFINITY,
            face: 3,
        };
        for a in 0..3 {
            let (far, r) = if s.neg[a] {
                (min[a], root.min[a])
            } else {
                (max[a], root.max[a])
            };
            if far != r {
                let t = (far - s.org[a]) * s.inv[a];
                x.ts[a] = t;
                if t < x.tf {
                    x.tf = t;
                    x.face = a;
                }
            }
        }
        x
    }

    /// Another far plane within rounding of the nearest (a ray through a cell edge or corner).
    #[inline(always)]
    pub fn tied(&self) -> bool {
        let reach = self.tf + (SLACK - 1.0) * self.tf.abs();
        (0..3).any(|a| a != self.face && self.ts[a] <= reach)
    }
}

/// One pass of a `sequential` or `ropes` walk (see the module doc).
pub(super) struct PointWalk<'t, 'a, L> {
    w: &'t Tree<'a, L>,
    pub(super) s: &'t Setup,
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
    /// A plane distance within rounding of the located point was met.
    pub(super) ambiguous: bool,
}

impl<L: Layout> PointWalk<'_, '_, L> {
    /// `PointWalk::locate` from the start node.
    #[inline(always)]
    pub(super) fn locate_start<C: Counter>(&mut self, tn: f32, c: &mut C) -> Cell {
        let f = self.w.from;
        let (min, max) = (f.cell.min.to_array(), f.cell.max.to_array());
        self.locate(f.node as usize, min, max, tn, c)
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
    pub(super) fn locate<C: Counter>(
        &mut self,
        mut idx: usize,
        mut min: [f32; 3],
        mut max: [f32; 3],
        tn: f32,
        c: &mut C,
    ) -> Cell {
        let s = self.s;
        let nodes = self.w.v.nodes;
        let at = Located::new(tn, self.floor, self.exact);
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

    /// Test leaf `idx` (one step); `true` when the ray is done (an any-hit found, or the step
    /// cap reached).
    #[inline(always)]
    pub(super) fn leaf<T: TriTest, C: Counter, const ANY: bool>(
        &mut self,
        idx: usize,
        pre: &T::Pre,
        ray: &Ray,
        best: &mut Best,
        c: &mut C,
    ) -> bool {
        let v = &self.w.v;
        self.steps += 1;
        leaf::<T, C, ANY>(v, v.nodes[idx], pre, ray, best, c) || capped(self.steps, v.step_cap, c)
    }

    /// Leave the cell `min..max` (one box): through the nearest far plane that is not a
    /// start-cell face, which becomes the floor of its axis and the exact axis of the next
    /// point. Another far plane within rounding of it is an ambiguity; the ray is done where no
    /// such face is left, or the closest hit `best_t` lies before it.
    #[inline(always)]
    pub(super) fn leave<C: Counter>(
        &mut self,
        min: &[f32; 3],
        max: &[f32; 3],
        best_t: f32,
        c: &mut C,
    ) -> Exit {
        let (s, r) = (self.s, &self.w.from.cell);
        c.boxes(1);
        let x = ExitFaces::of(s, r, min, max);
        let (tf, face) = (x.tf, x.face);
        if face == 3 || best_t <= tf || tf > s.t1 * SLACK {
            return Exit::Done;
        }
        if x.tied() {
            return Exit::Ambiguous;
        }
        self.floor[face] = if s.neg[face] { min[face] } else { max[face] };
        self.exact = face;
        Exit::Face(face, tf)
    }
}
