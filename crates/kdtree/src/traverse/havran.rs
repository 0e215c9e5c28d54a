//! `havran`: Havran's robust recursive traversal TA^B_rec with entry and exit points
//! (Havran 2000, Appendix C; Hapala and Havran 2011 §3.2).

use super::*;

/// A point on the ray: its parameter and coordinates.
#[derive(Clone, Copy)]
struct Pt {
    t: f32,
    p: [f32; 3],
}

/// The point at `t`, exact on axes of zero direction, clamped into the start cell `b`.
#[inline(always)]
fn point(b: &tb_core::Aabb, s: &Setup, t: f32) -> [f32; 3] {
    let mut p = [0.0; 3];
    for a in 0..3 {
        let x = if s.dir[a] == 0.0 {
            s.org[a]
        } else {
            s.org[a] + t * s.dir[a]
        };
        p[a] = min_num(max_num(b.min[a], x), b.max[a]);
    }
    p
}

/// `havran` (traversal 1): Havran's robust recursive traversal TA^B_rec (Havran 2000, Appendix
/// C; review §3.2). Entry and exit *points* (coordinates and distance) are kept for the
/// current node and on the stack, and the children to visit are decided by comparing the
/// entry and exit coordinates on the split axis with the split position (cases N1–N5, P1–P5,
/// Z), without division; the distance to the plane is computed only when the ray crosses it
/// (cases N4, P4), and the crossing point gets the split coordinate exactly. Case Z (the ray
/// lies in the split plane) visits both children, so triangles touching the plane from either
/// side are tested. The stored points are rounded (`o + t·d`), so a coordinate within
/// `8·2^-24·(|o_a| + max |start cell|_a)` of the split counts as possibly on either side:
/// an entry and exit both within it is case Z, one of them within it a crossing (near child by
/// the direction's sign); points on axes of zero direction are exactly `o_a`.
pub struct Havran<'a, L>(pub Tree<'a, L>);

impl<L: Layout> Havran<'_, L> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let w = &self.0;
        let b = &w.from.cell;
        let stack = Stack::<Entry<Pt>, STACK_SIZE>::new();
        let begin = |s: &Setup| {
            // Rounding allowance of point coordinates on each axis.
            let err: [f32; 3] = std::array::from_fn(|a| {
                8.0 * f32::EPSILON * (s.org[a].abs() + b.min[a].abs().max(b.max[a].abs()))
            });
            let en = Pt {
                t: s.t0,
                p: point(b, s, s.t0),
            };
            let ex = Pt {
                t: s.t1,
                p: point(b, s, s.t1),
            };
            (err, en, ex)
        };
        stack_walk::<T, C, L, Pt, [f32; 3], _, ANY>(w, ray, c, stack, begin, |p| p.t, {
            |s, err, idx, n, (en, ex), stack, c| {
                let a = n.axis();
                let split = n.split();
                let (left, right) = w.l.children(idx, n);
                let (ea, xa) = (en.p[a], ex.p[a]);
                let (lo, hi) = (split - err[a], split + err[a]);
                // Entry/exit possibly on the left (at most `split` up to rounding), possibly
                // on the right.
                let (el, er) = (ea <= hi, ea >= lo);
                let (xl, xr) = (xa <= hi, xa >= lo);
                // A direction component of 0 gives ea == xa: only the first three cases.
                let (near, far) = if !er && !xr {
                    return left; // N1, N2, N3 (and P5 beyond rounding)
                } else if !el && !xl {
                    return right; // P1, P2, P3 (and N5 beyond rounding)
                } else if el && er && xl && xr {
                    // Z: the ray lies in the plane (up to rounding): both children over the
                    // whole interval.
                    stack.defer((right as u32, *en, *ex), c);
                    return left;
                } else if !s.neg[a] {
                    // N4 (or a crossing within rounding): the ray runs left to right.
                    (left, right)
                } else {
                    (right, left) // P4
                };
                c.planes(1);
                let tp = (split - s.org[a]) * s.inv[a];
                let tp = min_num(max_num(en.t, tp), ex.t);
                let mut p = point(b, s, tp);
                p[a] = split;
                let mid = Pt { t: tp, p };
                stack.defer((far as u32, mid, *ex), c);
                *ex = mid;
                near
            }
        })
    }
}

tb_core::kernel_by_query!(walk: [L: Layout] Havran<'_, L>);
