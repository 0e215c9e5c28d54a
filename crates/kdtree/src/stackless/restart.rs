//! `restart` (Foley and Sugerman 2005, kd-restart; review §5.1): after each leaf, restart at
//! the start node and descend toward the last leaf to the next subtree
//! ([`Restarts::restart`]). `push-down` is this loop with the restart node pushed down
//! ([`super::push_down`]); sparse boxes' `sltr-mask` runs its own walk state through the same
//! loop ([`RestartSteps`], [`restart_loop`]).

use super::restarts::Restarts;
use crate::traverse::{Best, Setup, Tree};
use crate::Layout;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// The steps of a restart-type walk: the walk state of `restart` and `push-down`
/// ([`Restarts`]) and of sparse boxes' `sltr-mask`, run by [`restart_loop`].
pub trait RestartSteps {
    /// Where the walk continues after a restart: a subtree and its interval.
    type Next;

    /// Descend to the first leaf of the current subtree, each interior node counted.
    fn descend<C: Counter>(&mut self, c: &mut C);

    /// Test the leaf reached (one step); `true` when the ray is done (an any-hit found, the
    /// walk's early exit, or the step cap reached).
    fn leaf<T: TriTest, C: Counter, const ANY: bool>(
        &mut self,
        pre: &T::Pre,
        ray: &Ray,
        best: &mut Best,
        c: &mut C,
    ) -> bool;

    /// The next subtree after the leaf, passing over those that start beyond the closest hit
    /// `best_t`; `None` when none is left: the ray is done.
    fn restart<C: Counter, const ANY: bool>(
        &mut self,
        best_t: f32,
        c: &mut C,
    ) -> Option<Self::Next>;

    /// Continue in `next`.
    fn enter(&mut self, next: Self::Next);
}

/// The restart loop: down to a leaf, test it, restart (counted) toward the next subtree, until
/// the ray is done; `best` is the closest hit so far.
#[inline(always)]
pub fn restart_loop<W: RestartSteps, T: TriTest, C: Counter, const ANY: bool>(
    mut k: W,
    ray: &Ray,
    pre: &T::Pre,
    mut best: Best,
    c: &mut C,
) -> HitRecord {
    loop {
        k.descend(c);
        if k.leaf::<T, C, ANY>(pre, ray, &mut best, c) {
            return best.record();
        }
        c.restart();
        match k.restart::<C, ANY>(best.t, c) {
            Some(next) => k.enter(next),
            None => return best.record(),
        }
    }
}

/// Walk one ray clipped to `s` from the start node with the closest hit `best` and `steps`
/// steps taken (`sequential` and `ropes` hand rays over midway): `K` is [`super::RESTART`] or
/// [`super::PUSH_DOWN`].
#[inline(always)]
pub(super) fn walk<T: TriTest, C: Counter, L: Layout, const ANY: bool, const K: u8>(
    w: &Tree<'_, L>,
    s: &Setup,
    ray: &Ray,
    pre: &T::Pre,
    best: Best,
    steps: u32,
    c: &mut C,
) -> HitRecord {
    restart_loop::<_, T, C, ANY>(Restarts::<L, K>::new(w, s, steps), ray, pre, best, c)
}
