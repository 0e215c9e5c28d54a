//! `short-stack` (Horn et al. 2007; review §5.2): `push-down` with a circular stack of
//! `short_stack` far children (the oldest overwritten when full, [`Restarts::descend`]);
//! after a leaf the newest kept child that starts before the closest hit is next
//! ([`Restarts::pop`]), and a restart from the pushed-down node only when the stack runs dry.

use super::restarts::Restarts;
use super::RestartSteps;
use super::SHORT_STACK;
use crate::traverse::{Best, Setup, Tree};
use crate::Layout;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// Walk one ray clipped to `s` from the start node.
#[inline(always)]
pub(super) fn walk<T: TriTest, C: Counter, L: Layout, const ANY: bool>(
    w: &Tree<'_, L>,
    s: &Setup,
    ray: &Ray,
    pre: &T::Pre,
    mut best: Best,
    c: &mut C,
) -> HitRecord {
    let mut k = Restarts::<L, SHORT_STACK>::new(w, s, 0);
    loop {
        k.descend(c);
        if k.leaf::<T, C, ANY>(pre, ray, &mut best, c) {
            return best.record();
        }
        if k.pop::<ANY>(best.t) {
            continue;
        }
        c.restart();
        match k.restart::<C, ANY>(best.t, c) {
            Some(next) => k.enter(next),
            None => return best.record(),
        }
    }
}
