//! `backtrack` (Foley and Sugerman 2005, kd-backtrack; review §5.1.1, Alg. 3): from a leaf
//! climb the parent links, recomputing each node's interval from its cell (both stored in the
//! auxiliary array [`crate::KdTree::back_nodes`]), up to the first node where the walk went
//! both ways from the near child, then descend into its far child ([`Restarts::climb`]; none
//! above a leaf start node: the walk is done).

use super::restarts::Restarts;
use super::RestartSteps;
use super::BACKTRACK;
use crate::traverse::{Best, Setup, Tree};
use crate::view::BackNode;
use crate::Layout;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// Walk one ray clipped to `s` from the start node, climbing the parent links `back`.
#[inline(always)]
pub(super) fn walk<T: TriTest, C: Counter, L: Layout, const ANY: bool>(
    w: &Tree<'_, L>,
    back: &[BackNode],
    s: &Setup,
    ray: &Ray,
    pre: &T::Pre,
    mut best: Best,
    c: &mut C,
) -> HitRecord {
    let mut k = Restarts::<L, BACKTRACK>::new(w, s, 0);
    loop {
        k.descend(c);
        if k.leaf::<T, C, ANY>(pre, ray, &mut best, c) || k.at_start() {
            return best.record();
        }
        c.restart();
        match k.climb::<C, ANY>(back, best.t, c) {
            Some(next) => k.enter(next),
            None => return best.record(),
        }
    }
}
