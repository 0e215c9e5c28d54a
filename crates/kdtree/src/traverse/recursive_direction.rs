//! `recursive-direction`: the stack walk with near/far children by the sign of the ray
//! direction (Hapala and Havran 2011 §3.2, Alg. 2).

use super::*;

/// `recursive-direction` (traversal 0): the stack-based algorithm with near/far children
/// classified by the sign of the ray direction (Keller 1997, Wald 2004; review §3.2, Alg. 2
/// with the direction-based classification). The stack holds the far child with its entry and
/// exit distances. Per interior node: `t = (split − o_a)·(1/d_a)`; `t > t_exit·SLACK`: near
/// child only; `t·SLACK < t_entry`: far child only; otherwise both, near first, so rays
/// through cell edges and corners (up to rounding) visit every cell there ([`SLACK`]).
///
/// Zero direction components (the review's robustness fix, done without an epsilon): `1/±0`
/// is `±inf` with the sign of the zero, which also decides near/far, so `t = ±inf` selects the
/// half-space holding the ray; an origin exactly in the plane gives `t = NaN`, which fails both
/// comparisons, and both children are visited over the whole interval (the NaN is ignored by
/// the interval updates).
pub struct RecursiveDirection<'a, L>(pub Tree<'a, L>);

impl<L: Layout> RecursiveDirection<'_, L> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let stack = Stack::<Entry<f32>, STACK_SIZE>::new();
        by_direction::<T, C, L, _, ANY>(&self.0, ray, c, stack)
    }
}

/// The direction-classified stack walk of [`RecursiveDirection`] with its pending subtrees
/// kept in `pending` (the full stack, or `stack-spilling`'s short stack).
#[inline(always)]
pub(super) fn by_direction<T, C, L, P, const ANY: bool>(
    w: &Tree<'_, L>,
    ray: &Ray,
    c: &mut C,
    pending: P,
) -> HitRecord
where
    T: TriTest,
    C: Counter,
    L: Layout,
    P: Pending<f32>,
{
    let begin = |s: &Setup| ((), s.t0, s.t1);
    stack_walk::<T, C, L, f32, (), _, ANY>(w, ray, c, pending, begin, |t| *t, {
        |s, _, idx, n, (tn, tf), pending, c| {
            c.planes(1);
            let d = decide(w.l, n, idx, s, *tn, *tf);
            match d.kind {
                Kind::NearOnly => d.near,
                Kind::FarOnly => d.far,
                Kind::Both => {
                    pending.defer((d.far as u32, d.far_tn, *tf), c);
                    *tf = d.near_tf;
                    d.near
                }
            }
        }
    })
}

tb_core::kernel_by_query!(walk: [L: Layout] RecursiveDirection<'_, L>);
