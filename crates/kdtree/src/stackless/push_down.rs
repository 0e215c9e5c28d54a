//! `push-down` (Horn et al. 2007; review §5.2, Alg. 4): `restart`'s loop, restarting at the
//! pushed-down node, the deepest node above every subtree still to visit (pushed down while
//! the walk visits only one child, [`super::restarts::Restarts::descend`], and to the next
//! subtree when no other one is pending, [`super::restarts::Restarts::enter`]).

use super::{restart, PUSH_DOWN};
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
    best: Best,
    c: &mut C,
) -> HitRecord {
    restart::walk::<T, C, L, ANY, PUSH_DOWN>(w, s, ray, pre, best, 0, c)
}
