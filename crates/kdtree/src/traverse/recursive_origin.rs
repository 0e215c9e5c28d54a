//! `recursive-origin`: the stack walk with near/far children by the side of the split plane
//! holding the ray origin, as published (Hapala and Havran 2011 §3.2, Alg. 2).

use super::*;

/// `recursive-origin` (traversal 2): the stack-based algorithm with near/far children
/// classified by the side of the split plane holding the ray origin (Jansen 1986, Arvo 1988;
/// review §3.2, Alg. 2 as printed): `t = (split − o_a)/d_a`; `t < 0` or `t > t_exit`: near
/// only; `t < t_entry`: far only; otherwise both. An origin lying in a split plane (`o_a =
/// split`, near = the upper child) gives `t = 0` and may send the ray to the wrong child: the
/// algorithm is inherently not robust there (Havran et al. 1997), and kept as published.
pub struct RecursiveOrigin<'a, L>(pub Tree<'a, L>);

impl<L: Layout> RecursiveOrigin<'_, L> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let w = &self.0;
        let stack = Stack::<Entry<f32>, STACK_SIZE>::new();
        let begin = |s: &Setup| ((), s.t0, s.t1);
        stack_walk::<T, C, L, f32, (), _, ANY>(w, ray, c, stack, begin, |t| *t, {
            |s, _, idx, n, (tn, tf), stack, c| {
                c.planes(1);
                let a = n.axis();
                let split = n.split();
                let t = (split - s.org[a]) * s.inv[a];
                let (left, right) = w.l.children(idx, n);
                let (near, far) = if s.org[a] < split {
                    (left, right)
                } else {
                    (right, left)
                };
                if t < 0.0 || t > *tf * SLACK {
                    near
                } else if t * SLACK < *tn {
                    far
                } else {
                    // Clamped into the interval; a NaN `t` (origin in the plane, direction
                    // 0 on this axis) leaves both children the whole interval.
                    stack.defer((far as u32, max_num(*tn, t).min(*tf), *tf), c);
                    *tf = min_num(*tf, t).max(*tn);
                    near
                }
            }
        })
    }
}

tb_core::kernel_by_query!(walk: [L: Layout] RecursiveOrigin<'_, L>);
