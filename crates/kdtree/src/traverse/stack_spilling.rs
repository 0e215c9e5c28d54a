//! `stack-spilling`: `recursive-direction` with a short stack spilling to a memory stack
//! (Novák 2009; Hapala and Havran 2011 §5.2, Fig. 8).

use super::recursive_direction::by_direction;
use super::*;

/// `stack-spilling` (traversal 10): `recursive-direction` with a short circular stack of
/// [`crate::KdParams::short_stack`] entries whose oldest entry, on overflow, is *spilled* to a
/// full stack in memory instead of being discarded; on underflow the full stack is popped
/// before the walk ends, so no restart is ever needed (Novák 2009; Hapala and Havran 2011
/// §5.2, Figure 8, Table 3 "stack spilling"). Visits exactly the nodes of
/// `recursive-direction`; `boxes` counts 1 plus one per entry spilled or refilled (the
/// traffic to the memory stack). Extra memory: the short stack and a full stack per ray.
pub struct StackSpilling<'a, L>(pub Tree<'a, L>);

/// `stack-spilling`'s pending subtrees: a circular short stack of `size` entries whose oldest
/// entry is spilled to the memory stack on overflow, the memory stack popped when the short
/// one runs empty; `boxes` counts each entry spilled or refilled.
struct Spilling {
    short: [Entry<f32>; crate::MAX_SHORT_STACK],
    size: usize,
    /// `count` entries, the newest at `top - 1` (mod `size`).
    top: usize,
    count: usize,
    spill: Stack<Entry<f32>, STACK_SIZE>,
}

impl Pending<f32> for Spilling {
    #[inline(always)]
    fn defer<C: Counter>(&mut self, e: Entry<f32>, c: &mut C) {
        let size = self.size;
        if self.count == size {
            // Overflow: spill the oldest entry.
            let oldest = (self.top + size - self.count) % size;
            self.spill.push(self.short[oldest]);
            self.count -= 1;
            c.boxes(1);
        }
        self.short[self.top] = e;
        self.top = if self.top + 1 == size {
            0
        } else {
            self.top + 1
        };
        self.count += 1;
    }

    #[inline(always)]
    fn resume<C: Counter>(
        &mut self,
        keep: impl Fn(&Entry<f32>) -> bool,
        c: &mut C,
    ) -> Option<Entry<f32>> {
        loop {
            let e = if self.count > 0 {
                self.top = if self.top == 0 {
                    self.size - 1
                } else {
                    self.top - 1
                };
                self.count -= 1;
                self.short[self.top]
            } else {
                // Underflow: refill from the memory stack.
                let e = self.spill.pop()?;
                c.boxes(1);
                e
            };
            if keep(&e) {
                return Some(e);
            }
        }
    }
}

impl<L: Layout> StackSpilling<'_, L> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let w = &self.0;
        let pending = Spilling {
            short: [(0, 0.0, 0.0); crate::MAX_SHORT_STACK],
            size: w.v.short_stack as usize,
            top: 0,
            count: 0,
            spill: Stack::new(),
        };
        by_direction::<T, C, L, _, ANY>(w, ray, c, pending)
    }
}

tb_core::kernel_by_query!(walk: [L: Layout] StackSpilling<'_, L>);
