//! `ropes` (MacDonald and Booth 1990, Havran et al. 1998, Popov et al. 2007; review §3.3):
//! from a leaf, follow the pushed-down rope of its exit face (its record: its cell and six
//! ropes, [`crate::view::LeafRopes`]) and locate the next leaf below it as `sequential` does,
//! with the same hand-over to `restart` where a point cannot decide.

use super::locate::{point_walk, Exit, PointWalk};
use crate::traverse::{Best, Tree};
use crate::view::{Ropes, NO_ROPE};
use crate::Layout;
use tb_core::slab::max_num;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// Walk one ray over the leaves' ropes `ropes`.
#[inline(always)]
pub(super) fn walk<T: TriTest, C: Counter, L: Layout, const ANY: bool>(
    w: &Tree<'_, L>,
    ropes: &Ropes,
    ray: &Ray,
    c: &mut C,
) -> HitRecord {
    point_walk::<T, C, L, ANY>(w, ray, c, |pw, pre, best, c| {
        crawl::<T, C, L, ANY>(pw, ropes, ray, pre, best, c)
    })
}

/// One pass: `Some(true)` when the ray is done, `Some(false)` when it left the start cell or
/// met no rope, `None` where a point could not be placed.
#[inline(always)]
fn crawl<T: TriTest, C: Counter, L: Layout, const ANY: bool>(
    pw: &mut PointWalk<'_, '_, L>,
    ropes: &Ropes,
    ray: &Ray,
    pre: &T::Pre,
    best: &mut Best,
    c: &mut C,
) -> Option<bool> {
    let mut tn = pw.s.t0;
    let (mut idx, _, _) = pw.locate_start(tn, c);
    loop {
        if pw.ambiguous {
            return None;
        }
        // The leaf's record: its cell (the one located) and its ropes.
        let rec = ropes.leaf(idx);
        if pw.leaf::<T, C, ANY>(idx, pre, ray, best, c) {
            return Some(true);
        }
        let face = match pw.leave(&rec.min, &rec.max, best.t, c) {
            Exit::Done => return Some(false),
            Exit::Ambiguous => return None,
            Exit::Face(face, tf) => {
                tn = max_num(tn, tf);
                face
            }
        };
        let side = if pw.s.neg[face] { 0 } else { 1 };
        let rope = rec.ropes[2 * face + side];
        if rope == NO_ROPE {
            return Some(false);
        }
        // The cell the location tracks below the rope is not needed: the next leaf's record
        // has its cell.
        (idx, _, _) = pw.locate(rope as usize, rec.min, rec.max, tn, c);
    }
}
