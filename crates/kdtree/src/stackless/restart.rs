//! `restart` (Foley and Sugerman 2005, kd-restart; review §5.1): after each leaf, restart at
//! the start node and descend toward the last leaf to the next subtree
//! ([`Restarts::restart`]). `push-down` is this loop with the restart node pushed down
//! ([`super::push_down`]).

use super::restarts::Restarts;
use crate::traverse::{Best, Setup, Tree};
use crate::Layout;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// Walk one ray clipped to `s` from the start node with the closest hit `best` and `steps`
/// steps taken (`sequential` and `ropes` hand rays over midway): `K` is [`super::RESTART`] or
/// [`super::PUSH_DOWN`].
#[inline(always)]
pub(super) fn walk<T: TriTest, C: Counter, L: Layout, const ANY: bool, const K: u8>(
    w: &Tree<'_, L>,
    s: &Setup,
    ray: &Ray,
    pre: &T::Pre,
    mut best: Best,
    steps: u32,
    c: &mut C,
) -> HitRecord {
    let mut k = Restarts::<L, K>::new(w, s, steps);
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
