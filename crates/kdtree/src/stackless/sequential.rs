//! `sequential` (Kaplan 1985; review §3.1, Alg. 1): locate the entry leaf from the start node,
//! then repeatedly leave the leaf through its exit face and locate the next leaf from the
//! start node again (each a restart), with the point placed as the module doc says
//! ([`PointWalk::locate`]).

use super::locate::{point_walk, Exit, PointWalk};
use crate::traverse::{Best, Tree};
use crate::Layout;
use tb_core::slab::max_num;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// Walk one ray.
#[inline(always)]
pub(super) fn walk<T: TriTest, C: Counter, L: Layout, const ANY: bool>(
    w: &Tree<'_, L>,
    ray: &Ray,
    c: &mut C,
) -> HitRecord {
    point_walk::<T, C, L, ANY>(w, ray, c, |pw, pre, best, c| {
        crawl::<T, C, L, ANY>(pw, ray, pre, best, c)
    })
}

/// One pass: `Some(true)` when the ray is done, `Some(false)` when it left the start cell,
/// `None` where a point could not be placed.
#[inline(always)]
fn crawl<T: TriTest, C: Counter, L: Layout, const ANY: bool>(
    pw: &mut PointWalk<'_, '_, L>,
    ray: &Ray,
    pre: &T::Pre,
    best: &mut Best,
    c: &mut C,
) -> Option<bool> {
    let mut tn = pw.s.t0;
    let (mut idx, mut min, mut max) = pw.locate_start(tn, c);
    loop {
        if pw.ambiguous {
            return None;
        }
        if pw.leaf::<T, C, ANY>(idx, pre, ray, best, c) {
            return Some(true);
        }
        match pw.leave(&min, &max, best.t, c) {
            Exit::Done => return Some(false),
            Exit::Ambiguous => return None,
            Exit::Face(_, tf) => tn = max_num(tn, tf),
        }
        c.restart();
        (idx, min, max) = pw.locate_start(tn, c);
    }
}
