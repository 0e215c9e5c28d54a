//! The traversal stack every CPU walk keeps (one traversal vocabulary): the kd-tree
//! walks of the review (Hapala & Havran 2011 §3.2, §5), the BVH walks (pbrt-v3 §4.3.5; the
//! wide walk), the R-tree's `ordered` and `stack` (Feldmann 2015 §4.2, §5.2) and sparse
//! boxes' BTR (Havran & Bittner 2007 §5.2). Short stacks with their own rule (the kd
//! review's circular short stack, `branchless`'s write-then-advance array) keep their own.

use std::mem::MaybeUninit;

/// A stack of at most `N` entries, its storage left uninitialised: a walk pushes before it
/// pops, and zeroing a full-depth stack for every ray is work no walk needs (for the kd-tree's
/// `havran`, 64 entries of two points, 1.8 KB a ray: 6-10 % of its primary-ray trace time on
/// Sibenik and Sponza).
pub struct Stack<E, const N: usize> {
    items: [MaybeUninit<E>; N],
    len: usize,
}

impl<E: Copy, const N: usize> Default for Stack<E, N> {
    #[inline(always)]
    fn default() -> Self {
        Self::new()
    }
}

impl<E: Copy, const N: usize> Stack<E, N> {
    /// An empty stack.
    #[inline(always)]
    pub const fn new() -> Self {
        Stack {
            items: [const { MaybeUninit::uninit() }; N],
            len: 0,
        }
    }

    /// Push `e`; panics beyond `N` entries (the builders' depth limits keep walks within).
    #[inline(always)]
    pub fn push(&mut self, e: E) {
        self.items[self.len] = MaybeUninit::new(e);
        self.len += 1;
    }

    /// The top entry, removed; `None` when empty.
    #[inline(always)]
    pub fn pop(&mut self) -> Option<E> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: `push` keeps `len ≤ N` and writes every entry below `len`.
        Some(unsafe { self.items.get_unchecked(self.len).assume_init() })
    }

    /// The first entry from the top that `keep` accepts, it and the ones above it removed:
    /// the walks' pop of the next pending subtree, skipping those entered beyond the closest
    /// hit found since they were pushed. `None` when none is kept (the stack is then empty).
    #[inline(always)]
    pub fn pop_until(&mut self, keep: impl Fn(&E) -> bool) -> Option<E> {
        while let Some(e) = self.pop() {
            if keep(&e) {
                return Some(e);
            }
        }
        None
    }

    /// Insert `e` below the entries on top that it belongs under (`below(&e, &entry)`), as
    /// insertion sort does: a stack filled this way pops in that order (the R-tree's per-level
    /// stacks, nearest entry distance on top).
    #[inline(always)]
    pub fn insert_by(&mut self, e: E, below: impl Fn(&E, &E) -> bool) {
        let mut j = self.len;
        while j > 0 {
            // SAFETY: entries below `len` are written (`j ≤ len ≤ N`).
            let under = unsafe { self.items.get_unchecked(j - 1).assume_init() };
            if !below(&e, &under) {
                break;
            }
            self.items[j] = MaybeUninit::new(under);
            j -= 1;
        }
        self.items[j] = MaybeUninit::new(e);
        self.len += 1;
    }

    /// The entries, bottom to top.
    #[inline(always)]
    pub fn as_slice(&self) -> &[E] {
        // SAFETY: `push` and `insert_by` keep `len ≤ N` and write every entry below `len`;
        // `MaybeUninit<E>` has `E`'s layout.
        unsafe { std::slice::from_raw_parts(self.items.as_ptr().cast::<E>(), self.len) }
    }

    /// Remove every entry.
    #[inline(always)]
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Whether the stack holds no entry.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Number of entries on the stack.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.len
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pops_in_reverse_and_skips_what_is_not_kept() {
        let mut s = Stack::<(u32, f32), 8>::new();
        assert!(s.is_empty() && s.pop().is_none());
        for (i, t) in [(1, 0.5), (2, 3.0), (3, 1.0)] {
            s.push((i, t));
        }
        assert_eq!(s.len(), 3);
        assert_eq!(s.pop_until(|e| e.1 <= 2.0), Some((3, 1.0)));
        assert_eq!(
            s.pop_until(|e| e.1 <= 2.0),
            Some((1, 0.5)),
            "(2, 3.0) skipped"
        );
        assert!(s.is_empty() && s.pop_until(|_| true).is_none());
    }

    #[test]
    fn insert_by_pops_nearest_first() {
        let mut s = Stack::<(u32, f32), 8>::new();
        for (i, t) in [(1, 2.0), (2, 0.5), (3, 4.0), (4, 2.0), (5, 1.0)] {
            // Farther entries under nearer ones; of equal ones, the later pops first.
            s.insert_by((i, t), |e, x| x.1 < e.1);
        }
        let order: Vec<u32> = std::iter::from_fn(|| s.pop()).map(|e| e.0).collect();
        assert_eq!(order, [2, 5, 4, 1, 3]);
        s.push((9, 0.0));
        s.push((8, 1.0));
        assert_eq!(s.as_slice(), [(9, 0.0), (8, 1.0)]);
        s.clear();
        assert!(s.is_empty());
    }

    #[test]
    #[should_panic]
    fn push_beyond_capacity_panics() {
        let mut s = Stack::<u32, 2>::new();
        for i in 0..3 {
            s.push(i);
        }
    }
}
